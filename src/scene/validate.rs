//! Validation: raw [`SceneFile`] → [`Scene`] with resolved materials, grid
//! dimensions, particle counts and the [`Plan`].

use super::memory::{self, MemoryBudget, MemoryEstimate};
use super::plan::Plan;
use super::schema::*;
use super::{phase_field_gamma, FieldError, ResolvedDamage, SceneError};
use crate::geometry::{self, CrackGeometry, Lattice};
use crate::grid::shape;
use crate::material::ElasticConstants;
use serde::Serialize;
use std::collections::BTreeMap;

/// At most this many distinct contact groups (a node's groups are a bit mask).
pub const MAX_CONTACT_GROUPS: usize = 32;
/// Refuse grids larger than this many nodes (memory).
const MAX_NODES: usize = 50_000_000;
/// Refuse scenes with more particles than this (memory).
const MAX_PARTICLES: usize = 50_000_000;
/// Refuse scenes whose seeding would test more lattice points than this
/// ([`geometry::seed_cost`]): a few seconds of validation at most, however
/// large a lattice a short scene describes.
const MAX_SEED_COST: f64 = 1e9;
/// The default of `time.max_steps`.
pub const DEFAULT_MAX_STEPS: u64 = 10_000_000;

/// A material with its derived constants, as the engine uses it.
#[derive(Debug, Clone, PartialEq)]
pub struct ResolvedMaterial {
    /// The `[materials]` key, or `bodies[i]` for an inline material.
    pub name: String,
    pub model: MaterialModel,
    pub density: f64,
    pub youngs_modulus: f64,
    pub poissons_ratio: f64,
    /// Lamé constants, Pa.
    pub lambda: f64,
    pub mu: f64,
    /// The material's fracture model, if it has one: one at most, so
    /// that "phase field and damage on one material" cannot be held
    /// (validation refuses a material file with both, naming the field).
    pub fracture: Option<MaterialFracture>,
    /// Dilatational wave speed of the 2D model at rest, m/s:
    /// √((λ+2μ)/ρ) in plane strain, √(E/(ρ(1−ν²))) in plane stress.
    pub wave_speed: f64,
}

/// A material's fracture model, from its `phase_field` or `damage`
/// table.
#[derive(Debug, Clone, PartialEq)]
pub enum MaterialFracture {
    /// Phase-field fracture (Kakouris & Triantafyllou).
    PhaseField(PhaseFieldSpec),
    /// A continuum damage model with its derived constants (Homel &
    /// Herbold 2017, section 2.7).
    Damage(ResolvedDamage),
    /// Eigenerosion or eigensoftening (Molinos et al.).
    Eigen(crate::fracture::eigen::section::ResolvedEigen),
}

impl ResolvedMaterial {
    /// Its phase-field parameters, if its fracture model is the phase field.
    pub fn phase_field(&self) -> Option<&PhaseFieldSpec> {
        match &self.fracture {
            Some(MaterialFracture::PhaseField(pf)) => Some(pf),
            _ => None,
        }
    }

    /// Its damage model, if its fracture model is damage.
    pub fn damage(&self) -> Option<&ResolvedDamage> {
        match &self.fracture {
            Some(MaterialFracture::Damage(d)) => Some(d),
            _ => None,
        }
    }

    /// Its eigen model, if its fracture model is eigenerosion or
    /// eigensoftening.
    pub fn eigen(&self) -> Option<&crate::fracture::eigen::section::ResolvedEigen> {
        match &self.fracture {
            Some(MaterialFracture::Eigen(e)) => Some(e),
            _ => None,
        }
    }

    /// Its elastic part, as the material layer takes it
    /// ([`Elastic::new`](crate::material::Elastic::new)).
    pub fn elastic_constants(&self) -> ElasticConstants {
        ElasticConstants {
            model: self.model,
            density: self.density,
            youngs_modulus: self.youngs_modulus,
            poissons_ratio: self.poissons_ratio,
            lambda: self.lambda,
            mu: self.mu,
            wave_speed: self.wave_speed,
        }
    }
}

/// A validated scene, ready to run.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The scene as written (after defaults).
    pub file: SceneFile,
    /// Distinct materials; particles refer to them by index.
    pub materials: Vec<ResolvedMaterial>,
    /// For each body, its index into `materials`.
    pub body_material: Vec<usize>,
    /// For each body, its initial cracks (`cracks`) as the models place
    /// them: polylines in 2D, flat polygons in 3D.
    pub cracks: Vec<Vec<CrackGeometry>>,
    /// Cells along x and y (the grid's `max` is rounded up to whole cells).
    pub cells: [usize; 2],
    /// Cells along z in a 3D scene; None in 2D.
    pub cells_z: Option<usize>,
    /// Particles seeded in each body.
    pub particle_counts: Vec<usize>,
    /// Distinct contact groups, ascending; a body's field index is the
    /// position of its group in this list.
    pub contact_groups: Vec<u32>,
    /// The stages this scene needs.
    pub plan: Plan,
    /// What a run of it is expected to need in memory (checked against the
    /// budget it was validated with).
    pub memory: MemoryEstimate,
    /// The first time step and what sets it.
    pub time_step: TimeStepEstimate,
}

/// The time step a run starts with, as validation estimates it: a fixed
/// `time.dt`, or `time.cfl` × h / (c + |v|) with the fastest body's
/// dilatational wave speed c and its velocity (the formula of the run's
/// `next_dt`; a run's Δt only shrinks from there as particles speed up or a
/// neo-Hookean material stiffens).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TimeStepEstimate {
    /// s.
    pub dt: f64,
    /// The signal speed c + |v| it is set by, m/s (0 with a fixed `dt`).
    pub signal_speed: f64,
    /// The body that sets it (its index), if any.
    pub body: Option<usize>,
    /// Steps to `time.end` at this Δt: fewer than the run takes, never more.
    pub steps: f64,
}

impl Scene {
    pub fn total_particles(&self) -> usize {
        self.particle_counts.iter().sum()
    }

    /// The scene's dimension, 2 or 3 ([`SceneFile::dimension`]).
    pub fn dimension(&self) -> usize {
        self.file.dimension()
    }

    /// The cells along each axis: x and y, and z in 3D.
    pub fn cell_counts(&self) -> Vec<usize> {
        let mut cells = self.cells.to_vec();
        cells.extend(self.cells_z);
        cells
    }

    /// The seeding lattice of body `b` in a 2D scene.
    pub fn lattice(&self, b: usize) -> Lattice {
        lattice_of(&self.file.grid, self.cells, self.ppc(b))
    }

    /// The seeding lattice of body `b` in a 3D scene.
    pub fn lattice_3d(&self, b: usize) -> Lattice<3> {
        lattice_3d_of(&self.file.grid, self.cells_3d(), self.ppc(b))
    }

    /// The distance between neighbouring particles of body `b` as seeded.
    pub fn particle_spacing(&self, b: usize) -> f64 {
        self.file.grid.cell_size / per_dir(self.ppc(b), self.dimension()) as f64
    }

    /// The particles per cell of body `b` (validation writes the default in).
    fn ppc(&self, b: usize) -> u32 {
        self.file.bodies[b].ppc(self.dimension())
    }

    fn cells_3d(&self) -> [usize; 3] {
        [self.cells[0], self.cells[1], self.cells_z.unwrap_or(0)]
    }

    /// Validates a parsed scene; reports every problem found. Its memory
    /// estimate is checked against what this process may use
    /// ([`MemoryBudget::process`]).
    pub fn validate(file: SceneFile) -> Result<Scene, SceneError> {
        Scene::validate_within(file, &MemoryBudget::process())
    }

    /// [`Scene::validate`] with the memory estimate checked against
    /// `budget` (a server passes its own, with the process's:
    /// `MemoryBudget::process().min(MemoryBudget::of(bytes, "..."))`).
    ///
    /// Its cost is bounded whatever lattice the scene describes: every
    /// body's particles are estimated from its area before any is seeded,
    /// and the seeding's work from its bounding box, its holes and its
    /// polygons' edges ([`geometry::seed_cost`]).
    pub fn validate_within(
        mut file: SceneFile,
        budget: &MemoryBudget,
    ) -> Result<Scene, SceneError> {
        let mut c = Checker::default();
        let dim = file.dimension();
        write_defaults(&mut file, dim);
        let cells3 = check_grid(&mut c, &file.grid, dim);
        let cells = [cells3[0], cells3[1]];
        let cells_z = (dim == 3).then_some(cells3[2]);
        if dim == 3 {
            let [plane, thickness] = file.analysis.written();
            for (key, written) in [("plane", plane), ("thickness", thickness)] {
                if written {
                    c.err(
                        &format!("analysis.{key}"),
                        "is a 2D setting (plane strain or plane stress, and the out-of-plane \
                         thickness), but the grid is 3D (grid.max has 3 components) and a 3D \
                         scene is fully three-dimensional: remove it",
                    );
                }
            }
        } else {
            c.positive("analysis.thickness", file.analysis.thickness);
        }
        check_time(&mut c, &file.time);
        c.in_range("transfer.flip_blend", file.transfer.flip_blend, 0.0, 1.0);
        c.vector("body_force", file.body_force, dim);
        check_output_and_guards(&mut c, &file);
        check_resort(&mut c, &file);

        // Materials: named ones first, then inline ones per body.
        let mut materials = Vec::new();
        let mut by_name = BTreeMap::new();
        for (name, spec) in &file.materials {
            let path = format!("materials.{name}");
            if let Some(m) = resolve_material(
                &mut c,
                &path,
                name,
                spec,
                file.analysis.plane,
                file.grid.cell_size,
                dim,
            ) {
                by_name.insert(name.clone(), materials.len());
                materials.push(m);
            }
        }
        if file.bodies.is_empty() {
            c.err(
                "bodies",
                "the scene has no bodies: add at least one [[bodies]] entry",
            );
        }
        let mut body_material = Vec::with_capacity(file.bodies.len());
        let mut cracks = Vec::with_capacity(file.bodies.len());
        let mut seedable = Vec::with_capacity(file.bodies.len());
        let mut groups = std::collections::BTreeSet::new();
        for (i, body) in file.bodies.iter().enumerate() {
            let path = format!("bodies[{i}]");
            let mat = match &body.material {
                MaterialRef::Name(name) => match by_name.get(name) {
                    Some(&k) => Some(k),
                    None => {
                        if !file.materials.contains_key(name) {
                            let known: Vec<_> = file.materials.keys().map(String::as_str).collect();
                            c.err(
                                &format!("{path}.material"),
                                format!(
                                    "no material named `{name}` in [materials] (known: {})",
                                    list_or_none(&known)
                                ),
                            );
                        }
                        None
                    }
                },
                MaterialRef::Inline(spec) => resolve_material(
                    &mut c,
                    &format!("{path}.material"),
                    &path,
                    spec,
                    file.analysis.plane,
                    file.grid.cell_size,
                    dim,
                )
                .map(|m| {
                    materials.push(m);
                    materials.len() - 1
                }),
            };
            if let Some(m) = mat.and_then(|k| materials.get(k)) {
                // a particle's mass must survive in f64: a zero or subnormal
                // one divides nodal momenta by zero
                let s = file.grid.cell_size / per_dir(body.ppc(dim), dim) as f64;
                if dim == 3 {
                    let mass = m.density * s * s * s;
                    if s > 0.0 && !mass.is_normal() {
                        c.err(
                            &format!("{path}.material"),
                            format!("a particle's mass, density {:e} kg/m³ × spacing³ {:e} m³, is {mass:e} kg: beyond f64's range", m.density, s * s * s),
                        );
                    }
                } else {
                    let t = file.analysis.thickness;
                    let mass = m.density * s * s * t;
                    if t.is_finite() && t > 0.0 && s > 0.0 && !mass.is_normal() {
                        c.err(
                            &format!("{path}.material"),
                            format!("a particle's mass, density {:e} kg/m³ × spacing² {:e} m² × thickness {t:e} m, is {mass:e} kg: beyond f64's range", m.density, s * s),
                        );
                    }
                }
            }
            if mat.is_some() {
                let pf = phase_field_of(&file, &body.material);
                if let Some(pf) = pf {
                    let spacing = file.grid.cell_size / per_dir(body.ppc(dim), dim) as f64;
                    for (k, crack) in body.cracks.iter().enumerate() {
                        // a row of particles then lies within l0/4 of the line,
                        // with at least half the band's peak history
                        if crack.profile == CrackProfile::Borden && spacing > 0.5 * pf.l0 {
                            c.err(
                                &format!("{path}.cracks[{k}].profile"),
                                format!("the borden profile lays history within l0/2 = {:e} m of the crack, falling to 0 there, and needs particles at most l0/2 apart, but they are {spacing:e} m apart: use the line profile or more particles per cell", pf.l0 / 2.0),
                            );
                        }
                    }
                    let fourth = !phase_field_gamma(pf).is_zero();
                    let kind = file.grid.shape_function;
                    if fourth
                        && !matches!(
                            kind,
                            ShapeFunctionKind::QuadraticBspline | ShapeFunctionKind::CubicBspline
                        )
                    {
                        c.err(
                            "grid.shape_function",
                            format!("the 4th-order phase field of {path} needs second derivatives: use quadratic_bspline or cubic_bspline, not {:?}", kind.name()),
                        );
                    }
                } else if !body.cracks.is_empty()
                    && file.method.is_grid_mpm()
                    && !breaks(&file, &body.material)
                {
                    c.err(
                        &format!("{path}.cracks"),
                        "initial cracks need a material with a phase_field, damage or eigen model",
                    );
                } else if body.crack_origin.is_some() && !breaks(&file, &body.material) {
                    c.err(
                        &format!("{path}.crack_origin"),
                        "a crack-tip origin needs a material with a phase_field, damage or eigen model",
                    );
                }
            }
            if let Some(o) = body.crack_origin {
                c.vector(&format!("{path}.crack_origin"), o, dim);
            }
            let mut body_cracks = Vec::new();
            for (k, crack) in body.cracks.iter().enumerate() {
                if crack.profile == CrackProfile::Borden && breaks(&file, &body.material) {
                    c.err(&format!("{path}.cracks[{k}].profile"), "the borden profile is an initial history field: it is for phase-field materials, not damage or eigen models");
                }
                if dim == 2 && crack.points.len() < 2 {
                    c.err(
                        &format!("{path}.cracks[{k}].points"),
                        format!(
                            "a crack needs at least 2 points, got {}",
                            crack.points.len()
                        ),
                    );
                }
                let mut ok = true;
                for (q, pt) in crack.points.iter().enumerate() {
                    ok &= c.vector(&format!("{path}.cracks[{k}].points[{q}]"), *pt, dim);
                }
                if ok {
                    match CrackGeometry::new(&crack.points, dim) {
                        Ok(g) => body_cracks.push(g),
                        Err(why) => c.err(&format!("{path}.cracks[{k}].points"), why),
                    }
                }
            }
            cracks.push(body_cracks);
            body_material.push(mat.unwrap_or(usize::MAX));
            groups.insert(body.contact_group);
            seedable.push(check_body(&mut c, &path, body, &file.grid, dim, cells3));
            check_drive(&mut c, &path, body, dim, file.method);
        }
        let particle_counts = count_particles(&mut c, &file, cells3, &seedable);
        if groups.len() > MAX_CONTACT_GROUPS {
            c.err(
                "bodies",
                format!(
                    "{} contact groups; at most {MAX_CONTACT_GROUPS} are supported",
                    groups.len()
                ),
            );
        }
        check_contact(&mut c, &file.contact, &groups);
        check_newmark(&mut c, &file);
        let eigen_body = file.bodies.iter().position(|b| {
            file.material_of(&b.material)
                .is_some_and(|m| m.eigen.is_some())
        });
        if let Some(b) = eigen_body {
            if file.bodies.iter().any(|b| has_damage(&file, &b.material)) {
                c.err(
                    &format!("bodies[{b}].material"),
                    "a scene runs continuum damage or an eigen model, not both (their fragments and crack tips would be counted twice)",
                );
            }
            if file.dfg.is_some() {
                c.err(
                    "dfg",
                    format!("partitioning reads damage and the phase field, not the eigen models' χ (bodies[{b}]): not supported yet"),
                );
            }
        }
        if let Some(dfg) = &file.dfg {
            let any_fracture = file.bodies.iter().any(|b| {
                has_damage(&file, &b.material) || phase_field_of(&file, &b.material).is_some()
            });
            crate::fracture::dfg::section::check(
                &mut c,
                dfg,
                groups.len(),
                MAX_CONTACT_GROUPS,
                any_fracture,
            );
        }

        {
            let bodies: Vec<_> = file
                .bodies
                .iter()
                .map(|b| (&b.shape, b.explicit_cracks.as_slice()))
                .collect();
            let xy = |v: &Vector| {
                let c = v.components();
                [
                    c.first().copied().unwrap_or(0.0),
                    c.get(1).copied().unwrap_or(0.0),
                ]
            };
            let (lo, hi) = (xy(&file.grid.min), xy(&file.grid.max));
            crate::fracture::cracks::section::check(
                &mut c,
                &bodies,
                dim,
                groups.len(),
                (lo, hi, file.grid.cell_size),
                file.cramp.as_ref(),
                file.dfg.is_some(),
            );
        }

        let mut particle_counts = particle_counts;
        if file.method == MethodKind::DamageParticle {
            let models: Vec<_> = body_material
                .iter()
                .map(|&k| materials.get(k).map(|m: &ResolvedMaterial| m.model))
                .collect();
            particle_counts =
                crate::dpm::section::check(&mut c, &file, &models, cells3, &particle_counts);
        } else if file.damage_particle.is_some() {
            c.err(
                "damage_particle",
                "is the damage particle method's table: add method = \"damage_particle\" (the scene runs the grid MPM)",
            );
        }

        if !c.errors.is_empty() {
            return Err(SceneError { errors: c.errors });
        }
        let time_step = check_time_step(&mut c, &file, &materials, &body_material);
        let contact_groups: Vec<u32> = groups.into_iter().collect();
        let memory = memory::estimate(
            &file,
            cells3,
            &particle_counts,
            &materials,
            &body_material,
            contact_groups.len(),
        );
        if let Some((limit, what)) = &budget.limit {
            if memory.total() > *limit {
                c.err(
                    "bodies",
                    format!(
                        "a run needs {memory}, more than the {} that {what} allows: \
                         use fewer particles (a coarser grid.cell_size or fewer particles_per_cell) or more memory",
                        memory::human_bytes(*limit)
                    ),
                );
            }
        }
        if !c.errors.is_empty() {
            return Err(SceneError { errors: c.errors });
        }
        let plan = Plan::build(&file, &contact_groups);
        Ok(Scene {
            file,
            materials,
            body_material,
            cracks,
            cells,
            cells_z,
            particle_counts,
            contact_groups,
            plan,
            memory,
            time_step,
        })
    }

    /// The effective time step limit factor: `time.cfl`, or 0.5 by default.
    pub fn cfl(&self) -> f64 {
        self.file.time.cfl.unwrap_or(0.5)
    }
}

/// Particles per direction for a per-cell count (a perfect square in 2D,
/// a perfect cube in 3D).
fn per_dir(ppc: u32, dim: usize) -> usize {
    let n = if dim == 3 {
        (ppc as f64).cbrt()
    } else {
        (ppc as f64).sqrt()
    };
    (n.round() as usize).max(1)
}

/// The seeding lattice of a body with `ppc` particles per cell on a 2D grid.
fn lattice_of(grid: &GridSpec, cells: [usize; 2], ppc: u32) -> Lattice {
    Lattice {
        origin: grid.min.xy(),
        h: grid.cell_size,
        cells,
        per_dir: per_dir(ppc, 2),
    }
}

/// The seeding lattice of a body with `ppc` particles per cell on a 3D grid.
fn lattice_3d_of(grid: &GridSpec, cells: [usize; 3], ppc: u32) -> Lattice<3> {
    Lattice {
        origin: grid.min.xyz(),
        h: grid.cell_size,
        cells,
        per_dir: per_dir(ppc, 3),
    }
}

/// Writes the defaults that depend on the scene's dimension into a
/// parsed scene: the vectors left out become zeros of `dim` components,
/// a body's `particles_per_cell` its dimension's default, and a 2D
/// scene's `[analysis]` keys their defaults. A validated scene then
/// serialises every key it always has (a checkpoint compares the scene
/// it was written with key by key), and a 3D one none of the 2D keys.
fn write_defaults(file: &mut SceneFile, dim: usize) {
    file.grid.min = file.grid.min.or_zero(dim);
    file.body_force = file.body_force.or_zero(dim);
    if dim == 2 {
        file.analysis.write_defaults();
    }
    for body in &mut file.bodies {
        body.velocity = body.velocity.or_zero(dim);
        body.velocity_gradient = body.velocity_gradient.or_zero(dim);
        // the damage particle method has one particle per lattice vertex:
        // a written count is refused, not filled in
        if file.method == MethodKind::GridMpm {
            body.particles_per_cell = Some(body.ppc(dim));
        }
    }
}

/// Whether a body's material has a damage model.
fn has_damage(file: &SceneFile, m: &MaterialRef) -> bool {
    file.material_of(m).is_some_and(|s| s.damage.is_some())
}

/// Whether a body's material breaks particles (continuum damage or an
/// eigen model): initial cracks are then broken particles.
fn breaks(file: &SceneFile, m: &MaterialRef) -> bool {
    file.material_of(m)
        .is_some_and(|s| s.damage.is_some() || s.eigen.is_some())
}

/// The phase-field spec of a body's material, if any.
fn phase_field_of<'a>(file: &'a SceneFile, m: &'a MaterialRef) -> Option<&'a PhaseFieldSpec> {
    file.material_of(m).and_then(|s| s.phase_field.as_ref())
}

fn list_or_none(names: &[&str]) -> String {
    if names.is_empty() {
        "none".to_string()
    } else {
        names.join(", ")
    }
}

/// Collects the errors of a scene's validation, each naming its field
/// (the fracture models' section checks write into it too).
#[derive(Default)]
pub(crate) struct Checker {
    pub(crate) errors: Vec<FieldError>,
}

impl Checker {
    pub(crate) fn err(&mut self, path: &str, reason: impl Into<String>) {
        self.errors.push(FieldError {
            path: path.to_string(),
            reason: reason.into(),
        });
    }
    pub(crate) fn finite(&mut self, path: &str, v: f64) -> bool {
        if v.is_finite() {
            true
        } else {
            self.err(path, format!("must be a finite number, got {v}"));
            false
        }
    }
    pub(crate) fn positive(&mut self, path: &str, v: f64) -> bool {
        if !self.finite(path, v) {
            return false;
        }
        if v > 0.0 {
            true
        } else {
            self.err(path, format!("must be > 0, got {v}"));
            false
        }
    }
    pub(crate) fn in_range(&mut self, path: &str, v: f64, lo: f64, hi: f64) -> bool {
        if !self.finite(path, v) {
            return false;
        }
        if v >= lo && v <= hi {
            true
        } else {
            self.err(path, format!("must be in [{lo}, {hi}], got {v}"));
            false
        }
    }
    fn point(&mut self, path: &str, p: [f64; 2]) -> bool {
        let a = self.finite(&format!("{path}[0]"), p[0]);
        let b = self.finite(&format!("{path}[1]"), p[1]);
        a && b
    }
    /// A scene vector: `dim` components (the grid's dimension), each finite.
    fn vector(&mut self, path: &str, v: Vector, dim: usize) -> bool {
        if v.len() != dim {
            self.err(
                path,
                format!(
                    "has {} components, but the grid is {dim}D (grid.max has {dim})",
                    v.len()
                ),
            );
            return false;
        }
        let mut ok = true;
        for (d, x) in v.components().iter().enumerate() {
            ok &= self.finite(&format!("{path}[{d}]"), *x);
        }
        ok
    }
    /// A scene matrix: `dim` rows of `dim` finite components.
    fn matrix(&mut self, path: &str, m: &Matrix, dim: usize) -> bool {
        if m.rows().len() != dim {
            self.err(
                path,
                format!(
                    "has {} rows, but the grid is {dim}D (grid.max has {dim}): write {dim} rows of {dim}",
                    m.rows().len()
                ),
            );
            return false;
        }
        let mut ok = true;
        for (r, row) in m.rows().iter().enumerate() {
            ok &= self.vector(&format!("{path}[{r}]"), *row, dim);
        }
        ok
    }
    pub(crate) fn time_function(&mut self, path: &str, f: &TimeFunction) {
        match f {
            TimeFunction::Constant(v) => {
                self.finite(path, *v);
            }
            TimeFunction::Table { table } => {
                if table.is_empty() {
                    self.err(
                        &format!("{path}.table"),
                        "must have at least one [time, value] pair",
                    );
                }
                for (k, pair) in table.iter().enumerate() {
                    self.point(&format!("{path}.table[{k}]"), *pair);
                    if k > 0 && pair[0] < table[k - 1][0] {
                        self.err(
                            &format!("{path}.table[{k}]"),
                            format!(
                                "times must not decrease, got {} after {}",
                                pair[0],
                                table[k - 1][0]
                            ),
                        );
                    }
                }
            }
        }
    }
}

/// `grid.lme_gamma`: only with LME, and in the range whose support fits
/// the engine's four-node stencils ([`shape::Lme`]).
fn check_lme(c: &mut Checker, g: &GridSpec) {
    let Some(gamma) = g.lme_gamma else {
        return;
    };
    if g.shape_function != ShapeFunctionKind::Lme {
        c.err(
            "grid.lme_gamma",
            format!(
                "the LME locality applies to shape_function = \"lme\" only, not {:?}",
                g.shape_function.name()
            ),
        );
    } else if !(shape::LME_GAMMA_MIN..=shape::LME_GAMMA_MAX).contains(&gamma) {
        c.err(
            "grid.lme_gamma",
            format!(
                "{gamma} is outside [{:.4}, {}]: below, the nodes beyond the four-node support would \
                 carry more than 1e-6 of the weight (wider supports are not supported); above, \
                 the functions are the linear hat's (use shape_function = \"linear\")",
                shape::LME_GAMMA_MIN,
                shape::LME_GAMMA_MAX
            ),
        );
    }
}

/// The grid's cells along x, y and (in 3D) z; zeros when it is refused.
fn check_grid(c: &mut Checker, g: &GridSpec, dim: usize) -> [usize; 3] {
    let mut cells = [0usize; 3];
    let h_ok = c.positive("grid.cell_size", g.cell_size);
    check_lme(c, g);
    let min_ok = c.vector("grid.min", g.min, dim);
    let max_ok = c.vector("grid.max", g.max, dim);
    if !(h_ok && min_ok && max_ok) {
        return cells;
    }
    let axis = ["x", "y", "z"];
    for d in 0..dim {
        let len = g.max[d] - g.min[d];
        if len < g.cell_size {
            c.err(
                &format!("grid.max[{d}]"),
                format!(
                    "the grid must be at least one cell wide along {}: min {} max {} cell_size {}",
                    axis[d], g.min[d], g.max[d], g.cell_size
                ),
            );
            return [0; 3];
        }
        let n = (len / g.cell_size - 1e-9).ceil();
        if n > 1e8 {
            c.err(
                "grid.cell_size",
                format!("{n} cells along {} is too many", axis[d]),
            );
            return [0; 3];
        }
        cells[d] = n as usize;
    }
    // in f64: 3 axes of up to 1e8 cells overflow usize
    let nodes: f64 = cells[..dim].iter().map(|&n| n as f64 + 1.0).product();
    if nodes > MAX_NODES as f64 {
        let list: Vec<String> = cells[..dim].iter().map(usize::to_string).collect();
        c.err(
            "grid.cell_size",
            format!(
                "{} cells is more than the {MAX_NODES}-node limit",
                list.join(" × ")
            ),
        );
        return [0; 3];
    }
    let mut sides = vec![
        ("left", Some(&g.boundary.left)),
        ("right", Some(&g.boundary.right)),
        ("bottom", Some(&g.boundary.bottom)),
        ("top", Some(&g.boundary.top)),
    ];
    for (name, side) in [("back", &g.boundary.back), ("front", &g.boundary.front)] {
        if dim == 2 && side.is_some() {
            c.err(
                &format!("grid.boundary.{name}"),
                "is a side normal to z, but the grid is 2D (grid.max has 2 components): \
                 only left, right, bottom and top exist",
            );
        }
        sides.push((name, side.as_ref()));
    }
    for (name, side) in sides {
        let path = format!("grid.boundary.{name}");
        match side {
            Some(SideCondition::Velocity { x, y, z }) => {
                velocity_components(c, &path, "a velocity condition", [x, y, z], dim);
            }
            Some(SideCondition::Traction { normal, shear }) => {
                if normal.is_none() && shear.is_none() {
                    c.err(&path, "a traction condition needs `normal` and/or `shear`");
                }
                if let Some(f) = normal {
                    c.time_function(&format!("{path}.normal"), f);
                }
                if let Some(f) = shear {
                    c.time_function(&format!("{path}.shear"), f);
                }
            }
            _ => {}
        }
    }
    cells
}

/// The components of a prescribed velocity (a side's, a driven body's):
/// at least one, each a valid function of time, `z` only in 3D.
fn velocity_components(
    c: &mut Checker,
    path: &str,
    what: &str,
    [x, y, z]: [&Option<TimeFunction>; 3],
    dim: usize,
) {
    if x.is_none() && y.is_none() && z.is_none() {
        let which = if dim == 3 {
            "`x`, `y` and/or `z`"
        } else {
            "`x` and/or `y`"
        };
        c.err(path, format!("{what} needs {which}"));
    }
    if let Some(f) = x {
        c.time_function(&format!("{path}.x"), f);
    }
    if let Some(f) = y {
        c.time_function(&format!("{path}.y"), f);
    }
    if let Some(f) = z {
        if dim == 2 {
            c.err(
                &format!("{path}.z"),
                "a z velocity needs a 3D grid (grid.max has 2 components)",
            );
        } else {
            c.time_function(&format!("{path}.z"), f);
        }
    }
}

/// A driven body's `drive` ([`BodySpec::drive`]): its components, a grid
/// MPM scene, and a name that cannot be taken for a side's in the
/// reaction columns.
fn check_drive(c: &mut Checker, path: &str, body: &BodySpec, dim: usize, method: MethodKind) {
    let Some(d) = &body.drive else { return };
    let path = format!("{path}.drive");
    velocity_components(c, &path, "a drive", [&d.x, &d.y, &d.z], dim);
    if method == MethodKind::DamageParticle {
        c.err(
            &path,
            "drives grid nodes, and the damage particle method has no grid",
        );
    }
    const SIDES: [&str; 6] = ["left", "right", "bottom", "top", "back", "front"];
    if SIDES.contains(&body.name.as_str()) {
        c.err(
            &path,
            format!(
                "a driven body's reaction columns are named after it, and `{}` names a grid side: rename the body",
                body.name
            ),
        );
    }
}

fn check_time(c: &mut Checker, t: &TimeSpec) {
    c.positive("time.end", t.end);
    match (t.cfl, t.dt) {
        (Some(_), Some(_)) => c.err("time", "give either `cfl` or `dt`, not both"),
        (Some(cfl), None) => {
            if c.positive("time.cfl", cfl) && cfl > 1.0 {
                c.err(
                    "time.cfl",
                    format!("must be <= 1, got {cfl}: explicit MPM is unstable when a wave crosses more than one cell per step"),
                );
            }
        }
        (None, Some(dt)) => {
            if c.positive("time.dt", dt) && t.end.is_finite() && t.end > 0.0 {
                let steps = (t.end / dt).ceil();
                let cap = t.max_steps.unwrap_or(DEFAULT_MAX_STEPS) as f64;
                if steps > cap {
                    c.err(
                        "time.dt",
                        format!(
                            "{dt} s over {} s is {steps} steps, more than max_steps = {cap}",
                            t.end
                        ),
                    );
                }
            }
        }
        (None, None) => {}
    }
    if t.max_steps == Some(0) {
        c.err("time.max_steps", "must be >= 1, got 0");
    }
}

/// The Newmark predictor–corrector's γ and what it runs with: the velocity
/// fields of contact groups (contacted on the predictor and on the
/// corrector), but not those DFG or explicit cracks split a body into
/// (their contact passes are written for usl and musl), no phase field
/// (whose stagger re-solves on the step's own nodal state), and the
/// particle update of its own (PIC/FLIP blend only: APIC, XPIC(1) and
/// FMPM(1) are other particle updates).
fn check_newmark(c: &mut Checker, file: &SceneFile) {
    let t = &file.transfer;
    let Some(gamma) = t.newmark() else {
        if t.newmark_gamma.is_some() {
            c.err(
                "transfer.newmark_gamma",
                "is the Newmark predictor-corrector's gamma: give it with stress_update = \"newmark\" or remove it",
            );
        }
        return;
    };
    let why = "the Newmark predictor-corrector (transfer.stress_update = \"newmark\")";
    if c.finite("transfer.newmark_gamma", gamma) && !(0.5..=1.0).contains(&gamma) {
        c.err(
            "transfer.newmark_gamma",
            format!("must be in [0.5, 1], got {gamma}: below 0.5 the explicit scheme amplifies every mode, 0.5 is second order, above it damps"),
        );
    }
    if matches!(
        t.scheme,
        TransferKind::Apic | TransferKind::Xpic1 | TransferKind::Fmpm1
    ) {
        c.err(
            "transfer.scheme",
            format!("{why} has its own particle update (blended with PIC by flip_blend): use scheme = \"flip\" or \"pic\""),
        );
    }
    if file.dfg.is_some() {
        c.err(
            "dfg",
            format!(
                "{why} contacts the fields of contact groups, not DFG's partition: use usl or musl"
            ),
        );
    }
    if let Some(b) = file
        .bodies
        .iter()
        .position(|b| !b.explicit_cracks.is_empty())
    {
        c.err(
            &format!("bodies[{b}].explicit_cracks"),
            format!("{why} contacts the fields of contact groups, not the fields of explicit cracks: use usl or musl"),
        );
    }
    if let Some(b) = file
        .bodies
        .iter()
        .position(|b| phase_field_of(file, &b.material).is_some())
    {
        c.err(
            &format!("bodies[{b}].material"),
            format!("{why} does not run the phase field (its staggered solves are written for usl and musl): use usl or musl"),
        );
    }
}

/// `grid.resort_every` permutes the particle arrays, which the fracture
/// models' per-particle state and particle lists would have to follow
/// (not built yet), and needs the grid's tiles.
fn check_resort(c: &mut Checker, file: &SceneFile) {
    if file.grid.resort_every == 0 {
        return;
    }
    if file.method == MethodKind::DamageParticle {
        c.err(
            "grid.resort_every",
            "the damage particle method has no grid tiles to sort its particles by: remove it",
        );
        return;
    }
    let model = file.bodies.iter().find_map(|b| {
        if !b.explicit_cracks.is_empty() {
            return Some("explicit cracks");
        }
        let m = file.material_of(&b.material)?;
        if m.phase_field.is_some() {
            Some("a phase field")
        } else if m.damage.is_some() {
            Some("a damage model")
        } else if m.eigen.is_some() {
            Some("an eigen model")
        } else {
            None
        }
    });
    if let Some(model) = model.or(file.dfg.as_ref().map(|_| "[dfg]")) {
        c.err(
            "grid.resort_every",
            format!(
                "the scene has {model}, whose per-particle state does not follow a re-sort \
                 yet; the re-sort runs in scenes without fracture models: remove it"
            ),
        );
    }
}

fn check_output_and_guards(c: &mut Checker, file: &SceneFile) {
    if file.output.body_momenta {
        // each body's columns are named by the body: names must tell them apart
        let mut seen = std::collections::BTreeSet::new();
        for (i, b) in file.bodies.iter().enumerate() {
            if !b.name.is_empty() && !seen.insert(b.name.as_str()) {
                c.err(
                    &format!("bodies[{i}].name"),
                    format!("`{}` names another body too, and output.body_momenta names each body's columns by it: give the bodies distinct names", b.name),
                );
            }
        }
    }
    let pf = &file.phase_field_solver;
    if c.finite("phase_field_solver.tolerance", pf.tolerance)
        && !(pf.tolerance > 0.0 && pf.tolerance < 1.0)
    {
        c.err(
            "phase_field_solver.tolerance",
            format!("must be in (0, 1), got {}", pf.tolerance),
        );
    }
    if pf.max_iterations == 0 {
        c.err("phase_field_solver.max_iterations", "must be >= 1, got 0");
    }
    if !(1..=100).contains(&pf.max_staggers) {
        c.err(
            "phase_field_solver.max_staggers",
            format!("must be in [1, 100], got {}", pf.max_staggers),
        );
    }
    if c.finite("phase_field_solver.stagger_tolerance", pf.stagger_tolerance)
        && !(pf.stagger_tolerance > 0.0)
    {
        c.err(
            "phase_field_solver.stagger_tolerance",
            format!("must be > 0, got {}", pf.stagger_tolerance),
        );
    }
    if file.output.series_rows < 2 || file.output.series_rows > 10_000_000 {
        c.err(
            "output.series_rows",
            format!("must be in [2, 10000000], got {}", file.output.series_rows),
        );
    }
    let fd = file.output.fragment_damage;
    if !(fd > 0.0 && fd <= 1.0) {
        c.err(
            "output.fragment_damage",
            format!("must be in (0, 1], got {fd}"),
        );
    }
    if file.output.snapshots > 100_000 {
        c.err(
            "output.snapshots",
            format!("must be <= 100000, got {}", file.output.snapshots),
        );
    }
    if c.finite("guards.energy_growth", file.guards.energy_growth)
        && file.guards.energy_growth <= 1.0
    {
        c.err(
            "guards.energy_growth",
            format!("must be > 1, got {}", file.guards.energy_growth),
        );
    }
    let f = file.guards.min_node_mass_fraction;
    if c.finite("guards.min_node_mass_fraction", f) && !(0.0..1.0).contains(&f) {
        c.err(
            "guards.min_node_mass_fraction",
            format!("must be in [0, 1), got {f}"),
        );
    }
}

fn resolve_material(
    c: &mut Checker,
    path: &str,
    name: &str,
    m: &MaterialSpec,
    plane: PlaneKind,
    h: f64,
    dim: usize,
) -> Option<ResolvedMaterial> {
    let before = c.errors.len();
    c.positive(&format!("{path}.density"), m.density);
    c.positive(&format!("{path}.youngs_modulus"), m.youngs_modulus);
    let nu = m.poissons_ratio;
    if c.finite(&format!("{path}.poissons_ratio"), nu) && !(nu > -1.0 && nu < 0.5) {
        c.err(
            &format!("{path}.poissons_ratio"),
            format!("must be in (-1, 0.5), got {nu}"),
        );
    }
    if let Some(pf) = &m.phase_field {
        crate::fracture::phase_field::section::check(c, path, pf, m.model, plane, dim);
    }
    let damage = m.damage.as_ref().and_then(|d| {
        crate::fracture::damage::section::resolve(
            c,
            &format!("{path}.damage"),
            d,
            m.model,
            m.youngs_modulus,
            h,
            dim,
        )
    });
    let eigen = m.eigen.as_ref().and_then(|e| {
        crate::fracture::eigen::section::resolve(c, &format!("{path}.eigen"), e, m, plane, h, dim)
    });
    let given: Vec<&str> = [
        ("phase_field", m.phase_field.is_some()),
        ("damage", m.damage.is_some()),
        ("eigen", m.eigen.is_some()),
    ]
    .into_iter()
    .filter_map(|(k, g)| g.then_some(k))
    .collect();
    if given.len() > 1 {
        c.err(
            &format!("{path}.{}", given[1]),
            format!(
                "a material has one fracture model (phase_field, damage or eigen), this one has {}",
                given.join(" and ")
            ),
        );
    }
    if m.model == MaterialModel::NeoHookean && plane == PlaneKind::PlaneStress {
        c.err(
            &format!("{path}.model"),
            "neo_hookean is implemented for analysis.plane = \"plane_strain\" only",
        );
    }
    if c.errors.len() > before {
        return None;
    }
    let (e, rho) = (m.youngs_modulus, m.density);
    let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    let mu = e / (2.0 * (1.0 + nu));
    if !(lambda.is_finite() && mu.is_finite()) {
        c.err(
            &format!("{path}.youngs_modulus"),
            format!("the Lamé constants λ = {lambda:e} Pa, μ = {mu:e} Pa of E = {e:e} Pa and ν = {nu} are beyond f64's range"),
        );
        return None;
    }
    let wave_speed = match plane {
        PlaneKind::PlaneStrain => ((lambda + 2.0 * mu) / rho).sqrt(),
        PlaneKind::PlaneStress => (e / (rho * (1.0 - nu * nu))).sqrt(),
    };
    Some(ResolvedMaterial {
        name: name.to_string(),
        model: m.model,
        density: rho,
        youngs_modulus: e,
        poissons_ratio: nu,
        lambda,
        mu,
        fracture: match (&m.phase_field, damage, eigen) {
            (Some(pf), None, None) => Some(MaterialFracture::PhaseField(pf.clone())),
            (None, Some(d), None) => Some(MaterialFracture::Damage(d)),
            (None, None, Some(e)) => Some(MaterialFracture::Eigen(e)),
            // more than one was refused above
            _ => None,
        },
        wave_speed,
    })
}

pub(crate) fn check_shape(c: &mut Checker, path: &str, s: &ShapeSpec, dim: usize) -> bool {
    let before = c.errors.len();
    if !matches!(s, ShapeSpec::Box { .. }) && s.dimension() != dim {
        let (kind, instead) = if dim == 3 {
            ("2D", "sphere, cylinder, prism or box")
        } else {
            ("3D", "disk, ring, polygon, slot or box")
        };
        c.err(
            &format!("{path}.type"),
            format!(
                "{} is a {kind} shape, but the grid is {dim}D (grid.max has {dim} components): use {instead}",
                s.type_name()
            ),
        );
        return false;
    }
    match s {
        ShapeSpec::Box { min, max } => {
            if c.vector(&format!("{path}.min"), *min, dim)
                && c.vector(&format!("{path}.max"), *max, dim)
                && (0..dim).any(|d| max[d] <= min[d])
            {
                let axes = if dim == 3 { "x, y and z" } else { "x and y" };
                c.err(
                    path,
                    format!("max must exceed min in {axes}, got min {min:?} max {max:?}"),
                );
            }
        }
        ShapeSpec::Disk { center, radius } => {
            c.vector(&format!("{path}.center"), *center, 2);
            c.positive(&format!("{path}.radius"), *radius);
        }
        ShapeSpec::Ring {
            center,
            inner_radius,
            outer_radius,
        } => {
            c.vector(&format!("{path}.center"), *center, 2);
            let a = c.finite(&format!("{path}.inner_radius"), *inner_radius);
            let b = c.positive(&format!("{path}.outer_radius"), *outer_radius);
            if a && *inner_radius < 0.0 {
                c.err(
                    &format!("{path}.inner_radius"),
                    format!("must be >= 0, got {inner_radius}"),
                );
            }
            if a && b && inner_radius >= outer_radius {
                c.err(
                    &format!("{path}.inner_radius"),
                    format!("must be less than outer_radius {outer_radius}, got {inner_radius}"),
                );
            }
        }
        ShapeSpec::Polygon { vertices } => check_polygon(c, path, vertices),
        ShapeSpec::Slot { start, end, width } => {
            let a = c.vector(&format!("{path}.start"), *start, 2);
            let b = c.vector(&format!("{path}.end"), *end, 2);
            c.positive(&format!("{path}.width"), *width);
            if a && b && start == end {
                c.err(&format!("{path}.end"), "must differ from start");
            }
        }
        ShapeSpec::Sphere { center, radius } => {
            c.vector(&format!("{path}.center"), *center, 3);
            c.positive(&format!("{path}.radius"), *radius);
        }
        ShapeSpec::Cylinder { start, end, radius } => {
            let a = c.vector(&format!("{path}.start"), *start, 3);
            let b = c.vector(&format!("{path}.end"), *end, 3);
            c.positive(&format!("{path}.radius"), *radius);
            if a && b && start == end {
                c.err(&format!("{path}.end"), "must differ from start");
            }
        }
        ShapeSpec::Prism {
            vertices,
            z_min,
            z_max,
        } => {
            check_polygon(c, path, vertices);
            let a = c.finite(&format!("{path}.z_min"), *z_min);
            if c.finite(&format!("{path}.z_max"), *z_max) && a && z_max <= z_min {
                c.err(
                    &format!("{path}.z_max"),
                    format!("must exceed z_min {z_min}, got {z_max}"),
                );
            }
        }
    }
    c.errors.len() == before
}

/// A polygon's (or a prism's outline's) vertices: at least 3, finite, and
/// enclosing some area.
fn check_polygon(c: &mut Checker, path: &str, vertices: &[[f64; 2]]) {
    if vertices.len() < 3 {
        c.err(
            &format!("{path}.vertices"),
            format!(
                "a polygon needs at least 3 vertices, got {}",
                vertices.len()
            ),
        );
    } else {
        let ok = vertices
            .iter()
            .enumerate()
            .all(|(k, v)| c.point(&format!("{path}.vertices[{k}]"), *v));
        if ok && geometry::polygon_area2(vertices).abs() <= 0.0 {
            c.err(&format!("{path}.vertices"), "the polygon has zero area");
        }
    }
}

/// Checks a body's fields and that it lies in the grid; whether it can be
/// seeded.
fn check_body(
    c: &mut Checker,
    path: &str,
    body: &BodySpec,
    grid: &GridSpec,
    dim: usize,
    cells: [usize; 3],
) -> bool {
    let before = c.errors.len();
    let shape_ok = check_shape(c, &format!("{path}.shape"), &body.shape, dim);
    let holes_ok = body
        .holes
        .iter()
        .enumerate()
        .all(|(k, h)| check_shape(c, &format!("{path}.holes[{k}]"), h, dim));
    let ppc = body.ppc(dim);
    let n = per_dir(ppc, dim);
    if dim == 3 {
        if ppc == 0 || n * n * n != ppc as usize || n > 4 {
            c.err(
                &format!("{path}.particles_per_cell"),
                format!(
                    "must be a perfect cube from 1 to 64 (1, 8, 27, 64) in a 3D scene, got {ppc}"
                ),
            );
        }
    } else if ppc == 0 || n * n != ppc as usize || n > 8 {
        c.err(
            &format!("{path}.particles_per_cell"),
            format!("must be a perfect square from 1 to 64 (1, 4, 9, 16, ...), got {ppc}"),
        );
    }
    c.vector(&format!("{path}.velocity"), body.velocity, dim);
    c.matrix(
        &format!("{path}.velocity_gradient"),
        &body.velocity_gradient,
        dim,
    );
    if let Some(o) = body.velocity_origin {
        c.vector(&format!("{path}.velocity_origin"), o, dim);
    }
    if !(shape_ok && holes_ok) || cells[0] == 0 {
        return false;
    }
    let b = if dim == 3 {
        geometry::bounds_3d(&body.shape)
    } else {
        let b = geometry::bounds(&body.shape);
        geometry::Aabb {
            min: [b.min[0], b.min[1], 0.0],
            max: [b.max[0], b.max[1], 0.0],
        }
    };
    let gmax: [f64; 3] = std::array::from_fn(|d| grid.min[d] + cells[d] as f64 * grid.cell_size);
    let tol = 1e-9 * grid.cell_size;
    let axis = ["x", "y", "z"];
    for d in 0..dim {
        if b.min[d] < grid.min[d] - tol || b.max[d] > gmax[d] + tol {
            c.err(
                &format!("{path}.shape"),
                format!(
                    "extends outside the grid along {}: the body spans [{}, {}], the grid [{}, {}]",
                    axis[d], b.min[d], b.max[d], grid.min[d], gmax[d]
                ),
            );
        }
    }
    c.errors.len() == before
}

/// The particles of every body that passed [`check_body`] (`seedable`), 0
/// for the others. The counts are first estimated from the shapes' areas
/// and the seeding's cost from their bounding boxes, for all bodies
/// together, so that a scene describing billions of particles is refused
/// before any is seeded; then the bodies are seeded and counted exactly.
fn count_particles(
    c: &mut Checker,
    file: &SceneFile,
    cells: [usize; 3],
    seedable: &[bool],
) -> Vec<usize> {
    let mut counts = vec![0; file.bodies.len()];
    let dim = file.dimension();
    let bodies = || file.bodies.iter().enumerate().filter(|(i, _)| seedable[*i]);
    let lattice = |b: &BodySpec| lattice_of(&file.grid, [cells[0], cells[1]], b.ppc(dim));
    let lattice_3d = |b: &BodySpec| lattice_3d_of(&file.grid, cells, b.ppc(dim));
    let mut estimate = 0.0;
    let mut cost = 0.0;
    let mut largest = (0.0, 0usize);
    for (i, body) in bodies() {
        // in 3D a shape's volume over the spacing cubed, in 2D its area
        // over the spacing squared
        let (n, seeding) = if dim == 3 {
            let s = lattice_3d(body).spacing();
            let holes: f64 = body.holes.iter().map(geometry::volume).sum();
            let n = ((geometry::volume(&body.shape) - holes) / (s * s * s)).max(0.0);
            (
                n,
                geometry::seed_cost_3d(&body.shape, &body.holes, &lattice_3d(body)),
            )
        } else {
            let s = lattice(body).spacing();
            let holes: f64 = body.holes.iter().map(geometry::area).sum();
            let n = ((geometry::area(&body.shape) - holes) / (s * s)).max(0.0);
            (
                n,
                geometry::seed_cost(&body.shape, &body.holes, &lattice(body)),
            )
        };
        estimate += n;
        // the run's setup measures every particle's distance to every
        // segment of the body's initial cracks
        let crack_points: usize = body.cracks.iter().map(|k| k.points.len()).sum();
        let w = seeding + n * crack_points as f64;
        cost += w;
        if w > largest.0 {
            largest = (w, i);
        }
    }
    // the lattice count of a shape differs from its area's by a row of
    // particles along its outline: leave room for it
    if estimate > 1.5 * MAX_PARTICLES as f64 {
        c.err(
            "bodies",
            format!(
                "about {estimate:.3e} particles in all (the bodies' {} over the particle spacing {}); \
                 at most {MAX_PARTICLES} are supported: use a coarser grid.cell_size or fewer particles_per_cell",
                if dim == 3 { "volumes" } else { "areas" },
                if dim == 3 { "cubed" } else { "squared" },
            ),
        );
        return counts;
    }
    if cost > MAX_SEED_COST {
        c.err(
            &format!("bodies[{}].shape", largest.1),
            format!(
                "seeding would test {cost:.3e} points (lattice points in the bodies' bounding boxes × \
                 their shapes, holes and polygon edges, and particles × crack points; bodies[{}] {:.3e}), \
                 at most {MAX_SEED_COST:e}: use a coarser grid.cell_size, fewer particles_per_cell, \
                 holes, polygon vertices or crack points",
                largest.1, largest.0
            ),
        );
        return counts;
    }
    for (i, body) in bodies() {
        let mut n = 0usize;
        if dim == 3 {
            geometry::seed_3d(&body.shape, &body.holes, &lattice_3d(body), |_| n += 1);
        } else {
            geometry::seed(&body.shape, &body.holes, &lattice(body), |_| n += 1);
        }
        if n == 0 {
            c.err(
                &format!("bodies[{i}].shape"),
                format!(
                    "holds no particle at cell size {} with {} particles per cell",
                    file.grid.cell_size,
                    body.ppc(dim)
                ),
            );
        }
        counts[i] = n;
    }
    let total: usize = counts.iter().sum();
    if total > MAX_PARTICLES {
        c.err(
            "bodies",
            format!("{total} particles in all; at most {MAX_PARTICLES} are supported"),
        );
    }
    counts
}

/// The first time step ([`TimeStepEstimate`]); refuses a Δt that is zero,
/// subnormal or not finite, and a step count to `time.end` beyond
/// `time.max_steps` (a run would stop there), naming Δt, the wave speed,
/// the cell size and the body and material that set them.
fn check_time_step(
    c: &mut Checker,
    file: &SceneFile,
    materials: &[ResolvedMaterial],
    body_material: &[usize],
) -> TimeStepEstimate {
    let h = file.grid.cell_size;
    let t = &file.time;
    let cap = t.max_steps.unwrap_or(DEFAULT_MAX_STEPS);
    // The run's signal speed is max over particles of c + |v_p| (`next_dt`).
    // A lower bound: c of each body's material, plus |velocity| when the
    // body's mean particle velocity is its `velocity` (no gradient, or a
    // gradient about the particles' centroid).
    let mut fastest: Option<(f64, usize)> = None;
    for (b, body) in file.bodies.iter().enumerate() {
        let Some(m) = body_material.get(b).and_then(|&k| materials.get(k)) else {
            continue;
        };
        let v = body.velocity;
        let mean_is_velocity = body.velocity_gradient.is_zero() || body.velocity_origin.is_none();
        let speed = if mean_is_velocity {
            // x² + y² (+ z²), summed in that order
            v.components()
                .iter()
                .skip(1)
                .fold(v[0] * v[0], |s, x| s + x * x)
                .sqrt()
        } else {
            0.0
        };
        let signal = m.wave_speed + speed;
        // a NaN signal takes the place of any other (and is refused below)
        if fastest.is_none_or(|(s, _)| signal > s || signal.is_nan()) {
            fastest = Some((signal, b));
        }
    }
    let Some((signal, b)) = fastest else {
        return TimeStepEstimate {
            dt: 0.0,
            signal_speed: 0.0,
            body: None,
            steps: 0.0,
        };
    };
    let material = &materials[body_material[b]];
    let material_path = match &file.bodies[b].material {
        MaterialRef::Name(n) => format!("materials.{n}"),
        MaterialRef::Inline(_) => format!("bodies[{b}].material"),
    };
    let cause = format!(
        "the wave speed {:e} m/s of {material_path} (E = {:e} Pa, ρ = {:e} kg/m³) in bodies[{b}], \
         plus its speed, {signal:e} m/s, over the cell size {h:e} m",
        material.wave_speed, material.youngs_modulus, material.density
    );
    let (dt, path) = match t.dt {
        Some(dt) => (dt, "time.dt".to_string()),
        None => (
            file.time.cfl.unwrap_or(0.5) * h / signal,
            material_path.clone(),
        ),
    };
    let steps = t.end / dt;
    let estimate = TimeStepEstimate {
        dt,
        signal_speed: if t.dt.is_some() { 0.0 } else { signal },
        body: Some(b),
        steps,
    };
    if t.dt.is_none() && !signal.is_finite() {
        c.err(
            &material_path,
            format!("the time step cannot be computed: {cause} (the wave speed is not finite: the stiffness or density is beyond f64's range)"),
        );
    } else if !dt.is_normal() {
        c.err(
            &path,
            format!(
                "the time step would be {dt:e} s ({}): a run could not advance",
                if t.dt.is_some() {
                    "time.dt".to_string()
                } else {
                    format!("time.cfl × {cause}")
                }
            ),
        );
    } else if steps > cap as f64 + 1.0 {
        // the run takes at least this many steps: it would stop at max_steps
        c.err(
            "time.max_steps",
            format!(
                "time.end = {:e} s takes at least {steps:.4e} steps of Δt = {dt:e} s ({}), more than max_steps = {cap}",
                t.end,
                if t.dt.is_some() {
                    "time.dt".to_string()
                } else {
                    format!("time.cfl × {cause}")
                }
            ),
        );
    }
    estimate
}

fn check_contact(c: &mut Checker, contact: &ContactSpec, groups: &std::collections::BTreeSet<u32>) {
    if c.finite("contact.friction", contact.friction) && contact.friction < 0.0 {
        c.err(
            "contact.friction",
            format!("must be >= 0, got {}", contact.friction),
        );
    }
    for (k, pair) in contact.pairs.iter().enumerate() {
        let path = format!("contact.pairs[{k}]");
        if c.finite(&format!("{path}.friction"), pair.friction) && pair.friction < 0.0 {
            c.err(
                &format!("{path}.friction"),
                format!("must be >= 0, got {}", pair.friction),
            );
        }
        if pair.groups[0] == pair.groups[1] {
            c.err(
                &format!("{path}.groups"),
                format!("the two groups must differ, got {:?}", pair.groups),
            );
        }
        for g in pair.groups {
            if !groups.contains(&g) {
                c.err(
                    &format!("{path}.groups"),
                    format!("no body is in contact group {g}"),
                );
            }
        }
    }
}
