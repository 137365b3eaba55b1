//! Where a job's result files live for every server to read: the data
//! directory (one server, or a fleet sharing a file system), or an
//! S3-compatible bucket through the `object_store` crate.
//!
//! With a bucket, a worker still writes the job's files into its own data
//! directory, as with a directory, and copies them up: a snapshot when it
//! is written, the series and then the checkpoint at each checkpoint (so
//! that a checkpoint in the bucket never names series bytes the bucket
//! lacks), the series at the end. A worker that takes a job over first
//! copies the job's files down, and resumes from the checkpoint among
//! them. A bucket's `PUT` is atomic (a multipart upload completes at once),
//! so a reader sees a file whole or not at all, as with the directory's
//! write-and-rename. The API reads through a cache of its own under the
//! data directory (`cache/jobs/ID/`), never the worker's files.
//!
//! While a job runs on another server, its series in the bucket is the one
//! of its last checkpoint (the directory's grows row by row); its
//! snapshots appear as they are written.

use super::JobError;
use object_store::aws::AmazonS3Builder;
use object_store::path::Path as Key;
use object_store::{ObjectStore, ObjectStoreExt};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, OnceLock};
use tokio::io::AsyncWriteExt;
use tokio_stream::StreamExt;

/// Where the result files live.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum ResultsSpec {
    /// `jobs/ID/` in the data directory.
    #[default]
    DataDir,
    /// `s3://BUCKET/PREFIX`: objects `PREFIX/jobs/ID/NAME`. The endpoint,
    /// region and credentials come from the usual `AWS_*` environment
    /// variables (`AWS_ENDPOINT`, `AWS_REGION`, `AWS_ACCESS_KEY_ID`,
    /// `AWS_SECRET_ACCESS_KEY`, `AWS_ALLOW_HTTP`, …).
    Bucket { url: String },
}

impl ResultsSpec {
    /// `data-dir` (or empty) or an `s3://bucket[/prefix]` URL.
    pub fn parse(text: &str) -> Result<ResultsSpec, String> {
        let t = text.trim();
        if t.is_empty() || t == "data-dir" {
            return Ok(ResultsSpec::DataDir);
        }
        match t.strip_prefix("s3://") {
            Some(rest) if !rest.is_empty() && !rest.starts_with('/') => {
                Ok(ResultsSpec::Bucket { url: t.to_string() })
            }
            _ => Err(format!(
                "--results: {t:?} is neither `data-dir` nor an S3 URL (s3://bucket/prefix)"
            )),
        }
    }
}

/// The runtime of the bucket's calls: one per process, never dropped (a
/// runtime may not be dropped on an async thread, where the last handle
/// of a job manager may go).
fn runtime() -> Result<&'static tokio::runtime::Runtime, JobError> {
    static RT: OnceLock<Result<tokio::runtime::Runtime, String>> = OnceLock::new();
    RT.get_or_init(|| {
        tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .thread_name("cleave-bucket")
            .enable_all()
            .build()
            .map_err(|e| format!("cannot start the bucket's runtime: {e}"))
    })
    .as_ref()
    .map_err(|e| JobError::Store(e.clone()))
}

/// An S3-compatible bucket of result files. Its calls block (they are
/// made from runner threads and the service's blocking tasks).
pub struct Bucket {
    store: Arc<dyn ObjectStore>,
    /// The bucket's URL, for messages.
    url: String,
    /// Key prefix of the results (empty: the bucket's root).
    prefix: String,
    /// The API's copies of result files.
    cache: PathBuf,
}

/// An object of a job: its file name and size in bytes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Object {
    pub name: String,
    pub size: u64,
}

impl Bucket {
    /// Opens `s3://BUCKET/PREFIX` with the `AWS_*` environment and checks
    /// that it takes writes (a marker object, `PREFIX/cleave-results`).
    /// `data_dir` holds the API's cache.
    pub fn open(url: &str, data_dir: &Path) -> Result<Bucket, JobError> {
        // reqwest's rustls takes the process's crypto provider; the
        // service's TLS already uses ring (an error: one is installed)
        let _ = rustls::crypto::ring::default_provider().install_default();
        let rest = url.strip_prefix("s3://").unwrap_or(url);
        let prefix = rest.split_once('/').map_or("", |(_, p)| p);
        let store = AmazonS3Builder::from_env()
            .with_url(url)
            .build()
            .map_err(|e| JobError::Store(format!("--results {url}: {e}")))?;
        let bucket = Bucket {
            store: Arc::new(store),
            url: url.to_string(),
            prefix: prefix.trim_matches('/').to_string(),
            cache: data_dir.join("cache").join("jobs"),
        };
        // a marker written at start: the bucket exists and takes writes
        let marker = bucket.dir_key("").join("cleave-results");
        runtime()?
            .block_on(bucket.store.put(
                &marker,
                object_store::PutPayload::from_static(b"cleave results\n"),
            ))
            .map_err(|e| JobError::Store(format!("--results {url}: cannot write to it: {e}")))?;
        Ok(bucket)
    }

    fn key(&self, id: &str, name: &str) -> Key {
        self.dir_key(id).join(name)
    }

    fn dir_key(&self, id: &str) -> Key {
        let mut k = Key::from(self.prefix.as_str());
        if !id.is_empty() {
            k = k.join("jobs").join(id);
        }
        k
    }

    fn err(&self, what: &str, e: impl std::fmt::Display) -> JobError {
        JobError::Unavailable(format!("results bucket {}: {what}: {e}", self.url))
    }

    /// The files of job `id` in the bucket, by name.
    pub fn objects(&self, id: &str) -> Result<Vec<Object>, JobError> {
        let dir = self.dir_key(id);
        runtime()?.block_on(async {
            let mut out = Vec::new();
            let mut s = self.store.list(Some(&dir));
            while let Some(meta) = s.next().await {
                let meta = meta.map_err(|e| self.err("list", e))?;
                // only the job's own files, not those of deeper keys
                let name = meta.location.filename().unwrap_or_default();
                if meta.location == dir.clone().join(name) {
                    out.push(Object {
                        name: name.to_string(),
                        size: meta.size,
                    });
                }
            }
            out.sort_by(|a, b| a.name.cmp(&b.name));
            Ok(out)
        })
    }

    /// Copies the local file `file` up as job `id`'s object of the same
    /// name (a multipart upload beyond 10 MiB: it too appears whole).
    pub fn put_file(&self, id: &str, file: &Path) -> Result<(), JobError> {
        let name = file
            .file_name()
            .and_then(|n| n.to_str())
            .ok_or_else(|| JobError::Store(format!("{}: no file name", file.display())))?;
        let key = self.key(id, name);
        let mut src = std::fs::File::open(file)
            .map_err(|e| JobError::Store(format!("{}: {e}", file.display())))?;
        runtime()?.block_on(async {
            let mut w = object_store::buffered::BufWriter::new(self.store.clone(), key);
            let mut buf = vec![0u8; 1 << 20];
            let copied = async {
                loop {
                    let n = std::io::Read::read(&mut src, &mut buf)
                        .map_err(|e| JobError::Store(format!("{}: {e}", file.display())))?;
                    if n == 0 {
                        break;
                    }
                    w.write_all(&buf[..n])
                        .await
                        .map_err(|e| self.err(&format!("put {name}"), e))?;
                }
                w.shutdown()
                    .await
                    .map_err(|e| self.err(&format!("put {name}"), e))
            }
            .await;
            if copied.is_err() {
                // a multipart upload begun is not left behind
                let _ = w.abort().await;
            }
            copied
        })
    }

    /// Removes job `id`'s object `name` (gone already: fine).
    pub fn delete(&self, id: &str, name: &str) -> Result<(), JobError> {
        let key = self.key(id, name);
        runtime()?.block_on(async {
            match self.store.delete(&key).await {
                Ok(()) | Err(object_store::Error::NotFound { .. }) => Ok(()),
                Err(e) => Err(self.err(&format!("delete {name}"), e)),
            }
        })
    }

    /// Downloads job `id`'s object `name` to `to`, written beside it and
    /// renamed; false if there is no such object. (The file beside it has
    /// a name of its own per call: two API calls may fetch one series.)
    fn get_to(&self, id: &str, name: &str, to: &Path) -> Result<bool, JobError> {
        static CALLS: AtomicU64 = AtomicU64::new(0);
        let key = self.key(id, name);
        let mut tmp = to.as_os_str().to_owned();
        tmp.push(format!(
            ".{}-{}.part",
            std::process::id(),
            CALLS.fetch_add(1, Ordering::Relaxed)
        ));
        let tmp = PathBuf::from(tmp);
        let local = |e: std::io::Error| JobError::Store(format!("{}: {e}", tmp.display()));
        let found = runtime()?.block_on(async {
            let got = match self.store.get(&key).await {
                Ok(g) => g,
                Err(object_store::Error::NotFound { .. }) => return Ok(false),
                Err(e) => return Err(self.err(&format!("get {name}"), e)),
            };
            let mut out = std::io::BufWriter::new(std::fs::File::create(&tmp).map_err(local)?);
            let mut s = got.into_stream();
            while let Some(chunk) = s.next().await {
                let chunk = chunk.map_err(|e| self.err(&format!("get {name}"), e))?;
                std::io::Write::write_all(&mut out, &chunk).map_err(local)?;
            }
            std::io::Write::flush(&mut out).map_err(local)?;
            Ok(true)
        });
        match found {
            Ok(true) => std::fs::rename(&tmp, to)
                .map(|_| true)
                .map_err(|e| JobError::Store(format!("{}: {e}", to.display()))),
            other => {
                let _ = std::fs::remove_file(&tmp);
                other
            }
        }
    }

    /// Makes `dir` hold job `id`'s files as the bucket has them: a worker
    /// about to run the job (perhaps another's, taken over) starts from
    /// them. Local result files the bucket lacks are removed.
    pub fn pull(&self, id: &str, dir: &Path) -> Result<(), JobError> {
        let objects = self.objects(id)?;
        if let Ok(entries) = std::fs::read_dir(dir) {
            for e in entries.flatten() {
                let name = e.file_name();
                let name = name.to_string_lossy();
                if !objects.iter().any(|o| o.name == name) {
                    let _ = std::fs::remove_file(e.path());
                }
            }
        }
        for o in &objects {
            self.get_to(id, &o.name, &dir.join(&o.name))?;
        }
        Ok(())
    }

    /// The API's copy of job `id`'s file `name`, fetched now (None: the
    /// bucket has no such file). `fresh`: fetch it even if a copy is
    /// cached (a series grows; a snapshot, once written, does not).
    pub fn cached(&self, id: &str, name: &str, fresh: bool) -> Result<Option<PathBuf>, JobError> {
        let dir = self.cache.join(id);
        let path = dir.join(name);
        if !fresh && path.exists() {
            return Ok(Some(path));
        }
        std::fs::create_dir_all(&dir)
            .map_err(|e| JobError::Store(format!("{}: {e}", dir.display())))?;
        Ok(self.get_to(id, name, &path)?.then_some(path))
    }
}

impl std::fmt::Debug for Bucket {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Bucket").field("url", &self.url).finish()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_results_flag_names_what_it_refuses() {
        assert_eq!(ResultsSpec::parse(""), Ok(ResultsSpec::DataDir));
        assert_eq!(ResultsSpec::parse("data-dir"), Ok(ResultsSpec::DataDir));
        assert_eq!(
            ResultsSpec::parse("s3://bucket/runs/a"),
            Ok(ResultsSpec::Bucket {
                url: "s3://bucket/runs/a".into()
            })
        );
        for bad in ["s3://", "s3:///x", "/mnt/shared", "gs://b"] {
            let e = ResultsSpec::parse(bad).unwrap_err();
            assert!(e.starts_with("--results:") && e.contains("s3://"), "{e}");
        }
    }
}
