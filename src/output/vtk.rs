//! VTK XML writers: PolyData (`.vtp`) for particles and for a snapshot's
//! polylines (explicit cracks), ImageData (`.vti`) for the grid,
//! Collection (`.pvd`) for the time series. Arrays go in one
//! raw appended block (`header_type="UInt64"`, little endian): each array is
//! its byte count as a UInt64 followed by its values, and `offset` counts
//! from the byte after the `_` that opens the block.
//!
//! Fields go out in the shapes ParaView expects of a 3D data set: a 2D
//! vector (2 components) as x, y, 0, and an in-plane symmetric tensor
//! (4 components, xx yy xy zz in [`Field`]'s convention) as the 6
//! components of VTK's symmetric tensors, xx yy zz xy yz xz (the order of
//! `vtkMath::TensorFromSymmetricTensor` and the legacy format's
//! `TENSORS6`), with yz = xz = 0: ParaView then offers the magnitude,
//! the von Mises stress and the eigenvalues, and a vector can be a glyph's
//! direction.

use super::{write_atomic, OutputError};
use crate::diagnostics::{line_value_names, Field, FieldData, GridSnapshot, Polyline, Snapshot};
use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;

/// One appended array: its XML attributes and its values.
enum Values<'a> {
    F64(&'a [f64]),
    /// 2D vectors (x, y) written as (x, y, 0).
    Vector2(&'a [f64]),
    /// In-plane symmetric tensors (xx, yy, xy, zz) written in VTK's
    /// order (xx, yy, zz, xy, yz, xz) with yz = xz = 0.
    SymTensor2(&'a [f64]),
    U32(&'a [u32]),
    I64(&'a [i64]),
    Points(&'a [[f64; 3]]),
    Iota(usize),
    IotaFrom1(usize),
}

impl Values<'_> {
    fn bytes(&self) -> u64 {
        match self {
            Values::F64(v) => 8 * v.len() as u64,
            Values::Vector2(v) => 24 * (v.len() / 2) as u64,
            Values::SymTensor2(v) => 48 * (v.len() / 4) as u64,
            Values::U32(v) => 4 * v.len() as u64,
            Values::I64(v) => 8 * v.len() as u64,
            Values::Points(p) => 24 * p.len() as u64,
            Values::Iota(n) | Values::IotaFrom1(n) => 8 * *n as u64,
        }
    }

    fn write(&self, w: &mut impl Write) -> std::io::Result<()> {
        w.write_all(&self.bytes().to_le_bytes())?;
        match self {
            Values::F64(v) => v.iter().try_for_each(|x| w.write_all(&x.to_le_bytes())),
            Values::Vector2(v) => v.chunks_exact(2).try_for_each(|c| {
                [c[0], c[1], 0.0]
                    .iter()
                    .try_for_each(|x| w.write_all(&x.to_le_bytes()))
            }),
            Values::SymTensor2(v) => v.chunks_exact(4).try_for_each(|c| {
                let [xx, yy, xy, zz] = [c[0], c[1], c[2], c[3]];
                [xx, yy, zz, xy, 0.0, 0.0]
                    .iter()
                    .try_for_each(|x| w.write_all(&x.to_le_bytes()))
            }),
            Values::U32(v) => v.iter().try_for_each(|x| w.write_all(&x.to_le_bytes())),
            Values::I64(v) => v.iter().try_for_each(|x| w.write_all(&x.to_le_bytes())),
            Values::Points(p) => p
                .iter()
                .flatten()
                .try_for_each(|x| w.write_all(&x.to_le_bytes())),
            Values::Iota(n) => (0..*n as i64).try_for_each(|k| w.write_all(&k.to_le_bytes())),
            Values::IotaFrom1(n) => (1..=*n as i64).try_for_each(|k| w.write_all(&k.to_le_bytes())),
        }
    }
}

/// Builds the XML of the arrays and remembers what to append.
struct Appended<'a> {
    offset: u64,
    blocks: Vec<Values<'a>>,
}

impl<'a> Appended<'a> {
    fn new() -> Self {
        Appended {
            offset: 0,
            blocks: Vec::new(),
        }
    }

    /// The `<DataArray .../>` element for `values`.
    fn array(
        &mut self,
        xml: &mut String,
        ty: &str,
        name: Option<&str>,
        comps: usize,
        values: Values<'a>,
    ) {
        let name = name.map(|n| format!(" Name=\"{n}\"")).unwrap_or_default();
        let _ = writeln!(
            xml,
            "        <DataArray type=\"{ty}\"{name} NumberOfComponents=\"{comps}\" format=\"appended\" offset=\"{}\"/>",
            self.offset
        );
        self.offset += 8 + values.bytes();
        self.blocks.push(values);
    }

    fn field(&mut self, xml: &mut String, f: &'a Field) {
        match &f.data {
            FieldData::F64(v) => {
                let (comps, values) = match f.components {
                    2 => (3, Values::Vector2(v)),
                    4 => (6, Values::SymTensor2(v)),
                    c => (c, Values::F64(v)),
                };
                self.array(xml, "Float64", Some(&f.name), comps, values)
            }
            FieldData::U32(v) => {
                self.array(xml, "UInt32", Some(&f.name), f.components, Values::U32(v))
            }
        }
    }

    fn write(self, path: &Path, xml: String) -> Result<(), OutputError> {
        write_atomic(path, |w| {
            w.write_all(xml.as_bytes())?;
            w.write_all(b"  <AppendedData encoding=\"raw\">\n   _")?;
            for b in &self.blocks {
                b.write(w)?;
            }
            w.write_all(b"\n  </AppendedData>\n</VTKFile>\n")
        })
    }
}

const HEADER: &str = "<?xml version=\"1.0\"?>\n";

/// Particles as VTK PolyData: one vertex per particle, every field as
/// point data.
pub fn write_particles_vtp(path: &Path, snap: &Snapshot) -> Result<(), OutputError> {
    let n = snap.positions.len();
    let mut xml = String::from(HEADER);
    let _ = writeln!(xml, "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">");
    let _ = writeln!(xml, "  <PolyData>");
    let _ = writeln!(
        xml,
        "    <Piece NumberOfPoints=\"{n}\" NumberOfVerts=\"{n}\" NumberOfLines=\"0\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">"
    );
    let mut app = Appended::new();
    let _ = writeln!(xml, "      <PointData>");
    for f in &snap.fields {
        app.field(&mut xml, f);
    }
    let _ = writeln!(xml, "      </PointData>");
    let _ = writeln!(xml, "      <Points>");
    app.array(
        &mut xml,
        "Float64",
        Some("position"),
        3,
        Values::Points(&snap.positions),
    );
    let _ = writeln!(xml, "      </Points>");
    let _ = writeln!(xml, "      <Verts>");
    app.array(&mut xml, "Int64", Some("connectivity"), 1, Values::Iota(n));
    app.array(&mut xml, "Int64", Some("offsets"), 1, Values::IotaFrom1(n));
    let _ = writeln!(xml, "      </Verts>");
    let _ = writeln!(xml, "    </Piece>");
    let _ = writeln!(xml, "  </PolyData>");
    app.write(path, xml)
}

/// Polylines as VTK PolyData: the lines' points in order, one `<Lines>`
/// cell per polyline, and each value the lines give ([`Polyline`]'s
/// `cell_data`: an explicit crack's `crack` and `surface`) as a UInt32
/// cell-data array, [`Polyline::MISSING`] where a line lacks it. A
/// separate file from the particles', because VTK keeps one set of point
/// arrays per piece: crack points have none of the particles' fields.
pub fn write_lines_vtp(path: &Path, lines: &[Polyline]) -> Result<(), OutputError> {
    let points: Vec<[f64; 3]> = lines
        .iter()
        .flat_map(|l| l.points.iter().copied())
        .collect();
    let (n, cells) = (points.len(), lines.len());
    let offsets: Vec<i64> = lines
        .iter()
        .scan(0i64, |end, l| {
            *end += l.points.len() as i64;
            Some(*end)
        })
        .collect();
    let names = line_value_names(lines);
    let values: Vec<Vec<u32>> = names
        .iter()
        .map(|name| {
            lines
                .iter()
                .map(|l| l.value(name).unwrap_or(Polyline::MISSING))
                .collect()
        })
        .collect();
    let mut xml = String::from(HEADER);
    let _ = writeln!(xml, "<VTKFile type=\"PolyData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">");
    let _ = writeln!(xml, "  <PolyData>");
    let _ = writeln!(
        xml,
        "    <Piece NumberOfPoints=\"{n}\" NumberOfVerts=\"0\" NumberOfLines=\"{cells}\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">"
    );
    let mut app = Appended::new();
    let _ = writeln!(xml, "      <CellData>");
    for (name, v) in names.iter().zip(&values) {
        app.array(&mut xml, "UInt32", Some(name), 1, Values::U32(v));
    }
    let _ = writeln!(xml, "      </CellData>");
    let _ = writeln!(xml, "      <Points>");
    app.array(
        &mut xml,
        "Float64",
        Some("position"),
        3,
        Values::Points(&points),
    );
    let _ = writeln!(xml, "      </Points>");
    let _ = writeln!(xml, "      <Lines>");
    app.array(&mut xml, "Int64", Some("connectivity"), 1, Values::Iota(n));
    app.array(&mut xml, "Int64", Some("offsets"), 1, Values::I64(&offsets));
    let _ = writeln!(xml, "      </Lines>");
    let _ = writeln!(xml, "    </Piece>");
    let _ = writeln!(xml, "  </PolyData>");
    app.write(path, xml)
}

/// Grid nodes as VTK ImageData with the nodal fields as point data.
pub fn write_grid_vti(path: &Path, grid: &GridSnapshot) -> Result<(), OutputError> {
    let [nx, ny, nz] = grid.dims;
    let (o, h) = (grid.origin, grid.spacing);
    let extent = format!(
        "0 {} 0 {} 0 {}",
        nx.saturating_sub(1),
        ny.saturating_sub(1),
        nz.saturating_sub(1)
    );
    // a 2D grid's plane is z = 0, written as the files have always had it
    let z = if nz <= 1 && o[2] == 0.0 {
        "0".to_string()
    } else {
        format!("{:?}", o[2])
    };
    let mut xml = String::from(HEADER);
    let _ = writeln!(xml, "<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">");
    let _ = writeln!(
        xml,
        "  <ImageData WholeExtent=\"{extent}\" Origin=\"{:?} {:?} {z}\" Spacing=\"{h:?} {h:?} {h:?}\">",
        o[0], o[1]
    );
    let _ = writeln!(xml, "    <Piece Extent=\"{extent}\">");
    let mut app = Appended::new();
    let _ = writeln!(xml, "      <PointData>");
    for f in &grid.fields {
        app.field(&mut xml, f);
    }
    let _ = writeln!(xml, "      </PointData>");
    let _ = writeln!(xml, "    </Piece>");
    let _ = writeln!(xml, "  </ImageData>");
    app.write(path, xml)
}

/// A ParaView collection: `(time, file name relative to the .pvd)`.
pub fn write_pvd(path: &Path, entries: &[(f64, String)]) -> Result<(), OutputError> {
    let mut xml = String::from(HEADER);
    xml.push_str("<VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>\n");
    for (t, file) in entries {
        let _ = writeln!(
            xml,
            "    <DataSet timestep=\"{t:?}\" group=\"\" part=\"0\" file=\"{file}\"/>"
        );
    }
    xml.push_str("  </Collection>\n</VTKFile>\n");
    write_atomic(path, |w| w.write_all(xml.as_bytes()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn snapshot() -> Snapshot {
        Snapshot {
            index: 0,
            step: 3,
            time: 1.5e-6,
            dimension: 2,
            positions: vec![[0.1, 0.2, 0.0], [0.3, -0.4, 0.0], [1e-300, 7.0, 0.0]],
            fields: vec![
                Field {
                    name: "velocity".into(),
                    components: 2,
                    data: FieldData::F64(vec![1.0, 2.0, 3.0, 4.0, 5.0, f64::NAN]),
                },
                Field {
                    name: "particle_id".into(),
                    components: 1,
                    data: FieldData::U32(vec![7, 8, 9]),
                },
            ],
            grid: Some(GridSnapshot {
                origin: [-0.2, -0.2, 0.0],
                spacing: 0.1,
                dims: [2, 2, 1],
                fields: vec![Field {
                    name: "mass".into(),
                    components: 1,
                    data: FieldData::F64(vec![0.0, 1.0, 2.0, 3.0]),
                }],
            }),
            lines: Vec::new(),
        }
    }

    /// Decodes the appended block of a file by the offsets in its XML.
    fn blocks(bytes: &[u8]) -> Vec<Vec<u8>> {
        let text = String::from_utf8_lossy(bytes);
        let start = text.find("encoding=\"raw\">").unwrap();
        let underscore = bytes[start..].iter().position(|&b| b == b'_').unwrap() + start + 1;
        let mut offsets: Vec<usize> = text
            .match_indices("offset=\"")
            .map(|(i, m)| {
                text[i + m.len()..]
                    .split('"')
                    .next()
                    .unwrap()
                    .parse()
                    .unwrap()
            })
            .collect();
        offsets.sort();
        offsets
            .iter()
            .map(|&o| {
                let at = underscore + o;
                let len = u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize;
                bytes[at + 8..at + 8 + len].to_vec()
            })
            .collect()
    }

    fn f64s(b: &[u8]) -> Vec<f64> {
        b.chunks(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
            .collect()
    }

    #[test]
    fn vtp_arrays_decode_bit_for_bit() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("p.vtp");
        let snap = snapshot();
        write_particles_vtp(&p, &snap).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        assert!(bytes.ends_with(b"</AppendedData>\n</VTKFile>\n"));
        let b = blocks(&bytes);
        assert_eq!(b.len(), 5);
        // the 2D velocity as 3D vectors
        let v = f64s(&b[0]);
        assert_eq!(v.len(), 9);
        assert_eq!(v[..7], [1.0, 2.0, 0.0, 3.0, 4.0, 0.0, 5.0]);
        assert!(v[7].is_nan());
        assert_eq!(v[8], 0.0);
        assert!(
            String::from_utf8_lossy(&bytes).contains("Name=\"velocity\" NumberOfComponents=\"3\"")
        );
        let ids: Vec<u32> = b[1]
            .chunks(4)
            .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(ids, [7, 8, 9]);
        let pts = f64s(&b[2]);
        assert_eq!(pts, [0.1, 0.2, 0.0, 0.3, -0.4, 0.0, 1e-300, 7.0, 0.0]);
        let offs: Vec<i64> = b[4]
            .chunks(8)
            .map(|c| i64::from_le_bytes(c.try_into().unwrap()))
            .collect();
        assert_eq!(offs, [1, 2, 3]);
        // deterministic bytes
        let q = dir.path().join("q.vtp");
        write_particles_vtp(&q, &snap).unwrap();
        assert_eq!(bytes, std::fs::read(&q).unwrap());
        assert!(!dir.path().join("p.vtp.tmp").exists());
    }

    #[test]
    fn in_plane_tensors_go_out_in_vtk_order() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.vtp");
        let mut snap = snapshot();
        // σxx = 1, σyy = 2, σxy = 3, σzz = 4; then 5, 6, 7, 8
        snap.fields = vec![Field {
            name: "stress".into(),
            components: 4,
            data: FieldData::F64(vec![
                1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 0.0, 0.0, 0.0, 0.0,
            ]),
        }];
        write_particles_vtp(&p, &snap).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        assert!(
            String::from_utf8_lossy(&bytes).contains("Name=\"stress\" NumberOfComponents=\"6\"")
        );
        // xx yy zz xy yz xz
        assert_eq!(
            f64s(&blocks(&bytes)[0]),
            [
                1.0, 2.0, 4.0, 3.0, 0.0, 0.0, 5.0, 6.0, 8.0, 7.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                0.0, 0.0
            ]
        );
    }

    /// A 3D snapshot: positions with their z, a 3-vector and a symmetric
    /// tensor already in VTK's order go out as they are; the grid spans
    /// three axes from a 3D origin.
    #[test]
    fn a_3d_snapshot_goes_out_as_it_is() {
        let dir = tempfile::tempdir().unwrap();
        let snap = Snapshot {
            index: 0,
            step: 1,
            time: 0.0,
            dimension: 3,
            positions: vec![[0.1, 0.2, 0.3], [-0.4, 0.5, -0.6]],
            fields: vec![
                Field {
                    name: "velocity".into(),
                    components: 3,
                    data: FieldData::F64(vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]),
                },
                Field {
                    name: "stress".into(),
                    components: 6,
                    data: FieldData::F64((1..=12).map(f64::from).collect()),
                },
            ],
            grid: Some(GridSnapshot {
                origin: [-0.2, -0.1, 0.5],
                spacing: 0.1,
                dims: [2, 3, 4],
                fields: vec![Field {
                    name: "mass".into(),
                    components: 1,
                    data: FieldData::F64((0..24).map(f64::from).collect()),
                }],
            }),
            lines: Vec::new(),
        };
        let p = dir.path().join("p.vtp");
        write_particles_vtp(&p, &snap).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        let text = String::from_utf8_lossy(&bytes);
        assert!(text.contains("Name=\"velocity\" NumberOfComponents=\"3\""));
        assert!(text.contains("Name=\"stress\" NumberOfComponents=\"6\""));
        let b = blocks(&bytes);
        assert_eq!(f64s(&b[0]), [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        assert_eq!(f64s(&b[1]), (1..=12).map(f64::from).collect::<Vec<_>>());
        assert_eq!(f64s(&b[2]), [0.1, 0.2, 0.3, -0.4, 0.5, -0.6]);
        let g = dir.path().join("g.vti");
        write_grid_vti(&g, snap.grid.as_ref().unwrap()).unwrap();
        let bytes = std::fs::read(&g).unwrap();
        let text = String::from_utf8_lossy(&bytes);
        assert!(text.contains("WholeExtent=\"0 1 0 2 0 3\" Origin=\"-0.2 -0.1 0.5\""));
        assert_eq!(f64s(&blocks(&bytes)[0]).len(), 24);
    }

    /// Two lines, the second without one of the first's values: the
    /// points line after line, one cell each, the values as cell data with
    /// the missing one marked, and the same bytes every time.
    #[test]
    fn lines_go_out_as_cells_with_their_values() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("c.vtp");
        let lines = [
            Polyline {
                points: vec![[0.0, 0.0, 0.0], [1.0, 0.5, 0.0], [2.0, 1e-300, 0.0]],
                cell_data: vec![("crack".into(), 0), ("surface".into(), 1)],
            },
            Polyline {
                points: vec![[3.0, 4.0, 0.0], [5.0, 6.0, 0.0]],
                cell_data: vec![("crack".into(), 1)],
            },
        ];
        write_lines_vtp(&p, &lines).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        let text = String::from_utf8_lossy(&bytes);
        assert!(text.contains("NumberOfPoints=\"5\" NumberOfVerts=\"0\" NumberOfLines=\"2\""));
        assert!(text.contains("<CellData>\n        <DataArray type=\"UInt32\" Name=\"crack\""));
        assert!(text.contains("<Lines>"));
        let b = blocks(&bytes);
        assert_eq!(b.len(), 5);
        let u32s = |b: &[u8]| -> Vec<u32> {
            b.chunks(4)
                .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
                .collect()
        };
        let i64s = |b: &[u8]| -> Vec<i64> {
            b.chunks(8)
                .map(|c| i64::from_le_bytes(c.try_into().unwrap()))
                .collect()
        };
        assert_eq!(u32s(&b[0]), [0, 1]);
        assert_eq!(u32s(&b[1]), [1, Polyline::MISSING]);
        assert_eq!(
            f64s(&b[2]),
            [0.0, 0.0, 0.0, 1.0, 0.5, 0.0, 2.0, 1e-300, 0.0, 3.0, 4.0, 0.0, 5.0, 6.0, 0.0]
        );
        assert_eq!(i64s(&b[3]), [0, 1, 2, 3, 4]);
        assert_eq!(i64s(&b[4]), [3, 5]);
        let q = dir.path().join("d.vtp");
        write_lines_vtp(&q, &lines).unwrap();
        assert_eq!(bytes, std::fs::read(&q).unwrap());
    }

    #[test]
    fn vti_and_pvd() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("g.vti");
        let snap = snapshot();
        write_grid_vti(&p, snap.grid.as_ref().unwrap()).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        assert!(String::from_utf8_lossy(&bytes).contains("WholeExtent=\"0 1 0 1 0 0\""));
        assert_eq!(f64s(&blocks(&bytes)[0]), [0.0, 1.0, 2.0, 3.0]);
        let c = dir.path().join("c.pvd");
        write_pvd(&c, &[(0.0, "a.vtp".into()), (2.5e-7, "b.vtp".into())]).unwrap();
        let text = std::fs::read_to_string(&c).unwrap();
        let a = text.find("file=\"a.vtp\"").unwrap();
        let b = text
            .find("timestep=\"2.5e-7\" group=\"\" part=\"0\" file=\"b.vtp\"")
            .unwrap();
        assert!(a < b);
    }
}
