//! Small fixed-size tensors shared by 2D and 3D: the Voigt order of
//! symmetric tensors and the copies that let dimension-generic code call a
//! dimension's own formula.
//!
//! A symmetric tensor of `D` dimensions is stored as `[f64; V]` with
//! `V = D(D+1)/2` in Voigt order: 2D `(xx, yy, xy)`, 3D
//! `(xx, yy, zz, yz, xz, xy)`. Stable Rust cannot compute `V` from `D` in
//! a type, so generic code takes both and checks them with
//! [`check_voigt`]. A general `D × D` matrix (deformation gradient,
//! velocity gradient, the APIC matrix) is `[[f64; D]; D]`, row-major.

/// Compile-time check that `V` is the Voigt length of `D` (2 → 3, 3 → 6).
#[inline(always)]
pub const fn check_voigt<const D: usize, const V: usize>() {
    const { assert!((D == 2 || D == 3) && V == D * (D + 1) / 2) }
}

/// The Voigt index of component `(a, b)` of a symmetric tensor in `D`
/// dimensions: the diagonal first, then (2D) `xy` = 2, or (3D) `yz` = 3,
/// `xz` = 4, `xy` = 5.
#[inline(always)]
pub const fn voigt<const D: usize>(a: usize, b: usize) -> usize {
    if a == b {
        a
    } else if D == 2 {
        2
    } else {
        6 - a - b
    }
}

/// `a` copied into an array of `M` entries (the first `min(N, M)`; the rest
/// zero). Generic code uses it to hand a `[f64; V]` to a formula written
/// for one dimension's `[f64; 3]` or `[f64; 6]`: where `N == M` it is the
/// identity and compiles to nothing.
#[inline(always)]
pub fn resize<const N: usize, const M: usize>(a: [f64; N]) -> [f64; M] {
    let mut out = [0.0; M];
    let k = N.min(M);
    out[..k].copy_from_slice(&a[..k]);
    out
}

/// A `D × D` matrix copied into an `M × M` one (as [`resize`]).
#[inline(always)]
pub fn resize_mat<const N: usize, const M: usize>(a: [[f64; N]; N]) -> [[f64; M]; M] {
    let mut out = [[0.0; M]; M];
    for (o, r) in out.iter_mut().zip(a) {
        *o = resize(r);
    }
    out
}

/// The `D × D` identity.
#[inline(always)]
pub fn identity<const D: usize>() -> [[f64; D]; D] {
    let mut m = [[0.0; D]; D];
    for (d, row) in m.iter_mut().enumerate() {
        row[d] = 1.0;
    }
    m
}

/// Σ_b s_ab g_b of a symmetric tensor `s` (Voigt) and a vector `g`, summed
/// in `b` order from the first term.
#[inline(always)]
pub fn sym_times<const D: usize, const V: usize>(s: &[f64; V], g: [f64; D]) -> [f64; D] {
    std::array::from_fn(|a| {
        let mut t = s[voigt::<D>(a, 0)] * g[0];
        for b in 1..D {
            t += s[voigt::<D>(a, b)] * g[b];
        }
        t
    })
}

/// a · b, summed in axis order from the first term.
#[inline(always)]
pub fn dot<const D: usize>(a: [f64; D], b: [f64; D]) -> f64 {
    let mut s = a[0] * b[0];
    for d in 1..D {
        s += a[d] * b[d];
    }
    s
}

/// |a|.
#[inline(always)]
pub fn norm<const D: usize>(a: [f64; D]) -> f64 {
    dot(a, a).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn voigt_indices_cover_each_component_once() {
        for (d, len) in [(2, 3), (3, 6)] {
            let mut seen = vec![0; len];
            for a in 0..d {
                for b in a..d {
                    let i = if d == 2 {
                        voigt::<2>(a, b)
                    } else {
                        voigt::<3>(a, b)
                    };
                    let j = if d == 2 {
                        voigt::<2>(b, a)
                    } else {
                        voigt::<3>(b, a)
                    };
                    assert_eq!(i, j);
                    seen[i] += 1;
                }
            }
            assert!(seen.iter().all(|&n| n == 1), "{d}D: {seen:?}");
        }
        // the orders the formats name
        assert_eq!(voigt::<2>(0, 1), 2);
        assert_eq!(
            [voigt::<3>(1, 2), voigt::<3>(0, 2), voigt::<3>(0, 1)],
            [3, 4, 5]
        );
    }

    #[test]
    fn a_symmetric_tensor_times_a_vector() {
        // [[1, 6, 5], [6, 2, 4], [5, 4, 3]] · (1, 10, 100)
        let s = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        assert_eq!(
            sym_times::<3, 6>(&s, [1.0, 10.0, 100.0]),
            [561.0, 426.0, 345.0]
        );
        assert_eq!(
            sym_times::<2, 3>(&[1.0, 2.0, 3.0], [1.0, 10.0]),
            [31.0, 23.0]
        );
        assert_eq!(
            resize::<3, 6>([1.0, 2.0, 3.0]),
            [1.0, 2.0, 3.0, 0.0, 0.0, 0.0]
        );
        assert_eq!(resize_mat::<2, 3>(identity()), {
            let mut m = identity::<3>();
            m[2][2] = 0.0;
            m
        });
    }
}
