//! `cleave`: run fracture scenes in-process (and, later, against a server).
//!
//! Exit codes: 0 success, 1 simulation failure (or an output error),
//! 2 invalid scene or usage.

mod bench;
mod bench_dfg;
mod bench_fleet;
mod bench_pf;
mod bench_scene;
mod gc_polar;
mod remote;
mod study;

use anyhow::Context;
use clap::{Args, CommandFactory, FromArgMatches, Parser, Subcommand};
use cleave::diagnostics::{Control, Observer, Progress, SeriesRow, Snapshot};
use cleave::output::OutputWriter;
use cleave::scene::{Scene, SceneError};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "cleave", version = cleave::VERSION, about = "Dynamic fracture with the material point method")]
struct Cli {
    /// `cleave --server URL COMMAND` as earlier versions took it (hidden:
    /// the commands that talk to a server show these options).
    #[arg(long, hide = true)]
    server: Option<String>,
    #[arg(long, hide = true)]
    token: Option<String>,
    #[arg(long, hide = true)]
    ca_cert: Option<PathBuf>,
    #[command(subcommand)]
    command: Command,
}

/// Where a command that can talk to a server sends its work.
#[derive(Args, Debug, Clone, Default)]
struct ServerArgs {
    /// A cleave server (http://HOST:PORT or https://...; HOST:PORT means
    /// http://HOST:PORT). Without it (and without CLEAVE_SERVER), `run`,
    /// `validate` and `study` work in this process.
    #[arg(long, env = "CLEAVE_SERVER", value_name = "URL")]
    server: Option<String>,
    /// Bearer token for the server.
    #[arg(long, env = "CLEAVE_TOKEN", hide_env_values = true)]
    token: Option<String>,
    /// PEM certificate (or CA) to trust for an https:// server.
    #[arg(long, env = "CLEAVE_CA_CERT", value_name = "PEM")]
    ca_cert: Option<PathBuf>,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scene and write series.csv, VTK snapshots and plots (in this
    /// process, or as a job on --server).
    Run {
        /// Scene file (TOML or JSON).
        scene: PathBuf,
        /// Output directory (created if missing).
        #[arg(long, default_value = "out")]
        out: PathBuf,
        #[command(flatten)]
        server: ServerArgs,
        /// Print one JSON object with the run's summary on stdout.
        #[arg(long)]
        json: bool,
        /// No progress bar.
        #[arg(long)]
        quiet: bool,
        /// Save a checkpoint (OUT/checkpoint.bin) every this many seconds
        /// of wall time, so that `--resume` can go on after the process
        /// is lost; removed when the run completes. Embedded runs only.
        #[arg(long, value_name = "SECONDS")]
        checkpoint_every: Option<f64>,
        /// Go on from OUT/checkpoint.bin (the same scene): the series is
        /// cut back to the checkpoint and continued, bit for bit as if the
        /// run had not stopped (with the PCG phase-field solver, to its
        /// tolerance). Embedded runs only.
        #[arg(long)]
        resume: bool,
    },
    /// Measure particle-steps per second of the explicit step (1 and 2
    /// threads, or `--threads`), on the built-in block or, with `--scene`,
    /// on any scene with the time of each stage of its plan.
    Bench {
        /// Time this scene's steps instead of the built-in block: per
        /// thread count, ms per step, particle-steps per second, speed-up,
        /// parallel efficiency and every stage's ms per step (printed;
        /// written to --out if given).
        #[arg(long, conflicts_with_all = ["dim", "largest", "transfer", "kernel", "taichi"])]
        scene: Option<PathBuf>,
        /// With --scene: run the scene untimed to this simulated time (s)
        /// first, at each thread count, then warm up and time its steps
        /// there (a long run's late steps, whose particles have moved away
        /// from the order they were sorted in at the start).
        #[arg(long, requires = "scene", value_parser = non_negative_seconds)]
        after: Option<f64>,
        /// Dimension of the benchmark block: 2 (linear elastic, FLIP and
        /// APIC) or 3 (neo-Hookean, APIC, 8 particles per cell).
        #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u8).range(2..=3))]
        dim: u8,
        /// Markdown file for the table [default: docs/performance.md in
        /// 2D, docs/performance-taichi.md in 2D with --taichi,
        /// docs/performance-3d.md in 3D].
        #[arg(long)]
        out: Option<PathBuf>,
        /// Steps timed per configuration.
        #[arg(long, default_value_t = 20)]
        steps: usize,
        /// Largest block edge in cells [default: 512 in 2D (128: 65 k
        /// particles, 256: 262 k, 512: 1 M); 50 in 3D (16: 32 k, 32: 262 k,
        /// 50: 1 M)]. In 3D, a value below 16 runs that one size.
        #[arg(long)]
        largest: Option<usize>,
        /// Particle updates to measure, comma-separated: flip, pic, apic
        /// [default: flip,apic]. 3D measures APIC only.
        #[arg(long)]
        transfer: Option<String>,
        /// Shape functions to measure, comma-separated: linear, gimp,
        /// quadratic_bspline, cubic_bspline, lme [default:
        /// quadratic_bspline]. 2D only.
        #[arg(long)]
        kernel: Option<String>,
        /// Python with Taichi 1.7 installed: run Taichi on the same problem,
        /// interleaved with cleave: in 3D the 3D block
        /// (docs/scripts/taichi_mpm3d.py); in 2D the peer problem, a
        /// neo-Hookean APIC block (docs/scripts/taichi_mpm2d.py; written
        /// to docs/performance-taichi.md).
        #[arg(long)]
        taichi: Option<PathBuf>,
        /// Thread counts to measure, comma-separated, each run back to
        /// back in the same process (the speed-up is against the first).
        #[arg(long, default_value = "1,2")]
        threads: String,
    },
    /// Jobs per hour of small jobs with one server on SQLite, one on
    /// PostgreSQL and three sharing a PostgreSQL queue (real
    /// `cleave-server` processes), and the PostgreSQL store's cost per job.
    BenchFleet {
        /// A PostgreSQL server's URL (`postgres://USER@HOST:PORT/postgres`)
        /// on which the bench may create databases (`cleave_bench_*`).
        #[arg(long)]
        postgres: String,
        /// Jobs per case.
        #[arg(long, default_value_t = 60)]
        jobs: usize,
        /// Rounds (the cases alternate in each; medians are reported).
        #[arg(long, default_value_t = 3)]
        rounds: usize,
        /// Markdown file for the table.
        #[arg(long, default_value = "docs/fleet-performance.md")]
        out: PathBuf,
    },
    /// Measure the overhead of running through a server (in this process)
    /// and the FetchFields throughput.
    BenchService {
        /// Markdown file for the tables.
        #[arg(long, default_value = "docs/service-performance.md")]
        out: PathBuf,
        /// Runs of each kind (medians are reported).
        #[arg(long, default_value_t = 3)]
        repeats: usize,
    },
    /// Where the time of a phase-field step goes (MPM, assembly,
    /// factorization, solve): the direct solve, PCG with the last factor
    /// and PCG with the multigrid, for a scene with a fixed dt (default: `scenes/p1_plate.toml`
    /// at the paper's resolution).
    BenchPhaseField {
        /// Scene file with a phase field and a fixed time step.
        #[arg(long, default_value = "scenes/p1_plate.toml")]
        scene: PathBuf,
        /// Markdown file for the table.
        #[arg(long, default_value = "docs/phase-field-performance.md")]
        out: PathBuf,
        /// Untimed steps first (they include the symbolic analysis).
        #[arg(long, default_value_t = 5)]
        warmup: usize,
        /// Start every method from this checkpoint of a run of the scene
        /// (`cleave run --checkpoint-every`'s OUT/checkpoint.bin) instead of
        /// t = 0: a late instant without running up to it three times.
        #[arg(long)]
        from: Option<PathBuf>,
        /// Timed steps per method.
        #[arg(long, default_value_t = 40)]
        steps: usize,
        /// Also time every kind of factorization at this simulated time,
        /// s, stepping the PCG run on to it (untimed).
        #[arg(long, value_name = "SECONDS")]
        late: Option<f64>,
        /// Factorizations of each kind timed at each instant.
        #[arg(long, default_value_t = 3)]
        factor_repeats: usize,
    },
    /// DFG against single field for a damage scene (default: the dynamic
    /// Brazilian disk, Homel & Herbold's D4/D5) at several cell sizes: wall time per
    /// step, fragments and mean speed, cumulative fragment-size plot.
    BenchDfg {
        /// Scene file with damage.
        #[arg(long, default_value = "scenes/d4_brazilian.toml")]
        scene: PathBuf,
        /// Cell sizes, m, comma-separated.
        #[arg(long, value_delimiter = ',', default_value = "1.81e-4,9.4e-5,6.3e-5")]
        cells: Vec<f64>,
        /// The instants compared, s: DFG's, then single field's (the
        /// paper: 10 and 15 µs); the runs go to the later one.
        #[arg(long, value_delimiter = ',', default_value = "1e-5,1.5e-5")]
        instants: Vec<f64>,
        /// Markdown file for the table.
        #[arg(long, default_value = "docs/dfg-brazilian.md")]
        out: PathBuf,
        /// Where to draw the cumulative fragment-size plot.
        #[arg(long, default_value = "docs/figures/d4_fragments.png")]
        figure: PathBuf,
    },
    /// Accuracy against cost: run a scene at every combination of the
    /// given settings and write each run's wall time, metric and error
    /// (DIR/study.csv) and the error against wall time with the Pareto
    /// front (DIR/study.png). With --server the runs are jobs on the server.
    Study {
        /// Scene file (TOML or JSON).
        scene: PathBuf,
        /// A setting and its values: a dotted key into the scene and
        /// comma-separated values, e.g. grid.cell_size=1e-3,5e-4 or
        /// bodies[0].particles_per_cell=4,9 or dfg=on,off (a table on/off).
        /// Repeat for more settings: every combination runs.
        #[arg(long, required = true)]
        vary: Vec<String>,
        /// What to measure from each run's series: COLUMN (its last
        /// value), final:COLUMN, max:COLUMN, min:COLUMN,
        /// arrival:COLUMN=VALUE (the time it first reaches VALUE),
        /// crack_angle:X0,Y0, propagation_energy[:ENERGY[,LENGTH]] (the
        /// energy a crack dissipates while it runs) or energy_loss.
        #[arg(long, default_value = "fracture_energy")]
        metric: String,
        /// The value the error is taken against: `finest` (the run with the
        /// most particles × steps) or analytic:VALUE.
        #[arg(long, default_value = "finest")]
        reference: String,
        /// Output directory.
        #[arg(long)]
        out: PathBuf,
        /// Print the table as one JSON object.
        #[arg(long)]
        json: bool,
        /// Go on with the study an earlier `cleave study` left in --out
        /// (same scene and settings): its finished runs are kept, a run
        /// with a checkpoint goes on from it, the others run.
        #[arg(long)]
        resume: bool,
        /// Save the running variant's state every SECONDS of wall time
        /// (DIR/runs/NNN/checkpoint.bin), so that --resume loses at most
        /// that much of it. Runs in this process only.
        #[arg(long, value_name = "SECONDS")]
        checkpoint_every: Option<f64>,
        #[command(flatten)]
        server: ServerArgs,
    },
    /// The effective surface energy Gc(θ) of the anisotropic phase field
    /// (eq. 8 of Kakouris & Triantafyllou) as a table and a polar plot; with
    /// a 3D tensor, Gc of planes by their normal and its extremes over the
    /// sphere.
    GcPolar {
        /// Voigt entries: 2D g1111,g2222,g1122,g1212[,g1112,g2212]; 3D nine
        /// (orthotropic: g1111,g2222,g3333,g1122,g1133,g2233,g2323,g1313,g1212)
        /// or the 21 of the 6 × 6 matrix's upper triangle.
        #[arg(long, allow_hyphen_values = true)]
        gamma: String,
        /// 3D: a crack plane's normal nx,ny,nz (repeatable; default the
        /// three axes).
        #[arg(long, allow_hyphen_values = true)]
        normal: Vec<String>,
        /// The model parameter Ḡc, N/m (the table is in the same unit).
        #[arg(long)]
        gc_bar: f64,
        /// Angle step, degrees.
        #[arg(long, default_value_t = 1.0)]
        angle_step: f64,
        /// Print the table as one JSON object.
        #[arg(long)]
        json: bool,
        /// Where to write the polar plot of Gc and 1/Gc.
        #[arg(long, default_value = "gc-polar.png")]
        out: PathBuf,
    },
    /// Draw energies.png (and crack.png, with a crack tip) from a
    /// series.csv, e.g. one fetched from a server or cut short.
    Plot {
        /// The series.csv to plot.
        series: PathBuf,
        /// Directory for the plots (default: the series' directory).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Measure a run's series.csv as `cleave study` measures its runs:
    /// each --metric's value and, with --reference analytic:VALUE, its
    /// relative difference from VALUE (signed), and for
    /// propagation_energy the rows it spans. Works on a series still
    /// being written (the rows so far).
    Metric {
        /// The series.csv to measure.
        series: PathBuf,
        /// As `cleave study --metric` (COLUMN, final:, max:, min:,
        /// arrival:COLUMN=VALUE, crack_angle:X0,Y0,
        /// propagation_energy[:ENERGY[,LENGTH]], energy_loss); repeat
        /// for more.
        #[arg(long, required = true)]
        metric: Vec<String>,
        /// analytic:VALUE to compare with.
        #[arg(long)]
        reference: Option<String>,
        /// Print one JSON object.
        #[arg(long)]
        json: bool,
    },
    /// Check a scene without running it; prints its plan.
    Validate {
        /// Scene file (TOML or JSON).
        scene: PathBuf,
        /// Print the result as JSON on stdout.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        server: ServerArgs,
    },
    /// Submit a scene to the server; prints the job id.
    Submit {
        /// Scene file (TOML or JSON).
        scene: PathBuf,
        /// A label for your own bookkeeping.
        #[arg(long, default_value = "")]
        label: String,
        /// Wait for the job to end; exit with its outcome.
        #[arg(long)]
        wait: bool,
        /// Print the job as one JSON object.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        server: ServerArgs,
    },
    /// Follow a job to its end (progress bar, or JSON lines with --json).
    Watch {
        /// Job id (job-000001), as `submit` printed it.
        job: String,
        /// One JSON object per event on stdout.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        server: ServerArgs,
    },
    /// Fetch a job's results and write them like `run` does.
    Fetch {
        /// Job id (job-000001).
        job: String,
        /// Output directory (created if missing).
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Print the written files as one JSON object.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        server: ServerArgs,
    },
    /// List jobs, newest first.
    List {
        /// Only jobs in this state (queued, running, succeeded, failed, cancelled).
        #[arg(long)]
        state: Option<String>,
        /// At most this many jobs.
        #[arg(long, default_value_t = 50)]
        limit: u32,
        /// Print the jobs as one JSON array.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        server: ServerArgs,
    },
    /// Show one job.
    Get {
        /// Job id (job-000001).
        job: String,
        /// Print the job as one JSON object.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        server: ServerArgs,
    },
    /// Cancel a queued or running job and print its state afterwards.
    Cancel {
        /// Job id (job-000001).
        job: String,
        /// Print the job as one JSON object.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        server: ServerArgs,
    },
}

impl Command {
    /// The server options of a command that can talk to a server, and
    /// whether it was asked for JSON.
    fn server_args(&self) -> Option<(&ServerArgs, bool)> {
        match self {
            Command::Run { server, json, .. }
            | Command::Validate { server, json, .. }
            | Command::Study { server, json, .. }
            | Command::Submit { server, json, .. }
            | Command::Watch { server, json, .. }
            | Command::Fetch { server, json, .. }
            | Command::List { server, json, .. }
            | Command::Get { server, json, .. }
            | Command::Cancel { server, json, .. } => Some((server, *json)),
            Command::Bench { .. }
            | Command::BenchFleet { .. }
            | Command::BenchService { .. }
            | Command::BenchPhaseField { .. }
            | Command::BenchDfg { .. }
            | Command::GcPolar { .. }
            | Command::Plot { .. }
            | Command::Metric { .. } => None,
        }
    }
}

const EXIT_FAILED: u8 = 1;
const EXIT_INVALID: u8 = 2;

/// The status a shell reports for a tool that SIGPIPE ended (128 + 13).
const EXIT_CLOSED_STDOUT: i32 = 141;

/// A reader that closed `cleave`'s standard output (`cleave list | head
/// -1`) ends the process quietly with the status a shell gives a Unix tool
/// that SIGPIPE killed. Rust ignores SIGPIPE, so `println!` would panic
/// with a backtrace instead; every other panic goes to the default hook.
fn quiet_on_closed_stdout() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let p = info.payload();
        let msg = p
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| p.downcast_ref::<&str>().copied())
            .unwrap_or("");
        if msg.starts_with("failed printing to stdout")
            && (msg.contains("Broken pipe") || msg.contains("(os error 32)"))
        {
            std::process::exit(EXIT_CLOSED_STDOUT);
        }
        default(info);
    }));
}

fn main() -> ExitCode {
    quiet_on_closed_stdout();
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "warn".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    let matches = match Cli::command().try_get_matches() {
        Ok(m) => m,
        Err(e) => {
            let code = if e.use_stderr() { EXIT_INVALID } else { 0 };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    let cli = match Cli::from_arg_matches(&matches) {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(EXIT_INVALID);
        }
    };
    let Some(target) = server_target(&cli, &matches) else {
        return local_main(cli.command);
    };
    if cli.command.server_args().is_none() {
        eprintln!("error: this command runs in this process; drop --server");
        return ExitCode::from(EXIT_INVALID);
    }
    remote_main(&target, cli.command)
}

/// The server a command goes to: its own --server (or the hidden one before
/// the command, as earlier versions took it), else CLEAVE_SERVER.
fn server_target(cli: &Cli, matches: &clap::ArgMatches) -> Option<remote::Target> {
    use clap::parser::ValueSource;
    let sub = matches.subcommand().map(|(_, m)| m);
    let source = |name: &str| {
        sub.filter(|m| m.try_contains_id(name).unwrap_or(false))
            .and_then(|m| m.value_source(name))
    };
    let own = cli
        .command
        .server_args()
        .map(|(s, _)| s.clone())
        .unwrap_or_default();
    let explicit = |name: &str| source(name) == Some(ValueSource::CommandLine);
    let pick = |mine: Option<String>, top: Option<String>, name: &str| {
        if explicit(name) {
            mine
        } else {
            top.or(mine)
        }
    };
    let url = pick(own.server, cli.server.clone(), "server")?;
    let from_env = cli.server.is_none() && source("server") == Some(ValueSource::EnvVariable);
    Some(remote::Target {
        url: remote::with_scheme(&url),
        token: pick(own.token, cli.token.clone(), "token"),
        ca_cert: if explicit("ca_cert") {
            own.ca_cert
        } else {
            cli.ca_cert.clone().or(own.ca_cert)
        },
        from_env,
    })
}

/// Every command in this process.
fn local_main(command: Command) -> ExitCode {
    match command {
        Command::Run {
            scene,
            out,
            json,
            quiet,
            checkpoint_every,
            resume,
            ..
        } => run(
            &scene,
            &out,
            json,
            quiet,
            Checkpointing {
                every: checkpoint_every,
                resume,
            },
        ),
        Command::Validate { scene, json, .. } => validate(&scene, json),
        Command::Submit { .. }
        | Command::Watch { .. }
        | Command::Fetch { .. }
        | Command::List { .. }
        | Command::Get { .. }
        | Command::Cancel { .. } => {
            eprintln!(
                "error: this command talks to a server: give --server URL (or set CLEAVE_SERVER)"
            );
            ExitCode::from(EXIT_INVALID)
        }
        Command::GcPolar {
            gamma,
            gc_bar,
            angle_step,
            normal,
            json,
            out,
        } => gc_polar::run(&gamma, gc_bar, angle_step, &normal, json, &out),
        Command::Study {
            scene,
            vary,
            metric,
            reference,
            out,
            json,
            resume,
            checkpoint_every,
            ..
        } => study::main_local(study::Options {
            scene,
            vary,
            metric,
            reference,
            out,
            json,
            resume,
            checkpoint_every,
        }),
        Command::Metric {
            series,
            metric,
            reference,
            json,
        } => measure(&series, &metric, reference.as_deref(), json),
        Command::Plot { series, out } => match plot(&series, out.as_deref()) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: {e:#}");
                ExitCode::from(EXIT_FAILED)
            }
        },
        Command::BenchFleet {
            postgres,
            jobs,
            rounds,
            out,
        } => match bench_fleet::run(&postgres, jobs.max(1), rounds.max(1), &out) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: {e:#}");
                ExitCode::from(EXIT_FAILED)
            }
        },
        Command::BenchService { out, repeats } => match bench::run_service(&out, repeats.max(1)) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: {e:#}");
                ExitCode::from(EXIT_FAILED)
            }
        },
        Command::BenchPhaseField {
            scene,
            out,
            warmup,
            from,
            steps,
            late,
            factor_repeats,
        } => match bench_pf::run(
            &scene,
            &out,
            warmup,
            from.as_deref(),
            steps.max(1),
            late,
            factor_repeats,
        ) {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: {e:#}");
                ExitCode::from(EXIT_FAILED)
            }
        },
        Command::BenchDfg {
            scene,
            cells,
            instants,
            out,
            figure,
        } => {
            let result = match instants.as_slice() {
                &[a, b]
                    if a > 0.0
                        && b > 0.0
                        && !cells.is_empty()
                        && cells.iter().all(|h| *h > 0.0) =>
                {
                    bench_dfg::run(&scene, &cells, [a, b], &out, &figure)
                }
                _ => Err(anyhow::anyhow!(
                    "--instants takes two positive times and --cells positive sizes"
                )),
            };
            match result {
                Ok(()) => ExitCode::SUCCESS,
                Err(e) => {
                    eprintln!("error: {e:#}");
                    ExitCode::from(EXIT_FAILED)
                }
            }
        }
        Command::Bench {
            scene,
            after,
            dim,
            out,
            steps,
            largest,
            transfer,
            kernel,
            taichi,
            threads,
        } => match match scene {
            Some(scene) => thread_counts(&threads).and_then(|t| {
                anyhow::ensure!(steps > 0, "--steps must be at least 1");
                bench_scene::run(&scene, out.as_deref(), steps, &t, after.unwrap_or(0.0))
            }),
            None => bench_dims(
                dim,
                out,
                steps,
                largest,
                (transfer, kernel),
                taichi,
                &threads,
            ),
        } {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("error: {e:#}");
                ExitCode::from(EXIT_FAILED)
            }
        },
    }
}

/// `--after SECONDS`: a finite simulated time, not negative.
fn non_negative_seconds(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(t) if t.is_finite() && t >= 0.0 => Ok(t),
        Ok(t) => Err(format!("{t} is not a time: give seconds, 0 or more")),
        Err(e) => Err(format!("{s:?} is not a number of seconds: {e}")),
    }
}

/// `--threads LIST`: counts ≥ 1, comma-separated.
fn thread_counts(threads: &str) -> anyhow::Result<Vec<usize>> {
    threads
        .split(',')
        .map(|t| match t.trim().parse::<usize>() {
            Ok(n) if n >= 1 => Ok(n),
            _ => Err(anyhow::anyhow!(
                "--threads: {t:?} is not a thread count (give counts ≥ 1, comma-separated)"
            )),
        })
        .collect()
}

/// `cleave bench` in 2D or 3D, with each dimension's defaults.
fn bench_dims(
    dim: u8,
    out: Option<PathBuf>,
    steps: usize,
    largest: Option<usize>,
    (transfer, kernel): (Option<String>, Option<String>),
    taichi: Option<PathBuf>,
    threads: &str,
) -> anyhow::Result<()> {
    anyhow::ensure!(steps > 0, "--steps must be at least 1");
    let threads = thread_counts(threads)?;
    if dim == 3 {
        // The 3D problem is the issue's: APIC only, so a transfer list
        // other than `apic` would silently measure something else.
        if let Some(t) = transfer.as_deref() {
            anyhow::ensure!(
                t.trim() == "apic",
                "--dim 3 measures APIC only (issue 32's problem); drop --transfer {t}"
            );
        }
        anyhow::ensure!(
            kernel.is_none(),
            "--kernel compares the 2D problem; drop --dim 3"
        );
        let out = out.unwrap_or_else(|| PathBuf::from("docs/performance-3d.md"));
        bench::run_peer(
            3,
            &out,
            steps,
            largest.unwrap_or(50),
            taichi.as_deref(),
            &threads,
        )
    } else if let Some(python) = taichi.as_deref() {
        // the peer problem is fixed, as in 3D
        anyhow::ensure!(
            transfer.is_none() && kernel.is_none(),
            "--taichi measures the peer problem (neo-Hookean, APIC, quadratic B-splines); drop --transfer and --kernel"
        );
        let out = out.unwrap_or_else(|| PathBuf::from("docs/performance-taichi.md"));
        bench::run_peer(
            2,
            &out,
            steps,
            largest.unwrap_or(512),
            Some(python),
            &threads,
        )
    } else {
        let out = out.unwrap_or_else(|| PathBuf::from("docs/performance.md"));
        let transfer = transfer.unwrap_or_else(|| "flip,apic".into());
        let kernel = kernel.unwrap_or_else(|| "quadratic_bspline".into());
        bench::run(
            &out,
            steps,
            largest.unwrap_or(512),
            &transfer,
            &kernel,
            &threads,
        )
    }
}

/// `cleave metric`: exit 2 for a bad metric or reference, 1 if a metric
/// cannot be taken from the series (its column is missing, no crack ran).
fn measure(series: &Path, specs: &[String], reference: Option<&str>, json: bool) -> ExitCode {
    let invalid = |msg: String| {
        if json {
            println!("{}", json!({"status": "invalid", "error": msg}));
        }
        eprintln!("error: {msg}");
        ExitCode::from(EXIT_INVALID)
    };
    let metrics = match specs
        .iter()
        .map(|m| cleave::study::Metric::parse(m))
        .collect::<Result<Vec<_>, _>>()
    {
        Ok(m) => m,
        Err(e) => return invalid(e),
    };
    let reference = match reference.map(cleave::study::Reference::parse) {
        None => None,
        Some(Ok(cleave::study::Reference::Analytic(v))) => Some(v),
        Some(Ok(_)) => {
            return invalid("--reference: only analytic:VALUE has a meaning for one series".into())
        }
        Some(Err(e)) => return invalid(e),
    };
    let (columns, rows) = match cleave::output::read_series(series) {
        Ok(s) => s,
        Err(e) => return invalid(e.to_string()),
    };
    let mut failed = false;
    let mut out = Vec::new();
    for (spec, m) in specs.iter().zip(&metrics) {
        match m.measure(&columns, &rows) {
            Ok((v, window)) => {
                let diff = reference.map(|r| if r == 0.0 { v } else { (v - r) / r.abs() });
                if !json {
                    match diff {
                        Some(d) => println!(
                            "{spec} = {v:.6e} ({:+.2} % against {:e})",
                            100.0 * d,
                            reference.unwrap_or_default()
                        ),
                        None => println!("{spec} = {v:.6e}"),
                    }
                    if let Some(w) = window {
                        println!(
                            "  from t = {:.4e} s (crack length {:.4e}) to t = {:.4e} s ({:.4e})",
                            w.from.0, w.from.1, w.to.0, w.to.1
                        );
                    }
                }
                let window = window.map(|w| {
                    json!({"from": {"time": w.from.0, "length": w.from.1}, "to": {"time": w.to.0, "length": w.to.1}})
                });
                out.push(json!({"metric": spec, "value": v, "difference": diff, "window": window}));
            }
            Err(e) => {
                failed = true;
                if !json {
                    eprintln!("{spec}: {e}");
                }
                out.push(json!({"metric": spec, "error": e}));
            }
        }
    }
    if json {
        println!(
            "{}",
            json!({"series": series, "rows": rows.len(), "reference": reference, "metrics": out})
        );
    }
    if failed {
        ExitCode::from(EXIT_FAILED)
    } else {
        ExitCode::SUCCESS
    }
}

/// `cleave plot`: the run's plots from its series; says which files it
/// wrote (and why it drew no crack plot).
fn plot(series: &Path, out: Option<&Path>) -> anyhow::Result<()> {
    let (columns, rows) = cleave::output::read_series(series)?;
    let dir = out.or(series.parent()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).with_context(|| dir.display().to_string())?;
    for (name, drawn) in [
        (
            "energies.png",
            cleave::output::plot_energies(&dir.join("energies.png"), &rows)?,
        ),
        (
            "crack.png",
            cleave::output::plot_crack(&dir.join("crack.png"), &columns, &rows)?,
        ),
        (
            "j_integral.png",
            cleave::output::plot_j_integral(&dir.join("j_integral.png"), &columns, &rows)?,
        ),
    ] {
        // no word about a j_integral.png not drawn: a series without
        // explicit cracks prints what it always did
        if drawn {
            println!("wrote {}", dir.join(name).display());
        } else if name == "j_integral.png" {
            continue;
        } else if rows.len() < 2 {
            println!("no {name}: the series has fewer than two rows");
        } else if name == "crack.png" {
            println!("no {name}: the series has no crack_length column");
        }
    }
    Ok(())
}

fn report_invalid(path: &Path, e: &SceneError, json: bool) -> ExitCode {
    if json {
        let errors: Vec<_> = e
            .errors
            .iter()
            .map(|f| json!({"path": f.path, "reason": f.reason}))
            .collect();
        println!(
            "{}",
            json!({"status": "invalid", "scene": path, "errors": errors})
        );
    }
    eprintln!("error: invalid scene {}:", path.display());
    for f in &e.errors {
        eprintln!("  {f}");
    }
    ExitCode::from(EXIT_INVALID)
}

/// `200 x 100` (2D) or `40 x 20 x 10` (3D).
fn cells_text(scene: &Scene) -> String {
    scene
        .cell_counts()
        .iter()
        .map(usize::to_string)
        .collect::<Vec<_>>()
        .join(" x ")
}

fn validate(path: &Path, json: bool) -> ExitCode {
    match Scene::from_path(path) {
        Ok(scene) => {
            if json {
                println!(
                    "{}",
                    json!({
                        "status": "valid",
                        "scene": path,
                        "particles": scene.total_particles(),
                        "cells": scene.cell_counts(),
                        "stages": scene.plan.names(),
                        "memory": scene.memory,
                        "memory_bytes": scene.memory.total(),
                        "time_step": scene.time_step,
                    })
                );
            } else {
                println!(
                    "{}: valid; {} particles, {} cells{}; plan: {}",
                    path.display(),
                    scene.total_particles(),
                    cells_text(&scene),
                    match cleave::methods::runnable(&scene) {
                        Ok(()) => String::new(),
                        Err(e) => format!(" (it cannot be run yet: {e})"),
                    },
                    scene.plan
                );
                println!("  memory: {}", scene.memory);
                println!(
                    "  time step: {:.4e} s, at least {:.0} steps to time.end",
                    scene.time_step.dt, scene.time_step.steps
                );
            }
            ExitCode::SUCCESS
        }
        Err(e) => report_invalid(path, &e, json),
    }
}

/// `cleave run`'s checkpoint options.
#[derive(Debug, Clone, Copy)]
struct Checkpointing {
    /// Wall seconds between checkpoints.
    every: Option<f64>,
    resume: bool,
}

/// Writes results, drives the progress bar and asks for checkpoints.
struct RunObserver {
    writer: OutputWriter,
    bar: Option<ProgressBar>,
    checkpoints: cleave::checkpoint::CheckpointTimer,
}

impl Observer for RunObserver {
    fn series_columns(&mut self, columns: &[String]) -> Result<(), String> {
        self.writer.series_columns(columns)
    }
    fn series_row(&mut self, row: &SeriesRow) -> Result<(), String> {
        self.writer.series_row(row)
    }
    fn snapshot(&mut self, snapshot: &Snapshot) -> Result<(), String> {
        self.writer.snapshot(snapshot)
    }
    fn progress(&mut self, p: &Progress) -> Control {
        if let Some(bar) = &self.bar {
            bar.set_position((p.fraction() * 1000.0) as u64);
            if p.step % 16 == 0 {
                bar.set_message(format!("step {} t = {:.3e} s", p.step, p.time));
            }
        }
        if self.checkpoints.due(p) {
            Control::Checkpoint
        } else {
            Control::Continue
        }
    }
    fn checkpoint(&mut self, cp: cleave::checkpoint::Checkpoint<'_>) -> Result<(), String> {
        let (step, time) = (cp.step(), cp.time());
        let t0 = std::time::Instant::now();
        self.writer.checkpoint(cp)?;
        tracing::info!(
            step,
            time,
            seconds = t0.elapsed().as_secs_f64(),
            "checkpoint saved"
        );
        Ok(())
    }
}

fn run(path: &Path, out: &Path, json: bool, quiet: bool, ck: Checkpointing) -> ExitCode {
    // a valid scene no method runs yet (3D) is refused as the invalid
    // ones are, before anything is written to `out`
    let scene = match Scene::from_path(path).and_then(|s| cleave::methods::runnable(&s).map(|()| s))
    {
        Ok(s) => s,
        Err(e) => return report_invalid(path, &e, json),
    };
    match run_valid(path, &scene, out, json, quiet, ck) {
        Ok(code) => code,
        Err(e) => {
            if json {
                println!(
                    "{}",
                    json!({"status": "failed", "scene": path, "error": format!("{e:#}")})
                );
            }
            eprintln!("error: {e:#}");
            ExitCode::from(EXIT_FAILED)
        }
    }
}

fn run_valid(
    path: &Path,
    scene: &Scene,
    out: &Path,
    json: bool,
    quiet: bool,
    ck: Checkpointing,
) -> anyhow::Result<ExitCode> {
    let checkpoint_every = ck
        .every
        .map(cleave::checkpoint::CheckpointTimer::interval)
        .transpose()
        .map_err(anyhow::Error::msg)?;
    if !json {
        eprintln!(
            "{}: {} particles, {} cells; plan: {}",
            path.display(),
            scene.total_particles(),
            cells_text(scene),
            scene.plan
        );
    }
    let (writer, mut sim) = if ck.resume {
        // the scene is checked against the checkpoint before the series is
        // touched: a refused resume leaves the results as they were
        let mut cp = OutputWriter::load_checkpoint(out)
            .with_context(|| format!("cannot resume the run in {}", out.display()))?;
        if !json {
            eprintln!(
                "resuming at step {} (t = {:.6e} s) from {}",
                cp.step(),
                cp.time(),
                OutputWriter::checkpoint_path(out).display()
            );
        }
        let state = std::mem::take(&mut cp.observer);
        let sim = cleave::methods::resume(scene, cp).with_context(|| {
            format!(
                "cannot resume {} from {}",
                path.display(),
                OutputWriter::checkpoint_path(out).display()
            )
        })?;
        let writer = OutputWriter::resume(out, &state)
            .with_context(|| format!("cannot resume the run in {}", out.display()))?;
        (writer, sim)
    } else {
        let writer = OutputWriter::create(out)
            .with_context(|| format!("cannot write results to {}", out.display()))?;
        (writer, cleave::methods::build(scene)?)
    };
    let bar = (!quiet && !json).then(|| {
        let bar = ProgressBar::new(1000);
        bar.set_style(
            ProgressStyle::with_template(
                "{bar:40} {percent:>3}% {elapsed_precise} eta {eta} {msg}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar
    });
    let mut obs = RunObserver {
        writer,
        bar,
        checkpoints: cleave::checkpoint::CheckpointTimer::new(checkpoint_every),
    };
    let result = sim.run(&mut obs);
    if let Some(bar) = &obs.bar {
        bar.finish_and_clear();
    }
    let energy_error_relative = obs.writer.energy_error_relative();
    // Write the collections and plots even after a failure: the rows and
    // snapshots up to the failure are what a user needs to see why.
    let paths = obs.writer.finish().context("finishing the output files")?;
    if matches!(&result, Ok(s) if !s.cancelled) {
        // a finished run's checkpoint would only repeat its end
        let _ = std::fs::remove_file(OutputWriter::checkpoint_path(out));
    }
    match result {
        Ok(summary) => {
            let row = summary.last_row;
            if json {
                println!(
                    "{}",
                    json!({
                        "status": if summary.cancelled { "cancelled" } else { "succeeded" },
                        "scene": path,
                        "steps": summary.steps,
                        "time": summary.time,
                        "wall_seconds": summary.wall_seconds,
                        "particles": summary.particles,
                        "stages": summary.stages,
                        "kinetic_energy": row.kinetic_energy,
                        "strain_energy": row.strain_energy,
                        "external_work": row.external_work,
                        "energy_error": row.energy_error,
                        "energy_error_relative": energy_error_relative,
                        "stage_seconds": summary.stage_seconds,
                        "fracture": summary.fracture,
                        "outputs": paths,
                    })
                );
            } else {
                // the energy error counts no dissipation: with fracture,
                // say how much of it the cracks took
                let fractured = if row.fracture_energy != 0.0 {
                    format!(
                        ", {:.3e} J of it dissipated by fracture",
                        row.fracture_energy
                    )
                } else {
                    String::new()
                };
                eprintln!(
                    "done: {} steps to t = {:.6e} s in {:.2} s; kinetic {:.6e} J, strain {:.6e} J, energy balance error {:.3e} J ({:.2e} of the largest kinetic + strain){fractured}; results in {}",
                    summary.steps,
                    summary.time,
                    summary.wall_seconds,
                    row.kinetic_energy,
                    row.strain_energy,
                    row.energy_error,
                    energy_error_relative.unwrap_or(0.0),
                    out.display()
                );
            }
            Ok(ExitCode::SUCCESS)
        }
        Err(e) => {
            if json {
                println!(
                    "{}",
                    json!({"status": "failed", "scene": path, "error": e.to_string(), "outputs": paths})
                );
            }
            eprintln!("simulation failed: {e}");
            Ok(ExitCode::from(EXIT_FAILED))
        }
    }
}

/// Every command against a server.
fn remote_main(target: &remote::Target, command: Command) -> ExitCode {
    let json = command.server_args().is_some_and(|(_, json)| json);
    let runtime = match tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
    {
        Ok(r) => r,
        Err(e) => {
            eprintln!("error: cannot start the async runtime: {e}");
            return ExitCode::from(EXIT_FAILED);
        }
    };
    let server = target.url.as_str();
    let result = runtime.block_on(async move {
        let mut client = remote::connect(target).await?;
        match command {
            Command::Validate { scene, json, .. } => remote::validate(&mut client, &scene, json).await,
            Command::Study { scene, vary, metric, reference, out, json, resume, checkpoint_every, .. } => {
                study::main_remote(&mut client, study::Options { scene, vary, metric, reference, out, json, resume, checkpoint_every }).await
            }
            Command::Run { scene, out, json, quiet, checkpoint_every, resume, .. } => {
                if checkpoint_every.is_some() || resume {
                    return Err(remote::RemoteError::new(
                        EXIT_INVALID,
                        "--checkpoint-every and --resume work on embedded runs only (without --server)",
                    ));
                }
                let job = remote::submit(&mut client, &scene, "").await?;
                if !json {
                    eprintln!("{}: job {} on {server}; {} particles; plan: {}", scene.display(), job.id, job.particles, job.stages.join(" → "));
                }
                let job = remote::watch(&mut client, &job.id, !quiet && !json, false).await?;
                let paths = remote::fetch(&mut client, &job.id, &out).await?;
                let summary = job.summary.unwrap_or_default();
                if json {
                    let mut v = remote::job_value(&job);
                    v["status"] = serde_json::json!(match job.state { s if s == cleave::service::proto::JobState::Succeeded as i32 => "succeeded", s if s == cleave::service::proto::JobState::Cancelled as i32 => "cancelled", _ => "failed" });
                    v["steps"] = serde_json::json!(summary.steps);
                    v["wall_seconds"] = serde_json::json!(summary.wall_seconds);
                    v["kinetic_energy"] = serde_json::json!(summary.kinetic_energy);
                    v["strain_energy"] = serde_json::json!(summary.strain_energy);
                    v["outputs"] = serde_json::json!(paths);
                    println!("{v}");
                } else if job.error.is_empty() {
                    eprintln!("done: {} steps to t = {:.6e} s in {:.2} s; results in {}", summary.steps, summary.time, summary.wall_seconds, out.display());
                } else {
                    eprintln!("job {} {}: {}", job.id, if job.state == cleave::service::proto::JobState::Cancelled as i32 { "cancelled" } else { "failed" }, job.error);
                }
                Ok(remote::outcome(&job))
            }
            Command::Submit { scene, label, wait, json, .. } => {
                let job = remote::submit(&mut client, &scene, &label).await?;
                if !wait {
                    if json { remote::print_job(&job, true) } else { println!("{}", job.id) }
                    return Ok(ExitCode::SUCCESS);
                }
                if !json {
                    println!("{}", job.id);
                }
                let job = remote::watch(&mut client, &job.id, !json, false).await?;
                remote::print_job(&job, json);
                Ok(remote::outcome(&job))
            }
            Command::Watch { job, json, .. } => {
                let job = remote::watch(&mut client, &job, !json, json).await?;
                if !json {
                    remote::print_job(&job, false);
                }
                Ok(remote::outcome(&job))
            }
            Command::Fetch { job, out, json, .. } => {
                let paths = remote::fetch(&mut client, &job, &out).await?;
                if json {
                    println!("{}", serde_json::json!({"status": "fetched", "job_id": job, "outputs": paths}));
                } else {
                    eprintln!("{job}: results in {}", out.display());
                }
                Ok(ExitCode::SUCCESS)
            }
            Command::List { state, limit, json, .. } => {
                let jobs = remote::list(&mut client, state.as_deref(), limit).await?;
                if json {
                    println!("{}", serde_json::Value::Array(jobs.iter().map(remote::job_value).collect()));
                } else if jobs.is_empty() {
                    match &state {
                        Some(s) => println!("no {} jobs", s.to_lowercase()),
                        None => println!("no jobs"),
                    }
                } else {
                    remote::print_job_header();
                    for j in &jobs {
                        remote::print_job(j, false);
                    }
                }
                Ok(ExitCode::SUCCESS)
            }
            Command::Get { job, json, .. } => {
                let job = remote::get(&mut client, &job).await?;
                if json {
                    remote::print_job(&job, true);
                } else {
                    remote::print_job_details(&job);
                }
                Ok(ExitCode::SUCCESS)
            }
            Command::Cancel { job, json, .. } => remote::cancel_and_report(&mut client, &job, json).await,
            Command::Bench { .. } | Command::BenchFleet { .. } | Command::BenchService { .. } | Command::BenchPhaseField { .. } | Command::BenchDfg { .. } | Command::GcPolar { .. } | Command::Plot { .. } | Command::Metric { .. } => {
                eprintln!("error: this command runs in this process; drop --server");
                Ok(ExitCode::from(EXIT_INVALID))
            }
        }
    });
    result.unwrap_or_else(|e| target.explain(e).report(json))
}
