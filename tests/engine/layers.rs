//! Layers that point one way (issue 31). From the bottom:
//!
//! - the base (particles, grid, kernels, materials, geometry, contact,
//!   the measures) imports nothing above it: the scene builds base types
//!   (its schema re-exports the shape, shape-function, material-model and
//!   plane enums that live in the base);
//! - the fracture models never reach the engine that runs them, nor the
//!   methods, the run seam or anything that drives a run;
//! - what reports on a run (diagnostics, output, the checkpoint file)
//!   never reaches back into a step: it knows no method;
//! - the run seam (`run.rs`: the `Method` trait and what methods share)
//!   knows no method either; `methods.rs` is the one place that names
//!   them;
//! - a method (the grid MPM, the damage particle method) knows nothing of
//!   who drives it, nor of the other method;
//! - the drivers (jobs, the service, studies) build methods through
//!   `methods.rs`, never a method itself.
//!
//! A source check rather than a compiler one: the modules are one crate,
//! so only reading their files shows which way an import points.

use std::path::{Path, PathBuf};

/// Each layer: its files (or folders, every `.rs` under them), and the
/// modules it must not import.
const LAYERS: &[(&str, &[&str], &[&str])] = &[
    (
        "base",
        &[
            "src/particles.rs",
            "src/tensor.rs",
            "src/grid",
            "src/material",
            "src/geometry",
            "src/contact.rs",
            "src/diagnostics/measure.rs",
            "src/diagnostics/crack.rs",
            "src/diagnostics/fragments.rs",
        ],
        &[
            "scene",
            "mpm",
            "dpm",
            "fracture",
            "run",
            "methods",
            "checkpoint",
            "output",
            "study",
            "jobs",
            "service",
        ],
    ),
    (
        "fracture models",
        &["src/fracture"],
        &[
            "mpm", "dpm", "run", "methods", "output", "study", "jobs", "service",
        ],
    ),
    (
        "reporting",
        &["src/diagnostics", "src/output", "src/checkpoint.rs"],
        &["mpm", "methods", "study", "jobs", "service"],
    ),
    (
        "run seam",
        &["src/run.rs"],
        &["mpm", "methods", "output", "study", "jobs", "service"],
    ),
    (
        "methods",
        &["src/mpm"],
        &["dpm", "methods", "study", "jobs", "service"],
    ),
    (
        "the damage particle method (a method beside the grid MPM)",
        &["src/dpm"],
        &["mpm", "fracture", "methods", "study", "jobs", "service"],
    ),
    (
        "drivers",
        &["src/jobs", "src/service", "src/study.rs"],
        &["mpm", "dpm"],
    ),
];

#[test]
fn layers_import_nothing_above_them() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut found = Vec::new();
    for (layer, paths, above) in LAYERS {
        let mut files = Vec::new();
        for entry in *paths {
            let path = root.join(entry);
            assert!(
                path.exists(),
                "{entry} is listed in a layer but does not exist"
            );
            rust_files(&path, &mut files);
        }
        assert!(files.len() >= paths.len(), "{layer}: {} files", files.len());
        for file in &files {
            let text = std::fs::read_to_string(file).unwrap();
            let name = file.strip_prefix(root).unwrap().display().to_string();
            for (line, module) in imports_above(&text, above) {
                found.push(format!("{name}:{line}: crate::{module} ({layer})"));
            }
        }
    }
    assert!(
        found.is_empty(),
        "a layer imports from above it (move the type down and re-export \
         it from above instead):\n{}",
        found.join("\n")
    );
}

/// The check itself, on text it is known to catch and to let pass.
#[test]
fn the_layer_check_finds_what_it_should() {
    let text = "\
//! A doc link to [`Scene`](crate::scene::Scene) is fine.
use crate::grid::GridGeom;
use crate::scene::ShapeSpec;
/// So is [`crate::mpm::Simulation`] here.
pub fn f(c: &[crate::fracture::Crack]) {}
use crate::{grid, jobs::Store};
macro_rules! m { () => { $crate::scene::X::Y } }
use crate::scenery::Fine;

#[cfg(test)]
mod tests {
    use crate::scene::Scene;
    fn brace_in_string() -> &'static str { \"{\" }
}

fn after_tests() { crate::study::variants(); }
#[cfg(test)]
use crate::mpm::Simulation;
";
    let found = imports_above(text, LAYERS[0].2);
    assert_eq!(
        found,
        [
            (3, "scene"),
            (5, "fracture"),
            (6, "jobs"),
            (7, "scene"),
            (16, "study")
        ]
    );
}

fn rust_files(path: &Path, out: &mut Vec<PathBuf>) {
    if path.is_dir() {
        let mut entries: Vec<_> = std::fs::read_dir(path)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        entries.sort();
        for p in entries {
            rust_files(&p, out);
        }
    } else if path.extension().is_some_and(|e| e == "rs") {
        out.push(path.to_path_buf());
    }
}

/// (1-based line, module) for every path into a module of `above` in
/// non-test code: `crate::m` or `$crate::m` anywhere on a line, or `m` in a
/// one-line `use crate::{…}` group. Comment lines (`//`, `///`, `//!`) are
/// skipped, and so is the item after `#[cfg(test)]` (up to its closing
/// brace, or its `;`).
fn imports_above(text: &str, above: &[&'static str]) -> Vec<(usize, &'static str)> {
    let mut found = Vec::new();
    // inside a `#[cfg(test)]` item: its brace depth so far, and whether
    // its body has opened
    let mut test_item: Option<(i64, bool)> = None;
    for (i, raw) in text.lines().enumerate() {
        let mut line = raw.trim();
        if line.starts_with("//") {
            continue;
        }
        if let Some(rest) = line.strip_prefix("#[cfg(test)]") {
            test_item = Some((0, false));
            line = rest.trim();
            if line.is_empty() {
                continue;
            }
        }
        if let Some((depth, opened)) = test_item.as_mut() {
            let code = without_literals(line);
            *depth += code.matches('{').count() as i64 - code.matches('}').count() as i64;
            *opened |= code.contains('{');
            if (*opened && *depth <= 0) || (!*opened && code.ends_with(';')) {
                test_item = None;
            }
            continue;
        }
        for &module in above {
            if names_module(line, module) {
                found.push((i + 1, module));
            }
        }
    }
    found
}

/// Whether `line` has the path `crate::module` (whole segment) or names
/// `module` in a `crate::{…}` group.
fn names_module(line: &str, module: &str) -> bool {
    let segment_ends = |rest: &str| !rest.starts_with(|c: char| c.is_alphanumeric() || c == '_');
    let direct = format!("crate::{module}");
    if line
        .match_indices(&direct)
        .any(|(at, _)| segment_ends(&line[at + direct.len()..]))
    {
        return true;
    }
    let compact: String = line.chars().filter(|c| !c.is_whitespace()).collect();
    compact.match_indices("crate::{").any(|(at, open)| {
        let inner = &compact[at + open.len()..];
        let inner = &inner[..inner.find('}').unwrap_or(inner.len())];
        inner
            .split(',')
            .any(|item| item.strip_prefix(module).is_some_and(segment_ends))
    })
}

/// `line` with string and char literals emptied, so that their braces do
/// not count.
fn without_literals(line: &str) -> String {
    let mut out = String::new();
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' => {
                while let Some(c) = chars.next() {
                    match c {
                        '\\' => {
                            chars.next();
                        }
                        '"' => break,
                        _ => {}
                    }
                }
                out.push_str("\"\"");
            }
            // a char literal ('{', '\n'), not a lifetime ('a)
            '\'' if matches!(chars.clone().nth(1), Some('\'')) || chars.peek() == Some(&'\\') => {
                if chars.next() == Some('\\') {
                    chars.next();
                }
                chars.next();
                out.push_str("' '");
            }
            _ => out.push(c),
        }
    }
    out
}
