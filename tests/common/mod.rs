//! Helpers shared by the integration tests (each test file that needs
//! them declares `mod common;`). Each test file compiles this module
//! and uses only some of it, hence the allowance.
#![allow(dead_code)]

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

/// `f` run on a pool of `threads` threads: what the tests that compare one
/// and two threads run their simulation in.
pub fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("a thread pool")
        .install(f)
}
