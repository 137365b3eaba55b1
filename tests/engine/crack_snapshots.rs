//! Explicit cracks in a run's snapshot files (issue 33): beside each
//! `particles_NNNN.vtp` a `cracks_NNNN.vtp` with every crack's plane,
//! `above` and `below` surfaces as polylines, and a `cracks.pvd` that
//! ParaView opens with `particles.pvd`; nothing of the kind for a scene
//! without cracks, and a resumed run's collection still lists the files
//! written before its checkpoint.

use crate::common::Interrupted;
use cleave::fracture::cracks::snapshot::{ABOVE, BELOW, PLANE};
use cleave::fracture::cracks::Cramp;
use cleave::mpm::Simulation;
use cleave::output::{OutputPaths, OutputWriter};
use cleave::scene::Scene;
use std::collections::BTreeMap;
use std::path::Path;

/// The interface crack of `tests/engine/cracks.rs` (two stacked blocks, the top
/// one pulled away at 1 m/s, the crack 2.9 mm past their edges), and a
/// second crack inside the top block that rides along with it.
const INTERFACE: [[f64; 2]; 4] = [
    [0.0021, 0.0151],
    [0.0101, 0.0151],
    [0.0203, 0.0151],
    [0.0279, 0.0151],
];
const INSIDE: [[f64; 2]; 3] = [[0.0101, 0.0201], [0.0152, 0.0203], [0.0199, 0.0201]];

fn points(p: &[[f64; 2]]) -> String {
    let xy: Vec<String> = p.iter().map(|[x, y]| format!("[{x:?}, {y:?}]")).collect();
    format!("[{}]", xy.join(", "))
}

/// The scene (`tests/data/stacked_cracks.toml`), with its two cracks or
/// without; five snapshots over 0.1 ms.
fn scene(cracks: bool) -> Scene {
    let text = include_str!("../data/stacked_cracks.toml");
    // the expected points below are the file's
    for c in [&INTERFACE[..], &INSIDE[..]] {
        assert!(text.contains(&format!("points = {} }}", points(c))));
    }
    let text: String = text
        .lines()
        .filter(|l| cracks || !l.starts_with("explicit_cracks"))
        .map(|l| format!("{l}\n"))
        .collect();
    Scene::from_text(&text, None).unwrap_or_else(|e| panic!("{e}"))
}

/// Runs `scene` to its end with an [`OutputWriter`] in `dir`.
fn run(scene: &Scene, dir: &Path) -> (Simulation, OutputPaths) {
    let mut w = OutputWriter::create(dir).unwrap();
    let mut sim = Simulation::new(scene);
    let s = sim.run(&mut w).unwrap_or_else(|e| panic!("{e}"));
    assert!(!s.cancelled);
    (sim, w.finish().unwrap())
}

/// One decoded array of a VTK XML file with raw appended data.
#[derive(Debug, Clone, PartialEq)]
enum Array {
    F64(Vec<f64>),
    I64(Vec<i64>),
    U32(Vec<u32>),
}

/// A lines file read back: the piece's counts and the arrays by name
/// (`position`, `connectivity`, `offsets`, the cell data).
struct Lines {
    xml: String,
    points: usize,
    lines: usize,
    arrays: BTreeMap<String, Array>,
}

/// The value of attribute `name` in the XML element `tag`.
fn attr<'a>(tag: &'a str, name: &str) -> &'a str {
    let key = format!(" {name}=\"");
    let at = tag
        .find(&key)
        .unwrap_or_else(|| panic!("no {name} in {tag}"))
        + key.len();
    tag[at..].split('"').next().unwrap()
}

/// Parses a `.vtp` as the writer lays it out: the XML up to the appended
/// block, then each `DataArray`'s bytes at its offset after the `_`
/// (a UInt64 byte count, then the values, little endian).
fn read_lines(path: &Path) -> Lines {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let open = b"<AppendedData encoding=\"raw\">";
    let start = bytes.windows(open.len()).position(|w| w == open).unwrap();
    let base = start + bytes[start..].iter().position(|&b| b == b'_').unwrap() + 1;
    let xml = String::from_utf8(bytes[..start].to_vec()).unwrap();
    assert!(xml.starts_with("<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\""));
    assert!(bytes.ends_with(b"</AppendedData>\n</VTKFile>\n"));
    let piece = xml.lines().find(|l| l.contains("<Piece ")).unwrap();
    let mut arrays = BTreeMap::new();
    for tag in xml.lines().filter(|l| l.contains("<DataArray ")) {
        let at = base + attr(tag, "offset").parse::<usize>().unwrap();
        let len = u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize;
        let data = &bytes[at + 8..at + 8 + len];
        let array = match attr(tag, "type") {
            "Float64" => Array::F64(
                data.chunks_exact(8)
                    .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
                    .collect(),
            ),
            "Int64" => Array::I64(
                data.chunks_exact(8)
                    .map(|c| i64::from_le_bytes(c.try_into().unwrap()))
                    .collect(),
            ),
            "UInt32" => Array::U32(
                data.chunks_exact(4)
                    .map(|c| u32::from_le_bytes(c.try_into().unwrap()))
                    .collect(),
            ),
            t => panic!("unexpected type {t}"),
        };
        arrays.insert(attr(tag, "Name").to_string(), array);
    }
    Lines {
        points: attr(piece, "NumberOfPoints").parse().unwrap(),
        lines: attr(piece, "NumberOfLines").parse().unwrap(),
        xml,
        arrays,
    }
}

impl Lines {
    fn u32s(&self, name: &str) -> &[u32] {
        match &self.arrays[name] {
            Array::U32(v) => v,
            a => panic!("{name} is {a:?}"),
        }
    }

    fn i64s(&self, name: &str) -> &[i64] {
        match &self.arrays[name] {
            Array::I64(v) => v,
            a => panic!("{name} is {a:?}"),
        }
    }

    /// The points of line `k`, as (x, y) after checking z = 0.
    fn line(&self, k: usize) -> Vec<[f64; 2]> {
        let Array::F64(xyz) = &self.arrays["position"] else {
            panic!("position is not Float64")
        };
        let offsets = self.i64s("offsets");
        let from = if k == 0 { 0 } else { offsets[k - 1] as usize };
        let to = offsets[k] as usize;
        xyz[3 * from..3 * to]
            .chunks_exact(3)
            .map(|c| {
                assert_eq!(c[2], 0.0, "a 2D crack point off z = 0");
                [c[0], c[1]]
            })
            .collect()
    }
}

/// The `(timestep, file)` entries of a `.pvd`.
fn read_pvd(path: &Path) -> Vec<(f64, String)> {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .filter(|l| l.contains("<DataSet "))
        .map(|l| {
            (
                attr(l, "timestep").parse().unwrap(),
                attr(l, "file").to_string(),
            )
        })
        .collect()
}

/// Each crack file holds three polylines per crack (plane, above, below,
/// crack after crack), tagged `crack` and `surface` as cell data, with the
/// crack's points: at t = 0 the scene's, at the end the model's (the top
/// block has pulled the upper face of the interface crack away from the
/// lower one, so the surfaces differ there).
#[test]
fn each_crack_file_holds_every_cracks_plane_and_surfaces() {
    let tmp = tempfile::tempdir().unwrap();
    let (sim, paths) = run(&scene(true), tmp.path());
    let cramp = sim.model::<Cramp>().expect("the crack model");
    assert_eq!(cramp.cracks.len(), 2);

    let first = read_lines(&tmp.path().join("cracks_0000.vtp"));
    let last = read_lines(&tmp.path().join("cracks_0004.vtp"));
    assert!(!tmp.path().join("cracks_0005.vtp").exists());
    for f in [&first, &last] {
        assert_eq!(f.lines, 6, "three lines per crack");
        assert_eq!(f.points, 3 * (INTERFACE.len() + INSIDE.len()));
        assert_eq!(f.u32s("crack"), [0, 0, 0, 1, 1, 1]);
        assert_eq!(
            f.u32s("surface"),
            [PLANE, ABOVE, BELOW, PLANE, ABOVE, BELOW]
        );
        assert!(f.xml.contains("<CellData>") && f.xml.contains("<Lines>"));
        assert_eq!(
            f.i64s("connectivity"),
            (0..f.points as i64).collect::<Vec<_>>()
        );
        let n = [INTERFACE.len(), INSIDE.len()];
        let ends: Vec<i64> = [n[0], 2 * n[0], 3 * n[0]]
            .into_iter()
            .chain([1, 2, 3].map(|k| 3 * n[0] + k * n[1]))
            .map(|e| e as i64)
            .collect();
        assert_eq!(f.i64s("offsets"), ends);
    }
    // at t = 0 every line is the scene's polyline
    for (k, want) in [INTERFACE.to_vec(), INSIDE.to_vec()].iter().enumerate() {
        for s in 0..3 {
            assert_eq!(&first.line(3 * k + s), want, "crack {k} line {s} at t = 0");
        }
    }
    // at the end the model's points, first and last included
    for (k, crack) in cramp.cracks.iter().enumerate() {
        for (s, want) in [&crack.plane, &crack.above, &crack.below]
            .into_iter()
            .enumerate()
        {
            let got = last.line(3 * k + s);
            assert_eq!(got.len(), want.len());
            assert_eq!(got.first(), want.first(), "crack {k} line {s} starts");
            assert_eq!(got.last(), want.last(), "crack {k} line {s} ends");
            assert_eq!(&got, want, "crack {k} line {s}");
        }
    }
    let (above, below) = (last.line(1), last.line(2));
    assert!(
        above[1][1] - below[1][1] > 0.5 * sim.time(),
        "the interface crack did not open: {above:?} {below:?}"
    );
    assert_ne!(
        last.line(3),
        INSIDE.to_vec(),
        "the inner crack did not move"
    );

    // the collection: one entry per snapshot, at the particles' times
    let cracks = read_pvd(&tmp.path().join("cracks.pvd"));
    let particles = read_pvd(&tmp.path().join("particles.pvd"));
    assert_eq!(paths.cracks_pvd, Some(tmp.path().join("cracks.pvd")));
    assert_eq!(cracks.len(), 5);
    for (k, ((tc, fc), (tp, _))) in cracks.iter().zip(&particles).enumerate() {
        assert_eq!(fc, &format!("cracks_{k:04}.vtp"));
        assert_eq!(tc, tp, "{fc} is listed at another time than its particles");
        assert!(tmp.path().join(fc).is_file());
        assert!(paths.snapshots.contains(&tmp.path().join(fc)));
    }
    assert_eq!(cracks[0].0, 0.0);
    assert_eq!(cracks[4].0, sim.time());
}

/// A scene without cracks writes no crack file, no collection of them,
/// and reports none (its JSON is what it was before crack files).
#[test]
fn a_scene_without_cracks_writes_no_crack_files() {
    let tmp = tempfile::tempdir().unwrap();
    let (_, paths) = run(&scene(false), tmp.path());
    assert!(tmp.path().join("particles_0004.vtp").is_file());
    for e in std::fs::read_dir(tmp.path()).unwrap() {
        let name = e.unwrap().file_name();
        assert!(
            !name.to_string_lossy().starts_with("cracks"),
            "{name:?} written without cracks"
        );
    }
    assert_eq!(paths.cracks_pvd, None);
    let json = serde_json::to_string(&paths).unwrap();
    assert!(!json.contains("cracks"), "{json}");
}

/// A run checkpointed halfway, lost a quarter later and resumed from the
/// checkpoint writes the straight run's `cracks.pvd`: the entries from
/// before the checkpoint (which the resumed writer did not write) are
/// listed too, and the last crack file is the straight run's.
#[test]
fn a_resumed_runs_collection_lists_the_earlier_crack_files() {
    let scene = scene(true);
    let tmp = tempfile::tempdir().unwrap();
    let (a, b) = (tmp.path().join("straight"), tmp.path().join("resumed"));
    let (sim, _) = run(&scene, &a);
    let (at, lost) = (sim.steps() / 2, sim.steps() / 4);

    let mut obs = Interrupted {
        writer: OutputWriter::create(&b).unwrap(),
        at,
        lost,
    };
    let mut sim = Simulation::new(&scene);
    assert!(sim.run(&mut obs).unwrap().cancelled);
    obs.writer.finish().unwrap();
    let lost_entries = read_pvd(&b.join("cracks.pvd"));
    assert!(
        (3..5).contains(&lost_entries.len()),
        "the lost run wrote past the checkpoint, not to the end: {lost_entries:?}"
    );

    let mut cp = OutputWriter::load_checkpoint(&b).unwrap();
    let state = std::mem::take(&mut cp.observer);
    let mut sim = Simulation::resume(&scene, cp).unwrap_or_else(|e| panic!("{e}"));
    let mut w = OutputWriter::resume(&b, &state).unwrap();
    assert!(!sim.run(&mut w).unwrap().cancelled);
    let paths = w.finish().unwrap();

    let straight = read_pvd(&a.join("cracks.pvd"));
    assert_eq!(straight.len(), 5);
    assert_eq!(read_pvd(&b.join("cracks.pvd")), straight);
    assert_eq!(
        std::fs::read(b.join("cracks.pvd")).unwrap(),
        std::fs::read(a.join("cracks.pvd")).unwrap()
    );
    assert_eq!(paths.cracks_pvd, Some(b.join("cracks.pvd")));
    assert_eq!(
        std::fs::read(b.join("cracks_0004.vtp")).unwrap(),
        std::fs::read(a.join("cracks_0004.vtp")).unwrap()
    );
}
