//! The damage particle method's scene section: `method =
//! "damage_particle"` and the `[damage_particle]` table, their serde types
//! and their checks, which [`crate::scene::Scene::validate`] runs with the
//! field paths.
//!
//! What a scene of this method is: bodies on the lattice of the grid
//! (`grid.min` + k `grid.cell_size`): a box without holes (its corners on
//! the lattice) has one particle on each vertex of the lattice inside it
//! (its outline included: the paper's support must cover the cells'
//! faces, and held particles lie on the walls they are held by); any
//! other body has one at the centre of each lattice cell whose centre it
//! holds, owning that cell, and is their union ([`Seeding`]; a support of
//! at least [`CENTRED_SUPPORT`]; docs/dpm.md). Linear elastic materials,
//! walls (`fixed`, `roller`, `velocity`) that hold the particles lying on
//! them (or whose cell touches them), and the damage of [`DpmDamageSpec`].
//! The grid sets the spacing, the walls' planes and the domain (a particle more than one spacing outside
//! it stops the run: a wall that pulls moves its particles out of the
//! box); the method has no grid otherwise, so the grid MPM's options are
//! refused.

use crate::scene::schema::{MaterialModel, SceneFile, ShapeSpec, TimeFunction};
use crate::scene::Checker;
use crate::tensor::resize;
use serde::{Deserialize, Serialize};

/// The method a scene runs (`method = ...`, a top-level key).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MethodKind {
    /// The grid MPM (the default).
    #[default]
    GridMpm,
    /// The damage particle method of Wei & Chen (`[damage_particle]`).
    DamageParticle,
}

impl MethodKind {
    pub fn is_grid_mpm(&self) -> bool {
        *self == MethodKind::GridMpm
    }
}

/// `[damage_particle]`: the method's options.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DpmSpec {
    /// The kernel's support radius over the particle spacing (Wei & Chen
    /// use 1.5), in [1.2, 4]: below, a face point of a smoothing cell is
    /// covered by too few particles for the moment matrix.
    #[serde(default = "default_support")]
    pub support: f64,
    /// An irregular arrangement: each particle moved off its lattice
    /// vertex by up to `jitter` spacings along each axis, in [0, 0.45]
    /// (a fixed pseudo-random sequence of the particle's index, the same
    /// on every run); a coordinate on the body's outline stays there. The
    /// smoothing cells stay the lattice's squares (cubes): they tile the
    /// body and hold their particles, so the patch test still holds.
    /// Absent: the lattice's vertices.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jitter: Option<f64>,
    /// The damage of every body (absent: elastic).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damage: Option<DpmDamageSpec>,
    /// Regions whose particles are held at prescribed velocities (a wall
    /// over part of a side, an impactor's face), after the grid's walls.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub held: Vec<HeldSpec>,
    /// How the equations of motion are solved: explicit central
    /// differences (the default) or a static equilibrium per load step.
    #[serde(default, skip_serializing_if = "Integration::is_explicit")]
    pub integration: Integration,
    /// The static solve's convergence (with `integration = "static"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub equilibrium: Option<EquilibriumSpec>,
}

impl DpmSpec {
    /// The options of a scene without a `[damage_particle]` table.
    pub fn defaults() -> DpmSpec {
        DpmSpec {
            support: default_support(),
            jitter: None,
            damage: None,
            held: Vec::new(),
            integration: Integration::Explicit,
            equilibrium: None,
        }
    }
}

/// `damage_particle.integration`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Integration {
    /// Explicit central differences with the lumped mass (Wei & Chen's
    /// dynamic examples).
    #[default]
    Explicit,
    /// Quasi-static: no inertia; each step of `time.dt` moves the held
    /// components and the loads to their values at the step's end and
    /// iterates to equilibrium with the damage (Wei & Chen's
    /// "incremental–iterative procedure" for the bar).
    Static,
}

impl Integration {
    pub fn is_explicit(&self) -> bool {
        *self == Integration::Explicit
    }
}

/// `[damage_particle.equilibrium]`: when a static step has converged.
#[derive(Debug, Clone, Copy, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct EquilibriumSpec {
    /// The largest out-of-balance force component of a free particle over
    /// the force scale (the largest internal or external force component,
    /// at least the strength's force on one cell face).
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    /// Iterations before a step that has not converged stops the run.
    #[serde(default = "default_iterations")]
    pub max_iterations: u32,
}

impl Default for EquilibriumSpec {
    fn default() -> Self {
        EquilibriumSpec {
            tolerance: default_tolerance(),
            max_iterations: default_iterations(),
        }
    }
}

fn default_tolerance() -> f64 {
    1e-8
}

fn default_iterations() -> u32 {
    500
}

/// `[[damage_particle.held]]`: the particles inside `shape` held at the
/// velocity components given (m/s, functions of time; a component not
/// given is free), by singular kernels as the walls hold theirs. Its force
/// on the material is the series' `reaction_<name>_<axis>` with `[output]
/// reactions`.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct HeldSpec {
    /// Its name in the series (default `held<k>`, k its index).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    pub shape: ShapeSpec,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x: Option<TimeFunction>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y: Option<TimeFunction>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub z: Option<TimeFunction>,
}

impl HeldSpec {
    /// Its name in the series columns.
    pub fn label(&self, k: usize) -> String {
        self.name.clone().unwrap_or_else(|| format!("held{k}"))
    }
}

fn default_support() -> f64 {
    1.5
}

/// `[damage_particle.damage]`: Wei & Chen's damage (eq. 2 with Mazars'
/// equivalent strain, eq. 6) with linear softening regularised by eq. 33.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DpmDamageSpec {
    /// Tensile strength f_t, Pa (κ₀ = f_t / E).
    pub strength: f64,
    /// Fracture energy G_F, J/m².
    pub fracture_energy: f64,
    /// κ_c from each damaged cell's section (eq. 33; true, the method), or
    /// the constant `kappa_c` (false: the unregularised contrast).
    #[serde(default = "yes")]
    pub regularised: bool,
    /// The strain where a particle is fully damaged, with `regularised =
    /// false` only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kappa_c: Option<f64>,
    /// Criterion 27's tolerance: a neighbour of a particle whose damage
    /// started becomes a candidate when the cosine of its direction
    /// against the segment's normal is below `tol`, |n·r|/|r| < tol (0:
    /// none; 1: every neighbour off the normal).
    #[serde(default = "default_tol")]
    pub tol: f64,
    /// The neighbourhood criterion 27 looks in, in particle spacings: the
    /// particles within this distance of a damaged one (not across a
    /// crack). Absent: the particles whose supports cover it (its shape
    /// functions' neighbours). On a square lattice the neighbours within
    /// 1.5 spacings lie at 0, 45 and 90 degrees only (docs/dpm.md, R2).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tracking_radius: Option<f64>,
    /// Where a starting segment's normal comes from, in particle
    /// spacings: the largest principal direction of the stress averaged
    /// over the particles within this distance (not across a crack), each
    /// cell weighted by its volume, at the last step's damage. Absent: the
    /// particle's own cell's stress (Wei & Chen, Fig. 6).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal_radius: Option<f64>,
    /// The damage at which a particle's neighbours become candidates
    /// (criterion 27), in (0, 1]: 1, only once it is broken. Absent: as
    /// soon as its damage starts (Wei & Chen).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub track_at: Option<f64>,
    /// Where damage may start: only the particles in `shape` are
    /// candidates at the start (the others become candidates by criterion
    /// 27), their strength scaled by `strength_factor`. Absent: every
    /// particle is a candidate.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initiation: Option<InitiationSpec>,
}

fn yes() -> bool {
    true
}

fn default_tol() -> f64 {
    0.3
}

/// Where damage starts ([`DpmDamageSpec::initiation`]).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct InitiationSpec {
    pub shape: ShapeSpec,
    /// The strength there over `strength`, in (0, 1] (a weak plane).
    #[serde(default = "one")]
    pub strength_factor: f64,
}

fn one() -> f64 {
    1.0
}

/// How far off the lattice a box corner may be, in spacings.
const ON_LATTICE: f64 = 1e-9;

/// Particle positions with their smoothing cells' lower and upper
/// corners.
pub type BoxLattice<const D: usize> = (Vec<[f64; D]>, Vec<[f64; D]>, Vec<[f64; D]>);

/// The particles of a box body on the lattice of spacing `h` from
/// `origin`: their positions and smoothing cells (`lo..hi`, the vertex's
/// Voronoi cell clipped to the box), in lexicographic order (x fastest).
/// `lo`, `hi` are the box's corners, on the lattice.
pub fn box_lattice<const D: usize>(lo: [f64; D], hi: [f64; D], h: f64) -> BoxLattice<D> {
    let n: [usize; D] = std::array::from_fn(|d| ((hi[d] - lo[d]) / h).round() as usize);
    let total: usize = n.iter().map(|k| k + 1).product();
    let (mut x, mut clo, mut chi) = (
        Vec::with_capacity(total),
        Vec::with_capacity(total),
        Vec::with_capacity(total),
    );
    for k in 0..total {
        let mut rest = k;
        let mut p = [0.0; D];
        let mut a = [0.0; D];
        let mut b = [0.0; D];
        for d in 0..D {
            let i = rest % (n[d] + 1);
            rest /= n[d] + 1;
            // the last vertex exactly on the far side
            p[d] = if i == n[d] {
                hi[d]
            } else {
                lo[d] + i as f64 * h
            };
            a[d] = (p[d] - 0.5 * h).max(lo[d]);
            b[d] = (p[d] + 0.5 * h).min(hi[d]);
        }
        x.push(p);
        clo.push(a);
        chi.push(b);
    }
    (x, clo, chi)
}

/// Moves the particles `x` of a box body `lo..hi` (from [`box_lattice`],
/// spacing `h`) off their vertices by up to `jitter` spacings along each
/// axis (`damage_particle.jitter`): each offset is uniform in
/// [−jitter·h, jitter·h), drawn from a hash of the particle's index in the
/// body and the axis (SplitMix64's finaliser), so the arrangement is the
/// same on every run and for any thread count. A coordinate on the box's
/// outline is kept, so the walls hold the particles they held.
pub fn jitter_lattice<const D: usize>(
    x: &mut [[f64; D]],
    lo: [f64; D],
    hi: [f64; D],
    h: f64,
    jitter: f64,
) {
    let on = |v: f64, e: f64| (v - e).abs() <= ON_LATTICE * h;
    for (k, p) in x.iter_mut().enumerate() {
        for d in 0..D {
            if on(p[d], lo[d]) || on(p[d], hi[d]) {
                continue;
            }
            let s = super::mix(
                (k as u64)
                    .wrapping_mul(0x9E37_79B9_7F4A_7C15)
                    .wrapping_add((d as u64 + 1).wrapping_mul(0xD1B5_4A32_D192_ED03)),
            );
            // 53 random bits: uniform in [0, 1)
            let u = (s >> 11) as f64 / (1u64 << 53) as f64;
            p[d] += jitter * h * (2.0 * u - 1.0);
        }
    }
}

/// The corners of a box body, or None for another shape.
pub fn box_corners(shape: &ShapeSpec) -> Option<(Vec<f64>, Vec<f64>)> {
    match shape {
        ShapeSpec::Box { min, max } => Some((min.components().to_vec(), max.components().to_vec())),
        _ => None,
    }
}

/// Where a body's particles sit (docs/dpm.md, "Bodies other than boxes").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Seeding {
    /// On the lattice's vertices, the outline included, each owning its
    /// Voronoi cell clipped to the box: a box without holes.
    Vertices,
    /// At the centres of the lattice's cells whose centre lies in the
    /// shape and outside its holes, each owning its whole cell: every
    /// other body, which is then the union of those cells (a staircase,
    /// as the grid MPM's seeding makes it).
    Centres,
}

/// How a body with `shape` and `holes` is seeded.
pub fn seeding_of(shape: &ShapeSpec, holes: &[ShapeSpec]) -> Seeding {
    if holes.is_empty() && box_corners(shape).is_some() {
        Seeding::Vertices
    } else {
        Seeding::Centres
    }
}

/// The smallest support, in spacings, that covers every face point of a
/// body seeded at cell centres: with 1.5 a face point on the outline lies
/// half a spacing beyond the outermost row, which alone covers it, and the
/// moment matrix is singular (`scni::tests::the_paper_support_fails_on_the_outline_of_a_centred_lattice`).
pub const CENTRED_SUPPORT: f64 = 2.0;

/// The particles of a body seeded at cell centres ([`Seeding::Centres`])
/// on the lattice of spacing `h` from `origin` with `cells` cells along
/// each axis: positions and their cells `lo..hi` (corners on the lattice,
/// computed from the cell's index so that neighbours share their faces
/// bit for bit), in the grid MPM's seeding order (x fastest).
pub fn centred_lattice<const D: usize>(
    shape: &ShapeSpec,
    holes: &[ShapeSpec],
    origin: [f64; D],
    cells: [usize; D],
    h: f64,
) -> BoxLattice<D> {
    let (mut x, mut clo, mut chi) = (Vec::new(), Vec::new(), Vec::new());
    each_centre::<D>(shape, holes, origin, cells, h, |c| {
        let mut a = [0.0; D];
        let mut b = [0.0; D];
        for d in 0..D {
            let i = ((c[d] - origin[d]) / h).floor();
            a[d] = origin[d] + i * h;
            b[d] = origin[d] + (i + 1.0) * h;
        }
        x.push(c);
        clo.push(a);
        chi.push(b);
    });
    (x, clo, chi)
}

/// Calls `emit` with the centre of every lattice cell whose centre lies
/// in `shape` and outside `holes` (the grid MPM's seeding at one particle
/// per cell), in that seeding's order.
fn each_centre<const D: usize>(
    shape: &ShapeSpec,
    holes: &[ShapeSpec],
    origin: [f64; D],
    cells: [usize; D],
    h: f64,
    mut emit: impl FnMut([f64; D]),
) {
    if D == 2 {
        let lat = crate::geometry::Lattice {
            origin: resize(origin),
            h,
            cells: [cells[0], cells[1]],
            per_dir: 1,
        };
        crate::geometry::seed(shape, holes, &lat, |c| emit(resize(c)));
    } else {
        let lat = crate::geometry::Lattice::<3> {
            origin: resize(origin),
            h,
            cells: std::array::from_fn(|d| cells.get(d).copied().unwrap_or(1)),
            per_dir: 1,
        };
        crate::geometry::seed_3d(shape, holes, &lat, |c| emit(resize(c)));
    }
}

/// The particles of a body by its [`Seeding`]: positions and smoothing
/// cells, and the box that holds the cells (for [`jitter_lattice`]).
pub fn body_lattice<const D: usize>(
    shape: &ShapeSpec,
    holes: &[ShapeSpec],
    origin: [f64; D],
    cells: [usize; D],
    h: f64,
) -> (BoxLattice<D>, [f64; D], [f64; D]) {
    if let (Seeding::Vertices, Some((a, z))) = (seeding_of(shape, holes), box_corners(shape)) {
        let (a, z): ([f64; D], [f64; D]) =
            (std::array::from_fn(|d| a[d]), std::array::from_fn(|d| z[d]));
        return (box_lattice::<D>(a, z, h), a, z);
    }
    let lattice = centred_lattice::<D>(shape, holes, origin, cells, h);
    let mut a = [f64::INFINITY; D];
    let mut z = [f64::NEG_INFINITY; D];
    for (l, u) in lattice.1.iter().zip(&lattice.2) {
        for d in 0..D {
            a[d] = a[d].min(l[d]);
            z[d] = z[d].max(u[d]);
        }
    }
    (lattice, a, z)
}

/// Checks a scene that runs the damage particle method (`file.method` is
/// `damage_particle`), with each material's model (`models[b]`: body b's),
/// the grid's cells along each axis and the particles the grid MPM's
/// seeding found in each body (0 where a body was refused or not seeded);
/// returns the particles of each body as this method seeds them.
pub(crate) fn check(
    c: &mut Checker,
    file: &SceneFile,
    models: &[Option<MaterialModel>],
    cells: [usize; 3],
    seeded: &[usize],
) -> Vec<usize> {
    let dim = file.dimension();
    let h = file.grid.cell_size;
    let not_here =
        "the damage particle method (method = \"damage_particle\") has no background grid";
    let default = DpmSpec::defaults();
    let spec = file.damage_particle.as_ref().unwrap_or(&default);
    if c.finite("damage_particle.support", spec.support) && !(1.2..=4.0).contains(&spec.support) {
        c.err(
            "damage_particle.support",
            format!(
                "must be in [1.2, 4] particle spacings, got {}: below 1.2 a smoothing cell's face is covered by too few particles for the linear basis (Wei & Chen use 1.5)",
                spec.support
            ),
        );
    }
    if let Some(j) = spec.jitter {
        if c.finite("damage_particle.jitter", j) && !(0.0..=0.45).contains(&j) {
            c.err(
                "damage_particle.jitter",
                format!(
                    "must be in [0, 0.45] particle spacings, got {j}: a particle must stay inside its smoothing cell, the lattice's square about its vertex"
                ),
            );
        }
    }
    if let Some(d) = &spec.damage {
        let q = "damage_particle.damage";
        c.positive(&format!("{q}.strength"), d.strength);
        c.positive(&format!("{q}.fracture_energy"), d.fracture_energy);
        c.in_range(&format!("{q}.tol"), d.tol, 0.0, 1.0);
        if let Some(r) = d.tracking_radius {
            c.in_range(&format!("{q}.tracking_radius"), r, 1.0, 4.0);
        }
        if let Some(r) = d.normal_radius {
            c.in_range(&format!("{q}.normal_radius"), r, 1.0, 4.0);
        }
        if let Some(t) = d.track_at {
            if c.finite(&format!("{q}.track_at"), t) && !(t > 0.0 && t <= 1.0) {
                c.err(
                    &format!("{q}.track_at"),
                    format!("must be in (0, 1], got {t} (absent: when a particle's damage starts)"),
                );
            }
        }
        match (d.regularised, d.kappa_c) {
            (true, Some(_)) => c.err(
                &format!("{q}.kappa_c"),
                "is for regularised = false: regularised, κ_c comes from each cell (eq. 33)",
            ),
            (false, None) => c.err(
                &format!("{q}.kappa_c"),
                "regularised = false needs the strain κ_c where a particle is fully damaged",
            ),
            (false, Some(k)) => {
                c.positive(&format!("{q}.kappa_c"), k);
            }
            (true, None) => {}
        }
        if let Some(i) = &d.initiation {
            crate::scene::validate::check_shape(c, &format!("{q}.initiation.shape"), &i.shape, dim);
            let f = i.strength_factor;
            if c.finite(&format!("{q}.initiation.strength_factor"), f) && !(f > 0.0 && f <= 1.0) {
                c.err(
                    &format!("{q}.initiation.strength_factor"),
                    format!("must be in (0, 1], got {f}"),
                );
            }
        }
    }
    let mut names = std::collections::HashSet::new();
    for (k, held) in spec.held.iter().enumerate() {
        let q = format!("damage_particle.held[{k}]");
        let given = [&held.x, &held.y, &held.z];
        if given.iter().all(|f| f.is_none()) {
            c.err(&q, "holds no component: give x, y (or z) velocities, m/s");
        }
        if dim == 2 && held.z.is_some() {
            c.err(&format!("{q}.z"), "is for 3D scenes (this one is 2D)");
        }
        for (axis, f) in ["x", "y", "z"].into_iter().zip(given) {
            if let Some(f) = f {
                c.time_function(&format!("{q}.{axis}"), f);
            }
        }
        crate::scene::validate::check_shape(c, &format!("{q}.shape"), &held.shape, dim);
        let label = held.label(k);
        if !names.insert(label.clone()) {
            c.err(
                &format!("{q}.name"),
                format!("`{label}` names another held region: the series' reaction columns need one name each"),
            );
        }
    }
    if spec.integration == Integration::Static {
        let why = "a static solve (damage_particle.integration = \"static\") steps by a fixed load increment";
        if file.time.dt.is_none() {
            c.err("time.dt", format!("{why}: give time.dt, s"));
        }
        if file.time.cfl.is_some() {
            c.err(
                "time.cfl",
                format!("{why}, with no wave speed to follow: give time.dt instead"),
            );
        }
        for (i, body) in file.bodies.iter().enumerate() {
            if body.velocity.components().iter().any(|&v| v != 0.0) {
                c.err(
                    &format!("bodies[{i}].velocity"),
                    "a static solve has no inertia: the bodies start at rest (move them by held regions or walls)",
                );
            }
        }
        let eq = spec.equilibrium.unwrap_or_default();
        let q = "damage_particle.equilibrium";
        if c.finite(&format!("{q}.tolerance"), eq.tolerance)
            && !(eq.tolerance > 0.0 && eq.tolerance <= 1e-2)
        {
            c.err(
                &format!("{q}.tolerance"),
                format!("must be in (0, 1e-2], got {}", eq.tolerance),
            );
        }
        if eq.max_iterations == 0 {
            c.err(&format!("{q}.max_iterations"), "must be at least 1");
        }
    } else if spec.equilibrium.is_some() {
        c.err(
            "damage_particle.equilibrium",
            "is the static solve's: set damage_particle.integration = \"static\" or remove it",
        );
    }
    // what belongs to the grid MPM
    if file.grid.shape_function != Default::default() || file.grid.lme_gamma.is_some() {
        c.err(
            "grid.shape_function",
            format!("{not_here}: the particles' reproducing kernels replace the grid's shape functions (remove it)"),
        );
    }
    if serde_json::to_value(&file.transfer).ok()
        != serde_json::from_str::<crate::scene::schema::TransferSpec>("{}")
            .ok()
            .and_then(|t| serde_json::to_value(t).ok())
    {
        c.err(
            "transfer",
            format!("{not_here}: there is no particle–grid transfer to set (remove [transfer])"),
        );
    }
    if file.dfg.is_some() {
        c.err(
            "dfg",
            format!("{not_here}: partitioning is the grid MPM's (remove [dfg])"),
        );
    }
    if file.cramp.is_some() {
        c.err(
            "cramp",
            format!("{not_here}: explicit cracks are the grid MPM's (remove [cramp])"),
        );
    }
    let glo = file.grid.min.components();
    let glo_a: [f64; 3] = std::array::from_fn(|d| glo.get(d).copied().unwrap_or(0.0));
    let mut counts = vec![0; file.bodies.len()];
    for (i, body) in file.bodies.iter().enumerate() {
        let path = format!("bodies[{i}]");
        if let Some(Some(m)) = models.get(i) {
            if *m != MaterialModel::LinearElastic {
                c.err(
                    &format!("{path}.material"),
                    "the damage particle method is small-strain (Wei & Chen): use a linear_elastic material",
                );
            }
        }
        if let Some(spec) = file.material_of(&body.material) {
            for (key, set) in [
                ("phase_field", spec.phase_field.is_some()),
                ("damage", spec.damage.is_some()),
                ("eigen", spec.eigen.is_some()),
            ] {
                if set {
                    let at = match &body.material {
                        crate::scene::MaterialRef::Name(n) => format!("materials.{n}.{key}"),
                        crate::scene::MaterialRef::Inline(_) => format!("{path}.material.{key}"),
                    };
                    c.err(
                        &at,
                        "is a grid MPM fracture model: the damage particle method's damage is [damage_particle.damage]",
                    );
                }
            }
        }
        for (key, set) in [
            ("cracks", dim == 3 && !body.cracks.is_empty()),
            ("crack_origin", body.crack_origin.is_some()),
            ("explicit_cracks", !body.explicit_cracks.is_empty()),
            ("particles_per_cell", body.particles_per_cell.is_some()),
            (
                "velocity_gradient",
                body.velocity_gradient
                    .rows()
                    .iter()
                    .any(|r| r.components().iter().any(|&c| c != 0.0)),
            ),
        ] {
            if set {
                let why = match key {
                    "particles_per_cell" => "the damage particle method puts one particle on each vertex of the grid's lattice (at the centre of each cell in a body that is not a box): remove it",
                    "velocity_gradient" => "is not yet taken by the damage particle method (give a uniform velocity)",
                    "cracks" => "the damage particle method's pre-existing cracks (diffraction) are 2D",
                    _ => "is not yet taken by the damage particle method",
                };
                c.err(&format!("{path}.{key}"), why);
            }
        }
        for (k, crack) in body.cracks.iter().enumerate() {
            if crack.profile != crate::scene::schema::CrackProfile::Line {
                c.err(
                    &format!("{path}.cracks[{k}].profile"),
                    "a profile is a phase field's initial history: the damage particle method cuts the supports along the line (remove it)",
                );
            }
        }
        if body.shape.dimension() != dim || glo.len() != dim {
            continue; // the general checks name it
        }
        let (Seeding::Vertices, Some((lo, hi))) = (
            seeding_of(&body.shape, &body.holes),
            box_corners(&body.shape),
        ) else {
            // at the cells' centres: counted as they will be seeded, where
            // the grid MPM's seeding (`seeded`, whose cost validation has
            // bounded) found the body seedable
            if seeded.get(i).copied().unwrap_or(0) == 0 {
                continue;
            }
            let mut n = 0usize;
            if dim == 2 {
                let o = resize(glo_a);
                each_centre::<2>(&body.shape, &body.holes, o, [cells[0], cells[1]], h, |_| {
                    n += 1
                });
            } else {
                each_centre::<3>(&body.shape, &body.holes, glo_a, cells, h, |_| n += 1);
            }
            if n == 0 {
                c.err(
                    &format!("{path}.shape"),
                    format!("holds no centre of a grid cell (spacing {h} m): a body that is not a box without holes has a particle at the centre of each cell whose centre lies in it"),
                );
            }
            if spec.support < CENTRED_SUPPORT {
                c.err(
                    "damage_particle.support",
                    format!(
                        "must be at least {CENTRED_SUPPORT} particle spacings for {path}, got {}: a body that is not a box without holes has its particles at the cells' centres, half a spacing inside its outline, and a smaller support covers the outline's faces with one row of particles (docs/dpm.md)",
                        spec.support
                    ),
                );
            }
            counts[i] = n;
            continue;
        };
        if lo.len() != dim || hi.len() != dim {
            continue; // the general checks name it
        }
        let mut n = 1usize;
        for d in 0..dim {
            for (k, v) in [("min", lo[d]), ("max", hi[d])] {
                let off = (v - glo[d]) / h;
                if (off - off.round()).abs() > ON_LATTICE * off.abs().max(1.0) {
                    c.err(
                        &format!("{path}.shape.{k}[{d}]"),
                        format!(
                            "{v} is not on the grid's lattice (grid.min[{d}] + k × grid.cell_size): the particles sit on its vertices"
                        ),
                    );
                }
            }
            let cells = ((hi[d] - lo[d]) / h).round();
            if cells < 1.0 {
                c.err(
                    &format!("{path}.shape"),
                    format!("is less than one grid.cell_size wide along axis {d}"),
                );
            } else {
                n = n.saturating_mul(cells as usize + 1);
            }
        }
        counts[i] = n;
    }
    counts
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_body_that_is_not_a_box_is_the_union_of_the_cells_whose_centre_it_holds() {
        use crate::geometry::Vector;
        let disk = ShapeSpec::Disk {
            center: Vector::from([0.0, 0.0]),
            radius: 2.2,
        };
        let hole = ShapeSpec::Disk {
            center: Vector::from([0.0, 0.0]),
            radius: 0.9,
        };
        let square = ShapeSpec::Box {
            min: Vector::from([-2.0, -2.0]),
            max: Vector::from([2.0, 2.0]),
        };
        assert_eq!(seeding_of(&square, &[]), Seeding::Vertices);
        assert_eq!(
            seeding_of(&square, std::slice::from_ref(&hole)),
            Seeding::Centres
        );
        assert_eq!(seeding_of(&disk, &[]), Seeding::Centres);
        // a lattice of spacing 0.5 from −2.75: centres at k/2
        let (h, origin) = (0.5, [-2.75, -2.75]);
        let ((x, lo, hi), a, z) =
            body_lattice::<2>(&disk, std::slice::from_ref(&hole), origin, [11, 11], h);
        let want: Vec<[f64; 2]> = (0..11 * 11)
            .map(|k| [-2.5 + 0.5 * (k % 11) as f64, -2.5 + 0.5 * (k / 11) as f64])
            .filter(|c| {
                let r2 = c[0] * c[0] + c[1] * c[1];
                r2 <= 2.2 * 2.2 && r2 > 0.9 * 0.9
            })
            .collect();
        assert_eq!(x.len(), want.len());
        for (l, c) in x.iter().enumerate() {
            assert!((c[0] - want[l][0]).abs() < 1e-12 && (c[1] - want[l][1]).abs() < 1e-12);
            // each particle owns its whole cell, whose corners lie on the
            // lattice as multiples of the spacing from the origin
            for d in 0..2 {
                assert!(lo[l][d] < c[d] && c[d] < hi[l][d]);
                let k = (lo[l][d] - origin[d]) / h;
                assert_eq!(lo[l][d], origin[d] + k.round() * h);
                assert_eq!(hi[l][d], origin[d] + (k.round() + 1.0) * h);
            }
        }
        // neighbours share their faces bit for bit
        let shared = x
            .iter()
            .enumerate()
            .flat_map(|(l, _)| (0..x.len()).map(move |m| (l, m)))
            .filter(|&(l, m)| hi[l][0] == lo[m][0] && lo[l][1] == lo[m][1])
            .count();
        assert!(shared > x.len() / 2, "{shared} shared faces");
        assert_eq!(a, [-2.25, -2.25]);
        assert_eq!(z, [2.25, 2.25]);
    }

    #[test]
    fn a_box_lattice_has_its_outline_and_clipped_cells() {
        let (x, lo, hi) = box_lattice([0.0, 1.0], [2.0, 1.5], 0.5);
        assert_eq!(x.len(), 5 * 2);
        assert_eq!(x[0], [0.0, 1.0]);
        assert_eq!(x[9], [2.0, 1.5]);
        // corner cells a quarter, edge cells a half, interior a whole
        let area = |k: usize| (hi[k][0] - lo[k][0]) * (hi[k][1] - lo[k][1]);
        assert_eq!(area(0), 0.0625);
        assert_eq!(area(1), 0.125);
        let total: f64 = (0..x.len()).map(area).sum();
        assert!((total - 1.0).abs() < 1e-15);
    }
}
