//! The server's snapshot file: a JSON header and the raw little-endian
//! arrays, so that one field can be read without loading the others.
//!
//! ```text
//! b"CLEAVESNAP1\n"  u64 header length  header (JSON)  arrays...
//! ```
//! Particle arrays come first (`position` as 2 components, then the
//! snapshot's fields in order), then the grid's.

use crate::diagnostics::{Field, FieldData, GridSnapshot, Snapshot};
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
    pub origin: [f64; 2],
    pub spacing: f64,
    pub dims: [usize; 2],
    pub fields: Vec<ArrayInfo>,
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
    let positions = FieldData::F64(snap.positions.iter().flat_map(|p| [p[0], p[1]]).collect());
    let mut fields = vec![info("position", &positions, 2)];
    fields.extend(
        snap.fields
            .iter()
            .map(|f| info(&f.name, &f.data, f.components)),
    );
    let grid = snap.grid.as_ref().map(|g| GridInfo {
        origin: g.origin,
        spacing: g.spacing,
        dims: g.dims,
        fields: g
            .fields
            .iter()
            .map(|f| info(&f.name, &f.data, f.components))
            .collect(),
    });
    let header = SnapshotHeader {
        index: snap.index,
        step: snap.step,
        time: snap.time,
        particles: snap.positions.len(),
        fields,
        grid,
    };
    let json = serde_json::to_vec(&header).map_err(|e| e.to_string())?;
    let arrays = std::iter::once(&positions)
        .chain(snap.fields.iter().map(|f| &f.data))
        .chain(
            snap.grid
                .iter()
                .flat_map(|g| g.fields.iter().map(|f| &f.data)),
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
        let mut fields = Vec::new();
        let mut positions = Vec::new();
        for a in &h.fields {
            let data = self.read_array(a)?;
            if a.name == "position" && positions.is_empty() {
                if let FieldData::F64(v) = data {
                    positions = v.chunks_exact(2).map(|c| [c[0], c[1]]).collect();
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
                    origin: g.origin,
                    spacing: g.spacing,
                    dims: g.dims,
                    fields: gf,
                })
            }
            None => None,
        };
        Ok(Snapshot {
            index: h.index,
            step: h.step,
            time: h.time,
            positions,
            fields,
            grid,
        })
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
            positions: vec![[0.1, 0.2], [f64::MIN_POSITIVE, -3.0]],
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
                origin: [-1.0, -1.0],
                spacing: 0.5,
                dims: [2, 1],
                fields: vec![Field {
                    name: "mass".into(),
                    components: 1,
                    data: FieldData::F64(vec![0.5, 0.25]),
                }],
            }),
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
}
