//! What the end-to-end tests that start `cleave-server` processes share:
//! the binaries, a server on a free loopback port, and comparing output
//! directories byte for byte.

// each test crate uses part of it
#![allow(dead_code)]

use cleave::service::proto::cleave_client::CleaveClient;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};

pub fn cleave_bin() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_cleave"))
}

/// The server binary is built beside the client by `cargo test --workspace`.
pub fn server_bin() -> PathBuf {
    let p = cleave_bin().with_file_name(format!("cleave-server{}", std::env::consts::EXE_SUFFIX));
    assert!(
        p.exists(),
        "{} is missing: run the tests with `cargo test --release --workspace`",
        p.display()
    );
    p
}

/// A `cleave-server` process on a free loopback port, one runner of one
/// thread unless `extra` says otherwise; killed when dropped.
pub struct Server {
    pub child: Child,
    pub url: String,
    pub data: PathBuf,
}

impl Server {
    pub fn start(data: &Path, extra: &[&str]) -> Server {
        Server::start_in(data, extra, &[])
    }

    /// A server with more environment variables (a bucket's credentials).
    pub fn start_in(data: &Path, extra: &[&str], env: &[(&str, String)]) -> Server {
        let mut child = Command::new(server_bin())
            .args(["--listen", "127.0.0.1:0", "--data-dir"])
            .arg(data)
            .args(["--threads-per-job", "1"])
            .args(extra)
            .envs(env.iter().map(|(k, v)| (k, v)))
            .env("RUST_LOG", "warn")
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("start cleave-server");
        let mut line = String::new();
        let stdout = child.stdout.take().expect("server stdout");
        BufReader::new(stdout)
            .read_line(&mut line)
            .expect("read the listening line");
        let addr = line
            .trim()
            .strip_prefix("listening on ")
            .unwrap_or_else(|| panic!("unexpected server output {line:?}"))
            .to_string();
        Server {
            child,
            url: format!("http://{addr}"),
            data: data.to_path_buf(),
        }
    }

    /// `cleave --server URL ARGS…`.
    pub fn cli(&self, args: &[&str]) -> Output {
        Command::new(cleave_bin())
            .arg("--server")
            .arg(&self.url)
            .args(args)
            .output()
            .expect("run cleave")
    }

    pub async fn client(&self) -> CleaveClient<tonic::transport::Channel> {
        CleaveClient::connect(self.url.clone())
            .await
            .expect("connect")
            .max_decoding_message_size(usize::MAX)
    }

    /// Its name in a fleet's claims ends with this: `-PID`.
    pub fn pid_suffix(&self) -> String {
        format!("-{}", self.child.id())
    }

    /// SIGKILL.
    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.kill();
    }
}

/// Every file of `a` (at least `at_least` of them) is in `b` with the
/// same bytes.
pub fn same_files(a: &Path, b: &Path, at_least: usize) {
    let mut names: Vec<_> = std::fs::read_dir(a)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    names.sort();
    assert!(names.len() >= at_least, "too few files in {}", a.display());
    for n in names {
        let (x, y) = (
            std::fs::read(a.join(&n)).unwrap(),
            std::fs::read(b.join(&n)).unwrap_or_default(),
        );
        assert!(
            x == y,
            "{n:?} differs between {} and {}",
            a.display(),
            b.display()
        );
    }
}

/// Each run's metric and steps, as a study's JSON gives them.
pub type Metrics = Vec<(serde_json::Value, serde_json::Value)>;

/// Each run's metric and steps from `cleave study --json`'s output, which
/// must have succeeded.
pub fn study_metrics(o: &Output) -> Metrics {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value =
        serde_json::from_str(String::from_utf8_lossy(&o.stdout).trim()).unwrap();
    v["runs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| (r["metric"].clone(), r["steps"].clone()))
        .collect()
}

/// `cleave study SCENE --vary VARY --metric METRIC --json` embedded (into
/// `dir/local`) and against `server` (into `dir/remote`): each one's
/// [`study_metrics`], and the arguments of the remote study.
pub fn study_here_and_on(
    server: &Server,
    scene: &Path,
    vary: &str,
    metric: &str,
    dir: &Path,
) -> (Metrics, Metrics, Vec<String>) {
    let args = |out: &Path| -> Vec<String> {
        [
            "study",
            &scene.to_string_lossy(),
            "--vary",
            vary,
            "--metric",
            metric,
            "--json",
            "--out",
        ]
        .iter()
        .map(|s| s.to_string())
        .chain([out.to_string_lossy().into_owned()])
        .collect()
    };
    let local = Command::new(cleave_bin())
        .args(args(&dir.join("local")))
        .output()
        .unwrap();
    let remote_args = args(&dir.join("remote"));
    let remote = server.cli(&remote_args.iter().map(String::as_str).collect::<Vec<_>>());
    (study_metrics(&local), study_metrics(&remote), remote_args)
}
