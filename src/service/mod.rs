//! The gRPC service: proto ↔ domain conversions and thin handlers that call
//! [`crate::jobs::JobManager`]. Entry point: [`serve`].

pub mod proto;

use crate::jobs::{self, JobError, JobEvent, JobManager, JobState};
use crate::scene::{FieldError, Format, SceneError};
use proto::cleave_server::{Cleave, CleaveServer};
use std::net::SocketAddr;
use std::path::PathBuf;
use std::pin::Pin;
use tokio_stream::Stream;
use tonic::{Code, Request, Response, Status};
use tonic_types::{ErrorDetails, FieldViolation, StatusExt};

/// Bytes of field data per FetchFields chunk.
pub const CHUNK_BYTES: usize = 1 << 20;

/// Everything `cleave-server` is configured with.
#[derive(Debug, Clone)]
pub struct ServerConfig {
    pub listen: SocketAddr,
    pub jobs: jobs::JobConfig,
    /// Bearer token required on every RPC but health.
    pub token: Option<String>,
    pub max_request_bytes: usize,
    /// PEM certificate chain and key for TLS.
    pub tls: Option<(PathBuf, PathBuf)>,
}

fn status(e: JobError) -> Status {
    match e {
        JobError::Invalid(e) => invalid(&e),
        JobError::NotFound(m) => Status::not_found(m),
        JobError::Precondition(m) => Status::failed_precondition(m),
        JobError::Exhausted(m) => Status::resource_exhausted(m),
        JobError::Store(m) => Status::internal(m),
        JobError::Unavailable(m) => Status::unavailable(m),
        JobError::Fenced(m) => Status::aborted(m),
    }
}

/// Bytes of a scene's problems a refusal carries, in its message and
/// again in its details. Both travel in the trailing metadata, encoded
/// (the message percent-encoded, the details in base64: together about
/// 3.5 times these bytes), and gRPC clients cap that at 8 KiB (grpc's
/// soft limit; 16 KiB hard): over the cap a refusal reaches them as
/// RESOURCE_EXHAUSTED instead of INVALID_ARGUMENT (3 000 bad bodies did).
/// `ValidateScene` lists every problem in its reply's body.
const REFUSAL_BYTES: usize = 1536;

/// The longest path or reason a refusal quotes (a reason may echo the
/// scene).
const REASON_BYTES: usize = 512;

fn invalid(e: &SceneError) -> Status {
    let clip = |s: &str| -> String {
        if s.len() <= REASON_BYTES {
            return s.to_string();
        }
        let mut end = REASON_BYTES;
        while !s.is_char_boundary(end) {
            end -= 1;
        }
        format!("{}…", &s[..end])
    };
    let (mut shown, mut bytes) = (Vec::<FieldError>::new(), 0);
    for f in &e.errors {
        let f = FieldError {
            path: clip(&f.path),
            reason: clip(&f.reason),
        };
        let n = f.path.len() + f.reason.len() + 3;
        if !shown.is_empty() && bytes + n > REFUSAL_BYTES {
            break;
        }
        bytes += n;
        shown.push(f);
    }
    // each line `path: reason` (or the reason alone), `FieldError`'s Display
    let mut message: Vec<String> = shown.iter().map(ToString::to_string).collect();
    let rest = e.errors.len() - shown.len();
    if rest > 0 {
        message.push(format!(
            "… and {rest} more problems (ValidateScene lists every one)"
        ));
    }
    let shown = shown
        .into_iter()
        .map(|f| FieldViolation::new(f.path, f.reason))
        .collect();
    bad_request(format!("invalid scene: {}", message.join("\n")), shown)
}

/// INVALID_ARGUMENT for people and for programs: the message, and a
/// `google.rpc.BadRequest` in the status details (`grpc-status-details-bin`)
/// with one violation per bad field. A scene's violations carry the path
/// into the scene (`bodies[1].material.density`, as `ValidateScene`'s
/// `FieldError.path`); a request's, the request's field (`job_id`).
fn bad_request(message: String, violations: Vec<FieldViolation>) -> Status {
    Status::with_error_details(
        Code::InvalidArgument,
        message,
        ErrorDetails::with_bad_request(violations),
    )
}

/// A request field that cannot be served: `FIELD: REASON`, with its
/// violation.
fn bad_field(field: &str, reason: String) -> Status {
    bad_request(
        format!("{field}: {reason}"),
        vec![FieldViolation::new(field, reason)],
    )
}

/// The longest job id the server ever makes (`job-000001` is 10); a longer
/// one is refused without being echoed, so that an error stays small.
pub const MAX_JOB_ID: usize = 64;

/// A request's job id, checked to be one the server could have made.
fn job_id(id: String) -> Result<String, Status> {
    if id.is_empty() {
        return Err(bad_field(
            "job_id",
            "required (ids look like job-000001)".into(),
        ));
    }
    if id.len() > MAX_JOB_ID
        || !id
            .bytes()
            .all(|b| b.is_ascii_alphanumeric() || b == b'-' || b == b'_')
    {
        return Err(bad_field(
            "job_id",
            format!(
                "not a job id ({} bytes; ids look like job-000001, at most {MAX_JOB_ID} letters, digits, '-' or '_')",
                id.len()
            ),
        ));
    }
    Ok(id)
}

/// An enum field's value that this server does not know.
fn unknown_enum(field: &str, value: i32, names: &[&str]) -> Status {
    bad_field(
        field,
        format!("unknown value {value} (one of {})", names.join(", ")),
    )
}

fn format(f: i32) -> Result<Option<Format>, Status> {
    match proto::SceneFormat::try_from(f) {
        Ok(proto::SceneFormat::Unspecified) => Ok(None),
        Ok(proto::SceneFormat::Toml) => Ok(Some(Format::Toml)),
        Ok(proto::SceneFormat::Json) => Ok(Some(Format::Json)),
        Err(_) => Err(unknown_enum(
            "format",
            f,
            &[
                "SCENE_FORMAT_UNSPECIFIED",
                "SCENE_FORMAT_TOML",
                "SCENE_FORMAT_JSON",
            ],
        )),
    }
}

/// Whether a request's `view` asks for the scene text; `full_by_default`
/// is the method's default for JOB_VIEW_UNSPECIFIED.
fn full_view(v: i32, full_by_default: bool) -> Result<bool, Status> {
    match proto::JobView::try_from(v) {
        Ok(proto::JobView::Unspecified) => Ok(full_by_default),
        Ok(proto::JobView::Basic) => Ok(false),
        Ok(proto::JobView::Full) => Ok(true),
        Err(_) => Err(unknown_enum(
            "view",
            v,
            &["JOB_VIEW_UNSPECIFIED", "JOB_VIEW_BASIC", "JOB_VIEW_FULL"],
        )),
    }
}

/// The domain's state of a proto state (None for UNSPECIFIED): the proto
/// names are the domain's with the enum's prefix.
fn state_from_proto(s: proto::JobState) -> Option<JobState> {
    s.as_str_name()
        .strip_prefix("JOB_STATE_")
        .and_then(JobState::parse)
}

pub fn state_to_proto(s: JobState) -> proto::JobState {
    match s {
        JobState::Queued => proto::JobState::Queued,
        JobState::Running => proto::JobState::Running,
        JobState::Succeeded => proto::JobState::Succeeded,
        JobState::Failed => proto::JobState::Failed,
        JobState::Cancelled => proto::JobState::Cancelled,
    }
}

fn progress_to_proto(p: &jobs::JobProgress) -> proto::Progress {
    proto::Progress {
        step: p.step,
        time: p.time,
        end_time: p.end_time,
        fraction: p.fraction,
        eta_seconds: p.eta_seconds,
        kinetic_energy: p.kinetic_energy,
        strain_energy: p.strain_energy,
        wall_seconds: p.wall_seconds,
    }
}

fn summary_to_proto(s: &jobs::JobSummary) -> proto::Summary {
    proto::Summary {
        steps: s.steps,
        time: s.time,
        wall_seconds: s.wall_seconds,
        kinetic_energy: s.kinetic_energy,
        strain_energy: s.strain_energy,
        external_work: s.external_work,
        energy_error: s.energy_error,
        snapshots: s.snapshots,
        series_rows: s.series_rows,
    }
}

/// A job as the API shows it; the scene text only when `with_scene`.
fn job_to_proto(r: jobs::JobRecord, with_scene: bool) -> proto::Job {
    proto::Job {
        id: r.id,
        label: r.label,
        state: state_to_proto(r.state) as i32,
        created_at: r.created_at,
        started_at: r.started_at.unwrap_or(0.0),
        finished_at: r.finished_at.unwrap_or(0.0),
        error: r.error.unwrap_or_default(),
        particles: r.particles,
        stages: r.stages,
        progress: r.progress.as_ref().map(progress_to_proto),
        summary: r.summary.as_ref().map(summary_to_proto),
        scene: if with_scene { r.scene } else { String::new() },
        scene_name: r.scene_name,
        worker: r.worker,
    }
}

fn event_to_proto(sequence: u64, e: &JobEvent) -> proto::JobEvent {
    use proto::job_event::Event;
    let event = match e {
        JobEvent::State { state, error } => Event::State(proto::StateChange {
            state: state_to_proto(*state) as i32,
            error: error.clone().unwrap_or_default(),
        }),
        JobEvent::Progress(p) => Event::Progress(progress_to_proto(p)),
        JobEvent::Summary(s) => Event::Summary(summary_to_proto(s)),
    };
    proto::JobEvent {
        sequence,
        event: Some(event),
    }
}

fn dtype_to_proto(d: jobs::snapfile::Dtype) -> proto::DataType {
    match d {
        jobs::snapfile::Dtype::F64 => proto::DataType::Float64,
        jobs::snapfile::Dtype::U32 => proto::DataType::Uint32,
    }
}

fn field_info(a: &jobs::snapfile::ArrayInfo) -> proto::FieldInfo {
    proto::FieldInfo {
        name: a.name.clone(),
        dtype: dtype_to_proto(a.dtype) as i32,
        components: a.components as u32,
    }
}

fn snapshot_to_proto(h: &jobs::SnapshotHeader) -> proto::SnapshotInfo {
    proto::SnapshotInfo {
        index: h.index,
        step: h.step,
        time: h.time,
        particles: h.particles as u64,
        particle_fields: h.fields.iter().map(field_info).collect(),
        grid: h.grid.as_ref().map(|g| {
            let ([x, y, z], [nx, ny, nz]) = (g.origin3(), g.dims3());
            proto::GridInfo {
                origin_x: x,
                origin_y: y,
                origin_z: z,
                spacing: g.spacing,
                nx: nx as u64,
                ny: ny as u64,
                nz: nz as u64,
                fields: g.fields.iter().map(field_info).collect(),
            }
        }),
        dimension: h.dimension() as u32,
        // only for snapshots that have lines, so that a scene without
        // explicit cracks answers what it always did
        lines: h.lines.as_ref().map(|l| proto::LinesInfo {
            counts: l.counts.iter().map(|&n| n as u64).collect(),
            fields: std::iter::once(&l.points)
                .chain(&l.values)
                .map(field_info)
                .collect(),
        }),
    }
}

/// How often health reflects whether the job store answers.
const HEALTH_EVERY: std::time::Duration = std::time::Duration::from_millis(250);

/// Runs a blocking job-manager call off the async runtime.
async fn blocking<T: Send + 'static>(
    f: impl FnOnce() -> Result<T, JobError> + Send + 'static,
) -> Result<T, Status> {
    tokio::task::spawn_blocking(f)
        .await
        .map_err(|e| Status::internal(format!("worker: {e}")))?
        .map_err(status)
}

/// The `cleave.v1.Cleave` service.
pub struct CleaveService {
    jobs: JobManager,
}

type EventStream = Pin<Box<dyn Stream<Item = Result<proto::JobEvent, Status>> + Send>>;
type ChunkStream = Pin<Box<dyn Stream<Item = Result<proto::FieldChunk, Status>> + Send>>;

#[tonic::async_trait]
impl Cleave for CleaveService {
    async fn submit_job(
        &self,
        req: Request<proto::SubmitJobRequest>,
    ) -> Result<Response<proto::Job>, Status> {
        let r = req.into_inner();
        let format = format(r.format)?;
        // Validation may take a while on a large scene: if the client's
        // deadline passes (or it cancels) meanwhile, tonic drops this
        // future at the await, and nothing is queued.
        let (text, jobs) = (r.scene, self.jobs.clone());
        let (scene, text) = blocking(move || {
            let scene = jobs.validate(&text, format)?;
            Ok((scene, text))
        })
        .await?;
        let jobs = self.jobs.clone();
        let job = blocking(move || jobs.enqueue(&scene, &text, &r.label)).await?;
        Ok(Response::new(job_to_proto(job, false)))
    }

    async fn get_job(
        &self,
        req: Request<proto::GetJobRequest>,
    ) -> Result<Response<proto::Job>, Status> {
        let r = req.into_inner();
        let full = full_view(r.view, true)?;
        let id = job_id(r.job_id)?;
        let jobs = self.jobs.clone();
        Ok(Response::new(job_to_proto(
            blocking(move || jobs.get(&id)).await?,
            full,
        )))
    }

    async fn list_jobs(
        &self,
        req: Request<proto::ListJobsRequest>,
    ) -> Result<Response<proto::ListJobsResponse>, Status> {
        let r = req.into_inner();
        let state = match proto::JobState::try_from(r.state) {
            Ok(s) => state_from_proto(s),
            Err(_) => {
                let names: Vec<_> = (0..=5)
                    .filter_map(|v| proto::JobState::try_from(v).ok())
                    .map(|s| s.as_str_name())
                    .collect();
                return Err(unknown_enum("state", r.state, &names));
            }
        };
        let full = full_view(r.view, false)?;
        let size = if r.page_size == 0 {
            50
        } else {
            r.page_size as usize
        };
        let jobs = self.jobs.clone();
        let (list, next) = blocking(move || jobs.list(size, &r.page_token, state, full)).await?;
        Ok(Response::new(proto::ListJobsResponse {
            jobs: list.into_iter().map(|j| job_to_proto(j, full)).collect(),
            next_page_token: next,
        }))
    }

    async fn cancel_job(
        &self,
        req: Request<proto::CancelJobRequest>,
    ) -> Result<Response<proto::Job>, Status> {
        let id = job_id(req.into_inner().job_id)?;
        let jobs = self.jobs.clone();
        Ok(Response::new(job_to_proto(
            blocking(move || jobs.cancel(&id)).await?,
            false,
        )))
    }

    type WatchJobStream = EventStream;

    async fn watch_job(
        &self,
        req: Request<proto::WatchJobRequest>,
    ) -> Result<Response<EventStream>, Status> {
        let id = job_id(req.into_inner().job_id)?;
        let jobs = self.jobs.clone();
        let bus = blocking(move || jobs.watch(&id)).await?;
        let (tx, rx) = tokio::sync::mpsc::channel(64);
        tokio::spawn(async move {
            let mut seen = bus.subscribe();
            let mut next = 0usize;
            loop {
                let events = bus.since(next);
                for e in &events {
                    if tx.send(Ok(event_to_proto(next as u64, e))).await.is_err() {
                        return; // the watcher went away
                    }
                    next += 1;
                    if e.is_final() {
                        return;
                    }
                }
                if seen.changed().await.is_err() {
                    return;
                }
            }
        });
        Ok(Response::new(Box::pin(
            tokio_stream::wrappers::ReceiverStream::new(rx),
        )))
    }

    async fn list_snapshots(
        &self,
        req: Request<proto::ListSnapshotsRequest>,
    ) -> Result<Response<proto::ListSnapshotsResponse>, Status> {
        let id = job_id(req.into_inner().job_id)?;
        let jobs = self.jobs.clone();
        let heads = blocking(move || jobs.snapshots(&id)).await?;
        Ok(Response::new(proto::ListSnapshotsResponse {
            snapshots: heads.iter().map(snapshot_to_proto).collect(),
        }))
    }

    type FetchFieldsStream = ChunkStream;

    async fn fetch_fields(
        &self,
        req: Request<proto::FetchFieldsRequest>,
    ) -> Result<Response<ChunkStream>, Status> {
        let r = req.into_inner();
        let location = match proto::Location::try_from(r.location) {
            Ok(proto::Location::Unspecified) => {
                return Err(bad_field(
                    "location",
                    "required (LOCATION_PARTICLES, LOCATION_GRID or LOCATION_LINES)".into(),
                ))
            }
            Ok(l) => l,
            Err(_) => {
                return Err(unknown_enum(
                    "location",
                    r.location,
                    &["LOCATION_PARTICLES", "LOCATION_GRID", "LOCATION_LINES"],
                ))
            }
        };
        if r.latest && r.snapshot != 0 {
            return Err(bad_field(
                "snapshot",
                format!(
                    "{} given with latest = true; give one or the other",
                    r.snapshot
                ),
            ));
        }
        let id = job_id(r.job_id)?;
        let jobs = self.jobs.clone();
        let (latest, requested, job) = (r.latest, r.snapshot, id.clone());
        let (index, mut reader) = blocking(move || {
            let index = if latest {
                jobs.latest_snapshot(&job)?
            } else {
                requested
            };
            Ok((index, jobs.open_snapshot(&job, index)?))
        })
        .await?;
        let header = reader.header.clone();
        let available: Vec<jobs::snapfile::ArrayInfo> = match location {
            proto::Location::Grid => match &header.grid {
                Some(g) => g.fields.clone(),
                None => {
                    return Err(Status::failed_precondition(format!(
                        "snapshot {index} of {id} has no grid fields"
                    )))
                }
            },
            // the points, then each per-line value: the order of
            // SnapshotInfo.lines.fields
            proto::Location::Lines => match &header.lines {
                Some(l) => std::iter::once(&l.points)
                    .chain(&l.values)
                    .cloned()
                    .collect(),
                None => {
                    return Err(Status::failed_precondition(format!(
                        "snapshot {index} of {id} has no lines (its scene has no explicit cracks)"
                    )))
                }
            },
            // the particles (an unspecified location was refused above)
            _ => header.fields.clone(),
        };
        let chosen: Vec<_> = if r.fields.is_empty() {
            available
        } else {
            // each field once, in the order first asked for: a name
            // repeated cannot multiply the response
            let mut out: Vec<jobs::snapfile::ArrayInfo> = Vec::new();
            for name in &r.fields {
                if out.iter().any(|a| &a.name == name) {
                    continue;
                }
                match available.iter().find(|a| &a.name == name) {
                    Some(a) => out.push(a.clone()),
                    None => {
                        let names: Vec<_> = available.iter().map(|a| a.name.as_str()).collect();
                        // a name longer than any field's is not echoed
                        let shown = if name.len() <= 64 {
                            format!("{name:?}")
                        } else {
                            format!("of {} bytes", name.len())
                        };
                        return Err(bad_field(
                            "fields",
                            format!(
                                "no field {shown} in this snapshot (it has {})",
                                names.join(", ")
                            ),
                        ));
                    }
                }
            }
            out
        };
        let info = snapshot_to_proto(&header);
        let (tx, rx) = tokio::sync::mpsc::channel(4);
        tokio::task::spawn_blocking(move || {
            let mut first = Some(info);
            for a in chosen {
                let size = a.dtype.size();
                let per_chunk = (CHUNK_BYTES / size).max(1);
                let mut offset = 0usize;
                loop {
                    let count = per_chunk.min(a.len - offset);
                    let data = match reader.read_bytes(&a, (offset * size) as u64, count * size) {
                        Ok(d) => d,
                        Err(e) => {
                            let _ = tx.blocking_send(Err(Status::internal(e)));
                            return;
                        }
                    };
                    let chunk = proto::FieldChunk {
                        field: a.name.clone(),
                        dtype: dtype_to_proto(a.dtype) as i32,
                        components: a.components as u32,
                        total: a.len as u64,
                        offset: offset as u64,
                        data,
                        snapshot: first.take(),
                    };
                    if tx.blocking_send(Ok(chunk)).is_err() {
                        return;
                    }
                    offset += count;
                    if offset >= a.len {
                        break;
                    }
                }
            }
        });
        Ok(Response::new(Box::pin(
            tokio_stream::wrappers::ReceiverStream::new(rx),
        )))
    }

    async fn fetch_series(
        &self,
        req: Request<proto::FetchSeriesRequest>,
    ) -> Result<Response<proto::FetchSeriesResponse>, Status> {
        let id = job_id(req.into_inner().job_id)?;
        let jobs = self.jobs.clone();
        let (columns, rows) = blocking(move || jobs.series(&id)).await?;
        Ok(Response::new(proto::FetchSeriesResponse {
            columns,
            values: rows.iter().flat_map(|r| r.values()).collect(),
            rows: rows.len() as u32,
        }))
    }

    async fn validate_scene(
        &self,
        req: Request<proto::ValidateSceneRequest>,
    ) -> Result<Response<proto::ValidateSceneResponse>, Status> {
        let r = req.into_inner();
        let format = format(r.format)?;
        let jobs = self.jobs.clone();
        let resp = match tokio::task::spawn_blocking(move || jobs.validate(&r.scene, format))
            .await
            .map_err(|e| Status::internal(e.to_string()))?
        {
            Ok(scene) => proto::ValidateSceneResponse {
                valid: true,
                errors: vec![],
                particles: scene.total_particles() as u64,
                stages: scene.plan.names().into_iter().map(String::from).collect(),
                cells_x: scene.cells[0] as u64,
                cells_y: scene.cells[1] as u64,
                cells_z: scene.cells_z.unwrap_or(0) as u64,
                memory_bytes: scene.memory.total(),
                memory: scene.memory.to_string(),
                time_step: scene.time_step.dt,
                steps: scene.time_step.steps,
            },
            Err(e) => proto::ValidateSceneResponse {
                valid: false,
                errors: e
                    .errors
                    .iter()
                    .map(|f| proto::FieldError {
                        path: f.path.clone(),
                        reason: f.reason.clone(),
                    })
                    .collect(),
                ..Default::default()
            },
        };
        Ok(Response::new(resp))
    }
}

/// Gives the status codes the API promises to requests tonic refuses
/// before a handler runs: one it cannot decode (tonic: INTERNAL) is the
/// client's fault, INVALID_ARGUMENT; one over `--max-request-bytes`
/// (tonic: OUT_OF_RANGE) is RESOURCE_EXHAUSTED. Both come as a
/// trailers-only response, so the status is in the headers. Our handlers
/// return neither code with these messages.
fn request_status(mut r: http::Response<tonic::body::Body>) -> http::Response<tonic::body::Body> {
    let headers = r.headers_mut();
    let code = headers
        .get("grpc-status")
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.parse::<i32>().ok());
    let message = headers
        .get("grpc-message")
        .and_then(|v| v.to_str().ok())
        .map(|m| m.replace("%20", " "))
        .unwrap_or_default();
    let fixed = match code {
        Some(c) if c == Code::Internal as i32 && message.starts_with("failed to decode") => {
            Some(Code::InvalidArgument)
        }
        Some(c) if c == Code::OutOfRange as i32 && message.contains("message length too large") => {
            Some(Code::ResourceExhausted)
        }
        _ => None,
    };
    if let Some(code) = fixed {
        headers.insert("grpc-status", http::HeaderValue::from(code as i32));
    }
    r
}

/// Checks the bearer token of a request.
fn check_token(expected: &Option<String>, req: &Request<()>) -> Result<(), Status> {
    let Some(token) = expected else { return Ok(()) };
    let given = req
        .metadata()
        .get("authorization")
        .and_then(|v| v.to_str().ok())
        .unwrap_or("");
    // constant-time comparison of the token
    let want = format!("Bearer {token}");
    let ok = given.len() == want.len()
        && given
            .bytes()
            .zip(want.bytes())
            .fold(0u8, |a, (x, y)| a | (x ^ y))
            == 0;
    if ok {
        Ok(())
    } else {
        Err(Status::unauthenticated(
            "missing or wrong bearer token (authorization: Bearer <token>)",
        ))
    }
}

/// Binds, prints `listening on ADDR` on stdout, and serves until ctrl-c or
/// SIGTERM; on shutdown, running jobs save a checkpoint and stop, and the
/// next server resumes them (with checkpoints off, they are cancelled).
pub async fn serve(config: ServerConfig) -> anyhow::Result<()> {
    let listener = tokio::net::TcpListener::bind(config.listen).await?;
    let addr = listener.local_addr()?;
    println!("listening on {addr}");
    use std::io::Write;
    let _ = std::io::stdout().flush();
    let shutdown = async {
        let ctrl_c = tokio::signal::ctrl_c();
        #[cfg(unix)]
        {
            let mut term =
                match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
                    Ok(t) => t,
                    Err(_) => {
                        let _ = ctrl_c.await;
                        return;
                    }
                };
            tokio::select! { _ = ctrl_c => {}, _ = term.recv() => {} }
        }
        #[cfg(not(unix))]
        {
            let _ = ctrl_c.await;
        }
    };
    serve_on(listener, config, shutdown).await
}

/// Serves on a bound listener until `shutdown` completes (used by
/// [`serve`], and by benchmarks that run a server in-process).
pub async fn serve_on(
    listener: tokio::net::TcpListener,
    config: ServerConfig,
    shutdown: impl std::future::Future<Output = ()> + Send,
) -> anyhow::Result<()> {
    // off the runtime: a fleet's store connects with a blocking client
    let job_config = config.jobs.clone();
    let jobs = tokio::task::spawn_blocking(move || JobManager::start(job_config)).await??;
    let addr = listener.local_addr()?;
    let (reporter, health) = tonic_health::server::health_reporter();
    reporter.set_serving::<CleaveServer<CleaveService>>().await;
    // a fleet server whose database is away says so (it keeps serving
    // what it can, and its health comes back with the database)
    let watched = jobs.clone();
    let health_task = tokio::spawn(async move {
        use tonic_health::ServingStatus;
        let mut serving = true;
        loop {
            tokio::time::sleep(HEALTH_EVERY).await;
            let now = watched.store_reachable();
            if now != serving {
                serving = now;
                let status = if now {
                    ServingStatus::Serving
                } else {
                    ServingStatus::NotServing
                };
                reporter.set_service_status("", status).await;
                reporter
                    .set_service_status(
                        <CleaveServer<CleaveService> as tonic::server::NamedService>::NAME,
                        status,
                    )
                    .await;
            }
        }
    });
    // Both reflection versions: grpcurl and other tools ask for either.
    let reflection_builder = || {
        tonic_reflection::server::Builder::configure()
            .register_encoded_file_descriptor_set(proto::FILE_DESCRIPTOR_SET)
            .register_encoded_file_descriptor_set(tonic_health::pb::FILE_DESCRIPTOR_SET)
    };
    let reflection = reflection_builder().build_v1()?;
    let reflection_alpha = reflection_builder().build_v1alpha()?;
    let token = config.token.clone();
    let auth = move |req: Request<()>| check_token(&token, &req).map(|_| req);
    let cleave = tonic::service::interceptor::InterceptedService::new(
        CleaveServer::new(CleaveService { jobs: jobs.clone() })
            .max_decoding_message_size(config.max_request_bytes),
        auth.clone(),
    );
    let reflection = tonic::service::interceptor::InterceptedService::new(reflection, auth.clone());
    let reflection_alpha =
        tonic::service::interceptor::InterceptedService::new(reflection_alpha, auth);
    let mut builder = tonic::transport::Server::builder()
        .layer(tower::util::MapResponseLayer::new(request_status));
    if let Some((cert, key)) = &config.tls {
        let identity =
            tonic::transport::Identity::from_pem(std::fs::read(cert)?, std::fs::read(key)?);
        builder =
            builder.tls_config(tonic::transport::ServerTlsConfig::new().identity(identity))?;
    }
    tracing::info!(%addr, data_dir = %config.jobs.data_dir.display(), "serving");
    builder
        .add_service(health)
        .add_service(reflection)
        .add_service(reflection_alpha)
        .add_service(cleave)
        // TCP_NODELAY, as `Server::serve` would set: without it a small
        // unary response (headers, message and trailers written apart)
        // waits for the client's delayed ACK, ~40 ms on Linux
        .serve_with_incoming_shutdown(
            tonic::transport::server::TcpIncoming::from(listener).with_nodelay(Some(true)),
            shutdown,
        )
        .await?;
    health_task.abort();
    jobs.shutdown();
    // the running jobs' last step and checkpoint (a minute is ample for
    // the largest scenes' checkpoint: `scenes/p1_plate.toml` writes ~0.4 GB)
    let j = jobs.clone();
    let stopped =
        tokio::task::spawn_blocking(move || j.wait_stopped(std::time::Duration::from_secs(60)))
            .await
            .unwrap_or(false);
    if !stopped {
        tracing::warn!("stopped with jobs still running; without a checkpoint they are marked FAILED at the next start");
    }
    tracing::info!("stopped");
    Ok(())
}
