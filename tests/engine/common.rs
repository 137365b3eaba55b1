//! Helpers shared by the integration tests (the modules of `tests/engine`;
//! a module that needs them says `use crate::common;`).

use cleave::checkpoint::Checkpoint;
use cleave::diagnostics::{Control, Observer, Progress, SeriesRow, Snapshot};
use cleave::output::OutputWriter;

/// The least-squares slope of `(t, v)` samples taken after `after`: the
/// acceleration of a body whose velocity was sampled over time.
pub fn slope_after(samples: &[(f64, f64)], after: f64) -> f64 {
    let fit: Vec<_> = samples.iter().filter(|s| s.0 > after).collect();
    let n = fit.len() as f64;
    let (st, sv) = fit.iter().fold((0.0, 0.0), |a, s| (a.0 + s.0, a.1 + s.1));
    let (mt, mv) = (st / n, sv / n);
    let (num, den) = fit.iter().fold((0.0, 0.0), |a, s| {
        (a.0 + (s.0 - mt) * (s.1 - mv), a.1 + (s.0 - mt).powi(2))
    });
    num / den
}

/// `scene` run to its end in `D` dimensions, sampling the mass-weighted
/// mean x-velocity of body `body` after every step: the slope of those
/// samples after `after` seconds, the acceleration of a block sliding
/// down an incline (2D and 3D, with contact groups or DFG self-contact).
pub fn body_acceleration_x<const D: usize, const V: usize>(
    scene: &cleave::scene::Scene,
    body: u16,
    after: f64,
) -> f64
where
    cleave::particles::Particles<D, V>: cleave::mpm::Saved,
{
    let mut sim = cleave::mpm::Simulation::<D, V>::build(scene);
    let mut samples = Vec::new();
    while sim.time() < scene.file.time.end * (1.0 - 1e-12) {
        sim.step().expect("the block slides");
        let p = sim.particles();
        let (mut m, mut px) = (0.0, 0.0);
        for k in 0..p.len() {
            if p.body[k] == body {
                m += p.mass[k];
                px += p.mass[k] * p.v[k][0];
            }
        }
        samples.push((sim.time(), px / m));
    }
    slope_after(&samples, after)
}

/// The mass-weighted mean x-velocity of the particles right of `x0`: how
/// much of its motion the right half of a bar pulled apart keeps.
pub fn mean_vx_right_of<const D: usize, const V: usize>(
    p: &cleave::particles::Particles<D, V>,
    x0: f64,
) -> f64 {
    let (mut m, mut px) = (0.0, 0.0);
    for k in 0..p.len() {
        if p.x[k][0] > x0 {
            m += p.mass[k];
            px += p.mass[k] * p.v[k][0];
        }
    }
    px / m
}

/// The value of column `name` in the last row a run recorded.
pub fn last_value(rec: &cleave::diagnostics::Recorder, cols: &[String], name: &str) -> f64 {
    rec.rows
        .last()
        .expect("a recorded row")
        .get(cols, name)
        .unwrap_or_else(|| panic!("no column {name}"))
}

/// `f` run on a pool of `threads` threads: what the tests that compare one
/// and two threads run their simulation in.
pub fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool")
        .install(f)
}

/// What [`run_bits`] keeps of a run: the series with every value as its
/// bits (so that `==` compares them bitwise), the particles at the end,
/// and the count of steps with contact.
pub type RunBits<const D: usize, const V: usize> =
    (Vec<Vec<u64>>, cleave::particles::Particles<D, V>, u64);

/// `scene` run to its end in `D` dimensions, for the tests that compare
/// two runs (thread counts, the baseline and the wide copies of
/// `cleave::cpu`) to the bit. `what` names the run in a failure.
pub fn run_bits<const D: usize, const V: usize>(
    scene: &cleave::scene::Scene,
    what: &str,
) -> RunBits<D, V>
where
    cleave::particles::Particles<D, V>: cleave::mpm::Saved,
{
    let mut sim = cleave::mpm::Simulation::<D, V>::build(scene);
    let mut rec = cleave::diagnostics::Recorder::default();
    let summary = sim.run(&mut rec).unwrap_or_else(|e| panic!("{what}: {e}"));
    let rows = rec
        .rows
        .iter()
        .map(|r| r.values().iter().map(|v| v.to_bits()).collect())
        .collect();
    (rows, sim.particles().clone(), summary.contact_steps)
}

/// A small 3D impact: a stiff sphere at 60 m/s on a free beam, both with a
/// 2nd-order phase field, solved directly (so that a resumed run repeats
/// the straight one bit for bit, `tests/engine/checkpoint.rs`); `tests/engine/phase_field3d.rs`
/// runs it on 1 and 2 threads.
pub const PF_IMPACT_3D: &str = r#"
[grid]
cell_size = 1.0e-3
min = [0.0, 0.0, 0.0]
max = [0.016, 0.024, 0.008]
shape_function = "quadratic_bspline"
[time]
end = 1.2e-5
cfl = 0.4
[contact]
friction = 0.65
[materials.beam]
model = "linear_elastic"
density = 8000.0
youngs_modulus = 1.9e11
poissons_ratio = 0.3
phase_field = { gc = 20000.0, l0 = 2.0e-3 }
[materials.sphere]
model = "linear_elastic"
density = 8000.0
youngs_modulus = 1.9e11
poissons_ratio = 0.3
phase_field = { gc = 2.0e6, l0 = 2.0e-3 }
[[bodies]]
name = "beam"
shape = { type = "box", min = [0.008, 0.002, 0.002], max = [0.012, 0.022, 0.006] }
material = "beam"
contact_group = 1
[[bodies]]
name = "sphere"
shape = { type = "sphere", center = [0.0045, 0.012, 0.004], radius = 0.0025 }
material = "sphere"
velocity = [60.0, 0.0, 0.0]
[output]
series_rows = 13
snapshots = 0
[phase_field_solver]
method = "direct"
"#;

/// The text of `scenes/NAME`, a shipped scene.
pub fn shipped(name: &str) -> String {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Asserts that `text` is refused and that the refusal holds each of
/// `expect`.
pub fn refused(text: &str, expect: &[&str]) {
    let e = match cleave::scene::Scene::from_text(text, None) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    };
    for x in expect {
        assert!(e.contains(x), "{x:?} not in: {e}");
    }
}

/// The name libtest knows test `test` by in this binary: its module's
/// path without the crate's name, then the test's.
pub fn test_name(module_path: &str, test: &str) -> String {
    match module_path.split_once("::") {
        Some((_, module)) => format!("{module}::{test}"),
        None => test.to_string(),
    }
}

/// Whether this process is the child [`run_in_child`] started.
pub fn in_child() -> bool {
    std::env::var_os("CLEAVE_TEST_CHILD").is_some()
}

/// Runs the test `name` (as [`test_name`] gives it) of this test binary
/// again, alone, in a child process, for what a test must not do to the
/// process the other tests share: a resource limit, an environment. The
/// child runs under `sh -c "{shell}exec …"` (`shell` is empty or ends in
/// `&& `) with `envs` and `CLEAVE_TEST_CHILD` set; panics with its output
/// unless it ran that test and passed.
pub fn run_in_child(name: &str, shell: &str, envs: &[(&str, &std::ffi::OsStr)]) {
    let exe = std::env::current_exe().unwrap();
    let out = std::process::Command::new("sh")
        .arg("-c")
        .arg(format!(
            r#"{shell}exec "$0" --exact "$1" --test-threads=1 --nocapture"#
        ))
        .arg(exe)
        .arg(name)
        .env("CLEAVE_TEST_CHILD", "1")
        .envs(envs.iter().map(|&(k, v)| (k, v)))
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && text.contains("1 passed"), "{text}");
}

/// An output writer that asks for a checkpoint at the end of step `at`
/// and then stops (the process "is lost") `lost` steps later, after it has
/// written rows and snapshots past the checkpoint.
pub struct Interrupted {
    pub writer: OutputWriter,
    pub at: u64,
    pub lost: u64,
}

impl Observer for Interrupted {
    fn series_columns(&mut self, c: &[String]) -> Result<(), String> {
        self.writer.series_columns(c)
    }
    fn series_row(&mut self, r: &SeriesRow) -> Result<(), String> {
        self.writer.series_row(r)
    }
    fn snapshot(&mut self, s: &Snapshot) -> Result<(), String> {
        self.writer.snapshot(s)
    }
    fn progress(&mut self, p: &Progress) -> Control {
        match p.step {
            s if s == self.at => Control::Checkpoint,
            s if s == self.at + self.lost => Control::Stop,
            _ => Control::Continue,
        }
    }
    fn checkpoint(&mut self, cp: Checkpoint<'_>) -> Result<(), String> {
        self.writer.checkpoint(cp)
    }
}
