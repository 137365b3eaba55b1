//! The server's snapshot file: a JSON header and the raw little-endian
//! arrays, so that one field can be read without loading the others.
//!
//! ```text
//! b"CLEAVESNAP1\n"  u64 header length  header (JSON)  arrays...
//! ```
//! Particle arrays come first (`position` as 2 components in 2D, 3 in 3D,
//! then the snapshot's fields in order), then the grid's, then those of
//! the snapshot's polylines (explicit cracks: [`LinesInfo`]). The grid's
//! `origin` and `dims` have one entry per dimension, so that a 2D file is
//! byte for byte what it was before 3D runs wrote snapshots; the header
//! names `lines` only when there are some, so that a file without them is
//! what it was before lines were stored, and one written before reads as
//! having none.

use crate::diagnostics::{line_value_names, Field, FieldData, GridSnapshot, Polyline, Snapshot};
use serde::{Deserialize, Serialize};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::Path;

const MAGIC: &[u8; 12] = b"CLEAVESNAP1\n";

/// Element type of an array.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Dtype {
    F64,
    U32,
}

impl Dtype {
    pub fn size(self) -> usize {
        match self {
            Dtype::F64 => 8,
            Dtype::U32 => 4,
        }
    }
}

/// One stored array.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ArrayInfo {
    pub name: String,
    pub dtype: Dtype,
    pub components: usize,
    /// Number of values (points × components).
    pub len: usize,
    /// Byte offset from the start of the array section.
    pub offset: u64,
}

/// Grid metadata of a stored snapshot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GridInfo {
    /// Node (0, 0[, 0]), m: one entry per dimension.
    pub origin: Vec<f64>,
    pub spacing: f64,
    /// Nodes along each axis; as many as `origin`.
    pub dims: Vec<usize>,
    pub fields: Vec<ArrayInfo>,
}

impl GridInfo {
    /// The origin as (x, y, z), z = 0 in 2D.
    pub fn origin3(&self) -> [f64; 3] {
        let mut o = [0.0; 3];
        self.origin
            .iter()
            .take(3)
            .enumerate()
            .for_each(|(a, &x)| o[a] = x);
        o
    }

    /// The node counts as (x, y, z), z = 1 in 2D.
    pub fn dims3(&self) -> [usize; 3] {
        let mut d = [1; 3];
        self.dims
            .iter()
            .take(3)
            .enumerate()
            .for_each(|(a, &n)| d[a] = n);
        d
    }
}

/// The polylines of a stored snapshot (explicit cracks' planes and
/// surfaces).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinesInfo {
    /// Points of each line, in order.
    pub counts: Vec<usize>,
    /// `position`: every line's points, line after line, one component per
    /// dimension.
    pub points: ArrayInfo,
    /// Each value the lines give, one per line (`crack`, `surface`);
    /// [`Polyline::MISSING`] where a line lacks it.
    pub values: Vec<ArrayInfo>,
}

/// The header of a stored snapshot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SnapshotHeader {
    pub index: u32,
    pub step: u64,
    pub time: f64,
    pub particles: usize,
    /// `position` first, then the particle fields.
    pub fields: Vec<ArrayInfo>,
    pub grid: Option<GridInfo>,
    /// Absent when the snapshot has no lines.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lines: Option<LinesInfo>,
}

impl SnapshotHeader {
    /// 2 or 3: the components of `position` (2 when it is missing).
    pub fn dimension(&self) -> usize {
        self.fields
            .iter()
            .find(|a| a.name == "position")
            .map_or(2, |a| a.components)
    }

    /// Why a header read from disk cannot be a snapshot's: a dimension
    /// other than 2 or 3, or a grid of another dimension.
    fn check(&self) -> Result<(), String> {
        let d = self.dimension();
        if d != 2 && d != 3 {
            return Err(format!("position has {d} components, not 2 or 3"));
        }
        if let Some(g) = &self.grid {
            if g.origin.len() != d || g.dims.len() != d {
                return Err(format!(
                    "the grid has {} origin and {} dims entries in a {d}D snapshot",
                    g.origin.len(),
                    g.dims.len()
                ));
            }
        }
        if let Some(l) = &self.lines {
            let points: usize = l.counts.iter().sum();
            if l.points.components != d || l.points.len != points * d {
                return Err(format!(
                    "the lines' {} position values are not their {points} points in {d}D",
                    l.points.len
                ));
            }
            if let Some(a) = l.values.iter().find(|a| a.len != l.counts.len()) {
                return Err(format!(
                    "the lines' {} has {} values for {} lines",
                    a.name,
                    a.len,
                    l.counts.len()
                ));
            }
        }
        Ok(())
    }
}

fn io(path: &Path, e: std::io::Error) -> String {
    format!("{}: {e}", path.display())
}

/// Writes a snapshot atomically.
pub fn write(path: &Path, snap: &Snapshot) -> Result<(), String> {
    let mut offset = 0u64;
    let mut info = |name: &str, data: &FieldData, components: usize| {
        let (dtype, len) = match data {
            FieldData::F64(v) => (Dtype::F64, v.len()),
            FieldData::U32(v) => (Dtype::U32, v.len()),
        };
        let a = ArrayInfo {
            name: name.to_string(),
            dtype,
            components,
            len,
            offset,
        };
        offset += (len * dtype.size()) as u64;
        a
    };
    let d = snap.dimension;
    let positions = FieldData::F64(
        snap.positions
            .iter()
            .flat_map(|p| p.iter().copied().take(d))
            .collect(),
    );
    let mut fields = vec![info("position", &positions, d)];
    fields.extend(
        snap.fields
            .iter()
            .map(|f| info(&f.name, &f.data, f.components)),
    );
    let grid = snap.grid.as_ref().map(|g| GridInfo {
        origin: g.origin[..d].to_vec(),
        spacing: g.spacing,
        dims: g.dims[..d].to_vec(),
        fields: g
            .fields
            .iter()
            .map(|f| info(&f.name, &f.data, f.components))
            .collect(),
    });
    let (line_points, line_values) = line_arrays(&snap.lines, d);
    let lines = (!snap.lines.is_empty()).then(|| LinesInfo {
        counts: snap.lines.iter().map(|l| l.points.len()).collect(),
        points: info("position", &line_points, d),
        values: line_values
            .iter()
            .map(|(name, v)| info(name, v, 1))
            .collect(),
    });
    let header = SnapshotHeader {
        index: snap.index,
        step: snap.step,
        time: snap.time,
        particles: snap.positions.len(),
        fields,
        grid,
        lines,
    };
    let json = serde_json::to_vec(&header).map_err(|e| e.to_string())?;
    let arrays = std::iter::once(&positions)
        .chain(snap.fields.iter().map(|f| &f.data))
        .chain(
            snap.grid
                .iter()
                .flat_map(|g| g.fields.iter().map(|f| &f.data)),
        )
        .chain(
            (!snap.lines.is_empty())
                .then_some(&line_points)
                .into_iter()
                .chain(line_values.iter().map(|(_, v)| v)),
        );
    crate::output::write_atomic(path, |w| {
        w.write_all(MAGIC)?;
        w.write_all(&(json.len() as u64).to_le_bytes())?;
        w.write_all(&json)?;
        for a in arrays {
            match a {
                FieldData::F64(v) => v.iter().try_for_each(|x| w.write_all(&x.to_le_bytes()))?,
                FieldData::U32(v) => v.iter().try_for_each(|x| w.write_all(&x.to_le_bytes()))?,
            }
        }
        Ok(())
    })
    .map_err(|e| e.to_string())
}

/// The arrays of a snapshot's lines: their points (`d` components each)
/// and each named value, one per line ([`Polyline::MISSING`] where a line
/// lacks it).
fn line_arrays(lines: &[Polyline], d: usize) -> (FieldData, Vec<(String, FieldData)>) {
    let points = lines
        .iter()
        .flat_map(|l| &l.points)
        .flat_map(|p| p.iter().copied().take(d))
        .collect();
    let values = line_value_names(lines)
        .into_iter()
        .map(|name| {
            let v = lines
                .iter()
                .map(|l| l.value(name).unwrap_or(Polyline::MISSING))
                .collect();
            (name.to_string(), FieldData::U32(v))
        })
        .collect();
    (FieldData::F64(points), values)
}

/// An open snapshot file.
pub struct SnapshotReader {
    file: std::fs::File,
    path: std::path::PathBuf,
    pub header: SnapshotHeader,
    /// File offset of the array section.
    base: u64,
}

impl SnapshotReader {
    pub fn open(path: &Path) -> Result<SnapshotReader, String> {
        let mut file = std::fs::File::open(path).map_err(|e| io(path, e))?;
        let mut magic = [0u8; 12];
        file.read_exact(&mut magic).map_err(|e| io(path, e))?;
        if &magic != MAGIC {
            return Err(format!("{}: not a cleave snapshot", path.display()));
        }
        let mut len = [0u8; 8];
        file.read_exact(&mut len).map_err(|e| io(path, e))?;
        let len = u64::from_le_bytes(len);
        if len > 1 << 30 {
            return Err(format!("{}: corrupt header length {len}", path.display()));
        }
        let mut json = vec![0u8; len as usize];
        file.read_exact(&mut json).map_err(|e| io(path, e))?;
        let header: SnapshotHeader = serde_json::from_slice(&json)
            .map_err(|e| format!("{}: corrupt header: {e}", path.display()))?;
        header
            .check()
            .map_err(|e| format!("{}: corrupt header: {e}", path.display()))?;
        Ok(SnapshotReader {
            file,
            path: path.to_path_buf(),
            header,
            base: 20 + len,
        })
    }

    /// Reads `count` bytes of an array from byte `from` within it.
    pub fn read_bytes(
        &mut self,
        a: &ArrayInfo,
        from: u64,
        count: usize,
    ) -> Result<Vec<u8>, String> {
        let mut buf = vec![0u8; count];
        self.file
            .seek(SeekFrom::Start(self.base + a.offset + from))
            .map_err(|e| io(&self.path, e))?;
        self.file
            .read_exact(&mut buf)
            .map_err(|e| io(&self.path, e))?;
        Ok(buf)
    }

    fn read_array(&mut self, a: &ArrayInfo) -> Result<FieldData, String> {
        let bytes = self.read_bytes(a, 0, a.len * a.dtype.size())?;
        Ok(match a.dtype {
            Dtype::F64 => FieldData::F64(
                bytes
                    .chunks_exact(8)
                    .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
                    .collect(),
            ),
            Dtype::U32 => FieldData::U32(
                bytes
                    .chunks_exact(4)
                    .map(|c| u32::from_le_bytes(c.try_into().unwrap_or([0; 4])))
                    .collect(),
            ),
        })
    }

    /// Loads the whole snapshot.
    pub fn read_all(&mut self) -> Result<Snapshot, String> {
        let h = self.header.clone();
        let d = h.dimension();
        let mut fields = Vec::new();
        let mut positions = Vec::new();
        for a in &h.fields {
            let data = self.read_array(a)?;
            if a.name == "position" && positions.is_empty() {
                if let FieldData::F64(v) = data {
                    positions = v
                        .chunks_exact(d)
                        .map(|c| {
                            let mut x = [0.0; 3];
                            x[..d].copy_from_slice(c);
                            x
                        })
                        .collect();
                }
            } else {
                fields.push(Field {
                    name: a.name.clone(),
                    components: a.components,
                    data,
                });
            }
        }
        let grid = match &h.grid {
            Some(g) => {
                let mut gf = Vec::new();
                for a in &g.fields {
                    gf.push(Field {
                        name: a.name.clone(),
                        components: a.components,
                        data: self.read_array(a)?,
                    });
                }
                Some(GridSnapshot {
                    origin: g.origin3(),
                    spacing: g.spacing,
                    dims: g.dims3(),
                    fields: gf,
                })
            }
            None => None,
        };
        let lines = match &h.lines {
            Some(l) => self.read_lines(l, d)?,
            None => Vec::new(),
        };
        Ok(Snapshot {
            index: h.index,
            step: h.step,
            time: h.time,
            dimension: d,
            positions,
            fields,
            grid,
            lines,
        })
    }

    /// The polylines of a header's [`LinesInfo`] (checked on open: the
    /// counts add up to the points, one value per line).
    fn read_lines(&mut self, l: &LinesInfo, d: usize) -> Result<Vec<Polyline>, String> {
        let FieldData::F64(xy) = self.read_array(&l.points)? else {
            return Err(format!(
                "{}: line points are not numbers",
                self.path.display()
            ));
        };
        let mut values = Vec::new();
        for a in &l.values {
            match self.read_array(a)? {
                FieldData::U32(v) => values.push((a.name.clone(), v)),
                FieldData::F64(_) => {
                    return Err(format!(
                        "{}: line value {} is not integers",
                        self.path.display(),
                        a.name
                    ))
                }
            }
        }
        Ok(Polyline::from_parts(
            l.counts.iter().copied(),
            &xy,
            d,
            &values,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_is_exact() {
        let snap = Snapshot {
            index: 2,
            step: 9,
            time: 1.25e-5,
            dimension: 2,
            positions: vec![[0.1, 0.2, 0.0], [f64::MIN_POSITIVE, -3.0, 0.0]],
            fields: vec![
                Field {
                    name: "velocity".into(),
                    components: 2,
                    data: FieldData::F64(vec![1.0, 2.0, 3.0, f64::NAN]),
                },
                Field {
                    name: "particle_id".into(),
                    components: 1,
                    data: FieldData::U32(vec![5, 6]),
                },
            ],
            grid: Some(GridSnapshot {
                origin: [-1.0, -1.0, 0.0],
                spacing: 0.5,
                dims: [2, 1, 1],
                fields: vec![Field {
                    name: "mass".into(),
                    components: 1,
                    data: FieldData::F64(vec![0.5, 0.25]),
                }],
            }),
            lines: Vec::new(),
        };
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.bin");
        write(&p, &snap).unwrap();
        let back = SnapshotReader::open(&p).unwrap().read_all().unwrap();
        assert_eq!(back.positions, snap.positions);
        assert_eq!(back.grid, snap.grid);
        match (&back.fields[0].data, &snap.fields[0].data) {
            (FieldData::F64(a), FieldData::F64(b)) => {
                assert!(a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()))
            }
            _ => panic!(),
        }
        assert_eq!(back.fields[1], snap.fields[1]);
        std::fs::write(&p, b"not a snapshot at all").unwrap();
        assert!(SnapshotReader::open(&p).is_err());
    }

    /// Lines round-trip exactly after the grid's arrays (a line without
    /// one of the values reads back without it); a snapshot without lines
    /// names none in its header, and a header that does not count its
    /// lines' points right is refused as corrupt.
    #[test]
    fn lines_round_trip_and_are_absent_without_them() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.bin");
        let mut snap = Snapshot {
            index: 1,
            step: 4,
            time: 2e-6,
            dimension: 2,
            positions: vec![[0.5, 0.5, 0.0]],
            fields: vec![Field {
                name: "mass".into(),
                components: 1,
                data: FieldData::F64(vec![1.0]),
            }],
            grid: Some(GridSnapshot {
                origin: [0.0, 0.0, 0.0],
                spacing: 1.0,
                dims: [1, 1, 1],
                fields: vec![Field {
                    name: "mass".into(),
                    components: 1,
                    data: FieldData::F64(vec![3.0]),
                }],
            }),
            lines: Vec::new(),
        };
        write(&p, &snap).unwrap();
        assert!(!String::from_utf8_lossy(&std::fs::read(&p).unwrap()).contains("lines"));
        snap.lines = vec![
            Polyline {
                points: vec![[0.1, 0.2, 0.0], [0.3, 1e-300, 0.0], [0.7, 0.8, 0.0]],
                cell_data: vec![("crack".into(), 0), ("surface".into(), 2)],
            },
            Polyline {
                points: vec![[1.0, 2.0, 0.0], [3.0, 4.0, 0.0]],
                cell_data: vec![("crack".into(), 1)],
            },
        ];
        write(&p, &snap).unwrap();
        let r = SnapshotReader::open(&p).unwrap();
        assert_eq!(r.header.lines.as_ref().unwrap().counts, [3, 2]);
        assert_eq!({ r }.read_all().unwrap(), snap);

        let bytes = std::fs::read(&p).unwrap();
        let key = b"\"counts\":[3,2]";
        let at = bytes.windows(key.len()).position(|w| w == key).unwrap();
        let mut bad = bytes.clone();
        bad[at + key.len() - 2] = b'3';
        std::fs::write(&p, bad).unwrap();
        let e = SnapshotReader::open(&p).err().unwrap();
        assert!(e.contains("corrupt header") && e.contains("lines"), "{e}");
    }

    /// A 2D snapshot's header keeps the two-entry grid it always had (so
    /// files written before 3D read the same); a 3D one round-trips with
    /// three-component positions and a three-axis grid; a header whose grid
    /// is of another dimension than its positions is refused as corrupt.
    #[test]
    fn the_dimension_is_the_positions_and_the_grids() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.bin");
        let mut snap = Snapshot {
            index: 0,
            step: 1,
            time: 0.0,
            dimension: 3,
            positions: vec![[0.1, 0.2, 0.3], [4.0, 5.0, -6.0]],
            fields: vec![],
            grid: Some(GridSnapshot {
                origin: [-1.0, -2.0, -3.0],
                spacing: 0.5,
                dims: [2, 1, 3],
                fields: vec![Field {
                    name: "mass".into(),
                    components: 1,
                    data: FieldData::F64(vec![1.0; 6]),
                }],
            }),
            lines: Vec::new(),
        };
        write(&p, &snap).unwrap();
        let r = SnapshotReader::open(&p).unwrap();
        assert_eq!(r.header.dimension(), 3);
        assert_eq!(r.header.fields[0].components, 3);
        assert_eq!(r.header.grid.as_ref().unwrap().dims, [2, 1, 3]);
        let back = { r }.read_all().unwrap();
        assert_eq!(back, snap);

        snap.dimension = 2;
        snap.positions.iter_mut().for_each(|x| x[2] = 0.0);
        let g = snap.grid.as_mut().unwrap();
        (g.origin[2], g.dims, g.fields[0].data) = (0.0, [2, 1, 1], FieldData::F64(vec![1.0; 2]));
        write(&p, &snap).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        let text = String::from_utf8_lossy(&bytes);
        assert!(text.contains("\"origin\":[-1.0,-2.0],\"spacing\":0.5,\"dims\":[2,1]"));
        assert_eq!(SnapshotReader::open(&p).unwrap().read_all().unwrap(), snap);

        // a 2D grid under 3D positions (`position` is the first array)
        let key = b"\"components\":2";
        let at = bytes.windows(key.len()).position(|w| w == key).unwrap() + key.len() - 1;
        let mut bad = bytes.clone();
        bad[at] = b'3';
        std::fs::write(&p, bad).unwrap();
        let e = SnapshotReader::open(&p).err().unwrap();
        assert!(
            e.contains("corrupt header") && e.contains("3D snapshot"),
            "{e}"
        );
    }
}
