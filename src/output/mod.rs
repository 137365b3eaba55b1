//! Results on disk: `series.csv`, VTK snapshots (`.vtp` particles, `.vti`
//! grid, `cracks_NNNN.vtp` polylines when a model draws lines, `.pvd`
//! collections that ParaView opens as a time series), with
//! damage a `fragments_NNNN.csv` per snapshot, and a PNG plot of the
//! energies.
//!
//! Entry point: [`OutputWriter`], an [`Observer`] for
//! [`Simulation::run`](crate::mpm::Simulation::run). Every file is written
//! atomically (a `.tmp` beside it, then a rename) and byte-for-byte
//! deterministic: no timestamps, no unordered maps.

mod plot;
mod vtk;

pub use plot::{
    plot_crack, plot_energies, plot_j_integral, plot_log_x, plot_pareto, plot_particle_field,
    plot_polar, Panel,
};
pub use vtk::{write_grid_vti, write_lines_vtp, write_particles_vtp, write_pvd};

use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::diagnostics::{Observer, SeriesRow, Snapshot};
use serde::Serialize;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// A file that could not be written (or read back).
///
/// Its message already holds the I/O error's, so that error is not also
/// given as the `source`: a chain printed whole (`{:#}`) would say it twice.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {error}")]
pub struct OutputError {
    pub path: PathBuf,
    pub error: std::io::Error,
}

impl OutputError {
    pub(crate) fn new(path: &Path, source: std::io::Error) -> OutputError {
        OutputError {
            path: path.to_path_buf(),
            error: source,
        }
    }
}

/// What a run wrote.
#[derive(Debug, Clone, Default, Serialize)]
pub struct OutputPaths {
    pub dir: PathBuf,
    pub series_csv: PathBuf,
    pub particles_pvd: Option<PathBuf>,
    pub grid_pvd: Option<PathBuf>,
    /// `cracks.pvd`, for runs whose snapshots have lines (explicit cracks);
    /// left out of the JSON without them, so a run without cracks reports
    /// what it always did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cracks_pvd: Option<PathBuf>,
    pub energy_plot: Option<PathBuf>,
    /// `crack.png`, for series with a crack tip.
    pub crack_plot: Option<PathBuf>,
    /// `j_integral.png`, for series with an explicit crack's tip J; left
    /// out of the JSON without one, so a run without cracks reports what
    /// it always did.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub j_plot: Option<PathBuf>,
    /// Snapshot files in the order written (particles, then grid, then
    /// cracks).
    pub snapshots: Vec<PathBuf>,
}

/// A run's `series.csv` cut back to the `bytes` it had at a checkpoint
/// and opened to append the rows that follow.
pub(crate) fn reopen_series(path: &Path, bytes: u64) -> Result<File, OutputError> {
    let io = |e| OutputError::new(path, e);
    let mut file = std::fs::OpenOptions::new()
        .write(true)
        .open(path)
        .map_err(io)?;
    let len = file.metadata().map_err(io)?.len();
    if len < bytes {
        let m = format!("{len} bytes, fewer than the {bytes} it had at the checkpoint");
        return Err(io(std::io::Error::new(std::io::ErrorKind::InvalidData, m)));
    }
    file.set_len(bytes).map_err(io)?;
    std::io::Seek::seek(&mut file, std::io::SeekFrom::End(0)).map_err(io)?;
    Ok(file)
}

/// The length of a series after flushing it: what [`reopen_series`] cuts
/// it back to.
pub(crate) fn flushed_len(series: &mut BufWriter<File>, path: &Path) -> Result<u64, OutputError> {
    let io = |e| OutputError::new(path, e);
    series.flush().map_err(io)?;
    Ok(series.get_ref().metadata().map_err(io)?.len())
}

/// Writes a checkpoint to `path` atomically ([`write_atomic`]): a crash
/// while writing leaves the previous checkpoint in place.
pub fn save_checkpoint(path: &Path, cp: &Checkpoint<'_>) -> Result<(), OutputError> {
    write_atomic(path, |w| {
        cp.write_to(w).map_err(|e| match e {
            CheckpointError::Io(e) => e,
            e => std::io::Error::other(e.to_string()),
        })
    })
}

/// The checkpoint's file name in an output directory (and a server job's).
pub const CHECKPOINT_FILE: &str = "checkpoint.bin";

/// What a checkpoint keeps of an [`OutputWriter`].
#[derive(serde::Serialize, serde::Deserialize)]
pub(crate) struct WriterState {
    columns: Vec<String>,
    rows: Vec<SeriesRow>,
    particle_entries: Vec<(f64, String)>,
    grid_entries: Vec<(f64, String)>,
    snapshots: Vec<PathBuf>,
    /// Length of `series.csv` at the checkpoint.
    series_bytes: u64,
}

/// Writes a run's results into a directory as they arrive.
pub struct OutputWriter {
    dir: PathBuf,
    series: BufWriter<File>,
    series_path: PathBuf,
    columns: Vec<String>,
    rows: Vec<SeriesRow>,
    particle_entries: Vec<(f64, String)>,
    grid_entries: Vec<(f64, String)>,
    /// `cracks_NNNN.vtp` files for `cracks.pvd`. Not in [`WriterState`]
    /// (which would change the checkpoint's format): a resumed writer
    /// finds them again from the particle entries and the files written
    /// ([`crack_entries`]).
    crack_entries: Vec<(f64, String)>,
    snapshots: Vec<PathBuf>,
    plots: Pictures,
}

impl OutputWriter {
    /// Creates `dir` (and parents) and `series.csv` (its header comes with
    /// [`Observer::series_columns`]).
    pub fn create(dir: &Path) -> Result<OutputWriter, OutputError> {
        std::fs::create_dir_all(dir).map_err(|e| OutputError::new(dir, e))?;
        let series_path = dir.join("series.csv");
        let file = File::create(&series_path).map_err(|e| OutputError::new(&series_path, e))?;
        let series = BufWriter::new(file);
        Ok(OutputWriter {
            dir: dir.to_path_buf(),
            series,
            series_path,
            columns: Vec::new(),
            rows: Vec::new(),
            particle_entries: Vec::new(),
            grid_entries: Vec::new(),
            crack_entries: Vec::new(),
            snapshots: Vec::new(),
            plots: Pictures::default(),
        })
    }

    /// The writer's state, for a checkpoint of the run (postcard bytes; see
    /// [`OutputWriter::resume`]). Flushes the series first.
    fn checkpoint_state(&mut self) -> Result<Vec<u8>, OutputError> {
        let bytes = flushed_len(&mut self.series, &self.series_path)?;
        let state = WriterState {
            columns: self.columns.clone(),
            rows: self.rows.clone(),
            particle_entries: self.particle_entries.clone(),
            grid_entries: self.grid_entries.clone(),
            snapshots: self.snapshots.clone(),
            series_bytes: bytes,
        };
        postcard::to_stdvec(&state)
            .map_err(|e| OutputError::new(&self.series_path, std::io::Error::other(e)))
    }

    /// Where [`Observer::checkpoint`] saves a run's checkpoint in its
    /// output directory.
    pub fn checkpoint_path(dir: &Path) -> PathBuf {
        dir.join(CHECKPOINT_FILE)
    }

    /// The checkpoint of the run in `dir` ([`OutputWriter::checkpoint_path`]).
    /// Resuming: [`Simulation::resume`](crate::mpm::Simulation::resume)
    /// with it (which checks it against the scene), then
    /// [`OutputWriter::resume`] with its `observer` bytes.
    pub fn load_checkpoint(dir: &Path) -> Result<Checkpoint<'static>, OutputError> {
        let path = Self::checkpoint_path(dir);
        Checkpoint::load(&path).map_err(|e| match e {
            CheckpointError::Io(e) => OutputError::new(&path, e),
            e => OutputError::new(
                &path,
                std::io::Error::new(std::io::ErrorKind::InvalidData, e.to_string()),
            ),
        })
    }

    /// The writer of a run resumed in `dir` from a checkpoint whose
    /// `observer` bytes are `state` ([`Observer::checkpoint`] of this
    /// writer): `series.csv` is cut back to the rows written up to the
    /// checkpoint (rows a lost later part of the run wrote are dropped; the
    /// resumed run writes them again) and goes on from there. Snapshot
    /// files of the lost part are overwritten as the resumed run reaches
    /// them.
    pub fn resume(dir: &Path, state: &[u8]) -> Result<OutputWriter, OutputError> {
        let series_path = dir.join("series.csv");
        let bad = |m: String| {
            OutputError::new(
                &series_path,
                std::io::Error::new(std::io::ErrorKind::InvalidData, m),
            )
        };
        let s: WriterState = postcard::from_bytes(state)
            .map_err(|e| bad(format!("the checkpoint's output state: {e}")))?;
        let file = reopen_series(&series_path, s.series_bytes)?;
        let crack_entries = crack_entries(&s.particle_entries, &s.snapshots);
        Ok(OutputWriter {
            dir: dir.to_path_buf(),
            series: BufWriter::new(file),
            series_path,
            columns: s.columns,
            rows: s.rows,
            particle_entries: s.particle_entries,
            grid_entries: s.grid_entries,
            crack_entries,
            snapshots: s.snapshots,
            plots: Pictures::default(),
        })
    }

    /// The run's last energy balance error relative to the largest total
    /// energy it reached ([`relative_energy_error`] of the rows so far).
    pub fn energy_error_relative(&self) -> Option<f64> {
        relative_energy_error(&self.rows)
    }

    /// Flushes the series and writes the `.pvd` collections and the plots.
    /// A plot that cannot be drawn is warned of and left out of the
    /// returned paths; an Err is a results file that
    /// could not be written.
    pub fn finish(mut self) -> Result<OutputPaths, OutputError> {
        self.series
            .flush()
            .map_err(|e| OutputError::new(&self.series_path, e))?;
        let mut paths = OutputPaths {
            dir: self.dir.clone(),
            series_csv: self.series_path.clone(),
            snapshots: std::mem::take(&mut self.snapshots),
            ..Default::default()
        };
        if !self.particle_entries.is_empty() {
            let p = self.dir.join("particles.pvd");
            write_pvd(&p, &self.particle_entries)?;
            paths.particles_pvd = Some(p);
        }
        if !self.grid_entries.is_empty() {
            let p = self.dir.join("grid.pvd");
            write_pvd(&p, &self.grid_entries)?;
            paths.grid_pvd = Some(p);
        }
        if !self.crack_entries.is_empty() {
            let p = self.dir.join("cracks.pvd");
            write_pvd(&p, &self.crack_entries)?;
            paths.cracks_pvd = Some(p);
        }
        let p = self.dir.join("energies.png");
        if self.plots.draw(&p, || plot_energies(&p, &self.rows)) {
            paths.energy_plot = Some(p);
        }
        let p = self.dir.join("crack.png");
        if self
            .plots
            .draw(&p, || plot_crack(&p, &self.columns, &self.rows))
        {
            paths.crack_plot = Some(p);
        }
        let p = self.dir.join("j_integral.png");
        if self
            .plots
            .draw(&p, || plot_j_integral(&p, &self.columns, &self.rows))
        {
            paths.j_plot = Some(p);
        }
        self.plots.summarize();
        Ok(paths)
    }
}

/// The pictures of a run, drawn so that none can fail it: a picture is a
/// view of results that are already on disk (`series.csv`, the VTK
/// files), so one that cannot be drawn (no room on the disk for it, a
/// path taken, a bug in the plotting library) is reported and left out,
/// and the run's exit status still says what the simulation did.
#[derive(Debug, Default)]
struct Pictures {
    /// Pictures not drawn so far; the first is reported with its reason,
    /// the rest counted, so that a run with a thousand snapshots does not
    /// repeat the same warning a thousand times.
    failed: usize,
}

impl Pictures {
    /// Runs `plot` for the picture at `path`: Ok(true) as true, Ok(false)
    /// (nothing to draw) as false, and an error or a panic as false with a
    /// warning naming the file and the reason.
    fn draw(&mut self, path: &Path, plot: impl FnOnce() -> Result<bool, OutputError>) -> bool {
        let reason = match std::panic::catch_unwind(std::panic::AssertUnwindSafe(plot)) {
            Ok(Ok(drawn)) => return drawn,
            Ok(Err(e)) => e.error.to_string(),
            Err(panic) => panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "the plotting library panicked".to_string()),
        };
        self.failed += 1;
        if self.failed == 1 {
            tracing::warn!(
                "{}: picture not drawn ({reason}); the run's other files are written",
                path.display()
            );
        }
        false
    }

    /// Warns of the pictures not drawn after the first (which was warned
    /// of with its reason).
    fn summarize(&self) {
        if self.failed > 1 {
            tracing::warn!(
                "{} more pictures were not drawn, for the same reason or another",
                self.failed - 1
            );
        }
    }
}

impl Observer for OutputWriter {
    fn series_columns(&mut self, columns: &[String]) -> Result<(), String> {
        self.columns = columns.to_vec();
        writeln!(self.series, "{}", columns.join(","))
            .map_err(|e| OutputError::new(&self.series_path, e).to_string())
    }

    fn series_row(&mut self, row: &SeriesRow) -> Result<(), String> {
        write_series_line(&mut self.series, row)
            .and_then(|_| self.series.flush())
            .map_err(|e| OutputError::new(&self.series_path, e).to_string())?;
        self.rows.push(row.clone());
        Ok(())
    }

    /// Saves the checkpoint, with this writer's state, in the output
    /// directory ([`OutputWriter::checkpoint_path`]), atomically: the
    /// previous one stays until the new one is whole.
    fn checkpoint(&mut self, mut cp: Checkpoint<'_>) -> Result<(), String> {
        cp.observer = self.checkpoint_state().map_err(|e| e.to_string())?;
        save_checkpoint(&Self::checkpoint_path(&self.dir), &cp).map_err(|e| e.to_string())
    }

    fn snapshot(&mut self, snap: &Snapshot) -> Result<(), String> {
        // an image of the phase field, damage or χ of every snapshot that has one
        for field in ["phase_field", "damage", "chi"] {
            let image = self.dir.join(format!("{field}_{:04}.png", snap.index));
            if self.plots.draw(&image, || {
                plot_particle_field(&image, snap, field, 0.0, 1.0)
            }) {
                self.snapshots.push(image);
            }
        }
        let path = self.dir.join(format!("fragments_{:04}.csv", snap.index));
        let written = match snap.dimension {
            3 => crate::diagnostics::fragments::from_snapshot::<3>(snap)
                .map(|list| write_fragments_csv(&path, &list)),
            _ => crate::diagnostics::fragments::from_snapshot::<2>(snap)
                .map(|list| write_fragments_csv(&path, &list)),
        };
        if let Some(w) = written {
            w.map_err(|e| e.to_string())?;
            self.snapshots.push(path);
        }
        let name = format!("particles_{:04}.vtp", snap.index);
        let path = self.dir.join(&name);
        write_particles_vtp(&path, snap).map_err(|e| e.to_string())?;
        self.particle_entries.push((snap.time, name));
        self.snapshots.push(path);
        if let Some(grid) = &snap.grid {
            let name = format!("grid_{:04}.vti", snap.index);
            let path = self.dir.join(&name);
            write_grid_vti(&path, grid).map_err(|e| e.to_string())?;
            self.grid_entries.push((snap.time, name));
            self.snapshots.push(path);
        }
        if !snap.lines.is_empty() {
            let name = crack_file(snap.index);
            let path = self.dir.join(&name);
            write_lines_vtp(&path, &snap.lines).map_err(|e| e.to_string())?;
            self.crack_entries.push((snap.time, name));
            self.snapshots.push(path);
        }
        Ok(())
    }
}

/// The lines' file of snapshot `index`, beside its `particles_NNNN.vtp`.
fn crack_file(index: u32) -> String {
    format!("cracks_{index:04}.vtp")
}

/// The `cracks.pvd` entries of a writer resumed from a checkpoint: a
/// snapshot with lines wrote its `cracks_NNNN.vtp` beside its particles, at
/// the particles' time, and listed it among the files written; so the
/// snapshots whose crack file is listed are the entries, in their order.
/// File names are compared, not paths, so that a run moved to another
/// directory between its checkpoint and its resume keeps them.
fn crack_entries(particles: &[(f64, String)], written: &[PathBuf]) -> Vec<(f64, String)> {
    let written: std::collections::BTreeSet<&std::ffi::OsStr> =
        written.iter().filter_map(|p| p.file_name()).collect();
    particles
        .iter()
        .filter_map(|(t, name)| {
            let crack = format!("cracks_{}", name.strip_prefix("particles_")?);
            written
                .contains(std::ffi::OsStr::new(&crack))
                .then_some((*t, crack))
        })
        .collect()
}

/// The energy balance error of a series' last row (`energy_error`, an
/// absolute error in J: kinetic + strain − initial − external work)
/// divided by the largest total energy |kinetic + strain| of any row, so
/// that runs of different sizes compare: 0.01 is a loss of 1 % of the
/// energy in play. None without rows; a run that never had energy divides
/// by the smallest positive number, and so shows any error as huge.
pub fn relative_energy_error(rows: &[SeriesRow]) -> Option<f64> {
    let last = rows.last()?;
    let scale = rows
        .iter()
        .map(|r| (r.kinetic_energy + r.strain_energy).abs())
        .filter(|e| e.is_finite())
        .fold(0.0f64, f64::max)
        .max(f64::MIN_POSITIVE);
    Some(last.energy_error / scale)
}

/// The fragments of one snapshot, largest first: one row per fragment
/// (its number is the `fragment` label of its particles in the snapshot).
pub fn write_fragments_csv<const D: usize>(
    path: &Path,
    list: &[crate::diagnostics::fragments::Fragment<D>],
) -> Result<(), OutputError> {
    write_atomic(path, |w| {
        write!(w, "fragment,particles,mass,volume,speed")?;
        for axis in ["x", "y", "z"].iter().take(D) {
            write!(w, ",centroid_{axis}")?;
        }
        writeln!(w)?;
        for (k, f) in list.iter().enumerate() {
            write!(
                w,
                "{k},{},{:?},{:?},{:?}",
                f.particles, f.mass, f.volume, f.speed
            )?;
            for c in f.centroid {
                write!(w, ",{c:?}")?;
            }
            writeln!(w)?;
        }
        Ok(())
    })
}

/// One CSV line: the step as an integer, floats in shortest round-trip form.
pub(crate) fn write_series_line(w: &mut impl Write, row: &SeriesRow) -> std::io::Result<()> {
    let v = row.values();
    write!(w, "{}", row.step)?;
    for x in &v[1..] {
        write!(w, ",{x:?}")?;
    }
    writeln!(w)
}

/// Writes a whole series to `path` (atomically), as [`OutputWriter`] does.
pub fn write_series_csv(
    path: &Path,
    columns: &[String],
    rows: &[SeriesRow],
) -> Result<(), OutputError> {
    write_atomic(path, |w| {
        writeln!(w, "{}", columns.join(","))?;
        for r in rows {
            write_series_line(w, r)?;
        }
        Ok(())
    })
}

/// Reads the `series.csv` at `path` ([`parse_series`]); a file that is not
/// a series is an `InvalidData` error naming the path.
pub fn read_series(path: &Path) -> Result<(Vec<String>, Vec<SeriesRow>), OutputError> {
    let text = std::fs::read_to_string(path).map_err(|e| OutputError::new(path, e))?;
    parse_series(&text).map_err(|m| {
        OutputError::new(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidData, m),
        )
    })
}

/// Reads a `series.csv` back: its columns (the core ones of
/// [`SeriesRow::COLUMNS`] first, then the scene's) and rows. A file without
/// a header yet (a job that failed before its first row) has the core
/// columns and no rows; a last row cut short by a crash is dropped.
pub fn parse_series(text: &str) -> Result<(Vec<String>, Vec<SeriesRow>), String> {
    let mut lines = text.lines();
    let Some(header) = lines.next() else {
        return Ok((
            SeriesRow::COLUMNS.iter().map(|c| c.to_string()).collect(),
            Vec::new(),
        ));
    };
    let columns: Vec<String> = header.split(',').map(str::to_string).collect();
    if columns.len() < SeriesRow::COLUMNS.len()
        || columns[..SeriesRow::COLUMNS.len()] != SeriesRow::COLUMNS
    {
        return Err(format!("unexpected columns {header:?}"));
    }
    let mut rows = Vec::new();
    for line in lines {
        let v: Vec<f64> = match line
            .split(',')
            .map(|x| x.parse::<f64>())
            .collect::<Result<_, _>>()
        {
            Ok(v) => v,
            Err(_) => break,
        };
        if v.len() != columns.len() {
            break;
        }
        rows.extend(SeriesRow::from_values(&v));
    }
    Ok((columns, rows))
}

/// Writes through `fill` into `path.tmp`, then renames it over `path`.
pub(crate) fn write_atomic(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), OutputError> {
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = PathBuf::from(tmp);
    let result = (|| {
        let mut w = BufWriter::new(File::create(&tmp)?);
        fill(&mut w)?;
        w.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        OutputError::new(path, e)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnostics::{Field, FieldData};

    /// A snapshot of four particles with a phase field.
    fn snapshot() -> Snapshot {
        Snapshot {
            index: 0,
            step: 0,
            time: 0.0,
            dimension: 2,
            positions: vec![
                [0.0, 0.0, 0.0],
                [1e-3, 0.0, 0.0],
                [0.0, 1e-3, 0.0],
                [1e-3, 1e-3, 0.0],
            ],
            fields: vec![Field {
                name: "phase_field".into(),
                components: 1,
                data: FieldData::F64(vec![1.0, 0.5, 0.0, 1.0]),
            }],
            grid: None,
            lines: Vec::new(),
        }
    }

    #[test]
    fn a_picture_that_cannot_be_drawn_fails_nothing_else() {
        let dir = tempfile::tempdir().unwrap();
        // A directory where each picture goes: the picture is drawn, but
        // cannot take its place.
        for taken in ["energies.png", "phase_field_0000.png"] {
            std::fs::create_dir(dir.path().join(taken)).unwrap();
            std::fs::write(dir.path().join(taken).join("x"), b"x").unwrap();
        }
        let mut w = OutputWriter::create(dir.path()).unwrap();
        let columns: Vec<String> = SeriesRow::COLUMNS.iter().map(|c| c.to_string()).collect();
        w.series_columns(&columns).unwrap();
        for k in 0..3 {
            let row = SeriesRow {
                step: k,
                time: k as f64 * 1e-6,
                kinetic_energy: k as f64,
                ..Default::default()
            };
            w.series_row(&row).unwrap();
        }
        w.snapshot(&snapshot()).unwrap();
        let paths = w.finish().unwrap();

        assert_eq!(paths.energy_plot, None);
        assert!(!paths
            .snapshots
            .iter()
            .any(|p| p.ends_with("phase_field_0000.png")));
        let series = std::fs::read_to_string(dir.path().join("series.csv")).unwrap();
        assert_eq!(series.lines().count(), 4);
        assert!(dir.path().join("particles.pvd").is_file());
        assert!(dir.path().join("particles_0000.vtp").is_file());
        // no half-drawn picture left behind
        for e in std::fs::read_dir(dir.path()).unwrap() {
            let name = e.unwrap().file_name();
            assert!(!name.to_string_lossy().contains(".tmp"), "{name:?} left");
        }
    }

    /// A resumed writer's crack entries: the snapshots whose crack file
    /// was written, at their particles' times, by file name (the run may
    /// have moved since).
    #[test]
    fn crack_entries_come_back_from_the_files_written() {
        let particles = [
            (0.0, "particles_0000.vtp".to_string()),
            (1e-5, "particles_0001.vtp".to_string()),
            (2e-5, "particles_0002.vtp".to_string()),
        ];
        let written = [
            PathBuf::from("/old/particles_0000.vtp"),
            PathBuf::from("/old/cracks_0000.vtp"),
            PathBuf::from("/old/particles_0001.vtp"),
            PathBuf::from("/old/particles_0002.vtp"),
            PathBuf::from("/old/grid_0002.vti"),
            PathBuf::from("/old/cracks_0002.vtp"),
        ];
        assert_eq!(
            crack_entries(&particles, &written),
            [
                (0.0, "cracks_0000.vtp".to_string()),
                (2e-5, "cracks_0002.vtp".to_string())
            ]
        );
        assert_eq!(crack_entries(&particles, &written[2..5]), []);
    }

    #[test]
    fn energy_error_relative_to_the_largest_energy_reached() {
        assert_eq!(relative_energy_error(&[]), None);
        let row = |k: f64, s: f64, err: f64| SeriesRow {
            kinetic_energy: k,
            strain_energy: s,
            energy_error: err,
            ..Default::default()
        };
        // 4 J at most (not the last row's 2 J); −0.1 J lost at the end
        let rows = [row(3.0, 1.0, 0.0), row(1.0, 1.0, 0.0), row(1.5, 0.5, -0.1)];
        assert_eq!(relative_energy_error(&rows), Some(-0.1 / 4.0));
        let still = [row(0.0, 0.0, 0.0)];
        assert_eq!(relative_energy_error(&still), Some(0.0));
    }

    #[test]
    fn pictures_report_errors_and_panics_as_not_drawn() {
        let mut p = Pictures::default();
        let path = Path::new("a.png");
        assert!(p.draw(path, || Ok(true)));
        assert!(!p.draw(path, || Ok(false)));
        assert_eq!(p.failed, 0);
        let e = || Err(OutputError::new(path, std::io::Error::other("no room")));
        assert!(!p.draw(path, e));
        assert!(!p.draw(path, || panic!("a bug in the plotting library")));
        assert_eq!(p.failed, 2);
    }

    #[test]
    fn csv_round_trips_bit_for_bit() {
        let dir = tempfile::tempdir().unwrap();
        let rows: Vec<SeriesRow> = (0..5)
            .map(|k| SeriesRow {
                step: k,
                time: k as f64 * 1.0e-7 / 3.0,
                kinetic_energy: 0.1 + k as f64 / 7.0,
                strain_energy: 1e-300,
                momentum_x: -2.5e12,
                extra: vec![f64::NAN, 3.0e-9 * k as f64],
                ..Default::default()
            })
            .collect();
        let p = dir.path().join("s.csv");
        let mut columns: Vec<String> = SeriesRow::COLUMNS.iter().map(|c| c.to_string()).collect();
        columns.extend(["a".to_string(), "b".to_string()]);
        write_series_csv(&p, &columns, &rows).unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next().unwrap(), columns.join(","));
        for (line, row) in lines.zip(&rows) {
            let parsed: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
            let want = row.values();
            assert_eq!(parsed.len(), 14);
            assert_eq!(
                SeriesRow::from_values(&parsed)
                    .as_ref()
                    .map(|r| r.extra.len()),
                Some(2)
            );
            for (a, b) in parsed.iter().zip(want.iter()) {
                assert_eq!(a.to_bits(), b.to_bits());
            }
        }
    }
}
