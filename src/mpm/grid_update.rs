//! Grid update: nodal velocities before and after the step's forces,
//! v_i = p_i/m_i and v_i' = v_i + Δt (f_i/m_i + g), then the boundary
//! conditions of the four sides.
//!
//! Near-empty nodes (mass below the guard's threshold) get zero velocity:
//! dividing a force by a vanishing mass is the classic source of MPM
//! blow-ups at free surfaces. A negative nodal mass stops the run.

use crate::grid::{GridFields, GridGeom, MultiField, SyncPtr, PAD};
use crate::scene::{SideCondition, TimeFunction};
use rayon::prelude::*;
use std::ops::Range;

/// Fixed chunk for deterministic partial sums (independent of threads).
const CHUNK: usize = 4096;

/// Computes old and new nodal velocities for the active nodes (`active`
/// runs) and for the extra field slots from `extra` on. Returns the body
/// force work over the step, Σ m_i g·(v_i + v_i')/2 Δt, and the first slot
/// with negative mass, if any (both independent of the thread count: the
/// runs are summed in order).
pub fn update<const D: usize>(
    grid: &mut GridFields<D>,
    active: &[Range<usize>],
    extra: usize,
    dt: f64,
    g: [f64; D],
    m_min: f64,
) -> (f64, Option<(usize, f64)>) {
    let body_force = g != [0.0; D];
    let slots = grid.mass.len();
    let extra_runs: Vec<Range<usize>> = (extra..slots)
        .step_by(CHUNK)
        .map(|a| a..(a + CHUNK).min(slots))
        .collect();
    let (mass, mom, force) = (&grid.mass, &grid.momentum, &grid.force);
    let vel_old = SyncPtr::new(&mut grid.vel_old);
    let vel = SyncPtr::new(&mut grid.vel);
    let results: Vec<(f64, Option<(usize, f64)>)> = active
        .par_iter()
        .chain(extra_runs.par_iter())
        .map(|run| {
            let mut work = 0.0;
            let mut negative = None;
            for s in run.clone() {
                let m = mass[s];
                let (vo, vn) = if m > m_min {
                    let inv = 1.0 / m;
                    let vo: [f64; D] = std::array::from_fn(|a| mom[s][a] * inv);
                    let vn: [f64; D] =
                        std::array::from_fn(|a| vo[a] + dt * (force[s][a] * inv + g[a]));
                    if body_force {
                        let mut gv = g[0] * (vo[0] + vn[0]);
                        for a in 1..D {
                            gv += g[a] * (vo[a] + vn[a]);
                        }
                        work += 0.5 * m * dt * gv;
                    }
                    (vo, vn)
                } else {
                    if m < 0.0 && negative.is_none() {
                        negative = Some((s, m));
                    }
                    ([0.0; D], [0.0; D])
                };
                // SAFETY: the runs are disjoint.
                unsafe {
                    *vel_old.at(s) = vo;
                    *vel.at(s) = vn;
                }
            }
            (work, negative)
        })
        .collect();
    let mut work = 0.0;
    let mut negative = None;
    for (w, n) in results {
        work += w;
        if negative.is_none() {
            negative = n;
        }
    }
    (work, negative)
}

/// The constraint of one side.
#[derive(Debug, Clone)]
enum Constraint {
    Fixed,
    /// Zero velocity along this axis.
    Roller(usize),
    Velocity([Option<TimeFunction>; 2]),
}

/// Boundary conditions with their node lists, built once.
#[derive(Debug, Clone, Default)]
pub struct Boundary {
    sides: Vec<(Constraint, Vec<u32>)>,
}

impl Boundary {
    /// Resolves the scene's four sides. Each side acts on its wall node and
    /// the ghost nodes beyond it.
    pub fn new(geom: &GridGeom, spec: &crate::scene::BoundarySpec) -> Boundary {
        let [nx, ny] = geom.nodes;
        let side_nodes = |side: usize| -> Vec<u32> {
            let mut v = Vec::new();
            match side {
                0 => (0..ny).for_each(|j| (0..=PAD).for_each(|i| v.push(geom.node([i, j]) as u32))),
                1 => (0..ny).for_each(|j| {
                    (nx - 1 - PAD..nx).for_each(|i| v.push(geom.node([i, j]) as u32))
                }),
                2 => (0..=PAD).for_each(|j| (0..nx).for_each(|i| v.push(geom.node([i, j]) as u32))),
                _ => (ny - 1 - PAD..ny)
                    .for_each(|j| (0..nx).for_each(|i| v.push(geom.node([i, j]) as u32))),
            }
            v
        };
        let mut sides = Vec::new();
        for (k, cond) in [&spec.left, &spec.right, &spec.bottom, &spec.top]
            .into_iter()
            .enumerate()
        {
            let normal_axis = if k < 2 { 0 } else { 1 };
            let c = match cond {
                SideCondition::Free | SideCondition::Traction { .. } => continue,
                SideCondition::Fixed => Constraint::Fixed,
                SideCondition::Roller => Constraint::Roller(normal_axis),
                SideCondition::Velocity { x, y, .. } => {
                    Constraint::Velocity([x.clone(), y.clone()])
                }
            };
            sides.push((c, side_nodes(k)));
        }
        Boundary { sides }
    }

    /// Imposes the conditions at time `t` on the new velocities of every
    /// field at the boundary nodes. Returns the work done by the constraint
    /// impulses over the step, Σ m (v_bc − v)·v_bc (zero for fixed walls
    /// and rollers).
    pub fn apply(&self, t: f64, grid: &mut GridFields, multi: Option<&MultiField>) -> f64 {
        let nodes = grid.mass.len() - multi.map_or(0, |m| m.extra_node.len());
        let mut work = 0.0;
        for (c, list) in &self.sides {
            let target: [Option<f64>; 2] = match c {
                Constraint::Fixed => [Some(0.0), Some(0.0)],
                Constraint::Roller(a) => {
                    let mut t = [None, None];
                    t[*a] = Some(0.0);
                    t
                }
                Constraint::Velocity(f) => [
                    f[0].as_ref().map(|f| f.eval(t)),
                    f[1].as_ref().map(|f| f.eval(t)),
                ],
            };
            for &n in list {
                let n = n as usize;
                let extra = multi.map_or(0..0, |m| {
                    nodes + m.offset[n] as usize..nodes + m.offset[n + 1] as usize
                });
                for s in std::iter::once(n).chain(extra) {
                    let m = grid.mass[s].max(0.0);
                    let v = &mut grid.vel[s];
                    for a in 0..2 {
                        if let Some(vb) = target[a] {
                            // the node moves at v_bc throughout the step, so the
                            // constraint's power is R·v_bc with R Δt = m (v_bc − v)
                            work += m * (vb - v[a]) * vb;
                            v[a] = vb;
                        }
                    }
                }
            }
        }
        work
    }
}
