//! A fleet: several `cleave-server` processes sharing one PostgreSQL queue
//! (`--store postgres://…`) and one data directory. Each test starts its own
//! throwaway PostgreSQL cluster with `.ci/postgres.sh` (as an unprivileged
//! user). Where no PostgreSQL server is installed the tests say so and pass,
//! unless `CLEAVE_REQUIRE_POSTGRES` is set, as `.ci/run` sets it after
//! installing one. The results-in-a-bucket test starts an S3 endpoint
//! (moto's server, `.ci/s3.sh`) the same way (`CLEAVE_REQUIRE_S3`).

use cleave::jobs::{pg::Lease, JobError, JobEvent, JobState, PgStore};
use cleave::service::proto::{self, cleave_client::CleaveClient, job_event::Event};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

mod common;
use common::{cleave_bin, Server};

/// A server of the fleet on the database at `url`.
fn fleet_server(data: &Path, url: &str, flags: &[&str], env: &[(&str, String)]) -> Server {
    let mut args = vec!["--store", url];
    args.extend_from_slice(flags);
    Server::start_in(data, &args, env)
}

fn same_files(a: &Path, b: &Path) {
    common::same_files(a, b, 4)
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A throwaway service a `.ci` script starts in a temporary directory
/// (`bash .ci/SCRIPT start DIR` prints its URL) and stops when dropped.
struct Service {
    script: &'static str,
    dir: tempfile::TempDir,
    url: String,
}

impl Service {
    /// Starts one, or says why not (None) where the service is not
    /// installed (the script exits 3) and `require` is not set.
    fn start(script: &'static str, require: &str, hint: &str) -> Option<Service> {
        let dir = tempfile::tempdir().unwrap();
        let o = Command::new("bash")
            .arg(root().join(".ci").join(script))
            .arg("start")
            .arg(dir.path())
            .output()
            .expect("run bash");
        if !o.status.success() {
            let why = String::from_utf8_lossy(&o.stderr);
            if o.status.code() == Some(3) && std::env::var_os(require).is_none() {
                eprintln!("SKIPPED: {why} ({hint})");
                return None;
            }
            panic!("{script} start: {why}");
        }
        let url = String::from_utf8_lossy(&o.stdout).trim().to_string();
        Some(Service { script, dir, url })
    }

    /// `bash .ci/SCRIPT WHAT DIR`, which must succeed.
    fn ctl(&self, what: &str) {
        let o = Command::new("bash")
            .arg(root().join(".ci").join(self.script))
            .arg(what)
            .arg(self.dir.path())
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{} {what}: {}",
            self.script,
            String::from_utf8_lossy(&o.stderr)
        );
    }
}

impl Drop for Service {
    fn drop(&mut self) {
        let _ = Command::new("bash")
            .arg(root().join(".ci").join(self.script))
            .arg("stop")
            .arg(self.dir.path())
            .output();
    }
}

/// A throwaway PostgreSQL cluster (`Service::postgres`) or S3 endpoint
/// with an empty bucket `cleave-test` (`Service::s3`, moto's server).
impl Service {
    /// A PostgreSQL cluster, or None where PostgreSQL is not installed and
    /// no one asked for it.
    fn postgres() -> Option<Service> {
        Service::start(
            "postgres.sh",
            "CLEAVE_REQUIRE_POSTGRES",
            "install PostgreSQL to run the fleet tests",
        )
    }

    /// An S3 endpoint, or None where moto is not installed and no one
    /// asked for it.
    fn s3() -> Option<Service> {
        Service::start(
            "s3.sh",
            "CLEAVE_REQUIRE_S3",
            "pip install 'moto[server]' to run the bucket tests",
        )
    }

    /// PostgreSQL: a new empty database; its URL. (On a thread of its own: the
    /// blocking client cannot run on an async test's runtime.)
    fn database(&self, name: &str) -> String {
        std::thread::scope(|s| {
            s.spawn(|| {
                let mut c = postgres::Client::connect(&self.url, postgres::NoTls).unwrap();
                c.batch_execute(&format!("CREATE DATABASE {name}")).unwrap();
            })
            .join()
            .unwrap()
        });
        self.url.replace("/postgres", &format!("/{name}"))
    }

    /// S3: what a server needs in its environment to reach the bucket.
    fn env(&self) -> Vec<(&'static str, String)> {
        vec![
            ("AWS_ENDPOINT", self.url.clone()),
            ("AWS_ALLOW_HTTP", "true".into()),
            ("AWS_REGION", "us-east-1".into()),
            ("AWS_ACCESS_KEY_ID", "test".into()),
            ("AWS_SECRET_ACCESS_KEY", "test".into()),
        ]
    }

    /// S3: the names of the objects under `prefix` (moto answers a listing
    /// without a signature).
    fn keys(&self, prefix: &str) -> Vec<String> {
        let o = Command::new("python3")
            .args([
                "-c",
                "import sys, urllib.request; print(urllib.request.urlopen(sys.argv[1]).read().decode())",
            ])
            .arg(format!(
                "{}/cleave-test?list-type=2&prefix={prefix}",
                self.url
            ))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout)
            .split("<Key>")
            .skip(1)
            .filter_map(|k| k.split_once("</Key>").map(|(k, _)| k.to_string()))
            .collect()
    }
}

/// A spinning block of 25 600 particles that runs for about `end` × 14 s
/// on one thread (0.28 s for `end = 0.02` on this project's 2-core
/// machine), with `rows` series rows and 3 snapshots.
fn spin_scene(end: f64, rows: u32) -> String {
    format!(
        r#"
[grid]
cell_size = 0.01
max = [1.0, 1.0]
[time]
end = {end}
cfl = 0.5
[[bodies]]
shape = {{ type = "box", min = [0.1, 0.1], max = [0.9, 0.9] }}
material = {{ model = "linear_elastic", density = 1000.0, youngs_modulus = 1.0e6, poissons_ratio = 0.3 }}
velocity_gradient = [[0.0, -0.5], [0.5, 0.0]]
[output]
series_rows = {rows}
snapshots = 3
"#
    )
}

/// `cleave run --quiet` of `text`, embedded, into `out`.
fn run_embedded(dir: &Path, text: &str, out: &Path) {
    let scene = dir.join(format!(
        "{}.toml",
        out.file_name().unwrap().to_string_lossy()
    ));
    std::fs::write(&scene, text).unwrap();
    let o = Command::new(cleave_bin())
        .args(["run", "--quiet"])
        .arg(&scene)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// `cleave --server URL fetch ID --out OUT`.
fn fetch(server: &str, id: &str, out: &Path) {
    let o = Command::new(cleave_bin())
        .args(["--server", server, "fetch", id, "--out"])
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

async fn submit(
    c: &mut CleaveClient<tonic::transport::Channel>,
    scene: &str,
    label: &str,
) -> String {
    c.submit_job(proto::SubmitJobRequest {
        scene: scene.into(),
        label: label.into(),
        ..Default::default()
    })
    .await
    .unwrap()
    .into_inner()
    .id
}

/// The job, asked until it answers (a server may be without its database
/// for a moment).
async fn get(c: &mut CleaveClient<tonic::transport::Channel>, id: &str) -> proto::Job {
    let t0 = Instant::now();
    loop {
        match c
            .get_job(proto::GetJobRequest {
                job_id: id.into(),
                ..Default::default()
            })
            .await
        {
            Ok(j) => return j.into_inner(),
            Err(e) if t0.elapsed() < Duration::from_secs(30) => {
                assert_eq!(e.code(), tonic::Code::Unavailable, "{e}");
                tokio::time::sleep(Duration::from_millis(50)).await;
            }
            Err(e) => panic!("{id}: {e}"),
        }
    }
}

async fn wait_until(
    c: &mut CleaveClient<tonic::transport::Channel>,
    id: &str,
    within: Duration,
    what: &str,
    ok: impl Fn(&proto::Job) -> bool,
) -> proto::Job {
    let t0 = Instant::now();
    loop {
        let j = get(c, id).await;
        if ok(&j) {
            return j;
        }
        assert!(
            t0.elapsed() < within,
            "{id}: not {what} after {within:?}: {:?}, error {:?}",
            proto::JobState::try_from(j.state),
            j.error
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// Waits (up to 120 s) for the job to end; it must have succeeded.
async fn wait_succeeded(c: &mut CleaveClient<tonic::transport::Channel>, id: &str) {
    let j = wait_until(c, id, Duration::from_secs(120), "finished", |j| {
        proto::JobState::try_from(j.state)
            .is_ok_and(|s| s != proto::JobState::Queued && s != proto::JobState::Running)
    })
    .await;
    assert_eq!(
        j.state,
        proto::JobState::Succeeded as i32,
        "{id}: {}",
        j.error
    );
}

/// The whole event stream of a job, as one server tells it.
async fn events(c: &mut CleaveClient<tonic::transport::Channel>, id: &str) -> Vec<proto::JobEvent> {
    let mut s = c
        .watch_job(proto::WatchJobRequest { job_id: id.into() })
        .await
        .unwrap()
        .into_inner();
    let mut out = Vec::new();
    while let Some(e) = s.message().await.unwrap() {
        out.push(e);
    }
    out
}

/// The step of the first progress after the last RUNNING of a job's
/// events: where its last run started (a resumed run, at its checkpoint).
fn last_run_starts_at(events: &[proto::JobEvent]) -> u64 {
    let running = events
        .iter()
        .rposition(|e| matches!(&e.event, Some(Event::State(s)) if s.state == proto::JobState::Running as i32))
        .expect("a RUNNING state");
    events[running..]
        .iter()
        .find_map(|e| match &e.event {
            Some(Event::Progress(p)) => Some(p.step),
            _ => None,
        })
        .expect("progress after the last RUNNING")
}

fn states(events: &[proto::JobEvent]) -> Vec<proto::JobState> {
    events
        .iter()
        .filter_map(|e| match &e.event {
            Some(Event::State(s)) => proto::JobState::try_from(s.state).ok(),
            _ => None,
        })
        .collect()
}

/// The store's own rules, without servers: one claim per job however many
/// ask at once, the fencing token, lapsed leases, cancels, the schema
/// version.
#[test]
fn claims_are_exclusive_and_fenced() {
    let Some(pg) = Service::postgres() else {
        return;
    };
    let url = pg.database("store");
    let dir = tempfile::tempdir().unwrap();
    let store = PgStore::open(&url, dir.path()).unwrap();
    assert_eq!(
        store.schema_version().unwrap(),
        cleave::jobs::pg::MIGRATIONS.len()
    );
    for k in 0..20 {
        store
            .insert(&format!("j{k}"), "[grid]", "x", 1.0, 10, &["p2g".into()])
            .unwrap();
    }
    // eight claimers at once: every job exactly once
    let claimed: Vec<Vec<String>> = std::thread::scope(|s| {
        let hands: Vec<_> = (0..8)
            .map(|w| {
                let mine = store.connection();
                s.spawn(move || {
                    let mut got = Vec::new();
                    while let Some(c) = mine.claim(&format!("w{w}"), 30.0, 2.0).unwrap() {
                        assert_eq!(c.token, 1);
                        assert!(!c.rerun);
                        got.push(c.id);
                    }
                    got
                })
            })
            .collect();
        hands.into_iter().map(|h| h.join().unwrap()).collect()
    });
    let mut all: Vec<String> = claimed.concat();
    all.sort();
    let n = all.len();
    all.dedup();
    assert_eq!(
        (n, all.len()),
        (20, 20),
        "a job was claimed twice or not at all"
    );
    assert!(claimed.iter().filter(|c| !c.is_empty()).count() >= 2);

    // a lapsed lease: the job goes to the next claimer with a new token,
    // and the old holder can write nothing more
    let store2 = PgStore::open(&url, dir.path()).unwrap();
    let id = store.insert("lapse", "[grid]", "x", 1.0, 10, &[]).unwrap();
    let first = store.claim("a", 1.0, 3.0).unwrap().unwrap();
    assert_eq!(first.id, id);
    assert_eq!(
        store2.claim("b", 1.0, 3.0).unwrap(),
        None,
        "the lease still holds"
    );
    std::thread::sleep(Duration::from_millis(1100));
    let second = store2.claim("b", 30.0, 4.0).unwrap().unwrap();
    assert_eq!(
        (second.id.as_str(), second.token, second.rerun),
        (id.as_str(), 2, true)
    );
    let progress = JobEvent::Progress(Default::default());
    assert!(matches!(
        store.push(&id, first.token, &progress),
        Err(JobError::Fenced(_))
    ));
    assert!(matches!(
        store.finish(&id, first.token, JobState::Succeeded, 5.0, None, None),
        Err(JobError::Fenced(_))
    ));
    assert_eq!(
        store
            .renew("a", &[(id.clone(), first.token)], 30.0)
            .unwrap(),
        vec![Lease::Lost]
    );
    assert_eq!(
        store2
            .renew("b", &[(id.clone(), second.token)], 30.0)
            .unwrap(),
        vec![Lease::Held { cancel: false }]
    );
    // a cancel from anywhere reaches the holder's renewal
    assert_eq!(store.cancel(&id, 5.0).unwrap(), JobState::Running);
    assert_eq!(
        store2
            .renew("b", &[(id.clone(), second.token)], 30.0)
            .unwrap(),
        vec![Lease::Held { cancel: true }]
    );
    store2
        .finish(
            &id,
            second.token,
            JobState::Cancelled,
            6.0,
            Some("cancelled while running"),
            None,
        )
        .unwrap();
    let r = store.get(&id).unwrap();
    assert_eq!((r.state, r.worker.as_str()), (JobState::Cancelled, "b"));
    let log = store.events_since(&id, 0).unwrap();
    let kinds: Vec<_> = log
        .iter()
        .map(|e| match e {
            JobEvent::State { state, .. } => state.as_str(),
            _ => "other",
        })
        .collect();
    assert_eq!(kinds, ["QUEUED", "RUNNING", "RUNNING", "CANCELLED"]);
    // a queued job is cancelled at once
    let q = store.insert("q", "[grid]", "x", 1.0, 10, &[]).unwrap();
    assert_eq!(store.cancel(&q, 7.0).unwrap(), JobState::Queued);
    assert_eq!(store.get(&q).unwrap().state, JobState::Cancelled);

    // a database a newer server migrated is refused, and left as it is
    let mut c = postgres::Client::connect(&url, postgres::NoTls).unwrap();
    c.batch_execute("UPDATE cleave_schema SET version = 99")
        .unwrap();
    let e = PgStore::open(&url, dir.path()).err().expect("refused");
    assert!(e.to_string().contains("schema version 99"), "{e}");
}

/// Three servers, 30 small jobs submitted round-robin: every job runs
/// exactly once, on more than one server, and every server fetches every
/// job's results, byte for byte those of an embedded run.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn three_servers_run_thirty_jobs_once_each() {
    let Some(pg) = Service::postgres() else {
        return;
    };
    let url = pg.database("three");
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let servers: Vec<Server> = (0..3)
        .map(|_| fleet_server(&data, &url, &["--lease", "5"], &[]))
        .collect();
    let scenes: Vec<String> = (0..3)
        .map(|k| spin_scene(0.002 * (k + 1) as f64, 6))
        .collect();
    let mut clients = Vec::new();
    for s in &servers {
        clients.push(s.client().await);
    }
    let mut jobs = Vec::new();
    for k in 0..30 {
        let id = submit(&mut clients[k % 3], &scenes[k % 3], &format!("job {k}")).await;
        jobs.push((id, k % 3));
    }
    let mut workers = std::collections::BTreeSet::new();
    for (k, (id, _)) in jobs.iter().enumerate() {
        let c = &mut clients[(k + 1) % 3];
        let j = wait_until(c, id, Duration::from_secs(120), "finished", |j| {
            j.state == proto::JobState::Succeeded as i32
        })
        .await;
        workers.insert(j.worker.clone());
        // the whole stream from a server that may not have run it
        let log = events(&mut clients[(k + 2) % 3], id).await;
        assert_eq!(
            states(&log),
            [
                proto::JobState::Queued,
                proto::JobState::Running,
                proto::JobState::Succeeded
            ],
            "{id} did not run exactly once"
        );
        for (n, e) in log.iter().enumerate() {
            assert_eq!(e.sequence, n as u64);
        }
    }
    assert!(workers.len() >= 2, "one server ran every job: {workers:?}");
    assert!(
        workers
            .iter()
            .all(|w| servers.iter().any(|s| w.ends_with(&s.pid_suffix()))),
        "{workers:?}"
    );
    let local: Vec<PathBuf> = (0..3)
        .map(|k| {
            let out = dir.path().join(format!("local{k}"));
            run_embedded(dir.path(), &scenes[k], &out);
            out
        })
        .collect();
    for (n, (id, k)) in jobs.iter().enumerate() {
        // each job from every server (a third of them, to keep it short,
        // from all three)
        let from: Vec<usize> = if n % 3 == 0 {
            vec![0, 1, 2]
        } else {
            vec![n % 3]
        };
        for s in from {
            let out = dir.path().join(format!("{id}-from-{s}"));
            fetch(&servers[s].url, id, &out);
            same_files(&local[*k], &out);
        }
    }
}

/// kill -9 of the server running a job: another server takes it when its
/// lease lapses and finishes it from its checkpoint, with the results of
/// an uninterrupted run; a cancel on one server stops a job running on
/// another within a second.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_killed_servers_job_is_finished_by_another_from_its_checkpoint() {
    let Some(pg) = Service::postgres() else {
        return;
    };
    killed_server_takeover(&pg, "kill", None).await;
}

/// The same with the results in an S3 bucket and each server a data
/// directory of its own: the checkpoint reaches the next server through
/// the bucket, and a server that never ran the job serves its files.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn results_in_a_bucket_survive_the_server_that_wrote_them() {
    let Some(pg) = Service::postgres() else {
        return;
    };
    let Some(s3) = Service::s3() else { return };
    killed_server_takeover(&pg, "bucket", Some(&s3)).await;
}

async fn killed_server_takeover(pg: &Service, name: &str, s3: Option<&Service>) {
    let url = pg.database(name);
    let dir = tempfile::tempdir().unwrap();
    // one data directory for all, or one each with the bucket
    let data = |k: usize| match s3 {
        None => dir.path().join("data"),
        Some(_) => dir.path().join(format!("data{k}")),
    };
    let lease = 2.0;
    let every = 0.2;
    let results = format!("s3://cleave-test/{name}");
    let mut flags = vec!["--lease", "2", "--checkpoint-every", "0.2"];
    if s3.is_some() {
        flags.extend(["--results", &results]);
    }
    let env = s3.map(Service::env).unwrap_or_default();
    let mut servers: Vec<Option<Server>> = (0..2)
        .map(|k| Some(fleet_server(&data(k), &url, &flags, &env)))
        .collect();
    let text = spin_scene(0.35, 40);
    let mut c0 = servers[0].as_ref().unwrap().client().await;
    let id = submit(&mut c0, &text, "survivor").await;
    let running = wait_until(&mut c0, &id, Duration::from_secs(30), "running", |j| {
        j.state == proto::JobState::Running as i32
            && j.progress.as_ref().is_some_and(|p| p.fraction > 0.1)
    })
    .await;
    let k = servers
        .iter()
        .position(|s| running.worker.ends_with(&s.as_ref().unwrap().pid_suffix()))
        .expect("a server of ours runs it");
    // a checkpoint exists
    let cp = data(k).join("jobs").join(&id).join("checkpoint.bin");
    let t0 = Instant::now();
    while !cp.exists() {
        assert!(t0.elapsed() < Duration::from_secs(10), "no checkpoint");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(300));
    servers[k] = None; // SIGKILL
    let killed = Instant::now();
    let other = servers[1 - k].as_ref().unwrap();
    let mut c = other.client().await;
    let suffix = other.pid_suffix();
    let taken = wait_until(&mut c, &id, Duration::from_secs(30), "taken over", |j| {
        j.worker.ends_with(&suffix)
    })
    .await;
    let after = killed.elapsed().as_secs_f64();
    eprintln!("taken over {after:.3} s after the kill (lease {lease} s)");
    assert!(
        after < lease + every + 1.0,
        "taken over {after:.2} s after the kill (lease {lease} s, checkpoints every {every} s)"
    );
    assert_ne!(
        taken.state,
        proto::JobState::Failed as i32,
        "{}",
        taken.error
    );
    wait_succeeded(&mut c, &id).await;
    let log = events(&mut c, &id).await;
    assert_eq!(
        states(&log),
        [
            proto::JobState::Queued,
            proto::JobState::Running,
            proto::JobState::Running,
            proto::JobState::Succeeded
        ]
    );
    // the second run starts from the checkpoint, not from step 0
    let resumed_at = last_run_starts_at(&log);
    eprintln!("resumed at step {resumed_at}");
    assert!(
        resumed_at > 1,
        "the takeover started again at step {resumed_at}"
    );
    let local = dir.path().join("local");
    run_embedded(dir.path(), &text, &local);
    let remote = dir.path().join("remote");
    fetch(&other.url, &id, &remote);
    same_files(&local, &remote);
    let finisher_cp = data(1 - k).join("jobs").join(&id).join("checkpoint.bin");
    assert!(
        !finisher_cp.exists(),
        "the finished job's checkpoint is left"
    );
    let second = fleet_server(&data(2), &url, &flags, &env);
    if let Some(s3) = s3 {
        let keys = s3.keys(&format!("{name}/jobs/{id}/"));
        let names: Vec<&str> = keys.iter().filter_map(|k| k.rsplit('/').next()).collect();
        assert_eq!(
            names,
            [
                "series.csv",
                "snapshot_0000.bin",
                "snapshot_0001.bin",
                "snapshot_0002.bin"
            ],
            "the bucket holds the job's files and no checkpoint"
        );
        // a server that never ran the job serves it from the bucket
        let third = dir.path().join("third");
        fetch(&second.url, &id, &third);
        same_files(&local, &third);
        assert!(
            !data(2).join("jobs").join(&id).exists(),
            "the API read a worker's directory"
        );
    }

    // cancel on a server that does not run the job
    let mut c2 = second.client().await;
    let id = submit(&mut c2, &spin_scene(1.0, 10), "cancel me").await;
    let j = wait_until(&mut c2, &id, Duration::from_secs(30), "running", |j| {
        j.state == proto::JobState::Running as i32
    })
    .await;
    let (runner, elsewhere) = if j.worker.ends_with(&second.pid_suffix()) {
        (&second, other)
    } else {
        (other, &second)
    };
    let mut ce = elsewhere.client().await;
    let t0 = Instant::now();
    ce.cancel_job(proto::CancelJobRequest { job_id: id.clone() })
        .await
        .unwrap();
    let mut cr = runner.client().await;
    wait_until(
        &mut cr,
        &id,
        Duration::from_secs(1),
        "cancelled within a second",
        |j| j.state == proto::JobState::Cancelled as i32,
    )
    .await;
    eprintln!(
        "cancelled on another server in {:.3} s",
        t0.elapsed().as_secs_f64()
    );
}

/// One server on SQLite with its results in a bucket, killed after a
/// checkpoint and started again with its job directories gone (a new
/// disk): it resumes the job from the bucket's checkpoint, with the
/// results of an uninterrupted run.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_server_resumes_from_the_buckets_checkpoint() {
    let Some(s3) = Service::s3() else { return };
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let flags = [
        "--results",
        "s3://cleave-test/one",
        "--checkpoint-every",
        "0.2",
    ];
    let env = s3.env();
    let mut server = Server::start_in(&data, &flags, &env);
    let text = spin_scene(0.35, 40);
    let mut c = server.client().await;
    let id = submit(&mut c, &text, "one").await;
    let t0 = Instant::now();
    while !s3
        .keys(&format!("one/jobs/{id}/"))
        .iter()
        .any(|k| k.ends_with("/checkpoint.bin"))
    {
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "no checkpoint in the bucket"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    server.kill();
    std::fs::remove_dir_all(data.join("jobs")).unwrap();
    let server = Server::start_in(&data, &flags, &env);
    let mut c = server.client().await;
    wait_succeeded(&mut c, &id).await;
    let resumed_at = last_run_starts_at(&events(&mut c, &id).await);
    eprintln!("resumed at step {resumed_at}");
    assert!(resumed_at > 1, "started again at step {resumed_at}");
    let local = dir.path().join("local");
    run_embedded(dir.path(), &text, &local);
    let remote = dir.path().join("remote");
    fetch(&server.url, &id, &remote);
    same_files(&local, &remote);
}

/// `cleave study --server` against one server of three: the fleet's
/// workers claim its runs, and it measures what the embedded study does.
#[test]
fn a_study_spreads_over_the_fleet() {
    let Some(pg) = Service::postgres() else {
        return;
    };
    let url = pg.database("study");
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let servers: Vec<Server> = (0..3)
        .map(|_| fleet_server(&data, &url, &["--lease", "5"], &[]))
        .collect();
    let path = dir.path().join("spin.toml");
    std::fs::write(&path, spin_scene(0.02, 5)).unwrap();
    let (a, b, _) = common::study_here_and_on(
        &servers[0],
        &path,
        "time.cfl=0.2,0.25,0.3,0.35,0.4,0.45",
        "final:kinetic_energy",
        dir.path(),
    );
    assert_eq!(a.len(), 6);
    assert!(a.iter().all(|m| m.0.is_f64()), "{a:?}");
    assert_eq!(
        a, b,
        "the fleet's study measures what the embedded one does"
    );
    // every run ran once, and not all on one server
    let o = servers[2].cli(&["list", "--json"]);
    let jobs: Vec<serde_json::Value> =
        serde_json::from_str(String::from_utf8_lossy(&o.stdout).trim()).unwrap();
    assert_eq!(jobs.len(), 6);
    let mut workers: Vec<&str> = jobs.iter().map(|j| j["worker"].as_str().unwrap()).collect();
    assert!(
        workers
            .iter()
            .all(|w| servers.iter().any(|s| w.ends_with(&s.pid_suffix()))),
        "{workers:?}"
    );
    workers.sort();
    workers.dedup();
    eprintln!("the study's 6 runs ran on {} servers", workers.len());
    assert!(workers.len() >= 2, "all runs on {workers:?}");
}

/// Waits until the server's health is SERVING (or, `serving` false, is
/// not) for at most `within`.
async fn wait_health(
    health: &mut tonic_health::pb::health_client::HealthClient<tonic::transport::Channel>,
    serving: bool,
    within: Duration,
) {
    let t0 = Instant::now();
    loop {
        let h = health
            .check(tonic_health::pb::HealthCheckRequest {
                service: String::new(),
            })
            .await
            .unwrap()
            .into_inner();
        let is = h.status == tonic_health::pb::health_check_response::ServingStatus::Serving as i32;
        if is == serving {
            return;
        }
        assert!(
            t0.elapsed() < within,
            "health not {} after {within:?}",
            if serving { "SERVING" } else { "NOT_SERVING" }
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// PostgreSQL restarted while jobs run and wait: no job is lost or run
/// twice, the servers' health says NOT_SERVING while it is away and comes
/// back, and the results are those of an embedded run.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_database_restart_loses_no_job() {
    let Some(pg) = Service::postgres() else {
        return;
    };
    let url = pg.database("restart");
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let servers: Vec<Server> = (0..2)
        .map(|_| {
            fleet_server(
                &data,
                &url,
                &["--lease", "10", "--checkpoint-every", "0.3"],
                &[],
            )
        })
        .collect();
    let text = spin_scene(0.1, 8);
    let mut c = servers[0].client().await;
    let mut ids = Vec::new();
    for k in 0..8 {
        ids.push(submit(&mut c, &text, &format!("r{k}")).await);
    }
    wait_until(&mut c, &ids[0], Duration::from_secs(30), "running", |j| {
        j.state == proto::JobState::Running as i32
    })
    .await;
    // stop the database, see health go, start it again
    pg.ctl("stop");
    let mut health = tonic_health::pb::health_client::HealthClient::new(
        tonic::transport::Channel::from_shared(servers[1].url.clone())
            .unwrap()
            .connect()
            .await
            .unwrap(),
    );
    wait_health(&mut health, false, Duration::from_secs(5)).await;
    let e = c
        .get_job(proto::GetJobRequest {
            job_id: ids[0].clone(),
            ..Default::default()
        })
        .await
        .expect_err("no database");
    assert_eq!(e.code(), tonic::Code::Unavailable, "{e}");
    tokio::time::sleep(Duration::from_millis(1500)).await;
    pg.ctl("restart");
    wait_health(&mut health, true, Duration::from_secs(10)).await;
    let local = dir.path().join("local");
    run_embedded(dir.path(), &text, &local);
    for id in &ids {
        wait_succeeded(&mut c, id).await;
        assert_eq!(
            states(&events(&mut c, id).await),
            [
                proto::JobState::Queued,
                proto::JobState::Running,
                proto::JobState::Succeeded
            ],
            "{id} did not run exactly once"
        );
        let remote = dir.path().join(id);
        fetch(&servers[1].url, id, &remote);
        same_files(&local, &remote);
    }
}
