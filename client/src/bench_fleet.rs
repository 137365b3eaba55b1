//! `cleave bench-fleet`: jobs per hour of small jobs with one server on
//! SQLite, one server on PostgreSQL and three servers sharing a PostgreSQL
//! queue, and the PostgreSQL store's cost per job against SQLite's
//! (issue 38). Real `cleave-server` processes (the binary beside this
//! one), each with one runner on one thread, on loopback.

use cleave::service::proto::{self, cleave_client::CleaveClient};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A block of 6 400 particles spinning for 13 steps: about 15 ms of
/// compute, so the store's and the queue's costs show.
const SCENE: &str = r#"
[grid]
cell_size = 0.02
max = [1.0, 1.0]
[time]
end = 0.004
cfl = 0.5
[[bodies]]
shape = { type = "box", min = [0.1, 0.1], max = [0.9, 0.9] }
material = { model = "linear_elastic", density = 1000.0, youngs_modulus = 1.0e6, poissons_ratio = 0.3 }
velocity_gradient = [[0.0, -0.5], [0.5, 0.0]]
[output]
series_rows = 5
snapshots = 2
"#;

struct Server {
    child: Child,
    url: String,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn server_bin() -> anyhow::Result<PathBuf> {
    let me = std::env::current_exe()?;
    let p = me.with_file_name(format!("cleave-server{}", std::env::consts::EXE_SUFFIX));
    anyhow::ensure!(
        p.exists(),
        "{} is missing: build it with `cargo build --release --bin cleave-server`",
        p.display()
    );
    Ok(p)
}

fn start(data: &Path, store: &str) -> anyhow::Result<Server> {
    let mut child = Command::new(server_bin()?)
        .args(["--listen", "127.0.0.1:0", "--threads-per-job", "1"])
        .args(["--max-concurrent-jobs", "1", "--max-queued-jobs", "100000"])
        .args(["--checkpoint-every", "0", "--store", store, "--data-dir"])
        .arg(data)
        .env("RUST_LOG", "warn")
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()?;
    let mut line = String::new();
    BufReader::new(child.stdout.take().expect("piped")).read_line(&mut line)?;
    let addr = line
        .trim()
        .strip_prefix("listening on ")
        .ok_or_else(|| anyhow::anyhow!("unexpected server output {line:?}"))?;
    Ok(Server {
        url: format!("http://{addr}"),
        child,
    })
}

/// Submits `jobs` jobs round-robin to `servers` and waits for all: the
/// wall seconds from the first submission to the last job's end.
async fn batch(servers: &[Server], jobs: usize) -> anyhow::Result<f64> {
    let mut clients = Vec::new();
    for s in servers {
        clients.push(CleaveClient::connect(s.url.clone()).await?);
    }
    let t0 = Instant::now();
    let mut ids = Vec::new();
    for k in 0..jobs {
        let c = &mut clients[k % servers.len()];
        let j = c
            .submit_job(proto::SubmitJobRequest {
                scene: SCENE.into(),
                label: format!("bench {k}"),
                ..Default::default()
            })
            .await?
            .into_inner();
        ids.push(j.id);
    }
    // the last job queued ends last but for the order of the claims:
    // wait for every one
    for id in &ids {
        loop {
            let j = clients[0]
                .get_job(proto::GetJobRequest {
                    job_id: id.clone(),
                    view: proto::JobView::Basic as i32,
                })
                .await?
                .into_inner();
            if j.state == proto::JobState::Succeeded as i32 {
                break;
            }
            anyhow::ensure!(
                j.state != proto::JobState::Failed as i32
                    && j.state != proto::JobState::Cancelled as i32,
                "{id} ended {}: {}",
                j.state,
                j.error
            );
            tokio::time::sleep(Duration::from_millis(5)).await;
        }
    }
    Ok(t0.elapsed().as_secs_f64())
}

/// A new database on the PostgreSQL server of `url`; its URL.
fn database(url: &str, name: &str) -> anyhow::Result<String> {
    let mut c = postgres::Client::connect(url, postgres::NoTls)?;
    c.batch_execute(&format!("DROP DATABASE IF EXISTS {name}"))?;
    c.batch_execute(&format!("CREATE DATABASE {name}"))?;
    let (base, _) = url
        .rsplit_once('/')
        .ok_or_else(|| anyhow::anyhow!("--postgres: a URL ending in /DATABASE"))?;
    Ok(format!("{base}/{name}"))
}

/// `cleave bench-fleet`.
pub fn run(postgres: &str, jobs: usize, rounds: usize, out: &Path) -> anyhow::Result<()> {
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    let cases: [(&str, usize); 3] = [("sqlite", 1), ("postgres", 1), ("postgres", 3)];
    let mut walls = vec![Vec::new(); cases.len()];
    for round in 0..rounds {
        // alternated, so that every case sees the same machine
        for (k, (store, servers)) in cases.iter().enumerate() {
            let dir = tempfile::tempdir()?;
            let store_url = if *store == "sqlite" {
                "sqlite".to_string()
            } else {
                database(
                    postgres,
                    &format!("cleave_bench_{}_{k}", std::process::id()),
                )?
            };
            let fleet: Vec<Server> = (0..*servers)
                .map(|_| start(&dir.path().join("data"), &store_url))
                .collect::<anyhow::Result<_>>()?;
            let wall = rt.block_on(batch(&fleet, jobs))?;
            eprintln!(
                "round {round}: {store} × {servers}: {jobs} jobs in {wall:.2} s ({:.0} jobs/h)",
                3600.0 * jobs as f64 / wall
            );
            walls[k].push(wall);
        }
    }
    let med: Vec<f64> = walls
        .iter()
        .map(|w| super::bench::median(w.clone()))
        .collect();
    let rate = |w: f64| 3600.0 * jobs as f64 / w;
    let mut md = String::new();
    md.push_str(&format!(
        "# A fleet's throughput (issue 38)\n\n\
         `cleave bench-fleet --postgres URL --jobs {jobs} --rounds {rounds}` on {} ({} cores), \
         PostgreSQL from `bash .ci/postgres.sh start DIR` on the same machine (fsync off). \
         Each case starts fresh `cleave-server` processes (one runner each, one thread per job, \
         no checkpoints) on a new data directory (and a new database), submits {jobs} jobs \
         round-robin (a 6 400-particle block, 13 steps, 5 series rows, 2 snapshots: about 15 ms \
         of compute) and waits until every one has SUCCEEDED. Cases alternate within each round; \
         the table gives the median wall time over the rounds.\n\n\
         | store | servers | wall s (median) | jobs per hour | per job ms |\n|---|---:|---:|---:|---:|\n",
        super::bench::cpu_name(),
        std::thread::available_parallelism().map_or(1, |n| n.get()),
    ));
    for ((store, servers), w) in cases.iter().zip(&med) {
        md.push_str(&format!(
            "| {store} | {servers} | {w:.2} | {:.0} | {:.1} |\n",
            rate(*w),
            1000.0 * w / jobs as f64
        ));
    }
    let overhead = 1000.0 * (med[1] - med[0]) / jobs as f64;
    md.push_str(&format!(
        "\nThe PostgreSQL store against SQLite, one server: **{overhead:+.1} ms per job** \
         (its claim polls every 250 ms when idle, but a runner that finishes a job claims the \
         next at once; events, leases and the end are a few statements each). \
         Three servers against one on PostgreSQL: {:.2}× the jobs per hour, on a machine of {} cores \
         (three one-thread workers share them).\n\nEvery round:\n\n",
        med[1] / med[2],
        std::thread::available_parallelism().map_or(1, |n| n.get()),
    ));
    for (k, (store, servers)) in cases.iter().enumerate() {
        let list: Vec<String> = walls[k].iter().map(|w| format!("{w:.2}")).collect();
        md.push_str(&format!("- {store} × {servers}: {} s\n", list.join(", ")));
    }
    print!("{md}");
    std::fs::File::create(out)?.write_all(md.as_bytes())?;
    eprintln!("written to {}", out.display());
    Ok(())
}
