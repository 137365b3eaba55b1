//! Damage-field-gradient (DFG) partitioning (Homel & Herbold 2017,
//! section 2): the particles at a node are split into two velocity fields
//! by the direction of the gradient of a smooth damage field, so that
//! material on either side of a band of failed particles can separate,
//! slide with friction, and come back into contact.
//!
//! Per step ([`Dfg::field`], the `damage_field` stage, then
//! [`Dfg::partition`], the `field_partition` stage):
//! 1. the kernel damage field normalized by the kernel sum, eqs. 17–19,
//!    D̄(x) = Σ d_q ω(|x − x_q|/r) / Σ ω(|x − x_q|/r), ω(r̄) = 1 − 3r̄² + 2r̄³,
//!    and its gradient at every particle near damage, with d_q = max(s_q,
//!    D_q) (s_q the self-contact surface flag, section 2.4; D_q a damage
//!    model's damage, or for a phase-field particle
//!    [`dfg_damage`]`(c_q)`, 1 − c scaled so that c < 0.1 is failed — our
//!    extension, docs/phase-field.md). The sums run
//!    over the particle's own contact group; r is `dfg.radius` cell
//!    diagonals (the paper: one);
//! 2. the approximate nonlocal node gradient of Algorithm 1: each node takes
//!    the particle gradient of largest magnitude among the particles that
//!    map to it; then, where the node sees opposing surfaces, the direction
//!    along which they oppose ([`Dfg::balance`]; our change, see below);
//! 3. Algorithm 2: at each node a particle maps to side 0 of its contact
//!    group if ∇D̄_p·∇D̄_i ≥ 0, else side 1 — where the two are not
//!    (nearly) perpendicular; otherwise by its own surface normal or its
//!    position ([`side`]);
//! 4. the separability condition of section 2.3: the two sides of a group
//!    stay separate fields at a node only if a particle mapping there is
//!    fully damaged and both sides' mass-weighted mean damage (eq. 21)
//!    exceeds `dfg.separability`; otherwise they are one field, which is
//!    Algorithm 3's "treat as single field" (both fields move with the
//!    centre-of-mass velocity) done before the scatter rather than after.
//!    Separable fields then meet in the core's frictional contact
//!    ([`crate::contact`], eqs. 11–16) with `dfg.friction`.
//!
//! Neighbour lists come from binning the particles in cells of the build
//! reach r(1 + 2f) and are rebuilt only when a particle has moved more than
//! f·r since the last build (section 2.5; f = `dfg.rebuild_fraction`), so
//! every pair closer than r is always in the list.
//!
//! Only a node that a fully damaged particle maps to can separate (section
//! 2.3), so the work goes where such nodes are: the gradients ∇D̄ are
//! summed for the particles of tiles with a failed particle in or next to
//! them; with the paper's rules (no self-contact) Algorithm 1 writes its
//! directions at such nodes alone, and the partition's side tests and
//! sums run for the particles of those tiles, the rest going to side 0.
//! The fields and slots are the same as with directions everywhere
//! ([`Dfg::field`] says why).
//!
//! Departures from the paper, both for self-contact (section 2.4) and only
//! in scenes with it (without self-contact Algorithms 1 and 2 run as
//! written: the paper's rules give the better crack dissipation, +7.4 %
//! against +10 % on the notched bar of `tests/engine/dfg.rs`), where
//! d = max(s, D) is 1 in the surface bands of two faces that touch, D̄ is
//! flat between them and their particles have no gradient: Algorithm 1's
//! largest gradient follows a body's own free face where it meets another
//! surface, and the sign test of Algorithm 2 is a tie for particles whose
//! gradient is perpendicular to the node's or zero. Taken literally, a block
//! standing on a plane in one contact group shares a field with the plane
//! at its corner nodes, and is welded there (it slid 0.01 mm where two
//! contact groups slide 17.1 mm; with the changes the two agree to 0.01 %,
//! `tests/engine/dfg.rs`). At a straight crack the direction is still its normal;
//! the band's own particles (no gradient) split at the band's centre
//! instead of all going to side 0.
//!
//! One code path in 2D and 3D (`Dfg<D>`): positions, gradients and
//! normals have D components, the neighbour bins are squares or cubes, the
//! kernel ω(r̄) of eq. 18 is the same in 3D (the paper's section 2.2:
//! r̄ = |x − x_q|/r), r is one cell diagonal by default (h√2, h√3), and
//! the balanced direction's candidates cover the half circle or the half
//! sphere ([`Candidates`]). The 2D arithmetic is the one it was before the
//! code was generic (sums over axes start from the first term, in axis
//! order).
//!
//! Approximation: the side statistics of the separability test are summed
//! per node over all contact groups; they differ from the paper's per-field
//! sums only at nodes where two groups and damage meet.

pub(crate) mod model;
pub mod section;

use crate::contact::unit;
use crate::fracture::damage::FAILED;
use crate::fracture::phase_field::dfg_damage;
use crate::grid::shape::Kernel;
use crate::grid::{
    particle_support, scatter_tiles, Bins, FieldSlots, GridGeom, MultiField, SyncPtr, TILE,
};
use crate::neighbours::{bin_index, Neighbours};
use crate::particles::Particles;
use crate::tensor::{dot, sub};
use rayon::prelude::*;
use std::ops::Range;

/// Below this |cos| between a particle's damage gradient and the node's
/// direction the gradient does not tell the side (Algorithm 2's sign test
/// is a tie or nearly one) and [`side`] falls back on the particle's
/// surface normal, then its position.
const SIDE_COS: f64 = 0.5;

/// Algorithm 2's side (0 or 1) of a particle with damage gradient `gp`,
/// outward surface normal `op` (zero unless a self-contact surface
/// particle) and position `xp` at a node with unit direction `ni` and
/// surface position `cut` (along `ni`): side 1 where ∇D̄_p·n_i < 0. Where
/// the two are (nearly) perpendicular — the side faces of a block standing
/// on a plane, the flanks of a crack tip, particles inside a damaged or
/// surface band where D̄ is flat and has no gradient — the sign test is
/// arbitrary: the paper's rule puts them on side 0 with everything that
/// points along n_i, so a block's corner shares a field with the plane it
/// stands on and is welded to it. There the particle's own outward normal
/// decides if it has one (it points the way ∇D̄ would), and otherwise its
/// position: ∇D̄ points towards the surface, so side 0 lies behind it
/// (n_i·x_p < cut) and side 1 in front.
///
/// In 3D a surface particle (one with a normal) is placed by its normal
/// alone, never by ∇D̄: where two flagged surfaces touch, d = 1 in both
/// bands and ∇D̄ of a band particle points away from the nearest
/// unflagged (d = 0) particles, whichever body they belong to. Under the
/// bottom edges of a block standing on a plane, the plane's third layer
/// (below the 0.99 threshold's reach) is nearer than the block's own
/// interior, so the block's edge particles had ∇D̄ pointing up into the
/// block, like the plane's, and joined the plane's side (docs/dfg.md, "In
/// 3D", has the measurement). 2D keeps ∇D̄ first, as measured there.
///
/// In 3D, at a node whose direction is balanced (`balanced`: two surfaces
/// face each other there, [`Dfg::balance`]), a particle without a normal
/// (inside its body) is placed by its position alone, against the cut
/// between the two surfaces: its ∇D̄ points to the nearest band of any
/// surface, and inside a plate 40 mm thick that is the plate's own bottom
/// for the lower half, which put the plane's inner particles on the
/// block's side at the nodes the block reaches with its kernel tail. 2D
/// keeps ∇D̄ (its results are to stay as they were; these rules were
/// measured only on the 3D incline).
#[inline(always)]
fn side<const D: usize>(
    gp: [f64; D],
    op: [f64; D],
    ni: [f64; D],
    xp: [f64; D],
    cut: f64,
    balanced: bool,
) -> u32 {
    if D == 3 && balanced && op == [0.0; D] {
        return u32::from(dot(ni, xp) > cut);
    }
    let clear = |g: [f64; D]| {
        let d = dot(g, ni);
        (d * d > SIDE_COS * SIDE_COS * dot(g, g)).then_some(d < 0.0)
    };
    // 3D: a surface particle's own normal before ∇D̄ (see the doc above)
    let by_direction = if D == 3 && op != [0.0; D] {
        clear(op)
    } else {
        clear(gp).or_else(|| clear(op))
    };
    let behind = by_direction.unwrap_or_else(|| dot(ni, xp) > cut);
    u32::from(behind)
}

/// The side of a particle at a node: without self-contact (`paper`) the
/// sign test of Algorithm 2 as written, ∇D̄_p·∇D̄_i < 0 → side 1 (ties,
/// such as the gradient-free particles inside a failed band, go to side
/// 0); with it, [`side`].
#[inline(always)]
fn side_at<const D: usize>(
    paper: bool,
    gp: [f64; D],
    op: [f64; D],
    ni: [f64; D],
    xp: [f64; D],
    cut: f64,
    balanced: bool,
) -> u32 {
    if paper {
        u32::from(dot(gp, ni) < 0.0)
    } else {
        side(gp, op, ni, xp, cut, balanced)
    }
}

/// Candidate directions of the balanced nodal direction in 2D
/// ([`Dfg::balance`]), spaced 180°/NDIR.
const NDIR: usize = 16;

/// Candidate directions in 3D ([`Candidates`]): a spiral on the half
/// sphere, at most 11.25° between neighbours as in 2D.
const NDIR_3D: usize = 188;

/// Cube-map cells per face edge of the 3D candidates' lookup
/// ([`Candidates`]).
const BUCKETS_3D: usize = 8;

/// A particle counts for a side of candidate n_k in [`Dfg::balance`] only
/// if its direction lies within this cosine (26°) of ±n_k: two faces
/// meeting at a body's corner are perpendicular, not opposing.
const CONE_COS: f64 = 0.9;

/// A node's balanced direction is used only where its weaker side holds at
/// least this fraction of the node's Σ N_ip m_p over the particles with a
/// direction.
const BALANCE_MIN: f64 = 0.01;

/// [`BALANCE_MIN`] in 3D. Where a body reaches a node only with its
/// kernel's tail (weight 1/32 per axis, the rows next to a contact plane,
/// and less at the edges of a face), its share is below 1 %: the node then
/// kept Algorithm 1's direction and both bodies one field there, which
/// welded the block on the incline (docs/dfg.md, "Why it welds").
const BALANCE_MIN_3D: f64 = 0.001;

/// 3D: particles q count as facing p ([`facing`]) where each lies in front
/// of the other's normal by at least this cosine (80°).
const FACING_COS: f64 = 0.17;

/// 2D: the candidates within [`CONE_COS`] of a direction, at most five.
const CONE_K: usize = 5;

/// The candidate directions n_k of [`Dfg::balance`] (a unit direction and
/// its negative are one candidate with two slots, 2k for +n_k and 2k + 1
/// for −n_k, as `u16`) and how a particle's direction u finds those within
/// the cone |n_k·u| > [`CONE_COS`].
///
/// - 2D: NDIR = 16 directions on the half circle, n_k at angle 180°·k/16
///   (11.25° apart); the candidates in the cone of u are among the five
///   around the nearest one (2 · 11.25° < acos 0.9 = 25.8° < 3 · 11.25°).
/// - 3D: NDIR_3D = 188 directions on the upper half sphere, the spiral
///   (Fibonacci) point set z_k = 1 − (k + ½)/188, azimuth k times the
///   golden angle π(3 − √5): equal areas, 2π/188 sr per direction, as many
///   as a hexagonal lattice of 11.25° spacing needs. Measured
///   (`candidates_cover_the_half_sphere_evenly`, counting a direction's
///   negative as the same candidate): nearest neighbours 6.0°–10.2° apart
///   (mean 9.8°), every direction within 8.0° of one (2D: 5.6°). A
///   deterministic set with no preferred axis but z, at a density a
///   subdivided icosahedron (6, 21, 81, 321 directions on the half sphere)
///   does not offer. The candidates near u are found by a cube map: u's
///   face (its largest component) and an 8 × 8 cell of it; each cell lists,
///   once, when the candidates are built, every n_k with |n_k·c| ≥
///   cos(acos 0.9 + ρ) for its centre c and angular radius ρ (a cube-map
///   cell is a geodesic quadrilateral, farthest from its centre at a
///   corner), which by the triangle inequality holds every candidate within
///   the cone of any u in the cell: at most 37 to test, of which 15–23 pass
///   (`the_candidates_in_the_cone_are_those_a_full_search_finds`). Per node
///   the balance then sums 2 · 188 + 1 values (3 kB), a table sized at the
///   first balance, so only with self-contact.
#[derive(Debug, Clone)]
struct Candidates<const D: usize> {
    dir: Vec<[f64; D]>,
    /// 3D: `list[start[c]..start[c + 1]]` are the candidates near cube-map
    /// cell c (empty in 2D).
    start: Vec<u32>,
    list: Vec<u16>,
}

impl<const D: usize> Candidates<D> {
    fn new() -> Self {
        if D == 2 {
            let dir = (0..NDIR)
                .map(|k| {
                    let a = std::f64::consts::PI * k as f64 / NDIR as f64;
                    let mut n = [0.0; D];
                    (n[0], n[1]) = (a.cos(), a.sin());
                    n
                })
                .collect();
            return Candidates {
                dir,
                start: Vec::new(),
                list: Vec::new(),
            };
        }
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let dir: Vec<[f64; D]> = (0..NDIR_3D)
            .map(|k| {
                let z = 1.0 - (k as f64 + 0.5) / NDIR_3D as f64;
                let r = (1.0 - z * z).sqrt();
                let a = golden * k as f64;
                let mut n = [0.0; D];
                (n[0], n[1], n[2]) = (r * a.cos(), r * a.sin(), z);
                n
            })
            .collect();
        let cone = CONE_COS.acos();
        let m = BUCKETS_3D;
        let mut start = vec![0u32];
        let mut list = Vec::new();
        for cell in 0..6 * m * m {
            let corner = |i: f64, j: f64| cube_direction::<D>(cell / (m * m), i, j, m);
            let (i, j) = ((cell % (m * m)) % m, (cell % (m * m)) / m);
            let c = corner(i as f64 + 0.5, j as f64 + 0.5);
            let rho = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
                .iter()
                .map(|&(di, dj)| {
                    dot(c, corner(i as f64 + di, j as f64 + dj))
                        .clamp(-1.0, 1.0)
                        .acos()
                })
                .fold(0.0, f64::max);
            // (a margin for the rounding of the test against the bound)
            let reach = (cone + rho + 1e-6).min(std::f64::consts::FRAC_PI_2).cos();
            list.extend(
                (0..NDIR_3D)
                    .filter(|&k| dot(dir[k], c).abs() >= reach)
                    .map(|k| k as u16),
            );
            start.push(list.len() as u32);
        }
        Candidates { dir, start, list }
    }

    /// The candidates to test against unit direction `u` (ascending).
    #[inline(always)]
    fn near(&self, u: [f64; D]) -> &[u16] {
        let c = cube_cell(u, BUCKETS_3D);
        &self.list[self.start[c] as usize..self.start[c + 1] as usize]
    }

    /// Calls `f(slot, (n_k·u)²)` for every candidate within the cone of
    /// ±u (unit), slot 2k for +n_k and 2k + 1 for −n_k.
    #[inline(always)]
    fn in_cone(&self, u: [f64; D], mut f: impl FnMut(u16, f64)) {
        let mut test = |k: usize| {
            let c = dot(self.dir[k], u);
            if c.abs() > CONE_COS {
                f((2 * k + usize::from(c < 0.0)) as u16, c * c);
            }
        };
        if D == 2 {
            let theta = u[1].atan2(u[0]).rem_euclid(std::f64::consts::PI);
            let k0 = (theta * NDIR as f64 / std::f64::consts::PI).round() as usize;
            for dk in 0..CONE_K {
                test((k0 + NDIR + dk - CONE_K / 2) % NDIR);
            }
        } else {
            for &k in self.near(u) {
                test(k as usize);
            }
        }
    }
}

/// The unit direction at cube-map coordinates (i, j) (in cells, 0..m) of
/// face `face` (axis face / 2, sign − for odd faces); [`cube_cell`]'s
/// inverse at the cell's points.
fn cube_direction<const D: usize>(face: usize, i: f64, j: f64, m: usize) -> [f64; D] {
    let a = face / 2;
    let mut n = [0.0; D];
    n[a] = if face % 2 == 1 { -1.0 } else { 1.0 };
    n[(a + 1) % 3] = 2.0 * i / m as f64 - 1.0;
    n[(a + 2) % 3] = 2.0 * j / m as f64 - 1.0;
    unit(n).unwrap_or(n)
}

/// The cube-map cell of a 3D direction: the face of its largest component
/// (the first of equal ones), then an m × m cell of the face.
#[inline(always)]
fn cube_cell<const D: usize>(u: [f64; D], m: usize) -> usize {
    let mut a = 0;
    for b in 1..3 {
        if u[b].abs() > u[a].abs() {
            a = b;
        }
    }
    let face = 2 * a + usize::from(u[a] < 0.0);
    let at = |c: f64| ((((c / u[a].abs()) + 1.0) * 0.5 * m as f64).max(0.0) as usize).min(m - 1);
    let (i, j) = (at(u[(a + 1) % 3]), at(u[(a + 2) % 3]));
    face * m * m + j * m + i
}

/// An empty entry of a particle's balance shares.
const NONE_SLOT: u16 = u16::MAX;

/// Runs `f(p, node, N_ip m_p)` for every (particle, node) pair of the
/// particles in `hot` tiles for which `take(p)`, coloured like P2G (see
/// [`scatter_coloured`]: `f` may add into `node` through a [`SyncPtr`]).
fn scatter_hot<K: Kernel, const D: usize, const V: usize>(
    geom: &GridGeom<D>,
    parts: &Particles<D, V>,
    bins: &Bins,
    hot: &[bool],
    take: impl Fn(usize) -> bool + Sync,
    f: impl Fn(usize, usize, f64) + Sync,
) {
    for colour in &bins.colours {
        colour
            .par_iter()
            .filter(|&&t| hot[t as usize])
            .for_each(|&tile| {
                for &p in bins.particles_of(tile) {
                    let p = p as usize;
                    if !take(p) {
                        continue;
                    }
                    particle_support::<K, D, V>(geom, parts, p)
                        .for_each(|n| f(p, n.node, n.w * parts.mass[p]));
                }
            });
    }
}

/// 3D self-contact: the direction in which surface particle p faces
/// another surface, the kernel-weighted mean of the unit offsets x_q − x_p
/// to the surface particles q within the radius that *face* p, each lying
/// in front of the other's normal, (x_q − x_p)·n_p > 0 and
/// (x_p − x_q)·n_q > 0 (by [`FACING_COS`] of the distance); zero where
/// none does.
/// [`Dfg::balance`] uses it instead of p's normal. At the edges where a
/// block's face meets a plane's face flush with it, the particles' normals
/// are the two bodies' edge normals, (0, −0.71, 0.71) and (0, 0.71, 0.71),
/// 90° apart as the two faces of one body's convex corner are, so the
/// balance's cone could not tell them from a corner and the edge nodes kept
/// both bodies in one field; the particles of one convex corner lie behind
/// each other's normals, the two bodies' edge particles in front, and
/// their facing directions are −y and +y. (A concave corner of one body
/// faces itself by this rule; not measured.)
fn facing<const D: usize>(
    p: usize,
    x: &[[f64; D]],
    normal: &[[f64; D]],
    nb: &Neighbours<D>,
    r: f64,
) -> [f64; D] {
    let Some(np) = normal.get(p).copied().and_then(unit) else {
        return [0.0; D];
    };
    let mut c = [0.0; D];
    for &q in nb.of(p) {
        let q = q as usize;
        let Some(nq) = normal.get(q).copied().and_then(unit) else {
            continue;
        };
        let dx = sub(x[q], x[p]);
        let l = dot(dx, dx).sqrt();
        if l >= r || l == 0.0 {
            continue;
        }
        if dot(dx, np) > FACING_COS * l && -dot(dx, nq) > FACING_COS * l {
            let (w, _) = kernel(l / r, r);
            for a in 0..D {
                c[a] += w * dx[a] / l;
            }
        }
    }
    unit(c).unwrap_or([0.0; D])
}

/// The kernel of eq. 18 and its derivative factor: ω(r̄) and
/// (dω/dr̄)/(r̄ R²), so that ∇_x ω = factor · (x − x_q). The same in 2D
/// and 3D.
#[inline(always)]
fn kernel(rbar: f64, radius: f64) -> (f64, f64) {
    (
        1.0 - 3.0 * rbar * rbar + 2.0 * rbar * rbar * rbar,
        6.0 * (rbar - 1.0) / (radius * radius),
    )
}

/// Particles per rayon task of the kernel sums in [`Dfg::field`].
const GRAD_CHUNK: usize = 256;

/// Neighbours per block of [`damage_gradient`]'s first pass.
const GRAD_BLOCK: usize = 16;

/// ∇D̄ at particle p (eqs. 17–19): D̄ = Σ ω_q d_q / Σ ω_q over the
/// neighbours within the kernel radius `r`, and its gradient
/// (Σ ∇ω_q d_q − D̄ Σ ∇ω_q) / Σ ω_q. A flat field (every neighbour's d equal
/// to p's) has none and returns zero without the sums.
///
/// The sums run in two passes over each block of [`GRAD_BLOCK`]
/// neighbours: the first computes every neighbour's terms independently
/// (the square root and the divisions, which vectorise), the second adds
/// them in list order, a neighbour outside the radius adding zeros. The
/// sums start at +0 and every term is added in the order of the single
/// loop this replaced, and a zero added to a sum that is not −0 leaves its
/// bits as they are (a round-to-nearest sum that starts at +0 never gives
/// −0): the same bits as skipping the neighbour.
#[inline(always)]
fn damage_gradient<const D: usize>(
    p: usize,
    x: &[[f64; D]],
    d: &[f64],
    list: &[u32],
    r: f64,
) -> [f64; D] {
    let dp = d[p];
    if list.iter().all(|&q| d[q as usize] == dp) {
        return [0.0; D];
    }
    let xp = x[p];
    let (mut s, mut ds, mut gs, mut gds) = (0.0, 0.0, [0.0; D], [0.0; D]);
    let mut tw = [0.0; GRAD_BLOCK];
    let mut tdw = [0.0; GRAD_BLOCK];
    let mut tg = [[0.0; GRAD_BLOCK]; D];
    let mut tgd = [[0.0; GRAD_BLOCK]; D];
    let mut xq = [[0.0; GRAD_BLOCK]; D];
    let mut dq = [0.0; GRAD_BLOCK];
    for block in list.chunks(GRAD_BLOCK) {
        // gathered first, so that the arithmetic below is one loop of
        // fixed length over plain arrays (entries past the block's end are
        // left from the last block and masked)
        for (k, &q) in block.iter().enumerate() {
            let q = q as usize;
            for a in 0..D {
                xq[a][k] = x[q][a];
            }
            dq[k] = d[q];
        }
        let len = block.len();
        for k in 0..GRAD_BLOCK {
            let dx: [f64; D] = std::array::from_fn(|a| xp[a] - xq[a][k]);
            let r2 = dot(dx, dx);
            let (w, f) = kernel(r2.sqrt() / r, r);
            let inside = r2 < r * r && k < len;
            tw[k] = if inside { w } else { 0.0 };
            tdw[k] = if inside { dq[k] * w } else { 0.0 };
            for a in 0..D {
                tg[a][k] = if inside { f * dx[a] } else { 0.0 };
                tgd[a][k] = if inside { dq[k] * f * dx[a] } else { 0.0 };
            }
        }
        for k in 0..block.len() {
            s += tw[k];
            ds += tdw[k];
            for a in 0..D {
                gs[a] += tg[a][k];
                gds[a] += tgd[a][k];
            }
        }
    }
    if s > 0.0 {
        let dbar = ds / s;
        std::array::from_fn(|a| (gds[a] - dbar * gs[a]) / s)
    } else {
        [0.0; D]
    }
}

/// cof(F) N = det F · F⁻ᵀ N, the direction of a material normal N after
/// the deformation F (row-major): in 2D [F₁₁N₀ − F₁₀N₁, −F₀₁N₀ + F₀₀N₁];
/// in 3D N₀ a₁×a₂ + N₁ a₂×a₀ + N₂ a₀×a₁ with a_j the columns of F.
#[inline(always)]
fn cof_times<const D: usize>(f: &[[f64; D]; D], n: [f64; D]) -> [f64; D] {
    let mut out = [0.0; D];
    if D == 2 {
        out[0] = f[1][1] * n[0] - f[1][0] * n[1];
        out[1] = -f[0][1] * n[0] + f[0][0] * n[1];
    } else {
        let col = |j: usize| [f[0][j], f[1][j], f[2][j]];
        let cross = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let (a0, a1, a2) = (col(0), col(1), col(2));
        let (c0, c1, c2) = (cross(a1, a2), cross(a2, a0), cross(a0, a1));
        for k in 0..3 {
            out[k] = n[0] * c0[k] + n[1] * c1[k] + n[2] * c2[k];
        }
    }
    out
}

/// Settings of the partitioning, in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DfgParams {
    /// Kernel radius r, m.
    pub radius: f64,
    /// Rebuild fraction f of the radius.
    pub rebuild_fraction: f64,
    /// D_min of the separability condition.
    pub separability: f64,
    /// Coulomb friction between a group's two sides where they touch.
    pub self_friction: f64,
}

/// Per-node sums of the separability test, for sides 0 and 1:
/// Σ N m, Σ N m d, max d.
#[derive(Debug, Clone, Copy, Default)]
struct SideSums {
    w: [f64; 2],
    wd: [f64; 2],
    dmax: [f64; 2],
}

/// What the partitioning did this run.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DfgStats {
    /// Neighbour-list builds.
    pub neighbour_builds: u64,
    /// Nodes where the two sides of a group were separate fields in the
    /// last step.
    pub separated_nodes: u64,
    /// Surface particles flagged for self-contact.
    pub surface_particles: u64,
}

/// The partitioning state: neighbour lists, surface flags, the field
/// gradients of the current step, in `D` = 2 or 3 dimensions.
#[derive(Debug, Clone)]
pub struct Dfg<const D: usize = 2> {
    params: DfgParams,
    neighbours: Neighbours<D>,
    /// Self-contact surface flags s_p (empty without self-contact).
    surface: Vec<f64>,
    /// Outward unit normals of the surface particles in the reference
    /// configuration, from the gradient of their body's kernel sum (zero
    /// inside; empty without self-contact).
    normal0: Vec<[f64; D]>,
    /// `normal0` rotated by cof F at this step's partition, where the
    /// material tracks F (empty otherwise; see [`Dfg::normals`]).
    normal: Vec<[f64; D]>,
    /// d_p = max(s_p, D_p) of this step.
    d: Vec<f64>,
    /// Neighbour-list key: the contact group of particles that can carry
    /// damage or a surface flag, [`Neighbours::NONE`] for the rest (an
    /// elastic striker needs no damage field).
    key: Vec<u16>,
    /// ∇D̄ at the particles (zero away from damage).
    pub grad: Vec<[f64; D]>,
    /// The nodal direction: Algorithm 1's, turned towards opposing
    /// surfaces where there are some ([`Dfg::balance`]).
    pub node_grad: Vec<[f64; D]>,
    /// The candidate directions of [`Dfg::balance`].
    cand: Candidates<D>,
    /// Per node, `stride` entries: for each candidate direction n_k the
    /// two sides' sums of [`Dfg::balance`], then Σ N_ip m_p; reused by its
    /// second pass. Sized at the first balance (self-contact only).
    dirs: Vec<f64>,
    /// Per particle, its (slot, weight) entries of `dirs` (the balance):
    /// `shares[share_start[p]..share_start[p + 1]]`.
    share_start: Vec<u32>,
    shares: Vec<(u16, f64)>,
    /// 3D: each surface particle's facing direction ([`facing`]), this
    /// step (empty in 2D and without self-contact).
    facing: Vec<[f64; D]>,
    /// Where the surface lies at each node, along its unit direction
    /// (n_i·x, m; see [`Dfg::balance`]).
    pub cut: Vec<f64>,
    /// Nodes whose direction [`Dfg::balance`] turned towards opposing
    /// surfaces (false without self-contact); [`side`] places the particles
    /// without a normal by position there in 3D.
    pub balanced: Vec<bool>,
    /// Particle positions at this step's partition: the side rule
    /// ([`side`]) must give the same field in P2G and G2P, and G2P moves
    /// the particles.
    pub x_partition: Vec<[f64; D]>,
    sums: Vec<SideSums>,
    /// Node ranges written in the last step (zeroed before the next).
    written: Vec<Range<usize>>,
    /// Tiles with damage nearby (their particles get a gradient).
    hot: Vec<bool>,
    /// Nodes that a failed particle maps to, this step (the paper's rules
    /// only: see [`Dfg::field`]).
    failed_node: Vec<bool>,
    separated: u64,
    surface_count: u64,
}

impl<const D: usize> Dfg<D> {
    /// Sets up the partitioning; with `self_contact`, flags as surface
    /// particles those whose kernel sum over their own body is below
    /// `threshold` times the body's largest (section 2.4).
    /// `takes_part[m]` says whether particles of material m can be damaged
    /// (all particles take part with self-contact).
    pub fn new<const V: usize>(
        params: DfgParams,
        geom: &GridGeom<D>,
        parts: &Particles<D, V>,
        self_contact: Option<f64>,
        takes_part: &[bool],
    ) -> Dfg<D> {
        let n = parts.len();
        let key = (0..n)
            .map(|p| {
                if self_contact.is_some() || takes_part[parts.material[p] as usize] {
                    parts.group[p] as u16
                } else {
                    Neighbours::<D>::NONE
                }
            })
            .collect();
        let mut surface = Vec::new();
        let mut normal0 = Vec::new();
        let mut surface_count = 0;
        if let Some(threshold) = self_contact {
            let mut nb = Neighbours::<D>::default();
            nb.build(
                &parts.x,
                &parts.body,
                params.radius,
                geom.domain_min,
                geom.domain_max,
            );
            // kernel sum and its gradient (which points into the body)
            let (sum, sgrad): (Vec<f64>, Vec<[f64; D]>) = (0..n)
                .into_par_iter()
                .map(|p| {
                    let (mut s, mut g) = (0.0, [0.0; D]);
                    for &q in nb.of(p) {
                        let d = sub(parts.x[p], parts.x[q as usize]);
                        let rbar = dot(d, d).sqrt() / params.radius;
                        if rbar < 1.0 {
                            let (w, f) = kernel(rbar, params.radius);
                            s += w;
                            g = std::array::from_fn(|a| g[a] + f * d[a]);
                        }
                    }
                    (s, g)
                })
                .unzip();
            let bodies = parts
                .body
                .iter()
                .map(|&b| b as usize + 1)
                .max()
                .unwrap_or(0);
            let mut smax = vec![0.0f64; bodies];
            for (&b, &sp) in parts.body.iter().zip(&sum) {
                smax[b as usize] = smax[b as usize].max(sp);
            }
            surface = (0..n)
                .map(|p| {
                    if sum[p] < threshold * smax[parts.body[p] as usize] {
                        1.0
                    } else {
                        0.0
                    }
                })
                .collect();
            surface_count = surface.iter().filter(|&&s| s > 0.0).count() as u64;
            normal0 = (0..n)
                .map(|p| match unit(sgrad[p]) {
                    Some(u) if surface[p] > 0.0 => u.map(|c| -c),
                    _ => [0.0; D],
                })
                .collect();
        }
        Dfg {
            params,
            neighbours: Neighbours::default(),
            key,
            surface,
            normal: Vec::new(),
            normal0,
            d: vec![0.0; n],
            grad: vec![[0.0; D]; n],
            node_grad: vec![[0.0; D]; geom.node_count()],
            cand: Candidates::new(),
            dirs: Vec::new(),
            share_start: Vec::new(),
            shares: Vec::new(),
            facing: Vec::new(),
            cut: vec![0.0; geom.node_count()],
            balanced: vec![false; geom.node_count()],
            x_partition: Vec::with_capacity(n),
            sums: vec![SideSums::default(); geom.node_count()],
            written: Vec::new(),
            hot: Vec::new(),
            failed_node: vec![false; geom.node_count()],
            separated: 0,
            surface_count,
        }
    }

    /// What a checkpoint keeps of the neighbour lists: the positions they
    /// were built at (empty before the first build) and the builds so far.
    pub fn neighbour_state(&self) -> (Vec<[f64; D]>, u64) {
        (self.neighbours.built_at().to_vec(), self.neighbours.builds)
    }

    /// The neighbour lists of a checkpoint ([`Dfg::neighbour_state`]):
    /// built again at the same positions, so that they and the rebuild
    /// rule are as the run left them.
    pub fn restore_neighbours<const V: usize>(
        &mut self,
        geom: &GridGeom<D>,
        parts: &Particles<D, V>,
        x_built: &[[f64; D]],
        builds: u64,
    ) {
        self.neighbours = Neighbours::default();
        if !x_built.is_empty() {
            self.build_neighbours(geom, parts, x_built);
        }
        self.neighbours.builds = builds;
    }

    /// The neighbour lists at positions `x` (the search reach is the
    /// kernel radius plus twice the rebuild skin).
    fn build_neighbours<const V: usize>(
        &mut self,
        geom: &GridGeom<D>,
        parts: &Particles<D, V>,
        x: &[[f64; D]],
    ) {
        let r = self.params.radius;
        let skin = self.params.rebuild_fraction * r;
        let groups: Vec<u16> = parts.group.iter().map(|&g| g as u16).collect();
        self.neighbours
            .build(x, &groups, r + 2.0 * skin, geom.domain_min, geom.domain_max);
    }

    pub fn stats(&self) -> DfgStats {
        DfgStats {
            neighbour_builds: self.neighbours.builds,
            separated_nodes: self.separated,
            surface_particles: self.surface_count,
        }
    }

    /// The surface flags (empty without self-contact).
    pub fn surface(&self) -> &[f64] {
        &self.surface
    }

    /// The `damage_field` stage: d_p, the particle gradients ∇D̄ (eqs.
    /// 17–19) near damage, and the nodal gradients of Algorithm 1.
    pub fn field<K: Kernel, const V: usize>(
        &mut self,
        geom: &GridGeom<D>,
        parts: &Particles<D, V>,
        bins: &Bins,
    ) {
        let n = parts.len();
        let (damage, phase) = (&parts.damage, &parts.phase);
        let surface = &self.surface;
        self.d.par_iter_mut().enumerate().for_each(|(p, d)| {
            let a = damage.get(p).copied().unwrap_or(0.0);
            // (c = 1 on bodies without a phase field)
            let c = phase.get(p).map_or(0.0, |&c| dfg_damage(c));
            let s = surface.get(p).copied().unwrap_or(0.0);
            *d = a.max(c).max(s);
        });
        let r = self.params.radius;
        let skin = self.params.rebuild_fraction * r;
        if self.neighbours.stale(&parts.x, skin) {
            self.build_neighbours(geom, parts, &parts.x);
        }
        // Tiles with a failed particle (d = 1) in them or next to them (the
        // 3^D around it). Only a node that a failed particle maps to can
        // separate (section 2.3); the particles that share such a node are
        // within 3 cells of it, the kernel reaches r < 2 cells further
        // (one cell diagonal, h√2 or h√3), both inside the next tile (8
        // cells). Elsewhere the sides merge whatever the gradients say, so
        // they are left zero.
        let ntiles = geom.tile_count();
        self.hot.clear();
        self.hot.resize(ntiles, false);
        let tiles = geom.tiles;
        for t in 0..ntiles {
            if !bins
                .particles_of(t as u32)
                .iter()
                .any(|&p| self.d[p as usize] >= FAILED)
            {
                continue;
            }
            let mut rest = t;
            let c: [usize; D] = std::array::from_fn(|a| {
                let c = rest % tiles[a];
                rest /= tiles[a];
                c
            });
            let lo: [usize; D] = std::array::from_fn(|a| c[a].saturating_sub(1));
            let hi: [usize; D] = std::array::from_fn(|a| (c[a] + 2).min(tiles[a]));
            let mut at = lo;
            'tiles: loop {
                self.hot[bin_index(at, tiles)] = true;
                for a in 0..D {
                    at[a] += 1;
                    if at[a] < hi[a] {
                        continue 'tiles;
                    }
                    at[a] = lo[a];
                }
                break;
            }
        }
        debug_assert!(r < TILE as f64 * geom.h);
        // With the paper's rules a nodal direction counts only at the nodes
        // that a failed particle maps to (the only separable ones).
        // Elsewhere it only picks which side label a node's one field has
        // (both sides merge), and a node's one field takes the node's own
        // slot whatever its label. So Algorithm 1 writes those nodes alone,
        // and the partition tests no side elsewhere: the same fields, the
        // same slots. (Self-contact's balance also reads the directions
        // near surfaces, so it keeps them all.) Computing the gradients only
        // for the particles that map to such a node saves nothing: those
        // whose neighbourhood is not flat nearly all do (98 % on the disk).
        let paper = self.normal0.is_empty();
        let (x, d, nb, hot, tile_of, key) = (
            &parts.x,
            &self.d,
            &self.neighbours,
            &self.hot,
            &bins.tile_of,
            &self.key,
        );
        // Chunks of particles, each in `cpu::wide`'s copy (the same bits):
        // the kernel's square root and divisions then run on vector lanes.
        self.grad[..n]
            .par_chunks_mut(GRAD_CHUNK)
            .enumerate()
            .for_each(|(c, chunk)| {
                crate::cpu::wide(
                    #[inline(always)]
                    || {
                        for (i, g) in chunk.iter_mut().enumerate() {
                            let p = c * GRAD_CHUNK + i;
                            *g = [0.0; D];
                            if !hot[tile_of[p] as usize] || key[p] == Neighbours::<D>::NONE {
                                continue;
                            }
                            *g = damage_gradient(p, x, d, nb.of(p), r);
                        }
                    },
                )
            });
        // Algorithm 1, coloured like P2G (deterministic: within a colour the
        // tiles' node sets are disjoint; ties keep the first particle).
        for r in &self.written {
            self.node_grad[r.clone()].fill([0.0; D]);
            self.cut[r.clone()].fill(0.0);
            self.balanced[r.clone()].fill(false);
            self.sums[r.clone()].fill(SideSums::default());
            self.failed_node[r.clone()].fill(false);
        }
        self.written.clone_from(&bins.active);
        let ng = SyncPtr::new(&mut self.node_grad);
        let failed = SyncPtr::new(&mut self.failed_node);
        let (grad, d) = (&self.grad, &self.d);
        // (the failed particles all lie in hot tiles)
        scatter_hot::<K, D, V>(
            geom,
            parts,
            bins,
            &self.hot,
            |p| grad[p] != [0.0; D] || (paper && d[p] >= FAILED),
            |p, node, _| {
                // SAFETY: coloured scatter (see `scatter_coloured`).
                unsafe {
                    if paper && d[p] >= FAILED {
                        *failed.at(node) = true;
                    }
                    let g = grad[p];
                    let gi = ng.at(node);
                    if g != [0.0; D] && dot(g, g) > dot(*gi, *gi) {
                        *gi = g;
                    }
                }
            },
        );
        if paper {
            // (only the failed nodes keep a direction: the partition puts
            // every particle on side 0 elsewhere, without a test)
            for r in &self.written {
                for (g, &f) in self.node_grad[r.clone()]
                    .iter_mut()
                    .zip(&self.failed_node[r.clone()])
                {
                    if !f {
                        *g = [0.0; D];
                    }
                }
            }
        }
        if !paper && !parts.def_grad.is_empty() {
            // n ∝ F⁻ᵀ N = cof(F) N / det F
            self.normal.clear();
            self.normal.extend(
                self.normal0
                    .iter()
                    .zip(&parts.def_grad)
                    .map(|(n, f)| cof_times(f, *n)),
            );
        }
        // Without self-contact the paper's Algorithm 1 stands as it is: the
        // balance is for surfaces that touch (see the module docs).
        if !paper {
            self.balance::<K, V>(geom, parts, bins);
        }
    }

    /// Turns the nodal direction towards opposing surfaces and finds where
    /// the surface lies. Algorithm 1 takes the largest particle gradient,
    /// and eq. 20's formal direction (maximize Σ_p N_ip m_p |n·∇D̄_p|) the
    /// dominant one; both follow a body's own free face where it meets
    /// another surface — at the corner of a block standing on a plane the
    /// block's side face wins, the plane and the block land on one side and
    /// are welded there. Contact needs the direction along which particles
    /// face each other, so each particle contributes its unit direction u_p
    /// (∇D̄_p, or its outward normal where D̄ is flat), and among the
    /// candidates n_k ([`Candidates`]: 16 on the half circle in 2D, 188 on
    /// the half sphere in 3D) we take the one that maximizes the weaker
    /// side, min(Σ N m (n_k·u_p)² over u_p within [`CONE_COS`] of +n_k, the
    /// same for −n_k). At a straight crack that is the crack normal (as
    /// with Algorithm 1); at a lone free face no direction has an opposing
    /// side and Algorithm 1's gradient stays. The candidates are about
    /// 11.25° apart, well inside the [`side`] test's tolerance; the contact
    /// normals come from the mass gradients, not from this direction. A
    /// second pass puts the surface (`cut`, along n_i) at the centroid of
    /// d_p = max(s_p, D_p) — the damaged band, or the surface bands of two
    /// faces in contact, whose inner particles have no gradient and are
    /// placed by it; elsewhere it is the node. Leaves `node_grad` unit or
    /// zero.
    ///
    /// In 3D (docs/dfg.md, "Why it welds", items 6–8): a surface particle's
    /// direction is its [`facing`] direction where it has one; a node
    /// balances where its weaker side holds [`BALANCE_MIN_3D`] (0.1 %, so
    /// that a body reaching the node only with its kernel's tail counts);
    /// and at a balanced node the cut lies halfway between the innermost
    /// surface particles of the two sides (their directions, as above,
    /// within the cone of ±n_i)
    /// where both are there, not at the centroid of d, which lay inside the
    /// heavier body's surface band.
    fn balance<K: Kernel, const V: usize>(
        &mut self,
        geom: &GridGeom<D>,
        parts: &Particles<D, V>,
        bins: &Bins,
    ) {
        let ncand = self.cand.dir.len();
        let stride = 2 * ncand + 1;
        let total = stride * geom.node_count();
        if self.dirs.len() != total {
            self.dirs.clear();
            self.dirs.resize(total, 0.0);
        }
        // Each particle's shares, (slot, (n_k·u_p)²) for the candidates
        // within the cone of ±u_p, the same for all its nodes: counted,
        // then written.
        let normal: &[[f64; D]] = if self.normal.is_empty() {
            &self.normal0
        } else {
            &self.normal
        };
        let (grad, hot, tile_of, cand) = (&self.grad, &self.hot, &bins.tile_of, &self.cand);
        if D == 3 {
            let (nb, r) = (&self.neighbours, self.params.radius);
            self.facing.resize(parts.len(), [0.0; D]);
            self.facing.par_iter_mut().enumerate().for_each(|(p, f)| {
                *f = if hot[tile_of[p] as usize] {
                    facing(p, &parts.x, normal, nb, r)
                } else {
                    [0.0; D]
                };
            });
        }
        let facing_dir = &self.facing;
        let direction = |p: usize| {
            if !hot[tile_of[p] as usize] {
                return None;
            }
            // 3D: a surface particle's facing direction, else its own
            // normal, for the reasons given at `facing` and `side`; 2D:
            // ∇D̄, else the normal
            let own = normal.get(p).copied().and_then(unit);
            if D == 3 && own.is_some() {
                return unit(facing_dir[p]).or(own);
            }
            unit(grad[p]).or(own)
        };
        let n = parts.len();
        self.share_start.resize(n + 1, 0);
        self.share_start[0] = 0;
        self.share_start[1..]
            .par_iter_mut()
            .enumerate()
            .for_each(|(p, k)| {
                *k = 0;
                if let Some(u) = direction(p) {
                    cand.in_cone(u, |_, _| *k += 1);
                }
            });
        for p in 0..n {
            self.share_start[p + 1] += self.share_start[p];
        }
        self.shares
            .resize(self.share_start[n] as usize, (NONE_SLOT, 0.0));
        let shares = SyncPtr::new(&mut self.shares);
        let share_start = &self.share_start;
        (0..n).into_par_iter().for_each(|p| {
            let Some(u) = direction(p) else {
                return;
            };
            let mut at = share_start[p] as usize;
            cand.in_cone(u, |slot, c2| {
                // SAFETY: p writes only its own range of `shares`.
                unsafe { *shares.at(at) = (slot, c2) };
                at += 1;
            });
        });
        let dirs = SyncPtr::new(&mut self.dirs);
        let shares = &self.shares;
        let has_direction =
            |p: usize| grad[p] != [0.0; D] || normal.get(p).is_some_and(|n| *n != [0.0; D]);
        scatter_hot::<K, D, V>(geom, parts, bins, &self.hot, has_direction, |p, node, w| {
            let mine = &shares[share_start[p] as usize..share_start[p + 1] as usize];
            if mine.is_empty() {
                return;
            }
            let base = node * stride;
            for &(slot, c2) in mine {
                // SAFETY: coloured scatter (see `scatter_coloured`).
                unsafe { *dirs.at(base + slot as usize) += w * c2 };
            }
            // SAFETY: as above.
            unsafe { *dirs.at(base + 2 * ncand) += w };
        });
        for r in &self.written {
            for n in r.clone() {
                let a = &mut self.dirs[n * stride..(n + 1) * stride];
                let min = if D == 3 { BALANCE_MIN_3D } else { BALANCE_MIN };
                let (mut best, mut best_k) = (min * a[2 * ncand], ncand);
                for k in 0..ncand {
                    let weaker = a[2 * k].min(a[2 * k + 1]);
                    if weaker > best {
                        (best, best_k) = (weaker, k);
                    }
                }
                a.fill(0.0);
                let g = &mut self.node_grad[n];
                self.balanced[n] = best_k < ncand;
                if best_k < ncand {
                    *g = self.cand.dir[best_k];
                    a[2 * ncand] = 1.0; // balanced: the second pass finds the cut
                } else if let Some(u) = unit(*g) {
                    *g = u;
                }
                self.cut[n] = dot(*g, geom.node_position(n));
            }
        }
        let dirs = SyncPtr::new(&mut self.dirs);
        let (ng, d) = (&self.node_grad, &self.d);
        scatter_hot::<K, D, V>(
            geom,
            parts,
            bins,
            &self.hot,
            |p| d[p] != 0.0,
            |p, node, w| {
                let base = node * stride;
                // SAFETY: coloured scatter (see `scatter_coloured`).
                unsafe {
                    if *dirs.at(base + 2 * ncand) != 0.0 {
                        let w = w * d[p];
                        let at = dot(ng[node], parts.x[p]);
                        *dirs.at(base) += w;
                        *dirs.at(base + 1) += w * at;
                        // 3D: the innermost surface particles of the two
                        // sides (normal within the cone of ±n_i), slots
                        // 2–5 (max along n_i of side 0, min of side 1, and
                        // whether each has one)
                        if D == 3 {
                            // (a surface particle, by the direction the
                            // balance gave it: facing, else its normal)
                            let surface = normal.get(p).is_some_and(|n| *n != [0.0; D]);
                            if let Some(u) = direction(p).filter(|_| surface) {
                                let c = dot(u, ng[node]);
                                let (k, first) = if c > CONE_COS {
                                    (2, *dirs.at(base + 4) == 0.0)
                                } else if c < -CONE_COS {
                                    (3, *dirs.at(base + 5) == 0.0)
                                } else {
                                    (0, false)
                                };
                                if k != 0 {
                                    let e = dirs.at(base + k);
                                    *e = match (first, k) {
                                        (true, _) => at,
                                        (false, 2) => e.max(at),
                                        _ => e.min(at),
                                    };
                                    *dirs.at(base + k + 2) = 1.0;
                                }
                            }
                        }
                    }
                }
            },
        );
        for r in &self.written {
            for n in r.clone() {
                let a = &mut self.dirs[n * stride..(n + 1) * stride];
                if a[2 * ncand] != 0.0 && a[0] > 0.0 {
                    self.cut[n] = a[1] / a[0];
                }
                // 3D: halfway between the two surfaces where both are there
                if D == 3 && a[2 * ncand] != 0.0 && a[4] != 0.0 && a[5] != 0.0 {
                    self.cut[n] = 0.5 * (a[2] + a[3]);
                }
                a.fill(0.0);
            }
        }
    }

    /// The surface normals of this step's partition, what [`side`] falls
    /// back on: the reference ones, or rotated by cof F (empty without
    /// self-contact).
    pub fn normals(&self) -> &[[f64; D]] {
        Self::normals_of(&self.normal, &self.normal0)
    }

    /// [`Dfg::normals`] from the two fields alone (borrowing them, not all
    /// of `self`, so the sums can be written meanwhile).
    fn normals_of<'a>(normal: &'a [[f64; D]], normal0: &'a [[f64; D]]) -> &'a [[f64; D]] {
        if normal.is_empty() {
            normal0
        } else {
            normal
        }
    }

    /// The `field_partition` stage with DFG: marks the fields (two sides
    /// per contact group, Algorithm 2) present at each node, merges the two
    /// sides where the node is not separable (section 2.3), and lays out
    /// the slots. Returns the number of slots.
    pub fn partition<K: Kernel, const V: usize>(
        &mut self,
        geom: &GridGeom<D>,
        parts: &Particles<D, V>,
        bins: &Bins,
        multi: &mut MultiField,
    ) -> usize {
        let nodes = geom.node_count();
        multi.mask.clear();
        multi.mask.resize(nodes, 0);
        self.x_partition.clone_from(&parts.x);
        // (`field` zeroed the sums the last step wrote)
        let mask = SyncPtr::new(&mut multi.mask);
        let sums = SyncPtr::new(&mut self.sums);
        let (grad, ngrad, d) = (&self.grad, &self.node_grad, &self.d);
        let (cut, normal) = (&self.cut, Self::normals_of(&self.normal, &self.normal0));
        let balanced = &self.balanced;
        let paper = normal.is_empty();
        let (hot, failed_node) = (&self.hot, &self.failed_node);
        if paper {
            // With the paper's rules the particles of tiles away from
            // damage map to no failed node ([`Dfg::field`]), where there is
            // no direction: side 0 at every node and nothing to sum.
            scatter_tiles::<K, D, V>(
                geom,
                parts,
                bins,
                |t| !hot[t as usize],
                #[inline(always)]
                |p, sup| {
                    let bit = 1 << (2 * parts.group[p] as u32);
                    sup.for_each(
                        #[inline(always)]
                        |n| {
                            debug_assert!(!failed_node[n.node]);
                            // SAFETY: coloured scatter; every write is to `n.node`.
                            unsafe { *mask.at(n.node) |= bit };
                        },
                    );
                },
            );
        }
        // inline(always) down to the node: the loop runs in `cpu::wide`'s copy
        scatter_tiles::<K, D, V>(
            geom,
            parts,
            bins,
            |t| !paper || hot[t as usize],
            #[inline(always)]
            |p, sup| {
                let (gp, xp) = (grad[p], parts.x[p]);
                let op = normal.get(p).copied().unwrap_or([0.0; D]);
                let base = 2 * parts.group[p] as u32;
                let m = parts.mass[p];
                if paper && gp == [0.0; D] {
                    // Algorithm 2's sign test puts a particle without a
                    // gradient on side 0 at every node (most particles)
                    let dp = d[p];
                    sup.for_each(
                        #[inline(always)]
                        |n| {
                            let node = n.node;
                            // SAFETY: coloured scatter; every write is to `node`.
                            unsafe {
                                *mask.at(node) |= 1 << base;
                                if ngrad[node] != [0.0; D] {
                                    let s = sums.at(node);
                                    let w = n.w * m;
                                    s.w[0] += w;
                                    s.wd[0] += w * dp;
                                    s.dmax[0] = s.dmax[0].max(dp);
                                }
                            }
                        },
                    );
                    return;
                }
                sup.for_each(
                    #[inline(always)]
                    |n| {
                        let node = n.node;
                        let gi = ngrad[node];
                        // (a node without a direction has everything on side 0)
                        let side = if gi == [0.0; D] {
                            0
                        } else {
                            side_at(paper, gp, op, gi, xp, cut[node], balanced[node]) as usize
                        };
                        // SAFETY: coloured scatter; every write is to `node`.
                        unsafe {
                            *mask.at(node) |= 1 << (base + side as u32);
                            if gi != [0.0; D] {
                                let s = sums.at(node);
                                let w = n.w * m;
                                s.w[side] += w;
                                s.wd[side] += w * d[p];
                                s.dmax[side] = s.dmax[side].max(d[p]);
                            }
                        }
                    },
                );
            },
        );
        // Section 2.3: merge the sides of a group where not separable.
        let dmin = self.params.separability;
        let mut separated = 0u64;
        for (m, s) in multi.mask.iter_mut().zip(&self.sums) {
            let mut pairs = *m & (*m >> 1) & 0x5555_5555;
            while pairs != 0 {
                let bit = pairs.trailing_zeros();
                pairs &= pairs - 1;
                let mean = |k: usize| if s.w[k] > 0.0 { s.wd[k] / s.w[k] } else { 0.0 };
                let separable = s.dmax[0].max(s.dmax[1]) >= FAILED && mean(0).min(mean(1)) > dmin;
                if separable {
                    separated += 1;
                } else {
                    *m &= !(1 << (bit + 1));
                }
            }
        }
        self.separated = separated;
        multi.layout()
    }
}

/// Slots of a DFG step: the field of a (node, particle) pair is its
/// contact group's side by the sign of ∇D̄_p·∇D̄_i, or the other side where
/// the two were merged.
pub struct DfgFields<'a, const D: usize = 2> {
    /// Particle positions at the partition ([`Dfg::x_partition`]).
    pub x: &'a [[f64; D]],
    pub cut: &'a [f64],
    /// Nodes with a balanced direction ([`Dfg::balanced`]).
    pub balanced: &'a [bool],
    /// Surface normals at the partition ([`Dfg::normals`]).
    pub normal: &'a [[f64; D]],
    pub nodes: usize,
    pub multi: &'a MultiField,
    pub group: &'a [u8],
    pub grad: &'a [[f64; D]],
    pub node_grad: &'a [[f64; D]],
}

impl<const D: usize> FieldSlots for DfgFields<'_, D> {
    #[inline(always)]
    fn slot(&self, node: usize, particle: usize) -> usize {
        let base = 2 * self.group[particle] as u32;
        // Where the group has one side at this node (all but the separated
        // nodes), that is the particle's field whatever its side.
        let field = match (self.multi.mask[node] >> base) & 3 {
            1 => base,
            2 => base + 1,
            _ => {
                let (gp, gi) = (self.grad[particle], self.node_grad[node]);
                let op = self.normal.get(particle).copied().unwrap_or([0.0; D]);
                let mut field = base
                    + side_at(
                        self.normal.is_empty(),
                        gp,
                        op,
                        gi,
                        self.x[particle],
                        self.cut[node],
                        self.balanced[node],
                    );
                if self.multi.mask[node] & (1 << field) == 0 {
                    field ^= 1;
                }
                field
            }
        };
        self.multi.slot_of(self.nodes, node, field)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn kernel_matches_eq_18_and_its_derivative() {
        let r = 2.0;
        for rbar in [0.0, 0.25, 0.5, 0.9] {
            let (w, f) = kernel(rbar, r);
            assert!((w - (1.0 - 3.0 * rbar * rbar + 2.0 * rbar.powi(3))).abs() < 1e-15);
            // d/dx of ω(|x|/r) at x = rbar·r along x: f · x
            let hstep = 1e-6;
            let (wp, _) = kernel(rbar + hstep / r, r);
            let (wm, _) = kernel((rbar - hstep / r).abs(), r);
            let fd = (wp - wm) / (2.0 * hstep);
            assert!(
                (fd - f * rbar * r).abs() < 1e-6,
                "{rbar}: {fd} vs {}",
                f * rbar * r
            );
        }
        assert_eq!(kernel(1.0, r).0, 0.0);
    }

    /// The 3D candidates: unit, on the upper half sphere, at most 11.25°
    /// from their nearest neighbours (counting a direction's negative as
    /// the same candidate), every direction within 8.5° of one; 2D's are
    /// the 16 of the half circle.
    #[test]
    fn candidates_cover_the_half_sphere_evenly() {
        let c2 = Candidates::<2>::new();
        assert_eq!(c2.dir.len(), NDIR);
        assert_eq!(c2.dir[4], [(PI / 4.0).cos(), (PI / 4.0).sin()]);
        let c = Candidates::<3>::new();
        assert_eq!(c.dir.len(), NDIR_3D);
        assert!(2 * NDIR_3D < NONE_SLOT as usize);
        let angle = |a: [f64; 3], b: [f64; 3]| dot(a, b).abs().min(1.0).acos().to_degrees();
        let mut nearest = Vec::new();
        for (k, &n) in c.dir.iter().enumerate() {
            assert!((dot(n, n) - 1.0).abs() < 1e-14 && n[2] > 0.0);
            let m = (0..NDIR_3D)
                .filter(|&j| j != k)
                .map(|j| angle(n, c.dir[j]))
                .fold(f64::INFINITY, f64::min);
            nearest.push(m);
        }
        let (lo, hi) = nearest
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(l, h), &x| (l.min(x), h.max(x)));
        let mean = nearest.iter().sum::<f64>() / NDIR_3D as f64;
        // the farthest any direction lies from its nearest candidate
        let mut cover = 0.0f64;
        for u in directions(20_000) {
            let m = c
                .dir
                .iter()
                .map(|&n| angle(n, u))
                .fold(f64::INFINITY, f64::min);
            cover = cover.max(m);
        }
        println!("3D candidates: nearest neighbours {lo:.1}°–{hi:.1}° (mean {mean:.2}°), covering {cover:.1}°");
        assert!(lo > 5.5 && hi < 11.25 && mean > 9.5, "{lo} {hi} {mean}");
        assert!(cover < 8.5, "{cover}");
    }

    /// Quasi-random unit directions over the whole sphere.
    fn directions(n: usize) -> impl Iterator<Item = [f64; 3]> {
        (0..n).map(move |k| {
            let z = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let a = 2.399_963 * k as f64 + 0.3;
            [r * a.cos(), r * a.sin(), z]
        })
    }

    /// The cube map finds every candidate within the cone of ±u, as a
    /// search through all of them does, with the right slots; in 2D the
    /// window around the nearest candidate does.
    #[test]
    fn the_candidates_in_the_cone_are_those_a_full_search_finds() {
        fn check<const D: usize>(c: &Candidates<D>, u: [f64; D]) -> usize {
            let mut got = Vec::new();
            c.in_cone(u, |slot, c2| got.push((slot, c2)));
            got.sort_by_key(|e| e.0);
            let want: Vec<(u16, f64)> = (0..c.dir.len())
                .filter_map(|k| {
                    let x = dot(c.dir[k], u);
                    (x.abs() > CONE_COS).then(|| ((2 * k + usize::from(x < 0.0)) as u16, x * x))
                })
                .collect();
            assert_eq!(got, want, "{u:?}");
            got.len()
        }
        let c3 = Candidates::<3>::new();
        let (mut lo, mut hi) = (usize::MAX, 0);
        for u in directions(50_000).chain([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]) {
            let k = check(&c3, u);
            (lo, hi) = (lo.min(k), hi.max(k));
        }
        let longest = (0..6 * BUCKETS_3D * BUCKETS_3D)
            .map(|b| c3.start[b + 1] - c3.start[b])
            .max()
            .unwrap_or(0);
        println!("3D: {lo}–{hi} candidates in a cone, cube-map lists up to {longest}");
        assert!(lo >= 15 && hi <= 23 && longest <= 40, "{lo} {hi} {longest}");
        let c2 = Candidates::<2>::new();
        for k in 0..3600 {
            let a = PI * k as f64 / 1800.0 + 1e-3;
            check(&c2, [a.cos(), a.sin()]);
        }
    }
}
