//! The CPU's wider instructions for the hot loops, chosen at run time.
//!
//! A release build targets the baseline x86-64 (SSE2: sixteen 128-bit
//! registers), so that one binary runs on every x86-64 machine a fleet
//! has. The transfer loops keep more accumulators than SSE2 has registers
//! (G2P's APIC gathers 21 sums per particle in 3D) and spend much of their
//! time moving values to and from the stack. [`wide`] runs a closure in a
//! copy of itself compiled for AVX2 (with AVX-512 where the CPU has it:
//! 32 registers), chosen once per call by the CPU's feature flags, and the
//! plain copy elsewhere.
//!
//! **The same bits.** Enabling instruction sets changes which instructions
//! carry out each operation, never the operations: Rust neither fuses a
//! product and a sum into an FMA nor reorders floating-point sums (it
//! emits no fast-math or contraction flags), so every `+` and `*` is the
//! same IEEE operation, rounded the same way, in either copy. `f64::mul_add`
//! is a fused operation in both (an instruction here, a correctly rounded
//! libm call there). Results are bitwise the same with and without the wide
//! copy, which `tests/engine/verification3d.rs` checks on whole runs in 2D and
//! 3D ([`force`]).
//!
//! **How the compiler gets there.** `wide::<R>` calls an
//! `#[target_feature]` function that calls the closure; a function without
//! features may be inlined into one with more (LLVM's rule: the callee's
//! features a subset of the caller's), and the closure and everything it
//! inlines (`Support::for_each`, the per-node closures) is then compiled
//! with the wider set. So call it around a loop whose body is inlined: the
//! work of one rayon task (a tile, a chunk of particles), not around the
//! `par_iter` (rayon's job bodies are separate functions that would stay
//! baseline).
//!
//! `CLEAVE_CPU=baseline` (or `avx2`) in the environment caps the level
//! (to compare, or on a machine where a wider unit runs slower); it is
//! read once.

use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::OnceLock;

/// The instruction set [`wide`] runs its closure with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    /// The build's target (x86-64: SSE2), or a non-x86 machine.
    Baseline,
    /// AVX2 (and FMA for `mul_add`).
    Avx2,
    /// AVX-512 F (with AVX2): 32 vector registers.
    Avx512,
}

/// [`force`]'s cap: 0 none, else 1 + the level's rank.
static CAP: AtomicU8 = AtomicU8::new(0);

/// The level [`wide`] uses now: the widest this CPU has, capped by
/// `CLEAVE_CPU` (`baseline` or `avx2`, read once) and by [`force`].
pub fn level() -> Level {
    static FOUND: OnceLock<Level> = OnceLock::new();
    let found = *FOUND.get_or_init(|| {
        let found = detect();
        match std::env::var("CLEAVE_CPU").unwrap_or_default().as_str() {
            "baseline" => Level::Baseline,
            "avx2" if found == Level::Avx512 => Level::Avx2,
            _ => found,
        }
    });
    match CAP.load(Ordering::Relaxed) {
        0 => found,
        1 => Level::Baseline,
        2 => found.min(Level::Avx2),
        _ => found,
    }
}

/// Caps the level of every later [`wide`] call in this process (`None`:
/// no cap): for tests and benchmarks that compare the copies. Results do
/// not depend on it, only the time.
pub fn force(cap: Option<Level>) {
    let c = cap.map_or(0, |l| 1 + l as u8);
    CAP.store(c, Ordering::Relaxed);
}

#[cfg(target_arch = "x86_64")]
fn detect() -> Level {
    if std::is_x86_feature_detected!("avx512f")
        && std::is_x86_feature_detected!("avx2")
        && std::is_x86_feature_detected!("fma")
    {
        Level::Avx512
    } else if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
        Level::Avx2
    } else {
        Level::Baseline
    }
}

#[cfg(not(target_arch = "x86_64"))]
fn detect() -> Level {
    Level::Baseline
}

/// Runs `f` compiled for the widest instruction set of [`level`] (see the
/// module doc: same results, fewer instructions).
#[inline(always)]
pub fn wide<R>(f: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    {
        match level() {
            // SAFETY: `level` found the features on this CPU.
            Level::Avx512 => return unsafe { avx512(f) },
            Level::Avx2 => return unsafe { avx2(f) },
            Level::Baseline => {}
        }
    }
    f()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn avx2<R>(f: impl FnOnce() -> R) -> R {
    f()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx2,fma")]
unsafe fn avx512<R>(f: impl FnOnce() -> R) -> R {
    f()
}
