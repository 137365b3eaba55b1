//! What a run of a scene will need in memory, known at validation, and
//! what the process may use: a scene too large for the machine is refused
//! with its estimate instead of aborting mid-run when an allocation fails.
//!
//! The estimate counts the arrays that grow with the scene: the particle
//! arrays the scene's models enable, the grid's nodal fields, the phase
//! field's system and its Cholesky factor, and DFG's per-particle state
//! and neighbour lists. Its constants (bytes per particle, per node, per
//! nonzero) are read off the types in `particles.rs`, `grid/mod.rs`,
//! `fracture/phase_field/system.rs` and `fracture/dfg/mod.rs`; the factor's
//! fill follows the nested-dissection bound for 2D grids, nnz(L) ≈
//! c·n·log₂ n (George 1973), with c fitted to faer's AMD ordering on the
//! phase-field matrix (`DEPENDENCIES.md`: 10.4 M at n = 65 536, 50.4 M at
//! n = 265 225). `docs/stability.md` compares it with measured peaks.

use super::schema::{
    FactorOrdering, PhaseFieldMethod, SceneFile, ShapeFunctionKind, StressUpdate, TransferKind,
};
use super::validate::ResolvedMaterial;
use serde::Serialize;
use std::fmt;

/// Bytes a run of a scene is expected to need, by owner.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct MemoryEstimate {
    /// The program itself: code, libraries, thread stacks, the allocator's
    /// arenas (the peak of the smallest shipped scene).
    pub program: u64,
    /// The particle arrays (with the bins' order and the snapshot copies).
    pub particles: u64,
    /// The grid's nodal fields (every velocity field with contact).
    pub grid: u64,
    /// The phase field's matrices, right-hand sides and solver vectors.
    pub phase_field_system: u64,
    /// The phase field's Cholesky factor (its values in f64, and for PCG
    /// their f32 copy too, and its symbolic structure).
    pub phase_field_factor: u64,
    /// DFG's per-particle state and neighbour lists.
    pub dfg: u64,
}

impl MemoryEstimate {
    pub fn total(&self) -> u64 {
        self.program
            .saturating_add(self.particles)
            .saturating_add(self.grid)
            .saturating_add(self.phase_field_system)
            .saturating_add(self.phase_field_factor)
            .saturating_add(self.dfg)
    }
}

/// `1.23 GiB`, `45.6 MiB`, `789 KiB`.
pub fn human_bytes(b: u64) -> String {
    let b = b as f64;
    if b >= 1024.0 * 1024.0 * 1024.0 {
        format!("{:.2} GiB", b / (1024.0 * 1024.0 * 1024.0))
    } else if b >= 1024.0 * 1024.0 {
        format!("{:.1} MiB", b / (1024.0 * 1024.0))
    } else {
        format!("{:.0} KiB", (b / 1024.0).ceil())
    }
}

impl fmt::Display for MemoryEstimate {
    /// `about 1.20 GiB (particles 0.80 GiB, grid 12.0 MiB, ...)`, naming
    /// only the owners the scene has.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "about {} (program {}, particles {}",
            human_bytes(self.total()),
            human_bytes(self.program),
            human_bytes(self.particles)
        )?;
        write!(f, ", grid {}", human_bytes(self.grid))?;
        if self.phase_field_system > 0 {
            write!(
                f,
                ", phase-field system {}, its factor {}",
                human_bytes(self.phase_field_system),
                human_bytes(self.phase_field_factor)
            )?;
        }
        if self.dfg > 0 {
            write!(f, ", DFG lists {}", human_bytes(self.dfg))?;
        }
        write!(f, ")")
    }
}

/// The memory a scene's run may take: the least of the limits known.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct MemoryBudget {
    /// Bytes, with what set them (e.g. "the address-space limit"); None:
    /// no limit is known (the check is skipped).
    pub limit: Option<(u64, String)>,
}

impl MemoryBudget {
    /// No limit: every estimate passes.
    pub fn unlimited() -> MemoryBudget {
        MemoryBudget { limit: None }
    }

    /// A budget of `bytes`, set by `what` (a server's configured budget).
    pub fn of(bytes: u64, what: impl Into<String>) -> MemoryBudget {
        MemoryBudget {
            limit: Some((bytes, what.into())),
        }
    }

    /// The tighter of two budgets.
    pub fn min(self, other: MemoryBudget) -> MemoryBudget {
        match (self.limit, other.limit) {
            (Some(a), Some(b)) => MemoryBudget {
                limit: Some(if b.0 < a.0 { b } else { a }),
            },
            (a, b) => MemoryBudget { limit: a.or(b) },
        }
    }

    /// What this process may still use: its address-space limit
    /// (RLIMIT_AS, `ulimit -v`) less what it has mapped, and the memory
    /// the system has available. Read from `/proc` on Linux; elsewhere no
    /// limit is known.
    pub fn process() -> MemoryBudget {
        let read = |p: &str| std::fs::read_to_string(p).ok();
        let address_space = read("/proc/self/limits")
            .and_then(|l| address_space_limit(&l))
            .map(|limit| {
                let mapped = read("/proc/self/status")
                    .and_then(|s| kib_field(&s, "VmSize:"))
                    .unwrap_or(0);
                (
                    limit.saturating_sub(mapped),
                    format!(
                        "the process's address-space limit ({} less {} mapped)",
                        human_bytes(limit),
                        human_bytes(mapped)
                    ),
                )
            });
        let available = read("/proc/meminfo")
            .and_then(|m| kib_field(&m, "MemAvailable:"))
            .map(|b| (b, "the memory available on this machine".to_string()));
        MemoryBudget {
            limit: address_space,
        }
        .min(MemoryBudget { limit: available })
    }
}

/// The soft "Max address space" of `/proc/self/limits`, bytes (None when
/// unlimited or absent).
pub(super) fn address_space_limit(limits: &str) -> Option<u64> {
    let line = limits
        .lines()
        .find(|l| l.starts_with("Max address space"))?;
    line["Max address space".len()..]
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// A `Name:   123 kB` field of `/proc/meminfo` or `/proc/self/status`, bytes.
fn kib_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    let kib: u64 = line[name.len()..].split_whitespace().next()?.parse().ok()?;
    Some(kib.saturating_mul(1024))
}

/// The estimate for a validated scene's parts (see the module docs).
///
/// A 3D scene's is the same count with 3D sizes: vectors of 3
/// components, symmetric tensors of 6 and full ones of 9, nodes over
/// three axes, a phase-field row of 5³ (7³) neighbours, and its factor's
/// fill by the nested-dissection bound for 3D grids, nnz(L) ≈ c·n^{4/3}
/// (George 1973), c taken from the 2D fit at 65 536 unknowns: a guide
/// until a 3D run measures it.
pub(super) fn estimate(
    file: &SceneFile,
    cells: [usize; 3],
    particle_counts: &[usize],
    materials: &[ResolvedMaterial],
    body_material: &[usize],
    contact_groups: usize,
) -> MemoryEstimate {
    let n: u64 = particle_counts.iter().map(|&c| c as u64).sum();
    let mats = || {
        body_material
            .iter()
            .filter_map(|&m| materials.get(m))
            .collect::<Vec<_>>()
    };
    let any = |f: &dyn Fn(&ResolvedMaterial) -> bool| mats().into_iter().any(f);
    use super::schema::MaterialModel::{LinearElastic, NeoHookean};
    let three = file.dimension() == 3;
    // bytes of a vector, a symmetric tensor (Voigt) and a full tensor
    let (vector, sym, full): (u64, u64, u64) = if three { (24, 48, 72) } else { (16, 24, 32) };
    // id, body, material, group, x, v, mass, vol, vol0, stress
    let mut per_particle: u64 = 4 + 2 + 2 + 1 + vector + vector + 8 + 8 + 8 + sym;
    if any(&|m| m.model == LinearElastic) {
        per_particle += sym; // strain
    }
    if any(&|m| m.model == NeoHookean) {
        per_particle += full; // deformation gradient
    }
    if file.transfer.scheme == TransferKind::Apic {
        per_particle += full; // affine velocity field
    }
    if file.grid.shape_function == ShapeFunctionKind::Gimp {
        per_particle += 8;
    }
    if file.transfer.stress_update == StressUpdate::Newmark {
        per_particle += vector; // acceleration
    }
    let phase_field = any(&|m| m.phase_field().is_some());
    if phase_field {
        per_particle += 16; // phase, history
    }
    if any(&|m| m.damage().is_some()) {
        per_particle += 16; // damage, strength
    }
    let reach = mats()
        .into_iter()
        .filter_map(|m| m.eigen())
        .map(|e| e.epsilon * (1.0 + crate::fracture::eigen::SKIN))
        .fold(0.0, f64::max);
    if reach > 0.0 {
        // the softening state (onset, χ, d), the stage's two scratch
        // values, the neighbour list's start and build position, and its
        // entries: the points within ε plus the skin, π r² (4/3 π r³)
        // over the cell's area (volume) times the particles per cell
        let ppc = file
            .bodies
            .iter()
            .map(|b| b.ppc(file.dimension()) as f64)
            .fold(1.0, f64::max);
        let r = reach / file.grid.cell_size;
        let listed = if three {
            4.0 / 3.0 * std::f64::consts::PI * r * r * r * ppc
        } else {
            std::f64::consts::PI * r * r * ppc
        };
        // (no more than every particle: a hostile ε stays a finite count)
        per_particle += 32 + 16 + 4 + vector + 4 * listed.min(n as f64).ceil() as u64;
    }
    // the bins' order and a copy of the groups; MUSL's second pass keeps
    // the new positions
    let mut overhead: u64 = 4 + 1 + vector;
    if file.transfer.stress_update == StressUpdate::Musl {
        overhead += vector;
    }
    // a snapshot copies positions, velocities, stress, strain, mass,
    // volume and the ids into its own arrays while it is written
    let snapshot: u64 = match (file.output.snapshots > 0, three) {
        (false, _) => 0,
        (true, false) => 120,
        (true, true) => 2 * 24 + 2 * 72 + 8 + 8 + 4,
    };
    let particles = n.saturating_mul(per_particle + overhead + snapshot);

    let axes = if three { 3 } else { 2 };
    let nodes: u64 = cells[..axes].iter().map(|&c| c as u64 + 1).product();
    // mass, momentum, force, old and new velocity, mass gradient
    let per_slot: u64 = 8 + 5 * vector;
    let fields = if file.dfg.is_some() {
        2 * contact_groups as u64
    } else {
        contact_groups as u64
    };
    // with several fields only the nodes where they meet hold more than one
    // slot; count every node once, plus a tenth of the nodes per extra field,
    // and the multi-field index arrays
    let slots = nodes + nodes * fields.saturating_sub(1) / 10;
    let multi = if fields > 1 { nodes * 12 } else { 0 };
    let grid = slots * per_slot + multi;

    let (mut system, mut factor) = (0u64, 0u64);
    if phase_field {
        let h = file.grid.cell_size;
        for (b, body) in file.bodies.iter().enumerate() {
            let Some(m) = materials.get(body_material[b]) else {
                continue;
            };
            let Some(pf) = m.phase_field() else {
                continue;
            };
            // the nodes the body's particles touch: its bounding box, one
            // node of support beyond it (capped by the grid)
            let bb = crate::geometry::bounds_3d(&body.shape);
            let span = |d: usize| {
                let w = ((bb.max[d] - bb.min[d]) / h).ceil().max(0.0) + 3.0;
                w.min(cells[d] as f64 + 1.0)
            };
            let dofs = if three {
                span(0) * span(1) * span(2)
            } else {
                span(0) * span(1)
            };
            let fourth = !super::phase_field_gamma(pf).is_zero();
            // a quadratic B-spline couples a node with its 5 x 5
            // neighbours, 7 x 7 with the 4th-order term's second derivatives
            // (5³ and 7³ in 3D)
            let row: f64 = match (fourth, three) {
                (false, false) => 25.0,
                (true, false) => 49.0,
                (false, true) => 125.0,
                (true, true) => 343.0,
            };
            // row indices (usize), values (f64), assembly keys (u64); the
            // vectors of PCG and the right-hand side per dof
            system += (dofs * row * (8.0 + 8.0 + 8.0) + dofs * 12.0 * 8.0) as u64;
            // nnz(L) ≈ 10.5 n log₂ n (quadratic); the 4th-order stencil
            // fills about twice as much
            let fill = if fourth { 21.0 } else { 10.5 };
            let l = if three {
                // c·n^{4/3}, c matching 10.5 n log₂ n at n = 65 536
                fill * 16.0 / 65_536f64.cbrt() * dofs.powf(4.0 / 3.0)
            } else {
                fill * dofs * dofs.max(2.0).log2()
            };
            // its values: always factorized in f64 (an f32 factorization
            // meets subnormal numbers, slow on x86), and PCG keeps an f32
            // copy beside them as its preconditioner; the supernodal
            // structure and the factorization's workspace, per dof
            let value = match file.phase_field_solver.method {
                // "auto" holds the factor and the hierarchy during its trial
                PhaseFieldMethod::Pcg | PhaseFieldMethod::Auto => 8.0 + 4.0,
                _ => 8.0,
            } + match file.phase_field_solver.ordering {
                // the two halves' own factors beside the whole one's f64
                // values (a direct solve's, or a fall-back's)
                FactorOrdering::Dissection => 8.0,
                FactorOrdering::Amd => 0.0,
            };
            factor += (l * value + dofs * 64.0) as u64;
        }
    }
    let dfg = match &file.dfg {
        Some(spec) => {
            // per particle: surface, normal, damage, key, gradient, the
            // direction table (33 f64), the cone shares (5 x (u16, f64)),
            // cut, partition position, the neighbour list's start and
            // build positions; in 3D the vectors have three components,
            // a particle up to 23 shares, and the direction table is per
            // node (2 · 188 + 1 f64) and only with self-contact
            let state: u64 = if three {
                8 + 24 + 8 + 2 + 24 + 23 * 16 + 4 + 8 + 24 + 4 + 24
            } else {
                8 + 16 + 8 + 2 + 16 + 33 * 8 + 5 * 16 + 8 + 16 + 4 + 16
            };
            let table = if three && spec.self_contact {
                nodes.saturating_mul((2 * 188 + 1) * 8)
            } else {
                0
            };
            // neighbours within radius × h√2: π r² / spacing² of them
            let ppc = file
                .bodies
                .iter()
                .map(|b| b.ppc(file.dimension()) as f64)
                .fold(1.0, f64::max);
            let r = spec.radius * std::f64::consts::SQRT_2;
            let neighbours = if three {
                // within the sphere of radius r·√3/√2 · h
                let r = spec.radius * 3f64.sqrt();
                (4.0 / 3.0 * std::f64::consts::PI * r * r * r * ppc).ceil() as u64
            } else {
                (std::f64::consts::PI * r * r * ppc).ceil() as u64
            };
            n.saturating_mul(state + 4 * neighbours)
                .saturating_add(table)
        }
        None => 0,
    };
    MemoryEstimate {
        program: 16 << 20,
        particles,
        grid,
        phase_field_system: system,
        phase_field_factor: factor,
        dfg,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn proc_limits_are_read() {
        let limits = "Limit                     Soft Limit           Hard Limit           Units     \n\
                      Max cpu time              unlimited            unlimited            seconds   \n\
                      Max address space         4294967296           unlimited            bytes     \n";
        assert_eq!(address_space_limit(limits), Some(4_294_967_296));
        let unlimited =
            "Max address space         unlimited            unlimited            bytes\n";
        assert_eq!(address_space_limit(unlimited), None);
        let meminfo = "MemTotal:       24000000 kB\nMemAvailable:   1000 kB\n";
        assert_eq!(kib_field(meminfo, "MemAvailable:"), Some(1_024_000));
    }

    #[test]
    fn the_tighter_budget_wins() {
        let a = MemoryBudget::of(10, "a");
        let b = MemoryBudget::of(5, "b");
        assert_eq!(a.clone().min(b.clone()), b);
        assert_eq!(MemoryBudget::unlimited().min(a.clone()), a);
        assert_eq!(human_bytes(3 * 1024 * 1024 * 1024 / 2), "1.50 GiB");
    }
}
