//! Grid update: nodal velocities before and after the step's forces,
//! v_i = p_i/m_i and v_i' = v_i + Δt (f_i/m_i + g), then the boundary
//! conditions of the grid's sides and of the driven bodies (grips whose
//! nodes follow them).
//!
//! Near-empty nodes (mass below the guard's threshold) get zero velocity:
//! dividing a force by a vanishing mass is the classic source of MPM
//! blow-ups at free surfaces. A negative nodal mass stops the run.

use crate::grid::shape::Kernel;
use crate::grid::{particle_support, GridFields, GridGeom, MultiField, SyncPtr, PAD};
use crate::particles::Particles;
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
    let runs = runs(active, extra, grid.mass.len());
    let (mass, mom, force) = (&grid.mass, &grid.momentum, &grid.force);
    let vel_old = SyncPtr::new(&mut grid.vel_old);
    let vel = SyncPtr::new(&mut grid.vel);
    let results: Vec<(f64, Option<(usize, f64)>)> = runs
        .par_iter()
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

/// Newmark's corrector (Molinos et al., eq. 2; Algorithm 1, step 8) on
/// the active nodes and the extra slots: v_i = v_i^pred + `gamma_dt`
/// (f_i/m_i + g) with the (walled) predictor in `vel_old`; zero below
/// `m_min`. Returns the body force's work over the step, Σ m_i g·v_i^pred
/// Δt: the particles move by Δt Σ N v^pred, so this is the work along
/// their displacement (and the exact kinetic-energy change of a free
/// fall).
pub fn correct<const D: usize>(
    grid: &mut GridFields<D>,
    active: &[Range<usize>],
    extra: usize,
    gamma_dt: f64,
    dt: f64,
    g: [f64; D],
    m_min: f64,
) -> f64 {
    let body_force = g != [0.0; D];
    let runs = runs(active, extra, grid.mass.len());
    let (mass, force, vel_old) = (&grid.mass, &grid.force, &grid.vel_old);
    let vel = SyncPtr::new(&mut grid.vel);
    let works: Vec<f64> = runs
        .par_iter()
        .map(|run| {
            let mut work = 0.0;
            for s in run.clone() {
                let m = mass[s];
                let vp = vel_old[s];
                let vn: [f64; D] = if m > m_min {
                    let inv = 1.0 / m;
                    if body_force {
                        let mut gv = g[0] * vp[0];
                        for a in 1..D {
                            gv += g[a] * vp[a];
                        }
                        work += m * dt * gv;
                    }
                    std::array::from_fn(|a| vp[a] + gamma_dt * (force[s][a] * inv + g[a]))
                } else {
                    [0.0; D]
                };
                // SAFETY: the runs are disjoint.
                unsafe { *vel.at(s) = vn };
            }
            work
        })
        .collect();
    works.iter().sum()
}

/// The active runs, then the extra slots from `extra` to `slots` in
/// chunks of [`CHUNK`] (fixed, so that the partial sums do not depend on
/// the thread count).
fn runs(active: &[Range<usize>], extra: usize, slots: usize) -> Vec<Range<usize>> {
    active
        .iter()
        .cloned()
        .chain(
            (extra..slots)
                .step_by(CHUNK)
                .map(|a| a..(a + CHUNK).min(slots)),
        )
        .collect()
}

/// The constraint of one side.
#[derive(Debug, Clone)]
enum Constraint {
    Fixed,
    /// Zero velocity along this axis.
    Roller(usize),
    /// Prescribed velocity components (x, y, z; None: free).
    Velocity([Option<TimeFunction>; 3]),
}

/// Boundary conditions with their node lists: the grid's sides, built
/// once, then the driven bodies, whose nodes are found every step.
#[derive(Debug, Clone, Default)]
pub struct Boundary {
    sides: Vec<(Constraint, Vec<u32>)>,
    /// The scene's name of each entry in `sides` (`left`, …, `front`, then
    /// each driven body's name).
    names: Vec<String>,
    driven: Vec<Driven>,
    /// Σ_p N_ip m_p of one driven body's particles per node: scratch for
    /// [`Boundary::find_driven`] (zero outside it), one node-long array
    /// for all the driven bodies, and none without them.
    share: Vec<f64>,
    /// The nodes `share` was written at.
    touched: Vec<u32>,
}

/// A driven body ([`crate::scene::BodySpec::drive`]): a velocity
/// constraint in `Boundary::sides` whose node list is the body's nodes of
/// the step.
#[derive(Debug, Clone, Default)]
struct Driven {
    /// Its entry in `Boundary::sides`.
    side: usize,
    /// Its index in the scene's bodies (`Particles::body`).
    body: u16,
}

/// A driven body drives a node where it holds at least this fraction of
/// the node's mass (all fields): its own nodes and the half of the shared
/// ones nearer it, so that the driven layer ends midway across the
/// interface cells and not a kernel's reach into the body it pulls.
pub const DRIVEN_SHARE: f64 = 0.5;

impl Boundary {
    /// Resolves the scene's sides: left/right (x), bottom/top (y) and, in
    /// 3D, back/front (z). Each side acts on its wall node and the ghost
    /// nodes beyond it, listed in ascending node order.
    pub fn new<const D: usize>(geom: &GridGeom<D>, spec: &crate::scene::BoundarySpec) -> Boundary {
        let free = SideCondition::Free;
        let conds = [
            &spec.left,
            &spec.right,
            &spec.bottom,
            &spec.top,
            spec.back.as_ref().unwrap_or(&free),
            spec.front.as_ref().unwrap_or(&free),
        ];
        let side_nodes = |axis: usize, high: bool| -> Vec<u32> {
            let n = geom.nodes[axis];
            let layer = if high { n - 1 - PAD..n } else { 0..PAD + 1 };
            (0..geom.node_count())
                .filter(|&k| layer.contains(&geom.node_coords(k)[axis]))
                .map(|k| k as u32)
                .collect()
        };
        const NAMES: [&str; 6] = ["left", "right", "bottom", "top", "back", "front"];
        let mut sides = Vec::new();
        let mut names = Vec::new();
        for (k, cond) in conds.into_iter().enumerate().take(2 * D) {
            let normal_axis = k / 2;
            let c = match cond {
                SideCondition::Free | SideCondition::Traction { .. } => continue,
                SideCondition::Fixed => Constraint::Fixed,
                SideCondition::Roller => Constraint::Roller(normal_axis),
                SideCondition::Velocity { x, y, z } => {
                    Constraint::Velocity([x.clone(), y.clone(), z.clone()])
                }
            };
            sides.push((c, side_nodes(normal_axis, k % 2 == 1)));
            names.push(NAMES[k].to_string());
        }
        Boundary {
            sides,
            names,
            ..Boundary::default()
        }
    }

    /// Adds the bodies with a `drive`, after the sides: each named by its
    /// name (`b<index>` without one), its nodes found by
    /// [`Boundary::find_driven`] every step.
    pub fn with_drives(mut self, bodies: &[crate::scene::BodySpec], node_count: usize) -> Self {
        for (i, b) in bodies.iter().enumerate() {
            let Some(d) = &b.drive else { continue };
            self.driven.push(Driven {
                side: self.sides.len(),
                body: i as u16,
            });
            self.share.resize(node_count, 0.0);
            let target = [d.x.clone(), d.y.clone(), d.z.clone()];
            self.sides.push((Constraint::Velocity(target), Vec::new()));
            self.names.push(if b.name.is_empty() {
                format!("b{i}")
            } else {
                b.name.clone()
            });
        }
        self
    }

    /// Whether a body drives nodes ([`Boundary::find_driven`] has work).
    pub fn has_drives(&self) -> bool {
        !self.driven.is_empty()
    }

    /// After P2G: each driven body's nodes of this step, those where its
    /// particles' Σ N m is at least [`DRIVEN_SHARE`] of the node's mass
    /// over every field, in ascending order.
    pub fn find_driven<K: Kernel, const D: usize, const V: usize>(
        &mut self,
        geom: &GridGeom<D>,
        parts: &Particles<D, V>,
        grid: &GridFields<D>,
        multi: Option<&MultiField>,
    ) {
        let nodes = geom.node_count();
        let Boundary {
            sides,
            driven,
            share,
            touched,
            ..
        } = self;
        for d in driven.iter() {
            for p in (0..parts.len()).filter(|&p| parts.body[p] == d.body) {
                let m = parts.mass[p];
                particle_support::<K, D, V>(geom, parts, p).for_each(|n| {
                    let wm = n.w * m;
                    if wm > 0.0 {
                        if share[n.node] == 0.0 {
                            touched.push(n.node as u32);
                        }
                        share[n.node] += wm;
                    }
                });
            }
            let list = &mut sides[d.side].1;
            list.clear();
            for &n in touched.iter() {
                let n = n as usize;
                let extra = multi.map_or(0..0, |m| {
                    nodes + m.offset[n] as usize..nodes + m.offset[n + 1] as usize
                });
                let total: f64 = std::iter::once(n).chain(extra).map(|s| grid.mass[s]).sum();
                if share[n] >= DRIVEN_SHARE * total {
                    list.push(n as u32);
                }
                share[n] = 0.0;
            }
            touched.clear();
            list.sort_unstable();
        }
    }

    /// Imposes the conditions at time `t` on the new velocities of every
    /// field at the boundary nodes. Returns the work done by the constraint
    /// impulses over the step, Σ m (v_bc − v)·v_bc (zero for fixed walls
    /// and rollers).
    pub fn apply<const D: usize>(
        &self,
        t: f64,
        grid: &mut GridFields<D>,
        multi: Option<&MultiField>,
    ) -> f64 {
        self.apply_measured(t, grid, multi, &mut [])
    }

    /// The names of the constrained sides, in the order of the impulses
    /// [`Boundary::apply_measured`] reports.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// [`Boundary::apply`], adding each constrained side's impulse on the
    /// material, Σ m (v_bc − v) over its nodes (N·s: the wall's force times
    /// the step), to `impulses` (one per side in [`Boundary::names`]'
    /// order, or empty: not measured).
    pub fn apply_measured<const D: usize>(
        &self,
        t: f64,
        grid: &mut GridFields<D>,
        multi: Option<&MultiField>,
        impulses: &mut [[f64; D]],
    ) -> f64 {
        let nodes = grid.mass.len() - multi.map_or(0, |m| m.extra_node.len());
        let mut work = 0.0;
        for (k, (c, list)) in self.sides.iter().enumerate() {
            let mut impulse = [0.0; D];
            let target: [Option<f64>; D] = match c {
                Constraint::Fixed => [Some(0.0); D],
                Constraint::Roller(a) => {
                    let mut t = [None; D];
                    t[*a] = Some(0.0);
                    t
                }
                Constraint::Velocity(f) => {
                    std::array::from_fn(|a| f[a].as_ref().map(|f| f.eval(t)))
                }
            };
            for &n in list {
                let n = n as usize;
                let extra = multi.map_or(0..0, |m| {
                    nodes + m.offset[n] as usize..nodes + m.offset[n + 1] as usize
                });
                for s in std::iter::once(n).chain(extra) {
                    let m = grid.mass[s].max(0.0);
                    let v = &mut grid.vel[s];
                    for a in 0..D {
                        if let Some(vb) = target[a] {
                            // the node moves at v_bc throughout the step, so the
                            // constraint's power is R·v_bc with R Δt = m (v_bc − v)
                            work += m * (vb - v[a]) * vb;
                            impulse[a] += m * (vb - v[a]);
                            v[a] = vb;
                        }
                    }
                }
            }
            if let Some(i) = impulses.get_mut(k) {
                for a in 0..D {
                    i[a] += impulse[a];
                }
            }
        }
        work
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::BoundarySpec;

    /// Every side lists its wall layer and the ghost layers beyond it, in
    /// ascending node order: in 2D the lists the four-sided code built, in
    /// 3D the six sides; a roller holds only its normal component.
    #[test]
    fn sides_list_their_wall_and_ghost_layers() {
        let all = BoundarySpec {
            left: SideCondition::Fixed,
            right: SideCondition::Fixed,
            bottom: SideCondition::Fixed,
            top: SideCondition::Fixed,
            back: Some(SideCondition::Fixed),
            front: Some(SideCondition::Roller),
        };
        let g2 = GridGeom::<2>::new([0.0; 2], 0.1, [7, 5]);
        let b2 = Boundary::new(&g2, &all);
        assert_eq!(b2.sides.len(), 4, "back/front do not exist in 2D");
        let [nx, ny] = g2.nodes;
        let mut old: Vec<Vec<u32>> = vec![Vec::new(); 4];
        (0..ny).for_each(|j| (0..=PAD).for_each(|i| old[0].push(g2.node([i, j]) as u32)));
        (0..ny).for_each(|j| (nx - 1 - PAD..nx).for_each(|i| old[1].push(g2.node([i, j]) as u32)));
        (0..=PAD).for_each(|j| (0..nx).for_each(|i| old[2].push(g2.node([i, j]) as u32)));
        (ny - 1 - PAD..ny).for_each(|j| (0..nx).for_each(|i| old[3].push(g2.node([i, j]) as u32)));
        for (k, (_, list)) in b2.sides.iter().enumerate() {
            assert_eq!(list, &old[k], "2D side {k}");
        }

        let g3 = GridGeom::<3>::new([0.0; 3], 0.1, [6, 4, 5]);
        let b3 = Boundary::new(&g3, &all);
        assert_eq!(b3.sides.len(), 6);
        for (k, (_, list)) in b3.sides.iter().enumerate() {
            let (axis, high) = (k / 2, k % 2 == 1);
            let others: usize = (0..3).filter(|&d| d != axis).map(|d| g3.nodes[d]).product();
            assert_eq!(list.len(), (PAD + 1) * others, "3D side {k}");
            assert!(list.windows(2).all(|w| w[0] < w[1]));
            for &n in list {
                let c = g3.node_coords(n as usize)[axis];
                assert!(if high {
                    c >= g3.nodes[axis] - 1 - PAD
                } else {
                    c <= PAD
                });
            }
        }
        // the front roller holds v_z only; the fixed back holds everything
        let mut grid = GridFields::<3>::default();
        let nodes = g3.node_count();
        grid.reset(nodes, nodes, false, &[]);
        grid.mass.fill(1.0);
        grid.vel.fill([1.0, 2.0, 3.0]);
        let only_front = BoundarySpec {
            front: Some(SideCondition::Roller),
            ..BoundarySpec::default()
        };
        Boundary::new(&g3, &only_front).apply(0.0, &mut grid, None);
        let front = g3.node([3, 2, g3.nodes[2] - 1]);
        let inside = g3.node([3, 2, 3]);
        assert_eq!(grid.vel[front], [1.0, 2.0, 0.0]);
        assert_eq!(grid.vel[inside], [1.0, 2.0, 3.0]);
    }
}
