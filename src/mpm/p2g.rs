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
use crate::tensor::{check_voigt, voigt};
use rayon::prelude::*;

/// Scatters all particles to the grid. `grid` must have been reset.
pub fn p2g<
    K: Kernel,
    S: FieldSlots,
    const APIC: bool,
    const MGRAD: bool,
    const D: usize,
    const V: usize,
>(
    geom: &GridGeom<D>,
    parts: &Particles<D, V>,
    bins: &Bins,
    slots: &S,
    grid: &mut GridFields<D>,
) {
    check_voigt::<D, V>();
    let mass = SyncPtr::new(&mut grid.mass);
    let mom = SyncPtr::new(&mut grid.momentum);
    let force = SyncPtr::new(&mut grid.force);
    let mgrad = SyncPtr::new(&mut grid.mass_grad);
    // inline(always) down to the node, as `scatter_coloured` asks
    scatter_coloured::<K, D, V>(
        geom,
        parts,
        bins,
        #[inline(always)]
        |p, sup| {
            let m = parts.mass[p];
            let v = parts.v[p];
            let vol = parts.vol[p];
            let s = parts.stress[p];
            let c = if APIC { parts.affine[p] } else { [[0.0; D]; D] };
            let h = geom.h;
            let xi = sup.xi();
            sup.for_each(
                #[inline(always)]
                |n| {
                    let (w, g) = (n.w, n.grad);
                    let slot = slots.slot(n.node, p);
                    let wm = w * m;
                    // SAFETY: coloured scatter (see `scatter_coloured`).
                    unsafe {
                        *mass.at(slot) += wm;
                        let q = mom.at(slot);
                        if APIC {
                            add_affine_momentum(q, wm, v, &c, n.at, xi, h);
                        } else {
                            for a in 0..D {
                                q[a] += wm * v[a];
                            }
                        }
                        add_internal_force(force.at(slot), vol, &s, &g);
                        if MGRAD {
                            let mg = mgrad.at(slot);
                            for a in 0..D {
                                mg[a] += m * g[a];
                            }
                        }
                    }
                },
            );
        },
    );
}

/// Adds a particle's internal force at a node to `f`: −V σ ∇N, each
/// component's (σ ∇N)_a summed over b in order from the first term.
#[inline(always)]
fn add_internal_force<const D: usize, const V: usize>(
    f: &mut [f64; D],
    vol: f64,
    s: &[f64; V],
    g: &[f64; D],
) {
    for a in 0..D {
        let mut t = s[voigt::<D>(a, 0)] * g[0];
        for b in 1..D {
            t += s[voigt::<D>(a, b)] * g[b];
        }
        f[a] -= vol * t;
    }
}

/// Newmark's predictor scatter (Molinos et al., eq. 1 and Algorithm 1,
/// steps 1–2): the mass Σ N m_p and the momentum Σ N m_p (v_p + `lead` a_p)
/// with `lead` = (1 − γ) Δt, and with `MGRAD` the mass gradient as [`p2g`]
/// scatters it (contact's normals). No force: it comes from the stress the
/// predictor gives ([`scatter_forces`]). `grid` must have been reset.
/// Coloured like [`p2g`].
pub fn p2g_predictor<
    K: Kernel,
    S: FieldSlots,
    const MGRAD: bool,
    const D: usize,
    const V: usize,
>(
    geom: &GridGeom<D>,
    parts: &Particles<D, V>,
    bins: &Bins,
    slots: &S,
    grid: &mut GridFields<D>,
    lead: f64,
) {
    let mass = SyncPtr::new(&mut grid.mass);
    let mom = SyncPtr::new(&mut grid.momentum);
    let mgrad = SyncPtr::new(&mut grid.mass_grad);
    scatter_coloured::<K, D, V>(
        geom,
        parts,
        bins,
        #[inline(always)]
        |p, sup| {
            let m = parts.mass[p];
            let (v, a) = (parts.v[p], parts.accel[p]);
            let mut u = [0.0; D];
            for c in 0..D {
                u[c] = v[c] + lead * a[c];
            }
            sup.for_each(
                #[inline(always)]
                |n| {
                    let slot = slots.slot(n.node, p);
                    let wm = n.w * m;
                    // SAFETY: coloured scatter (see `scatter_coloured`).
                    unsafe {
                        *mass.at(slot) += wm;
                        let q = mom.at(slot);
                        for c in 0..D {
                            q[c] += wm * u[c];
                        }
                        if MGRAD {
                            let mg = mgrad.at(slot);
                            for c in 0..D {
                                mg[c] += m * n.grad[c];
                            }
                        }
                    }
                },
            );
        },
    );
}

/// Newmark's internal forces (Algorithm 1, step 7): −Σ_p V_p σ_p ∇N_ip
/// of the stress the predictor gave, added to what the nodes hold (the
/// tractions). Coloured like [`p2g`], at the positions of the step's
/// scatter.
pub fn scatter_forces<K: Kernel, S: FieldSlots, const D: usize, const V: usize>(
    geom: &GridGeom<D>,
    parts: &Particles<D, V>,
    bins: &Bins,
    slots: &S,
    grid: &mut GridFields<D>,
) {
    check_voigt::<D, V>();
    let force = SyncPtr::new(&mut grid.force);
    scatter_coloured::<K, D, V>(
        geom,
        parts,
        bins,
        #[inline(always)]
        |p, sup| {
            let (vol, s) = (parts.vol[p], parts.stress[p]);
            sup.for_each(
                #[inline(always)]
                |n| {
                    // SAFETY: coloured scatter (see `scatter_coloured`).
                    unsafe {
                        add_internal_force(force.at(slots.slot(n.node, p)), vol, &s, &n.grad)
                    };
                },
            );
        },
    );
}

/// Adds a particle's APIC momentum at a node to `q`: N m (v + C (x_i − x_p))
/// with `wm` = N m, the node at lattice position `at`, the particle at `xi`
/// (both in cells) and cell size `h`; each component's affine sum in axis
/// order. Inlined into the per-node closures of [`p2g`] and
/// [`remap_velocities`] (they run in `cpu::wide`'s copy).
#[inline(always)]
fn add_affine_momentum<const D: usize>(
    q: &mut [f64; D],
    wm: f64,
    v: [f64; D],
    c: &[[f64; D]; D],
    at: [isize; D],
    xi: [f64; D],
    h: f64,
) {
    let mut d = [0.0; D];
    for a in 0..D {
        d[a] = (at[a] as f64 - xi[a]) * h;
    }
    for a in 0..D {
        let mut t = v[a];
        for b in 0..D {
            t += c[a][b] * d[b];
        }
        q[a] += wm * t;
    }
}

/// Marks, for every node, which contact groups have particles whose support
/// covers it (the field partition of a contact scene), then lays out the
/// extra slots. Coloured like [`p2g`]; a bitwise OR is order-independent.
pub fn partition_fields<K: Kernel, const D: usize, const V: usize>(
    geom: &GridGeom<D>,
    parts: &Particles<D, V>,
    bins: &Bins,
    multi: &mut crate::grid::MultiField,
) -> usize {
    let nodes = geom.node_count();
    multi.mask.clear();
    multi.mask.resize(nodes, 0);
    let mask = SyncPtr::new(&mut multi.mask);
    scatter_coloured::<K, D, V>(
        geom,
        parts,
        bins,
        #[inline(always)]
        |p, sup| {
            let bit = 1u32 << parts.group[p];
            // Every node of the support, even at zero weight: P2G writes the
            // gradient there, so the slot must exist.
            sup.for_each(
                #[inline(always)]
                |n| {
                    // SAFETY: coloured scatter; a bitwise OR is order-independent.
                    unsafe { *mask.at(n.node) |= bit };
                },
            );
        },
    );
    multi.layout()
}

/// MUSL remap: the updated particle momenta back to the grid (same
/// positions and weights as the step's P2G), then the nodal velocities.
/// Coloured like [`p2g`].
#[allow(clippy::too_many_arguments)]
pub fn remap_velocities<
    K: Kernel,
    S: FieldSlots,
    const APIC: bool,
    const D: usize,
    const V: usize,
>(
    geom: &GridGeom<D>,
    parts: &Particles<D, V>,
    bins: &Bins,
    slots: &S,
    grid: &mut GridFields<D>,
    active: &[std::ops::Range<usize>],
    m_min: f64,
) {
    // Only the active nodes and the extra slots can hold momentum.
    let nodes = geom.node_count();
    for r in active {
        grid.momentum[r.clone()].fill([0.0; D]);
    }
    grid.momentum[nodes..].fill([0.0; D]);
    let mom = SyncPtr::new(&mut grid.momentum);
    scatter_coloured::<K, D, V>(
        geom,
        parts,
        bins,
        #[inline(always)]
        |p, sup| {
            let (m, v) = (parts.mass[p], parts.v[p]);
            let c = if APIC { parts.affine[p] } else { [[0.0; D]; D] };
            let xi = sup.xi();
            sup.for_each(
                #[inline(always)]
                |n| {
                    let wm = n.w * m;
                    // SAFETY: coloured scatter (see `scatter_coloured`).
                    let q = unsafe { mom.at(slots.slot(n.node, p)) };
                    // the remap always carries the affine term (zero without APIC)
                    add_affine_momentum(q, wm, v, &c, n.at, xi, geom.h);
                },
            );
        },
    );
    let (mass, mom) = (&grid.mass, &grid.momentum);
    grid.vel.par_iter_mut().enumerate().for_each(|(s, v)| {
        *v = if mass[s] > m_min {
            std::array::from_fn(|a| mom[s][a] / mass[s])
        } else {
            [0.0; D]
        };
    });
}
