//! Building a [`Simulation`] from a validated scene: particles, grid,
//! boundary conditions, tractions, friction table.

use super::grid_update::Boundary;
use super::{Simulation, StageTimes};
use crate::contact::ContactLaw;
use crate::fracture::model::SetupContext;
use crate::geometry;
use crate::grid::shape::{self, Kernel};
use crate::grid::{particle_support, Bins, FieldSlots, GridFields, GridGeom, MultiField};
use crate::material::Elastic;
use crate::particles::Particles;
use crate::scene::{
    MaterialModel, Scene, ShapeFunctionKind, SideCondition, Stage, TimeFunction, TransferKind,
};

pub(super) fn build(scene: &Scene) -> Simulation {
    let file = &scene.file;
    let mut geom = GridGeom::new(file.grid.min.xy(), file.grid.cell_size, scene.cells);
    let b = &file.grid.boundary;
    let wall = |s: &SideCondition| matches!(s, SideCondition::Fixed | SideCondition::Roller);
    geom.walls = [
        [wall(&b.left), wall(&b.right)],
        [wall(&b.bottom), wall(&b.top)],
    ];
    let mats: Vec<Elastic> = scene
        .materials
        .iter()
        .map(|m| Elastic::new(&m.elastic_constants(), file.analysis.plane))
        .collect();
    let apic = file.transfer.scheme == TransferKind::Apic;
    let gimp = file.grid.shape_function == ShapeFunctionKind::Gimp;
    let any_linear = mats.iter().any(|m| m.model == MaterialModel::LinearElastic);
    let any_neo = mats.iter().any(|m| m.model == MaterialModel::NeoHookean);

    let n_total = scene.total_particles();
    let mut parts = Particles::default();
    let reserve = |v: &mut Vec<_>| v.reserve_exact(n_total);
    reserve(&mut parts.x);
    let thickness = file.analysis.thickness;
    for (b, body) in file.bodies.iter().enumerate() {
        let lat = scene.lattice(b);
        let spacing = lat.spacing();
        let vol = spacing * spacing * thickness;
        let mi = scene.body_material[b];
        let mat = &mats[mi];
        let group = scene
            .contact_groups
            .iter()
            .position(|&g| g == body.contact_group)
            .unwrap_or(0) as u8;
        let first = parts.x.len();
        geometry::seed(&body.shape, &body.holes, &lat, |p| parts.x.push(p));
        let count = parts.x.len() - first;
        let origin = body.velocity_origin.map(|o| o.xy()).unwrap_or_else(|| {
            let (mut sx, mut sy) = (0.0, 0.0);
            for p in &parts.x[first..] {
                sx += p[0];
                sy += p[1];
            }
            [sx / count.max(1) as f64, sy / count.max(1) as f64]
        });
        let g = body.velocity_gradient.xy();
        for k in 0..count {
            let x = parts.x[first + k];
            let d = [x[0] - origin[0], x[1] - origin[1]];
            parts.v.push([
                body.velocity[0] + g[0][0] * d[0] + g[0][1] * d[1],
                body.velocity[1] + g[1][0] * d[0] + g[1][1] * d[1],
            ]);
            parts.id.push((first + k) as u32);
            parts.body.push(b as u16);
            parts.material.push(mi as u16);
            parts.group.push(group);
            parts.mass.push(mat.density * vol);
            parts.vol.push(vol);
            parts.vol0.push(vol);
            parts.stress.push([0.0; 3]);
            if any_linear {
                parts.strain.push([0.0; 3]);
            }
            if any_neo {
                parts.def_grad.push([[1.0, 0.0], [0.0, 1.0]]);
            }
            if apic {
                // the affine field of a linear velocity is its gradient
                parts.affine.push([[g[0][0], g[0][1]], [g[1][0], g[1][1]]]);
            }
            if gimp {
                parts.half_size.push(0.5 / lat.per_dir as f64);
            }
        }
    }

    // Store the particles in the bins' order (by tile, and by support in a
    // tile): the coloured stages then walk memory in order.
    let support = shape::support(file.grid.shape_function);
    let order = Bins::new(&geom, &parts.x, support).order;
    permute(&mut parts, &order);
    let bins = Bins::new(&geom, &parts.x, support);

    let (mut max_signal, mut scale, mut min_mass) = (0.0f64, 0.0, f64::INFINITY);
    for p in 0..parts.len() {
        let m = &mats[parts.material[p] as usize];
        let v = parts.v[p];
        max_signal = max_signal.max(m.wave_speed + (v[0] * v[0] + v[1] * v[1]).sqrt());
        scale += parts.mass[p] * m.wave_speed * m.wave_speed;
        min_mass = min_mass.min(parts.mass[p]);
    }

    // The scene's fracture models, in the order of the registry.
    let mut at = SetupContext {
        scene,
        geom: &geom,
        parts: &mut parts,
    };
    let mut models: Vec<_> = crate::fracture::MODELS
        .iter()
        .filter_map(|build| build(&mut at))
        .collect();
    let split = models.iter_mut().find_map(|m| m.field_split());

    let groups = scene.contact_groups.len();
    let mut friction = ContactLaw {
        groups,
        mu: vec![file.contact.friction; groups * groups],
        fields_per_group: if split.is_some() { 2 } else { 1 },
        self_friction: split.map_or(0.0, |s| s.self_friction()),
        full_node_mass: mats.iter().map(|m| m.density).fold(f64::INFINITY, f64::min)
            * file.grid.cell_size
            * file.grid.cell_size
            * thickness,
    };
    for pair in &file.contact.pairs {
        let ia = scene
            .contact_groups
            .iter()
            .position(|&g| g == pair.groups[0]);
        let ib = scene
            .contact_groups
            .iter()
            .position(|&g| g == pair.groups[1]);
        if let (Some(a), Some(b)) = (ia, ib) {
            friction.mu[a * groups + b] = pair.friction;
            friction.mu[b * groups + a] = pair.friction;
        }
    }
    let tractions = Tractions::new(scene, &parts);
    Simulation {
        scene: scene.clone(),
        boundary: Boundary::new(&geom, &file.grid.boundary),
        geom,
        mats,
        grid: GridFields::default(),
        multi: scene.plan.has(Stage::Contact).then(MultiField::default),
        friction,
        bins,
        tractions,
        models,
        group_of: parts.group.clone(),
        parts,
        apic,
        x_next: Vec::new(),
        written: Vec::new(),
        flip: match file.transfer.scheme {
            TransferKind::Pic => 0.0,
            _ => file.transfer.flip_blend,
        },
        body_force: file.body_force.xy(),
        m_min: file.guards.min_node_mass_fraction * min_mass,
        time: 0.0,
        step: 0,
        dt: 0.0,
        max_signal,
        external_work: 0.0,
        abs_work: 0.0,
        initial_energy: 0.0,
        energy_floor: 1e-9 * scale,
        times: StageTimes::new(&scene.plan),
        contact_steps: 0,
        snapshot_index: 0,
        grid_valid: false,
        row_due: false,
        output_due: false,
        resumed: None,
    }
}

/// Reorders every particle array so that new index k holds old particle
/// `order[k]`.
fn permute(parts: &mut Particles, order: &[u32]) {
    fn apply<T: Copy>(v: &mut Vec<T>, order: &[u32]) {
        if !v.is_empty() {
            *v = order.iter().map(|&p| v[p as usize]).collect();
        }
    }
    apply(&mut parts.id, order);
    apply(&mut parts.body, order);
    apply(&mut parts.material, order);
    apply(&mut parts.group, order);
    apply(&mut parts.x, order);
    apply(&mut parts.v, order);
    apply(&mut parts.mass, order);
    apply(&mut parts.vol, order);
    apply(&mut parts.vol0, order);
    apply(&mut parts.stress, order);
    apply(&mut parts.strain, order);
    apply(&mut parts.def_grad, order);
    apply(&mut parts.affine, order);
    apply(&mut parts.half_size, order);
    apply(&mut parts.damage, order);
    apply(&mut parts.strength, order);
}

/// Surface tractions of the grid sides that ask for one, carried by the
/// particles that face each side (in every row or column of the particle
/// lattice, the outermost particle of all bodies).
#[derive(Debug, Clone, Default)]
pub(super) struct Tractions {
    sides: Vec<TractionSide>,
}

#[derive(Debug, Clone)]
struct TractionSide {
    normal: Option<TimeFunction>,
    shear: Option<TimeFunction>,
    /// Outward unit normal of the side.
    out: [f64; 2],
    /// Shear direction: +x on bottom/top, +y on left/right.
    tangent: [f64; 2],
    /// (particle index, surface length × thickness per particle, m²).
    particles: Vec<(u32, f64)>,
}

impl Tractions {
    fn new(scene: &Scene, parts: &Particles) -> Tractions {
        let file = &scene.file;
        let b = &file.grid.boundary;
        let spacing: Vec<f64> = (0..file.bodies.len())
            .map(|k| scene.particle_spacing(k))
            .collect();
        let finest = spacing.iter().cloned().fold(f64::INFINITY, f64::min);
        let mut sides = Vec::new();
        for (k, cond) in [&b.left, &b.right, &b.bottom, &b.top]
            .into_iter()
            .enumerate()
        {
            let SideCondition::Traction { normal, shear } = cond else {
                continue;
            };
            // along = axis running along the side; across = the side's normal axis
            let (along, across, sign) = match k {
                0 => (1, 0, -1.0),
                1 => (1, 0, 1.0),
                2 => (0, 1, -1.0),
                _ => (0, 1, 1.0),
            };
            let mut best: std::collections::BTreeMap<i64, usize> =
                std::collections::BTreeMap::new();
            for p in 0..parts.len() {
                let key = ((parts.x[p][along] - file.grid.min[along]) / finest).floor() as i64;
                let e = best.entry(key).or_insert(p);
                if sign * parts.x[p][across] > sign * parts.x[*e][across] {
                    *e = p;
                }
            }
            let mut out = [0.0; 2];
            out[across] = sign;
            let mut tangent = [0.0; 2];
            tangent[along] = 1.0;
            let particles = best
                .values()
                .map(|&p| {
                    (
                        p as u32,
                        spacing[parts.body[p] as usize] * file.analysis.thickness,
                    )
                })
                .collect();
            sides.push(TractionSide {
                normal: normal.clone(),
                shear: shear.clone(),
                out,
                tangent,
                particles,
            });
        }
        Tractions { sides }
    }

    /// Adds the traction forces at time `t` to the grid; returns their work
    /// over the step, F·v_p Δt.
    pub(super) fn apply<K: Kernel, S: FieldSlots>(
        &self,
        t: f64,
        dt: f64,
        geom: &GridGeom,
        parts: &Particles,
        slots: &S,
        grid: &mut GridFields,
    ) -> f64 {
        let mut work = 0.0;
        for side in &self.sides {
            let sn = side.normal.as_ref().map_or(0.0, |f| f.eval(t));
            let ss = side.shear.as_ref().map_or(0.0, |f| f.eval(t));
            let tr = [
                sn * side.out[0] + ss * side.tangent[0],
                sn * side.out[1] + ss * side.tangent[1],
            ];
            for &(p, area) in &side.particles {
                let p = p as usize;
                let f = [tr[0] * area, tr[1] * area];
                let v = parts.v[p];
                work += (f[0] * v[0] + f[1] * v[1]) * dt;
                particle_support::<K, 2, 3>(geom, parts, p).for_each(|n| {
                    let s = slots.slot(n.node, p);
                    grid.force[s][0] += n.w * f[0];
                    grid.force[s][1] += n.w * f[1];
                });
            }
        }
        work
    }
}
