//! A fleet: several `cleave-server` processes sharing one PostgreSQL queue
//! (`--store postgres://…`) and one data directory. Each test starts its own
//! throwaway PostgreSQL cluster with `.ci/postgres.sh` (as an unprivileged
//! user). Where no PostgreSQL server is installed the tests say so and pass,
//! unless `CLEAVE_REQUIRE_POSTGRES` is set, as `.ci/run` sets it after
//! installing one.

use cleave::jobs::{pg::Lease, JobError, JobEvent, JobState, PgStore};
use cleave::service::proto::{self, cleave_client::CleaveClient, job_event::Event};
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn cleave_bin() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_cleave"))
}

fn server_bin() -> PathBuf {
    let p = cleave_bin().with_file_name(format!("cleave-server{}", std::env::consts::EXE_SUFFIX));
    assert!(
        p.exists(),
        "{} is missing: run the tests with `cargo test --release --workspace`",
        p.display()
    );
    p
}

/// A throwaway PostgreSQL cluster, stopped when dropped.
struct Cluster {
    dir: tempfile::TempDir,
    url: String,
}

impl Cluster {
    /// Starts one, or says why not (None) where PostgreSQL is not
    /// installed and no one asked for it.
    fn start() -> Option<Cluster> {
        let dir = tempfile::tempdir().unwrap();
        let o = Command::new("bash")
            .arg(root().join(".ci/postgres.sh"))
            .arg("start")
            .arg(dir.path())
            .output()
            .expect("run bash");
        if !o.status.success() {
            let why = String::from_utf8_lossy(&o.stderr);
            if o.status.code() == Some(3) && std::env::var_os("CLEAVE_REQUIRE_POSTGRES").is_none() {
                eprintln!("SKIPPED: {why} (install PostgreSQL to run the fleet tests)");
                return None;
            }
            panic!("cannot start PostgreSQL: {why}");
        }
        let url = String::from_utf8_lossy(&o.stdout).trim().to_string();
        Some(Cluster { dir, url })
    }

    fn ctl(&self, what: &str) {
        let o = Command::new("bash")
            .arg(root().join(".ci/postgres.sh"))
            .arg(what)
            .arg(self.dir.path())
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "postgres {what}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }

    /// A new empty database; its URL. (On a thread of its own: the
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
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new("bash")
            .arg(root().join(".ci/postgres.sh"))
            .arg("stop")
            .arg(self.dir.path())
            .output();
    }
}

struct Server {
    child: Child,
    url: String,
}

impl Server {
    fn start(data: &Path, store: &str, extra: &[&str]) -> Server {
        let mut child = Command::new(server_bin())
            .args(["--listen", "127.0.0.1:0", "--data-dir"])
            .arg(data)
            .args(["--threads-per-job", "1", "--store", store])
            .args(extra)
            .env("RUST_LOG", "warn")
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("start cleave-server");
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        let addr = line
            .trim()
            .strip_prefix("listening on ")
            .unwrap_or_else(|| panic!("unexpected server output {line:?}"))
            .to_string();
        Server {
            child,
            url: format!("http://{addr}"),
        }
    }

    /// Its name in claims: `host-pid`.
    fn pid_suffix(&self) -> String {
        format!("-{}", self.child.id())
    }

    async fn client(&self) -> CleaveClient<tonic::transport::Channel> {
        CleaveClient::connect(self.url.clone())
            .await
            .unwrap()
            .max_decoding_message_size(usize::MAX)
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
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

fn same_files(a: &Path, b: &Path) {
    let mut names: Vec<_> = std::fs::read_dir(a)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    names.sort();
    assert!(names.len() >= 4, "too few files in {}", a.display());
    for n in names {
        let x = std::fs::read(a.join(&n)).unwrap();
        let y = std::fs::read(b.join(&n)).unwrap_or_default();
        assert!(
            x == y,
            "{n:?} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
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
    let Some(pg) = Cluster::start() else { return };
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
    let Some(pg) = Cluster::start() else { return };
    let url = pg.database("three");
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let servers: Vec<Server> = (0..3)
        .map(|_| Server::start(&data, &url, &["--lease", "5"]))
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
    let Some(pg) = Cluster::start() else { return };
    let url = pg.database("kill");
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let lease = 2.0;
    let every = 0.2;
    let flags = ["--lease", "2", "--checkpoint-every", "0.2"];
    let mut servers: Vec<Option<Server>> = (0..2)
        .map(|_| Some(Server::start(&data, &url, &flags)))
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
    let cp = data.join("jobs").join(&id).join("checkpoint.bin");
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
    let done = wait_until(&mut c, &id, Duration::from_secs(120), "finished", |j| {
        proto::JobState::try_from(j.state)
            .is_ok_and(|s| matches!(s, proto::JobState::Succeeded | proto::JobState::Failed))
    })
    .await;
    assert_eq!(
        done.state,
        proto::JobState::Succeeded as i32,
        "{}",
        done.error
    );
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
    let local = dir.path().join("local");
    run_embedded(dir.path(), &text, &local);
    let remote = dir.path().join("remote");
    fetch(&other.url, &id, &remote);
    same_files(&local, &remote);
    assert!(!cp.exists(), "the finished job's checkpoint is left");

    // cancel on a server that does not run the job
    let second = Server::start(&data, &url, &flags);
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

/// PostgreSQL restarted while jobs run and wait: no job is lost or run
/// twice, the servers' health says NOT_SERVING while it is away and comes
/// back, and the results are those of an embedded run.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_database_restart_loses_no_job() {
    let Some(pg) = Cluster::start() else { return };
    let url = pg.database("restart");
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let servers: Vec<Server> = (0..2)
        .map(|_| Server::start(&data, &url, &["--lease", "10", "--checkpoint-every", "0.3"]))
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
    let serving = |h: &tonic_health::pb::HealthCheckResponse| {
        h.status == tonic_health::pb::health_check_response::ServingStatus::Serving as i32
    };
    let t0 = Instant::now();
    loop {
        let h = health
            .check(tonic_health::pb::HealthCheckRequest {
                service: String::new(),
            })
            .await
            .unwrap()
            .into_inner();
        if !serving(&h) {
            break;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(5),
            "still SERVING without its database"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
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
    let t0 = Instant::now();
    loop {
        let h = health
            .check(tonic_health::pb::HealthCheckRequest {
                service: String::new(),
            })
            .await
            .unwrap()
            .into_inner();
        if serving(&h) {
            break;
        }
        assert!(t0.elapsed() < Duration::from_secs(10), "not SERVING again");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let local = dir.path().join("local");
    run_embedded(dir.path(), &text, &local);
    for id in &ids {
        let j = wait_until(&mut c, id, Duration::from_secs(120), "finished", |j| {
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
