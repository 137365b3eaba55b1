//! P2G: particles to grid.
//!
//! - mass m_i = Σ_p N_ip m_p;
//! - momentum p_i = Σ_p N_ip m_p (v_p + C_p (x_i − x_p)) (the affine term
//!   only with APIC, Jiang et al. 2015 eq. 15);
//! - internal force f_i = −Σ_p V_p σ_p ∇N_ip (Sulsky et al. 1994);
//! - with contact, the mass gradient Σ_p m_p ∇N_ip per field, whose
//!   direction is the outward surface normal (Homel & Herbold eq. 11).
//!
//! Body force is added on the grid (m_i g) in the grid update.
//!
//! Parallel and deterministic: tiles of one colour run concurrently (their
//! node ranges are disjoint), colours run one after another, and inside a
//! tile particles are visited in ascending index. The sum at each node is
//! therefore taken in the same order for any number of threads.

use crate::grid::shape::Kernel;
use crate::grid::{scatter_coloured, Bins, FieldSlots, GridFields, GridGeom, SyncPtr};
use crate::particles::Particles;
use rayon::prelude::*;

/// Scatters all particles to the grid. `grid` must have been reset.
pub fn p2g<K: Kernel, S: FieldSlots, const APIC: bool, const MGRAD: bool>(
    geom: &GridGeom,
    parts: &Particles,
    bins: &Bins,
    slots: &S,
    grid: &mut GridFields,
) {
    let mass = SyncPtr::new(&mut grid.mass);
    let mom = SyncPtr::new(&mut grid.momentum);
    let force = SyncPtr::new(&mut grid.force);
    let mgrad = SyncPtr::new(&mut grid.mass_grad);
    scatter_coloured::<K>(geom, parts, bins, |p, sup| {
        let m = parts.mass[p];
        let v = parts.v[p];
        let vol = parts.vol[p];
        let s = parts.stress[p];
        let c = if APIC { parts.affine[p] } else { [0.0; 4] };
        let h = geom.h;
        let xi = sup.xi();
        sup.for_each(|n| {
            let (w, [gx, gy]) = (n.w, n.grad);
            let slot = slots.slot(n.node, p);
            let wm = w * m;
            let (mx, my) = if APIC {
                let dx = (n.at[0] as f64 - xi[0]) * h;
                let dy = (n.at[1] as f64 - xi[1]) * h;
                (
                    wm * (v[0] + c[0] * dx + c[1] * dy),
                    wm * (v[1] + c[2] * dx + c[3] * dy),
                )
            } else {
                (wm * v[0], wm * v[1])
            };
            // SAFETY: coloured scatter (see `scatter_coloured`).
            unsafe {
                *mass.at(slot) += wm;
                let q = mom.at(slot);
                q[0] += mx;
                q[1] += my;
                let f = force.at(slot);
                f[0] -= vol * (s[0] * gx + s[2] * gy);
                f[1] -= vol * (s[2] * gx + s[1] * gy);
                if MGRAD {
                    let mg = mgrad.at(slot);
                    mg[0] += m * gx;
                    mg[1] += m * gy;
                }
            }
        });
    });
}

/// Marks, for every node, which contact groups have particles whose support
/// covers it (the field partition of a contact scene), then lays out the
/// extra slots. Coloured like [`p2g`]; a bitwise OR is order-independent.
pub fn partition_fields<K: Kernel>(
    geom: &GridGeom,
    parts: &Particles,
    bins: &Bins,
    multi: &mut crate::grid::MultiField,
) -> usize {
    let nodes = geom.node_count();
    multi.mask.clear();
    multi.mask.resize(nodes, 0);
    let mask = SyncPtr::new(&mut multi.mask);
    scatter_coloured::<K>(geom, parts, bins, |p, sup| {
        let bit = 1u32 << parts.group[p];
        // Every node of the support, even at zero weight: P2G writes the
        // gradient there, so the slot must exist.
        sup.for_each(|n| {
            // SAFETY: coloured scatter; a bitwise OR is order-independent.
            unsafe { *mask.at(n.node) |= bit };
        });
    });
    multi.layout()
}

/// MUSL remap: the updated particle momenta back to the grid (same
/// positions and weights as the step's P2G), then the nodal velocities.
/// Coloured like [`p2g`].
pub fn remap_velocities<K: Kernel, S: FieldSlots, const APIC: bool>(
    geom: &GridGeom,
    parts: &Particles,
    bins: &Bins,
    slots: &S,
    grid: &mut GridFields,
    active: &[std::ops::Range<usize>],
    m_min: f64,
) {
    // Only the active nodes and the extra slots can hold momentum.
    let nodes = geom.node_count();
    for r in active {
        grid.momentum[r.clone()].fill([0.0; 2]);
    }
    grid.momentum[nodes..].fill([0.0; 2]);
    let mom = SyncPtr::new(&mut grid.momentum);
    scatter_coloured::<K>(geom, parts, bins, |p, sup| {
        let (m, v) = (parts.mass[p], parts.v[p]);
        let c = if APIC { parts.affine[p] } else { [0.0; 4] };
        let xi = sup.xi();
        sup.for_each(|n| {
            let dy = (n.at[1] as f64 - xi[1]) * geom.h;
            let wm = n.w * m;
            let dx = (n.at[0] as f64 - xi[0]) * geom.h;
            // SAFETY: coloured scatter (see `scatter_coloured`).
            let q = unsafe { mom.at(slots.slot(n.node, p)) };
            q[0] += wm * (v[0] + c[0] * dx + c[1] * dy);
            q[1] += wm * (v[1] + c[2] * dx + c[3] * dy);
        });
    });
    let (mass, mom) = (&grid.mass, &grid.momentum);
    grid.vel.par_iter_mut().enumerate().for_each(|(s, v)| {
        *v = if mass[s] > m_min {
            [mom[s][0] / mass[s], mom[s][1] / mass[s]]
        } else {
            [0.0; 2]
        };
    });
}
