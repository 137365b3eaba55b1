//! The damage particle method as a [`Method`]: a scene with `method =
//! "damage_particle"` set up as particles on the lattice's vertices (a
//! box) or at its cells' centres (any other body; [`super::section`]),
//! run by explicit central differences ([`Explicit`]) whose stages are
//! the scene's plan (`dpm_advance → dpm_strain → [dpm_damage →]
//! [dpm_traction →] dpm_force`), or
//! statically (`integration = "static"`: `dpm_load → dpm_equilibrium`,
//! [`Equilibrium`]), with the series, snapshots, progress and checkpoints
//! of every method. A static step's reactions are the out-of-balance
//! forces on the held components at equilibrium, R = f_int − f_ext − m g,
//! their work summed by the trapezoid rule as the explicit run's.
//!
//! Walls hold the particles that lie on them (at cells' centres: those
//! whose cell touches the wall, half a spacing inside it): a `fixed` side
//! every component, a `roller` side the normal one, a `velocity` side the
//! components it gives; the held particles carry singular kernels, so
//! that their coefficient is their displacement (Chen & Wang's singular
//! kernel method, as Wei & Chen impose essential conditions). A particle
//! on two walls is held by both; where both hold the same component the
//! first side in the order left, right, bottom, top, back, front decides
//! it. The force a wall exerts on the material (its reaction, the
//! `[output] reactions` columns) is what holds its components:
//! R = m (v_held(t + Δt) − v_held(t + Δt/2)) / (Δt/2) − m a_free, and its
//! work, counted with the trapezoid rule over each step's held
//! displacement, is the series' `external_work` (with gravity's and the
//! tractions').
//!
//! A `traction` side loads the outline faces of the smoothing cells that
//! face it (the outermost along each lattice line, as the grid MPM loads
//! its outermost particles): each face puts N_I(x_f)|f| t on particle I,
//! x_f its centre, the point SCNI's smoothed gradients use there, so a
//! constant stress and its tractions balance particle by particle
//! ([`Scni::face_loads`]).

use super::crack::Cuts;
use super::explicit::{DamageParams, DamageState, Explicit, Held};
use super::implicit::Equilibrium;
use super::scni::{Cells, Scni};
use super::section::{body_lattice, box_corners, jitter_lattice, seeding_of, Seeding};
use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::diagnostics::{measure, Field, FieldData, Observer, SeriesRow};
use crate::material::Elastic;
use crate::particles::Particles;
use crate::run::{Method, MethodEntry, RunClock, RunSummary, SimError, StageTimes};
use crate::scene::{
    MethodKind, Scene, SceneError, SideCondition, SideTraction, Stage, TimeFunction,
};
use crate::tensor::resize;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use std::time::Instant;

/// The damage particle method in the method registry
/// ([`crate::methods`]): it runs the scenes with `method =
/// "damage_particle"`.
pub const METHOD: MethodEntry = MethodEntry {
    name: "damage_particle",
    runs: |scene| scene.file.method == MethodKind::DamageParticle,
    build: |scene| {
        Ok(if scene.dimension() == 3 {
            Box::new(Dpm::<3, 6>::build(scene)?)
        } else {
            Box::new(Dpm::<2, 3>::build(scene)?)
        })
    },
    resume: |scene, cp| {
        Ok(if scene.dimension() == 3 {
            Box::new(Dpm::<3, 6>::resume(scene, cp)?)
        } else {
            Box::new(Dpm::<2, 3>::resume(scene, cp)?)
        })
    },
};

/// What a held component follows: zero, or a side's velocity function.
#[derive(Debug, Clone)]
struct Hold {
    /// The side holding it (an index into `Dpm::sides`).
    side: usize,
    velocity: Option<TimeFunction>,
}

/// A traction side's load on its faces, spread to the particles.
#[derive(Debug, Clone)]
struct Load<const D: usize> {
    load: SideTraction<D>,
    /// (particle, Σ over the loaded faces of N_I(x_f)|f|, m²; 2D: × the
    /// thickness), by particle.
    weights: Vec<(u32, f64)>,
}

/// The tractions' external forces at time `t` on the `loaded` particles.
fn load_at<const D: usize>(loads: &[Load<D>], loaded: &[u32], external: &mut [[f64; D]], t: f64) {
    for &p in loaded {
        external[p as usize] = [0.0; D];
    }
    for l in loads {
        let tr = l.load.at(t);
        for &(p, w) in &l.weights {
            for a in 0..D {
                external[p as usize][a] += w * tr[a];
            }
        }
    }
}

/// Which particles a wall or a held region holds.
#[derive(Clone, Copy)]
enum Holding<'a> {
    /// Those on the plane x[axis] = plane (a wall).
    Plane { axis: usize, plane: f64 },
    /// Those inside the shape of `damage_particle.held[k]`.
    Region(usize, &'a crate::scene::ShapeSpec),
}

/// Held components (axes) and what each follows (None: zero velocity).
type Targets = Vec<(usize, Option<TimeFunction>)>;

/// The components given velocities, with their functions (the first `D`
/// of x, y, z).
fn velocities<const D: usize>(given: [&Option<TimeFunction>; 3]) -> Targets {
    given
        .into_iter()
        .enumerate()
        .take(D)
        .filter_map(|(a, f)| f.clone().map(|f| (a, Some(f))))
        .collect()
}

/// A run of the damage particle method in `D` dimensions (`V`: the Voigt
/// length).
pub struct Dpm<const D: usize, const V: usize> {
    scene: Scene,
    run: Explicit<D, V>,
    /// The static solve (`integration = "static"`; None: explicit).
    equilibrium: Option<Equilibrium<D, V>>,
    /// Reference positions (the particles move to x₀ + d).
    x0: Vec<[f64; D]>,
    /// The output's view of the particles (ids, bodies, materials, masses
    /// and volumes fixed; positions, velocities, stress and strain filled
    /// at each row and snapshot).
    view: Particles<D, V>,
    mats: Vec<Elastic>,
    /// What each of `run.held` follows.
    holds: Vec<Hold>,
    /// The constrained sides' and held regions' names, in the order of
    /// `reactions`.
    sides: Vec<String>,
    /// The traction sides' loads, and the particles they load.
    loads: Vec<Load<D>>,
    loaded: Vec<u32>,
    /// Each held component's reaction at the end of the last step, N.
    reaction: Vec<f64>,
    /// With `[output] reactions`: each side's force on the material at the
    /// end of the last step (else empty).
    reactions: Vec<[f64; D]>,
    /// The grid's box grown by a spacing on every side: a particle outside
    /// stops the run.
    lo: [f64; D],
    hi: [f64; D],
    /// The length the CFL step is taken over: `h`, or less where the
    /// arrangement's highest frequency asks for it.
    step_length: f64,
    /// The fastest dilatational wave speed, m/s.
    wave: f64,
    /// The particles' greatest speed, m/s (measured by the guards after
    /// each step).
    max_speed: f64,
    time: f64,
    step: u64,
    dt: f64,
    external_work: f64,
    abs_work: f64,
    dissipated: f64,
    initial_energy: f64,
    energy_floor: f64,
    times: StageTimes,
    snapshot_index: u32,
    resumed: Option<RunClock>,
}

impl<const D: usize, const V: usize> Dpm<D, V> {
    /// Sets up a validated scene's run: the particles of each body on the
    /// lattice, their SCNI tables (refused, naming the particle, where a
    /// cell's face is covered by too few particles for the moment matrix),
    /// the held components, the initial velocities and the damage state.
    pub fn build(scene: &Scene) -> Result<Self, SceneError> {
        crate::tensor::check_voigt::<D, V>();
        let file = &scene.file;
        let h = file.grid.cell_size;
        let spec = file
            .damage_particle
            .clone()
            .unwrap_or_else(super::section::DpmSpec::defaults);
        let (mut x, mut lo, mut hi) = (Vec::new(), Vec::new(), Vec::new());
        let (mut body, mut material, mut velocity) = (Vec::new(), Vec::new(), Vec::new());
        let glo: [f64; D] = std::array::from_fn(|d| file.grid.min.components()[d]);
        let ghi: [f64; D] = std::array::from_fn(|d| file.grid.max.components()[d]);
        let counts = scene.cell_counts();
        let cells: [usize; D] = std::array::from_fn(|d| counts.get(d).copied().unwrap_or(1));
        let seeding: Vec<Seeding> = file
            .bodies
            .iter()
            .map(|b| seeding_of(&b.shape, &b.holes))
            .collect();
        for (b, spec_b) in file.bodies.iter().enumerate() {
            let ((mut px, plo, phi), a, z) =
                body_lattice::<D>(&spec_b.shape, &spec_b.holes, glo, cells, h);
            if let Some(j) = spec.jitter {
                jitter_lattice(&mut px, a, z, h, j);
            }
            let v: [f64; D] = std::array::from_fn(|d| {
                spec_b.velocity.components().get(d).copied().unwrap_or(0.0)
            });
            body.extend(std::iter::repeat_n(b as u16, px.len()));
            material.extend(std::iter::repeat_n(scene.body_material[b] as u16, px.len()));
            velocity.extend(std::iter::repeat_n(v, px.len()));
            x.extend(px);
            lo.extend(plo);
            hi.extend(phi);
        }
        let n = x.len();
        // the held components, side by side
        let bc = &file.grid.boundary;
        let named: [(&'static str, Option<&SideCondition>, usize, bool); 6] = [
            ("left", Some(&bc.left), 0, false),
            ("right", Some(&bc.right), 0, true),
            ("bottom", Some(&bc.bottom), 1, false),
            ("top", Some(&bc.top), 1, true),
            ("back", bc.back.as_ref(), 2, false),
            ("front", bc.front.as_ref(), 2, true),
        ];
        // what holds components: the walls (the particles on a side's
        // plane), then the held regions (the particles inside a shape);
        // each with the components it holds and what they follow
        let mut holders: Vec<(String, Holding<'_>, Targets)> = Vec::new();
        for (name, cond, axis, far) in named {
            if axis >= D {
                continue;
            }
            let targets: Targets = match cond {
                None | Some(SideCondition::Free) | Some(SideCondition::Traction { .. }) => continue,
                Some(SideCondition::Fixed) => (0..D).map(|a| (a, None)).collect(),
                Some(SideCondition::Roller) => vec![(axis, None)],
                Some(SideCondition::Velocity { x, y, z }) => velocities::<D>([x, y, z]),
            };
            let plane = if far { ghi[axis] } else { glo[axis] };
            holders.push((name.to_string(), Holding::Plane { axis, plane }, targets));
        }
        for (k, region) in spec.held.iter().enumerate() {
            let targets = velocities::<D>([&region.x, &region.y, &region.z]);
            holders.push((region.label(k), Holding::Region(k, &region.shape), targets));
        }
        let mut sides = Vec::new();
        let mut held = Vec::new();
        let mut holds = Vec::new();
        let mut taken = std::collections::HashSet::new();
        for (side, (name, holding, targets)) in holders.into_iter().enumerate() {
            sides.push(name);
            let mut holds_any = false;
            for (p, q) in x.iter().enumerate() {
                let on = match holding {
                    // a particle on the plane, or at a cell's centre, one
                    // whose cell touches it
                    Holding::Plane { axis, plane } => match seeding[body[p] as usize] {
                        Seeding::Vertices => (q[axis] - plane).abs() <= 1e-9 * h,
                        Seeding::Centres => {
                            (lo[p][axis] - plane).abs() <= 1e-9 * h
                                || (hi[p][axis] - plane).abs() <= 1e-9 * h
                        }
                    },
                    Holding::Region(_, shape) => inside(shape, *q),
                };
                if !on {
                    continue;
                }
                holds_any = true;
                for (a, f) in &targets {
                    if taken.insert((p, *a)) {
                        held.push(Held {
                            particle: p as u32,
                            axis: *a as u8,
                            velocity: 0.0,
                        });
                        holds.push(Hold {
                            side,
                            velocity: f.clone(),
                        });
                    }
                }
            }
            if let (false, Holding::Region(k, _)) = (holds_any, holding) {
                return Err(SceneError::single(
                    format!("damage_particle.held[{k}].shape"),
                    format!("holds no particle (the particles sit on the vertices of the grid's lattice, spacing {h} m)"),
                ));
            }
        }
        // the pre-existing cracks (2D), diffracting the supports
        let mut cuts = Cuts::<D>::none();
        let mut crack_of = Vec::new();
        if D == 2 {
            let tol = 1e-9 * h;
            for (b, spec_b) in file.bodies.iter().enumerate() {
                if spec_b.cracks.is_empty() {
                    continue;
                }
                // a crack's end strictly inside the body is a tip: inside
                // the box, or every corner of a tiny square about it in a
                // cell of the body's
                let box_of = box_corners(&spec_b.shape);
                let mine: std::collections::HashSet<[i64; D]> = match seeding[b] {
                    Seeding::Vertices => Default::default(),
                    Seeding::Centres => (0..n)
                        .filter(|&p| body[p] as usize == b)
                        .map(|p| cell_index(lo[p], hi[p], glo, h))
                        .collect(),
                };
                let interior = |p: [f64; D]| match (seeding[b], &box_of) {
                    (Seeding::Vertices, Some((a, z))) => {
                        (0..D).all(|d| p[d] > a[d] + tol && p[d] < z[d] - tol)
                    }
                    _ => (0..1usize << D).all(|corner| {
                        let c: [i64; D] = std::array::from_fn(|d| {
                            let s = if corner >> d & 1 == 1 { tol } else { -tol };
                            ((p[d] + s - glo[d]) / h).floor() as i64
                        });
                        mine.contains(&c)
                    }),
                };
                for (k, crack) in spec_b.cracks.iter().enumerate() {
                    let pts: Vec<[f64; D]> = crack
                        .points
                        .iter()
                        .map(|v| std::array::from_fn(|d| v.components()[d]))
                        .collect();
                    cuts.add(b as u16, &pts, interior);
                    crack_of.push((b, k));
                }
            }
            for (p, q) in x.iter().enumerate() {
                if let Some(line) = cuts.on_crack(body[p], *q, 1e-9 * h) {
                    let (b, k) = crack_of[line];
                    return Err(SceneError::single(
                        format!("bodies[{b}].cracks[{k}]"),
                        format!(
                            "passes through the particle at {q:?} m: a particle on a crack belongs to neither face (move the crack off the particles, by half a spacing for instance: they sit on the lattice's vertices in a box body, at its cells' centres in any other)"
                        ),
                    ));
                }
                let centre: [f64; D] = std::array::from_fn(|d| 0.5 * (lo[p][d] + hi[p][d]));
                if let Some(line) = cuts.between(body[p], *q, centre) {
                    let (b, k) = crack_of[line];
                    return Err(SceneError::single(
                        format!("bodies[{b}].cracks[{k}]"),
                        format!(
                            "passes between the particle at {q:?} m and the centre of its smoothing cell, {centre:?} m: the particle would belong to the other face (move the crack to half a spacing from the particles' lattice points, or lower damage_particle.jitter)"
                        ),
                    ));
                }
            }
        }
        let mut singular = vec![false; n];
        for c in &held {
            singular[c.particle as usize] = true;
        }
        let radius = vec![spec.support * h; n];
        let too_small = |e: super::scni::ScniError| {
            let p = e.particle as usize;
            SceneError::single(
                "damage_particle.support",
                format!(
                    "bodies[{}]: the smoothing cell of the particle at {:?} m: {}: a support of {} spacings does not cover it with enough particles for the linear basis (make the body wider or the support larger)",
                    body[p], x[p], e.source, spec.support
                ),
            )
        };
        let cells = Cells {
            x: &x,
            lo: &lo,
            hi: &hi,
            radius: &radius,
            singular: &singular,
            key: &body,
            cuts: &cuts,
        };
        let scni = Scni::<D>::build_cut(&cells).map_err(too_small)?;
        let thickness = if D == 2 { file.analysis.thickness } else { 1.0 };
        // the traction sides' loaded faces: each body's outline faces that
        // face the side, the outermost along each lattice line
        let mut loads = Vec::new();
        for (k, (name, cond, axis, far)) in named.into_iter().enumerate() {
            let (Some(SideCondition::Traction { normal, shear }), true) = (cond, axis < D) else {
                continue;
            };
            let sign = if far { 1.0 } else { -1.0 };
            let mut outer: std::collections::BTreeMap<[i64; 3], (usize, f64)> =
                std::collections::BTreeMap::new();
            for (l, q) in x.iter().enumerate() {
                let at = if far { hi[l][axis] } else { lo[l][axis] };
                // the lattice line: of the vertex a particle belongs to, or
                // of the cell a centred particle owns (a line of its own)
                let centred = seeding[body[l] as usize] == Seeding::Centres;
                let line: [i64; D] = if centred {
                    cell_index(lo[l], hi[l], glo, h)
                } else {
                    std::array::from_fn(|d| ((q[d] - glo[d]) / h).round() as i64)
                };
                let mut key = [i64::from(centred), 0, 0];
                for (slot, d) in (0..D).filter(|&d| d != axis).enumerate() {
                    key[slot + 1] = line[d];
                }
                let e = outer.entry(key).or_insert((l, at));
                if sign * at > sign * e.1 {
                    *e = (l, at);
                }
            }
            let faces: Vec<(usize, usize, bool)> =
                outer.values().map(|&(l, _)| (l, axis, far)).collect();
            let per_face = Scni::<D>::face_loads(&cells, &faces).map_err(too_small)?;
            let mut weights = std::collections::BTreeMap::<u32, f64>::new();
            for (i, w) in per_face.into_iter().flatten() {
                *weights.entry(i).or_insert(0.0) += w * thickness;
            }
            tracing::debug!(side = name, faces = faces.len(), "damage particle traction");
            loads.push(Load {
                load: SideTraction::new(k, normal, shear),
                weights: weights.into_iter().collect(),
            });
        }
        let mut loaded: Vec<u32> = loads
            .iter()
            .flat_map(|l| l.weights.iter().map(|w| w.0))
            .collect();
        loaded.sort_unstable();
        loaded.dedup();
        let mats: Vec<Elastic> = scene
            .materials
            .iter()
            .map(|m| Elastic::new(&m.elastic_constants(), file.analysis.plane))
            .collect();
        let vol: Vec<f64> = scni.cell.iter().map(|a| a * thickness).collect();
        let mut run = Explicit::<D, V>::new(scni, vol.clone(), material.clone(), mats.clone());
        run.v = velocity;
        run.held = held;
        run.body_force =
            std::array::from_fn(|d| file.body_force.components().get(d).copied().unwrap_or(0.0));
        if let Some(dmg) = &spec.damage {
            run.damage_params = scene
                .materials
                .iter()
                .map(|_| {
                    Some(DamageParams {
                        g_f: dmg.fracture_energy,
                        f_t: dmg.strength,
                        regularised: dmg.regularised,
                        kappa_c: dmg.kappa_c.unwrap_or(0.0),
                        tol: dmg.tol,
                        track_at: dmg.track_at.unwrap_or(0.0),
                    })
                })
                .collect();
            let mut kappa_0 = Vec::with_capacity(n);
            let mut candidate = Vec::with_capacity(n);
            for (p, q) in x.iter().enumerate() {
                let e = scene.materials[material[p] as usize].youngs_modulus;
                let inside = dmg
                    .initiation
                    .as_ref()
                    .map(|i| (inside(&i.shape, *q), i.strength_factor));
                let (cand, factor) = match inside {
                    None => (true, 1.0),
                    Some((true, f)) => (true, f),
                    Some((false, _)) => (false, 1.0),
                };
                kappa_0.push(factor * dmg.strength / e);
                candidate.push(cand);
            }
            let mut state = DamageState::new(x.clone(), lo, hi, kappa_0, candidate);
            if let Some(r) = dmg.tracking_radius {
                state.tracking = Some(tracking_lists(&x, &body, &cuts, r * h));
            }
            if let Some(r) = dmg.normal_radius {
                state.averaging = Some(tracking_lists(&x, &body, &cuts, r * h));
            }
            run.damage = Some(state);
        }
        // the forces of the initial state (zero strain: gravity and the
        // tractions at t = 0)
        load_at(&loads, &loaded, &mut run.external, 0.0);
        run.accelerations();
        let ids: Vec<u32> = (0..n as u32).collect();
        let view = Particles::<D, V> {
            id: ids,
            body: body.clone(),
            material,
            group: vec![0; n],
            x: x.clone(),
            v: run.v.clone(),
            mass: run.mass.clone(),
            vol,
            stress: vec![[0.0; V]; n],
            strain: vec![[0.0; V]; n],
            damage: if run.damage.is_some() {
                vec![0.0; n]
            } else {
                Vec::new()
            },
            ..Default::default()
        };
        let wave = mats.iter().map(|m| m.wave_speed).fold(0.0, f64::max);
        let scale = view
            .mass
            .iter()
            .map(|m| m * (wave * wave))
            .sum::<f64>()
            .max(f64::MIN_POSITIVE);
        let reactions = if file.output.reactions {
            vec![[0.0; D]; sides.len()]
        } else {
            Vec::new()
        };
        let speed = max_speed(&run.v);
        // the CFL step's length: the spacing, or less where the
        // arrangement's highest frequency needs a shorter step than the
        // spacing's (a jittered arrangement at a small support; the
        // lattice's ω h / 2c is 0.77–0.84 in the shipped scenes, docs/dpm.md);
        // 5 % for the power method's estimate from below
        let mut step_length = h;
        if spec.integration == super::section::Integration::Explicit && n > 0 {
            let omega = 1.05 * run.highest_frequency(100);
            tracing::info!(
                "highest frequency {omega:.4e} rad/s (5 % over the power method's), ω h / 2c = {:.4}",
                omega * h / (2.0 * wave)
            );
            if omega * h > 2.0 * wave {
                step_length = 2.0 * wave / omega;
                tracing::warn!(
                    "the particles' arrangement limits the explicit step: its highest frequency {omega:.4e} rad/s asks for the step of a spacing of {step_length:.4e} m, {:.3} of the particle spacing (a larger damage_particle.support lifts it)",
                    step_length / h
                );
            }
        }
        let equilibrium = if spec.integration == super::section::Integration::Static {
            let eq = spec.equilibrium.unwrap_or_default();
            // the smallest force scale: the strength (or a strain of 1e-6)
            // on one cell face
            let face = h.powi(D as i32 - 1) * thickness;
            let stiffest = scene
                .materials
                .iter()
                .map(|m| m.youngs_modulus)
                .fold(0.0, f64::max);
            let stress = spec.damage.as_ref().map_or(1e-6 * stiffest, |d| d.strength);
            Some(
                Equilibrium::new(&run, eq.tolerance, eq.max_iterations, stress * face)
                    .map_err(|e| SceneError::single("damage_particle.integration", e))?,
            )
        } else {
            None
        };
        Ok(Dpm {
            equilibrium,
            reaction: vec![0.0; run.held.len()],
            run,
            x0: x,
            view,
            mats,
            holds,
            sides,
            loads,
            loaded,
            reactions,
            lo: std::array::from_fn(|d| glo[d] - h),
            hi: std::array::from_fn(|d| ghi[d] + h),
            step_length,
            wave,
            max_speed: speed,
            time: 0.0,
            step: 0,
            dt: 0.0,
            external_work: 0.0,
            abs_work: 0.0,
            dissipated: 0.0,
            initial_energy: 0.0,
            energy_floor: 1e-9 * scale,
            times: StageTimes::new(&scene.plan),
            snapshot_index: 0,
            resumed: None,
            scene: scene.clone(),
        })
    }

    /// The held components' velocities at `t`.
    fn hold_at(&mut self, t: f64) {
        for (c, h) in self.run.held.iter_mut().zip(&self.holds) {
            c.velocity = h.velocity.as_ref().map_or(0.0, |f| f.eval(t));
        }
    }

    /// The next time step: fixed (checked against h / max(c + |v|)) or
    /// `time.cfl` × that, clipped to land on `end`.
    fn next_dt(&self, end: f64) -> Result<f64, SimError> {
        // a static step follows no wave: time.dt, with no limit
        let signal = if self.equilibrium.is_some() {
            0.0
        } else {
            self.wave + self.max_speed
        };
        crate::run::clip_dt(
            &self.scene,
            self.step,
            self.time,
            end,
            self.step_length,
            signal,
            || self.fastest(),
        )
    }

    /// The fastest particle (asked only for an error message).
    fn fastest(&self) -> u32 {
        let mut best = (0u32, 0.0);
        for (p, v) in self.run.v.iter().enumerate() {
            let s = crate::tensor::norm(*v);
            if s > best.1 {
                best = (p as u32, s);
            }
        }
        best.0
    }

    /// One step of Δt: the plan's stages in order, each timed; then the
    /// walls' reactions and work, and the guards.
    pub fn advance(&mut self, dt: f64) -> Result<(), SimError> {
        let t = self.time;
        let mut times = std::mem::take(&mut self.times.stages);
        let mut mid = Vec::new();
        let mut failed = None;
        for st in times.iter_mut() {
            let t0 = Instant::now();
            match st.stage {
                Stage::DpmAdvance => {
                    self.hold_at(t + 0.5 * dt);
                    self.run.advance(dt);
                    mid.extend(self.run.held.iter().map(|c| c.velocity));
                    if self.run.body_force.iter().any(|&g| g != 0.0) {
                        let g = self.run.body_force;
                        let w: f64 = self
                            .run
                            .v
                            .par_iter()
                            .zip(&self.run.mass)
                            .map(|(v, m)| m * (0..D).map(|k| g[k] * v[k]).sum::<f64>())
                            .sum();
                        self.external_work += w * dt;
                        self.abs_work += (w * dt).abs();
                    }
                }
                Stage::DpmStrain => self.run.stresses(),
                Stage::DpmDamage => self.dissipated += self.run.damage_step(),
                Stage::DpmTraction => {
                    // the work over the step: the trapezoid of the loads'
                    // power on the step's velocities, Δd = Δt v(t + Δt/2)
                    let before = self.load_power();
                    load_at(&self.loads, &self.loaded, &mut self.run.external, t + dt);
                    let w = 0.5 * (before + self.load_power()) * dt;
                    self.external_work += w;
                    self.abs_work += w.abs();
                }
                Stage::DpmForce => {
                    self.hold_at(t + dt);
                    self.run.finish(dt);
                }
                Stage::DpmLoad => {
                    if let Some(eq) = self.equilibrium.as_mut() {
                        eq.begin(&self.run);
                    }
                    self.hold_at(t + 0.5 * dt);
                    for c in &self.run.held {
                        self.run.d[c.particle as usize][c.axis as usize] += dt * c.velocity;
                    }
                    load_at(&self.loads, &self.loaded, &mut self.run.external, t + dt);
                }
                Stage::DpmEquilibrium => {
                    if let Some(eq) = self.equilibrium.as_mut() {
                        match eq.solve(&mut self.run) {
                            Ok(done) => {
                                self.dissipated += done.dissipated;
                                self.run.track_candidates();
                            }
                            Err(message) => failed = Some(message),
                        }
                    }
                }
                _ => {}
            }
            st.seconds += t0.elapsed().as_secs_f64();
            st.runs += 1;
            if failed.is_some() {
                break;
            }
        }
        self.times.stages = times;
        if let Some(message) = failed {
            return Err(SimError::Equilibrium {
                step: self.step + 1,
                time: t + dt,
                message,
            });
        }
        if self.equilibrium.is_some() {
            self.static_work();
        } else {
            self.walls(dt, &mid);
        }
        self.time += dt;
        self.step += 1;
        self.dt = dt;
        self.guard()
    }

    /// The tractions' power on the present velocities, W.
    fn load_power(&self) -> f64 {
        let (f, v) = (&self.run.external, &self.run.v);
        self.loaded
            .iter()
            .map(|&p| {
                (0..D)
                    .map(|a| f[p as usize][a] * v[p as usize][a])
                    .sum::<f64>()
            })
            .sum()
    }

    /// The held components' reactions at the end of the step and their
    /// work over it (`mid`: their velocities over the step).
    fn walls(&mut self, dt: f64, mid: &[f64]) {
        for r in self.reactions.iter_mut() {
            *r = [0.0; D];
        }
        let mut work = 0.0;
        for (k, c) in self.run.held.iter().enumerate() {
            let (p, a) = (c.particle as usize, c.axis as usize);
            let m = self.run.mass[p];
            let r = m * ((c.velocity - mid[k]) / (0.5 * dt) - self.run.a[p][a]);
            work += 0.5 * (r + self.reaction[k]) * mid[k] * dt;
            self.reaction[k] = r;
            if let Some(s) = self.reactions.get_mut(self.holds[k].side) {
                s[a] += r;
            }
        }
        self.external_work += work;
        self.abs_work += work.abs();
    }

    /// A static step's reactions at equilibrium, R = f_int − f_ext − m g
    /// on each held component, and the step's work by the trapezoid rule:
    /// the reactions', the tractions' and gravity's over the step's
    /// displacements.
    fn static_work(&mut self) {
        let Some(eq) = self.equilibrium.as_ref() else {
            return;
        };
        for r in self.reactions.iter_mut() {
            *r = [0.0; D];
        }
        let run = &self.run;
        let g = run.body_force;
        let step = |p: usize, a: usize| run.d[p][a] - eq.d_before[p][a];
        let mut work = 0.0;
        for (k, c) in run.held.iter().enumerate() {
            let (p, a) = (c.particle as usize, c.axis as usize);
            let r = run.force[p][a] - run.external[p][a] - run.mass[p] * g[a];
            work += 0.5 * (r + self.reaction[k]) * step(p, a);
            self.reaction[k] = r;
            if let Some(s) = self.reactions.get_mut(self.holds[k].side) {
                s[a] += r;
            }
        }
        for &p in &self.loaded {
            let p = p as usize;
            for a in 0..D {
                work += 0.5 * (eq.external_before[p][a] + run.external[p][a]) * step(p, a);
            }
        }
        if g.iter().any(|&c| c != 0.0) {
            for p in 0..run.d.len() {
                for a in 0..D {
                    work += run.mass[p] * g[a] * step(p, a);
                }
            }
        }
        self.external_work += work;
        self.abs_work += work.abs();
    }

    /// The particle guards (and the greatest speed, for the next step):
    /// a non-finite displacement or velocity, a
    /// particle outside the grid's box.
    fn guard(&mut self) -> Result<(), SimError> {
        self.max_speed = max_speed(&self.run.v);
        let (lo, hi) = (self.lo, self.hi);
        let bad = (0..self.x0.len()).into_par_iter().find_first(|&p| {
            let (d, v) = (self.run.d[p], self.run.v[p]);
            (0..D).any(|k| {
                let x = self.x0[p][k] + d[k];
                !(x.is_finite() && v[k].is_finite()) || x < lo[k] || x > hi[k]
            })
        });
        let Some(p) = bad else {
            return Ok(());
        };
        let (d, v) = (self.run.d[p], self.run.v[p]);
        let x: [f64; D] = std::array::from_fn(|k| self.x0[p][k] + d[k]);
        if let Some(q) = [("displacement", d), ("velocity", v)]
            .into_iter()
            .find(|(_, a)| a.iter().any(|c| !c.is_finite()))
        {
            return Err(SimError::NonFinite {
                step: self.step,
                time: self.time,
                particle: p as u32,
                quantity: q.0,
            });
        }
        Err(SimError::LeftGrid {
            step: self.step,
            time: self.time,
            particle: p as u32,
            x: x[0],
            y: x[1],
            z: (D == 3).then(|| x[D - 1]),
        })
    }

    /// The output's view at the present state.
    fn fill_view(&mut self) {
        let (run, x0, view) = (&self.run, &self.x0, &mut self.view);
        for (p, x) in view.x.iter_mut().enumerate() {
            *x = std::array::from_fn(|k| x0[p][k] + run.d[p][k]);
        }
        view.v.copy_from_slice(&run.v);
        view.stress.copy_from_slice(&run.stress);
        view.strain.copy_from_slice(&run.strain);
        if let Some(st) = &run.damage {
            view.damage.copy_from_slice(&st.damage);
        }
    }

    /// The series' columns: the core's, the 3D ones, the walls' reactions,
    /// the bodies' momenta, then the damage's.
    pub fn series_columns(&self) -> Vec<String> {
        const AXES: [&str; 3] = ["x", "y", "z"];
        let mut c: Vec<String> = SeriesRow::COLUMNS.iter().map(|s| s.to_string()).collect();
        if D == 3 {
            c.extend(SeriesRow::COLUMNS_3D.iter().map(|s| s.to_string()));
        }
        if !self.reactions.is_empty() {
            for side in &self.sides {
                c.extend(AXES[..D].iter().map(|a| format!("reaction_{side}_{a}")));
            }
        }
        if self.scene.file.output.body_momenta {
            for (i, b) in self.scene.file.bodies.iter().enumerate() {
                let name = if b.name.is_empty() {
                    format!("b{i}")
                } else {
                    b.name.clone()
                };
                c.extend(AXES[..D].iter().map(|a| format!("momentum_{a}_{name}")));
            }
        }
        if self.run.damage.is_some() {
            c.extend(["damaged_particles", "broken_particles", "energy_balance"].map(String::from));
        }
        c
    }

    /// The series row of the present state.
    pub fn row(&mut self) -> SeriesRow {
        let t0 = Instant::now();
        self.fill_view();
        let m = measure::measure(&self.view, &self.mats, None);
        let mut extra = Vec::new();
        let angular = if D == 3 {
            extra.extend([m.momentum[2], m.angular[0], m.angular[1], m.angular[2]]);
            crate::tensor::norm(m.angular)
        } else {
            m.angular[2]
        };
        extra.extend(self.reactions.iter().flatten());
        if self.scene.file.output.body_momenta {
            let mut per_body = vec![[0.0; D]; self.scene.file.bodies.len()];
            for p in 0..self.view.len() {
                let b = &mut per_body[self.view.body[p] as usize];
                for a in 0..D {
                    b[a] += self.view.mass[p] * self.view.v[p][a];
                }
            }
            extra.extend(per_body.iter().flatten());
        }
        let e = m.kinetic + m.strain;
        if let Some(st) = &self.run.damage {
            let damaged = st.damage.iter().filter(|&&d| d > 0.0).count();
            let broken = st.damage.iter().filter(|&&d| d >= BROKEN).count();
            extra.extend([
                damaged as f64,
                broken as f64,
                e + self.dissipated - self.initial_energy - self.external_work,
            ]);
        }
        let row = SeriesRow {
            step: self.step,
            time: self.time,
            kinetic_energy: m.kinetic,
            strain_energy: m.strain,
            external_work: self.external_work,
            energy_error: if self.step == 0 {
                0.0
            } else {
                e - self.initial_energy - self.external_work
            },
            total_mass: m.mass,
            momentum_x: m.momentum[0],
            momentum_y: m.momentum[1],
            angular_momentum: angular,
            dt: self.dt,
            fracture_energy: self.dissipated,
            extra,
        };
        self.times.diagnostics += t0.elapsed().as_secs_f64();
        row
    }

    fn emit_snapshot(&mut self, obs: &mut dyn Observer) -> Result<(), SimError> {
        let t0 = Instant::now();
        self.fill_view();
        let mut snap = measure::snapshot(
            self.snapshot_index,
            self.step,
            self.time,
            &self.view,
            &self.mats,
            None,
        );
        snap.fields.push(Field {
            name: "displacement".into(),
            components: D,
            data: FieldData::F64(self.run.d.iter().flatten().copied().collect()),
        });
        if let Some(st) = &self.run.damage {
            snap.fields.push(Field {
                name: "candidate".into(),
                components: 1,
                data: FieldData::U32(st.candidate.iter().map(|&c| c as u32).collect()),
            });
        }
        self.snapshot_index += 1;
        self.times.diagnostics += t0.elapsed().as_secs_f64();
        obs.snapshot(&snap).map_err(SimError::Observer)
    }

    /// The state at the end of the present step, with the run loop at
    /// `clock` (the SCNI tables and everything else are rebuilt from the
    /// scene on resume).
    fn checkpoint_at(&self, clock: RunClock) -> Checkpoint<'_> {
        let flat = |a: &[[f64; D]]| a.iter().flatten().copied().collect::<Vec<f64>>();
        let state = State {
            step: self.step,
            time: self.time,
            dt: self.dt,
            external_work: self.external_work,
            abs_work: self.abs_work,
            dissipated: self.dissipated,
            initial_energy: self.initial_energy,
            snapshot_index: self.snapshot_index,
            times: self.times.clone(),
            clock,
            d: flat(&self.run.d),
            v: flat(&self.run.v),
            a: flat(&self.run.a),
            reaction: self.reaction.clone(),
            reactions: flat(&self.reactions),
            damage: self.run.damage.as_ref().map(|st| SavedDamage {
                kappa: st.kappa.clone(),
                kappa_c: st.kappa_c.clone(),
                normal: flat(&st.normal),
                damage: st.damage.clone(),
                candidate: st.candidate.clone(),
            }),
        };
        Checkpoint::new(
            &self.scene,
            METHOD.name,
            self.step,
            self.time,
            Arc::new(state),
        )
    }

    /// The run of `scene` at a checkpoint this method wrote: the setup is
    /// rebuilt from the scene (the same tables, bit for bit), the state
    /// read back; [`Dpm::run`] then goes on from its step.
    pub fn resume(scene: &Scene, cp: Checkpoint<'_>) -> Result<Self, CheckpointError> {
        cp.check_scene(scene, &[])?;
        let bad = CheckpointError::Inconsistent;
        let mut dpm = Dpm::<D, V>::build(scene).map_err(|e| bad(e.to_string()))?;
        let s: State = postcard::from_bytes(cp.state_bytes().unwrap_or_default())
            .map_err(|e| CheckpointError::Decode(e.to_string()))?;
        let n = dpm.x0.len();
        let unflat =
            |a: &[f64], what: &str, len: usize| -> Result<Vec<[f64; D]>, CheckpointError> {
                if a.len() != D * len {
                    return Err(bad(format!(
                        "its `{what}` holds {} values, the scene's run {}",
                        a.len(),
                        D * len
                    )));
                }
                Ok(a.chunks_exact(D)
                    .map(|c| std::array::from_fn(|k| c[k]))
                    .collect())
            };
        if !s
            .times
            .stages
            .iter()
            .map(|t| t.stage)
            .eq(dpm.times.stages.iter().map(|t| t.stage))
        {
            return Err(bad("its stages are not the scene's".into()));
        }
        dpm.run.d = unflat(&s.d, "d", n)?;
        dpm.run.v = unflat(&s.v, "v", n)?;
        dpm.run.a = unflat(&s.a, "a", n)?;
        if s.reaction.len() != dpm.reaction.len() {
            return Err(bad("its held components are not the scene's".into()));
        }
        dpm.reaction = s.reaction;
        dpm.reactions = unflat(&s.reactions, "reactions", dpm.reactions.len())?;
        match (dpm.run.damage.as_mut(), s.damage) {
            (None, None) => {}
            (Some(st), Some(sd)) => {
                if [
                    sd.kappa.len(),
                    sd.kappa_c.len(),
                    sd.damage.len(),
                    sd.candidate.len(),
                ]
                .iter()
                .any(|&l| l != n)
                {
                    return Err(bad(
                        "its damage arrays do not have the scene's length".into()
                    ));
                }
                st.kappa = sd.kappa;
                st.kappa_c = sd.kappa_c;
                st.normal = unflat(&sd.normal, "normal", n)?;
                st.damage = sd.damage;
                st.candidate = sd.candidate;
            }
            _ => return Err(bad("the scene's damage is not the checkpoint's".into())),
        }
        // the strain and the (degraded) stress of the saved state; the
        // accelerations are the saved ones, the next step recomputes the
        // forces
        dpm.run.stresses();
        if let Some(st) = &dpm.run.damage {
            for (s, d) in dpm.run.stress.iter_mut().zip(&st.damage) {
                for c in s.iter_mut() {
                    *c *= 1.0 - d;
                }
            }
        }
        dpm.time = s.time;
        dpm.step = s.step;
        dpm.dt = s.dt;
        dpm.external_work = s.external_work;
        dpm.abs_work = s.abs_work;
        dpm.dissipated = s.dissipated;
        dpm.initial_energy = s.initial_energy;
        dpm.snapshot_index = s.snapshot_index;
        dpm.times = s.times;
        dpm.max_speed = max_speed(&dpm.run.v);
        // the tractions at the saved time, as the straight run left them
        load_at(&dpm.loads, &dpm.loaded, &mut dpm.run.external, dpm.time);
        dpm.resumed = Some(s.clock);
        Ok(dpm)
    }
}

/// Criterion 27's neighbourhoods of `tracking_radius`: for each particle,
/// the others of its body within `reach` (by the diffracted distance, so
/// none across a crack), in CSR form (start, list), ascending.
fn tracking_lists<const D: usize>(
    x: &[[f64; D]],
    body: &[u16],
    cuts: &Cuts<D>,
    reach: f64,
) -> (Vec<u32>, Vec<u32>) {
    let mut lists = crate::neighbours::Neighbours::<D>::default();
    let mut min = [f64::INFINITY; D];
    let mut max = [f64::NEG_INFINITY; D];
    for p in x {
        for d in 0..D {
            min[d] = min[d].min(p[d] - reach);
            max[d] = max[d].max(p[d] + reach);
        }
    }
    let reach = reach * (1.0 + 1e-9);
    if !x.is_empty() {
        lists.build(x, body, reach, min, max);
        lists.sort();
    }
    let (mut start, mut list) = (vec![0u32], Vec::new());
    for (l, xl) in x.iter().enumerate() {
        for &i in lists.of(l) {
            let xi = x[i as usize];
            let s0 = crate::tensor::norm(crate::tensor::sub(xi, *xl));
            if i as usize != l && cuts.distance(body[l], *xl, xi, s0) <= reach {
                list.push(i);
            }
        }
        start.push(list.len() as u32);
    }
    (start, list)
}

/// The lattice index of the cell `lo..hi` (a centred particle's, whose
/// corners lie on the lattice from `origin`): its centre's floor.
fn cell_index<const D: usize>(lo: [f64; D], hi: [f64; D], origin: [f64; D], h: f64) -> [i64; D] {
    std::array::from_fn(|d| ((0.5 * (lo[d] + hi[d]) - origin[d]) / h).floor() as i64)
}

/// Whether the point `q` lies in `shape` (of the scene's dimension).
fn inside<const D: usize>(shape: &crate::scene::ShapeSpec, q: [f64; D]) -> bool {
    if D == 2 {
        crate::geometry::contains(shape, resize(q))
    } else {
        crate::geometry::contains_3d(shape, resize(q))
    }
}

/// The greatest of the particles' speeds, m/s.
fn max_speed<const D: usize>(v: &[[f64; D]]) -> f64 {
    v.par_iter()
        .map(|v| crate::tensor::norm(*v))
        .reduce(|| 0.0, f64::max)
}

/// Damage from which a particle counts as broken in the series.
const BROKEN: f64 = 0.99;

/// What a checkpoint of this method holds (vectors flattened).
#[derive(Debug, Clone, Serialize, Deserialize)]
struct State {
    step: u64,
    time: f64,
    dt: f64,
    external_work: f64,
    abs_work: f64,
    dissipated: f64,
    initial_energy: f64,
    snapshot_index: u32,
    times: StageTimes,
    clock: RunClock,
    d: Vec<f64>,
    v: Vec<f64>,
    a: Vec<f64>,
    reaction: Vec<f64>,
    reactions: Vec<f64>,
    damage: Option<SavedDamage>,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
struct SavedDamage {
    kappa: Vec<f64>,
    kappa_c: Vec<f64>,
    normal: Vec<f64>,
    damage: Vec<f64>,
    candidate: Vec<bool>,
}

impl<const D: usize, const V: usize> Method for Dpm<D, V> {
    fn name(&self) -> &'static str {
        METHOD.name
    }
    fn scene(&self) -> &Scene {
        &self.scene
    }
    fn particle_count(&self) -> usize {
        self.x0.len()
    }
    fn time(&self) -> f64 {
        self.time
    }
    fn steps(&self) -> u64 {
        self.step
    }
    fn series_columns(&mut self) -> Vec<String> {
        Dpm::series_columns(self)
    }
    fn step(&mut self) -> Result<f64, SimError> {
        let dt = self.next_dt(self.scene.file.time.end)?;
        self.advance(dt)?;
        Ok(dt)
    }
    fn run(&mut self, obs: &mut dyn Observer) -> Result<RunSummary, SimError> {
        crate::run::drive(self, obs)
    }
    fn stage_times(&self) -> &StageTimes {
        &self.times
    }
    fn row(&mut self) -> SeriesRow {
        Dpm::row(self)
    }
}

impl<const D: usize, const V: usize> crate::run::Stepper for Dpm<D, V> {
    fn scene(&self) -> &Scene {
        &self.scene
    }
    fn now(&self) -> f64 {
        self.time
    }
    fn steps_taken(&self) -> u64 {
        self.step
    }
    fn take_resumed(&mut self) -> Option<RunClock> {
        self.resumed.take()
    }
    fn set_initial_energy(&mut self, energy: f64) {
        self.initial_energy = energy;
    }
    fn series_columns(&mut self) -> Vec<String> {
        Dpm::series_columns(self)
    }
    fn next_dt(&self, end: f64) -> Result<f64, SimError> {
        Dpm::next_dt(self, end)
    }
    fn advance(&mut self, dt: f64) -> Result<(), SimError> {
        Dpm::advance(self, dt)
    }
    fn row(&mut self) -> SeriesRow {
        Dpm::row(self)
    }
    fn check_energy(&self, row: &SeriesRow) -> Result<(), SimError> {
        crate::run::energy_guard(
            &self.scene,
            row,
            self.initial_energy,
            self.abs_work,
            self.energy_floor,
        )
    }
    fn emit_snapshot(&mut self, obs: &mut dyn Observer) -> Result<(), SimError> {
        Dpm::emit_snapshot(self, obs)
    }
    fn checkpoint_at(&self, clock: RunClock) -> Checkpoint<'_> {
        Dpm::checkpoint_at(self, clock)
    }
    fn summary_parts(&self) -> (usize, u64, serde_json::Map<String, serde_json::Value>) {
        let mut fracture = serde_json::Map::new();
        if let Some(st) = &self.run.damage {
            let mut part = serde_json::json!({
                "damaged_particles": st.damage.iter().filter(|&&d| d > 0.0).count(),
                "broken_particles": st.damage.iter().filter(|&&d| d >= BROKEN).count(),
                "dissipated": self.dissipated,
            });
            // the static solve's iterations since this process started
            // the run (a resumed run counts from its checkpoint)
            if let (Some(eq), Some(map)) = (&self.equilibrium, part.as_object_mut()) {
                map.insert("equilibrium_iterations".into(), eq.iterations.into());
            }
            fracture.insert("damage_particle".into(), part);
        }
        (self.x0.len(), 0, fracture)
    }
    fn times(&self) -> &StageTimes {
        &self.times
    }
}
