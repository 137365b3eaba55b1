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
//! - cubic B-spline, support 4 nodes, C².

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
}

/// Evaluates `body` with the type `K` bound to the kernel of `kind`: one
/// dispatch from the scene's shape function to the generic stages.
macro_rules! by_kernel {
    ($kind:expr, $K:ident => $body:expr) => {
        by_kernel!(@arms $kind, $K, $body, Linear, Gimp, QuadraticBspline, CubicBspline)
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
    /// `lp`: GIMP half-width of the particle in cells (ignored by others).
    fn eval(xi: f64, lp: f64) -> Weights1;
    /// Second derivatives d²N_k/dξ² (zero where the kernel is not C¹).
    fn eval2(xi: f64, lp: f64) -> (Weights1, [f64; MAX_SUPPORT]) {
        (Self::eval(xi, lp), [0.0; MAX_SUPPORT])
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
    fn eval(xi: f64, _lp: f64) -> Weights1 {
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
    fn eval(xi: f64, lp: f64) -> Weights1 {
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
    fn eval(xi: f64, _lp: f64) -> Weights1 {
        let base = floor(xi - 0.5);
        let fx = xi - base;
        let (a, b, c) = (1.5 - fx, fx - 1.0, fx - 0.5);
        Weights1 {
            base: base as isize,
            w: [0.5 * a * a, 0.75 - b * b, 0.5 * c * c, 0.0],
            dw: [-a, -2.0 * b, c, 0.0],
        }
    }
    fn eval2(xi: f64, lp: f64) -> (Weights1, [f64; MAX_SUPPORT]) {
        (Self::eval(xi, lp), [1.0, -2.0, 1.0, 0.0])
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
    fn eval(xi: f64, _lp: f64) -> Weights1 {
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
    fn eval2(xi: f64, _lp: f64) -> (Weights1, [f64; MAX_SUPPORT]) {
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

/// Support width of a kernel kind.
pub fn support(kind: ShapeFunctionKind) -> usize {
    match kind {
        ShapeFunctionKind::Linear => Linear::N,
        ShapeFunctionKind::Gimp => Gimp::N,
        ShapeFunctionKind::QuadraticBspline => QuadraticBspline::N,
        ShapeFunctionKind::CubicBspline => CubicBspline::N,
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

    fn check_kernel<K: Kernel>(lp: f64) {
        for k in 0..200 {
            let xi = 3.0 + k as f64 * 0.00731;
            let w = K::eval(xi, lp);
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
            assert!(w.w.iter().all(|&v| v >= 0.0));
            // Derivative by central differences.
            let e = 1e-6;
            let (a, b) = (K::eval(xi - e, lp), K::eval(xi + e, lp));
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
        check_kernel::<Linear>(0.0);
        check_kernel::<Gimp>(0.25);
        check_kernel::<Gimp>(0.5);
        check_kernel::<QuadraticBspline>(0.0);
        check_kernel::<CubicBspline>(0.0);
    }

    #[test]
    fn second_derivatives_match_finite_differences() {
        fn check<K: Kernel>() {
            for k in 0..100 {
                let xi = 5.0 + 0.0137 * k as f64;
                let (w, d2) = K::eval2(xi, 0.0);
                let e = 1e-5;
                let (a, b) = (K::eval(xi - e, 0.0), K::eval(xi + e, 0.0));
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
