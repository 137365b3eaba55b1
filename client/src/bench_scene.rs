//! `cleave bench --scene FILE`: any scene's steps per second at each thread
//! count, with the time of every stage of its plan and the parallel
//! efficiency (issue 37). The scene runs through the same method seam as
//! `cleave run` (`methods::build`), so what is timed is what a run does,
//! minus its output (no series rows, snapshots or checkpoints).

use anyhow::Context;
use cleave::scene::Scene;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// Steps run before the timing starts (the first steps allocate).
const WARMUP: usize = 3;

/// One thread count's measurement.
struct Measured {
    threads: usize,
    steps: usize,
    particles: usize,
    seconds: f64,
    /// (stage name, seconds over the timed steps), in plan order.
    stages: Vec<(&'static str, f64)>,
    /// Seconds of the diagnostics the step measures itself.
    diagnostics: f64,
}

fn measure(scene: &Scene, threads: usize, steps: usize, after: f64) -> anyhow::Result<Measured> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("thread pool")?;
    pool.install(|| {
        let mut m = cleave::methods::build(scene)
            .map_err(|e| anyhow::anyhow!("{}: {e}", scene.file.meta.name))?;
        let end = scene.file.time.end;
        let step = |m: &mut Box<dyn cleave::run::Method>| -> anyhow::Result<bool> {
            if m.time() >= end {
                return Ok(false);
            }
            m.step()
                .map_err(|e| anyhow::anyhow!("step {}: {e}", m.steps() + 1))?;
            Ok(true)
        };
        while m.time() < after && step(&mut m)? {}
        for _ in 0..WARMUP {
            step(&mut m)?;
        }
        let before = m.stage_times().clone();
        let t0 = Instant::now();
        let mut taken = 0;
        while taken < steps && step(&mut m)? {
            taken += 1;
        }
        let seconds = t0.elapsed().as_secs_f64();
        anyhow::ensure!(
            taken > 0,
            "the scene ends before its {WARMUP} warm-up steps are done: nothing to time (lengthen time.end, or lower --after)"
        );
        let after = m.stage_times();
        let stages = after
            .stages
            .iter()
            .map(|t| (t.stage.name(), t.seconds - before.get(t.stage)))
            .collect();
        Ok(Measured {
            threads,
            steps: taken,
            particles: m.particle_count(),
            seconds,
            stages,
            diagnostics: after.diagnostics - before.diagnostics,
        })
    })
}

/// Runs the bench on the scene at `path` for each of `thread_counts`,
/// prints the tables and, with `out`, writes them to that Markdown file.
pub fn run(
    path: &Path,
    out: Option<&Path>,
    steps: usize,
    thread_counts: &[usize],
    after: f64,
) -> anyhow::Result<()> {
    let scene = Scene::from_path(path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let mut runs = Vec::new();
    for &threads in thread_counts {
        let m = measure(&scene, threads, steps, after)?;
        eprintln!(
            "{} threads: {} steps in {:.3} s{}",
            threads,
            m.steps,
            m.seconds,
            if after > 0.0 {
                format!(" (from t = {after:e} s)")
            } else {
                String::new()
            }
        );
        runs.push(m);
    }
    let base = &runs[0];
    let per_step = |m: &Measured| m.seconds / m.steps as f64;
    let mut md = String::new();
    let _ = writeln!(
        md,
        "| threads | steps | ms / step | M particle-steps / s | speed-up | efficiency |\n|---:|---:|---:|---:|---:|---:|"
    );
    println!(
        "{:>8} {:>6} {:>10} {:>12} {:>9} {:>11}",
        "threads", "steps", "ms/step", "Mp-steps/s", "speed-up", "efficiency"
    );
    for m in &runs {
        let speedup = per_step(base) / per_step(m);
        // against perfect scaling from the first count
        let efficiency = speedup * base.threads as f64 / m.threads as f64;
        let rate = m.particles as f64 / per_step(m) / 1e6;
        println!(
            "{:>8} {:>6} {:>10.3} {:>12.3} {:>9.2} {:>10.0}%",
            m.threads,
            m.steps,
            1e3 * per_step(m),
            rate,
            speedup,
            100.0 * efficiency
        );
        let _ = writeln!(
            md,
            "| {} | {} | {:.3} | {:.3} | {:.2} | {:.0} % |",
            m.threads,
            m.steps,
            1e3 * per_step(m),
            rate,
            speedup,
            100.0 * efficiency
        );
    }
    // the stages, ms per step at each count, and each one's speed-up
    let counts: Vec<String> = runs.iter().map(|m| format!("{} thr", m.threads)).collect();
    println!();
    print!("{:>22}", "stage (ms/step)");
    for c in &counts {
        print!(" {c:>10}");
    }
    println!(" {:>9}", "speed-up");
    let _ = writeln!(
        md,
        "\n| stage, ms / step | {} | speed-up |\n|---|{}---:|",
        counts.join(" | "),
        "---:|".repeat(counts.len())
    );
    let rows: Vec<(&str, Vec<f64>)> = base
        .stages
        .iter()
        .enumerate()
        .map(|(k, &(name, _))| {
            (
                name,
                runs.iter()
                    .map(|m| 1e3 * m.stages[k].1 / m.steps as f64)
                    .collect(),
            )
        })
        .chain(std::iter::once((
            "(diagnostics)",
            runs.iter()
                .map(|m| 1e3 * m.diagnostics / m.steps as f64)
                .collect(),
        )))
        .collect();
    for (name, ms) in &rows {
        let last = ms.last().copied().unwrap_or(0.0);
        // a stage that took no time has no speed-up
        let speedup = if last > 0.0 {
            format!("{:.2}", ms[0] / last)
        } else {
            "–".into()
        };
        print!("{name:>22}");
        for v in ms {
            print!(" {v:>10.3}");
        }
        println!(" {speedup:>9}");
        let cells: Vec<String> = ms.iter().map(|v| format!("{v:.3}")).collect();
        let _ = writeln!(md, "| {name} | {} | {speedup} |", cells.join(" | "));
    }
    if let Some(out) = out {
        let list: Vec<String> = thread_counts.iter().map(|t| t.to_string()).collect();
        let doc = format!(
            "# `{}` on {} ({} logical CPUs)\n\n\
             Measured by `cargo run --release -p cleave-client -- bench --scene {}{} --steps {steps} --threads {}`: \
             {} particles, {}{WARMUP} warm-up steps, then up to {steps} steps timed (fewer where the scene ends), \
             each thread count in its own pool, back to back in one process. \
             Efficiency is the speed-up over the ratio of thread counts (100 % is perfect scaling); \
             a stage's speed-up is from the first thread count to the last.\n\n{md}",
            path.display(),
            crate::bench::cpu_name(),
            std::thread::available_parallelism().map_or(0, |n| n.get()),
            path.display(),
            if after > 0.0 { format!(" --after {after:e}") } else { String::new() },
            list.join(","),
            base.particles,
            if after > 0.0 { format!("run untimed to t = {after:e} s, then ") } else { String::new() },
        );
        if let Some(dir) = out.parent() {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        }
        std::fs::write(out, doc).with_context(|| format!("writing {}", out.display()))?;
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}
