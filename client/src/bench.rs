//! `cleave bench`: particle-steps per second of the explicit step for a 2D
//! linear-elastic block (quadratic B-splines or the kernels of `--kernel`,
//! 4 particles per cell) or,
//! with `--dim 3`, a 3D neo-Hookean APIC block (8 particles per cell, with
//! bytes per particle and optionally Taichi on the same block) at several
//! sizes and thread counts. Prints the table and writes it to a Markdown
//! file.

use anyhow::Context;
use cleave::mpm::Simulation;
use cleave::scene::{Scene, Stage};
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// The run of a validated scene by its method, as the library builds it:
/// the benchmarks step it through the trait object, so that the step is
/// compiled once, in the library, and not again in this binary (whose
/// release build it cost minutes: docs/ci.md).
pub(crate) fn built(scene: &Scene) -> anyhow::Result<Box<dyn cleave::run::Method>> {
    cleave::methods::build(scene).map_err(|e| anyhow::anyhow!("{e}"))
}

/// The benchmark block: `cells × cells` cells of material with 2 × 2
/// particles each, in a grid with a 4-cell margin, stretching and spinning
/// slowly so the particles move.
fn scene(cells: usize, transfer: &str, kernel: &str) -> anyhow::Result<Scene> {
    Scene::from_text(&scene_text(cells, transfer, kernel), None)
        .map_err(|e| anyhow::anyhow!("benchmark scene: {e}"))
}

/// The text of [`scene`].
fn scene_text(cells: usize, transfer: &str, kernel: &str) -> String {
    let h = 1.0 / cells as f64;
    let m = 4.0 * h;
    format!(
        r#"
[grid]
cell_size = {h:e}
min = [{neg:e}, {neg:e}]
max = [{pos:e}, {pos:e}]
shape_function = "{kernel}"

[time]
end = 1.0
cfl = 0.5

[transfer]
scheme = "{transfer}"

[[bodies]]
shape = {{ type = "box", min = [0.0, 0.0], max = [1.0, 1.0] }}
material = {{ model = "linear_elastic", density = 1000.0, youngs_modulus = 1.0e7, poissons_ratio = 0.3 }}
particles_per_cell = 4
velocity_gradient = [[1.0, -2.0], [2.0, -1.0]]

[output]
snapshots = 0
"#,
        neg = -m,
        pos = 1.0 + m,
    )
}

/// One configuration's result.
struct Measured {
    /// Particle-steps per second.
    rate: f64,
    /// Seconds per step.
    per_step: f64,
    /// Seconds per step in P2G, grid update, G2P.
    stages: [f64; 3],
    /// Mean Δt of the timed steps (the CFL's), s; the 3D bench's Taichi
    /// run takes this one.
    dt: f64,
    /// Heap bytes of the particle arrays and of the grid side, after the
    /// timed steps (so any growth counts).
    bytes: cleave::mpm::HeapBytes,
    particles: usize,
}

/// Particle-steps per second over `steps` steps (after 3 warm-up steps)
/// of the `D`-dimensional simulation of `scene`.
fn measure<const D: usize, const V: usize>(
    scene: &Scene,
    threads: usize,
    steps: usize,
) -> anyhow::Result<Measured>
where
    cleave::particles::Particles<D, V>: cleave::mpm::Saved,
{
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("thread pool")?;
    pool.install(|| {
        let mut sim = built(scene)?;
        for _ in 0..3 {
            sim.step()?;
        }
        let before = sim.stage_times().clone();
        let mut dt = 0.0;
        let t0 = Instant::now();
        for _ in 0..steps {
            dt += sim.step()?;
        }
        let secs = t0.elapsed().as_secs_f64();
        let after = sim.stage_times();
        let per = |a: f64, b: f64| (a - b) / steps as f64;
        let particles = sim.particle_count();
        let grid_run = (*sim)
            .as_any()
            .downcast_ref::<Simulation<D, V>>()
            .context("the block runs on the grid")?;
        Ok(Measured {
            rate: particles as f64 * steps as f64 / secs,
            per_step: secs / steps as f64,
            stages: [
                // LME's kept supports are evaluated for the scatter first
                per(
                    after.sum(|s| matches!(s, Stage::Supports | Stage::P2g)),
                    before.sum(|s| matches!(s, Stage::Supports | Stage::P2g)),
                ),
                per(after.get(Stage::GridUpdate), before.get(Stage::GridUpdate)),
                per(
                    after.sum(|s| matches!(s, Stage::G2p | Stage::Rebin)),
                    before.sum(|s| matches!(s, Stage::G2p | Stage::Rebin)),
                ),
            ],
            dt: dt / steps as f64,
            bytes: grid_run.heap_bytes(),
            particles,
        })
    })
}

pub fn run(
    out: &Path,
    steps: usize,
    largest: usize,
    transfers: &str,
    kernels: &str,
    thread_counts: &[usize],
) -> anyhow::Result<()> {
    let sizes: Vec<usize> = [128usize, 256, 512]
        .into_iter()
        .filter(|&c| c <= largest)
        .collect();
    let mut table = String::new();
    let _ = writeln!(table, "| kernel | transfer | particles | threads | ms / step | M particle-steps / s | speed-up | P2G ms | grid ms | G2P ms |");
    let _ = writeln!(table, "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    println!(
        "{:>17} {:>8} {:>10} {:>8} {:>10} {:>12} {:>9}",
        "kernel", "transfer", "particles", "threads", "ms/step", "Mp-steps/s", "speed-up"
    );
    let pairs = kernels
        .split(',')
        .map(str::trim)
        .flat_map(|k| transfers.split(',').map(str::trim).map(move |t| (k, t)));
    for (kernel, transfer) in pairs {
        for &cells in &sizes {
            let sc = scene(cells, transfer, kernel)?;
            let n = sc.total_particles();
            let mut base = 0.0;
            for (i, &threads) in thread_counts.iter().enumerate() {
                let m = measure::<2, 3>(&sc, threads, steps)?;
                if i == 0 {
                    base = m.rate;
                }
                let speedup = m.rate / base;
                println!(
                    "{kernel:>17} {transfer:>8} {n:>10} {threads:>8} {:>10.2} {:>12.2} {speedup:>9.2}",
                    1e3 * m.per_step,
                    m.rate / 1e6
                );
                let _ = writeln!(
                    table,
                    "| {kernel} | {transfer} | {n} | {threads} | {:.2} | {:.2} | {speedup:.2} | {:.2} | {:.2} | {:.2} |",
                    1e3 * m.per_step,
                    m.rate / 1e6,
                    1e3 * m.stages[0],
                    1e3 * m.stages[1],
                    1e3 * m.stages[2]
                );
            }
        }
    }
    let machine = cpu_name();
    let doc = format!(
        "# Performance of the explicit step\n\n\
         Measured by `cargo run --release -p cleave-client -- bench --steps {steps} --transfer {transfers}{kernel_arg}{largest_arg}{threads_arg}` on {machine} \
         ({} logical CPUs). A 2D linear-elastic block (plane strain), the kernels named (LME at the default \
         locality γ = 4), 2 × 2 particles per cell, \
         USL, CFL 0.5; the block spins and stretches so particles cross cells. Each row is the mean over {steps} steps \
         after 3 warm-up steps; {thread_list} threads run back to back in the same process, so their ratio is meaningful \
         even on a noisy machine. P2G includes, for LME, the `supports` stage that evaluates each particle's \
         support once for the step's transfers; G2P includes the particle update (strain, stress, guards) and the tile \
         re-binning.\n\n{table}\n\
         Target (issue 2): at least 16 M particle-steps/s with 2 threads at 1 M particles in f64; Taichi's CPU \
         backend reaches 14–18 M on such a machine single-threaded and 8–10 M with 2 threads (atomics). The scatter \
         has no atomics: tiles of 8 × 8 cells are coloured so that tiles of one colour never share a node, and \
         the particles are stored tile by tile, so each tile reads a contiguous range of every particle array. \
         Storing them in seeding order instead (rows across the whole body) cost 40 % at 1 M particles \
         (P2G 58 ms instead of 29 ms on one thread; `cleave bench` at commit fe9ff49, before the sort).\n\n\
         Against Taichi's CPU backend on the same machine in the same run (issue 37's peer problem: \
         neo-Hookean, APIC): `docs/performance-taichi.md`, by `cleave bench --taichi PYTHON`.\n",
        std::thread::available_parallelism().map_or(0, |n| n.get()),
        threads_arg = threads_arg(thread_counts),
        thread_list = thread_list(thread_counts),
        largest_arg = if largest == 512 {
            String::new()
        } else {
            format!(" --largest {largest}")
        },
        kernel_arg = if kernels == "quadratic_bspline" {
            String::new()
        } else {
            format!(" --kernel {kernels}")
        },
    );
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::write(out, doc).with_context(|| format!("writing {}", out.display()))?;
    println!("written to {}", out.display());
    Ok(())
}

/// The 3D benchmark block (issue 32's speed problem): `cells`³ cells of
/// neo-Hookean material with 2 × 2 × 2 particles each, quadratic
/// B-splines, APIC, in a grid with a 4-cell margin, stretching and spinning
/// slowly so the particles move. The same block as the 2D bench's but for
/// the material (the issue asks for neo-Hookean) and the transfer (APIC,
/// what Taichi's MLS-MPM does).
fn scene_3d(cells: usize) -> anyhow::Result<Scene> {
    let h = 1.0 / cells as f64;
    let m = 4.0 * h;
    let text = format!(
        r#"
[grid]
cell_size = {h:e}
min = [{neg:e}, {neg:e}, {neg:e}]
max = [{pos:e}, {pos:e}, {pos:e}]
shape_function = "quadratic_bspline"

[time]
end = 1.0
cfl = 0.5

[transfer]
scheme = "apic"

[[bodies]]
shape = {{ type = "box", min = [0.0, 0.0, 0.0], max = [1.0, 1.0, 1.0] }}
material = {{ model = "neo_hookean", density = 1000.0, youngs_modulus = 1.0e7, poissons_ratio = 0.3 }}
particles_per_cell = 8
velocity_gradient = [[1.0, -2.0, 0.0], [2.0, -1.0, 0.0], [0.0, 0.0, 0.5]]

[output]
snapshots = 0
"#,
        neg = -m,
        pos = 1.0 + m,
    );
    Scene::from_text(&text, None).map_err(|e| anyhow::anyhow!("3D benchmark scene: {e}"))
}

/// The 2D peer problem (issue 37's): the 3D block's material and transfer
/// on the 2D bench's block, `cells`² cells of neo-Hookean material (plane
/// strain) with 2 × 2 particles each, quadratic B-splines, APIC.
fn scene_peer_2d(cells: usize) -> anyhow::Result<Scene> {
    let text = scene_text(cells, "apic", "quadratic_bspline")
        .replace("model = \"linear_elastic\"", "model = \"neo_hookean\"");
    Scene::from_text(&text, None).map_err(|e| anyhow::anyhow!("2D peer scene: {e}"))
}

/// The Taichi scripts, embedded so the bench runs them from any directory.
const TAICHI_SCRIPT_2D: &str = include_str!("../../docs/scripts/taichi_mpm2d.py");
const TAICHI_SCRIPT_3D: &str = include_str!("../../docs/scripts/taichi_mpm3d.py");

/// Runs the Taichi script on the same block (`cells`, `dt`) and returns its
/// particle-steps per second and particle count.
fn taichi(
    python: &Path,
    script: &Path,
    cells: usize,
    threads: usize,
    steps: usize,
    dt: f64,
) -> anyhow::Result<(f64, usize)> {
    let out = std::process::Command::new(python)
        .arg(script)
        .args(["--cells", &cells.to_string()])
        .args(["--threads", &threads.to_string()])
        .args(["--steps", &steps.to_string()])
        .args(["--dt", &format!("{dt:e}")])
        .output()
        .with_context(|| format!("running {}", python.display()))?;
    let stdout = String::from_utf8_lossy(&out.stdout);
    anyhow::ensure!(
        out.status.success(),
        "the Taichi script failed ({}): {}",
        out.status,
        String::from_utf8_lossy(&out.stderr).trim()
    );
    let field = |name: &str| {
        stdout
            .lines()
            .find_map(|l| l.strip_prefix(name))
            .map(str::trim)
            .with_context(|| format!("no `{name}` line in the Taichi script's output: {stdout}"))
    };
    let rate: f64 = field("rate ")?.parse().context("the Taichi rate")?;
    let n: usize = field("particles ")?
        .parse()
        .context("the Taichi particle count")?;
    Ok((rate, n))
}

/// Peak resident set of this process so far, bytes (Linux; 0 elsewhere).
fn peak_rss() -> usize {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("VmHWM:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<usize>().ok())
        })
        .map_or(0, |kb| kb * 1024)
}

/// `/proc/loadavg`'s first three fields, or `unknown`.
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(", "))
        .unwrap_or_else(|| "unknown".into())
}

pub(crate) fn cpu_name() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|c| {
            c.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
        + &format!(
            "; transfer loops in the {:?} copy (`cleave::cpu`)",
            cleave::cpu::level()
        )
}

/// The thread counts as the docs say them: "1 and 2", "1, 2 and 4".
fn thread_list(counts: &[usize]) -> String {
    let words: Vec<String> = counts.iter().map(|t| t.to_string()).collect();
    match words.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} and {last}", rest.join(", ")),
        _ => words.join(""),
    }
}

/// `--threads LIST` for the command line a doc quotes, empty for the
/// default 1 and 2.
fn threads_arg(counts: &[usize]) -> String {
    if counts == [1, 2] {
        String::new()
    } else {
        let list: Vec<String> = counts.iter().map(|t| t.to_string()).collect();
        format!(" --threads {}", list.join(","))
    }
}

/// `cleave bench --dim 3`: the 3D block at 16³, 32³ and 50³ cells (32 k,
/// 262 k, 1 M particles) up to `largest` (a `largest` below 16 runs that one
/// size, for tests), 1 and 2 threads, with bytes per particle and, given a
/// Python with Taichi, Taichi's rate on the same block in the same run.
/// With `dim` 2 (`cleave bench --taichi`), the 2D peer problem
/// ([`scene_peer_2d`]) at 128², 256² and 512² cells (65 k, 262 k, 1 M
/// particles) against `docs/scripts/taichi_mpm2d.py`.
pub fn run_peer(
    dim: u8,
    out: &Path,
    steps: usize,
    largest: usize,
    python: Option<&Path>,
    thread_counts: &[usize],
) -> anyhow::Result<()> {
    anyhow::ensure!(largest >= 1, "--largest must be at least 1");
    let (all_sizes, script_text) = match dim {
        2 => ([128usize, 256, 512], TAICHI_SCRIPT_2D),
        _ => ([16usize, 32, 50], TAICHI_SCRIPT_3D),
    };
    let mut sizes: Vec<usize> = all_sizes.into_iter().filter(|&c| c <= largest).collect();
    if sizes.is_empty() {
        sizes.push(largest);
    }
    let script = match python {
        Some(_) => {
            let p = std::env::temp_dir()
                .join(format!("cleave-taichi-mpm{dim}d-{}.py", std::process::id()));
            std::fs::write(&p, script_text).with_context(|| format!("writing {}", p.display()))?;
            Some(p)
        }
        None => None,
    };
    // The load average before and after goes into the doc: on a shared
    // machine the 2-thread speed-up says as much about the other jobs as
    // about the code.
    let load_before = load_average();
    let result = (|| -> anyhow::Result<String> {
        let mut table = String::new();
        let _ = write!(
            table,
            "| particles | threads | ms / step | M particle-steps / s | speed-up | P2G ms | grid ms | G2P ms | \
             bytes / particle (particles + grid) | peak RSS MB |"
        );
        if python.is_some() {
            let _ = write!(table, " Taichi M particle-steps / s | cleave / Taichi |");
        }
        let _ = writeln!(table);
        let _ = write!(table, "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
        if python.is_some() {
            let _ = write!(table, "---:|---:|");
        }
        let _ = writeln!(table);
        println!(
            "{:>10} {:>8} {:>10} {:>12} {:>9} {:>10} {:>12}",
            "particles",
            "threads",
            "ms/step",
            "Mp-steps/s",
            "speed-up",
            "B/particle",
            "Taichi Mp/s"
        );
        for &cells in &sizes {
            let sc = match dim {
                2 => scene_peer_2d(cells)?,
                _ => scene_3d(cells)?,
            };
            let mut base = 0.0;
            let mut dt = None;
            for (i, &threads) in thread_counts.iter().enumerate() {
                let r = match dim {
                    2 => measure::<2, 3>(&sc, threads, steps)?,
                    _ => measure::<3, 6>(&sc, threads, steps)?,
                };
                let n = r.particles;
                if i == 0 {
                    base = r.rate;
                }
                // Taichi takes the Δt of cleave's one-thread run, so both
                // codes step the same block with the same step.
                let dt = *dt.get_or_insert(r.dt);
                let speedup = r.rate / base;
                let bpp = (r.bytes.particles + r.bytes.grid) as f64 / n as f64;
                let (pb, gb) = (
                    r.bytes.particles as f64 / n as f64,
                    r.bytes.grid as f64 / n as f64,
                );
                let rss = peak_rss() as f64 / 1e6;
                let ti = match (python, &script) {
                    (Some(py), Some(s)) => {
                        let (rate, tn) = taichi(py, s, cells, threads, steps, dt)?;
                        anyhow::ensure!(
                            tn == n,
                            "Taichi seeded {tn} particles, cleave {n}: not the same problem"
                        );
                        Some(rate)
                    }
                    _ => None,
                };
                println!(
                    "{n:>10} {threads:>8} {:>10.2} {:>12.2} {speedup:>9.2} {bpp:>10.0} {:>12}",
                    1e3 * r.per_step,
                    r.rate / 1e6,
                    ti.map_or("-".into(), |t| format!("{:.2}", t / 1e6))
                );
                let _ = write!(
                    table,
                    "| {n} | {threads} | {:.2} | {:.2} | {speedup:.2} | {:.2} | {:.2} | {:.2} | {bpp:.0} ({pb:.0} + {gb:.0}) | {rss:.0} |",
                    1e3 * r.per_step,
                    r.rate / 1e6,
                    1e3 * r.stages[0],
                    1e3 * r.stages[1],
                    1e3 * r.stages[2],
                );
                if let Some(t) = ti {
                    let _ = write!(table, " {:.2} | {:.2} |", t / 1e6, r.rate / t);
                }
                let _ = writeln!(table);
            }
        }
        Ok(table)
    })();
    if let Some(s) = &script {
        let _ = std::fs::remove_file(s);
    }
    let table = result?;
    let load_after = load_average();
    let command = format!(
        "cargo run --release -p cleave-client -- bench{} --steps {steps} --largest {largest}{}{}",
        if dim == 3 { " --dim 3" } else { "" },
        threads_arg(thread_counts),
        python.map_or(String::new(), |p| format!(" --taichi {}", p.display()))
    );
    let taichi_text = if python.is_some() {
        format!(
            "The Taichi columns are `docs/scripts/taichi_mpm{dim}d.py` (Taichi 1.7.4, `arch=ti.cpu`, f64, \
             `cpu_max_num_threads` = the row's threads) on the same block: same particles, same velocity \
             gradient, the Δt of cleave's one-thread run, MLS-MPM/APIC with quadratic B-splines and the same \
             neo-Hookean law, a dense grid and atomic scatter; timed over the same number of steps after 3 \
             warm-up steps between two `ti.sync()`s. Each Taichi row runs right after the cleave row above it, \
             so both see the same machine load.\n\n"
        )
    } else {
        "No Taichi columns: add `--taichi PYTHON` (a Python with Taichi 1.7.4) to run \
         `docs/scripts/taichi_mpm3d.py` on the same block in the same run.\n\n"
            .to_string()
    };
    let (title, problem, target) = match dim {
        2 => (
            "# The explicit step against Taichi in 2D",
            "A 2D neo-Hookean block in plane strain (issue 37's peer problem), quadratic B-splines, 2 × 2 \
             particles per cell, APIC",
            "Target (issue 37): one thread at least 1.2× Taichi's one thread on this problem in the same run, \
             and 2 threads at least 1.9× one thread (the issue's measurement on a 16-core Xeon: Taichi 1.7.4 \
             13.5 M particle-steps/s on one thread and 35.4 M on 16; cleave 9.4 M and 96.1 M).",
        ),
        _ => (
            "# Performance of the explicit step in 3D",
            "A 3D neo-Hookean block (issue 32's speed \
             problem), quadratic B-splines, 2 × 2 × 2 particles per cell, APIC (fixed: `--transfer` does not apply \
             in 3D)",
            "Target (issue 32): at least Taichi's 3D CPU backend per thread on the same problem in the same run \
             (Taichi 1.7.4 measured 2.1 M particle-steps/s on one thread of a 16-core Xeon, 7.4 M on 16 threads).",
        ),
    };
    let doc = format!(
        "{title}\n\n\
         Measured by `{command}` on {machine} ({cpus} logical CPUs). {problem}, USL, CFL 0.5; the block spins and stretches so particles cross cells. Each row is the mean over \
         {steps} steps after 3 warm-up steps; {thread_list} threads run back to back in the same process; the \
         speed-up is against the first. G2P includes \
         the particle update (F, stress, guards) and the tile re-binning.\n\n\
         **Bytes per particle** are counted, not sampled: the capacities × element sizes of every particle array \
         (`Particles`, struct of arrays) plus the grid side (nodal mass, momentum, force and velocities, the tile \
         bins, the scratch of next positions), divided by the particle count, after the timed steps \
         (`Simulation::heap_bytes`). Per-material and per-model state and the allocator's own overhead are left \
         out. *Peak RSS* is the process's high-water mark (`VmHWM`) after the row, so it includes every earlier \
         (smaller) run and the binary itself; it is a cross-check, not a per-size figure.\n\n\
         {taichi_text}{table}\n\
         Load average (1, 5, 15 min) before the run: {load_before}; after: {load_after}. A load above the \
         CPU count means other jobs shared the cores, and the 2-thread rows (of both codes) then measure \
         the machine as much as the code.\n\n\
         {target}\n",
        machine = cpu_name(),
        cpus = std::thread::available_parallelism().map_or(0, |n| n.get()),
        thread_list = thread_list(thread_counts),
    );
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::write(out, doc).with_context(|| format!("writing {}", out.display()))?;
    println!("written to {}", out.display());
    Ok(())
}

/// A block scene of `cells`² cells for the service benchmark.
fn service_scene(cells: usize, end_steps: usize, snapshots: u32) -> String {
    let h = 1.0 / cells as f64;
    // c = 36.7 m/s for this material; CFL 0.5
    let dt = 0.5 * h / 36.7;
    format!(
        r#"
[grid]
cell_size = {h:e}
min = [{m:e}, {m:e}]
max = [{p:e}, {p:e}]
[time]
end = {end:e}
dt = {dt:e}
[[bodies]]
shape = {{ type = "box", min = [0.0, 0.0], max = [1.0, 1.0] }}
material = {{ model = "linear_elastic", density = 1000.0, youngs_modulus = 1.0e6, poissons_ratio = 0.3 }}
velocity_gradient = [[0.0, -0.5], [0.5, 0.0]]
[output]
series_rows = 200
snapshots = {snapshots}
"#,
        m = -4.0 * h,
        p = 1.0 + 4.0 * h,
        end = dt * end_steps as f64 * 0.999,
    )
}

pub(crate) fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

/// `cleave bench-service`: the overhead of running a scene through a server
/// (in this process, over loopback gRPC) instead of embedded, and the
/// FetchFields throughput.
pub fn run_service(out: &Path, repeats: usize) -> anyhow::Result<()> {
    use cleave::service::proto::{self, cleave_client::CleaveClient};
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let data = std::env::temp_dir().join(format!("cleave-bench-service-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&data);
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    let listener = rt.block_on(tokio::net::TcpListener::bind("127.0.0.1:0"))?;
    let url = format!("http://{}", listener.local_addr()?);
    let config = cleave::service::ServerConfig {
        listen: listener.local_addr()?,
        jobs: cleave::jobs::JobConfig {
            data_dir: data.clone(),
            max_concurrent: 1,
            threads_per_job: threads,
            max_particles: u64::MAX,
            max_memory: None,
            max_queued: 100,
            store: cleave::jobs::StoreSpec::Sqlite,
            results: cleave::jobs::ResultsSpec::DataDir,
            // the overhead measured is that of the service alone
            checkpoint_every: None,
        },
        token: None,
        max_request_bytes: 16 << 20,
        tls: None,
    };
    let (stop_tx, stop_rx) = tokio::sync::oneshot::channel::<()>();
    let server = rt.spawn(cleave::service::serve_on(listener, config, async {
        let _ = stop_rx.await;
    }));
    let result = (|| -> anyhow::Result<String> {
        let mut client = rt.block_on(async {
            for _ in 0..50 {
                if let Ok(c) = CleaveClient::connect(url.clone()).await {
                    return Ok(c.max_decoding_message_size(usize::MAX));
                }
                tokio::time::sleep(std::time::Duration::from_millis(20)).await;
            }
            anyhow::bail!("the in-process server did not come up")
        })?;
        // 1. Overhead: the same scene embedded (with the CLI's output writer)
        // and through the server, alternating.
        let text = service_scene(256, 300, 6);
        let scene = Scene::from_text(&text, None).map_err(|e| anyhow::anyhow!("{e}"))?;
        let (mut embedded, mut served, mut bare) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..repeats {
            let t0 = Instant::now();
            built(&scene)?.run(&mut NoOutput)?;
            bare.push(t0.elapsed().as_secs_f64());
            let dir = data.join(format!("embedded-{k}"));
            let t0 = Instant::now();
            let mut writer = cleave::output::OutputWriter::create(&dir)?;
            built(&scene)?.run(&mut writer)?;
            writer.finish()?;
            embedded.push(t0.elapsed().as_secs_f64());
            let t0 = Instant::now();
            rt.block_on(async {
                let job = client
                    .submit_job(proto::SubmitJobRequest {
                        scene: text.clone(),
                        ..Default::default()
                    })
                    .await?
                    .into_inner();
                let mut s = client
                    .watch_job(proto::WatchJobRequest {
                        job_id: job.id.clone(),
                    })
                    .await?
                    .into_inner();
                while s.message().await?.is_some() {}
                let j = client
                    .get_job(proto::GetJobRequest {
                        job_id: job.id,
                        view: proto::JobView::Basic as i32,
                    })
                    .await?
                    .into_inner();
                anyhow::ensure!(
                    j.state == proto::JobState::Succeeded as i32,
                    "benchmark job failed: {}",
                    j.error
                );
                Ok::<_, anyhow::Error>(())
            })?;
            served.push(t0.elapsed().as_secs_f64());
            println!(
                "run {k}: compute only {:.3} s, embedded {:.3} s, through the server {:.3} s",
                bare[k], embedded[k], served[k]
            );
        }
        let (e, s, c) = (
            median(embedded.clone()),
            median(served.clone()),
            median(bare.clone()),
        );
        let overhead = 100.0 * (s / e - 1.0);
        let over_compute = 100.0 * (s / c - 1.0);
        // 2. FetchFields throughput on the snapshot of a 1 M particle block.
        let big = service_scene(512, 1, 2);
        let (id, bytes, fetch) = rt.block_on(async {
            let job = client
                .submit_job(proto::SubmitJobRequest {
                    scene: big,
                    ..Default::default()
                })
                .await?
                .into_inner();
            let mut st = client
                .watch_job(proto::WatchJobRequest {
                    job_id: job.id.clone(),
                })
                .await?
                .into_inner();
            while st.message().await?.is_some() {}
            let mut times = Vec::new();
            let mut bytes = 0usize;
            for _ in 0..repeats.max(3) {
                let t0 = Instant::now();
                let mut st = client
                    .fetch_fields(proto::FetchFieldsRequest {
                        job_id: job.id.clone(),
                        snapshot: 0,
                        location: proto::Location::Particles as i32,
                        ..Default::default()
                    })
                    .await?
                    .into_inner();
                bytes = 0;
                while let Some(c) = st.message().await? {
                    bytes += c.data.len();
                }
                times.push(t0.elapsed().as_secs_f64());
            }
            Ok::<_, anyhow::Error>((job.id, bytes, median(times)))
        })?;
        let mbps = bytes as f64 / fetch / 1e6;
        println!("overhead {overhead:+.2} % (median embedded {e:.3} s, server {s:.3} s); FetchFields {:.1} MB in {fetch:.3} s = {mbps:.0} MB/s ({id})", bytes as f64 / 1e6);
        let rows: String = (0..repeats)
            .map(|k| {
                let (x, a, b) = (bare[k], embedded[k], served[k]);
                format!(
                    "| {k} | {x:.3} | {a:.3} | {b:.3} | {:+.2} % |\n",
                    100.0 * (b / a - 1.0)
                )
            })
            .collect();
        Ok(format!(
            "# Service performance\n\n\
             Measured by `cargo run --release -p cleave-client -- bench-service --repeats {repeats}` on {threads} cores. \
             The server runs in the same process (tonic over loopback TCP), with one job at a time on {threads} threads.\n\n\
             ## Overhead of running through the server\n\n\
             A {n}-particle block, 300 steps, 6 snapshots, 200 series rows. *Embedded* is what `cleave run` does \
             (simulation plus VTK, CSV and PNG output); *server* is submit → watch until the final event (the job \
             writes its series and binary snapshots); *compute only* is the simulation with no output at all. The runs \
             alternate, so all see the same machine load. Target: under 2 %.\n\n\
             | run | compute only s | embedded s | server s | server vs embedded |\n|---:|---:|---:|---:|---:|\n{rows}\n\
             Median: embedded {e:.3} s, server {s:.3} s: **{overhead:+.2} %**. The server is not slower than `cleave run` \
             because its snapshots are a raw binary dump while `cleave run` writes VTK and a PNG; against the bare \
             simulation (median {c:.3} s) the server costs {over_compute:+.2} %, which is the price of its snapshot files, \
             the series and the event stream.\n\n\
             ## FetchFields throughput\n\n\
             All particle fields of a {big_n}-particle snapshot ({mb:.1} MB in chunks of at most 1 MiB), median of \
             {reps} fetches: {fetch:.3} s, **{mbps:.0} MB/s** (target: above 500 MB/s).\n",
            n = scene.total_particles(),
            big_n = 512 * 512 * 4,
            mb = bytes as f64 / 1e6,
            reps = repeats.max(3),
        ))
    })();
    let _ = stop_tx.send(());
    let _ = rt.block_on(server);
    let _ = std::fs::remove_dir_all(&data);
    let doc = result?;
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(out, doc).with_context(|| format!("writing {}", out.display()))?;
    println!("written to {}", out.display());
    Ok(())
}

/// An observer that keeps nothing (compute-only timing).
struct NoOutput;

impl cleave::diagnostics::Observer for NoOutput {
    fn series_columns(&mut self, _: &[String]) -> Result<(), String> {
        Ok(())
    }
    fn series_row(&mut self, _: &cleave::diagnostics::SeriesRow) -> Result<(), String> {
        Ok(())
    }
    fn snapshot(&mut self, _: &cleave::diagnostics::Snapshot) -> Result<(), String> {
        Ok(())
    }
}
