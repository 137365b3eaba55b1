//! `cleave-server`: the gRPC service. Flags or environment variables:
//! where to listen, where to keep data, how many jobs run at once and on
//! how many threads, the bearer token, limits, TLS.

use clap::Parser;
use cleave::jobs::{JobConfig, ResultsSpec, StoreSpec};
use cleave::service::{serve, ServerConfig};
use std::net::SocketAddr;
use std::path::PathBuf;

#[derive(Parser)]
#[command(name = "cleave-server", version = cleave::VERSION, about = "The cleave simulation service (gRPC)")]
struct Args {
    /// Address to listen on (port 0 picks a free port; the chosen address is
    /// printed as `listening on ADDR`).
    #[arg(long, env = "CLEAVE_LISTEN", default_value = "127.0.0.1:50051")]
    listen: SocketAddr,
    /// Directory of the job database and results. With a PostgreSQL store,
    /// the results' directory, which every server of the fleet must reach
    /// (a shared file system), unless the results are in a bucket
    /// (`--results s3://…`): then each server's own working copy.
    #[arg(long, env = "CLEAVE_DATA_DIR", default_value = "./cleave-data")]
    data_dir: PathBuf,
    /// Where the job records live: `sqlite` (in the data directory, one
    /// server) or a PostgreSQL URL, `postgres://user:password@host/db`,
    /// that several servers share: each serves the API for every job and
    /// runs jobs from the one queue.
    #[arg(
        long,
        env = "CLEAVE_STORE",
        default_value = "sqlite",
        hide_env_values = true
    )]
    store: String,
    /// Seconds a fleet server's claim on a running job lasts without
    /// renewal (it renews four times a second): if its server dies, another
    /// takes the job this long after, from its last checkpoint.
    #[arg(long, env = "CLEAVE_LEASE", default_value_t = 10.0)]
    lease: f64,
    /// Where the result files (series, snapshots, checkpoints) live:
    /// `data-dir`, or an S3-compatible bucket, `s3://bucket/prefix`, that
    /// every server of a fleet reaches. The bucket's endpoint, region and
    /// credentials come from the AWS_* environment variables
    /// (AWS_ENDPOINT, AWS_REGION, AWS_ACCESS_KEY_ID, AWS_SECRET_ACCESS_KEY;
    /// AWS_ALLOW_HTTP=true for a plain-HTTP endpoint).
    #[arg(long, env = "CLEAVE_RESULTS", default_value = "data-dir")]
    results: String,
    /// Jobs running at once; the rest wait in the queue.
    #[arg(long, env = "CLEAVE_MAX_CONCURRENT_JOBS", default_value_t = 1)]
    max_concurrent_jobs: usize,
    /// Threads of each job's pool (default: the machine's cores).
    #[arg(long, env = "CLEAVE_THREADS_PER_JOB")]
    threads_per_job: Option<usize>,
    /// Bearer token every RPC but health must carry.
    #[arg(long, env = "CLEAVE_TOKEN", hide_env_values = true)]
    token: Option<String>,
    /// Largest job accepted, in particles.
    #[arg(long, env = "CLEAVE_MAX_PARTICLES", default_value_t = 20_000_000)]
    max_particles: u64,
    /// Largest job accepted by its scene's memory estimate, in bytes
    /// (default: what the process may use, its address-space limit and the
    /// memory available). `cleave validate` prints a scene's estimate.
    #[arg(long, env = "CLEAVE_MAX_MEMORY", value_name = "BYTES")]
    max_memory: Option<u64>,
    /// Most jobs waiting in the queue.
    #[arg(long, env = "CLEAVE_MAX_QUEUED_JOBS", default_value_t = 100)]
    max_queued_jobs: usize,
    /// Largest request accepted, in bytes.
    #[arg(long, env = "CLEAVE_MAX_REQUEST_BYTES", default_value_t = 16 << 20)]
    max_request_bytes: usize,
    /// Seconds of wall time between a running job's checkpoints (0: none).
    /// A job with a checkpoint survives the server: the next server resumes
    /// it, with the results it would have had.
    #[arg(long, env = "CLEAVE_CHECKPOINT_EVERY", default_value_t = 600.0)]
    checkpoint_every: f64,
    /// PEM certificate chain for TLS (with --tls-key).
    #[arg(long, env = "CLEAVE_TLS_CERT", requires = "tls_key")]
    tls_cert: Option<PathBuf>,
    /// PEM private key for TLS.
    #[arg(long, env = "CLEAVE_TLS_KEY", requires = "tls_cert")]
    tls_key: Option<PathBuf>,
}

fn main() -> anyhow::Result<()> {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "info".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    let a = Args::parse();
    let threads = a
        .threads_per_job
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let config = ServerConfig {
        listen: a.listen,
        jobs: JobConfig {
            data_dir: a.data_dir,
            max_concurrent: a.max_concurrent_jobs.max(1),
            threads_per_job: threads.max(1),
            max_particles: a.max_particles,
            max_memory: a.max_memory,
            max_queued: a.max_queued_jobs,
            store: StoreSpec::parse(&a.store, a.lease).map_err(anyhow::Error::msg)?,
            results: ResultsSpec::parse(&a.results).map_err(anyhow::Error::msg)?,
            checkpoint_every: match cleave::checkpoint::CheckpointTimer::interval(
                a.checkpoint_every,
            )
            .map_err(anyhow::Error::msg)?
            {
                std::time::Duration::ZERO => None,
                every => Some(every),
            },
        },
        token: a.token.filter(|t| !t.is_empty()),
        max_request_bytes: a.max_request_bytes,
        tls: a.tls_cert.zip(a.tls_key),
    };
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    runtime.block_on(serve(config))
}
