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
use crate::grid::{Bins, FieldSlots, GridFields, GridGeom, Support, SyncPtr};
use crate::material::Elastic;
use crate::particles::Particles;
use crate::scene::MaterialModel;
use rayon::prelude::*;

const CHUNK: usize = 2048;

/// What went wrong with a particle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BadKind {
    NonFinite(&'static str),
    LeftGrid([f64; 2]),
    VolumeVanished(f64),
}

/// Reductions of one G2P pass.
#[derive(Debug, Clone, Copy, Default)]
pub struct G2pStats {
    /// max over particles of (wave speed + |v|), m/s: the CFL signal speed.
    pub max_signal: f64,
    /// The lowest-index particle that failed a guard.
    pub bad: Option<(usize, BadKind)>,
    /// Some particle changed tile (the bins must be rebuilt).
    pub moved_tile: bool,
}

impl G2pStats {
    fn merge(mut self, o: G2pStats) -> G2pStats {
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
    /// FLIP fraction α (ignored for APIC).
    pub flip: f64,
}

/// The constitutive update of particle `p` with velocity gradient `l`
/// (xx, xy, yx, yy): strain or deformation gradient, volume, stress.
/// Returns the stress and J = V/V₀.
///
/// # Safety
/// Particle `p` is accessed by this task only.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn constitutive(
    mat: &Elastic,
    l: [f64; 4],
    dt: f64,
    p: usize,
    strain: SyncPtr<'_, [f64; 3]>,
    def_grad: SyncPtr<'_, [f64; 4]>,
    vol: SyncPtr<'_, f64>,
    vol0: &[f64],
) -> ([f64; 3], f64) {
    match mat.model {
        MaterialModel::LinearElastic => {
            let e = unsafe { strain.at(p) };
            e[0] += dt * l[0];
            e[1] += dt * l[3];
            e[2] += 0.5 * dt * (l[1] + l[2]);
            let vv = unsafe { vol.at(p) };
            *vv *= 1.0 + dt * (l[0] + l[3]);
            (mat.hooke(*e), *vv / vol0[p])
        }
        MaterialModel::NeoHookean => {
            let f = unsafe { def_grad.at(p) };
            let a = [1.0 + dt * l[0], dt * l[1], dt * l[2], 1.0 + dt * l[3]];
            *f = [
                a[0] * f[0] + a[1] * f[2],
                a[0] * f[1] + a[1] * f[3],
                a[2] * f[0] + a[3] * f[2],
                a[2] * f[1] + a[3] * f[3],
            ];
            let (s, jr) = mat.neo_hookean(*f);
            unsafe { *vol.at(p) = vol0[p] * jr };
            (s, jr)
        }
    }
}

/// The guards every particle passes after its update.
#[inline(always)]
fn guard(
    geom: &GridGeom,
    x: [f64; 2],
    v: [f64; 2],
    sig: [f64; 3],
    j_ratio: f64,
) -> Option<BadKind> {
    if !(x[0].is_finite() && x[1].is_finite()) {
        Some(BadKind::NonFinite("position"))
    } else if !(v[0].is_finite() && v[1].is_finite()) {
        Some(BadKind::NonFinite("velocity"))
    } else if !(sig[0].is_finite() && sig[1].is_finite() && sig[2].is_finite()) {
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
pub fn g2p<K: Kernel, S: FieldSlots, const APIC: bool>(
    geom: &GridGeom,
    parts: &mut Particles,
    bins: &mut Bins,
    slots: &S,
    grid: &GridFields,
    mats: &[Elastic],
    transfer: Transfer,
    dt: f64,
) -> G2pStats {
    gather::<K, S, APIC, false>(geom, parts, bins, &mut [], slots, grid, mats, transfer, dt)
}

/// MUSL, first pass: new particle velocities (and APIC affine matrices) and
/// the positions they move to, written to `x_next`; stresses and positions
/// are left for [`musl_stress`].
#[allow(clippy::too_many_arguments)]
pub fn musl_velocities<K: Kernel, S: FieldSlots, const APIC: bool>(
    geom: &GridGeom,
    parts: &mut Particles,
    bins: &mut Bins,
    x_next: &mut [[f64; 2]],
    slots: &S,
    grid: &GridFields,
    mats: &[Elastic],
    transfer: Transfer,
    dt: f64,
) {
    gather::<K, S, APIC, true>(geom, parts, bins, x_next, slots, grid, mats, transfer, dt);
}

#[allow(clippy::too_many_arguments)]
fn gather<K: Kernel, S: FieldSlots, const APIC: bool, const VELOCITY_ONLY: bool>(
    geom: &GridGeom,
    parts: &mut Particles,
    bins: &mut Bins,
    x_next: &mut [[f64; 2]],
    slots: &S,
    grid: &GridFields,
    mats: &[Elastic],
    transfer: Transfer,
    dt: f64,
) -> G2pStats {
    let x_next = SyncPtr::new(x_next);
    let n = parts.len();
    let gimp = !parts.half_size.is_empty();
    let (vel, vel_old) = (&grid.vel, &grid.vel_old);
    let x = SyncPtr::new(&mut parts.x);
    let v = SyncPtr::new(&mut parts.v);
    let vol = SyncPtr::new(&mut parts.vol);
    let stress = SyncPtr::new(&mut parts.stress);
    let strain = SyncPtr::new(&mut parts.strain);
    let def_grad = SyncPtr::new(&mut parts.def_grad);
    let affine = SyncPtr::new(&mut parts.affine);
    let tile_of = SyncPtr::new(&mut bins.tile_of);
    let (material, vol0, half_size) = (&parts.material, &parts.vol0, &parts.half_size);
    let alpha = transfer.flip;
    let dinv = K::APIC_DINV_H2.map(|d| d * geom.inv_h * geom.inv_h);
    (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut st = G2pStats::default();
            for p in c * CHUNK..((c + 1) * CHUNK).min(n) {
                // SAFETY: particle p belongs to this chunk only.
                let (xp, vp) = unsafe { (x.at(p), v.at(p)) };
                let lp = if gimp { half_size[p] } else { 0.0 };
                let sup = Support::<K>::new(geom, *xp, lp);
                let xi = sup.xi();
                let mut vpic = [0.0; 2];
                let mut dflip = [0.0; 2];
                let mut l = [0.0; 4]; // ∂v_a/∂x_b: (xx, xy, yx, yy)
                let mut b = [0.0; 4];
                sup.for_each(|n| {
                    let s = slots.slot(n.node, p);
                    let (w, [gx, gy]) = (n.w, n.grad);
                    let vi = vel[s];
                    vpic[0] += w * vi[0];
                    vpic[1] += w * vi[1];
                    if !APIC {
                        let vo = vel_old[s];
                        dflip[0] += w * (vi[0] - vo[0]);
                        dflip[1] += w * (vi[1] - vo[1]);
                    } else if dinv.is_some() {
                        let dx = n.at[0] as f64 - xi[0];
                        let dy = n.at[1] as f64 - xi[1];
                        b[0] += w * vi[0] * dx;
                        b[1] += w * vi[0] * dy;
                        b[2] += w * vi[1] * dx;
                        b[3] += w * vi[1] * dy;
                    }
                    l[0] += vi[0] * gx;
                    l[1] += vi[0] * gy;
                    l[2] += vi[1] * gx;
                    l[3] += vi[1] * gy;
                });
                // velocity and position
                let vnew = if APIC {
                    // SAFETY: as above.
                    let a = unsafe { affine.at(p) };
                    *a = match dinv {
                        // B is in cell units of distance: C = B h D⁻¹.
                        Some(d) => [
                            b[0] * geom.h * d,
                            b[1] * geom.h * d,
                            b[2] * geom.h * d,
                            b[3] * geom.h * d,
                        ],
                        None => l,
                    };
                    vpic
                } else {
                    [
                        alpha * (vp[0] + dflip[0]) + (1.0 - alpha) * vpic[0],
                        alpha * (vp[1] + dflip[1]) + (1.0 - alpha) * vpic[1],
                    ]
                };
                *vp = vnew;
                let mut moved = [xp[0] + dt * vpic[0], xp[1] + dt * vpic[1]];
                geom.keep_inside(&mut moved, vp);
                if VELOCITY_ONLY {
                    // SAFETY: as above.
                    unsafe { *x_next.at(p) = moved };
                    continue;
                }
                *xp = moved;
                // constitutive update and guards
                let mat = &mats[material[p] as usize];
                // SAFETY: as above.
                let (sig, j_ratio) =
                    unsafe { constitutive(mat, l, dt, p, strain, def_grad, vol, vol0) };
                unsafe { *stress.at(p) = sig };
                // SAFETY: as above.
                unsafe { finish(geom, p, *xp, vnew, sig, j_ratio, mat, tile_of, &mut st) };
            }
            st
        })
        .reduce(G2pStats::default, G2pStats::merge)
}

/// MUSL, last pass: the velocity gradient from the remapped grid velocities
/// at the step's start positions, the constitutive update, then the move to
/// `x_next` and the guards.
#[allow(clippy::too_many_arguments)]
pub fn musl_stress<K: Kernel, S: FieldSlots>(
    geom: &GridGeom,
    parts: &mut Particles,
    bins: &mut Bins,
    x_next: &[[f64; 2]],
    slots: &S,
    grid: &GridFields,
    mats: &[Elastic],
    dt: f64,
) -> G2pStats {
    let n = parts.len();
    let gimp = !parts.half_size.is_empty();
    let vel = &grid.vel;
    let x = SyncPtr::new(&mut parts.x);
    let vol = SyncPtr::new(&mut parts.vol);
    let stress = SyncPtr::new(&mut parts.stress);
    let strain = SyncPtr::new(&mut parts.strain);
    let def_grad = SyncPtr::new(&mut parts.def_grad);
    let tile_of = SyncPtr::new(&mut bins.tile_of);
    let (material, vol0, half_size, v) = (&parts.material, &parts.vol0, &parts.half_size, &parts.v);
    (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut st = G2pStats::default();
            for p in c * CHUNK..((c + 1) * CHUNK).min(n) {
                // SAFETY: particle p belongs to this chunk only.
                let xp = unsafe { x.at(p) };
                let lp = if gimp { half_size[p] } else { 0.0 };
                let mut l = [0.0; 4];
                Support::<K>::new(geom, *xp, lp).for_each(|n| {
                    let vi = vel[slots.slot(n.node, p)];
                    let [gx, gy] = n.grad;
                    l[0] += vi[0] * gx;
                    l[1] += vi[0] * gy;
                    l[2] += vi[1] * gx;
                    l[3] += vi[1] * gy;
                });
                let mat = &mats[material[p] as usize];
                // SAFETY: as above.
                let (sig, j_ratio) =
                    unsafe { constitutive(mat, l, dt, p, strain, def_grad, vol, vol0) };
                unsafe { *stress.at(p) = sig };
                *xp = x_next[p];
                // SAFETY: as above.
                unsafe { finish(geom, p, *xp, v[p], sig, j_ratio, mat, tile_of, &mut st) };
            }
            st
        })
        .reduce(G2pStats::default, G2pStats::merge)
}

/// Guards, CFL signal speed and tile bookkeeping after a particle's update.
///
/// # Safety
/// Particle `p` is accessed by this task only.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
unsafe fn finish(
    geom: &GridGeom,
    p: usize,
    x: [f64; 2],
    v: [f64; 2],
    sig: [f64; 3],
    j_ratio: f64,
    mat: &Elastic,
    tile_of: SyncPtr<'_, u32>,
    st: &mut G2pStats,
) {
    if let Some(k) = guard(geom, x, v, sig, j_ratio) {
        if st.bad.is_none() {
            st.bad = Some((p, k));
        }
        return;
    }
    let speed = (v[0] * v[0] + v[1] * v[1]).sqrt();
    st.max_signal = st.max_signal.max(mat.wave_speed_at(j_ratio) + speed);
    let t = geom.tile_of(geom.xi(x));
    let to = unsafe { tile_of.at(p) };
    if *to != t {
        *to = t;
        st.moved_tile = true;
    }
}
