//! 1D shape functions on a uniform grid, combined by tensor product in 2D.
//!
//! All kernels work in cell units: `xi = (x − x_0)/h` is the particle's
//! position in node indices. [`Kernel::eval`] returns the first node of the
//! support, the weights, and their derivatives with respect to the particle
//! position (per cell: divide by `h` for per-metre). B-splines also give
//! second derivatives ([`Kernel::eval2`]), which the 4th-order phase field
//! needs.
//!
//! - linear hat (Sulsky et al. 1994), support 2 nodes;
//! - uniform GIMP (Bardenhagen & Kober 2004, eq. 34 with the particle
//!   half-width `lp` fixed at its initial value), support 3 nodes;
//! - quadratic B-spline (Steffen et al. 2008), support 3 nodes, C¹;
//! - cubic B-spline, support 4 nodes, C²;
//! - local maximum-entropy approximants (Arroyo & Ortiz 2006), support
//!   4 nodes, locality γ from the grid ([`Lme`]).

use serde::{Deserialize, Serialize};

/// The grid's shape functions (a scene's `grid.shape_function`);
/// `by_kernel!` turns one into its kernel type.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ShapeFunctionKind {
    /// Bilinear hat functions (C⁰, cell-crossing noise).
    Linear,
    /// Uniform GIMP with the particle domain fixed at its initial size.
    Gimp,
    /// Quadratic B-splines (C¹): the default.
    #[default]
    QuadraticBspline,
    /// Cubic B-splines (C²).
    CubicBspline,
    /// Local maximum-entropy approximants (C∞ inside a cell; locality
    /// `grid.lme_gamma`).
    Lme,
}

impl ShapeFunctionKind {
    /// The name a scene gives it (`grid.shape_function`).
    pub fn name(self) -> &'static str {
        match self {
            ShapeFunctionKind::Linear => "linear",
            ShapeFunctionKind::Gimp => "gimp",
            ShapeFunctionKind::QuadraticBspline => "quadratic_bspline",
            ShapeFunctionKind::CubicBspline => "cubic_bspline",
            ShapeFunctionKind::Lme => "lme",
        }
    }
}

/// Evaluates `body` with the type `K` bound to the kernel of `kind`: one
/// dispatch from the scene's shape function to the generic stages.
macro_rules! by_kernel {
    ($kind:expr, $K:ident => $body:expr) => {
        by_kernel!(@arms $kind, $K, $body, Linear, Gimp, QuadraticBspline, CubicBspline, Lme)
    };
    // each ShapeFunctionKind variant is named as its kernel type
    (@arms $kind:expr, $K:ident, $body:expr, $($kernel:ident),*) => {
        match $kind {
            $($crate::grid::shape::ShapeFunctionKind::$kernel => {
                type $K = $crate::grid::shape::$kernel;
                $body
            })*
        }
    };
}
pub(crate) use by_kernel;

/// ⌊x⌋, inlined. `f64::floor` is a call into libm on the default x86-64
/// target (no SSE4.1 `roundsd`), and every kernel evaluation of every
/// stage makes one or two: 3.4 % of a `p1_plate.toml` phase-field step's profile.
/// Exact for |x| < 2⁶³ (the cast truncates toward zero; from 2⁵² on every
/// f64 is an integer); beyond that, and for NaN, the result differs from
/// `floor` only where a later `as isize` saturates alike.
#[inline(always)]
pub fn floor(x: f64) -> f64 {
    let t = x as i64 as f64;
    if t > x {
        t - 1.0
    } else {
        t
    }
}

/// Widest support of any kernel (nodes per direction).
pub const MAX_SUPPORT: usize = 4;

/// One 1D kernel evaluation.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Weights1 {
    /// Index of the first node of the support.
    pub base: isize,
    /// N_k(ξ) for k < support.
    pub w: [f64; MAX_SUPPORT],
    /// dN_k/dξ.
    pub dw: [f64; MAX_SUPPORT],
}

/// A 1D kernel. `N` is the support width; arrays past `N` are zero.
pub trait Kernel: Copy + Send + Sync + 'static {
    const N: usize;
    /// `lp`: GIMP half-width of the particle in cells; `gamma`: the LME
    /// locality γ = βh² (the grid's, [`crate::grid::GridGeom::lme_gamma`]).
    /// Each kernel ignores the other's.
    fn eval(xi: f64, lp: f64, gamma: f64) -> Weights1;
    /// Second derivatives d²N_k/dξ² (zero where the kernel is not C¹).
    fn eval2(xi: f64, lp: f64, gamma: f64) -> (Weights1, [f64; MAX_SUPPORT]) {
        (Self::eval(xi, lp, gamma), [0.0; MAX_SUPPORT])
    }
    /// APIC inertia scaling D⁻¹·h² if it is constant for the kernel
    /// (B-splines); None means use the velocity gradient as the affine matrix.
    const APIC_DINV_H2: Option<f64>;
    /// The two-scale mask: a function of this kernel on a grid of spacing
    /// 2h is `Σ_k REFINE[k]·N_{2I+k−(len−1)}` of spacing h. For B-splines of
    /// degree p it is exact, binom(p+1, k)/2^p (de Boor, *A Practical Guide
    /// to Splines*, the knot-insertion relation); the hat and GIMP take linear
    /// interpolation. The phase field's multigrid prolongs with it.
    const REFINE: &'static [f64];
    /// Evaluating the kernel costs enough that a step evaluates each
    /// particle's support once and keeps it for the step's transfers
    /// ([`crate::grid::SupportCache`]): LME's two Newton solves, not a
    /// B-spline's few products (reading a kept support back would cost
    /// them more than it saves).
    const KEPT: bool = false;
}

#[derive(Debug, Clone, Copy)]
pub struct Linear;
#[derive(Debug, Clone, Copy)]
pub struct Gimp;
#[derive(Debug, Clone, Copy)]
pub struct QuadraticBspline;
#[derive(Debug, Clone, Copy)]
pub struct CubicBspline;

impl Kernel for Linear {
    const N: usize = 2;
    const APIC_DINV_H2: Option<f64> = None;
    const REFINE: &'static [f64] = &[0.5, 1.0, 0.5];
    #[inline(always)]
    fn eval(xi: f64, _lp: f64, _gamma: f64) -> Weights1 {
        let b = floor(xi);
        let f = xi - b;
        Weights1 {
            base: b as isize,
            w: [1.0 - f, f, 0.0, 0.0],
            dw: [-1.0, 1.0, 0.0, 0.0],
        }
    }
}

/// GIMP weight and derivative for particle-minus-node distance `d` and
/// half-width `lp` (cells), Bardenhagen & Kober (2004) eq. 34.
#[inline(always)]
fn gimp_1d(d: f64, lp: f64) -> (f64, f64) {
    let a = d.abs();
    let s = if d < 0.0 { -1.0 } else { 1.0 };
    if a < lp {
        (1.0 - (d * d + lp * lp) / (2.0 * lp), -d / lp)
    } else if a < 1.0 - lp {
        (1.0 - a, -s)
    } else if a < 1.0 + lp {
        let t = 1.0 + lp - a;
        (t * t / (4.0 * lp), -s * t / (2.0 * lp))
    } else {
        (0.0, 0.0)
    }
}

impl Kernel for Gimp {
    const N: usize = 3;
    const APIC_DINV_H2: Option<f64> = None;
    const REFINE: &'static [f64] = &[0.5, 1.0, 0.5];
    #[inline(always)]
    fn eval(xi: f64, lp: f64, _gamma: f64) -> Weights1 {
        let base = floor(xi + 0.5) - 1.0;
        let mut out = Weights1 {
            base: base as isize,
            ..Default::default()
        };
        for k in 0..3 {
            let (w, dw) = gimp_1d(xi - (base + k as f64), lp);
            out.w[k] = w;
            out.dw[k] = dw;
        }
        out
    }
}

impl Kernel for QuadraticBspline {
    const N: usize = 3;
    const APIC_DINV_H2: Option<f64> = Some(4.0);
    const REFINE: &'static [f64] = &[0.25, 0.75, 0.75, 0.25];
    #[inline(always)]
    fn eval(xi: f64, _lp: f64, _gamma: f64) -> Weights1 {
        let base = floor(xi - 0.5);
        let fx = xi - base;
        let (a, b, c) = (1.5 - fx, fx - 1.0, fx - 0.5);
        Weights1 {
            base: base as isize,
            w: [0.5 * a * a, 0.75 - b * b, 0.5 * c * c, 0.0],
            dw: [-a, -2.0 * b, c, 0.0],
        }
    }
    fn eval2(xi: f64, lp: f64, gamma: f64) -> (Weights1, [f64; MAX_SUPPORT]) {
        (Self::eval(xi, lp, gamma), [1.0, -2.0, 1.0, 0.0])
    }
}

/// Cubic B-spline N(d), N'(d), N''(d) for particle-minus-node distance `d`.
#[inline(always)]
fn cubic_1d(d: f64) -> (f64, f64, f64) {
    let a = d.abs();
    let s = if d < 0.0 { -1.0 } else { 1.0 };
    if a < 1.0 {
        (
            2.0 / 3.0 - a * a + 0.5 * a * a * a,
            s * (-2.0 * a + 1.5 * a * a),
            -2.0 + 3.0 * a,
        )
    } else if a < 2.0 {
        let t = 2.0 - a;
        (t * t * t / 6.0, -s * 0.5 * t * t, t)
    } else {
        (0.0, 0.0, 0.0)
    }
}

impl Kernel for CubicBspline {
    const N: usize = 4;
    const APIC_DINV_H2: Option<f64> = Some(3.0);
    const REFINE: &'static [f64] = &[0.125, 0.5, 0.75, 0.5, 0.125];
    #[inline(always)]
    fn eval(xi: f64, _lp: f64, _gamma: f64) -> Weights1 {
        let base = floor(xi) - 1.0;
        let mut out = Weights1 {
            base: base as isize,
            ..Default::default()
        };
        for k in 0..4 {
            let (w, dw, _) = cubic_1d(xi - (base + k as f64));
            out.w[k] = w;
            out.dw[k] = dw;
        }
        out
    }
    fn eval2(xi: f64, _lp: f64, _gamma: f64) -> (Weights1, [f64; MAX_SUPPORT]) {
        let base = floor(xi) - 1.0;
        let mut out = Weights1 {
            base: base as isize,
            ..Default::default()
        };
        let mut d2 = [0.0; MAX_SUPPORT];
        for k in 0..4 {
            let (w, dw, ddw) = cubic_1d(xi - (base + k as f64));
            out.w[k] = w;
            out.dw[k] = dw;
            d2[k] = ddw;
        }
        (out, d2)
    }
}

/// Least LME locality γ a scene may ask for: the nodes left out of the
/// 4-node box are at least two cells away, and their weight relative to
/// the nearest node's is below exp(−4γ) ≤ 10⁻⁶ (the truncation tolerance
/// Molinos et al. recommend after Arroyo & Ortiz) for γ ≥ ln(10⁶)/4.
pub const LME_GAMMA_MIN: f64 = 3.4538776394910684;
/// The LME locality of a scene that names none (`grid.lme_gamma`).
pub const LME_GAMMA_DEFAULT: f64 = 4.0;
/// Largest LME locality γ a scene may ask for: the weights differ from
/// the linear hat's by about exp(−γ) (10⁻¹³ at γ = 30; checked in this
/// file's tests), so a larger γ buys nothing over `linear`, and its far
/// weights exp(−γd²) end in subnormal numbers, which x86 handles slowly.
pub const LME_GAMMA_MAX: f64 = 100.0;

/// Local maximum-entropy (LME) approximants, Arroyo & Ortiz (2006), as
/// Molinos et al. use them for the material point method (their eqs. 6–10):
/// N_I = exp(−β|x − x_I|² + λ*·(x − x_I)) / Z (eq. 6–7), β = γ/h², with λ*
/// the minimiser of log Z (the first moment Σ N_I (x − x_I) = 0, eq. 10)
/// found by Newton, and ∇N_I = −N_I J⁻¹ (x − x_I) (eq. 8), J the Hessian of
/// log Z (eq. 9).
///
/// **A tensor product.** On a Cartesian grid with the box of nodes
/// `⌊ξ⌋−1 … ⌊ξ⌋+2` along each axis, |x − x_I|² and λ·(x − x_I) are sums
/// over the axes, so Z is the product of one partition function per
/// axis, log Z separates, λ* is found axis by axis and J is diagonal: the
/// D-dimensional LME on the box *is* the product of 1D LME functions, to
/// the last bit of the Newton solve. So it runs through the same
/// [`crate::grid::Support`] as the B-splines. The paper truncates its
/// support at a weight tolerance (10⁻⁶) on a ball instead; the box keeps
/// every node the ball keeps for γ ≥ [`LME_GAMMA_MIN`], and the box's
/// corner nodes weigh less than 10⁻¹² there. The cost of the box: at a
/// cell face the support shifts by one node, and a node of weight below
/// exp(−4γ)/Z leaves it, so N jumps by at most that much (10⁻⁶ at the
/// least γ) — the truncation's own discontinuity.
///
/// Smaller γ (wider functions, 1.8 in many LME papers) need 6 nodes per
/// axis, more than the engine's stencils (two ghost nodes, tiles of
/// support ≤ 4) allow: refused with the reason, not approximated.
#[derive(Debug, Clone, Copy)]
pub struct Lme;

/// The 1D LME weights and derivatives on the four nodes `⌊ξ⌋−1 … ⌊ξ⌋+2`:
/// Newton on the scalar λ (in cell units) for r(λ) = Σ p_k d_k = 0,
/// d_k = ξ − x_k, safeguarded by bisection in the bracket Newton's own
/// iterates give (r is increasing in λ: r' = J = Σ p_k d_k² − r² > 0).
#[inline]
fn lme_1d(xi: f64, gamma: f64) -> Weights1 {
    let b = floor(xi);
    let f = xi - b;
    let d = [f + 1.0, f, f - 1.0, f - 2.0];
    // With d_k = f − j (j = k − 1 = −1, 0, 1, 2), −γd² + λd =
    // (−γf² + λf) + j·u − γj² with u = 2γf − λ. The first term is common
    // to the four nodes and cancels in Z, so N_k ∝ c_j·t^j with t = e^u
    // and c = (e^−γ, 1, e^−γ, e^−4γ): one exponential per Newton step.
    // Scaled by t² (u > 0) or t (u ≤ 0), no factor exceeds 1, so nothing
    // overflows for any λ in the bracket.
    let c1 = (-gamma).exp();
    let c3 = (c1 * c1) * (c1 * c1);
    let moments = |lambda: f64| {
        let u = 2.0 * gamma * f - lambda;
        let e = if u > 0.0 {
            let v = (-u).exp();
            [c1 * (v * v * v), v * v, c1 * v, c3]
        } else {
            let t = u.exp();
            [c1, t, c1 * (t * t), c3 * (t * t * t)]
        };
        let z = e[0] + e[1] + e[2] + e[3];
        let p: [f64; 4] = std::array::from_fn(|k| e[k] / z);
        let r = p[0] * d[0] + p[1] * d[1] + p[2] * d[2] + p[3] * d[3];
        let m2 = p[0] * d[0] * d[0] + p[1] * d[1] * d[1] + p[2] * d[2] * d[2] + p[3] * d[3] * d[3];
        (p, r, m2 - r * r)
    };
    // λ* lies in ±(2γ + 2): beyond, the farthest node on one side
    // outweighs the rest and r has that side's sign
    let bound = 2.0 * gamma + 2.0;
    let (mut lo, mut hi) = (-bound, bound);
    // start from the two nearest nodes' exact solution (the hat: weights
    // 1 − f and f), which the far nodes only perturb when γ is large
    let mut lambda = if f > 0.0 {
        (gamma * (2.0 * f - 1.0) + ((1.0 - f) / f).ln()).clamp(lo, hi)
    } else {
        0.0
    };
    let (mut p, mut r, mut j) = moments(lambda);
    // 0–6 steps (3 on average at γ = 4); the cap bounds a pathological
    // input (NaN positions end here too)
    for _ in 0..100 {
        if r.abs() <= 1e-15 {
            break;
        }
        if r > 0.0 {
            hi = lambda;
        } else {
            lo = lambda;
        }
        let step = if j > 0.0 { r / j } else { f64::INFINITY };
        let mut next = lambda - step;
        if !(next > lo && next < hi) {
            next = 0.5 * (lo + hi);
        }
        lambda = next;
        (p, r, j) = moments(lambda);
        // round-off bounds r near 1e-16; a step that no longer moves λ
        // has converged
        if step.abs() <= 1e-15 * (1.0 + lambda.abs()) {
            break;
        }
    }
    Weights1 {
        base: b as isize - 1,
        w: p,
        // dN_k/dξ = −N_k d_k / J (eq. 8 per axis, J diagonal)
        dw: std::array::from_fn(|k| -p[k] * (d[k] - r) / j),
    }
}

impl Kernel for Lme {
    const N: usize = 4;
    const APIC_DINV_H2: Option<f64> = None;
    // not refinable: the multigrid prolongs with linear interpolation, as
    // for the hat and GIMP
    const REFINE: &'static [f64] = &[0.5, 1.0, 0.5];
    const KEPT: bool = true;
    #[inline(always)]
    fn eval(xi: f64, _lp: f64, gamma: f64) -> Weights1 {
        lme_1d(xi, gamma)
    }
}

/// Support width of a kernel kind.
pub fn support(kind: ShapeFunctionKind) -> usize {
    match kind {
        ShapeFunctionKind::Linear => Linear::N,
        ShapeFunctionKind::Gimp => Gimp::N,
        ShapeFunctionKind::QuadraticBspline => QuadraticBspline::N,
        ShapeFunctionKind::CubicBspline => CubicBspline::N,
        ShapeFunctionKind::Lme => Lme::N,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inlined_floor_is_floor() {
        let edge = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.999999999999999,
            -2.000000000000001,
            4503599627370495.5,
            -4503599627370495.5,
            9.0e15,
            -9.0e15,
        ];
        for x in edge
            .into_iter()
            .chain((0..2001).map(|k| -10.0 + k as f64 * 0.01))
        {
            assert_eq!(floor(x), x.floor(), "floor({x})");
        }
    }

    fn check_kernel<K: Kernel>(lp: f64, gamma: f64) {
        for k in 0..200 {
            let xi = 3.0 + k as f64 * 0.00731;
            let w = K::eval(xi, lp, gamma);
            let sum: f64 = w.w[..K::N].iter().sum();
            let dsum: f64 = w.dw[..K::N].iter().sum();
            let first: f64 = (0..K::N)
                .map(|j| w.w[j] * (w.base + j as isize) as f64)
                .sum();
            assert!(
                (sum - 1.0).abs() < 1e-12,
                "partition of unity at {xi}: {sum}"
            );
            assert!(dsum.abs() < 1e-12, "gradient sum at {xi}: {dsum}");
            // Linear completeness: Σ N_k x_k = ξ.
            assert!(
                (first - xi).abs() < 1e-12,
                "linear completeness at {xi}: {first}"
            );
            // Σ dN_k/dξ x_k = 1
            let slope: f64 = (0..K::N)
                .map(|j| w.dw[j] * (w.base + j as isize) as f64)
                .sum();
            assert!((slope - 1.0).abs() < 1e-12, "Σ N' x at {xi}: {slope}");
            assert!(w.w.iter().all(|&v| v >= 0.0));
            // Derivative by central differences.
            let e = 1e-6;
            let (a, b) = (K::eval(xi - e, lp, gamma), K::eval(xi + e, lp, gamma));
            if a.base == w.base && b.base == w.base {
                for j in 0..K::N {
                    let fd = (b.w[j] - a.w[j]) / (2.0 * e);
                    assert!(
                        (fd - w.dw[j]).abs() < 1e-5,
                        "dw[{j}] at {xi}: {} vs {fd}",
                        w.dw[j]
                    );
                }
            }
        }
    }

    #[test]
    fn kernels_are_partitions_of_unity_with_correct_gradients() {
        check_kernel::<Linear>(0.0, 0.0);
        check_kernel::<Gimp>(0.25, 0.0);
        check_kernel::<Gimp>(0.5, 0.0);
        check_kernel::<QuadraticBspline>(0.0, 0.0);
        check_kernel::<CubicBspline>(0.0, 0.0);
        for gamma in [LME_GAMMA_MIN, LME_GAMMA_DEFAULT, 10.0, 30.0, LME_GAMMA_MAX] {
            check_kernel::<Lme>(0.0, gamma);
        }
    }

    /// The LME functions on the box are Arroyo & Ortiz's: a direct
    /// minimisation of log Z over λ (golden-section search, no Newton)
    /// gives the same weights; they are smooth across a cell face to the
    /// truncation's exp(−4γ); and large γ tends to the linear hat
    /// (Arroyo & Ortiz's Delaunay limit), small γ spreads the weight.
    #[test]
    fn lme_is_the_max_ent_solution_and_tends_to_the_hat() {
        for gamma in [LME_GAMMA_MIN, 6.0, 25.0] {
            for k in 0..97 {
                let xi = -2.0 + 0.0613 * k as f64;
                let w = Lme::eval(xi, 0.0, gamma);
                // log Z(λ) = log Σ exp(−γ d² + λ d) is convex in λ
                let d = |j: usize| xi - (w.base + j as isize) as f64;
                let log_z = |l: f64| {
                    (0..4)
                        .map(|j| (-gamma * d(j) * d(j) + l * d(j)).exp())
                        .sum::<f64>()
                        .ln()
                };
                let (mut a, mut b) = (-200.0f64, 200.0f64);
                let g = 0.5 * (5f64.sqrt() - 1.0);
                for _ in 0..200 {
                    let (c, e) = (b - g * (b - a), a + g * (b - a));
                    if log_z(c) < log_z(e) {
                        b = e;
                    } else {
                        a = c;
                    }
                }
                let l = 0.5 * (a + b);
                let z: f64 = (0..4)
                    .map(|j| (-gamma * d(j) * d(j) + l * d(j)).exp())
                    .sum();
                for j in 0..4 {
                    let p = (-gamma * d(j) * d(j) + l * d(j)).exp() / z;
                    assert!(
                        (p - w.w[j]).abs() < 1e-7,
                        "γ {gamma} ξ {xi} node {j}: {p} vs {}",
                        w.w[j]
                    );
                }
            }
            // across the face at ξ = 5: the node sets differ by one far node
            let (left, right) = (
                Lme::eval(5.0 - 1e-12, 0.0, gamma),
                Lme::eval(5.0, 0.0, gamma),
            );
            assert_eq!(right.base, left.base + 1);
            // plus the 1e-12 the two points are apart, at slopes below 1
            let tol = 3.0 * (-4.0 * gamma).exp() + 1e-11;
            for node in left.base..=right.base + 3 {
                let at = |w: &Weights1| {
                    let j = node - w.base;
                    if (0..4).contains(&j) {
                        w.w[j as usize]
                    } else {
                        0.0
                    }
                };
                assert!(
                    (at(&left) - at(&right)).abs() < tol,
                    "γ {gamma} node {node}"
                );
            }
        }
        // the linear hat's limit (Arroyo & Ortiz's Delaunay limit): the
        // weights differ from the hat's by about exp(−γ)
        for gamma in [30.0, LME_GAMMA_MAX] {
            for k in 0..=50 {
                let xi = 7.0 + 0.02 * k as f64;
                let (lme, hat) = (Lme::eval(xi, 0.0, gamma), Linear::eval(xi, 0.0, 0.0));
                for j in 0..4 {
                    let node = lme.base + j as isize;
                    let h = match node - hat.base {
                        0 => hat.w[0],
                        1 => hat.w[1],
                        _ => 0.0,
                    };
                    assert!(
                        (lme.w[j] - h).abs() < 4.0 * (-gamma).exp() + 1e-14,
                        "γ {gamma} ξ {xi} node {node}: {} vs {h}",
                        lme.w[j]
                    );
                }
            }
        }
        // a smaller γ spreads the weight: the node one cell away weighs more
        let (narrow, wide) = (
            Lme::eval(3.0, 0.0, 30.0),
            Lme::eval(3.0, 0.0, LME_GAMMA_MIN),
        );
        assert!(wide.w[0] > narrow.w[0] && wide.w[1] < narrow.w[1]);
    }

    #[test]
    fn second_derivatives_match_finite_differences() {
        fn check<K: Kernel>() {
            for k in 0..100 {
                let xi = 5.0 + 0.0137 * k as f64;
                let (w, d2) = K::eval2(xi, 0.0, 0.0);
                let e = 1e-5;
                let (a, b) = (K::eval(xi - e, 0.0, 0.0), K::eval(xi + e, 0.0, 0.0));
                if a.base == w.base && b.base == w.base {
                    for j in 0..K::N {
                        let fd = (b.dw[j] - a.dw[j]) / (2.0 * e);
                        assert!(
                            (fd - d2[j]).abs() < 1e-4,
                            "d2[{j}] at {xi}: {} vs {fd}",
                            d2[j]
                        );
                    }
                }
                let s: f64 = d2[..K::N].iter().sum();
                assert!(s.abs() < 1e-12);
            }
        }
        check::<QuadraticBspline>();
        check::<CubicBspline>();
    }
}
