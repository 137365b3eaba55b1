//! Frictional contact between velocity fields at multi-field nodes
//! (Bardenhagen et al. 2001, as summarised in Homel & Herbold 2017,
//! eqs. 11–16 and Algorithm 3 without the DFG separability test).
//!
//! At a node with fields ς = 1..k (each holding at least
//! [`MIN_FIELD_FRACTION`] of the node's mass):
//! - normals from the field mass gradients (eq. 11), collinear between a
//!   field and the rest so that for two fields n_1 = −n_2 exactly and the
//!   exchanged momenta cancel. Of the two gradients we take the larger
//!   (the better resolved surface) rather than their average: averaging
//!   tilts the normal at a body's end, and a block sliding on a plane
//!   "plows" and is held back; with the larger gradient it matches
//!   g(sin θ − μ cos θ), see the sliding-block test;
//! - the centre-of-mass velocity v_cm = Σ m_ς v_ς / Σ m_ς (eq. 12);
//! - contact only if the field approaches the rest,
//!   (v_cm − v_ς)·n_ς > 0 (no interpenetration; separation is free);
//! - the velocity change Δv = v_cm − v_ς split into the normal part and a
//!   tangential part capped by Coulomb friction μ‖normal‖ (eq. 16).
//!
//! Sign: g = Σ_p m_p ∇N_i(x_p) points out of its body (towards the node),
//! so the inward normal of field ς is −ĝ_ς or ĝ_rest; with it the approach
//! test reads as in Algorithm 3.
//!
//! Known limitation: where a body's corner sits on a surface that lies
//! mid-cell, the corner's gradient is the larger one and the normal tilts;
//! a body sliding on such a surface is held back.

use crate::grid::{GridFields, MultiField, SyncPtr};
use crate::tensor::{dot, norm};
use rayon::prelude::*;

/// Contact parameters: Coulomb friction between dense contact-group
/// indices, and the scale for negligible fields.
#[derive(Debug, Clone, Default)]
pub struct ContactLaw {
    pub groups: usize,
    /// μ between contact groups a and b at `mu[a * groups + b]`.
    pub mu: Vec<f64>,
    /// Velocity fields per contact group: 1, or 2 with DFG partitioning
    /// (field 2g + side).
    pub fields_per_group: usize,
    /// μ between the two sides of one group (DFG crack faces and
    /// self-contact).
    pub self_friction: f64,
    /// Mass of a node fully covered by the lightest material (2D: ρ h² t,
    /// 3D: ρ h³), kg.
    pub full_node_mass: f64,
}

impl ContactLaw {
    /// μ between velocity fields (mask bits) `a` and `b`.
    pub fn friction(&self, a: usize, b: usize) -> f64 {
        let k = self.fields_per_group.max(1);
        let (ga, gb) = (a / k, b / k);
        if ga == gb {
            self.self_friction
        } else {
            self.mu[ga * self.groups + gb]
        }
    }
}

/// Most fields at one node (one per contact group, or two with DFG).
const MAX_FIELDS: usize = 32;

/// A field takes part in contact at a node only if it holds at least this
/// fraction of a fully covered node's mass (ρ h² t of the lightest
/// material). A field that merely reaches a node with the tail of its
/// kernel has a meaningless velocity there (a finite stress gradient over
/// almost no mass) and would otherwise be "in contact" every step, ahead of
/// a sliding body's corner for instance; at a real interface both fields
/// hold 15 % or more of a full node at the shared nodes for any offset of
/// the interface in its cell (quadratic B-splines, 2×2 particles).
pub const MIN_FIELD_FRACTION: f64 = 0.05;

/// Applies contact at every multi-field node; returns how many nodes had
/// at least one field in contact.
pub fn apply<const D: usize>(
    grid: &mut GridFields<D>,
    multi: &MultiField,
    law: &ContactLaw,
    m_min: f64,
) -> usize {
    let nodes = grid.mass.len() - multi.extra_node.len();
    let vel = SyncPtr::new(&mut grid.vel);
    let (mass, mgrad) = (&grid.mass, &grid.mass_grad);
    multi
        .multi_nodes
        .par_iter()
        .map(|&n| {
            let n = n as usize;
            let mask = multi.mask[n];
            let k = mask.count_ones() as usize;
            let mut slot = [0usize; MAX_FIELDS];
            let mut group = [0usize; MAX_FIELDS];
            let mut bits = mask;
            for r in 0..k {
                group[r] = bits.trailing_zeros() as usize;
                bits &= bits - 1;
                slot[r] = if r == 0 {
                    n
                } else {
                    nodes + multi.offset[n] as usize + r - 1
                };
            }
            // SAFETY: the slots of node n belong to n alone; nodes are distinct.
            let v = |s: usize| unsafe { *vel.at(s) };
            let floor = m_min.max(MIN_FIELD_FRACTION * law.full_node_mass);
            let (mut mt, mut pm) = (0.0, [0.0; D]);
            let mut live = 0;
            for r in 0..k {
                let m = mass[slot[r]];
                if m > floor {
                    live += 1;
                    mt += m;
                    let vs = v(slot[r]);
                    for a in 0..D {
                        pm[a] += m * vs[a];
                    }
                }
            }
            if live < 2 {
                return 0;
            }
            let vcm: [f64; D] = std::array::from_fn(|a| pm[a] / mt);
            let mut dv = [[0.0f64; D]; MAX_FIELDS];
            let mut touched = false;
            for r in 0..k {
                let s = slot[r];
                if mass[s] <= floor {
                    continue;
                }
                let own = mgrad[s];
                // the rest: the other fields' summed mass gradient, and the
                // group of the heaviest of them for the friction coefficient
                let (mut rest, mut heavy, mut heavy_m) = ([0.0; D], group[r], -1.0);
                for q in 0..k {
                    if q != r && mass[slot[q]] > floor {
                        for a in 0..D {
                            rest[a] += mgrad[slot[q]][a];
                        }
                        if mass[slot[q]] > heavy_m {
                            heavy_m = mass[slot[q]];
                            heavy = group[q];
                        }
                    }
                }
                // Inward normal of this field, collinear with the rest's: from
                // whichever of the two mass gradients is larger (the better
                // resolved surface). Averaging them tilts the normal at a
                // body's end and the body "plows" into a flat surface.
                let inward = if norm(own) >= norm(rest) {
                    own.map(|c| -c)
                } else {
                    rest
                };
                let Some(nrm) = unit(inward) else { continue };
                let vs = v(s);
                let d: [f64; D] = std::array::from_fn(|a| vcm[a] - vs[a]);
                let dn = dot(d, nrm);
                if dn <= 0.0 {
                    continue; // separating: no contact force
                }
                touched = true;
                let t: [f64; D] = std::array::from_fn(|a| d[a] - dn * nrm[a]);
                let tn = norm(t);
                let mu = law.friction(group[r], heavy);
                dv[r] = if tn <= mu * dn {
                    d // stick
                } else {
                    let f = mu * dn / tn;
                    std::array::from_fn(|a| dn * nrm[a] + f * t[a])
                };
            }
            for r in 0..k {
                if dv[r] != [0.0; D] {
                    // SAFETY: as above.
                    let vs = unsafe { vel.at(slot[r]) };
                    for a in 0..D {
                        vs[a] += dv[r][a];
                    }
                }
            }
            usize::from(touched)
        })
        .sum()
}

pub(crate) fn unit<const D: usize>(a: [f64; D]) -> Option<[f64; D]> {
    let n = norm(a);
    if n > 0.0 && n.is_finite() {
        Some(a.map(|c| c / n))
    } else {
        None
    }
}
