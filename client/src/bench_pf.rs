//! `cleave bench-phase-field`: where the time of a phase-field step goes,
//! for a scene (by default `p1_plate.toml` at the paper's resolution), with the direct
//! solve (the baseline) and the two warm-started PCGs (the last factor, the
//! multigrid) in the same run, from t = 0 or from a checkpoint; then every
//! kind of numeric factorization a run makes, timed alone on the PCG run's
//! matrix at the start and (with `--late`) at a late instant (the timed
//! steps above never include one: PCG's factor is made in the warm-up).
//! Prints the tables and writes them to a Markdown file, above the file's
//! `KEEP_BELOW` line: what a person wrote under that line survives a
//! re-run.

use anyhow::Context;
use cleave::checkpoint::Checkpoint;
use cleave::fracture::phase_field::model::PhaseFields;
use cleave::fracture::phase_field::system::FactorKind;
use cleave::mpm::Simulation;
use cleave::run::Method;
use cleave::scene::{PhaseFieldMethod, Scene, Stage};
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// Seconds per step of one method.
struct Split {
    method: &'static str,
    /// P2G, traction, grid update, G2P, re-binning.
    mpm: f64,
    assembly: f64,
    /// Symbolic analysis and numeric factorization.
    factorization: f64,
    /// Triangular solves, PCG iterations.
    solve: f64,
    /// Mapping c to particles, degradation, stagger check.
    other_pf: f64,
    /// Wall time per step (includes the series diagnostics: none here).
    wall: f64,
    factorizations: u64,
    analyses: u64,
    pcg_iterations: f64,
}

/// Seconds per numeric factorization of each kind at one instant.
struct FactorTimes {
    time: f64,
    unknowns: usize,
    preconditioner: f64,
    direct: f64,
}

/// The scene's phase fields (the model whose solver is timed here).
fn phase_fields(sim: &mut dyn Method) -> anyhow::Result<&mut PhaseFields> {
    sim.as_any_mut()
        .downcast_mut::<Simulation>()
        .and_then(|s| s.model_mut::<PhaseFields>())
        .context("the scene has no phase field (in a 2D grid run)")
}

/// Times `repeats` factorizations of each kind a run makes on the
/// simulation's current matrices (the seconds the run's stats count).
fn time_factorizations(sim: &mut dyn Method, repeats: usize) -> anyhow::Result<FactorTimes> {
    let mut seconds = [0.0; 2];
    for _ in 0..repeats {
        // the preconditioner last: the run goes on with the factor it would have
        for (k, kind) in [FactorKind::Direct, FactorKind::Preconditioner]
            .into_iter()
            .enumerate()
        {
            let pf = phase_fields(sim)?;
            let before = pf.stats();
            pf.factorize_kind(kind)?;
            seconds[k] += pf.stats().factorization - before.factorization;
        }
    }
    let unknowns = phase_fields(sim)?.unknowns();
    Ok(FactorTimes {
        time: sim.time(),
        unknowns,
        direct: seconds[0] / repeats as f64,
        preconditioner: seconds[1] / repeats as f64,
    })
}

/// What `measure` does after its timed steps with method PCG: time the
/// factorizations there and, with `late`, again at that time.
struct FactorPlan {
    late: Option<f64>,
    repeats: usize,
}

fn measure(
    scene: &Scene,
    method: PhaseFieldMethod,
    from: Option<&Path>,
    warmup: usize,
    steps: usize,
    factors: Option<(&FactorPlan, &mut Vec<FactorTimes>)>,
) -> anyhow::Result<Split> {
    let mut scene = scene.clone();
    scene.file.phase_field_solver.method = method;
    let t = Instant::now();
    let mut sim = match from {
        Some(path) => {
            let cp = Checkpoint::load(path).with_context(|| path.display().to_string())?;
            let sim = cleave::methods::resume(&scene, cp)
                .with_context(|| format!("cannot start from {}", path.display()))?;
            eprintln!(
                "{method:?}: resumed at step {}, t = {:e} s",
                sim.steps(),
                sim.time()
            );
            sim
        }
        None => crate::bench::built(&scene)?,
    };
    eprintln!(
        "{method:?}: {} particles set up in {:.1} s",
        sim.particle_count(),
        t.elapsed().as_secs_f64()
    );
    for _ in 0..warmup {
        sim.step()?;
    }
    let (t0, s0) = (sim.stage_times().clone(), phase_fields(&mut *sim)?.stats());
    let wall = Instant::now();
    for _ in 0..steps {
        sim.step()?;
    }
    let wall = wall.elapsed().as_secs_f64();
    let s1 = phase_fields(&mut *sim)?.stats();
    let t1 = sim.stage_times();
    let per = |a: f64, b: f64| (a - b) / steps as f64;
    let mpm = per(
        t1.sum(|s| !s.is_phase_field()),
        t0.sum(|s| !s.is_phase_field()),
    );
    let assembly = per(s1.assembly, s0.assembly);
    let factorization = per(
        s1.analysis + s1.factorization,
        s0.analysis + s0.factorization,
    );
    let solve = per(s1.solve, s0.solve);
    let pf = per(t1.sum(Stage::is_phase_field), t0.sum(Stage::is_phase_field));
    let solves = (s1.pcg_solves - s0.pcg_solves).max(1) as f64;
    if let Some((plan, out)) = factors {
        out.push(time_factorizations(&mut *sim, plan.repeats)?);
        if let Some(late) = plan.late {
            eprintln!("{method:?}: running on to t = {late:e} s for the late factorizations");
            while sim.time() < late * (1.0 - 1e-9) {
                sim.step()?;
            }
            out.push(time_factorizations(&mut *sim, plan.repeats)?);
        }
    }
    Ok(Split {
        method: match method {
            PhaseFieldMethod::Direct => "direct (Cholesky every step)",
            PhaseFieldMethod::Pcg => "PCG (warm start, last factor)",
            PhaseFieldMethod::Multigrid => "PCG (warm start, multigrid V-cycle)",
            PhaseFieldMethod::Auto => "auto (the faster of the two PCGs)",
        },
        mpm,
        assembly,
        factorization,
        solve,
        other_pf: (pf - assembly - factorization - solve).max(0.0),
        wall: wall / steps as f64,
        factorizations: s1.factorizations - s0.factorizations,
        analyses: s1.analyses - s0.analyses,
        pcg_iterations: (s1.pcg_iterations - s0.pcg_iterations) as f64 / solves,
    })
}

pub fn run(
    scene_path: &Path,
    out: &Path,
    warmup: usize,
    from: Option<&Path>,
    steps: usize,
    late: Option<f64>,
    factor_repeats: usize,
) -> anyhow::Result<()> {
    let scene = Scene::from_path(scene_path)
        .map_err(|e| anyhow::anyhow!("{}: {e}", scene_path.display()))?;
    anyhow::ensure!(
        scene.dimension() == 2,
        "{}: the phase-field benchmark runs 2D scenes (the phase field is 2D so far)",
        scene_path.display()
    );
    let dt =
        scene.file.time.dt.context(
            "the benchmark needs a scene with a fixed time.dt (to extrapolate to time.end)",
        )?;
    let total_steps = (scene.file.time.end / dt).round();
    let threads = rayon::current_num_threads();
    let plan = FactorPlan {
        late,
        repeats: factor_repeats.max(1),
    };
    let mut factor_rows = Vec::new();
    let mut rows = Vec::new();
    for method in [
        PhaseFieldMethod::Direct,
        PhaseFieldMethod::Pcg,
        PhaseFieldMethod::Multigrid,
    ] {
        let factors = (method == PhaseFieldMethod::Pcg).then_some((&plan, &mut factor_rows));
        rows.push(measure(&scene, method, from, warmup, steps, factors)?);
    }
    let mut md = String::new();
    writeln!(md, "# Phase-field step: where the time goes\n")?;
    writeln!(
        md,
        "`cargo run --release -p cleave-client -- bench-phase-field --scene {}{} --warmup {warmup} --steps {steps}` \
         on this machine ({threads} threads). The scene has {} particles on {} × {} cells. \
         Seconds per step over {steps} steps after {warmup} warm-up steps (the warm-up includes the \
         symbolic analysis), {}; all methods in the same run, the direct solve is the baseline. \
         *Full run* extrapolates the wall time per step to the scene's {total_steps} steps \
         (series rows and snapshots not included).\n",
        scene_path.display(),
        from.map(|p| format!(" --from {}", p.display())).unwrap_or_default(),
        scene.particle_counts.iter().sum::<usize>(),
        scene.cells[0],
        scene.cells[1],
        if from.is_some() { "each method resumed from the checkpoint" } else { "from t = 0" },
    )?;
    writeln!(md, "| method | MPM | assembly | factorization | solve | other phase field | wall per step | full run | factorizations | PCG iterations per solve |")?;
    writeln!(md, "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")?;
    for r in &rows {
        writeln!(
            md,
            "| {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.1} min | {} ({} analyses) | {} |",
            r.method,
            r.mpm,
            r.assembly,
            r.factorization,
            r.solve,
            r.other_pf,
            r.wall,
            r.wall * total_steps / 60.0,
            r.factorizations,
            r.analyses,
            if r.method.starts_with("PCG") { format!("{:.2}", r.pcg_iterations) } else { "–".into() },
        )?;
    }
    let (d, p, m) = (&rows[0], &rows[1], &rows[2]);
    writeln!(
        md,
        "\nAgainst the direct solve, the wall time per step: PCG with the last factor {:.2}×, with the multigrid {:.2}×.",
        p.wall / d.wall,
        m.wall / d.wall
    )?;
    writeln!(
        md,
        "\n## Every kind of factorization a run makes\n\n\
         Seconds per numeric factorization, the mean of {} of each kind on the PCG run's matrix after its \
         timed steps{}: *preconditioner* is PCG's (the f64 factor rounded to f32: a run's \
         `preconditioner_factorizations`), *direct* the f64 factor of method direct and of a fall-back \
         (`direct_factorizations`). A run's mean seconds per factorization of each kind should be \
         near these.\n",
        plan.repeats,
        match late {
            Some(t) => format!(" and at t = {t:e} s (the same run stepped on)"),
            None => " (`--late T` adds a late instant)".into(),
        },
    )?;
    writeln!(md, "| t, s | unknowns | preconditioner | direct (f64) |")?;
    writeln!(md, "|---:|---:|---:|---:|")?;
    for f in &factor_rows {
        writeln!(
            md,
            "| {:e} | {} | {:.3} | {:.3} |",
            f.time, f.unknowns, f.preconditioner, f.direct
        )?;
    }
    print!("{md}");
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir).with_context(|| dir.display().to_string())?;
    }
    let old = match std::fs::read_to_string(out) {
        Ok(s) => Some(s),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
        Err(e) => return Err(e).with_context(|| out.display().to_string()),
    };
    std::fs::write(out, with_kept_part(&md, old.as_deref()))
        .with_context(|| out.display().to_string())?;
    eprintln!(
        "wrote {} (the text below its line \"{KEEP_BELOW}\" is kept)",
        out.display()
    );
    Ok(())
}

/// The line under which the benchmark's output file holds hand-written
/// text that a re-run keeps.
const KEEP_BELOW: &str =
    "<!-- bench-phase-field writes what is above this line; what is below it is kept -->";

/// The new generated text, then the marker and whatever followed the
/// marker in the old file (nothing if it had no marker: a file without it
/// was all generated).
fn with_kept_part(generated: &str, old: Option<&str>) -> String {
    let kept = old
        .and_then(|o| o.find(KEEP_BELOW).map(|i| &o[i + KEEP_BELOW.len()..]))
        .unwrap_or("\n");
    format!("{}\n\n{KEEP_BELOW}{kept}", generated.trim_end_matches('\n'))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rerun_replaces_the_table_and_keeps_the_hand_written_text() {
        let first = with_kept_part("# T\n| a |\n", None);
        assert_eq!(first, format!("# T\n| a |\n\n{KEEP_BELOW}\n"));
        let edited = format!("{first}## Notes\nwritten by hand\n");
        let second = with_kept_part("# T\n| b |\n", Some(&edited));
        assert_eq!(
            second,
            format!("# T\n| b |\n\n{KEEP_BELOW}\n## Notes\nwritten by hand\n")
        );
        // Without a marker the old file was all generated: nothing kept.
        assert_eq!(
            with_kept_part("x\n", Some("old table\n")),
            format!("x\n\n{KEEP_BELOW}\n")
        );
    }
}
