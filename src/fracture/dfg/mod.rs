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
//! Departures from the paper, both for self-contact (section 2.4) and only
//! in scenes with it (without self-contact Algorithms 1 and 2 run as
//! written: the paper's rules give the better crack dissipation, +7.4 %
//! against +10 % on the notched bar of `tests/dfg.rs`), where
//! d = max(s, D) is 1 in the surface bands of two faces that touch, D̄ is
//! flat between them and their particles have no gradient: Algorithm 1's
//! largest gradient follows a body's own free face where it meets another
//! surface, and the sign test of Algorithm 2 is a tie for particles whose
//! gradient is perpendicular to the node's or zero. Taken literally, a block
//! standing on a plane in one contact group shares a field with the plane
//! at its corner nodes, and is welded there (it slid 0.01 mm where two
//! contact groups slide 17.1 mm; with the changes the two agree to 0.01 %,
//! `tests/dfg.rs`). At a straight crack the direction is still its normal;
//! the band's own particles (no gradient) split at the band's centre
//! instead of all going to side 0.
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
    particle_support, scatter_coloured, Bins, FieldSlots, GridGeom, MultiField, SyncPtr, TILE,
};
use crate::particles::Particles;
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
#[inline(always)]
fn side(gp: [f64; 2], op: [f64; 2], ni: [f64; 2], xp: [f64; 2], cut: f64) -> u32 {
    let clear = |g: [f64; 2]| {
        let dot = g[0] * ni[0] + g[1] * ni[1];
        (dot * dot > SIDE_COS * SIDE_COS * (g[0] * g[0] + g[1] * g[1])).then_some(dot < 0.0)
    };
    let behind = clear(gp)
        .or_else(|| clear(op))
        .unwrap_or_else(|| ni[0] * xp[0] + ni[1] * xp[1] > cut);
    u32::from(behind)
}

/// The side of a particle at a node: without self-contact (`paper`) the
/// sign test of Algorithm 2 as written, ∇D̄_p·∇D̄_i < 0 → side 1 (ties,
/// such as the gradient-free particles inside a failed band, go to side
/// 0); with it, [`side`].
#[inline(always)]
fn side_at(paper: bool, gp: [f64; 2], op: [f64; 2], ni: [f64; 2], xp: [f64; 2], cut: f64) -> u32 {
    if paper {
        u32::from(gp[0] * ni[0] + gp[1] * ni[1] < 0.0)
    } else {
        side(gp, op, ni, xp, cut)
    }
}

/// Candidate directions of the balanced nodal direction
/// ([`Dfg::balance`]), spaced 180°/NDIR.
const NDIR: usize = 16;

/// A particle counts for a side of candidate n_k in [`Dfg::balance`] only
/// if its direction lies within this cosine (26°) of ±n_k: two faces
/// meeting at a body's corner are perpendicular, not opposing.
const CONE_COS: f64 = 0.9;

/// A node's balanced direction is used only where its weaker side holds at
/// least this fraction of the node's Σ N_ip m_p over the particles with a
/// direction.
const BALANCE_MIN: f64 = 0.01;

/// Candidates within [`CONE_COS`] of a direction: at most five.
const CONE_K: usize = 5;
/// An empty entry of a particle's balance shares.
const NONE_SLOT: u8 = u8::MAX;

/// Runs `f(p, node, N_ip m_p)` for every (particle, node) pair of the
/// particles in `hot` tiles for which `take(p)`, coloured like P2G (see
/// [`scatter_coloured`]: `f` may add into `node` through a [`SyncPtr`]).
fn scatter_hot<K: Kernel>(
    geom: &GridGeom,
    parts: &Particles,
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
                    particle_support::<K, 2, 3>(geom, parts, p)
                        .for_each(|n| f(p, n.node, n.w * parts.mass[p]));
                }
            });
    }
}

/// The kernel of eq. 18 and its derivative factor: ω(r̄) and
/// (dω/dr̄)/(r̄ R²), so that ∇_x ω = factor · (x − x_q).
#[inline(always)]
fn kernel(rbar: f64, radius: f64) -> (f64, f64) {
    (
        1.0 - 3.0 * rbar * rbar + 2.0 * rbar * rbar * rbar,
        6.0 * (rbar - 1.0) / (radius * radius),
    )
}

/// Neighbour lists by cell binning (section 2.5).
#[derive(Debug, Clone, Default)]
pub struct Neighbours {
    /// `list[start[p]..start[p+1]]` are the particles within the build
    /// reach of p (p included), in bin order.
    start: Vec<u32>,
    list: Vec<u32>,
    /// Positions at the last build.
    x_built: Vec<[f64; 2]>,
    /// Lists built so far.
    pub builds: u64,
}

impl Neighbours {
    /// The key of particles that take no part.
    pub const NONE: u16 = u16::MAX;

    pub fn of(&self, p: usize) -> &[u32] {
        &self.list[self.start[p] as usize..self.start[p + 1] as usize]
    }

    /// Builds the lists: pairs closer than `reach` with the same `key`.
    /// Particles keyed [`Neighbours::NONE`] get no list and are in none.
    pub fn build(&mut self, x: &[[f64; 2]], key: &[u16], reach: f64, min: [f64; 2], max: [f64; 2]) {
        let n = x.len();
        let nb = [
            ((max[0] - min[0]) / reach).ceil() as usize + 1,
            ((max[1] - min[1]) / reach).ceil() as usize + 1,
        ];
        // counting sort by bin (stable: ascending index inside a bin)
        let mut bin_start = vec![0u32; nb[0] * nb[1] + 1];
        let bin_of: Vec<u32> = x
            .iter()
            .map(|&p| {
                let (cx, cy) = bin_cell(p, min, reach, nb);
                (cx + cy * nb[0]) as u32
            })
            .collect();
        for &b in &bin_of {
            bin_start[b as usize + 1] += 1;
        }
        for b in 0..nb[0] * nb[1] {
            bin_start[b + 1] += bin_start[b];
        }
        let mut order = vec![0u32; n];
        let mut cursor = bin_start.clone();
        for (p, &b) in bin_of.iter().enumerate() {
            order[cursor[b as usize] as usize] = p as u32;
            cursor[b as usize] += 1;
        }
        let grid = BinGrid {
            x,
            key,
            order: &order,
            bin_start: &bin_start,
            nb,
            min,
            reach,
        };
        let counts: Vec<u32> = (0..n)
            .into_par_iter()
            .map(|p| {
                let mut k = 0u32;
                grid.visit(p, |_| k += 1);
                k
            })
            .collect();
        self.start.clear();
        self.start.reserve(n + 1);
        let mut total = 0u32;
        self.start.push(0);
        for &k in &counts {
            total += k;
            self.start.push(total);
        }
        self.list.resize(total as usize, 0);
        let list = SyncPtr::new(&mut self.list);
        let start = &self.start;
        (0..n).into_par_iter().for_each(|p| {
            let mut at = start[p] as usize;
            grid.visit(p, |q| {
                // SAFETY: p writes only its own range start[p]..start[p+1].
                unsafe { *list.at(at) = q };
                at += 1;
            });
        });
        self.x_built.clear();
        self.x_built.extend_from_slice(x);
        self.builds += 1;
    }

    /// Whether some particle with a list moved more than `limit` since
    /// the last build.
    pub fn stale(&self, x: &[[f64; 2]], limit: f64) -> bool {
        if self.x_built.len() != x.len() {
            return true;
        }
        let l2 = limit * limit;
        x.par_iter()
            .zip(&self.x_built)
            .enumerate()
            .any(|(p, (a, b))| {
                let d = [a[0] - b[0], a[1] - b[1]];
                self.start[p + 1] > self.start[p] && d[0] * d[0] + d[1] * d[1] > l2
            })
    }
}

/// The bin of a point (clamped into the bin grid).
#[inline(always)]
fn bin_cell(p: [f64; 2], min: [f64; 2], reach: f64, nb: [usize; 2]) -> (usize, usize) {
    let cx = (((p[0] - min[0]) / reach).max(0.0) as usize).min(nb[0] - 1);
    let cy = (((p[1] - min[1]) / reach).max(0.0) as usize).min(nb[1] - 1);
    (cx, cy)
}

/// Particles sorted into square bins of the search reach.
struct BinGrid<'a> {
    x: &'a [[f64; 2]],
    key: &'a [u16],
    order: &'a [u32],
    bin_start: &'a [u32],
    nb: [usize; 2],
    min: [f64; 2],
    reach: f64,
}

impl BinGrid<'_> {
    /// Calls `f(q)` for every q closer than the reach to p with p's key, in
    /// bin order.
    #[inline(always)]
    fn visit(&self, p: usize, mut f: impl FnMut(u32)) {
        if self.key[p] == Neighbours::NONE {
            return;
        }
        let (x, r2) = (self.x, self.reach * self.reach);
        let (cx, cy) = bin_cell(x[p], self.min, self.reach, self.nb);
        for by in cy.saturating_sub(1)..(cy + 2).min(self.nb[1]) {
            for bx in cx.saturating_sub(1)..(cx + 2).min(self.nb[0]) {
                let b = bx + by * self.nb[0];
                for &q in &self.order[self.bin_start[b] as usize..self.bin_start[b + 1] as usize] {
                    let d = [x[q as usize][0] - x[p][0], x[q as usize][1] - x[p][1]];
                    if self.key[q as usize] == self.key[p] && d[0] * d[0] + d[1] * d[1] < r2 {
                        f(q);
                    }
                }
            }
        }
    }
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
/// gradients of the current step.
#[derive(Debug, Clone)]
pub struct Dfg {
    params: DfgParams,
    neighbours: Neighbours,
    /// Self-contact surface flags s_p (empty without self-contact).
    surface: Vec<f64>,
    /// Outward unit normals of the surface particles in the reference
    /// configuration, from the gradient of their body's kernel sum (zero
    /// inside; empty without self-contact).
    normal0: Vec<[f64; 2]>,
    /// `normal0` rotated by cof F at this step's partition, where the
    /// material tracks F (empty otherwise; see [`Dfg::normals`]).
    normal: Vec<[f64; 2]>,
    /// d_p = max(s_p, D_p) of this step.
    d: Vec<f64>,
    /// Neighbour-list key: the contact group of particles that can carry
    /// damage or a surface flag, [`Neighbours::NONE`] for the rest (an
    /// elastic striker needs no damage field).
    key: Vec<u16>,
    /// ∇D̄ at the particles (zero away from damage).
    pub grad: Vec<[f64; 2]>,
    /// The nodal direction: Algorithm 1's, turned towards opposing
    /// surfaces where there are some ([`Dfg::balance`]).
    pub node_grad: Vec<[f64; 2]>,
    /// Per node: for each candidate direction n_k the two sides' sums of
    /// [`Dfg::balance`], then Σ N_ip m_p; reused by its second pass.
    dirs: Vec<[f64; 2 * NDIR + 1]>,
    /// Per particle, its (slot, weight) entries of `dirs` (the balance).
    shares: Vec<[(u8, f64); CONE_K]>,
    /// Where the surface lies at each node, along its unit direction
    /// (n_i·x, m; see [`Dfg::balance`]).
    pub cut: Vec<f64>,
    /// Particle positions at this step's partition: the side rule
    /// ([`side`]) must give the same field in P2G and G2P, and G2P moves
    /// the particles.
    pub x_partition: Vec<[f64; 2]>,
    sums: Vec<SideSums>,
    /// Node ranges written in the last step (zeroed before the next).
    written: Vec<Range<usize>>,
    /// Tiles with damage nearby (their particles get a gradient).
    hot: Vec<bool>,
    separated: u64,
    surface_count: u64,
}

impl Dfg {
    /// Sets up the partitioning; with `self_contact`, flags as surface
    /// particles those whose kernel sum over their own body is below
    /// `threshold` times the body's largest (section 2.4).
    /// `takes_part[m]` says whether particles of material m can be damaged
    /// (all particles take part with self-contact).
    pub fn new(
        params: DfgParams,
        geom: &GridGeom,
        parts: &Particles,
        self_contact: Option<f64>,
        takes_part: &[bool],
    ) -> Dfg {
        let n = parts.len();
        let key = (0..n)
            .map(|p| {
                if self_contact.is_some() || takes_part[parts.material[p] as usize] {
                    parts.group[p] as u16
                } else {
                    Neighbours::NONE
                }
            })
            .collect();
        let mut surface = Vec::new();
        let mut normal0 = Vec::new();
        let mut surface_count = 0;
        if let Some(threshold) = self_contact {
            let mut nb = Neighbours::default();
            nb.build(
                &parts.x,
                &parts.body,
                params.radius,
                geom.domain_min,
                geom.domain_max,
            );
            // kernel sum and its gradient (which points into the body)
            let (sum, sgrad): (Vec<f64>, Vec<[f64; 2]>) = (0..n)
                .into_par_iter()
                .map(|p| {
                    let (mut s, mut g) = (0.0, [0.0; 2]);
                    for &q in nb.of(p) {
                        let d = [
                            parts.x[p][0] - parts.x[q as usize][0],
                            parts.x[p][1] - parts.x[q as usize][1],
                        ];
                        let rbar = (d[0] * d[0] + d[1] * d[1]).sqrt() / params.radius;
                        if rbar < 1.0 {
                            let (w, f) = kernel(rbar, params.radius);
                            s += w;
                            g = [g[0] + f * d[0], g[1] + f * d[1]];
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
                    Some(u) if surface[p] > 0.0 => [-u[0], -u[1]],
                    _ => [0.0; 2],
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
            grad: vec![[0.0; 2]; n],
            node_grad: vec![[0.0; 2]; geom.node_count()],
            dirs: vec![[0.0; 2 * NDIR + 1]; geom.node_count()],
            shares: Vec::new(),
            cut: vec![0.0; geom.node_count()],
            x_partition: Vec::with_capacity(n),
            sums: vec![SideSums::default(); geom.node_count()],
            written: Vec::new(),
            hot: Vec::new(),
            separated: 0,
            surface_count,
        }
    }

    /// What a checkpoint keeps of the neighbour lists: the positions they
    /// were built at (empty before the first build) and the builds so far.
    pub fn neighbour_state(&self) -> (Vec<[f64; 2]>, u64) {
        (self.neighbours.x_built.clone(), self.neighbours.builds)
    }

    /// The neighbour lists of a checkpoint ([`Dfg::neighbour_state`]):
    /// built again at the same positions, so that they and the rebuild
    /// rule are as the run left them.
    pub fn restore_neighbours(
        &mut self,
        geom: &GridGeom,
        parts: &Particles,
        x_built: &[[f64; 2]],
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
    fn build_neighbours(&mut self, geom: &GridGeom, parts: &Particles, x: &[[f64; 2]]) {
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
    pub fn field<K: Kernel>(&mut self, geom: &GridGeom, parts: &Particles, bins: &Bins) {
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
        // Tiles with a failed particle (d = 1) in them or next to them. Only
        // a node that a failed particle maps to can separate (section 2.3);
        // the particles that share such a node are within 3 cells of it,
        // the kernel reaches r < 2 cells further, both inside the next tile
        // (8 cells). Elsewhere the sides merge whatever the gradients say,
        // so they are left zero.
        let ntiles = geom.tiles[0] * geom.tiles[1];
        let mut any = vec![false; ntiles];
        for (t, a) in any.iter_mut().enumerate() {
            *a = bins
                .particles_of(t as u32)
                .iter()
                .any(|&p| self.d[p as usize] >= FAILED);
        }
        self.hot.clear();
        self.hot.resize(ntiles, false);
        let [ntx, nty] = geom.tiles;
        for (t, _) in any.iter().enumerate().filter(|a| *a.1) {
            {
                let (tx, ty) = (t % ntx, t / ntx);
                for y in ty.saturating_sub(1)..(ty + 2).min(nty) {
                    for x in tx.saturating_sub(1)..(tx + 2).min(ntx) {
                        self.hot[x + y * ntx] = true;
                    }
                }
            }
        }
        debug_assert!(r < TILE as f64 * geom.h);
        let (x, d, nb, hot, tile_of, key) = (
            &parts.x,
            &self.d,
            &self.neighbours,
            &self.hot,
            &bins.tile_of,
            &self.key,
        );
        self.grad[..n]
            .par_iter_mut()
            .enumerate()
            .for_each(|(p, g)| {
                *g = [0.0; 2];
                if !hot[tile_of[p] as usize] || key[p] == Neighbours::NONE {
                    return;
                }
                let list = nb.of(p);
                // A flat field has no gradient (the sums below give exactly
                // zero): most particles of a hot tile stop here.
                if list.iter().all(|&q| d[q as usize] == d[p]) {
                    return;
                }
                let (mut s, mut ds, mut gs, mut gds) = (0.0, 0.0, [0.0; 2], [0.0; 2]);
                for &q in list {
                    let q = q as usize;
                    let dx = [x[p][0] - x[q][0], x[p][1] - x[q][1]];
                    let r2 = dx[0] * dx[0] + dx[1] * dx[1];
                    if r2 >= r * r {
                        continue;
                    }
                    let (w, f) = kernel(r2.sqrt() / r, r);
                    s += w;
                    ds += d[q] * w;
                    gs[0] += f * dx[0];
                    gs[1] += f * dx[1];
                    gds[0] += d[q] * f * dx[0];
                    gds[1] += d[q] * f * dx[1];
                }
                if s > 0.0 {
                    let dbar = ds / s;
                    *g = [(gds[0] - dbar * gs[0]) / s, (gds[1] - dbar * gs[1]) / s];
                }
            });
        // Algorithm 1, coloured like P2G (deterministic: within a colour the
        // tiles' node sets are disjoint; ties keep the first particle).
        for r in &self.written {
            self.node_grad[r.clone()].fill([0.0; 2]);
            self.cut[r.clone()].fill(0.0);
            self.sums[r.clone()].fill(SideSums::default());
        }
        self.written.clone_from(&bins.active);
        let ng = SyncPtr::new(&mut self.node_grad);
        let grad = &self.grad;
        scatter_hot::<K>(
            geom,
            parts,
            bins,
            &self.hot,
            |p| grad[p] != [0.0; 2],
            |p, node, _| {
                let g = grad[p];
                // SAFETY: coloured scatter (see `scatter_coloured`).
                let gi = unsafe { ng.at(node) };
                if g[0] * g[0] + g[1] * g[1] > gi[0] * gi[0] + gi[1] * gi[1] {
                    *gi = g;
                }
            },
        );
        if !self.normal0.is_empty() && !parts.def_grad.is_empty() {
            // n ∝ F⁻ᵀ N = cof(F) N / det F
            self.normal.clear();
            self.normal
                .extend(self.normal0.iter().zip(&parts.def_grad).map(|(n, f)| {
                    [
                        f[1][1] * n[0] - f[1][0] * n[1],
                        -f[0][1] * n[0] + f[0][0] * n[1],
                    ]
                }));
        }
        // Without self-contact the paper's Algorithm 1 stands as it is: the
        // balance is for surfaces that touch (see the module docs).
        if !self.normal0.is_empty() {
            self.balance::<K>(geom, parts, bins);
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
    /// (∇D̄_p, or its outward normal where D̄ is flat), and among NDIR
    /// candidates n_k we take the one that maximizes the weaker side,
    /// min(Σ N m (n_k·u_p)² over u_p within [`CONE_COS`] of +n_k, the same
    /// for −n_k). At a straight crack that is the crack normal (as with
    /// Algorithm 1); at a lone free face no direction has an opposing side
    /// and Algorithm 1's gradient stays. The candidates are 11.25° apart,
    /// well inside the [`side`] test's tolerance; the contact normals come
    /// from the mass gradients, not from this direction. A second pass puts
    /// the surface (`cut`, along n_i) at the centroid of d_p = max(s_p,
    /// D_p) — the damaged band, or the surface bands of two faces in
    /// contact, whose inner particles have no gradient and are placed by
    /// it; elsewhere it is the node. Leaves `node_grad` unit or zero.
    fn balance<K: Kernel>(&mut self, geom: &GridGeom, parts: &Particles, bins: &Bins) {
        let cand: [[f64; 2]; NDIR] = std::array::from_fn(|k| {
            let a = std::f64::consts::PI * k as f64 / NDIR as f64;
            [a.cos(), a.sin()]
        });
        // Each particle's share, (slot, (n_k·u_p)²) for the candidates
        // within the cone of ±u_p: those within two of the nearest one
        // (2 · 11.25° < acos 0.9 = 25.8° < 3 · 11.25°), the same for the
        // particle's nine nodes.
        let normal: &[[f64; 2]] = if self.normal.is_empty() {
            &self.normal0
        } else {
            &self.normal
        };
        let (grad, hot, tile_of) = (&self.grad, &self.hot, &bins.tile_of);
        self.shares.resize(parts.len(), [(0, 0.0); CONE_K]);
        self.shares
            .par_iter_mut()
            .enumerate()
            .for_each(|(p, share)| {
                *share = [(NONE_SLOT, 0.0); CONE_K];
                if !hot[tile_of[p] as usize] {
                    return;
                }
                let Some(g) = unit(grad[p]).or_else(|| normal.get(p).copied().and_then(unit))
                else {
                    return;
                };
                let theta = g[1].atan2(g[0]).rem_euclid(std::f64::consts::PI);
                let k0 = (theta * NDIR as f64 / std::f64::consts::PI).round() as usize;
                for (e, dk) in share.iter_mut().zip(0..CONE_K) {
                    let k = (k0 + NDIR + dk - CONE_K / 2) % NDIR;
                    let n = cand[k];
                    let c = n[0] * g[0] + n[1] * g[1];
                    if c.abs() > CONE_COS {
                        *e = ((2 * k + usize::from(c < 0.0)) as u8, c * c);
                    }
                }
            });
        let dirs = SyncPtr::new(&mut self.dirs);
        let shares = &self.shares;
        let has_direction =
            |p: usize| grad[p] != [0.0; 2] || normal.get(p).is_some_and(|n| *n != [0.0; 2]);
        scatter_hot::<K>(geom, parts, bins, &self.hot, has_direction, |p, node, w| {
            if shares[p][CONE_K / 2].0 == NONE_SLOT && shares[p].iter().all(|e| e.0 == NONE_SLOT) {
                return;
            }
            // SAFETY: coloured scatter (see `scatter_coloured`).
            let a = unsafe { dirs.at(node) };
            for &(slot, c2) in &shares[p] {
                if slot != NONE_SLOT {
                    a[slot as usize] += w * c2;
                }
            }
            a[2 * NDIR] += w;
        });
        for r in &self.written {
            for n in r.clone() {
                let a = &mut self.dirs[n];
                let (mut best, mut best_k) = (BALANCE_MIN * a[2 * NDIR], NDIR);
                for k in 0..NDIR {
                    let weaker = a[2 * k].min(a[2 * k + 1]);
                    if weaker > best {
                        (best, best_k) = (weaker, k);
                    }
                }
                *a = [0.0; 2 * NDIR + 1];
                let g = &mut self.node_grad[n];
                if best_k < NDIR {
                    *g = cand[best_k];
                    a[2 * NDIR] = 1.0; // balanced: the second pass finds the cut
                } else if let Some(u) = unit(*g) {
                    *g = u;
                }
                let x = geom.node_position(n);
                self.cut[n] = g[0] * x[0] + g[1] * x[1];
            }
        }
        let dirs = SyncPtr::new(&mut self.dirs);
        let (ng, d) = (&self.node_grad, &self.d);
        scatter_hot::<K>(
            geom,
            parts,
            bins,
            &self.hot,
            |p| d[p] != 0.0,
            |p, node, w| {
                // SAFETY: coloured scatter (see `scatter_coloured`).
                let a = unsafe { dirs.at(node) };
                if a[2 * NDIR] != 0.0 {
                    let (n, x) = (ng[node], parts.x[p]);
                    let w = w * d[p];
                    a[0] += w;
                    a[1] += w * (n[0] * x[0] + n[1] * x[1]);
                }
            },
        );
        for r in &self.written {
            for n in r.clone() {
                let a = &mut self.dirs[n];
                if a[2 * NDIR] != 0.0 && a[0] > 0.0 {
                    self.cut[n] = a[1] / a[0];
                }
                *a = [0.0; 2 * NDIR + 1];
            }
        }
    }

    /// The surface normals of this step's partition, what [`side`] falls
    /// back on: the reference ones, or rotated by cof F (empty without
    /// self-contact).
    pub fn normals(&self) -> &[[f64; 2]] {
        Self::normals_of(&self.normal, &self.normal0)
    }

    /// [`Dfg::normals`] from the two fields alone (borrowing them, not all
    /// of `self`, so the sums can be written meanwhile).
    fn normals_of<'a>(normal: &'a [[f64; 2]], normal0: &'a [[f64; 2]]) -> &'a [[f64; 2]] {
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
    pub fn partition<K: Kernel>(
        &mut self,
        geom: &GridGeom,
        parts: &Particles,
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
        let paper = normal.is_empty();
        scatter_coloured::<K, 2, 3>(geom, parts, bins, |p, sup| {
            let (gp, xp) = (grad[p], parts.x[p]);
            let op = normal.get(p).copied().unwrap_or([0.0; 2]);
            let base = 2 * parts.group[p] as u32;
            let m = parts.mass[p];
            sup.for_each(|n| {
                let node = n.node;
                let gi = ngrad[node];
                // (a node without a direction has everything on side 0)
                let side = if gi == [0.0; 2] {
                    0
                } else {
                    side_at(paper, gp, op, gi, xp, cut[node]) as usize
                };
                // SAFETY: coloured scatter; every write is to `node`.
                unsafe {
                    *mask.at(node) |= 1 << (base + side as u32);
                    if gi != [0.0; 2] {
                        let s = sums.at(node);
                        let w = n.w * m;
                        s.w[side] += w;
                        s.wd[side] += w * d[p];
                        s.dmax[side] = s.dmax[side].max(d[p]);
                    }
                }
            });
        });
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
pub struct DfgFields<'a> {
    /// Particle positions at the partition ([`Dfg::x_partition`]).
    pub x: &'a [[f64; 2]],
    pub cut: &'a [f64],
    /// Surface normals at the partition ([`Dfg::normals`]).
    pub normal: &'a [[f64; 2]],
    pub nodes: usize,
    pub multi: &'a MultiField,
    pub group: &'a [u8],
    pub grad: &'a [[f64; 2]],
    pub node_grad: &'a [[f64; 2]],
}

impl FieldSlots for DfgFields<'_> {
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
                let op = self.normal.get(particle).copied().unwrap_or([0.0; 2]);
                let mut field = base
                    + side_at(
                        self.normal.is_empty(),
                        gp,
                        op,
                        gi,
                        self.x[particle],
                        self.cut[node],
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

    #[test]
    fn neighbour_lists_hold_every_close_pair_of_the_same_key() {
        let mut x = Vec::new();
        let mut key = Vec::new();
        for i in 0..30 {
            for j in 0..20 {
                x.push([0.013 * i as f64 + 0.001 * (j % 3) as f64, 0.011 * j as f64]);
                key.push(u16::from(i >= 15));
            }
        }
        let mut nb = Neighbours::default();
        let reach = 0.03;
        nb.build(&x, &key, reach, [0.0, 0.0], [0.4, 0.25]);
        for p in 0..x.len() {
            let mut want: Vec<u32> = (0..x.len() as u32)
                .filter(|&q| {
                    let d = [x[q as usize][0] - x[p][0], x[q as usize][1] - x[p][1]];
                    key[q as usize] == key[p] && d[0] * d[0] + d[1] * d[1] < reach * reach
                })
                .collect();
            let mut got = nb.of(p).to_vec();
            got.sort();
            want.sort();
            assert_eq!(got, want, "particle {p}");
        }
        assert!(!nb.stale(&x, 0.001));
        let mut y = x.clone();
        y[7][0] += 0.002;
        assert!(nb.stale(&y, 0.001));
    }
}
