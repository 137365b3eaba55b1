//! End to end: a real `cleave-server` process on a free loopback port with a
//! temporary data directory, driven by the `cleave` client and by the gRPC
//! API directly.

use cleave::service::proto::{self, cleave_client::CleaveClient, job_event::Event};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};
use tonic_types::StatusExt;

mod common;
use common::{cleave_bin, Server};

fn same_files5(a: &Path, b: &Path) {
    common::same_files(a, b, 5)
}

fn scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("scenes")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A scene that runs for many seconds (a large block, long end time).
fn slow_scene() -> String {
    r#"
[grid]
cell_size = 0.005
max = [1.0, 1.0]
[time]
end = 10.0
cfl = 0.5
[[bodies]]
shape = { type = "box", min = [0.1, 0.1], max = [0.9, 0.9] }
material = { model = "linear_elastic", density = 1000.0, youngs_modulus = 1.0e6, poissons_ratio = 0.3 }
velocity_gradient = [[0.0, -0.5], [0.5, 0.0]]
[output]
series_rows = 1000
snapshots = 1000
"#
    .to_string()
}

/// `cleave run --quiet SCENE --out OUT`, embedded (no server); it must
/// succeed.
fn run_embedded(scene: &Path, out: &Path) {
    let o = Command::new(cleave_bin())
        .args(["run", "--quiet"])
        .arg(scene)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
}

async fn wait_state(
    client: &mut CleaveClient<tonic::transport::Channel>,
    id: &str,
    want: proto::JobState,
    within: Duration,
) -> proto::Job {
    let t0 = Instant::now();
    loop {
        let j = client
            .get_job(proto::GetJobRequest {
                job_id: id.into(),
                ..Default::default()
            })
            .await
            .unwrap()
            .into_inner();
        if j.state == want as i32 {
            return j;
        }
        assert!(
            t0.elapsed() < within,
            "{id} is {:?}, not {want:?}, after {within:?}",
            proto::JobState::try_from(j.state)
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

async fn wait_running_with_snapshot(
    client: &mut CleaveClient<tonic::transport::Channel>,
    id: &str,
) {
    wait_state(
        client,
        id,
        proto::JobState::Running,
        Duration::from_secs(30),
    )
    .await;
    let t0 = Instant::now();
    loop {
        let n = client
            .list_snapshots(proto::ListSnapshotsRequest { job_id: id.into() })
            .await
            .unwrap()
            .into_inner()
            .snapshots
            .len();
        if n >= 2 {
            return;
        }
        assert!(t0.elapsed() < Duration::from_secs(30), "no snapshots");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

#[test]
fn submit_watch_fetch_matches_an_embedded_run_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(&dir.path().join("data"), &[]);
    let scene = scenes().join("sliding_block.toml");
    let local = dir.path().join("local");
    run_embedded(&scene, &local);
    // submit, watch to completion, fetch
    let o = server.cli(&["submit", scene.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let id = stdout(&o).trim().to_string();
    assert!(id.starts_with("job-"), "{id}");
    let o = server.cli(&["watch", &id, "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let events: Vec<serde_json::Value> = stdout(&o)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(events.first().unwrap()["state"], "QUEUED");
    assert_eq!(events.last().unwrap()["state"], "SUCCEEDED");
    assert!(events.iter().any(|e| e["type"] == "progress"));
    assert!(events.iter().any(|e| e["type"] == "summary"));
    for (k, e) in events.iter().enumerate() {
        assert_eq!(e["sequence"], k as u64);
    }
    let remote = dir.path().join("remote");
    let o = server.cli(&["fetch", &id, "--out", remote.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    same_files5(&local, &remote);
    // `run --server` does all three and gives the same files too
    let remote2 = dir.path().join("remote2");
    let o = server.cli(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        remote2.to_str().unwrap(),
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["status"], "succeeded");
    assert_eq!(
        v["stages"],
        serde_json::json!([
            "field_partition",
            "p2g",
            "grid_update",
            "contact",
            "g2p",
            "rebin"
        ])
    );
    same_files5(&local, &remote2);
    // list and get
    let o = server.cli(&["list", "--json"]);
    let list: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(list.as_array().unwrap().len(), 2);
    let o = server.cli(&["list", "--state", "failed", "--json"]);
    assert_eq!(
        serde_json::from_str::<serde_json::Value>(stdout(&o).trim()).unwrap(),
        serde_json::json!([])
    );
}

/// A 3D job: the snapshots and the series fetched from a server are the
/// files an embedded run writes, bit for bit, and ListSnapshots says the
/// shapes a client needs to read them: dimension 3, positions and
/// velocities of 3 components, stresses of 6, a grid with nz nodes along z.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_3d_job_fetches_what_an_embedded_run_writes() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(&dir.path().join("data"), &[]);
    let scene = scenes().join("two_spheres_3d.toml");
    let local = dir.path().join("local");
    run_embedded(&scene, &local);
    let mut c = server.client().await;
    let v = c
        .validate_scene(proto::ValidateSceneRequest {
            scene: std::fs::read_to_string(&scene).unwrap(),
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    assert!(v.valid);
    assert_eq!((v.cells_x, v.cells_y, v.cells_z), (20, 20, 20));
    let job = c
        .submit_job(proto::SubmitJobRequest {
            scene: std::fs::read_to_string(&scene).unwrap(),
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    wait_state(
        &mut c,
        &job.id,
        proto::JobState::Succeeded,
        Duration::from_secs(120),
    )
    .await;
    let snaps = c
        .list_snapshots(proto::ListSnapshotsRequest {
            job_id: job.id.clone(),
        })
        .await
        .unwrap()
        .into_inner()
        .snapshots;
    assert_eq!(snaps.len(), 11);
    let s = &snaps[0];
    assert_eq!(s.dimension, 3);
    let comps = |name: &str| {
        s.particle_fields
            .iter()
            .find(|f| f.name == name)
            .map(|f| f.components)
    };
    assert_eq!(s.particle_fields[0].name, "position");
    assert_eq!(
        [comps("position"), comps("velocity"), comps("stress")],
        [Some(3), Some(3), Some(6)]
    );
    // the grid of the last snapshot (the first, at t = 0, has none yet)
    let last = snaps.last().unwrap();
    let g = last.grid.as_ref().unwrap();
    assert!(g.nz > 20 && g.nx == g.nz && g.ny == g.nz, "{g:?}");
    let mut chunks = c
        .fetch_fields(proto::FetchFieldsRequest {
            job_id: job.id.clone(),
            snapshot: last.index,
            location: proto::Location::Grid as i32,
            fields: vec!["mass".into()],
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    let first = chunks.message().await.unwrap().unwrap();
    assert_eq!(first.total, g.nx * g.ny * g.nz);
    let remote = dir.path().join("remote");
    let o = server.cli(&["fetch", &job.id, "--out", remote.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    same_files5(&local, &remote);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn errors_have_the_right_status_codes() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(&dir.path().join("data"), &[]);
    let mut c = server.client().await;
    let bad = std::fs::read_to_string(scenes().join("wave_bar.toml"))
        .unwrap()
        .replace("youngs_modulus = 2.0e11", "youngs_modulus = -3");
    let e = c
        .submit_job(proto::SubmitJobRequest {
            scene: bad.clone(),
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::InvalidArgument);
    assert!(
        e.message()
            .contains("materials.steel.youngs_modulus: must be > 0, got -3"),
        "{}",
        e.message()
    );
    // and for programs, the field in google.rpc.BadRequest
    let details = e.get_error_details();
    let violations = &details
        .bad_request()
        .expect("a BadRequest")
        .field_violations;
    assert!(
        violations
            .iter()
            .any(|v| v.field == "materials.steel.youngs_modulus"
                && v.description == "must be > 0, got -3"),
        "{violations:?}"
    );
    let v = c
        .validate_scene(proto::ValidateSceneRequest {
            scene: bad,
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    assert!(!v.valid);
    assert_eq!(v.errors[0].path, "materials.steel.youngs_modulus");
    let e = c
        .get_job(proto::GetJobRequest {
            job_id: "job-424242".into(),
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::NotFound);
    let e = c
        .watch_job(proto::WatchJobRequest {
            job_id: "nope".into(),
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::NotFound);
    let e = c
        .fetch_fields(proto::FetchFieldsRequest {
            job_id: "nope".into(),
            location: proto::Location::Particles as i32,
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::NotFound);
    // the CLI maps them to exit codes
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, "[grid]\ncell_size = -1\nmax = [1, 1]\n[time]\nend = 1\n[[bodies]]\nshape = { type = \"disk\", center = [0.5, 0.5], radius = 0.1 }\nmaterial = { model = \"linear_elastic\", density = 1.0, youngs_modulus = 1.0, poissons_ratio = 0.0 }\n").unwrap();
    let o = server.cli(&["submit", path.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("grid.cell_size: must be > 0"),
        "{}",
        stderr(&o)
    );
    let o = server.cli(&["get", "job-424242"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("not found"));
}

/// `list`, `get` and `cancel` as a person reads them: jobs of one scene
/// told apart by their times, an empty list said so, a cancel that shows
/// the state it led to, and one with nothing to cancel.
#[test]
fn list_get_and_cancel_say_what_a_person_needs() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(&dir.path().join("data"), &[]);
    let o = server.cli(&["list"]);
    assert_eq!(stdout(&o).trim(), "no jobs");
    let o = server.cli(&["list", "--state", "running"]);
    assert_eq!(stdout(&o).trim(), "no running jobs");
    let scene = scenes().join("two_disks.toml");
    let o = server.cli(&["submit", "--wait", scene.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let done = stdout(&o).lines().next().unwrap().trim().to_string();
    let slow = dir.path().join("slow.toml");
    std::fs::write(
        &slow,
        format!("[meta]\nname = \"slow_block\"\n{}", slow_scene()),
    )
    .unwrap();
    let o = server.cli(&["submit", slow.to_str().unwrap()]);
    let running = stdout(&o).trim().to_string();
    let o = server.cli(&["list"]);
    let text = stdout(&o);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 3, "{text}");
    assert!(lines[0].contains("scene") && lines[0].contains("submitted (UTC)"));
    assert!(
        lines[1].starts_with(&running) && lines[1].contains("slow_block"),
        "{text}"
    );
    assert!(
        lines[2].starts_with(&done) && lines[2].contains("two_disks"),
        "{text}"
    );
    // the submit, start and end times of the finished job
    let year = &remote_utc_year();
    assert_eq!(lines[2].matches(year.as_str()).count(), 3, "{text}");
    let o = server.cli(&["get", &done]);
    let text = stdout(&o);
    for want in [
        "state:      SUCCEEDED",
        "scene:      two_disks",
        "submitted:  ",
        "ended:      ",
    ] {
        assert!(text.contains(want), "{want:?} in {text}");
    }
    let o = server.cli(&["cancel", &running]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(stdout(&o).trim(), format!("{running}: CANCELLED"));
    let o = server.cli(&["cancel", &done]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("had already ended (SUCCEEDED); nothing to cancel"),
        "{}",
        stdout(&o)
    );
    // the server's address without a scheme is taken as http://
    let bare = server.url.trim_start_matches("http://").to_string();
    let o = Command::new(cleave_bin())
        .args(["get", &done, "--server", &bare])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
}

/// The current year as `list` prints it (UTC).
fn remote_utc_year() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_secs();
    // good to the day for any year this test will run in
    (1970 + (secs as f64 / (365.2425 * 86_400.0)) as u64).to_string()
}

/// Sends `body` (encoded as it is) to `path` of the server: a request the
/// generated client could not make.
async fn raw_call<M: prost::Message + Default + 'static>(
    url: &str,
    path: &'static str,
    body: M,
) -> tonic::Status {
    let channel = tonic::transport::Channel::from_shared(url.to_string())
        .unwrap()
        .connect()
        .await
        .unwrap();
    let mut grpc = tonic::client::Grpc::new(channel);
    grpc.ready().await.unwrap();
    let codec = tonic_prost::ProstCodec::<M, proto::Job>::default();
    grpc.unary(
        tonic::Request::new(body),
        tonic::codegen::http::uri::PathAndQuery::from_static(path),
        codec,
    )
    .await
    .unwrap_err()
}

/// The API's conventions (issue 29) and its answers to hostile requests
/// (issue 30): malformed and oversized messages, unknown enum values, long
/// ids, repeated field names, the scene text only on request, the latest
/// snapshot without listing, comments through reflection.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hostile_requests_get_the_promised_status_and_bounded_answers() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(&dir.path().join("data"), &["--max-request-bytes", "65536"]);
    let mut c = server.client().await;
    let scene = std::fs::read_to_string(scenes().join("two_disks.toml")).unwrap();
    // a message that does not decode as the method's request: GetJob's
    // job_id is a string, here field 1 is a varint
    let e = raw_call(
        &server.url,
        "/cleave.v1.Cleave/GetJob",
        proto::ListJobsRequest {
            page_size: 7,
            ..Default::default()
        },
    )
    .await;
    assert_eq!(e.code(), tonic::Code::InvalidArgument, "{e:?}");
    // over --max-request-bytes
    let e = c
        .validate_scene(proto::ValidateSceneRequest {
            scene: "#".repeat(100_000),
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::ResourceExhausted, "{e:?}");
    // unknown enum values name their field
    for (e, field) in [
        (
            c.submit_job(proto::SubmitJobRequest {
                scene: scene.clone(),
                format: 99,
                ..Default::default()
            })
            .await
            .unwrap_err(),
            "format",
        ),
        (
            c.validate_scene(proto::ValidateSceneRequest {
                scene: scene.clone(),
                format: -1,
            })
            .await
            .unwrap_err(),
            "format",
        ),
        (
            c.list_jobs(proto::ListJobsRequest {
                state: 17,
                ..Default::default()
            })
            .await
            .unwrap_err(),
            "state",
        ),
        (
            c.list_jobs(proto::ListJobsRequest {
                view: 3,
                ..Default::default()
            })
            .await
            .unwrap_err(),
            "view",
        ),
    ] {
        assert_eq!(e.code(), tonic::Code::InvalidArgument, "{e:?}");
        assert!(e.message().starts_with(&format!("{field}: ")), "{e:?}");
        let details = e.get_error_details();
        let v = &details
            .bad_request()
            .expect("a BadRequest")
            .field_violations;
        assert!(v.len() == 1 && v[0].field == field, "{v:?}");
    }
    // ValidateScene gives the memory estimate and the time step
    let v = c
        .validate_scene(proto::ValidateSceneRequest {
            scene: scene.clone(),
            format: proto::SceneFormat::Toml as i32,
        })
        .await
        .unwrap()
        .into_inner();
    assert!(v.valid && v.memory_bytes > 1 << 20 && v.memory.contains("particles"));
    assert!(v.time_step > 0.0 && v.steps > 100.0, "{v:?}");
    // a server's --max-memory refuses a scene whose estimate is over it
    let small = Server::start(&dir.path().join("small"), &["--max-memory", "1000000"]);
    let e = small
        .client()
        .await
        .submit_job(proto::SubmitJobRequest {
            scene: scene.clone(),
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::InvalidArgument, "{e:?}");
    assert!(e.message().contains("--max-memory"), "{}", e.message());
    drop(small);
    // nothing was queued by those
    assert!(c
        .list_jobs(proto::ListJobsRequest::default())
        .await
        .unwrap()
        .into_inner()
        .jobs
        .is_empty());
    // a job id far longer than any is refused without being echoed
    let e = c
        .get_job(proto::GetJobRequest {
            job_id: "x".repeat(10_000),
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::InvalidArgument);
    assert!(e.message().len() < 200, "{}", e.message().len());
    // a finished job: ListJobs leaves its scene out unless asked
    let id = c
        .submit_job(proto::SubmitJobRequest {
            scene: scene.clone(),
            format: proto::SceneFormat::Toml as i32,
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner()
        .id;
    wait_state(
        &mut c,
        &id,
        proto::JobState::Succeeded,
        Duration::from_secs(60),
    )
    .await;
    let basic = c
        .list_jobs(proto::ListJobsRequest::default())
        .await
        .unwrap()
        .into_inner()
        .jobs;
    assert_eq!(basic.len(), 1);
    assert_eq!(basic[0].scene, "");
    assert_eq!(basic[0].scene_name, "two_disks");
    let full = c
        .list_jobs(proto::ListJobsRequest {
            view: proto::JobView::Full as i32,
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner()
        .jobs;
    assert_eq!(full[0].scene, scene);
    let got = c
        .get_job(proto::GetJobRequest {
            job_id: id.clone(),
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(got.scene, scene, "GetJob's default view is FULL");
    // FetchFields: a location is required; the latest snapshot without
    // listing; a name repeated is sent once
    let e = c
        .fetch_fields(proto::FetchFieldsRequest {
            job_id: id.clone(),
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::InvalidArgument);
    assert!(e.message().starts_with("location: "), "{e:?}");
    let e = c
        .fetch_fields(proto::FetchFieldsRequest {
            job_id: id.clone(),
            location: 7,
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert!(e.message().starts_with("location: "), "{e:?}");
    let snapshots = c
        .list_snapshots(proto::ListSnapshotsRequest { job_id: id.clone() })
        .await
        .unwrap()
        .into_inner()
        .snapshots;
    assert!(snapshots.len() > 2);
    let mut stream = c
        .fetch_fields(proto::FetchFieldsRequest {
            job_id: id.clone(),
            location: proto::Location::Particles as i32,
            latest: true,
            fields: vec!["mass".to_string(); 10_000],
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    let mut chunks = Vec::new();
    while let Some(ch) = stream.message().await.unwrap() {
        chunks.push(ch);
    }
    let info = chunks[0].snapshot.clone().unwrap();
    assert_eq!(info.index, snapshots.last().unwrap().index);
    let bytes: usize = chunks.iter().map(|c| c.data.len()).sum();
    assert!(chunks.iter().all(|c| c.field == "mass"));
    assert_eq!(bytes, 8 * info.particles as usize, "mass is sent once");
    // the proto's comments come through reflection (no .proto needed)
    use prost::Message;
    use tonic_reflection::pb::v1::{
        server_reflection_client::ServerReflectionClient,
        server_reflection_request::MessageRequest, server_reflection_response::MessageResponse,
        ServerReflectionRequest,
    };
    let channel = tonic::transport::Channel::from_shared(server.url.clone())
        .unwrap()
        .connect()
        .await
        .unwrap();
    let mut refl = ServerReflectionClient::new(channel);
    let ask = ServerReflectionRequest {
        host: String::new(),
        message_request: Some(MessageRequest::FileContainingSymbol(
            "cleave.v1.Cleave".into(),
        )),
    };
    let mut answers = refl
        .server_reflection_info(tokio_stream::iter(vec![ask]))
        .await
        .unwrap()
        .into_inner();
    let Some(MessageResponse::FileDescriptorResponse(files)) =
        answers.message().await.unwrap().unwrap().message_response
    else {
        panic!("no file descriptor")
    };
    let comments: Vec<String> = files
        .file_descriptor_proto
        .iter()
        .map(|b| prost_types::FileDescriptorProto::decode(b.as_slice()).unwrap())
        .filter_map(|f| f.source_code_info)
        .flat_map(|i| i.location)
        .filter_map(|l| l.leading_comments)
        .collect();
    assert!(
        comments
            .iter()
            .any(|c| c.contains("Validates and queues a scene")),
        "{comments:?}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn token_is_required_except_for_health() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(&dir.path().join("data"), &["--token", "s3cret"]);
    let mut c = server.client().await;
    let e = c
        .list_jobs(proto::ListJobsRequest::default())
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::Unauthenticated);
    let mut req = tonic::Request::new(proto::ListJobsRequest::default());
    req.metadata_mut()
        .insert("authorization", "Bearer wrong".parse().unwrap());
    assert_eq!(
        c.list_jobs(req).await.unwrap_err().code(),
        tonic::Code::Unauthenticated
    );
    let mut req = tonic::Request::new(proto::ListJobsRequest::default());
    req.metadata_mut()
        .insert("authorization", "Bearer s3cret".parse().unwrap());
    assert!(c.list_jobs(req).await.is_ok());
    // health needs no token and says SERVING
    let channel = tonic::transport::Channel::from_shared(server.url.clone())
        .unwrap()
        .connect()
        .await
        .unwrap();
    let mut health = tonic_health::pb::health_client::HealthClient::new(channel);
    let r = health
        .check(tonic_health::pb::HealthCheckRequest {
            service: "cleave.v1.Cleave".into(),
        })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(
        r.status,
        tonic_health::pb::health_check_response::ServingStatus::Serving as i32
    );
    // reflection (what grpcurl uses) lists every service, with the token
    use tonic_reflection::pb::v1::{
        server_reflection_client::ServerReflectionClient,
        server_reflection_request::MessageRequest, server_reflection_response::MessageResponse,
        ServerReflectionRequest,
    };
    let channel = tonic::transport::Channel::from_shared(server.url.clone())
        .unwrap()
        .connect()
        .await
        .unwrap();
    let token: tonic::metadata::MetadataValue<_> = "Bearer s3cret".parse().unwrap();
    let mut refl =
        ServerReflectionClient::with_interceptor(channel, move |mut r: tonic::Request<()>| {
            r.metadata_mut().insert("authorization", token.clone());
            Ok(r)
        });
    let ask = ServerReflectionRequest {
        host: String::new(),
        message_request: Some(MessageRequest::ListServices(String::new())),
    };
    let mut answers = refl
        .server_reflection_info(tokio_stream::iter(vec![ask]))
        .await
        .unwrap()
        .into_inner();
    let Some(MessageResponse::ListServicesResponse(list)) =
        answers.message().await.unwrap().unwrap().message_response
    else {
        panic!("no service list")
    };
    let names: Vec<_> = list.service.iter().map(|s| s.name.as_str()).collect();
    for want in ["cleave.v1.Cleave", "grpc.health.v1.Health"] {
        assert!(names.contains(&want), "reflection lists {names:?}");
    }
    // the CLI: exit 3 without or with a wrong token, 0 with the right one
    let o = server.cli(&["list"]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains("unauthenticated"));
    assert_eq!(
        server.cli(&["--token", "wrong", "list"]).status.code(),
        Some(3)
    );
    assert_eq!(
        server.cli(&["--token", "s3cret", "list"]).status.code(),
        Some(0)
    );
    // an unreachable server is exit 3 too
    let o = Command::new(cleave_bin())
        .args(["--server", "http://127.0.0.1:9", "list"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(3));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn cancel_takes_effect_within_a_second_and_writes_nothing_more() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(&dir.path().join("data"), &[]);
    let mut c = server.client().await;
    let job = c
        .submit_job(proto::SubmitJobRequest {
            scene: slow_scene(),
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    wait_running_with_snapshot(&mut c, &job.id).await;
    let t0 = Instant::now();
    c.cancel_job(proto::CancelJobRequest {
        job_id: job.id.clone(),
    })
    .await
    .unwrap();
    let done = wait_state(
        &mut c,
        &job.id,
        proto::JobState::Cancelled,
        Duration::from_secs(1),
    )
    .await;
    assert!(t0.elapsed() < Duration::from_secs(1));
    assert!(done.error.contains("cancelled"));
    let jobdir = server.data.join("jobs").join(&job.id);
    let count = || {
        std::fs::read_dir(&jobdir)
            .unwrap()
            .filter(|e| {
                e.as_ref()
                    .unwrap()
                    .file_name()
                    .to_string_lossy()
                    .starts_with("snapshot_")
            })
            .count()
    };
    let n = count();
    tokio::time::sleep(Duration::from_millis(500)).await;
    assert_eq!(count(), n, "snapshots written after cancellation");
    // a queued job is cancelled at once
    let a = c
        .submit_job(proto::SubmitJobRequest {
            scene: slow_scene(),
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    let b = c
        .submit_job(proto::SubmitJobRequest {
            scene: slow_scene(),
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    let b = c
        .cancel_job(proto::CancelJobRequest {
            job_id: b.id.clone(),
        })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(b.state, proto::JobState::Cancelled as i32);
    c.cancel_job(proto::CancelJobRequest {
        job_id: a.id.clone(),
    })
    .await
    .unwrap();
    wait_state(
        &mut c,
        &a.id,
        proto::JobState::Cancelled,
        Duration::from_secs(5),
    )
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_killed_server_keeps_finished_jobs_and_fails_the_interrupted_one() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let mut server = Server::start(&data, &[]);
    let scene = scenes().join("two_disks.toml");
    let o = server.cli(&["submit", "--wait", scene.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let done = stdout(&o).lines().next().unwrap().trim().to_string();
    let before = dir.path().join("before");
    assert!(server
        .cli(&["fetch", &done, "--out", before.to_str().unwrap()])
        .status
        .success());
    let mut c = server.client().await;
    let slow = c
        .submit_job(proto::SubmitJobRequest {
            scene: slow_scene(),
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    wait_running_with_snapshot(&mut c, &slow.id).await;
    // a watcher of the running job when its server dies: exit 3 (the
    // connection), not 1 (the job), and how to pick the job up again
    let watcher = Command::new(cleave_bin())
        .args(["watch", &slow.id, "--server", &server.url])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    tokio::time::sleep(Duration::from_millis(500)).await;
    server.kill(); // SIGKILL in the middle of the run
    let o = watcher.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("lost the connection to the server")
            && stderr(&o).contains(&format!("cleave watch {}", slow.id))
            && !stderr(&o).starts_with("error: error"),
        "{}",
        stderr(&o)
    );
    let server = Server::start(&data, &[]);
    let mut c = server.client().await;
    let j = c
        .get_job(proto::GetJobRequest {
            job_id: slow.id.clone(),
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(j.state, proto::JobState::Failed as i32);
    assert!(j.error.contains("server stopped"), "{}", j.error);
    let j = c
        .get_job(proto::GetJobRequest {
            job_id: done.clone(),
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(j.state, proto::JobState::Succeeded as i32);
    let after = dir.path().join("after");
    assert!(server
        .cli(&["fetch", &done, "--out", after.to_str().unwrap()])
        .status
        .success());
    same_files5(&before, &after);
    // watching a finished job of the earlier server replays its end
    let o = server.cli(&["watch", &done, "--json"]);
    assert!(o.status.success());
    assert!(stdout(&o).lines().last().unwrap().contains("SUCCEEDED"));
}

/// Waits until the job has saved a checkpoint newer than `after`.
async fn wait_checkpoint(server: &Server, id: &str, after: Option<std::time::SystemTime>) {
    let path = server.data.join("jobs").join(id).join("checkpoint.bin");
    let t0 = Instant::now();
    loop {
        let modified = std::fs::metadata(&path).and_then(|m| m.modified()).ok();
        if modified.is_some_and(|m| after.is_none_or(|a| m > a)) {
            return;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "no checkpoint of {id}"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_job_resumes_from_its_checkpoint_after_a_kill_and_a_shutdown_with_the_same_results() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    let text = slow_scene()
        .replace("end = 10.0", "end = 0.03")
        .replace("series_rows = 1000", "series_rows = 40")
        .replace("snapshots = 1000", "snapshots = 4");
    let scene = dir.path().join("spin.toml");
    std::fs::write(&scene, &text).unwrap();
    let local = dir.path().join("local");
    run_embedded(&scene, &local);

    let flags = ["--checkpoint-every", "0.2"];
    let mut server = Server::start(&data, &flags);
    let mut c = server.client().await;
    let job = c
        .submit_job(proto::SubmitJobRequest {
            scene: text.clone(),
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    wait_state(
        &mut c,
        &job.id,
        proto::JobState::Running,
        Duration::from_secs(30),
    )
    .await;
    wait_checkpoint(&server, &job.id, None).await;
    server.kill(); // SIGKILL in the middle of the run, after a checkpoint
    let first = std::fs::metadata(
        server
            .data
            .join("jobs")
            .join(&job.id)
            .join("checkpoint.bin"),
    )
    .unwrap()
    .modified()
    .unwrap();

    // the next server resumes it; then a graceful stop (SIGTERM) checkpoints it
    let mut server = Server::start(&data, &flags);
    let mut c = server.client().await;
    wait_state(
        &mut c,
        &job.id,
        proto::JobState::Running,
        Duration::from_secs(30),
    )
    .await;
    wait_checkpoint(&server, &job.id, Some(first)).await;
    let j = c
        .get_job(proto::GetJobRequest {
            job_id: job.id.clone(),
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    assert_eq!(
        j.state,
        proto::JobState::Running as i32,
        "the job ended before the shutdown: make the scene longer"
    );
    let term = Command::new("kill")
        .arg("-TERM")
        .arg(server.child.id().to_string())
        .status()
        .unwrap();
    assert!(term.success());
    let status = server.child.wait().unwrap();
    assert!(
        status.success(),
        "the server did not stop cleanly: {status:?}"
    );

    let server = Server::start(&data, &flags);
    let mut c = server.client().await;
    let j = wait_state(
        &mut c,
        &job.id,
        proto::JobState::Succeeded,
        Duration::from_secs(120),
    )
    .await;
    assert!(j.error.is_empty(), "{}", j.error);
    assert!(
        !server
            .data
            .join("jobs")
            .join(&job.id)
            .join("checkpoint.bin")
            .exists(),
        "the finished job's checkpoint is left"
    );
    let remote = dir.path().join("remote");
    let o = server.cli(&["fetch", &job.id, "--out", remote.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    same_files5(&local, &remote);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_blow_up_fails_with_a_diagnosis_while_another_job_finishes() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(&dir.path().join("data"), &["--max-concurrent-jobs", "2"]);
    let mut c = server.client().await;
    // fixed dt far beyond the CFL limit of the moving block
    let bad = slow_scene().replace("cfl = 0.5", "dt = 1.0e-2");
    let bad = c
        .submit_job(proto::SubmitJobRequest {
            scene: bad,
            label: "bad".into(),
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    let good = std::fs::read_to_string(scenes().join("wave_bar.toml")).unwrap();
    let good = c
        .submit_job(proto::SubmitJobRequest {
            scene: good,
            label: "good".into(),
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    let b = wait_state(
        &mut c,
        &bad.id,
        proto::JobState::Failed,
        Duration::from_secs(30),
    )
    .await;
    assert!(b.error.contains("CFL"), "{}", b.error);
    wait_state(
        &mut c,
        &good.id,
        proto::JobState::Succeeded,
        Duration::from_secs(60),
    )
    .await;
    // and a scene that asks too much is refused up front
    let huge = slow_scene().replace("cell_size = 0.005", "cell_size = 0.0005");
    let server2 = Server::start(&dir.path().join("data2"), &["--max-particles", "1000"]);
    let mut c2 = server2.client().await;
    let e = c2
        .submit_job(proto::SubmitJobRequest {
            scene: huge,
            ..Default::default()
        })
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::ResourceExhausted);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn thirty_two_watchers_see_the_complete_ordered_stream() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(&dir.path().join("data"), &[]);
    let mut c = server.client().await;
    let scene = std::fs::read_to_string(scenes().join("two_disks.toml")).unwrap();
    let job = c
        .submit_job(proto::SubmitJobRequest {
            scene,
            ..Default::default()
        })
        .await
        .unwrap()
        .into_inner();
    let mut tasks = Vec::new();
    for _ in 0..32 {
        let url = server.url.clone();
        let id = job.id.clone();
        tasks.push(tokio::spawn(async move {
            let mut c = CleaveClient::connect(url).await.unwrap();
            let mut s = c
                .watch_job(proto::WatchJobRequest { job_id: id })
                .await
                .unwrap()
                .into_inner();
            let mut events = Vec::new();
            while let Some(e) = s.message().await.unwrap() {
                events.push(e);
            }
            events
        }));
    }
    let mut streams = Vec::new();
    for t in tasks {
        streams.push(t.await.unwrap());
    }
    let first = &streams[0];
    assert!(first.len() >= 5, "too few events: {}", first.len());
    for (k, e) in first.iter().enumerate() {
        assert_eq!(e.sequence, k as u64);
    }
    assert!(
        matches!(&first[0].event, Some(Event::State(s)) if s.state == proto::JobState::Queued as i32)
    );
    assert!(
        matches!(&first.last().unwrap().event, Some(Event::State(s)) if s.state == proto::JobState::Succeeded as i32)
    );
    for s in &streams {
        assert_eq!(s, first, "a watcher saw a different stream");
    }
}

#[test]
fn tls_with_a_self_signed_certificate() {
    let dir = tempfile::tempdir().unwrap();
    let cert = rcgen::generate_simple_self_signed(vec!["localhost".to_string()]).unwrap();
    let (crt, key) = (dir.path().join("server.crt"), dir.path().join("server.key"));
    std::fs::write(&crt, cert.cert.pem()).unwrap();
    std::fs::write(&key, cert.signing_key.serialize_pem()).unwrap();
    let server = Server::start(
        &dir.path().join("data"),
        &[
            "--tls-cert",
            crt.to_str().unwrap(),
            "--tls-key",
            key.to_str().unwrap(),
        ],
    );
    let https = server.url.replace("http://127.0.0.1", "https://localhost");
    let run = |extra: &[&str]| {
        Command::new(cleave_bin())
            .args(["--server", &https])
            .args(extra)
            .args(["validate"])
            .arg(scenes().join("wave_bar.toml"))
            .output()
            .unwrap()
    };
    let o = run(&["--ca-cert", crt.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("valid"));
    // without trusting the certificate the client cannot connect (exit 3)
    let o = run(&[]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
}

/// `cleave study --server`: the variants run as jobs on the server and the
/// study's metrics are the ones of the same study in this process (the
/// wall times differ: the server's jobs share its cores). `--resume`
/// submits no job again: not for a finished run, nor for one whose job
/// the server still has.
#[test]
fn a_study_against_a_server_measures_what_an_embedded_one_does() {
    let dir = tempfile::tempdir().unwrap();
    let server = Server::start(&dir.path().join("data"), &["--max-concurrent-jobs", "2"]);
    let scene = std::fs::read_to_string(scenes().join("wave_bar.toml"))
        .unwrap()
        .replace("cell_size = 0.005", "cell_size = 0.01")
        .replace("end = 2.5e-4", "end = 5.0e-5");
    let path = dir.path().join("bar.toml");
    std::fs::write(&path, scene).unwrap();
    let metrics = common::study_metrics;
    let (a, b, remote_args) = common::study_here_and_on(
        &server,
        &path,
        "time.cfl=0.2,0.5",
        "final:momentum_x",
        dir.path(),
    );
    assert_eq!(a.len(), 2);
    assert!(a.iter().all(|m| m.0.is_f64()), "{a:?}");
    assert_eq!(a, b);
    let jobs = || -> Vec<serde_json::Value> {
        let o = server.cli(&["list", "--json"]);
        serde_json::from_str::<serde_json::Value>(stdout(&o).trim())
            .unwrap()
            .as_array()
            .unwrap()
            .clone()
    };
    assert_eq!(jobs().len(), 2);

    // --resume keeps the finished runs and submits nothing
    let mut resume: Vec<&str> = remote_args.iter().map(String::as_str).collect();
    resume.push("--resume");
    assert_eq!(metrics(&server.cli(&resume)), b);
    assert_eq!(jobs().len(), 2);
    // a run whose job the earlier study submitted but did not see end is
    // followed, not submitted again
    let run1 = dir.path().join("remote").join("runs").join("001");
    std::fs::remove_file(run1.join("outcome.json")).unwrap();
    let id = jobs()
        .iter()
        .find(|j| j["label"].as_str().unwrap().starts_with("study 001"))
        .unwrap()["id"]
        .as_str()
        .unwrap()
        .to_string();
    std::fs::write(run1.join("job"), &id).unwrap();
    let o = server.cli(&resume);
    assert!(
        stderr(&o).contains(&format!("following job {id}")),
        "{}",
        stderr(&o)
    );
    assert_eq!(metrics(&o), b);
    assert_eq!(jobs().len(), 2);
    assert!(!run1.join("job").exists());
    // --checkpoint-every is for runs in this process
    let mut ck = resume.clone();
    ck.extend(["--checkpoint-every", "10"]);
    assert_eq!(server.cli(&ck).status.code(), Some(2));
}
