//! The dynamic J integral of a crack tip on a grid contour (Nairn &
//! Aimene, section 2.2: the contour term of eq. 9 on a square of grid
//! lines about the node nearest the tip, with virtual nodes where cracks
//! cross it), and K_I, K_II from it.
//!
//! The fields on the contour (W, K, σ, ∇u) are extrapolated from the
//! particles to each of its nodes here, at the row, with the step's shape
//! functions and mass weights ("standard MPM extrapolation"), separately
//! for the particles on each side of the cracks: a particle–node pair's
//! field is the set of cracks the line between them crosses (the
//! partition's test), so field 0 of a node is the particles on its own
//! side of every crack. The contour needs no grid of the step and runs
//! on the series cadence (and after every step of a growing crack).
//!
//! Contours met by a crack other than the target's are handled by the
//! paper's FIJC (`[cramp] j_method`, [`JMethod`]): the contour's edge
//! moved off another crack's tip (step 6), two virtual nodes where a crack
//! crosses an interval, each side taking the fields of the particles on
//! its side (PIJC's path), and the integrals along both faces of every
//! other crack inside the contour (step 5, [`faces_term`]).

use super::j_integral::{
    along, contour_term, decompose, interaction_term, Auxiliary, ContourPoint,
};
use super::section::{JMethod, KSplit};
use super::traction::traction_j;
use super::{crossing, Crack};
use crate::diagnostics::measure::strain_energy_density;
use crate::grid::shape::Kernel;
use crate::grid::{particle_support, GridGeom};
use crate::material::{Elastic, PlaneKind};
use crate::particles::Particles;
use rayon::prelude::*;

/// Which end of a crack's polyline: its first point or its last.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum End {
    Start,
    End,
}

impl End {
    pub const BOTH: [End; 2] = [End::Start, End::End];

    /// The series columns' name for it.
    pub fn name(self) -> &'static str {
        match self {
            End::Start => "start",
            End::End => "end",
        }
    }
}

/// J and the stress intensity factors of one crack tip.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TipJ {
    /// J_1, J_2 in the grid's axes (eq. 9's contour term), J/m².
    pub j12: [f64; 2],
    /// J along the crack's direction at the tip (eq. 10), J/m².
    pub j: f64,
    /// K_I and K_II, Pa·√m.
    pub k1: f64,
    pub k2: f64,
    /// The effective modulus E* of the material at the tip, Pa (what
    /// splits J into K_I, K_II, and turns a J_Ic into K_Ic).
    pub e_star: f64,
}

/// The particles' velocities and displacement gradients at the start of
/// a step whose end needs J (one that ends on a row; with growth, every
/// step), and that step's Δt: with the step's end, they
/// give each particle's acceleration (v − v₀)/Δt and velocity gradient
/// (∇u − ∇u₀)/Δt (exactly the L the step's update summed into ∇u), which
/// the volume term of eq. 9 needs.
#[derive(Debug, Clone, Default)]
pub struct BeforeRow {
    pub v: Vec<[f64; 2]>,
    pub grad_u: Vec<[[f64; 2]; 2]>,
    pub dt: f64,
    /// The 2D thickness, m (a particle's mass over it is its ρ dA).
    pub thickness: f64,
}

impl super::Cramp {
    /// Keeps what J's volume term at the end of this step needs
    /// ([`BeforeRow`]).
    pub fn keep_before_row<const V: usize>(&mut self, parts: &Particles<2, V>, dt: f64) {
        let mut b = self.before_row.take().unwrap_or_default();
        b.v.clone_from(&parts.v);
        b.grad_u.clone_from(&parts.grad_u);
        b.dt = dt;
        b.thickness = self.thickness;
        self.before_row = Some(b);
    }
}

/// How a tip's J is taken: the step's start for the volume term (none:
/// no volume term) and how other cracks at the contour are treated.
#[derive(Debug, Clone, Copy)]
pub struct JOptions<'a> {
    pub before: Option<&'a BeforeRow>,
    pub method: JMethod,
    /// How J is split into K_I and K_II.
    pub split: KSplit,
    /// Every crack's face pressure now, Pa (empty: none has one).
    pub pressure: &'a [f64],
}

/// What the integrals about one tip read: the grid, the particles and
/// their materials, the cracks, the target crack, the particles near the
/// tip (in particle order) and every crack's face pressure, Pa.
#[derive(Clone, Copy)]
struct Around<'a, const V: usize> {
    geom: &'a GridGeom<2>,
    parts: &'a Particles<2, V>,
    mats: &'a [Elastic],
    cracks: &'a [Crack],
    target: usize,
    near: &'a [u32],
    pressure: &'a [f64],
}

/// Why a tip has no J (the series shows NaN there).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoJ {
    /// No particle of the crack's body within a cell of the end: the end
    /// lies outside the material (an edge crack's mouth); or growth has
    /// joined the end to another crack.
    NotATip,
    /// The contour leaves the grid.
    OffGrid,
    /// The crack crosses the contour other than once.
    Crossings,
    /// Two cracks cross one interval of the contour (not handled yet).
    Crowded,
}

/// Sums of the mass-weighted particle fields at one node for one set of
/// crossed cracks: Σ S m, and Σ S m times W, K, σ (xx, yy, xy), ∇u.
#[derive(Debug, Clone, Copy, Default)]
struct Acc {
    cracks: u64,
    m: f64,
    w: f64,
    k: f64,
    s: [f64; 3],
    g: [[f64; 2]; 2],
}

impl Acc {
    /// Adds a particle's fields (`particle_fields`) with weight `w`.
    fn add(&mut self, w: f64, (mass, wk, s, g): ParticleFields) {
        let sm = w * mass;
        self.m += sm;
        self.w += sm * wk[0];
        self.k += sm * wk[1];
        for i in 0..3 {
            self.s[i] += sm * s[i];
        }
        for i in 0..2 {
            for j in 0..2 {
                self.g[i][j] += sm * g[i][j];
            }
        }
    }

    /// The extrapolated fields (zero where no particle reaches).
    fn value(&self) -> Fields {
        if !(self.m > 0.0) {
            return Fields::default();
        }
        let r = 1.0 / self.m;
        Fields {
            w: self.w * r,
            k: self.k * r,
            s: self.s.map(|v| v * r),
            g: self.g.map(|row| row.map(|v| v * r)),
        }
    }
}

/// W, K, σ and ∇u at a contour point.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Fields {
    w: f64,
    k: f64,
    s: [f64; 3],
    g: [[f64; 2]; 2],
}

impl Fields {
    /// (1 − f) a + f b.
    fn lerp(a: &Fields, b: &Fields, f: f64) -> Fields {
        let l = |x: f64, y: f64| (1.0 - f) * x + f * y;
        Fields {
            w: l(a.w, b.w),
            k: l(a.k, b.k),
            s: std::array::from_fn(|i| l(a.s[i], b.s[i])),
            g: std::array::from_fn(|i| std::array::from_fn(|j| l(a.g[i][j], b.g[i][j]))),
        }
    }

    fn at(&self, x: [f64; 2]) -> ContourPoint {
        ContourPoint {
            x,
            w: self.w,
            k: self.k,
            stress: self.s,
            grad_u: self.g,
        }
    }
}

/// The effective modulus E* of a material: E in plane stress, E/(1 − ν²)
/// in plane strain (the one J = (K_I² + K_II²)/E* takes).
pub fn e_star(mat: &Elastic) -> f64 {
    let nu = mat.poissons_ratio;
    let e = 2.0 * mat.mu * (1.0 + nu);
    match mat.plane {
        PlaneKind::PlaneStress => e,
        PlaneKind::PlaneStrain => e / (1.0 - nu * nu),
    }
}

/// The shear modulus μ and Kolosov's κ of a material (3 − 4ν in plane
/// strain, (3 − ν)/(1 + ν) in plane stress): what Williams' fields of the
/// interaction integral take.
pub fn mu_kappa(mat: &Elastic) -> (f64, f64) {
    let nu = mat.poissons_ratio;
    let kappa = match mat.plane {
        PlaneKind::PlaneStress => (3.0 - nu) / (1.0 + nu),
        PlaneKind::PlaneStrain => 3.0 - 4.0 * nu,
    };
    (mat.mu, kappa)
}

/// The tip at `end` of crack `c`: its position and the unit direction in
/// which it would grow (along its last segment, outward).
pub fn tip_of(crack: &Crack, end: End) -> ([f64; 2], [f64; 2]) {
    let n = crack.plane.len();
    let (a, b) = match end {
        End::Start => (crack.plane[1], crack.plane[0]),
        End::End => (crack.plane[n - 2], crack.plane[n - 1]),
    };
    let d = [b[0] - a[0], b[1] - a[1]];
    let l = (d[0] * d[0] + d[1] * d[1]).sqrt().max(f64::MIN_POSITIVE);
    (b, [d[0] / l, d[1] / l])
}

/// The crack-opening displacement near the tip in the crack's axes at the
/// tip (δ_n along the normal to the left of the growth direction, δ_t
/// along it; δ = upper face − lower face), m, from the crack points
/// between `from` and `to` back from the tip along the crack (one and
/// three cells): the mean δ_n, and δ_t as the least-squares ratio
/// Σδ_tδ_n/Σδ_n² times it (the ratio is what splits J: near a tip both
/// openings grow as √r with the same factor). The nearest cell is left
/// out because the tracked surfaces there take their velocities from
/// nodes that see both faces; on the inclined crack of
/// `cramp_inclined_crack.toml` the ratio at one cell was 41 % off tan β at
/// one tip (docs/cracks.md). With no point in the range, the opening at
/// the first point beyond it (or at the crack's far end).
pub fn tip_opening(crack: &Crack, end: End, (from, to): (f64, f64)) -> (f64, f64) {
    let n = crack.plane.len();
    let order: Vec<usize> = match end {
        End::End => (0..n).rev().collect(),
        End::Start => (0..n).collect(),
    };
    let (_, t) = tip_of(crack, end);
    let nrm = [-t[1], t[0]];
    // the upper face (left of the growth direction) is the crack's
    // "above" at its end and its "below" at its start
    let opening = |k: usize| {
        let (up, low) = match end {
            End::End => (crack.above[k], crack.below[k]),
            End::Start => (crack.below[k], crack.above[k]),
        };
        let d = [up[0] - low[0], up[1] - low[1]];
        (d[0] * nrm[0] + d[1] * nrm[1], d[0] * t[0] + d[1] * t[1])
    };
    let (mut sn, mut snn, mut stn, mut count) = (0.0, 0.0, 0.0, 0);
    let mut last = order[order.len() - 1];
    let mut run = 0.0;
    for w in order.windows(2) {
        let (p, q) = (crack.plane[w[0]], crack.plane[w[1]]);
        run += ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2)).sqrt();
        if run > to {
            if count == 0 {
                last = w[1];
            }
            break;
        }
        last = w[1];
        if run >= from {
            let (dn, dt) = opening(w[1]);
            sn += dn;
            snn += dn * dn;
            stn += dt * dn;
            count += 1;
        }
    }
    if count == 0 || !(snn > 0.0) {
        return opening(last);
    }
    let dn = sn / count as f64;
    (dn, stn / snn * dn)
}

/// The nodes of the square contour of `side` cells about node `centre`,
/// counter-clockwise from its lower-left corner (each once), or None where
/// it leaves the grid.
#[cfg(test)]
fn ring(geom: &GridGeom<2>, centre: [isize; 2], side: u32) -> Option<Vec<usize>> {
    let r = side as isize / 2;
    rect_ring(geom, Rect::square(centre, r))
}

/// A contour's rectangle of grid nodes, by their indices (inclusive).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Rect {
    lo: [isize; 2],
    hi: [isize; 2],
}

impl Rect {
    /// The square ±`r` cells about the node `centre`.
    fn square(centre: [isize; 2], r: isize) -> Rect {
        Rect {
            lo: [centre[0] - r, centre[1] - r],
            hi: [centre[0] + r, centre[1] + r],
        }
    }

    /// Whether the point `o` (grid index units) lies inside, or in a cell
    /// next to it (Nairn & Aimene's note 1 of step 6).
    fn near(&self, o: [f64; 2]) -> bool {
        (0..2).all(|a| o[a] > (self.lo[a] - 1) as f64 && o[a] < (self.hi[a] + 1) as f64)
    }

    /// Step 6 of §2.2.2: the rectangle with the one edge moved (the one
    /// that moves least) that leaves another crack's tip at `o` two cells
    /// outside while the target tip at `t` stays two cells inside ("for
    /// accuracy and whenever possible, keep the new edge at least 2 cells
    /// from each crack tip"), else one cell each; None where no edge can
    /// (both tips in one cell or nearly: note 2, the contour is kept and
    /// the other crack's faces integrated up to its tip).
    fn adapted(&self, t: [f64; 2], o: [f64; 2]) -> Option<Rect> {
        for margin in [2.0, 1.0] {
            let mut best: Option<(isize, Rect)> = None;
            for a in 0..2 {
                let mut r = *self;
                if o[a] > t[a] {
                    let edge = (o[a] - margin).floor() as isize;
                    if (edge as f64) < t[a] + margin {
                        continue;
                    }
                    r.hi[a] = edge.min(self.hi[a]);
                } else {
                    let edge = (o[a] + margin).ceil() as isize;
                    if (edge as f64) > t[a] - margin {
                        continue;
                    }
                    r.lo[a] = edge.max(self.lo[a]);
                }
                let moved = (self.hi[a] - r.hi[a]) + (r.lo[a] - self.lo[a]);
                if best.is_none_or(|(m, _)| moved < m) {
                    best = Some((moved, r));
                }
            }
            if let Some((_, r)) = best {
                return Some(r);
            }
        }
        None
    }
}

/// The nodes of a rectangle's boundary, counter-clockwise from its
/// lower-left corner; None if it leaves the grid.
fn rect_ring(geom: &GridGeom<2>, r: Rect) -> Option<Vec<usize>> {
    let ([i0, j0], [i1, j1]) = (r.lo, r.hi);
    if i0 < 0 || j0 < 0 || i1 >= geom.nodes[0] as isize || j1 >= geom.nodes[1] as isize {
        return None;
    }
    if i1 <= i0 || j1 <= j0 {
        return None;
    }
    let node = |i: isize, j: isize| geom.node([i as usize, j as usize]);
    let mut out = Vec::with_capacity(2 * ((i1 - i0) + (j1 - j0)) as usize);
    out.extend((i0..i1).map(|i| node(i, j0)));
    out.extend((j0..j1).map(|j| node(i1, j)));
    out.extend((i0 + 1..=i1).rev().map(|i| node(i, j1)));
    out.extend((j0 + 1..=j1).rev().map(|j| node(i0, j)));
    Some(out)
}

/// The cracks (bits) the line from `p` to `q` crosses.
fn crossed(cracks: &[Crack], p: [f64; 2], q: [f64; 2]) -> u64 {
    let mut bits = 0;
    for (c, crack) in cracks.iter().enumerate() {
        if crossing(&crack.plane, p, q).is_some() {
            bits |= 1 << c;
        }
    }
    bits
}

/// Where crack `crack` crosses the interval from `a` to `b`: the fraction
/// from `a`, if it does.
fn cut(crack: &Crack, a: [f64; 2], b: [f64; 2]) -> Option<f64> {
    let x = crossing(&crack.plane, a, b)?;
    let (k, t) = (x.seg as usize, x.t);
    let (p, q) = (crack.plane[k], crack.plane[k + 1]);
    let at = [p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])];
    let len2 = (b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2);
    let f = ((at[0] - a[0]) * (b[0] - a[0]) + (at[1] - a[1]) * (b[1] - a[1])) / len2;
    Some(f.clamp(0.0, 1.0))
}

/// J and K of crack `target`'s tip at `end` on the contours of `sides`
/// cells (one result per side, in order), the scene's kernel `K`: the
/// particles are looked at once (those within the largest contour's reach),
/// then each contour is extrapolated and integrated.
pub fn tip_j<K: Kernel, const V: usize>(
    geom: &GridGeom<2>,
    parts: &Particles<2, V>,
    mats: &[Elastic],
    cracks: &[Crack],
    how: JOptions<'_>,
    (target, end): (usize, End),
    sides: &[u32],
) -> Vec<Result<TipJ, NoJ>> {
    let crack = &cracks[target];
    if crack.is_joined(end) {
        return sides.iter().map(|_| Err(NoJ::NotATip)).collect();
    }
    let (tip, dir) = tip_of(crack, end);
    let xi = geom.xi(tip);
    let centre = [xi[0].round() as isize, xi[1].round() as isize];
    let h = geom.h;
    // the particles of the crack's body within reach of the largest
    // contour (a kernel support beyond its nodes), in particle order: J is
    // the crack's body's, and another body bonded to it (a loading grip,
    // typically far denser) would add its own kinetic energy and inertia
    // to the integrals where a contour reaches it
    let big = sides.iter().copied().max().unwrap_or(0) as f64 * 0.5 + 2.0;
    let lo = [
        geom.origin[0] + (centre[0] as f64 - big) * h,
        geom.origin[1] + (centre[1] as f64 - big) * h,
    ];
    let hi = [
        geom.origin[0] + (centre[0] as f64 + big) * h,
        geom.origin[1] + (centre[1] as f64 + big) * h,
    ];
    let near: Vec<u32> = (0..parts.len() as u32)
        .into_par_iter()
        .filter(|&p| {
            let x = parts.x[p as usize];
            parts.body[p as usize] == crack.body
                && x[0] >= lo[0]
                && x[0] <= hi[0]
                && x[1] >= lo[1]
                && x[1] <= hi[1]
        })
        .collect();
    // a tip has material of its crack's body within a cell
    let body = near.iter().find(|&&p| {
        let x = parts.x[p as usize];
        (x[0] - tip[0]).powi(2) + (x[1] - tip[1]).powi(2) <= h * h
    });
    let Some(&first) = body else {
        return sides.iter().map(|_| Err(NoJ::NotATip)).collect();
    };
    let mat = &mats[parts.material[first as usize] as usize];
    let e_star = e_star(mat);
    let cod = (how.split == KSplit::Cod).then(|| tip_opening(crack, end, (h, 3.0 * h)));
    // the other cracks' ends, grid index units (tips a contour must leave
    // out under adaptive FIJC; an edge crack's mouth too, harmlessly)
    let others: Vec<[f64; 2]> = cracks
        .iter()
        .enumerate()
        .filter(|&(c, _)| c != target)
        .flat_map(|(_, k)| [k.plane[0], k.plane[k.plane.len() - 1]])
        .map(|x| geom.xi(x))
        .collect();
    let around = Around {
        geom,
        parts,
        mats,
        cracks,
        target,
        near: &near,
        pressure: how.pressure,
    };
    sides
        .iter()
        .map(|&side| {
            let mut rect = Rect::square(centre, side as isize / 2);
            if how.method == JMethod::Fijc {
                for &o in &others {
                    if rect.near(o) {
                        rect = rect.adapted(xi, o).unwrap_or(rect);
                    }
                }
            }
            let nodes = rect_ring(geom, rect).ok_or(NoJ::OffGrid)?;
            let path = contour_path::<K, V>(&around, &nodes)?;
            let mut j12 = contour_term(&path);
            let square = ring_box(geom, &nodes);
            // the interaction integral on the same path, faces and
            // particles (the ratio that splits J), the path's first point
            // on the crack's faces
            let aux = (how.split == KSplit::Interaction)
                .then(|| Auxiliary::new(tip, dir, mu_kappa(mat), path[0].x));
            let mut m = aux.as_ref().map(|a| interaction_term(&path, a));
            if how.method != JMethod::Pijc {
                // J's and M's integrands in one walk along the faces
                let f = faces_term(&around, square, |x, f, out, t| {
                    let j: [f64; 2] = std::array::from_fn(|k| {
                        (f.w + f.k) * out[k] - (t[0] * f.g[0][k] + t[1] * f.g[1][k])
                    });
                    let m = aux
                        .as_ref()
                        .map_or([0.0; 2], |a| a.integrand(x, a.theta(x), (f.g, t), out));
                    [j[0], j[1], m[0], m[1]]
                });
                j12 = [j12[0] + f[0], j12[1] + f[1]];
                if let Some(m) = &mut m {
                    *m = [m[0] + f[2], m[1] + f[3]];
                }
            }
            if let Some(b) = how.before {
                let v = volume_term(parts, b, &near, square, |p| {
                    std::array::from_fn(|k| {
                        let mut t = 0.0;
                        for i in 0..2 {
                            t += p.a[i] * p.g[i][k] - p.v[i] * p.l[i][k];
                        }
                        t
                    })
                });
                j12 = [j12[0] + v[0], j12[1] + v[1]];
                if let (Some(a), Some(m)) = (&aux, &mut m) {
                    let v = volume_term(parts, b, &near, square, |p| a.inertia(p.x, p.a));
                    *m = [m[0] + v[0], m[1] + v[1]];
                }
            }
            // step 9: the target crack's own face pressure (eqs. 11–12),
            // along the crack; in M the unit mode I field's opening where
            // the crack leaves the contour (mode II opens none)
            let mut j = along(j12, dir[1].atan2(dir[0]));
            let p = how.pressure.get(target).copied().unwrap_or(0.0);
            if p != 0.0 {
                j += traction_j(cracks, (target, end), p, square);
                if let (Some(a), Some(m)) = (&aux, &mut m) {
                    m[0] += p * a.opening_i(length_inside(crack, end, square));
                }
            }
            let (ratio_n, ratio_t) = match (m, cod) {
                (Some(m), _) => (m[0], m[1]),
                (None, Some(c)) => c,
                (None, None) => (1.0, 0.0),
            };
            let (k1, k2) = decompose(j, e_star, ratio_n, ratio_t);
            Ok(TipJ {
                j12,
                j,
                k1,
                k2,
                e_star,
            })
        })
        .collect()
}

/// The path of eq. 9's contour term on the ring `nodes`
/// (counter-clockwise) about crack `target`'s tip, from the particles
/// `near`: the fields at its points, from a virtual node on the target
/// crack's lower face round to one on its upper face.
fn contour_path<K: Kernel, const V: usize>(
    at: &Around<'_, V>,
    nodes: &[usize],
) -> Result<Vec<ContourPoint>, NoJ> {
    let Around {
        geom,
        parts,
        mats,
        cracks,
        target,
        near,
        ..
    } = *at;
    let n = nodes.len();
    let pos: Vec<[f64; 2]> = nodes.iter().map(|&i| geom.node_position(i)).collect();
    // the cracks crossing each interval (ring k to k + 1) and where
    let mut cuts: Vec<Option<(usize, f64)>> = vec![None; n];
    let mut target_at = None;
    for k in 0..n {
        let (a, b) = (pos[k], pos[(k + 1) % n]);
        for (c, crack) in cracks.iter().enumerate() {
            if let Some(f) = cut(crack, a, b) {
                if cuts[k].is_some() {
                    return Err(NoJ::Crowded);
                }
                cuts[k] = Some((c, f));
                if c == target {
                    if target_at.is_some() {
                        return Err(NoJ::Crossings);
                    }
                    target_at = Some(k);
                }
            }
        }
    }
    let q = target_at.ok_or(NoJ::Crossings)?;
    // the fields each ring node needs: its own side's (no crack crossed),
    // and across the crack that cuts an interval beside it
    let mut accs: Vec<Vec<Acc>> = (0..n)
        .map(|k| {
            let mut v = vec![Acc::default()];
            for c in [cuts[k], cuts[(k + n - 1) % n]].into_iter().flatten() {
                v.push(Acc {
                    cracks: 1 << c.0,
                    ..Acc::default()
                });
            }
            v
        })
        .collect();
    let mut of_node: Vec<(usize, usize)> = nodes.iter().enumerate().map(|(k, &i)| (i, k)).collect();
    of_node.sort_unstable();
    for &p in near {
        let p = p as usize;
        let x = parts.x[p];
        let sup = particle_support::<K, 2, V>(geom, parts, p);
        let mut fields = None;
        sup.for_each(|sn| {
            if sn.w <= 0.0 {
                return;
            }
            let Ok(at) = of_node.binary_search_by_key(&sn.node, |e| e.0) else {
                return;
            };
            let k = of_node[at].1;
            let bits = crossed(cracks, x, pos[k]);
            let Some(acc) = accs[k].iter_mut().find(|a| a.cracks == bits) else {
                return;
            };
            acc.add(
                sn.w,
                *fields.get_or_insert_with(|| particle_fields(parts, mats, p)),
            );
        });
    }
    let field = |k: usize, bits: u64| {
        accs[k]
            .iter()
            .find(|a| a.cracks == bits)
            .map(Acc::value)
            .unwrap_or_default()
    };
    // the path: from the target's crossing on the far node's side, round
    // the ring, back to the crossing on the near node's side; the virtual
    // node on a node's side interpolates that node's own field and the
    // other end's field across the crack (Nairn & Aimene, section 2.2)
    let virtual_pair = |k: usize| {
        let (c, f) = cuts[k].expect("a cut interval");
        let (a, b) = (k, (k + 1) % n);
        let x = [
            pos[a][0] + f * (pos[b][0] - pos[a][0]),
            pos[a][1] + f * (pos[b][1] - pos[a][1]),
        ];
        let a_side = Fields::lerp(&field(a, 0), &field(b, 1 << c), f).at(x);
        let b_side = Fields::lerp(&field(a, 1 << c), &field(b, 0), f).at(x);
        (a_side, b_side)
    };
    let mut path = Vec::with_capacity(n + 8);
    let (end_point, start_point) = virtual_pair(q);
    path.push(start_point);
    for step in 1..=n {
        let k = (q + step) % n;
        path.push(field(k, 0).at(pos[k]));
        if step < n && cuts[k].is_some() {
            let (a_side, b_side) = virtual_pair(k);
            path.push(a_side);
            path.push(b_side);
        }
    }
    path.push(end_point);
    Ok(path)
}

/// A crack's segments from its tip at `end` outward, for a crack of `n`
/// points: each with whether the tip's side is its end `t = 1`.
pub(crate) fn segments_from_tip(n: usize, end: End) -> Vec<(usize, bool)> {
    match end {
        End::End => (0..n - 1).rev().map(|s| (s, true)).collect(),
        End::Start => (0..n - 1).map(|s| (s, false)).collect(),
    }
}

/// The length of crack `crack` from its tip at `end` to where it leaves
/// the box `(lo, hi)`, m (the whole crack if it does not).
fn length_inside(crack: &Crack, end: End, (lo, hi): ([f64; 2], [f64; 2])) -> f64 {
    let mut len = 0.0;
    for (s, tip_at_one) in segments_from_tip(crack.plane.len(), end) {
        let (a, b) = (crack.plane[s], crack.plane[s + 1]);
        let l = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        let Some((t0, t1)) = clip(a, b, lo, hi) else {
            break;
        };
        len += (t1 - t0) * l;
        if (tip_at_one && t0 > 0.0) || (!tip_at_one && t1 < 1.0) {
            break;
        }
    }
    len
}

/// Step 5 of §2.2.2 (FIJC): the first term of eq. 9 along both faces of
/// every crack but the target inside the contour's rectangle `(lo, hi)`.
/// The region the contour bounds has those faces as boundary too: with
/// the outward normal of the material there (−n̂ on the face above the
/// crack, n̂ below), each face adds ∫ ((W + K) n_k − T_i ∂u_i/∂x_k) ds,
/// the traction T = σ·n where the faces touch (the tracked surfaces
/// closed) and zero where the crack is open. Each segment is clipped to
/// the rectangle (the paper's φ fractions of its first and last segments,
/// and its corner case, come out of the clipping) and integrated by the
/// trapezoid rule on points at most half a cell apart, whatever the
/// spacing of the crack's points. The faces' fields at a point are the
/// mass- and quadratic-B-spline-weighted means of the particles on that
/// face's side within 1.5 cells (the paper extrapolates the face's
/// velocity field from the grid to the crack points; this takes the
/// particles directly, as the contour's nodes do). `integrand` gives a
/// face point's contribution from its position, its fields, the
/// material's outward normal and the traction on the material; J's is
/// (W + K) n_k − T_i ∂u_i/∂x_k, the interaction integral's its own.
fn faces_term<const V: usize, const N: usize>(
    at: &Around<'_, V>,
    (lo, hi): ([f64; 2], [f64; 2]),
    integrand: impl Fn([f64; 2], &Fields, [f64; 2], [f64; 2]) -> [f64; N],
) -> [f64; N] {
    let Around {
        geom,
        parts,
        mats,
        cracks,
        target,
        near,
        pressure,
    } = *at;
    let mut j = [0.0; N];
    for (c, crack) in cracks.iter().enumerate() {
        if c == target {
            continue;
        }
        let p = pressure.get(c).copied().unwrap_or(0.0);
        for k in 0..crack.plane.len() - 1 {
            let (a, b) = (crack.plane[k], crack.plane[k + 1]);
            let Some((t0, t1)) = clip(a, b, lo, hi) else {
                continue;
            };
            let nrm = crack.normal(k);
            let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
            let (open_a, open_b) = (crack.opening_at(k, nrm), crack.opening_at(k + 1, nrm));
            let along_face = |t: f64| {
                let x = [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
                let closed = (1.0 - t) * open_a + t * open_b <= 0.0;
                let mut v = [0.0; N];
                // above: the material's outward normal is −n̂; below, n̂
                for sign in [-1.0, 1.0] {
                    let out = [sign * nrm[0], sign * nrm[1]];
                    // the face's side, a hair off the plane
                    let eps = -1e-4 * geom.h * sign;
                    let at = [x[0] + eps * nrm[0], x[1] + eps * nrm[1]];
                    let f = face_fields(geom, parts, mats, cracks, near, at);
                    // open faces carry their pressure (step 5's case 3):
                    // the traction on the material is −P times its
                    // outward normal
                    let t = if closed {
                        [
                            f.s[0] * out[0] + f.s[2] * out[1],
                            f.s[2] * out[0] + f.s[1] * out[1],
                        ]
                    } else if p != 0.0 {
                        [-p * out[0], -p * out[1]]
                    } else {
                        [0.0; 2]
                    };
                    let c = integrand(at, &f, out, t);
                    for k in 0..N {
                        v[k] += c[k];
                    }
                }
                v
            };
            // the trapezoid rule on points at most half a cell apart, the
            // faces' fields taken there (however far apart the crack's
            // own points are)
            let m = (((t1 - t0) * len / (0.5 * geom.h)).ceil() as usize).max(1);
            let dt = (t1 - t0) / m as f64;
            let mut prev = along_face(t0);
            for q in 1..=m {
                let next = along_face(t0 + q as f64 * dt);
                for i in 0..N {
                    j[i] += 0.5 * (prev[i] + next[i]) * dt * len;
                }
                prev = next;
            }
        }
    }
    j
}

/// The part of the segment `a`–`b` inside the box `(lo, hi)`, as
/// parameters t0 < t1 along it (Liang–Barsky), if any.
pub(crate) fn clip(a: [f64; 2], b: [f64; 2], lo: [f64; 2], hi: [f64; 2]) -> Option<(f64, f64)> {
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for d in 0..2 {
        let dx = b[d] - a[d];
        if dx == 0.0 {
            if a[d] < lo[d] || a[d] > hi[d] {
                return None;
            }
            continue;
        }
        let (u, v) = ((lo[d] - a[d]) / dx, (hi[d] - a[d]) / dx);
        t0 = t0.max(u.min(v));
        t1 = t1.min(u.max(v));
    }
    (t1 > t0).then_some((t0, t1))
}

/// The fields at `x` from the particles of `near` whose line to it
/// crosses no crack, weighted by mass and a quadratic B-spline of their
/// distance in cells each way.
fn face_fields<const V: usize>(
    geom: &GridGeom<2>,
    parts: &Particles<2, V>,
    mats: &[Elastic],
    cracks: &[Crack],
    near: &[u32],
    x: [f64; 2],
) -> Fields {
    let b2 = |d: f64| {
        let d = d.abs();
        if d < 0.5 {
            0.75 - d * d
        } else if d < 1.5 {
            0.5 * (1.5 - d) * (1.5 - d)
        } else {
            0.0
        }
    };
    let mut acc = Acc::default();
    for &p in near {
        let p = p as usize;
        let xp = parts.x[p];
        let w = b2((xp[0] - x[0]) / geom.h) * b2((xp[1] - x[1]) / geom.h);
        if w <= 0.0 || crossed(cracks, xp, x) != 0 {
            continue;
        }
        acc.add(w, particle_fields(parts, mats, p));
    }
    acc.value()
}

/// The square a ring of nodes bounds: its lower-left and upper-right
/// corners, m.
fn ring_box(geom: &GridGeom<2>, nodes: &[usize]) -> ([f64; 2], [f64; 2]) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for &n in nodes {
        let x = geom.node_position(n);
        for d in 0..2 {
            lo[d] = lo[d].min(x[d]);
            hi[d] = hi[d].max(x[d]);
        }
    }
    (lo, hi)
}

/// A particle's position, acceleration, velocity, ∇u and velocity
/// gradient ∂u̇_i/∂x_k (row i) over the step before a row, what a volume
/// term integrates.
struct Motion {
    x: [f64; 2],
    a: [f64; 2],
    v: [f64; 2],
    g: [[f64; 2]; 2],
    l: [[f64; 2]; 2],
}

/// A volume term over the particles of `near` inside the contour's
/// square, per unit thickness like the contour term: Σ m_p/t f_p (ρ dA
/// being the particle's mass over the thickness t), f_p = `integrand` of
/// the particle's [`Motion`] over the step before the row
/// ([`BeforeRow`]). Eq. 9's is ü_i ∂u_i/∂x_k − u̇_i ∂u̇_i/∂x_k.
fn volume_term<const V: usize>(
    parts: &Particles<2, V>,
    before: &BeforeRow,
    near: &[u32],
    (lo, hi): ([f64; 2], [f64; 2]),
    integrand: impl Fn(&Motion) -> [f64; 2],
) -> [f64; 2] {
    let mut j = [0.0; 2];
    if !(before.dt > 0.0 && before.thickness > 0.0)
        || before.v.len() != parts.len()
        || parts.grad_u.len() != parts.len()
    {
        return j;
    }
    let inv = 1.0 / before.dt;
    let per_area = 1.0 / before.thickness;
    for &p in near {
        let p = p as usize;
        let x = parts.x[p];
        if !(x[0] > lo[0] && x[0] < hi[0] && x[1] > lo[1] && x[1] < hi[1]) {
            continue;
        }
        let (v, g, m) = (parts.v[p], parts.grad_u[p], parts.mass[p]);
        let a = [0, 1].map(|i| (v[i] - before.v[p][i]) * inv);
        let l = std::array::from_fn(|i| {
            std::array::from_fn(|k| (g[i][k] - before.grad_u[p][i][k]) * inv)
        });
        let t = integrand(&Motion { x, a, v, g, l });
        for k in 0..2 {
            j[k] += m * per_area * t[k];
        }
    }
    j
}

/// Particle `p`'s mass, its strain and kinetic energy densities per
/// current volume, W and K (J/m³), its stress and its ∇u.
/// A particle's mass, W and K, σ (xx, yy, xy) and ∇u.
type ParticleFields = (f64, [f64; 2], [f64; 3], [[f64; 2]; 2]);

fn particle_fields<const V: usize>(
    parts: &Particles<2, V>,
    mats: &[Elastic],
    p: usize,
) -> ParticleFields {
    let (psi, v_ref) = strain_energy_density(mats, parts, p);
    let vol = parts.vol[p];
    let m = parts.mass[p];
    let v = parts.v[p];
    let w = psi * v_ref / vol;
    let k = 0.5 * m / vol * (v[0] * v[0] + v[1] * v[1]);
    let s = parts.stress[p];
    let g = parts.grad_u.get(p).copied().unwrap_or_default();
    (m, [w, k], [s[0], s[1], s[V - 1]], g)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fracture::cracks::j_integral::tests::point;
    use crate::grid::shape::QuadraticBspline;
    use crate::material::{ElasticConstants, MaterialModel};

    /// Particles (two per cell each way) carrying Williams' near-tip field
    /// of a crack along −x with its tip at `tip` (between the grid's
    /// nodes and particle rows), and the crack as a polyline: the grid
    /// contour's J of both modes equals (K_I² + K_II²)/E* within 2 % on
    /// 4-, 8- and 12-cell contours, and K_I, K_II come back within 2 %.
    /// This checks the extrapolation to the ring's nodes, the fields taken
    /// by side of the crack, the virtual nodes and the path's direction.
    #[test]
    fn the_grid_contour_gives_j_and_k_of_the_near_tip_field() {
        let (e, nu, rho, h) = (1.0e9, 0.3, 1000.0, 1.0e-3);
        let mu = e / (2.0 * (1.0 + nu));
        let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        let consts = ElasticConstants {
            model: MaterialModel::LinearElastic,
            density: rho,
            youngs_modulus: e,
            poissons_ratio: nu,
            lambda,
            mu,
            wave_speed: ((lambda + 2.0 * mu) / rho).sqrt(),
        };
        let mats = [Elastic::new(&consts, PlaneKind::PlaneStrain)];
        let e_s = e_star(&mats[0]);
        assert!((e_s - e / (1.0 - nu * nu)).abs() < 1e-6 * e);
        let geom = GridGeom::new([0.0, 0.0], h, [40, 40]);
        let tip = [0.0201, 0.0201];
        for (k1, k2) in [(1.0e6, 0.0), (0.8e6, 0.4e6), (0.6e6, -0.5e6)] {
            let mut parts = Particles::<2, 3>::default();
            let vol = (0.5 * h) * (0.5 * h);
            for j in 0..80 {
                for i in 0..80 {
                    let x = [(i as f64 + 0.5) * 0.5 * h, (j as f64 + 0.5) * 0.5 * h];
                    let r = [x[0] - tip[0], x[1] - tip[1]];
                    let cp = point(k1, k2, e, nu, r);
                    let g = cp.grad_u;
                    parts.x.push(x);
                    parts.v.push([0.0; 2]);
                    parts.body.push(0);
                    parts.material.push(0);
                    parts.mass.push(rho * vol);
                    parts.vol.push(vol);
                    parts.vol0.push(vol);
                    parts.stress.push(cp.stress);
                    parts
                        .strain
                        .push([g[0][0], g[1][1], 0.5 * (g[0][1] + g[1][0])]);
                    parts.grad_u.push(g);
                }
            }
            // the crack from 2 mm outside the particles to the tip, its
            // points about every half cell, its surfaces where the field
            // puts them
            let (n, x0) = (45, -0.002);
            let pts: Vec<[f64; 2]> = (0..n)
                .map(|k| [x0 + (tip[0] - x0) * k as f64 / (n - 1) as f64, tip[1]])
                .collect();
            let mut crack = Crack::new(0, 0.0, pts);
            let disp = |x: [f64; 2], dy: f64| {
                let (_, u) = crate::fracture::cracks::j_integral::tests::williams(
                    k1,
                    k2,
                    e,
                    nu,
                    [x[0] - tip[0], dy],
                );
                [x[0] + u[0], x[1] + u[1]]
            };
            for k in 0..n - 1 {
                crack.above[k] = disp(crack.plane[k], 1e-12);
                crack.below[k] = disp(crack.plane[k], -1e-12);
            }
            let cracks = [crack];
            let j_at = |end: End, split: KSplit, sides: &[u32]| {
                let how = JOptions {
                    before: None,
                    method: JMethod::Fijc,
                    split,
                    pressure: &[],
                };
                tip_j::<QuadraticBspline, 3>(&geom, &parts, &mats, &cracks, how, (0, end), sides)
            };
            for split in [KSplit::Interaction, KSplit::Cod] {
                let js = j_at(End::End, split, &[4, 8, 12]);
                let want = (k1 * k1 + k2 * k2) / e_s;
                for (side, r) in [4, 8, 12].iter().zip(&js) {
                    let t = r.expect("a J");
                    assert!(
                        (t.j / want - 1.0).abs() < 0.02,
                        "K {k1:e} {k2:e}, {side} cells: J {} against {want}",
                        t.j
                    );
                    assert!(
                        (t.k1 / k1 - 1.0).abs() < 0.02,
                        "{side}: K_I {} against {k1}",
                        t.k1
                    );
                    assert!(
                        (t.k2 - k2).abs() < 0.02 * k1.abs().max(k2.abs()),
                        "{split:?}, {side}: K_II {} against {k2}",
                        t.k2
                    );
                }
            }
            // the crack's mouth, outside the material, is no tip
            let start = j_at(End::Start, KSplit::Interaction, &[4]);
            assert_eq!(start[0], Err(NoJ::NotATip));
        }
    }

    #[test]
    fn a_contour_moves_the_edge_that_leaves_out_the_other_tip() {
        let square = Rect::square([0, 0], 6);
        let t = [0.3, 0.2];
        // ahead on the right: the right edge two cells short of it
        let r = square.adapted(t, [6.0, 0.1]).expect("adapted");
        assert_eq!((r.lo, r.hi), ([-6, -6], [4, 6]));
        assert!(!r.near([6.0, 0.1]));
        // below and a little left, too near for two cells each side: the
        // bottom edge a cell and a half above it, 2.2 cells below the tip
        let r = square.adapted(t, [-0.5, -3.5]).expect("adapted");
        assert_eq!((r.lo, r.hi), ([-6, -2], [6, 6]));
        // 3.1 cells ahead: a cell each side
        let r = square.adapted(t, [3.4, 0.0]).expect("adapted");
        assert_eq!(r.hi[0], 2);
        // 1.5 cells off, or in the tip's own cell: no contour leaves it out
        // (note 2)
        assert_eq!(square.adapted(t, [1.8, 0.0]), None);
        assert_eq!(square.adapted(t, [0.9, 0.0]), None);
    }

    #[test]
    fn a_ring_runs_counter_clockwise_round_its_centre() {
        let geom = GridGeom::new([0.0, 0.0], 1.0, [10, 10]);
        let r = ring(&geom, [5, 5], 4).expect("inside");
        assert_eq!(r.len(), 16);
        let pos: Vec<[f64; 2]> = r.iter().map(|&n| geom.node_position(n)).collect();
        // the signed area of the polygon: positive counter-clockwise, the
        // square's 16
        let area: f64 = (0..16)
            .map(|k| {
                let (a, b) = (pos[k], pos[(k + 1) % 16]);
                0.5 * (a[0] * b[1] - b[0] * a[1])
            })
            .sum();
        assert!((area - 16.0).abs() < 1e-9, "{area}");
        for k in 0..16 {
            let (a, b) = (pos[k], pos[(k + 1) % 16]);
            assert!(((a[0] - b[0]).abs() + (a[1] - b[1]).abs() - 1.0).abs() < 1e-12);
        }
        assert!(ring(&geom, [1, 5], 4).is_none());
    }

    #[test]
    fn the_opening_is_read_in_the_tips_own_axes() {
        // a crack along +x, opened by 2 (above up 1, below down 1) and slid
        // by 0.5 (above +x)
        let mut c = Crack::new(0, 0.0, vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [3.0, 0.0]]);
        for k in 0..4 {
            c.above[k] = [c.plane[k][0] + 0.25, 1.0];
            c.below[k] = [c.plane[k][0] - 0.25, -1.0];
        }
        // at the end, growth along +x, the upper face is "above"
        let (n, t) = tip_opening(&c, End::End, (1.0, 2.0));
        assert!(
            (n - 2.0).abs() < 1e-12 && (t - 0.5).abs() < 1e-12,
            "{n} {t}"
        );
        // at the start, growth along −x: the upper face (left of −x) is
        // "below"; the opening is the same, the sliding's sign as seen
        // from that tip too (upper face moved along −x by 0.25)
        let (n, t) = tip_opening(&c, End::Start, (1.0, 2.0));
        assert!(
            (n - 2.0).abs() < 1e-12 && (t - 0.5).abs() < 1e-12,
            "{n} {t}"
        );
    }
}
