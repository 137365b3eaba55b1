//! The client side of the gRPC service: connect, submit, watch, fetch.

use cleave::diagnostics::{
    Field, FieldData, GridSnapshot, Observer, Polyline, SeriesRow, Snapshot,
};
use cleave::output::{OutputPaths, OutputWriter};
use cleave::service::proto::{self, cleave_client::CleaveClient, job_event::Event};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;
use std::path::Path;
use std::process::ExitCode;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Channel;
use tonic::{Code, Request, Status};

pub const EXIT_FAILED: u8 = 1;
pub const EXIT_INVALID: u8 = 2;
pub const EXIT_UNREACHABLE: u8 = 3;

/// A failed remote call, with the exit code it maps to.
#[derive(Debug)]
pub struct RemoteError {
    pub code: u8,
    pub message: String,
}

impl From<Status> for RemoteError {
    fn from(s: Status) -> Self {
        let code = match s.code() {
            Code::InvalidArgument
            | Code::NotFound
            | Code::FailedPrecondition
            | Code::OutOfRange => EXIT_INVALID,
            Code::Unauthenticated
            | Code::PermissionDenied
            | Code::Unavailable
            | Code::DeadlineExceeded => EXIT_UNREACHABLE,
            _ => EXIT_FAILED,
        };
        RemoteError {
            code,
            message: format!("{}: {}", code_name(s.code()), s.message()),
        }
    }
}

fn code_name(c: Code) -> &'static str {
    match c {
        Code::InvalidArgument => "invalid argument",
        Code::NotFound => "not found",
        Code::FailedPrecondition => "failed precondition",
        Code::Unauthenticated => "unauthenticated",
        Code::PermissionDenied => "permission denied",
        Code::ResourceExhausted => "resource exhausted",
        Code::Unavailable => "server unavailable",
        Code::DeadlineExceeded => "deadline exceeded",
        Code::Cancelled => "cancelled",
        Code::Internal => "server error",
        Code::Unknown => "unknown error",
        _ => "server error",
    }
}

/// An error in the middle of a stream the server had started: unless the
/// server said why (a status it chose), the connection was lost, and the
/// job goes on without us. Exit 3, with the command that picks it up again.
fn lost(s: Status, id: &str) -> RemoteError {
    match s.code() {
        Code::InvalidArgument
        | Code::NotFound
        | Code::FailedPrecondition
        | Code::Unauthenticated
        | Code::PermissionDenied
        | Code::ResourceExhausted => s.into(),
        _ => RemoteError::new(
            EXIT_UNREACHABLE,
            format!(
                "lost the connection to the server ({}); the job may still be running: cleave watch {id}",
                s.message()
            ),
        ),
    }
}

/// The server a command talks to, and how it was named.
#[derive(Debug, Clone)]
pub struct Target {
    /// With its scheme (see [`with_scheme`]).
    pub url: String,
    pub token: Option<String>,
    pub ca_cert: Option<std::path::PathBuf>,
    /// Named by CLEAVE_SERVER rather than --server.
    pub from_env: bool,
}

impl Target {
    /// Adds to an unreachable server's error that the environment chose it.
    pub fn explain(&self, mut e: RemoteError) -> RemoteError {
        if self.from_env && e.code == EXIT_UNREACHABLE {
            e.message.push_str(&format!(
                "\n(the command went to {} because CLEAVE_SERVER is set; unset it, e.g. `env -u CLEAVE_SERVER cleave run ...`, to run in this process)",
                self.url
            ));
        }
        e
    }
}

/// `HOST:PORT` means `http://HOST:PORT`; a URL with a scheme is kept.
pub fn with_scheme(url: &str) -> String {
    if url.contains("://") {
        url.to_string()
    } else {
        format!("http://{url}")
    }
}

impl RemoteError {
    pub fn new(code: u8, message: impl Into<String>) -> Self {
        RemoteError {
            code,
            message: message.into(),
        }
    }

    /// Prints the error and returns its exit code.
    pub fn report(self, json: bool) -> ExitCode {
        if json {
            println!(
                "{}",
                json!({"status": "error", "error": self.message, "exit_code": self.code})
            );
        }
        eprintln!("error: {}", self.message);
        ExitCode::from(self.code)
    }
}

/// Adds the bearer token to every call.
#[derive(Clone)]
pub struct Auth(Option<tonic::metadata::MetadataValue<tonic::metadata::Ascii>>);

impl tonic::service::Interceptor for Auth {
    fn call(&mut self, mut req: Request<()>) -> Result<Request<()>, Status> {
        if let Some(v) = &self.0 {
            req.metadata_mut().insert("authorization", v.clone());
        }
        Ok(req)
    }
}

pub type Client = CleaveClient<InterceptedService<Channel, Auth>>;

/// Connects to the target's URL (http:// or https://). For https, its
/// `ca_cert` is a PEM file of the certificate authority to trust (a
/// self-signed server certificate itself will do).
pub async fn connect(target: &Target) -> Result<Client, RemoteError> {
    let (url, token, ca_cert) = (
        target.url.as_str(),
        target.token.as_deref(),
        target.ca_cert.as_deref(),
    );
    let endpoint = Channel::from_shared(url.to_string())
        .map_err(|e| RemoteError::new(EXIT_INVALID, format!("--server {url:?}: {e}")))?;
    let endpoint = if url.starts_with("https://") {
        let mut tls = tonic::transport::ClientTlsConfig::new();
        if let Some(ca) = ca_cert {
            let pem = std::fs::read(ca).map_err(|e| {
                RemoteError::new(EXIT_INVALID, format!("--ca-cert {}: {e}", ca.display()))
            })?;
            tls = tls.ca_certificate(tonic::transport::Certificate::from_pem(pem));
        }
        endpoint
            .tls_config(tls)
            .map_err(|e| RemoteError::new(EXIT_UNREACHABLE, format!("TLS: {e}")))?
    } else {
        endpoint
    };
    let channel = endpoint.connect().await.map_err(|e| {
        RemoteError::new(
            EXIT_UNREACHABLE,
            format!("cannot reach the server at {url}: {e}"),
        )
    })?;
    let auth =
        match token {
            Some(t) => Some(format!("Bearer {t}").parse().map_err(|_| {
                RemoteError::new(EXIT_INVALID, "--token: not a valid header value")
            })?),
            None => None,
        };
    Ok(CleaveClient::with_interceptor(channel, Auth(auth)).max_decoding_message_size(usize::MAX))
}

/// A job state as the CLI shows it: QUEUED, RUNNING, ... (the proto's
/// name without its JOB_STATE_ prefix).
fn state_name(s: i32) -> &'static str {
    proto::JobState::try_from(s).map_or("UNKNOWN", |s| {
        let n = s.as_str_name();
        n.strip_prefix("JOB_STATE_").unwrap_or(n)
    })
}

fn is_final(state: i32) -> bool {
    [
        proto::JobState::Succeeded,
        proto::JobState::Failed,
        proto::JobState::Cancelled,
    ]
    .iter()
    .any(|s| *s as i32 == state)
}

/// Seconds since the Unix epoch as `YYYY-MM-DD HH:MM:SS` UTC; `-` for 0
/// (a time the job has not reached).
pub fn utc(t: f64) -> String {
    if t.is_nan() || t <= 0.0 || t.is_infinite() {
        return "-".to_string();
    }
    let secs = t.floor() as i64;
    let (days, rem) = (secs.div_euclid(86_400), secs.rem_euclid(86_400));
    // civil date from days since 1970-01-01 (Howard Hinnant's algorithm)
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02}:{:02}",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

fn job_json(j: &proto::Job) -> serde_json::Value {
    json!({
        "id": j.id,
        "label": j.label,
        "scene_name": j.scene_name,
        "state": state_name(j.state),
        "created_at": j.created_at,
        "started_at": j.started_at,
        "finished_at": j.finished_at,
        "error": j.error,
        "particles": j.particles,
        "stages": j.stages,
        "worker": j.worker,
        "progress": j.progress.as_ref().map(|p| json!({"step": p.step, "time": p.time, "fraction": p.fraction, "eta_seconds": p.eta_seconds})),
        "summary": j.summary.as_ref().map(summary_json),
    })
}

fn summary_json(s: &proto::Summary) -> serde_json::Value {
    json!({
        "steps": s.steps, "time": s.time, "wall_seconds": s.wall_seconds,
        "kinetic_energy": s.kinetic_energy, "strain_energy": s.strain_energy,
        "external_work": s.external_work, "energy_error": s.energy_error,
        "snapshots": s.snapshots, "series_rows": s.series_rows,
    })
}

/// Reads a scene file as text (exit 2 if it cannot be read).
pub fn read_scene(path: &Path) -> Result<String, RemoteError> {
    let bytes = std::fs::read(path).map_err(|e| {
        RemoteError::new(
            EXIT_INVALID,
            format!("cannot read scene file {}: {e}", path.display()),
        )
    })?;
    String::from_utf8(bytes).map_err(|e| {
        RemoteError::new(
            EXIT_INVALID,
            format!(
                "invalid scene {}: not UTF-8 text (invalid byte at offset {})",
                path.display(),
                e.utf8_error().valid_up_to()
            ),
        )
    })
}

fn scene_format(path: &Path) -> i32 {
    match path.extension().and_then(|e| e.to_str()) {
        Some("json") => proto::SceneFormat::Json as i32,
        Some("toml") => proto::SceneFormat::Toml as i32,
        _ => proto::SceneFormat::Unspecified as i32,
    }
}

pub async fn submit(
    client: &mut Client,
    path: &Path,
    label: &str,
) -> Result<proto::Job, RemoteError> {
    let scene = read_scene(path)?;
    let job = client
        .submit_job(proto::SubmitJobRequest {
            scene,
            format: scene_format(path),
            label: label.to_string(),
        })
        .await?
        .into_inner();
    Ok(job)
}

pub async fn validate(
    client: &mut Client,
    path: &Path,
    json_out: bool,
) -> Result<ExitCode, RemoteError> {
    let scene = read_scene(path)?;
    let r = client
        .validate_scene(proto::ValidateSceneRequest {
            scene,
            format: scene_format(path),
        })
        .await?
        .into_inner();
    // x, y and, for a 3D scene, z
    let cells: Vec<u64> = [r.cells_x, r.cells_y]
        .into_iter()
        .chain((r.cells_z > 0).then_some(r.cells_z))
        .collect();
    if json_out {
        let errors: Vec<_> = r
            .errors
            .iter()
            .map(|e| json!({"path": e.path, "reason": e.reason}))
            .collect();
        println!(
            "{}",
            json!({"status": if r.valid { "valid" } else { "invalid" }, "scene": path, "particles": r.particles, "cells": cells, "stages": r.stages, "memory_bytes": r.memory_bytes, "memory": r.memory, "time_step": {"dt": r.time_step, "steps": r.steps}, "errors": errors})
        );
    }
    if r.valid {
        if !json_out {
            println!(
                "{}: valid; {} particles, {} cells; plan: {}",
                path.display(),
                r.particles,
                cells
                    .iter()
                    .map(u64::to_string)
                    .collect::<Vec<_>>()
                    .join(" x "),
                r.stages.join(" → ")
            );
            println!("  memory: {}", r.memory);
            println!(
                "  time step: {:.4e} s, at least {:.0} steps to time.end",
                r.time_step, r.steps
            );
        }
        Ok(ExitCode::SUCCESS)
    } else {
        eprintln!("error: invalid scene {}:", path.display());
        for e in &r.errors {
            if e.path.is_empty() {
                eprintln!("  {}", e.reason);
            } else {
                eprintln!("  {}: {}", e.path, e.reason);
            }
        }
        Ok(ExitCode::from(EXIT_INVALID))
    }
}

/// Follows a job to its end: a progress bar, or one JSON object per event
/// with `json_events`. Returns the final job.
pub async fn watch(
    client: &mut Client,
    id: &str,
    bar: bool,
    json_events: bool,
) -> Result<proto::Job, RemoteError> {
    let mut stream = client
        .watch_job(proto::WatchJobRequest {
            job_id: id.to_string(),
        })
        .await?
        .into_inner();
    let pb = bar.then(|| {
        let pb = ProgressBar::new(1000);
        pb.set_style(
            ProgressStyle::with_template(
                "{bar:40} {percent:>3}% {elapsed_precise} eta {eta} {msg}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        pb
    });
    while let Some(ev) = stream.message().await.map_err(|e| lost(e, id))? {
        if json_events {
            let body = match &ev.event {
                Some(Event::State(s)) => {
                    json!({"type": "state", "state": state_name(s.state), "error": s.error})
                }
                Some(Event::Progress(p)) => {
                    json!({"type": "progress", "step": p.step, "time": p.time, "fraction": p.fraction, "eta_seconds": p.eta_seconds, "kinetic_energy": p.kinetic_energy, "strain_energy": p.strain_energy})
                }
                Some(Event::Summary(s)) => json!({"type": "summary", "summary": summary_json(s)}),
                None => json!({"type": "unknown"}),
            };
            let mut body = body;
            body["sequence"] = json!(ev.sequence);
            body["job_id"] = json!(id);
            println!("{body}");
        }
        if let (Some(pb), Some(Event::Progress(p))) = (&pb, &ev.event) {
            pb.set_position((p.fraction * 1000.0) as u64);
            pb.set_message(format!("step {} t = {:.3e} s", p.step, p.time));
        }
    }
    if let Some(pb) = pb {
        pb.finish_and_clear();
    }
    client
        .get_job(proto::GetJobRequest {
            job_id: id.to_string(),
            view: proto::JobView::Basic as i32,
        })
        .await
        .map(|r| r.into_inner())
        .map_err(|e| lost(e, id))
}

/// Exit code of a finished job.
pub fn outcome(job: &proto::Job) -> ExitCode {
    if job.state == proto::JobState::Succeeded as i32 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_FAILED)
    }
}

async fn fetch_snapshot(
    client: &mut Client,
    id: &str,
    index: u32,
    with_grid: bool,
) -> Result<Snapshot, RemoteError> {
    let (info, particle_fields) =
        fetch_location(client, id, index, proto::Location::Particles).await?;
    let mut positions = Vec::new();
    let mut fields = Vec::new();
    // 2 or 3 (a server older than 3D runs sends no dimension: 2)
    let dimension = if info.dimension == 3 { 3 } else { 2 };
    for f in particle_fields {
        if f.name == "position" && positions.is_empty() {
            if let FieldData::F64(v) = &f.data {
                positions = v
                    .chunks_exact(dimension)
                    .map(|c| {
                        let mut x = [0.0; 3];
                        x[..dimension].copy_from_slice(c);
                        x
                    })
                    .collect();
            }
        } else {
            fields.push(f);
        }
    }
    let grid = match (&info.grid, with_grid) {
        (Some(g), true) => {
            let (_, gf) = fetch_location(client, id, index, proto::Location::Grid).await?;
            Some(GridSnapshot {
                origin: [g.origin_x, g.origin_y, g.origin_z],
                spacing: g.spacing,
                dims: [g.nx as usize, g.ny as usize, g.nz.max(1) as usize],
                fields: gf,
            })
        }
        _ => None,
    };
    // only a server that stores lines sets `lines`, and only for a
    // snapshot that has some: an older server or a scene without cracks
    // costs no call
    let lines = match &info.lines {
        Some(l) => {
            let (_, lf) = fetch_location(client, id, index, proto::Location::Lines).await?;
            polylines(&l.counts, lf, dimension)
                .map_err(|e| RemoteError::new(EXIT_FAILED, format!("snapshot {index}: {e}")))?
        }
        None => Vec::new(),
    };
    Ok(Snapshot {
        index: info.index,
        step: info.step,
        time: info.time,
        dimension,
        positions,
        fields,
        grid,
        lines,
    })
}

/// The polylines of a snapshot from its `LinesInfo` counts and the
/// fetched `LOCATION_LINES` fields (`position`, then one value per line),
/// as the server's snapshot-file reader rebuilds them: a value of
/// [`Polyline::MISSING`] is one the line lacks. An Err says the server
/// sent arrays that do not fit the counts (never trusted to index by).
fn polylines(counts: &[u64], fields: Vec<Field>, d: usize) -> Result<Vec<Polyline>, String> {
    let mut xy = None;
    let mut values = Vec::new();
    for Field { name, data, .. } in fields {
        match data {
            FieldData::F64(v) if name == "position" && xy.is_none() => xy = Some(v),
            FieldData::U32(v) if v.len() == counts.len() => values.push((name, v)),
            _ => {
                return Err(format!(
                    "the lines' {name} is neither their position nor {} integers, one per line",
                    counts.len()
                ))
            }
        }
    }
    let xy = xy.ok_or("the lines came without their position")?;
    let total = counts
        .iter()
        .try_fold(0u64, |a, &n| a.checked_add(n))
        .and_then(|n| usize::try_from(n).ok())
        .and_then(|n| n.checked_mul(d));
    if total != Some(xy.len()) {
        return Err(format!(
            "the lines' {} position values are not their counted points in {d}D",
            xy.len()
        ));
    }
    Ok(Polyline::from_parts(
        counts.iter().map(|&n| n as usize),
        &xy,
        d,
        &values,
    ))
}

/// All fields of one location of a snapshot, rebuilt from the chunks.
async fn fetch_location(
    client: &mut Client,
    id: &str,
    index: u32,
    location: proto::Location,
) -> Result<(proto::SnapshotInfo, Vec<Field>), RemoteError> {
    let mut stream = client
        .fetch_fields(proto::FetchFieldsRequest {
            job_id: id.to_string(),
            snapshot: index,
            location: location as i32,
            fields: vec![],
            latest: false,
        })
        .await
        .map_err(|e| lost(e, id))?
        .into_inner();
    let mut info = None;
    let mut fields: Vec<(Field, Vec<u8>)> = Vec::new();
    while let Some(c) = stream.message().await.map_err(|e| lost(e, id))? {
        if let Some(s) = c.snapshot {
            info = Some(s);
        }
        let same = fields.last().is_some_and(|(f, _)| f.name == c.field);
        if !same {
            let data = if c.dtype == proto::DataType::Uint32 as i32 {
                FieldData::U32(Vec::new())
            } else {
                FieldData::F64(Vec::new())
            };
            fields.push((
                Field {
                    name: c.field.clone(),
                    components: c.components as usize,
                    data,
                },
                Vec::new(),
            ));
        }
        if let Some((_, bytes)) = fields.last_mut() {
            bytes.extend_from_slice(&c.data);
        }
    }
    let info =
        info.ok_or_else(|| RemoteError::new(EXIT_FAILED, "the server sent no snapshot header"))?;
    let fields = fields
        .into_iter()
        .map(|(mut f, bytes)| {
            f.data = match f.data {
                FieldData::U32(_) => FieldData::U32(
                    bytes
                        .chunks_exact(4)
                        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
                        .collect(),
                ),
                FieldData::F64(_) => FieldData::F64(
                    bytes
                        .chunks_exact(8)
                        .map(|c| {
                            f64::from_le_bytes([c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]])
                        })
                        .collect(),
                ),
            };
            f
        })
        .collect();
    Ok((info, fields))
}

/// A job's series: its column names and rows.
pub async fn fetch_series(
    client: &mut Client,
    id: &str,
) -> Result<(Vec<String>, Vec<SeriesRow>), RemoteError> {
    let series = client
        .fetch_series(proto::FetchSeriesRequest {
            job_id: id.to_string(),
        })
        .await?
        .into_inner();
    let cols = series.columns.len();
    if cols < SeriesRow::COLUMNS.len()
        || series.columns[..SeriesRow::COLUMNS.len()] != SeriesRow::COLUMNS
    {
        return Err(RemoteError::new(
            EXIT_FAILED,
            format!(
                "the server's series starts with columns {:?}, this client expects {:?}",
                series.columns,
                SeriesRow::COLUMNS
            ),
        ));
    }
    let rows = series
        .values
        .chunks_exact(cols)
        .map(|v| {
            SeriesRow::from_values(v)
                .ok_or_else(|| RemoteError::new(EXIT_FAILED, "malformed series row"))
        })
        .collect::<Result<_, _>>()?;
    Ok((series.columns, rows))
}

/// Fetches a job's series and snapshots and writes them like `cleave run`.
pub async fn fetch(client: &mut Client, id: &str, out: &Path) -> Result<OutputPaths, RemoteError> {
    let (columns, rows) = fetch_series(client, id).await?;
    let snaps = client
        .list_snapshots(proto::ListSnapshotsRequest {
            job_id: id.to_string(),
        })
        .await?
        .into_inner();
    let write_err = |e: String| {
        RemoteError::new(
            EXIT_FAILED,
            format!("writing results to {}: {e}", out.display()),
        )
    };
    let mut writer = OutputWriter::create(out).map_err(|e| write_err(e.to_string()))?;
    writer.series_columns(&columns).map_err(write_err)?;
    for row in &rows {
        writer.series_row(row).map_err(write_err)?;
    }
    for s in &snaps.snapshots {
        let snap = fetch_snapshot(client, id, s.index, s.grid.is_some()).await?;
        writer.snapshot(&snap).map_err(write_err)?;
    }
    writer.finish().map_err(|e| write_err(e.to_string()))
}

pub async fn get(client: &mut Client, id: &str) -> Result<proto::Job, RemoteError> {
    Ok(client
        .get_job(proto::GetJobRequest {
            job_id: id.to_string(),
            view: proto::JobView::Basic as i32,
        })
        .await?
        .into_inner())
}

pub async fn cancel(client: &mut Client, id: &str) -> Result<proto::Job, RemoteError> {
    Ok(client
        .cancel_job(proto::CancelJobRequest {
            job_id: id.to_string(),
        })
        .await?
        .into_inner())
}

/// `cleave cancel`: cancels a job and prints its state once the cancel
/// has taken effect (a running job stops within a second), or says that
/// it had already ended. Exit 0 either way; 1 if it is still running
/// after the wait.
pub async fn cancel_and_report(
    client: &mut Client,
    id: &str,
    json_out: bool,
) -> Result<ExitCode, RemoteError> {
    let before = get(client, id).await?;
    if is_final(before.state) {
        if json_out {
            let mut v = job_json(&before);
            v["cancelled"] = json!(false);
            v["note"] = json!("the job had already ended; nothing to cancel");
            println!("{v}");
        } else {
            println!(
                "{id} had already ended ({}); nothing to cancel",
                state_name(before.state)
            );
        }
        return Ok(ExitCode::SUCCESS);
    }
    let mut job = cancel(client, id).await?;
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
    while !is_final(job.state) && std::time::Instant::now() < deadline {
        tokio::time::sleep(std::time::Duration::from_millis(100)).await;
        job = get(client, id).await?;
    }
    if json_out {
        let mut v = job_json(&job);
        v["cancelled"] = json!(job.state == proto::JobState::Cancelled as i32);
        println!("{v}");
    } else if is_final(job.state) {
        println!("{id}: {}", state_name(job.state));
    } else {
        println!(
            "{id}: still {} 10 s after the cancel; `cleave get {id}` shows when it stops",
            state_name(job.state)
        );
    }
    Ok(if is_final(job.state) {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_FAILED)
    })
}

pub async fn list(
    client: &mut Client,
    state: Option<&str>,
    limit: u32,
) -> Result<Vec<proto::Job>, RemoteError> {
    let state = match state {
        None => 0,
        Some(s) => proto::JobState::from_str_name(&format!("JOB_STATE_{}", s.to_uppercase()))
            .filter(|s| *s != proto::JobState::Unspecified)
            .ok_or_else(|| {
                RemoteError::new(
                    EXIT_INVALID,
                    format!(
                    "--state: unknown state {s:?} (queued, running, succeeded, failed, cancelled)"
                ),
                )
            })? as i32,
    };
    let mut out = Vec::new();
    let mut token = String::new();
    loop {
        let page = client
            .list_jobs(proto::ListJobsRequest {
                page_size: limit.clamp(1, 1000),
                page_token: token,
                state,
                view: proto::JobView::Basic as i32,
            })
            .await?
            .into_inner();
        out.extend(page.jobs);
        if page.next_page_token.is_empty() || out.len() >= limit as usize {
            break;
        }
        token = page.next_page_token;
    }
    out.truncate(limit as usize);
    Ok(out)
}

/// The column names above [`print_job`]'s lines.
pub fn print_job_header() {
    println!(
        "{:<12}  {:<9}  {:<20}  {:<19}  {:<19}  {:<19}  {:>10}  label",
        "id", "state", "scene", "submitted (UTC)", "started", "ended", "particles"
    );
}

/// Prints a job as one line of text (under [`print_job_header`]) or JSON.
pub fn print_job(j: &proto::Job, json_out: bool) {
    if json_out {
        println!("{}", job_json(j));
    } else {
        let mut extra = if j.error.is_empty() {
            String::new()
        } else {
            format!("  {}", j.error)
        };
        // servers that share a queue say which runs the job
        if !j.worker.is_empty() {
            extra = format!("  [on {}]{extra}", j.worker);
        }
        let state = match (&j.progress, j.state == proto::JobState::Running as i32) {
            (Some(p), true) => format!("{} {:.0}%", state_name(j.state), 100.0 * p.fraction),
            _ => state_name(j.state).to_string(),
        };
        let scene = if j.scene_name.is_empty() {
            "-"
        } else {
            &j.scene_name
        };
        println!(
            "{:<12}  {:<9}  {:<20}  {:<19}  {:<19}  {:<19}  {:>10}  {}{extra}",
            j.id,
            state,
            scene,
            utc(j.created_at),
            utc(j.started_at),
            utc(j.finished_at),
            j.particles,
            j.label
        );
    }
}

/// `cleave get`: one job, a field a line.
pub fn print_job_details(j: &proto::Job) {
    println!("id:         {}", j.id);
    println!("state:      {}", state_name(j.state));
    println!(
        "scene:      {}",
        if j.scene_name.is_empty() {
            "-"
        } else {
            &j.scene_name
        }
    );
    if !j.label.is_empty() {
        println!("label:      {}", j.label);
    }
    println!("submitted:  {} UTC", utc(j.created_at));
    println!("started:    {}", utc(j.started_at));
    println!("ended:      {}", utc(j.finished_at));
    println!("particles:  {}", j.particles);
    if !j.worker.is_empty() {
        println!("worker:     {}", j.worker);
    }
    println!("plan:       {}", j.stages.join(" → "));
    if let Some(p) = &j.progress {
        println!(
            "progress:   step {}, t = {:.6e} s of {:.6e} s ({:.1} %)",
            p.step,
            p.time,
            p.end_time,
            100.0 * p.fraction
        );
    }
    if let Some(s) = &j.summary {
        println!(
            "summary:    {} steps to t = {:.6e} s in {:.2} s; {} snapshots",
            s.steps, s.time, s.wall_seconds, s.snapshots
        );
    }
    if !j.error.is_empty() {
        println!("error:      {}", j.error);
    }
}

pub fn job_value(j: &proto::Job) -> serde_json::Value {
    job_json(j)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn field(name: &str, data: FieldData) -> Field {
        Field {
            name: name.into(),
            components: 1,
            data,
        }
    }

    /// Lines rebuild in order with their values (a MISSING value is one
    /// the line lacks); a server whose arrays do not fit its counts gets
    /// an error, not a panic or lines cut anywhere.
    #[test]
    fn polylines_rebuild_and_refuse_arrays_that_do_not_fit() {
        let xy = || {
            field(
                "position",
                FieldData::F64(vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0]),
            )
        };
        let crack = || field("crack", FieldData::U32(vec![0, Polyline::MISSING]));
        let lines = polylines(&[2, 1], vec![xy(), crack()], 2).unwrap();
        assert_eq!(
            lines,
            [
                Polyline {
                    points: vec![[0.0, 1.0, 0.0], [2.0, 3.0, 0.0]],
                    cell_data: vec![("crack".into(), 0)],
                },
                Polyline {
                    points: vec![[4.0, 5.0, 0.0]],
                    cell_data: vec![],
                },
            ]
        );
        for (counts, fields) in [
            (vec![2, 2], vec![xy(), crack()]),
            (vec![u64::MAX, 4], vec![xy(), crack()]),
            (vec![2, 1], vec![xy(), xy(), crack()]),
            (vec![2, 1], vec![crack()]),
            (vec![3], vec![xy(), crack()]),
        ] {
            assert!(polylines(&counts, fields, 2).is_err(), "{counts:?}");
        }
    }
}
