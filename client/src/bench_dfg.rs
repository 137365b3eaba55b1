//! `cleave bench-dfg`: Homel & Herbold's D4 and D5 in one command. Runs a
//! damage scene (by default the dynamic Brazilian disk) at several cell
//! sizes, each in single-field mode (the scene without `[dfg]`, the
//! baseline) and with DFG partitioning, one after the other in the same
//! run. Reports the wall time per step of both (D5: the DFG overhead), and
//! the fragments of undamaged material and the mean speed of the damaged
//! material at two instants (D4: the paper compares DFG at 10 µs with
//! single field at 15 µs). Prints the tables, writes them to a Markdown
//! file and the cumulative fragment-size distributions to a PNG.

use anyhow::Context;
use cleave::diagnostics::fragments::{from_snapshot, Fragment};
use cleave::diagnostics::{Observer, Recorder, SeriesRow, Snapshot};
use cleave::scene::{Scene, Stage};
use std::fmt::Write as _;
use std::path::Path;

/// Keeps the series and the fragment tables of the snapshots.
struct Keep {
    series: Recorder,
    fragments: Vec<(f64, Vec<Fragment>)>,
}

impl Observer for Keep {
    fn series_columns(&mut self, columns: &[String]) -> Result<(), String> {
        self.series.series_columns(columns)
    }
    fn series_row(&mut self, row: &SeriesRow) -> Result<(), String> {
        self.series.series_row(row)
    }
    fn snapshot(&mut self, snap: &Snapshot) -> Result<(), String> {
        if let Some(list) = from_snapshot(snap) {
            self.fragments.push((snap.time, list));
        }
        Ok(())
    }
}

/// One run's figures.
struct Case {
    particles: usize,
    steps: u64,
    /// Wall seconds per step without the series diagnostics.
    per_step: f64,
    /// Seconds per step in the damage field + partition stages, and in
    /// contact.
    dfg: f64,
    contact: f64,
    /// At each compared instant: (time, fragments, mean speed).
    at: Vec<(f64, Vec<Fragment>, f64)>,
}

fn run_case(file: &cleave::scene::SceneFile, instants: &[f64]) -> anyhow::Result<Case> {
    let scene = Scene::validate(file.clone()).map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut sim = crate::bench::built(&scene)?;
    let mut keep = Keep {
        series: Recorder::series_only(),
        fragments: Vec::new(),
    };
    let s = sim.run(&mut keep)?;
    let t = &s.stage_seconds;
    let steps = s.steps.max(1);
    let speed_col = keep.series.columns.iter().position(|c| c == "mean_speed");
    let mut at = Vec::new();
    for &ti in instants {
        let near = |t: f64| (t - ti).abs();
        let frag = keep
            .fragments
            .iter()
            .min_by(|a, b| near(a.0).total_cmp(&near(b.0)))
            .context("the run wrote no fragments (does a material have damage?)")?;
        let row = keep
            .series
            .rows
            .iter()
            .min_by(|a, b| near(a.time).total_cmp(&near(b.time)))
            .context("no series rows")?;
        let speed = speed_col
            .and_then(|k| row.values().get(k).copied())
            .unwrap_or(f64::NAN);
        at.push((frag.0, frag.1.clone(), speed));
    }
    Ok(Case {
        particles: s.particles,
        steps: s.steps,
        per_step: (s.wall_seconds - t.diagnostics) / steps as f64,
        dfg: t.sum(|s| matches!(s, Stage::DamageField | Stage::FieldPartition)) / steps as f64,
        contact: t.get(Stage::Contact) / steps as f64,
        at,
    })
}

/// Equivalent diameter of a fragment of volume `v` in a plane-strain slab
/// of thickness `t`: the circle of the same area, m.
fn diameter(v: f64, t: f64) -> f64 {
    2.0 * (v / (t * std::f64::consts::PI)).sqrt()
}

/// Cumulative mass fraction of the fragments with diameter ≤ d, as
/// (d in mm, fraction) points of a step function.
fn cumulative(list: &[Fragment], t: f64) -> Vec<(f64, f64)> {
    let mut d: Vec<(f64, f64)> = list
        .iter()
        .map(|f| (diameter(f.volume, t), f.mass))
        .collect();
    d.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = d.iter().map(|x| x.1).sum();
    let mut acc = 0.0;
    let mut out = Vec::with_capacity(d.len());
    for (di, m) in d {
        // a step at each fragment's size
        out.push((di * 1e3, acc / total));
        acc += m;
        out.push((di * 1e3, acc / total));
    }
    out
}

/// Mass-weighted median diameter d50, mm.
fn d50(list: &[Fragment], t: f64) -> f64 {
    cumulative(list, t)
        .into_iter()
        .find(|p| p.1 >= 0.5)
        .map_or(f64::NAN, |p| p.0)
}

pub fn run(
    scene_path: &Path,
    cells: &[f64],
    instants: [f64; 2],
    out: &Path,
    figure: &Path,
) -> anyhow::Result<()> {
    let text =
        std::fs::read_to_string(scene_path).with_context(|| scene_path.display().to_string())?;
    let format = cleave::scene::Format::sniff(&text);
    let base = cleave::scene::parse(&text, format)
        .map_err(|e| anyhow::anyhow!("{}: {e}", scene_path.display()))?;
    let Some(dfg) = base.dfg.clone() else {
        anyhow::bail!(
            "{}: the scene has no [dfg] table to compare with",
            scene_path.display()
        );
    };
    anyhow::ensure!(
        base.dimension() == 2,
        "{}: the DFG benchmark runs 2D scenes (DFG is 2D so far)",
        scene_path.display()
    );
    let thickness = base.analysis.thickness;
    let end = instants[0].max(instants[1]);
    let threads = rayon::current_num_threads();
    // (cell size, single field, DFG)
    let mut results = Vec::new();
    for &h in cells {
        let mut f = base.clone();
        f.grid.cell_size = h;
        f.time.end = end;
        // a snapshot every end/30: the instants are at most end/60 off one
        f.output.snapshots = 31;
        f.output.grid_fields = false;
        let mut sf = f.clone();
        sf.dfg = None;
        f.dfg = Some(dfg.clone());
        eprintln!("dx = {:.3} mm: single field", h * 1e3);
        let a = run_case(&sf, &instants)?;
        eprintln!(
            "  {} particles, {} steps, {:.4} s/step",
            a.particles, a.steps, a.per_step
        );
        eprintln!("dx = {:.3} mm: DFG", h * 1e3);
        let b = run_case(&f, &instants)?;
        eprintln!(
            "  {} particles, {} steps, {:.4} s/step",
            b.particles, b.steps, b.per_step
        );
        results.push((h, a, b));
    }
    let mut md = String::new();
    writeln!(md, "# DFG against single field: cost and fragments\n")?;
    writeln!(
        md,
        "`cargo run --release -p cleave-client -- bench-dfg --scene {} --cells {}` on this machine \
         ({threads} threads): each resolution runs the scene without `[dfg]` (single field, the \
         baseline) and then with it, to {:.0} µs. Wall time per step excludes the series diagnostics \
         (fragments are counted on every row). *DFG stages* are the damage field, Algorithm 1 \
         and the partition.\n",
        scene_path.display(),
        cells.iter().map(|h| format!("{h:e}")).collect::<Vec<_>>().join(","),
        end * 1e6,
    )?;
    writeln!(md, "## Cost per step (D5)\n")?;
    writeln!(md, "| dx (mm) | particles | steps SF / DFG | SF s/step | DFG s/step | DFG / SF | DFG stages s/step | contact s/step SF / DFG |")?;
    writeln!(md, "|---:|---:|---:|---:|---:|---:|---:|---:|")?;
    for (h, a, b) in &results {
        writeln!(
            md,
            "| {:.3} | {} | {} / {} | {:.4} | {:.4} | {:.2} | {:.4} | {:.4} / {:.4} |",
            h * 1e3,
            a.particles,
            a.steps,
            b.steps,
            a.per_step,
            b.per_step,
            b.per_step / a.per_step,
            b.dfg,
            a.contact,
            b.contact
        )?;
    }
    writeln!(md, "\n## Fragments and mean speed (D4)\n")?;
    writeln!(
        md,
        "Fragments are connected components of particles with damage below `output.fragment_damage` \
         (1.5 particle spacings link two particles); d is the diameter of the circle of a fragment's \
         area, d50 the mass-weighted median of d, *largest* the largest fragment's share of the \
         fragment mass; mean speed is the mass-weighted mean |v| of the damage-model material.\n"
    )?;
    writeln!(md, "| dx (mm) | model | t (µs) | fragments | ≥ 10 particles | largest | d50 (mm) | mean speed (m/s) |")?;
    writeln!(md, "|---:|---|---:|---:|---:|---:|---:|---:|")?;
    for (h, a, b) in &results {
        for (name, c) in [("single field", a), ("DFG", b)] {
            for (t, list, speed) in &c.at {
                let total: f64 = list.iter().map(|f| f.mass).sum();
                writeln!(
                    md,
                    "| {:.3} | {name} | {:.1} | {} | {} | {:.2} | {:.3} | {:.1} |",
                    h * 1e3,
                    t * 1e6,
                    list.len(),
                    list.iter().filter(|f| f.particles >= 10).count(),
                    list.first().map_or(0.0, |f| f.mass / total),
                    d50(list, thickness),
                    speed
                )?;
            }
        }
    }
    // The figure: cumulative distributions, single field at the later
    // instant and DFG at the earlier one (the paper's Fig. 18), and both
    // models at both instants in the table.
    let (t_dfg, t_sf) = (instants[0], instants[1]);
    let panel =
        |name: &str, t: f64, pick: &dyn Fn(&(f64, Case, Case)) -> &Case| -> cleave::output::Panel {
            let lines = results
                .iter()
                .map(|r| {
                    let c = pick(r);
                    let k = (0..c.at.len())
                        .min_by(|&a, &b| (c.at[a].0 - t).abs().total_cmp(&(c.at[b].0 - t).abs()))
                        .unwrap_or(0);
                    (
                        format!("dx = {:.3} mm, {:.0} m/s", r.0 * 1e3, c.at[k].2),
                        cumulative(&c.at[k].1, thickness),
                    )
                })
                .collect();
            (format!("{name} at {:.0} µs", t * 1e6), lines)
        };
    let panels = vec![
        panel("single field", t_sf, &|r| &r.1),
        panel("DFG", t_dfg, &|r| &r.2),
    ];
    if let Some(dir) = figure.parent() {
        std::fs::create_dir_all(dir).with_context(|| dir.display().to_string())?;
    }
    cleave::output::plot_log_x(
        figure,
        "fragment diameter in mm",
        "cumulative mass fraction",
        &panels,
    )?;
    writeln!(
        md,
        "\n![cumulative fragment-size distributions]({})",
        figure.file_name().map_or(String::new(), |n| format!(
            "figures/{}",
            n.to_string_lossy()
        ))
    )?;
    print!("{md}");
    if let Some(dir) = out.parent() {
        std::fs::create_dir_all(dir).with_context(|| dir.display().to_string())?;
    }
    std::fs::write(out, md).with_context(|| out.display().to_string())?;
    eprintln!("wrote {} and {}", out.display(), figure.display());
    Ok(())
}
