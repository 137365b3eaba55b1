//! G2P: grid to particles, and the particle update (update-stress-last).
//!
//! - velocity: PIC/FLIP blend v_p ← α (v_p + Σ N (v_i' − v_i)) + (1−α) Σ N v_i'
//!   (Brackbill & Ruppel's FLIP; α = 0 is PIC), or APIC v_p ← Σ N v_i' with
//!   C_p = Σ N v_i' (x_i − x_p)ᵀ D⁻¹ (Jiang et al. 2015 eqs. 8–10; for linear
//!   and GIMP kernels C_p = ∇v, their eq. 11);
//! - position x_p ← x_p + Δt Σ N v_i';
//! - velocity gradient L = Σ v_i' ⊗ ∇N, then the constitutive update
//!   (see [`crate::material`]) and the volume.
//!
//! Guards checked for every particle (they stop the run): non-finite
//! position, velocity or stress; a particle leaving the grid's domain; a
//! volume that vanished or inverted (J ≤ 0).
//!
//! Parallel over fixed chunks of particles; each particle is written by one
//! task only, and the reductions (max, first bad index, any-moved) are
//! order-independent, so results do not depend on the thread count.

use crate::grid::shape::Kernel;
use crate::grid::{Bins, FieldSlots, GridFields, GridGeom, Support, SupportCache, SyncPtr};
use crate::material::Elastic;
use crate::particles::Particles;
use crate::scene::MaterialModel;
use crate::tensor::{check_voigt, resize, resize_mat, voigt};
use rayon::prelude::*;

const CHUNK: usize = 2048;

/// What went wrong with a particle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BadKind<const D: usize = 2> {
    NonFinite(&'static str),
    LeftGrid([f64; D]),
    VolumeVanished(f64),
}

/// Reductions of one G2P pass.
#[derive(Debug, Clone, Copy, Default)]
pub struct G2pStats<const D: usize = 2> {
    /// max over particles of (wave speed + |v|), m/s: the CFL signal speed.
    pub max_signal: f64,
    /// The lowest-index particle that failed a guard.
    pub bad: Option<(usize, BadKind<D>)>,
    /// Some particle changed tile (the bins must be rebuilt).
    pub moved_tile: bool,
}

impl<const D: usize> G2pStats<D> {
    fn merge(mut self, o: G2pStats<D>) -> G2pStats<D> {
        self.max_signal = self.max_signal.max(o.max_signal);
        self.bad = match (self.bad, o.bad) {
            (Some(a), Some(b)) => Some(if a.0 <= b.0 { a } else { b }),
            (a, b) => a.or(b),
        };
        self.moved_tile |= o.moved_tile;
        self
    }
}

/// Parameters of the transfer.
#[derive(Debug, Clone, Copy)]
pub struct Transfer {
    /// FLIP fraction α (ignored for APIC and the second-order updates).
    pub flip: f64,
    /// The particle update (ignored for APIC).
    pub update: ParticleUpdate,
}

/// How a non-APIC particle takes its new velocity and position from the
/// grid. S v̄ is the updated grid velocity at the particle, S v⁰ the
/// scattered one (before forces, walls and contact), v_p its own.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ParticleUpdate {
    /// v_p ← α (v_p + S(v̄ − v⁰)) + (1 − α) S v̄, x_p ← x_p + Δt S v̄.
    #[default]
    Blend,
    /// XPIC(1) (Hammerquist & Nairn 2017, as Nairn & Aimene write it for
    /// crack particles after their eq. 6): v_p ← S v̄ and
    /// x_p ← x_p + Δt (S v⁰ + ½ (S v̄ − v_p)), the position second order
    /// in the change of velocity the particle sees.
    Xpic1,
    /// FMPM(1) (Nairn & Hammerquist 2021, order one: the lumped mass):
    /// v_p ← S v̄ and x_p ← x_p + ½ Δt (v_p + S v̄), the trapezoid of the
    /// particle's old and new velocities.
    Fmpm1,
}

/// The constitutive update of particle `p` with velocity gradient `l`
/// (`l[a][b]` = ∂v_a/∂x_b): strain or deformation gradient, volume,
/// stress. Returns the stress and J = V/V₀.
///
/// Linear elastic: ε ← ε + Δt sym(L), V ← V (1 + Δt tr L); neo-Hookean:
/// F ← (I + Δt L) F, V = J V₀. The stress is the 2D (plane) or the 3D law
/// of [`Elastic`] as `D` says.
///
/// # Safety
/// Particle `p` is accessed by this task only.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn constitutive<const D: usize, const V: usize>(
    mat: &Elastic,
    l: [[f64; D]; D],
    dt: f64,
    p: usize,
    strain: SyncPtr<'_, [f64; V]>,
    def_grad: SyncPtr<'_, [[f64; D]; D]>,
    vol: SyncPtr<'_, f64>,
    vol0: &[f64],
) -> ([f64; V], f64) {
    match mat.model {
        MaterialModel::LinearElastic => {
            let e = unsafe { strain.at(p) };
            for a in 0..D {
                e[a] += dt * l[a][a];
            }
            for a in 0..D {
                for b in a + 1..D {
                    e[voigt::<D>(a, b)] += 0.5 * dt * (l[a][b] + l[b][a]);
                }
            }
            let mut tr = l[0][0];
            for (a, row) in l.iter().enumerate().skip(1) {
                tr += row[a];
            }
            let vv = unsafe { vol.at(p) };
            *vv *= 1.0 + dt * tr;
            let s = if D == 2 {
                resize(mat.hooke(resize(*e)))
            } else {
                resize(mat.hooke_3d(resize(*e)))
            };
            (s, *vv / vol0[p])
        }
        MaterialModel::NeoHookean => {
            let f = unsafe { def_grad.at(p) };
            // A = I + Δt L; F ← A F, each entry summed over k in order
            let mut a = l;
            for (r, row) in a.iter_mut().enumerate() {
                for (c, v) in row.iter_mut().enumerate() {
                    *v = if r == c { 1.0 + dt * *v } else { dt * *v };
                }
            }
            let old = *f;
            for r in 0..D {
                for c in 0..D {
                    let mut t = a[r][0] * old[0][c];
                    for k in 1..D {
                        t += a[r][k] * old[k][c];
                    }
                    f[r][c] = t;
                }
            }
            let (s, jr) = if D == 2 {
                let (s, j) = mat.neo_hookean(resize_mat(*f));
                (resize(s), j)
            } else {
                let (s, j) = mat.neo_hookean_3d(resize_mat(*f));
                (resize(s), j)
            };
            unsafe { *vol.at(p) = vol0[p] * jr };
            (s, jr)
        }
    }
}

/// The guards every particle passes after its update.
#[inline(always)]
fn guard<const D: usize, const V: usize>(
    geom: &GridGeom<D>,
    x: [f64; D],
    v: [f64; D],
    sig: [f64; V],
    j_ratio: f64,
) -> Option<BadKind<D>> {
    if !x.iter().all(|c| c.is_finite()) {
        Some(BadKind::NonFinite("position"))
    } else if !v.iter().all(|c| c.is_finite()) {
        Some(BadKind::NonFinite("velocity"))
    } else if !sig.iter().all(|c| c.is_finite()) {
        Some(BadKind::NonFinite("stress"))
    } else if j_ratio <= 1e-6 || !j_ratio.is_finite() {
        Some(BadKind::VolumeVanished(j_ratio))
    } else if !geom.inside_domain(x) {
        Some(BadKind::LeftGrid(x))
    } else {
        None
    }
}

/// Gathers grid velocities to particles and updates every particle.
#[allow(clippy::too_many_arguments)]
pub fn g2p<K: Kernel, S: FieldSlots, const APIC: bool, const D: usize, const V: usize>(
    geom: &GridGeom<D>,
    parts: &mut Particles<D, V>,
    bins: &mut Bins,
    slots: &S,
    grid: &GridFields<D>,
    mats: &[Elastic],
    transfer: Transfer,
    dt: f64,
) -> G2pStats<D> {
    gather::<K, S, APIC, false, D, V>(geom, parts, bins, &mut [], slots, grid, mats, transfer, dt)
}

/// MUSL, first pass: new particle velocities (and APIC affine matrices) and
/// the positions they move to, written to `x_next`; stresses and positions
/// are left for [`musl_stress`].
#[allow(clippy::too_many_arguments)]
pub fn musl_velocities<
    K: Kernel,
    S: FieldSlots,
    const APIC: bool,
    const D: usize,
    const V: usize,
>(
    geom: &GridGeom<D>,
    parts: &mut Particles<D, V>,
    bins: &mut Bins,
    x_next: &mut [[f64; D]],
    slots: &S,
    grid: &GridFields<D>,
    mats: &[Elastic],
    transfer: Transfer,
    dt: f64,
) {
    gather::<K, S, APIC, true, D, V>(geom, parts, bins, x_next, slots, grid, mats, transfer, dt);
}

/// The [`Update`] of `parts` (a macro rather than a function so that the
/// pass may still borrow the particles' other arrays beside it).
macro_rules! update {
    ($geom:expr, $mats:expr, $dt:expr, $parts:expr, $bins:expr) => {
        Update {
            geom: $geom,
            mats: $mats,
            dt: $dt,
            material: &$parts.material,
            vol0: &$parts.vol0,
            vol: SyncPtr::new(&mut $parts.vol),
            stress: SyncPtr::new(&mut $parts.stress),
            strain: SyncPtr::new(&mut $parts.strain),
            def_grad: SyncPtr::new(&mut $parts.def_grad),
            grad_u: SyncPtr::new(&mut $parts.grad_u),
            tile_of: SyncPtr::new(&mut $bins.tile_of),
        }
    };
}

#[allow(clippy::too_many_arguments)]
fn gather<
    K: Kernel,
    S: FieldSlots,
    const APIC: bool,
    const VELOCITY_ONLY: bool,
    const D: usize,
    const V: usize,
>(
    geom: &GridGeom<D>,
    parts: &mut Particles<D, V>,
    bins: &mut Bins,
    x_next: &mut [[f64; D]],
    slots: &S,
    grid: &GridFields<D>,
    mats: &[Elastic],
    transfer: Transfer,
    dt: f64,
) -> G2pStats<D> {
    check_voigt::<D, V>();
    let n = parts.len();
    let pass = Gather {
        up: update!(geom, mats, dt, parts, bins),
        slots,
        vel: &grid.vel,
        vel_old: &grid.vel_old,
        half_size: &parts.half_size,
        kept: &parts.supports,
        x: SyncPtr::new(&mut parts.x),
        v: SyncPtr::new(&mut parts.v),
        affine: SyncPtr::new(&mut parts.affine),
        x_next: SyncPtr::new(x_next),
        alpha: transfer.flip,
        update: transfer.update,
        dinv: K::APIC_DINV_H2.map(|d| d * geom.inv_h * geom.inv_h),
    };
    (0..n.div_ceil(CHUNK))
        .into_par_iter()
        // SAFETY: the chunks are disjoint.
        .map(|c| {
            crate::cpu::wide(
                #[inline(always)]
                || unsafe { gather_chunk::<K, S, APIC, VELOCITY_ONLY, D, V>(&pass, chunk(c, n)) },
            )
        })
        .reduce(G2pStats::default, G2pStats::merge)
}

/// MUSL, last pass: the velocity gradient from the remapped grid velocities
/// at the step's start positions, the constitutive update, then the move to
/// `x_next` and the guards. Newmark's stress pass is the same without the
/// move (`x_next` None): the gradient of the predictor velocities.
#[allow(clippy::too_many_arguments)]
pub fn musl_stress<K: Kernel, S: FieldSlots, const D: usize, const V: usize>(
    geom: &GridGeom<D>,
    parts: &mut Particles<D, V>,
    bins: &mut Bins,
    x_next: Option<&[[f64; D]]>,
    slots: &S,
    grid: &GridFields<D>,
    mats: &[Elastic],
    dt: f64,
) -> G2pStats<D> {
    check_voigt::<D, V>();
    let n = parts.len();
    let pass = Stress {
        up: update!(geom, mats, dt, parts, bins),
        slots,
        vel: &grid.vel,
        half_size: &parts.half_size,
        kept: &parts.supports,
        v: &parts.v,
        x: SyncPtr::new(&mut parts.x),
        x_next,
    };
    (0..n.div_ceil(CHUNK))
        .into_par_iter()
        // SAFETY: the chunks are disjoint.
        .map(|c| {
            crate::cpu::wide(
                #[inline(always)]
                || unsafe { stress_chunk::<K, S, D, V>(&pass, chunk(c, n)) },
            )
        })
        .reduce(G2pStats::default, G2pStats::merge)
}

/// Newmark's particle update (Molinos et al., eqs. 3–5; Algorithm 1, step
/// 9, as docs/eigen.md reads it). With S the step's shape functions at the
/// particle, v⁰ the walled predictor (`vel_old`) and v̄ the corrected nodal
/// velocities (`vel`): a_p ← S(v̄ − v⁰)/(γ Δt), the nodal acceleration at
/// the particle; v_p ← α (v_p + (1 − γ) Δt a_p^old + γ Δt a_p) + (1 − α) S v̄
/// (Newmark's corrector on the particle, blended with PIC by the FLIP
/// fraction α); x_p ← x_p + Δt S v⁰, the motion whose gradient gave the
/// step's strain. Then the guards, as every gather ends. The stress is
/// the stress pass's (`musl_stress` without a move). With contact
/// (`moved_by`: the contacted predictor) the particles move with S v⁰ of
/// the contacted predictor, and a_p is measured, as without contact, from
/// the walled predictor in `vel_old` (the corrector's contact is in the
/// corrected velocities).
#[allow(clippy::too_many_arguments)]
pub fn newmark<K: Kernel, S: FieldSlots, const D: usize, const V: usize>(
    geom: &GridGeom<D>,
    parts: &mut Particles<D, V>,
    bins: &mut Bins,
    slots: &S,
    grid: &GridFields<D>,
    mats: &[Elastic],
    alpha: f64,
    gamma: f64,
    dt: f64,
    moved_by: Option<&[[f64; D]]>,
) -> G2pStats<D> {
    let n = parts.len();
    let pass = NewmarkPass {
        geom,
        mats,
        slots,
        vel: &grid.vel,
        vel_old: &grid.vel_old,
        moved_by: moved_by.unwrap_or(&[]),
        half_size: &parts.half_size,
        kept: &parts.supports,
        material: &parts.material,
        stress: &parts.stress,
        vol: &parts.vol,
        vol0: &parts.vol0,
        x: SyncPtr::new(&mut parts.x),
        v: SyncPtr::new(&mut parts.v),
        accel: SyncPtr::new(&mut parts.accel),
        tile_of: SyncPtr::new(&mut bins.tile_of),
        alpha,
        gamma,
        dt,
    };
    (0..n.div_ceil(CHUNK))
        .into_par_iter()
        // SAFETY: the chunks are disjoint.
        .map(|c| {
            crate::cpu::wide(
                #[inline(always)]
                || unsafe {
                    if moved_by.is_some() {
                        newmark_chunk::<K, S, true, D, V>(&pass, chunk(c, n))
                    } else {
                        newmark_chunk::<K, S, false, D, V>(&pass, chunk(c, n))
                    }
                },
            )
        })
        .reduce(G2pStats::default, G2pStats::merge)
}

/// [`newmark`]'s view of the particles and the grid.
struct NewmarkPass<'a, S, const D: usize, const V: usize> {
    geom: &'a GridGeom<D>,
    mats: &'a [Elastic],
    slots: &'a S,
    vel: &'a [[f64; D]],
    vel_old: &'a [[f64; D]],
    /// The contacted predictor the particles move with (empty: `vel_old`).
    moved_by: &'a [[f64; D]],
    /// GIMP half-widths (empty: a point kernel).
    half_size: &'a [f64],
    kept: &'a SupportCache<D>,
    material: &'a [u16],
    stress: &'a [[f64; V]],
    vol: &'a [f64],
    vol0: &'a [f64],
    x: SyncPtr<'a, [f64; D]>,
    v: SyncPtr<'a, [f64; D]>,
    accel: SyncPtr<'a, [f64; D]>,
    tile_of: SyncPtr<'a, u32>,
    alpha: f64,
    gamma: f64,
    dt: f64,
}

/// [`newmark`] for the particles `range`.
///
/// # Safety
/// No other task accesses the particles of `range`.
#[inline(always)]
unsafe fn newmark_chunk<
    K: Kernel,
    S: FieldSlots,
    const MOVED: bool,
    const D: usize,
    const V: usize,
>(
    s: &NewmarkPass<'_, S, D, V>,
    range: std::ops::Range<usize>,
) -> G2pStats<D> {
    let (geom, dt, alpha) = (s.geom, s.dt, s.alpha);
    let gimp = !s.half_size.is_empty();
    let gamma_dt = s.gamma * dt;
    let lead = (1.0 - s.gamma) * dt;
    let mut st = G2pStats::default();
    for p in range {
        // SAFETY: particle p belongs to this chunk only.
        let (xp, vp, ap) = unsafe { (s.x.at(p), s.v.at(p), s.accel.at(p)) };
        let lp = if gimp { s.half_size[p] } else { 0.0 };
        let mut vbar = [0.0; D];
        let mut vpre = [0.0; D];
        let mut vmov = [0.0; D];
        Support::<K, D>::kept(geom, *xp, lp, s.kept, p).for_each(
            #[inline(always)]
            |n| {
                let k = s.slots.slot(n.node, p);
                let (vi, vo) = (s.vel[k], s.vel_old[k]);
                for a in 0..D {
                    vbar[a] += n.w * vi[a];
                    vpre[a] += n.w * vo[a];
                }
                if MOVED {
                    let vm = s.moved_by[k];
                    for a in 0..D {
                        vmov[a] += n.w * vm[a];
                    }
                }
            },
        );
        if !MOVED {
            vmov = vpre;
        }
        let mut vnew = [0.0; D];
        let mut moved = [0.0; D];
        for a in 0..D {
            let corr = vbar[a] - vpre[a]; // γ Δt a_p
            let newmark = vp[a] + lead * ap[a] + corr;
            vnew[a] = alpha * newmark + (1.0 - alpha) * vbar[a];
            ap[a] = corr / gamma_dt;
            moved[a] = xp[a] + dt * vmov[a];
        }
        geom.keep_inside(&mut moved, &mut vnew);
        *xp = moved;
        *vp = vnew;
        let mat = &s.mats[s.material[p] as usize];
        let j_ratio = s.vol[p] / s.vol0[p];
        // SAFETY: as above.
        unsafe {
            finish(
                geom,
                p,
                moved,
                vnew,
                s.stress[p],
                j_ratio,
                mat,
                s.tile_of,
                &mut st,
            )
        };
    }
    st
}

/// The particles of chunk `c` of `n` particles.
#[inline(always)]
fn chunk(c: usize, n: usize) -> std::ops::Range<usize> {
    c * CHUNK..((c + 1) * CHUNK).min(n)
}

// The chunk functions below are `#[inline(always)]` down to the per-node
// closures: each is called inside `cpu::wide`, and only code inlined into
// its `#[target_feature]` copy runs with the wider instructions (see
// `crate::cpu`).

/// What both passes that end in the constitutive update share: the arrays
/// it writes (each particle by the task of its chunk only) and reads.
#[derive(Clone, Copy)]
struct Update<'a, const D: usize, const V: usize> {
    geom: &'a GridGeom<D>,
    mats: &'a [Elastic],
    dt: f64,
    material: &'a [u16],
    vol0: &'a [f64],
    vol: SyncPtr<'a, f64>,
    stress: SyncPtr<'a, [f64; V]>,
    strain: SyncPtr<'a, [f64; V]>,
    def_grad: SyncPtr<'a, [[f64; D]; D]>,
    /// ∫ L dt per particle, or empty (`Particles::grad_u`).
    grad_u: SyncPtr<'a, [[f64; D]; D]>,
    tile_of: SyncPtr<'a, u32>,
}

impl<const D: usize, const V: usize> Update<'_, D, V> {
    /// The constitutive update of particle `p` with velocity gradient `l`,
    /// its stress stored, then [`finish`] for the particle now at `x` with
    /// velocity `v`.
    ///
    /// # Safety
    /// Particle `p` is accessed by this task only.
    #[inline(always)]
    unsafe fn particle(
        &self,
        p: usize,
        l: [[f64; D]; D],
        x: [f64; D],
        v: [f64; D],
        st: &mut G2pStats<D>,
    ) {
        let mat = &self.mats[self.material[p] as usize];
        let (sig, j_ratio) = unsafe {
            constitutive(
                mat,
                l,
                self.dt,
                p,
                self.strain,
                self.def_grad,
                self.vol,
                self.vol0,
            )
        };
        unsafe { *self.stress.at(p) = sig };
        if !self.grad_u.is_empty() {
            let g = unsafe { self.grad_u.at(p) };
            for (row, lr) in g.iter_mut().zip(&l) {
                for (v, lv) in row.iter_mut().zip(lr) {
                    *v += self.dt * lv;
                }
            }
        }
        unsafe { finish(self.geom, p, x, v, sig, j_ratio, mat, self.tile_of, st) };
    }
}

/// [`gather`]'s view of the particles and the grid.
struct Gather<'a, S, const D: usize, const V: usize> {
    up: Update<'a, D, V>,
    slots: &'a S,
    vel: &'a [[f64; D]],
    vel_old: &'a [[f64; D]],
    /// GIMP half-widths (empty: a point kernel).
    half_size: &'a [f64],
    kept: &'a SupportCache<D>,
    x: SyncPtr<'a, [f64; D]>,
    v: SyncPtr<'a, [f64; D]>,
    affine: SyncPtr<'a, [[f64; D]; D]>,
    x_next: SyncPtr<'a, [f64; D]>,
    /// The FLIP fraction.
    alpha: f64,
    update: ParticleUpdate,
    /// APIC's D⁻¹ (None: C = L, linear and GIMP kernels).
    dinv: Option<f64>,
}

/// [`gather`] for the particles `range`.
///
/// # Safety
/// No other task accesses the particles of `range`.
#[inline(always)]
unsafe fn gather_chunk<
    K: Kernel,
    S: FieldSlots,
    const APIC: bool,
    const VELOCITY_ONLY: bool,
    const D: usize,
    const V: usize,
>(
    g: &Gather<'_, S, D, V>,
    range: std::ops::Range<usize>,
) -> G2pStats<D> {
    let Gather {
        up,
        slots,
        vel,
        vel_old,
        half_size,
        kept,
        x,
        v,
        affine,
        x_next,
        alpha,
        update,
        dinv,
    } = *g;
    let (geom, dt, gimp) = (up.geom, up.dt, !half_size.is_empty());
    let mut st = G2pStats::default();
    for p in range {
        // SAFETY: particle p belongs to this chunk only.
        let (xp, vp) = unsafe { (x.at(p), v.at(p)) };
        let lp = if gimp { half_size[p] } else { 0.0 };
        let sup = Support::<K, D>::kept(geom, *xp, lp, kept, p);
        let xi = sup.xi();
        let mut vpic = [0.0; D];
        let mut dflip = [0.0; D];
        let mut l = [[0.0; D]; D]; // ∂v_a/∂x_b
        let mut b = [[0.0; D]; D];
        sup.for_each(
            #[inline(always)]
            |n| {
                let s = slots.slot(n.node, p);
                let (w, g) = (n.w, n.grad);
                let vi = vel[s];
                for a in 0..D {
                    vpic[a] += w * vi[a];
                }
                if !APIC {
                    let vo = vel_old[s];
                    for a in 0..D {
                        dflip[a] += w * (vi[a] - vo[a]);
                    }
                } else if dinv.is_some() {
                    let mut d = [0.0; D];
                    for c in 0..D {
                        d[c] = n.at[c] as f64 - xi[c];
                    }
                    for a in 0..D {
                        let wv = w * vi[a];
                        for c in 0..D {
                            b[a][c] += wv * d[c];
                        }
                    }
                }
                for a in 0..D {
                    for c in 0..D {
                        l[a][c] += vi[a] * g[c];
                    }
                }
            },
        );
        // velocity and position
        let vnew = if APIC {
            // SAFETY: as above.
            let a = unsafe { affine.at(p) };
            *a = match dinv {
                // B is in cell units of distance: C = B h D⁻¹.
                Some(d) => {
                    let mut c = [[0.0; D]; D];
                    for r in 0..D {
                        for k in 0..D {
                            c[r][k] = b[r][k] * geom.h * d;
                        }
                    }
                    c
                }
                None => l,
            };
            vpic
        } else {
            let mut v = [0.0; D];
            match update {
                ParticleUpdate::Blend => {
                    for a in 0..D {
                        v[a] = alpha * (vp[a] + dflip[a]) + (1.0 - alpha) * vpic[a];
                    }
                }
                ParticleUpdate::Xpic1 | ParticleUpdate::Fmpm1 => v = vpic,
            }
            v
        };
        // the position's rate over the step
        // APIC moves with the PIC velocity whatever `update` says
        let update = if APIC { ParticleUpdate::Blend } else { update };
        let rate = |a: usize| match update {
            ParticleUpdate::Blend => vpic[a],
            // S v⁰ = S v̄ − S(v̄ − v⁰)
            ParticleUpdate::Xpic1 => vpic[a] - dflip[a] + 0.5 * (vpic[a] - vp[a]),
            ParticleUpdate::Fmpm1 => 0.5 * (vp[a] + vpic[a]),
        };
        let mut moved = [0.0; D];
        for a in 0..D {
            moved[a] = xp[a] + dt * rate(a);
        }
        *vp = vnew;
        geom.keep_inside(&mut moved, vp);
        if VELOCITY_ONLY {
            // SAFETY: as above.
            unsafe { *x_next.at(p) = moved };
            continue;
        }
        *xp = moved;
        // SAFETY: as above.
        unsafe { up.particle(p, l, *xp, vnew, &mut st) };
    }
    st
}

/// [`musl_stress`]'s view of the particles and the grid.
struct Stress<'a, S, const D: usize, const V: usize> {
    up: Update<'a, D, V>,
    slots: &'a S,
    vel: &'a [[f64; D]],
    /// GIMP half-widths (empty: a point kernel).
    half_size: &'a [f64],
    kept: &'a SupportCache<D>,
    v: &'a [[f64; D]],
    x: SyncPtr<'a, [f64; D]>,
    /// Where the particles move (MUSL); None: they stay (Newmark's stress
    /// pass, whose particles move in its last gather).
    x_next: Option<&'a [[f64; D]]>,
}

/// [`musl_stress`] for the particles `range`.
///
/// # Safety
/// No other task accesses the particles of `range`.
#[inline(always)]
unsafe fn stress_chunk<K: Kernel, S: FieldSlots, const D: usize, const V: usize>(
    s: &Stress<'_, S, D, V>,
    range: std::ops::Range<usize>,
) -> G2pStats<D> {
    let Stress {
        up,
        slots,
        vel,
        half_size,
        kept,
        v,
        x,
        x_next,
    } = *s;
    let gimp = !half_size.is_empty();
    let mut st = G2pStats::default();
    for p in range {
        // SAFETY: particle p belongs to this chunk only.
        let xp = unsafe { x.at(p) };
        let lp = if gimp { half_size[p] } else { 0.0 };
        let mut l = [[0.0; D]; D];
        Support::<K, D>::kept(up.geom, *xp, lp, kept, p).for_each(
            #[inline(always)]
            |n| {
                let vi = vel[slots.slot(n.node, p)];
                for a in 0..D {
                    for c in 0..D {
                        l[a][c] += vi[a] * n.grad[c];
                    }
                }
            },
        );
        if let Some(x_next) = x_next {
            *xp = x_next[p];
        }
        // SAFETY: as above.
        unsafe { up.particle(p, l, *xp, v[p], &mut st) };
    }
    st
}

/// Guards, CFL signal speed and tile bookkeeping after a particle's update.
///
/// # Safety
/// Particle `p` is accessed by this task only.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn finish<const D: usize, const V: usize>(
    geom: &GridGeom<D>,
    p: usize,
    x: [f64; D],
    v: [f64; D],
    sig: [f64; V],
    j_ratio: f64,
    mat: &Elastic,
    tile_of: SyncPtr<'_, u32>,
    st: &mut G2pStats<D>,
) {
    if let Some(k) = guard(geom, x, v, sig, j_ratio) {
        if st.bad.is_none() {
            st.bad = Some((p, k));
        }
        return;
    }
    let mut v2 = v[0] * v[0];
    for c in &v[1..] {
        v2 += c * c;
    }
    let speed = v2.sqrt();
    st.max_signal = st.max_signal.max(mat.wave_speed_at(j_ratio) + speed);
    let t = geom.tile_of(geom.xi(x));
    let to = unsafe { tile_of.at(p) };
    if *to != t {
        *to = t;
        st.moved_tile = true;
    }
}
