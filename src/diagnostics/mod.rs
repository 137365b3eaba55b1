//! What a run reports: time-series rows, snapshots of particle and grid
//! fields, progress, and the final summary. The engine fills these; the
//! output writers and (later) the job runner consume them through
//! [`Observer`].

use serde::Serialize;

/// One row of the time series (`series.csv`). Energies are per the analysis
/// thickness (J for plane stress with a thickness, J/m for plane strain with
/// the default 1 m).
///
/// The first twelve columns ([`SeriesRow::COLUMNS`]) are in every series;
/// `extra` holds the columns of the stages a scene has (e.g. the phase
/// field's solver times and crack tip), named by
/// [`Simulation::series_columns`](crate::mpm::Simulation::series_columns).
#[derive(Debug, Clone, Default, PartialEq, Serialize, serde::Deserialize)]
pub struct SeriesRow {
    pub step: u64,
    /// Simulated time, s.
    pub time: f64,
    /// Σ ½ m_p |v_p|², J.
    pub kinetic_energy: f64,
    /// Σ V_p ψ_p (stored elastic energy), J.
    pub strain_energy: f64,
    /// Work done on the system by body forces, tractions and prescribed
    /// velocities since t = 0, J.
    pub external_work: f64,
    /// kinetic + strain − initial (kinetic + strain) − external work, J:
    /// zero for a conservative scheme, negative when energy is dissipated.
    pub energy_error: f64,
    /// Σ m_p, kg.
    pub total_mass: f64,
    /// Σ m_p v_p, kg·m/s.
    pub momentum_x: f64,
    pub momentum_y: f64,
    /// Σ m_p (x_p × v_p) about the origin (plus the APIC affine spin term
    /// with B-splines), kg·m²/s.
    pub angular_momentum: f64,
    /// The time step used for the last step, s.
    pub dt: f64,
    /// Ψ_f = Σ Ḡc Z V over phase-field bodies (Kakouris & Triantafyllou, eq. 3), J; zero
    /// without a fracture model.
    pub fracture_energy: f64,
    /// The scene's stage-specific columns, after the core ones.
    pub extra: Vec<f64>,
}

impl SeriesRow {
    /// Column names in the order of [`SeriesRow::values`].
    pub const COLUMNS: [&'static str; 12] = [
        "step",
        "time",
        "kinetic_energy",
        "strain_energy",
        "external_work",
        "energy_error",
        "total_mass",
        "momentum_x",
        "momentum_y",
        "angular_momentum",
        "dt",
        "fracture_energy",
    ];

    /// The row back from [`SeriesRow::values`]; None if `v` is shorter
    /// than the core columns. Values past them become `extra`.
    /// The columns a 3D run adds right after [`SeriesRow::COLUMNS`]
    /// (`angular_momentum` is then |L|).
    pub const COLUMNS_3D: [&'static str; 4] = [
        "momentum_z",
        "angular_momentum_x",
        "angular_momentum_y",
        "angular_momentum_z",
    ];

    pub fn from_values(v: &[f64]) -> Option<SeriesRow> {
        if v.len() < Self::COLUMNS.len() {
            return None;
        }
        Some(SeriesRow {
            step: v[0] as u64,
            time: v[1],
            kinetic_energy: v[2],
            strain_energy: v[3],
            external_work: v[4],
            energy_error: v[5],
            total_mass: v[6],
            momentum_x: v[7],
            momentum_y: v[8],
            angular_momentum: v[9],
            dt: v[10],
            fracture_energy: v[11],
            extra: v[12..].to_vec(),
        })
    }

    /// The row's values: [`SeriesRow::COLUMNS`], then `extra`.
    pub fn values(&self) -> Vec<f64> {
        let mut v = vec![
            self.step as f64,
            self.time,
            self.kinetic_energy,
            self.strain_energy,
            self.external_work,
            self.energy_error,
            self.total_mass,
            self.momentum_x,
            self.momentum_y,
            self.angular_momentum,
            self.dt,
            self.fracture_energy,
        ];
        v.extend_from_slice(&self.extra);
        v
    }

    /// The value of a named column of a series with `columns`.
    pub fn get(&self, columns: &[String], name: &str) -> Option<f64> {
        let i = columns.iter().position(|c| c == name)?;
        match i.checked_sub(Self::COLUMNS.len()) {
            None => Some(self.values()[i]),
            Some(k) => self.extra.get(k).copied(),
        }
    }
}

/// Values of one named field, `components` numbers per point, point-major.
#[derive(Debug, Clone, PartialEq)]
pub enum FieldData {
    F64(Vec<f64>),
    U32(Vec<u32>),
}

impl FieldData {
    pub fn len(&self) -> usize {
        match self {
            FieldData::F64(v) => v.len(),
            FieldData::U32(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A named field on particles or grid nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    /// e.g. `velocity`, `stress`, `particle_id`.
    pub name: String,
    /// Numbers per point: 1 a scalar; 2 a 2D vector (x, y); 3 a 3D vector;
    /// 4 a 2D run's symmetric tensor with its out-of-plane normal
    /// component, (xx, yy, xy, zz); 6 a 3D symmetric tensor in VTK's
    /// order, (xx, yy, zz, xy, yz, xz).
    pub components: usize,
    pub data: FieldData,
}

/// Grid fields of a snapshot on the uniform node lattice.
#[derive(Debug, Clone, PartialEq)]
pub struct GridSnapshot {
    /// Coordinates of node (0, 0, 0), m (z = 0 in 2D).
    pub origin: [f64; 3],
    /// Node spacing, m.
    pub spacing: f64,
    /// Nodes along x, y and z (1 in 2D); node (i, j, k) has index
    /// i + dims[0]·(j + dims[1]·k).
    pub dims: [usize; 3],
    /// Nodal fields (e.g. `mass`, `velocity`), summed over velocity fields.
    pub fields: Vec<Field>,
}

/// Particle (and optionally grid) fields at one instant.
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// 0, 1, 2, ... in the order written.
    pub index: u32,
    pub step: u64,
    pub time: f64,
    /// The run's dimension, 2 or 3: the number of components of a
    /// position and of a vector field.
    pub dimension: usize,
    /// Particle positions, m (x, y, z; z = 0 in 2D).
    pub positions: Vec<[f64; 3]>,
    /// Particle fields: velocity, stress, strain, mass, volume, material_id,
    /// body_id, particle_id, ...
    pub fields: Vec<Field>,
    pub grid: Option<GridSnapshot>,
    /// Polylines a fracture model draws (explicit cracks' planes and
    /// surfaces), in the models' order; empty for a scene without them,
    /// which then writes no line files.
    pub lines: Vec<Polyline>,
}

/// A polyline of a snapshot, with integer values that label it as a whole
/// (VTK cell data: an explicit crack's `crack` index and its `surface`),
/// so that ParaView can colour or pick the lines by them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Polyline {
    /// Its points in order, m (x, y, z; z = 0 in 2D).
    pub points: Vec<[f64; 3]>,
    /// Named values of the line. Lines of one snapshot may name different
    /// values: a writer gives a line [`Polyline::MISSING`] for a name it
    /// lacks.
    pub cell_data: Vec<(String, u32)>,
}

impl Polyline {
    /// The value written for a name a line does not give (and read back
    /// as absent).
    pub const MISSING: u32 = u32::MAX;

    /// Lines rebuilt from flat arrays (what a snapshot file and the API
    /// store): `counts[k]` points of line k, taken in order from `xy`
    /// (`d` components a point), and per named array one value a line,
    /// [`Polyline::MISSING`] read as absent. The caller has checked that
    /// the counts add up to the points.
    pub fn from_parts(
        counts: impl IntoIterator<Item = usize>,
        xy: &[f64],
        d: usize,
        values: &[(String, Vec<u32>)],
    ) -> Vec<Polyline> {
        let mut points = xy.chunks_exact(d).map(|c| {
            let mut x = [0.0; 3];
            x[..d].copy_from_slice(c);
            x
        });
        counts
            .into_iter()
            .enumerate()
            .map(|(k, n)| Polyline {
                points: points.by_ref().take(n).collect(),
                cell_data: values
                    .iter()
                    .filter_map(|(name, v)| {
                        let x = *v.get(k)?;
                        (x != Polyline::MISSING).then(|| (name.clone(), x))
                    })
                    .collect(),
            })
            .collect()
    }

    /// The value of `name`, if the line gives it.
    pub fn value(&self, name: &str) -> Option<u32> {
        self.cell_data
            .iter()
            .find(|(n, _)| n == name)
            .map(|&(_, v)| v)
    }
}

/// The names of the values `lines` give, in the order they first appear:
/// the cell-data arrays of a file of these lines.
pub fn line_value_names(lines: &[Polyline]) -> Vec<&str> {
    let mut names: Vec<&str> = Vec::new();
    for (n, _) in lines.iter().flat_map(|l| &l.cell_data) {
        if !names.contains(&n.as_str()) {
            names.push(n);
        }
    }
    names
}

impl Snapshot {
    /// The values of the particle field `name`, if the snapshot has it.
    pub fn field(&self, name: &str) -> Option<&FieldData> {
        self.fields.iter().find(|f| f.name == name).map(|f| &f.data)
    }
}

/// Progress of a running simulation, reported at least every few steps.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Progress {
    pub step: u64,
    pub time: f64,
    pub end_time: f64,
    /// Latest series values.
    pub kinetic_energy: f64,
    pub strain_energy: f64,
}

impl Progress {
    pub fn fraction(&self) -> f64 {
        if self.end_time > 0.0 {
            (self.time / self.end_time).clamp(0.0, 1.0)
        } else {
            1.0
        }
    }
}

/// What an observer asks the engine to do next.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Control {
    Continue,
    /// Stop at the end of this step (cancellation).
    Stop,
    /// Hand a checkpoint of the end of this step to
    /// [`Observer::checkpoint`], then go on.
    Checkpoint,
}

/// Receives what a run produces. Errors from an observer (e.g. a full disk)
/// stop the run and are reported as such.
pub trait Observer {
    /// The series' column names (the core ones, then the scene's), once,
    /// before the first row.
    fn series_columns(&mut self, columns: &[String]) -> Result<(), String>;
    fn series_row(&mut self, row: &SeriesRow) -> Result<(), String>;
    fn snapshot(&mut self, snapshot: &Snapshot) -> Result<(), String>;
    /// Called after every step; return [`Control::Stop`] to cancel.
    fn progress(&mut self, _progress: &Progress) -> Control {
        Control::Continue
    }
    /// The run's state at the end of the step whose progress asked for it
    /// with [`Control::Checkpoint`], after that step's row and snapshot
    /// were handed over.
    fn checkpoint(&mut self, _checkpoint: crate::checkpoint::Checkpoint<'_>) -> Result<(), String> {
        Ok(())
    }
}

/// An observer that keeps everything in memory (tests, studies).
#[derive(Debug, Default)]
pub struct Recorder {
    pub columns: Vec<String>,
    pub rows: Vec<SeriesRow>,
    pub snapshots: Vec<Snapshot>,
    /// Keep the series only (snapshots are dropped as they come).
    pub series_only: bool,
}

impl Recorder {
    /// A recorder of the series alone.
    pub fn series_only() -> Recorder {
        Recorder {
            series_only: true,
            ..Default::default()
        }
    }

    /// The values of a named column, one per row (None if no such column).
    pub fn column(&self, name: &str) -> Option<Vec<f64>> {
        self.columns.iter().position(|c| c == name)?;
        self.rows
            .iter()
            .map(|r| r.get(&self.columns, name))
            .collect()
    }
}

impl Observer for Recorder {
    fn series_columns(&mut self, columns: &[String]) -> Result<(), String> {
        self.columns = columns.to_vec();
        Ok(())
    }
    fn series_row(&mut self, row: &SeriesRow) -> Result<(), String> {
        self.rows.push(row.clone());
        Ok(())
    }
    fn snapshot(&mut self, snapshot: &Snapshot) -> Result<(), String> {
        if !self.series_only {
            self.snapshots.push(snapshot.clone());
        }
        Ok(())
    }
}

pub mod crack;
pub mod fragments;
pub mod measure;
