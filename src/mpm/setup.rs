//! Building a [`Simulation`] from a validated scene: particles, grid,
//! boundary conditions, tractions, friction table.

use super::g2p::ParticleUpdate;
use super::grid_update::Boundary;
use super::{Saved, Simulation, StageTimes};
use crate::contact::ContactLaw;
use crate::fracture::model::Build;
use crate::fracture::model::SetupContext;
use crate::geometry;
use crate::grid::shape::{self, Kernel};
use crate::grid::{particle_support, Bins, FieldSlots, GridFields, GridGeom, MultiField};
use crate::material::Elastic;
use crate::particles::Particles;
use crate::scene::{
    MaterialModel, Scene, ShapeFunctionKind, SideCondition, SideTraction, Stage, TransferKind,
};
use crate::tensor::{check_voigt, identity, norm, resize};

pub(super) fn build<const D: usize, const V: usize>(scene: &Scene) -> Simulation<D, V>
where
    Particles<D, V>: Saved,
{
    check_voigt::<D, V>();
    // a caller's mistake, not a user's: methods::build picks by dimension
    assert_eq!(
        scene.dimension(),
        D,
        "a {}D scene set up as a {D}D simulation (Simulation::new is 2D; \
         Simulation::<3, 6>::build or methods::build for 3D)",
        scene.dimension()
    );
    let file = &scene.file;
    let cells: [usize; D] = std::array::from_fn(|d| scene.cell_counts()[d]);
    let mut geom = GridGeom::new(file.grid.min.get::<D>(), file.grid.cell_size, cells);
    let b = &file.grid.boundary;
    let wall = |s: &SideCondition| matches!(s, SideCondition::Fixed | SideCondition::Roller);
    let free = SideCondition::Free;
    let sides = [
        [wall(&b.left), wall(&b.right)],
        [wall(&b.bottom), wall(&b.top)],
        [
            wall(b.back.as_ref().unwrap_or(&free)),
            wall(b.front.as_ref().unwrap_or(&free)),
        ],
    ];
    geom.walls = std::array::from_fn(|d| sides[d]);
    geom.lme_gamma = file.grid.lme_gamma.unwrap_or(shape::LME_GAMMA_DEFAULT);
    let mats: Vec<Elastic> = scene
        .materials
        .iter()
        .map(|m| Elastic::new(&m.elastic_constants(), file.analysis.plane))
        .collect();
    let apic = file.transfer.scheme == TransferKind::Apic;
    let newmark = file.transfer.newmark();
    let body_force = file.body_force.get::<D>();
    let gimp = file.grid.shape_function == ShapeFunctionKind::Gimp;
    let any_linear = mats.iter().any(|m| m.model == MaterialModel::LinearElastic);
    let any_neo = mats.iter().any(|m| m.model == MaterialModel::NeoHookean);

    let n_total = scene.total_particles();
    let mut parts = Particles::<D, V>::default();
    let reserve = |v: &mut Vec<_>| v.reserve_exact(n_total);
    reserve(&mut parts.x);
    let thickness = file.analysis.thickness;
    for (b, body) in file.bodies.iter().enumerate() {
        let first = parts.x.len();
        // the particle volume: 2D spacing² × thickness, 3D spacing³
        let (vol, per_dir) = if D == 2 {
            let lat = scene.lattice(b);
            geometry::seed(&body.shape, &body.holes, &lat, |p| parts.x.push(resize(p)));
            let spacing = lat.spacing();
            (spacing * spacing * thickness, lat.per_dir)
        } else {
            let lat = scene.lattice_3d(b);
            geometry::seed_3d(&body.shape, &body.holes, &lat, |p| parts.x.push(resize(p)));
            let spacing = lat.spacing();
            (spacing * spacing * spacing, lat.per_dir)
        };
        let mi = scene.body_material[b];
        let mat = &mats[mi];
        let group = scene
            .contact_groups
            .iter()
            .position(|&g| g == body.contact_group)
            .unwrap_or(0) as u8;
        let count = parts.x.len() - first;
        let origin = body
            .velocity_origin
            .map(|o| o.get::<D>())
            .unwrap_or_else(|| {
                let mut sum = [0.0; D];
                for p in &parts.x[first..] {
                    for d in 0..D {
                        sum[d] += p[d];
                    }
                }
                sum.map(|s| s / count.max(1) as f64)
            });
        let g = body.velocity_gradient.get::<D>();
        let v0 = body.velocity.get::<D>();
        for k in 0..count {
            let x = parts.x[first + k];
            let mut d = [0.0; D];
            for a in 0..D {
                d[a] = x[a] - origin[a];
            }
            let mut v = [0.0; D];
            for a in 0..D {
                let mut t = v0[a];
                for c in 0..D {
                    t += g[a][c] * d[c];
                }
                v[a] = t;
            }
            parts.v.push(v);
            parts.id.push((first + k) as u32);
            parts.body.push(b as u16);
            parts.material.push(mi as u16);
            parts.group.push(group);
            parts.mass.push(mat.density * vol);
            parts.vol.push(vol);
            parts.vol0.push(vol);
            parts.stress.push([0.0; V]);
            if any_linear {
                parts.strain.push([0.0; V]);
            }
            if any_neo {
                parts.def_grad.push(identity());
            }
            if apic {
                // the affine field of a linear velocity is its gradient
                parts.affine.push(g);
            }
            if gimp {
                parts.half_size.push(0.5 / per_dir as f64);
            }
            if newmark.is_some() {
                // the stress starts at zero: the first acceleration is
                // the body force's (a free fall then moves exactly)
                parts.accel.push(body_force);
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
        max_signal = max_signal.max(m.wave_speed + norm(v));
        scale += parts.mass[p] * m.wave_speed * m.wave_speed;
        min_mass = min_mass.min(parts.mass[p]);
    }

    // The scene's fracture models, in the order of the registry.
    let mut at = SetupContext {
        scene,
        geom: &geom,
        parts: &mut parts,
    };
    let mut models: Vec<_> = registry::<D, V>()
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
        full_node_mass: {
            let (rho, h) = (
                mats.iter().map(|m| m.density).fold(f64::INFINITY, f64::min),
                file.grid.cell_size,
            );
            // ρ h² t in 2D, ρ h³ in 3D
            if D == 2 {
                rho * h * h * thickness
            } else {
                rho * h * h * h
            }
        },
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
    let tractions = Tractions::<D>::new(scene, &parts);
    let boundary =
        Boundary::new(&geom, &file.grid.boundary).with_drives(&file.bodies, geom.node_count());
    let sides = if file.output.reactions {
        boundary.names().len()
    } else {
        0
    };
    Simulation {
        scene: scene.clone(),
        boundary,
        geom,
        mats,
        grid: GridFields::default(),
        multi: scene.plan.has(Stage::Contact).then(MultiField::default),
        friction,
        bins,
        tractions,
        models,
        group_of: parts.group.clone(),
        resorted: false,
        parts,
        apic,
        x_next: Vec::new(),
        written: Vec::new(),
        flip: match file.transfer.scheme {
            TransferKind::Pic | TransferKind::Xpic1 | TransferKind::Fmpm1 => 0.0,
            _ => file.transfer.flip_blend,
        },
        update: match file.transfer.scheme {
            TransferKind::Xpic1 => ParticleUpdate::Xpic1,
            TransferKind::Fmpm1 => ParticleUpdate::Fmpm1,
            _ => ParticleUpdate::Blend,
        },
        body_force,
        newmark,
        reactions: vec![[0.0; D]; sides],
        impulses: vec![[0.0; D]; sides],
        m_min: file.guards.min_node_mass_fraction * min_mass,
        time: 0.0,
        step: 0,
        dt: 0.0,
        max_signal,
        external_work: 0.0,
        abs_work: 0.0,
        applied: Vec::new(),
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

/// The fracture models of a `D`-dimensional run: [`crate::fracture::MODELS`]
/// in 2D, [`crate::fracture::MODELS_3D`] in 3D (damage;
/// [`crate::methods::runnable`] refuses a 3D scene that asks for another).
/// Each registry is typed for its dimension, so a generic `D` reaches them
/// by a type check at run time.
fn registry<const D: usize, const V: usize>() -> &'static [Build<D, V>] {
    let models: &'static [Build] = crate::fracture::MODELS;
    let models_3d: &'static [Build<3, 6>] = crate::fracture::MODELS_3D;
    (&models as &dyn std::any::Any)
        .downcast_ref::<&'static [Build<D, V>]>()
        .or_else(|| (&models_3d as &dyn std::any::Any).downcast_ref::<&'static [Build<D, V>]>())
        .copied()
        .unwrap_or(&[])
}

/// Reorders every particle array so that new index k holds old particle
/// `order[k]` (the LME supports, scratch refilled each step, are left).
pub(super) fn permute<const D: usize, const V: usize>(parts: &mut Particles<D, V>, order: &[u32]) {
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
    apply(&mut parts.phase, order);
    apply(&mut parts.history, order);
    apply(&mut parts.damage, order);
    apply(&mut parts.strength, order);
    apply(&mut parts.grad_u, order);
    apply(&mut parts.softening, order);
    apply(&mut parts.accel, order);
}

/// Surface tractions of the grid sides that ask for one, carried by the
/// particles that face each side (in every row or column of the particle
/// lattice, the outermost particle of all bodies). In 3D the lattice lines
/// run across the side's face; the shear acts along +y on the x sides and
/// along +x on the others.
#[derive(Debug, Clone, Default)]
pub(super) struct Tractions<const D: usize> {
    sides: Vec<TractionSide<D>>,
}

#[derive(Debug, Clone)]
struct TractionSide<const D: usize> {
    load: SideTraction<D>,
    /// (particle index, surface per particle, m²: 2D spacing × thickness,
    /// 3D spacing²).
    particles: Vec<(u32, f64)>,
}

impl<const D: usize> Tractions<D> {
    /// After the particle arrays were permuted by `order` (new index k
    /// holds old particle `order[k]`): the sides' particles by their new
    /// indices.
    pub(super) fn renumber(&mut self, order: &[u32]) {
        if self.sides.is_empty() {
            return;
        }
        let mut new_of = vec![0u32; order.len()];
        for (k, &p) in order.iter().enumerate() {
            new_of[p as usize] = k as u32;
        }
        for side in &mut self.sides {
            for (p, _) in &mut side.particles {
                *p = new_of[*p as usize];
            }
        }
    }

    fn new<const V: usize>(scene: &Scene, parts: &Particles<D, V>) -> Tractions<D> {
        let file = &scene.file;
        let b = &file.grid.boundary;
        let spacing: Vec<f64> = (0..file.bodies.len())
            .map(|k| scene.particle_spacing(k))
            .collect();
        let finest = spacing.iter().cloned().fold(f64::INFINITY, f64::min);
        let min = file.grid.min.get::<D>();
        let free = SideCondition::Free;
        let conds = [
            &b.left,
            &b.right,
            &b.bottom,
            &b.top,
            b.back.as_ref().unwrap_or(&free),
            b.front.as_ref().unwrap_or(&free),
        ];
        let mut sides = Vec::new();
        for (k, cond) in conds.into_iter().enumerate().take(2 * D) {
            let SideCondition::Traction { normal, shear } = cond else {
                continue;
            };
            // across = the side's normal axis; the lattice lines run along it
            let (across, sign) = (k / 2, if k % 2 == 0 { -1.0 } else { 1.0 });
            let along: Vec<usize> = (0..D).filter(|&d| d != across).collect();
            let mut best: std::collections::BTreeMap<[i64; 2], usize> =
                std::collections::BTreeMap::new();
            for p in 0..parts.len() {
                let mut key = [0i64; 2];
                for (slot, &d) in along.iter().enumerate() {
                    key[slot] = ((parts.x[p][d] - min[d]) / finest).floor() as i64;
                }
                let e = best.entry(key).or_insert(p);
                if sign * parts.x[p][across] > sign * parts.x[*e][across] {
                    *e = p;
                }
            }
            let particles = best
                .values()
                .map(|&p| {
                    let s = spacing[parts.body[p] as usize];
                    (
                        p as u32,
                        if D == 2 {
                            s * file.analysis.thickness
                        } else {
                            s * s
                        },
                    )
                })
                .collect();
            sides.push(TractionSide {
                load: SideTraction::new(k, normal, shear),
                particles,
            });
        }
        Tractions { sides }
    }

    /// Adds the traction forces at time `t` to the grid, and each nodal
    /// share to `applied` (slot, force): their work is counted once the
    /// grid velocities the particles move with are known
    /// (`Simulation::applied_work`).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn apply<K: Kernel, S: FieldSlots, const V: usize>(
        &self,
        t: f64,
        geom: &GridGeom<D>,
        parts: &Particles<D, V>,
        slots: &S,
        grid: &mut GridFields<D>,
        applied: &mut Vec<(usize, [f64; D])>,
    ) {
        for side in &self.sides {
            let tr = side.load.at(t);
            for &(p, area) in &side.particles {
                let p = p as usize;
                let f = tr.map(|c| c * area);
                particle_support::<K, D, V>(geom, parts, p).for_each(|n| {
                    let s = slots.slot(n.node, p);
                    let fi = f.map(|c| n.w * c);
                    for a in 0..D {
                        grid.force[s][a] += fi[a];
                    }
                    applied.push((s, fi));
                });
            }
        }
    }
}
