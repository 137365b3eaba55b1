//! Crack polylines through the service (issue 33): ListSnapshots names a
//! crack job's snapshot lines, FetchFields serves them at
//! `LOCATION_LINES`, and `cleave fetch` writes the `cracks_NNNN.vtp` files
//! and `cracks.pvd` an embedded run writes, with the points the job
//! stored; a scene without cracks fetches what it always did.
//!
//! The server runs in this process (`service::serve_on` on a loopback
//! port), so the test needs only the `cleave` binary of this package.

use cleave::jobs::snapfile::SnapshotReader;
use cleave::jobs::JobConfig;
use cleave::service::proto::{self, cleave_client::CleaveClient};
use cleave::service::{serve_on, ServerConfig};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant};

/// The stacked blocks of `tests/engine/crack_snapshots.rs`
/// (`tests/data/stacked_cracks.toml`), the top one pulled away: with an
/// interface crack through both edges and a crack inside the top block
/// (whose ends are tips, so the series has a finite J), or without
/// cracks; five snapshots over 0.1 ms.
fn scene(cracks: bool) -> String {
    include_str!("../../tests/data/stacked_cracks.toml")
        .lines()
        .filter(|l| cracks || !l.starts_with("explicit_cracks"))
        .map(|l| format!("{l}\n"))
        .collect()
}

/// A server on a free loopback port inside this process, with its data
/// directory; dropping it shuts the server down.
struct Server {
    runtime: tokio::runtime::Runtime,
    url: String,
    data: PathBuf,
    stop: Option<tokio::sync::oneshot::Sender<()>>,
}

impl Server {
    fn start(data: &Path) -> Server {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .unwrap();
        let listener = runtime
            .block_on(tokio::net::TcpListener::bind("127.0.0.1:0"))
            .unwrap();
        let addr = listener.local_addr().unwrap();
        let config = ServerConfig {
            listen: addr,
            jobs: JobConfig {
                data_dir: data.to_path_buf(),
                max_concurrent: 1,
                threads_per_job: 1,
                max_particles: 1_000_000,
                max_memory: None,
                max_queued: 8,
                store: cleave::jobs::StoreSpec::Sqlite,
                results: cleave::jobs::ResultsSpec::DataDir,
                checkpoint_every: None,
            },
            token: None,
            max_request_bytes: 4 << 20,
            tls: None,
        };
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        runtime.spawn(async move {
            let shutdown = async {
                let _ = stopped.await;
            };
            if let Err(e) = serve_on(listener, config, shutdown).await {
                panic!("the server stopped: {e}");
            }
        });
        Server {
            runtime,
            url: format!("http://{addr}"),
            data: data.to_path_buf(),
            stop: Some(stop),
        }
    }

    fn client(&self) -> CleaveClient<tonic::transport::Channel> {
        self.runtime
            .block_on(CleaveClient::connect(self.url.clone()))
            .expect("connect")
    }

    /// Submits `scene` and waits for the job to succeed; its id.
    fn run_job(&self, scene: &str) -> String {
        let mut c = self.client();
        self.runtime.block_on(async {
            let id = c
                .submit_job(proto::SubmitJobRequest {
                    scene: scene.to_string(),
                    ..Default::default()
                })
                .await
                .unwrap()
                .into_inner()
                .id;
            let t0 = Instant::now();
            loop {
                let j = c
                    .get_job(proto::GetJobRequest {
                        job_id: id.clone(),
                        ..Default::default()
                    })
                    .await
                    .unwrap()
                    .into_inner();
                if j.state == proto::JobState::Succeeded as i32 {
                    return id;
                }
                assert!(
                    j.state == proto::JobState::Queued as i32
                        || j.state == proto::JobState::Running as i32,
                    "{id} ended {:?}: {}",
                    proto::JobState::try_from(j.state),
                    j.error
                );
                assert!(t0.elapsed() < Duration::from_secs(120), "{id} too slow");
                tokio::time::sleep(Duration::from_millis(20)).await;
            }
        })
    }

    fn snapshots(&self, id: &str) -> Vec<proto::SnapshotInfo> {
        let mut c = self.client();
        self.runtime
            .block_on(c.list_snapshots(proto::ListSnapshotsRequest { job_id: id.into() }))
            .unwrap()
            .into_inner()
            .snapshots
    }

    /// `cleave fetch ID --out OUT`, which must succeed.
    fn fetch(&self, id: &str, out: &Path) {
        let o = cleave(&["--server", &self.url, "fetch", id, "--out"], out);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
    }
}

/// The `cleave` binary with `args`, then `path`.
fn cleave(args: &[&str], path: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cleave"))
        .args(args)
        .arg(path)
        .output()
        .expect("run cleave")
}

/// `cleave run --quiet SCENE --out OUT`, embedded.
fn run_embedded(scene: &str, dir: &Path) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let file = dir.join("scene.toml");
    std::fs::write(&file, scene).unwrap();
    let out = dir.join("out");
    let o = Command::new(env!("CARGO_BIN_EXE_cleave"))
        .args(["run", "--quiet"])
        .arg(&file)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out
}

fn names(dir: &Path) -> Vec<String> {
    let mut n: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    n.sort();
    n
}

/// The same file names with the same bytes in both directories.
fn same_files(a: &Path, b: &Path) {
    assert_eq!(names(a), names(b), "{} and {}", a.display(), b.display());
    for n in names(a) {
        assert!(
            std::fs::read(a.join(&n)).unwrap() == std::fs::read(b.join(&n)).unwrap(),
            "{n} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

/// A crack job's snapshots list their lines (three per crack, with the
/// cracks' point counts); `cleave fetch` writes a `cracks_NNNN.vtp` per
/// snapshot with the lines the job stored, and its output directory is
/// the embedded run's byte for byte (crack files, `cracks.pvd` and
/// `j_integral.png` included).
#[test]
fn a_crack_job_fetches_its_crack_files() {
    let tmp = tempfile::tempdir().unwrap();
    let server = Server::start(&tmp.path().join("data"));
    let text = scene(true);
    let id = server.run_job(&text);

    let snaps = server.snapshots(&id);
    assert_eq!(snaps.len(), 5);
    for s in &snaps {
        let l = s.lines.as_ref().expect("a crack snapshot's lines");
        assert_eq!(l.counts, [4, 4, 4, 3, 3, 3]);
        let fields: Vec<(&str, u32)> = l
            .fields
            .iter()
            .map(|f| (f.name.as_str(), f.components))
            .collect();
        assert_eq!(fields, [("position", 2), ("crack", 1), ("surface", 1)]);
    }

    let remote = tmp.path().join("remote");
    server.fetch(&id, &remote);
    for s in &snaps {
        let stored = SnapshotReader::open(
            &server
                .data
                .join("jobs")
                .join(&id)
                .join(format!("snapshot_{:04}.bin", s.index)),
        )
        .and_then(|mut r| r.read_all())
        .unwrap();
        assert_eq!(stored.lines.len(), 6);
        let fetched = remote.join(format!("cracks_{:04}.vtp", s.index));
        let want = tmp.path().join("want.vtp");
        cleave::output::write_lines_vtp(&want, &stored.lines).unwrap();
        assert!(
            std::fs::read(&fetched).unwrap() == std::fs::read(&want).unwrap(),
            "{} is not the job's stored lines",
            fetched.display()
        );
        // and the points themselves, where the file keeps them
        let bytes = std::fs::read(&fetched).unwrap();
        let xyz: Vec<[f64; 3]> = stored.lines.iter().flat_map(|l| l.points.clone()).collect();
        let raw: Vec<u8> = xyz
            .iter()
            .flat_map(|p| p.iter().flat_map(|x| x.to_le_bytes()))
            .collect();
        assert!(bytes.windows(raw.len()).any(|w| w == raw));
    }
    let local = run_embedded(&text, &tmp.path().join("local"));
    let files = names(&local);
    assert!(files.contains(&"cracks.pvd".to_string()), "{files:?}");
    assert!(files.contains(&"j_integral.png".to_string()), "{files:?}");
    same_files(&local, &remote);
}

/// A job without cracks lists no lines, refuses `LOCATION_LINES` as a
/// result it does not have, and fetches as before: the embedded run's
/// files, none of them about cracks.
#[test]
fn a_job_without_cracks_fetches_as_before() {
    let tmp = tempfile::tempdir().unwrap();
    let server = Server::start(&tmp.path().join("data"));
    let text = scene(false);
    let id = server.run_job(&text);
    let snaps = server.snapshots(&id);
    assert_eq!(snaps.len(), 5);
    assert!(snaps.iter().all(|s| s.lines.is_none()));

    let mut c = server.client();
    let asked = server
        .runtime
        .block_on(c.fetch_fields(proto::FetchFieldsRequest {
            job_id: id.clone(),
            location: proto::Location::Lines as i32,
            ..Default::default()
        }));
    let Err(e) = asked else {
        panic!("lines fetched from a job without cracks")
    };
    assert_eq!(e.code(), tonic::Code::FailedPrecondition, "{e:?}");
    assert!(e.message().contains("no lines"), "{}", e.message());

    let remote = tmp.path().join("remote");
    server.fetch(&id, &remote);
    let local = run_embedded(&text, &tmp.path().join("local"));
    same_files(&local, &remote);
    assert!(
        names(&remote)
            .iter()
            .all(|n| !n.starts_with("cracks") && !n.starts_with("j_integral")),
        "{:?}",
        names(&remote)
    );
}
