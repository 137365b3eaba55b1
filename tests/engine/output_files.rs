//! The files of a run as a user (and ParaView) gets them: pictures drawn on
//! a machine without any font installed, whose text is really there, and
//! VTK files whose arrays have the shapes VTK expects (vectors of 3,
//! symmetric tensors of 6 in VTK's order), every array as long as its
//! points times its components.

use crate::common;
use cleave::mpm::Simulation;
use cleave::output::{OutputPaths, OutputWriter};
use cleave::scene::Scene;
use std::path::Path;

fn scene_text(file: &str, edits: &[(&str, &str)]) -> String {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut text = std::fs::read_to_string(dir.join(file)).unwrap();
    for (from, to) in edits {
        assert!(text.contains(from), "{file} has no {from:?}");
        text = text.replace(from, to);
    }
    text
}

/// Runs the test `test` of this module again in a child process whose
/// environment has no fonts, as in a bare container: an empty fontconfig
/// configuration and homes with no font directories (a child, because
/// the environment is the process's, which the other tests share).
/// True in that child, where the test goes on; false here once the child
/// passed.
fn in_a_process_without_fonts(test: &str) -> bool {
    if common::in_child() {
        return true;
    }
    let dir = tempfile::tempdir().unwrap();
    let conf = dir.path().join("fonts.conf");
    std::fs::write(&conf, "<?xml version=\"1.0\"?>\n<fontconfig/>\n").unwrap();
    let d = dir.path().as_os_str();
    common::run_in_child(
        &common::test_name(module_path!(), test),
        "",
        &[
            ("FONTCONFIG_FILE", conf.as_os_str()),
            ("FONTCONFIG_PATH", d),
            ("XDG_DATA_HOME", d),
            ("HOME", d),
        ],
    );
    false
}

/// Runs `text` to its end with an [`OutputWriter`] in `dir`.
fn run(text: &str, dir: &Path) -> OutputPaths {
    let scene = Scene::from_text(text, None).unwrap();
    let mut w = OutputWriter::create(dir).unwrap();
    let mut sim = Simulation::new(&scene);
    let s = sim.run(&mut w).unwrap();
    assert!(!s.cancelled);
    w.finish().unwrap()
}

/// Width and height from a PNG's IHDR chunk.
fn png_size(path: &Path) -> (u32, u32) {
    let b = std::fs::read(path).unwrap();
    assert_eq!(
        &b[..8],
        b"\x89PNG\r\n\x1a\n",
        "{} is not a PNG",
        path.display()
    );
    assert_eq!(&b[12..16], b"IHDR");
    let be = |i: usize| u32::from_be_bytes(b[i..i + 4].try_into().unwrap());
    (be(16), be(20))
}

/// Pixels of `img` in the rectangle [x0, x1) × [y0, y1) for which `pick`
/// holds.
fn count(
    img: &image::RgbImage,
    (x0, x1): (u32, u32),
    (y0, y1): (u32, u32),
    pick: impl Fn([u8; 3]) -> bool,
) -> usize {
    let mut n = 0;
    for y in y0..y1.min(img.height()) {
        for x in x0..x1.min(img.width()) {
            n += pick(img.get_pixel(x, y).0) as usize;
        }
    }
    n
}

fn dark(p: [u8; 3]) -> bool {
    p.iter().all(|&c| c < 110)
}

#[test]
fn a_run_without_fonts_writes_pictures_with_their_text() {
    if !in_a_process_without_fonts("a_run_without_fonts_writes_pictures_with_their_text") {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    // the coarse P1 plate, a few steps: a phase field, a crack tip
    let text = scene_text(
        "p1_plate_coarse.toml",
        &[
            ("end = 8.0e-5", "end = 2.0e-6"),
            ("series_rows = 81", "series_rows = 5"),
            ("snapshots = 9", "snapshots = 2"),
        ],
    );
    let paths = run(&text, tmp.path());

    let energies = paths.energy_plot.expect("energies.png drawn");
    assert!(paths.crack_plot.is_some(), "crack.png drawn");
    assert_eq!(png_size(&energies), (900, 520));
    let img = image::open(&energies).unwrap().to_rgb8();
    // the caption "Energies" above the chart, the rotated "energy in J"
    // on the left, the tick labels under it
    assert!(count(&img, (350, 550), (0, 40), dark) > 40, "no caption");
    assert!(count(&img, (0, 40), (100, 420), dark) > 20, "no y label");
    assert!(count(&img, (80, 900), (470, 495), dark) > 40, "no x ticks");

    let images: Vec<&Path> = paths
        .snapshots
        .iter()
        .map(|p| p.as_path())
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    assert_eq!(images.len(), 2, "{:?}", paths.snapshots);
    let last = images.len() - 1;
    for (k, path) in images.into_iter().enumerate() {
        assert!(path
            .file_name()
            .unwrap()
            .to_string_lossy()
            .starts_with("phase_field_"));
        let (w, h) = png_size(path);
        // the plate is 100 mm × 40 mm: a wide picture
        assert!(w > 1000 && h > 400 && w > 2 * h, "{w} × {h}");
        let img = image::open(path).unwrap().to_rgb8();
        assert!(count(&img, (0, 400), (0, 35), dark) > 60, "no title");
        assert!(count(&img, (0, 45), (80, h - 80), dark) > 20, "no y label");
        // the colour bar's two ends (viridis: dark purple, yellow) on the
        // right, and after the first phase-field solve (not yet at t = 0)
        // the crack (c = 0) in the plate
        let bar = (w - 170, w);
        let purple = |p: [u8; 3]| p[0] < 90 && p[1] < 40 && p[2] > 60;
        let yellow = |p: [u8; 3]| p[0] > 220 && p[1] > 200 && p[2] < 80;
        assert!(count(&img, bar, (0, h), purple) > 50, "bar bottom");
        assert!(count(&img, bar, (0, h), yellow) > 50, "bar top");
        if k == last {
            assert!(count(&img, (100, w - 200), (0, h), purple) > 500, "crack");
        }
        // the bar's name, rotated, at the far right
        assert!(
            count(&img, (w - 40, w), (60, h - 60), dark) > 40,
            "bar label"
        );
    }
}

/// One `<DataArray>` of a VTK XML file: its attributes and its bytes.
struct Array {
    name: String,
    ty: String,
    components: usize,
    bytes: Vec<u8>,
}

/// Reads the attribute `key` of the XML element text `el`.
fn attr<'a>(el: &'a str, key: &str) -> Option<&'a str> {
    let at = el.find(&format!(" {key}=\""))? + key.len() + 3;
    el[at..].split('"').next()
}

/// The `<DataArray>`s of a file written with raw appended data, decoded
/// by their offsets, and the number of points the file declares.
fn arrays(path: &Path) -> (usize, Vec<Array>) {
    let bytes = std::fs::read(path).unwrap();
    let open = b"<AppendedData encoding=\"raw\">";
    let start = bytes
        .windows(open.len())
        .position(|w| w == open)
        .expect("appended data");
    let xml = std::str::from_utf8(&bytes[..start]).unwrap();
    let data = start + bytes[start..].iter().position(|&b| b == b'_').unwrap() + 1;
    assert!(attr(xml, "header_type") == Some("UInt64"));
    let points = if let Some(n) = attr(xml, "NumberOfPoints") {
        n.parse().unwrap()
    } else {
        let e: Vec<usize> = attr(xml, "WholeExtent")
            .unwrap()
            .split(' ')
            .map(|v| v.parse().unwrap())
            .collect();
        (e[1] - e[0] + 1) * (e[3] - e[2] + 1) * (e[5] - e[4] + 1)
    };
    let arrays = xml
        .split("<DataArray")
        .skip(1)
        .map(|el| {
            let el = el.split("/>").next().unwrap();
            let offset: usize = attr(el, "offset").unwrap().parse().unwrap();
            let at = data + offset;
            let len = u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap()) as usize;
            Array {
                name: attr(el, "Name").unwrap_or("").to_string(),
                ty: attr(el, "type").unwrap().to_string(),
                components: attr(el, "NumberOfComponents").unwrap().parse().unwrap(),
                bytes: bytes[at + 8..at + 8 + len].to_vec(),
            }
        })
        .collect();
    (points, arrays)
}

fn f64s(b: &[u8]) -> Vec<f64> {
    b.chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

#[test]
fn vtk_files_have_the_shapes_paraview_expects() {
    let tmp = tempfile::tempdir().unwrap();
    // the two disks just after they meet: stress in both, shear too
    let text = scene_text(
        "two_disks.toml",
        &[
            ("end = 3.0", "end = 1.3"),
            ("series_rows = 301", "series_rows = 3"),
            ("snapshots = 13", "snapshots = 2"),
        ],
    );
    let paths = run(&text, tmp.path());
    let (mut vtp, mut vti, mut shear) = (0, 0, false);
    for path in &paths.snapshots {
        let ext = path.extension().unwrap().to_string_lossy().to_string();
        if ext != "vtp" && ext != "vti" {
            continue;
        }
        let (points, list) = arrays(path);
        assert!(points > 0);
        for a in &list {
            let size = match a.ty.as_str() {
                "Float64" | "Int64" => 8,
                "UInt32" => 4,
                t => panic!("{}: type {t}", path.display()),
            };
            let values = a.bytes.len() / size;
            // the vertices' connectivity and offsets count vertices, one per
            // point here; every other array has a tuple per point
            assert_eq!(
                values,
                points * a.components,
                "{}: {} has {values} values for {points} points × {}",
                path.display(),
                a.name,
                a.components
            );
            let want = match a.name.as_str() {
                "velocity" | "position" => 3,
                "stress" | "strain" => 6,
                _ => 1,
            };
            assert_eq!(a.components, want, "{}: {}", path.display(), a.name);
        }
        let get = |name: &str| f64s(&list.iter().find(|a| a.name == name).unwrap().bytes);
        let v = get("velocity");
        assert!(v.chunks(3).all(|c| c[2] == 0.0), "velocity z");
        assert!(v.iter().any(|&x| x != 0.0), "velocity all zero");
        if ext == "vti" {
            vti += 1;
            continue;
        }
        vtp += 1;
        // Plane-strain linear elasticity (the disks' material, E = 1000 Pa,
        // ν = 0.3): ε_zz = 0 and σ_zz = λ(ε_xx + ε_yy), with
        // λ = Eν/((1+ν)(1−2ν)). In VTK's order xx yy zz xy yz xz that puts
        // λ times the sum of the first two strain components in the
        // stress's third, and zeros in the strain's third and the last two
        // of both.
        let lambda = 1000.0 * 0.3 / (1.3 * 0.4);
        let (s, e) = (get("stress"), get("strain"));
        for (s, e) in s.chunks(6).zip(e.chunks(6)) {
            assert_eq!([e[2], e[4], e[5], s[4], s[5]], [0.0; 5]);
            let want = lambda * (e[0] + e[1]);
            assert!(
                (s[2] - want).abs() <= 1e-9 * want.abs() + 1e-300,
                "σzz {} ≠ λ(εxx + εyy) = {want}",
                s[2]
            );
            shear |= s[3] != 0.0 && e[3] != 0.0;
        }
    }
    // the grid is written from the first step on, so not at t = 0
    assert_eq!((vtp, vti), (2, 1), "{:?}", paths.snapshots);
    assert!(shear, "no shear stress and strain in the snapshots");
}
