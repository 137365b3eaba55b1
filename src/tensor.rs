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

/// s : e of two symmetric tensors in Voigt order with tensor (not
/// engineering) shear components: the diagonal terms, then twice the
/// shear ones, summed in Voigt order from the first term. Half of it is
/// the small-strain energy density of stress s at strain e.
#[inline(always)]
pub fn contract<const D: usize, const V: usize>(s: &[f64; V], e: &[f64; V]) -> f64 {
    let mut w = s[0] * e[0];
    for k in 1..D {
        w += s[k] * e[k];
    }
    for k in D..V {
        w += 2.0 * s[k] * e[k];
    }
    w
}

/// a − b, component by component.
#[inline(always)]
pub fn sub<const D: usize>(a: [f64; D], b: [f64; D]) -> [f64; D] {
    std::array::from_fn(|k| a[k] - b[k])
}

/// |a|.
#[inline(always)]
pub fn norm<const D: usize>(a: [f64; D]) -> f64 {
    dot(a, a).sqrt()
}

/// Eigenvalues (largest first) and unit eigenvectors (`vectors[i]` belongs
/// to `values[i]`) of a symmetric 3 × 3 tensor in 3D Voigt order, by
/// cyclic Jacobi rotations (Golub & Van Loan, Matrix Computations,
/// section 8.5, the classical Jacobi method with the rotation of
/// Rutishauser's formula t = sgn(θ)/(|θ| + √(θ² + 1)),
/// θ = (a_qq − a_pp)/(2 a_pq)). Robust for repeated eigenvalues (where
/// closed forms lose the directions), deterministic (plain arithmetic in a
/// fixed order), and exact for a tensor that is already diagonal (no
/// rotation is made). Sweeps until the off-diagonal part is below
/// 1e-15 of the tensor's norm, at most 24 sweeps (3 × 3 converges
/// quadratically, in 4 to 6).
pub fn sym_eigen3(s: [f64; 6]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut a = [[s[0], s[5], s[4]], [s[5], s[1], s[3]], [s[4], s[3], s[2]]];
    // columns of v are the eigenvectors
    let mut v = identity::<3>();
    let fro2 = a[0][0] * a[0][0]
        + a[1][1] * a[1][1]
        + a[2][2] * a[2][2]
        + 2.0 * (s[3] * s[3] + s[4] * s[4] + s[5] * s[5]);
    for _sweep in 0..24 {
        let off2 = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        if !(off2 > 1e-30 * fro2) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            let apq = a[p][q];
            if apq == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * apq);
            let sign = if theta >= 0.0 { 1.0 } else { -1.0 };
            let t = sign / (theta.abs() + theta.hypot(1.0));
            let c = 1.0 / (t * t + 1.0).sqrt();
            let sn = t * c;
            // A ← Pᵀ A P, V ← V P with P the rotation in the (p, q) plane
            for k in 0..3 {
                let (akp, akq) = (a[k][p], a[k][q]);
                a[k][p] = c * akp - sn * akq;
                a[k][q] = sn * akp + c * akq;
            }
            for k in 0..3 {
                let (apk, aqk) = (a[p][k], a[q][k]);
                a[p][k] = c * apk - sn * aqk;
                a[q][k] = sn * apk + c * aqk;
            }
            a[p][q] = 0.0;
            a[q][p] = 0.0;
            for k in 0..3 {
                let (vkp, vkq) = (v[k][p], v[k][q]);
                v[k][p] = c * vkp - sn * vkq;
                v[k][q] = sn * vkp + c * vkq;
            }
        }
    }
    let mut order = [0, 1, 2];
    order.sort_by(|&i, &j| a[j][j].total_cmp(&a[i][i]));
    (
        order.map(|i| a[i][i]),
        order.map(|i| [v[0][i], v[1][i], v[2][i]]),
    )
}

/// Serde for a point of `D` coordinates whatever `D` (serde implements
/// arrays for each length, not for a generic one): a tuple of `D` numbers,
/// which is how serde writes `[f64; 2]` and `[f64; 3]`, so the bytes (and
/// the traced checkpoint layout) are those of the fixed array. Use as
/// `#[serde(with = "crate::tensor::serde_point")]`.
pub mod serde_point {
    use serde::de::{Error, SeqAccess, Visitor};
    use serde::ser::SerializeTuple;
    use serde::{Deserializer, Serializer};

    pub fn serialize<S: Serializer, const D: usize>(a: &[f64; D], s: S) -> Result<S::Ok, S::Error> {
        let mut t = s.serialize_tuple(D)?;
        for x in a {
            t.serialize_element(x)?;
        }
        t.end()
    }

    pub fn deserialize<'de, De: Deserializer<'de>, const D: usize>(
        d: De,
    ) -> Result<[f64; D], De::Error> {
        struct Point<const D: usize>;
        impl<'de, const D: usize> Visitor<'de> for Point<D> {
            type Value = [f64; D];
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                write!(f, "{D} numbers")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<[f64; D], A::Error> {
                let mut a = [0.0; D];
                for (i, x) in a.iter_mut().enumerate() {
                    *x = seq
                        .next_element()?
                        .ok_or_else(|| A::Error::invalid_length(i, &self))?;
                }
                Ok(a)
            }
        }
        d.deserialize_tuple(D, Point::<D>)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point written through [`serde_point`] has the bytes of the fixed
    /// array it replaced (2D checkpoints load as before) and reads back in
    /// 3D; a short record is an error, not a zero.
    #[test]
    fn a_point_is_written_as_the_fixed_array_it_replaces() {
        #[derive(serde::Serialize, serde::Deserialize, PartialEq, Debug)]
        struct P<const D: usize> {
            #[serde(with = "serde_point")]
            x: [f64; D],
        }
        let two = postcard::to_allocvec(&P { x: [1.5, -2.0] }).unwrap();
        assert_eq!(two, postcard::to_allocvec(&[1.5f64, -2.0]).unwrap());
        let three = P { x: [1.0, 2.0, 3.0] };
        let bytes = postcard::to_allocvec(&three).unwrap();
        assert_eq!(bytes, postcard::to_allocvec(&[1.0f64, 2.0, 3.0]).unwrap());
        assert_eq!(postcard::from_bytes::<P<3>>(&bytes).unwrap(), three);
        assert!(postcard::from_bytes::<P<3>>(&bytes[..16]).is_err());
    }

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
    /// A tensor built from known principal values on a rotated frame (and
    /// with a repeated value) gives them back, with directions that
    /// rebuild it; a diagonal tensor is returned exactly.
    #[test]
    fn symmetric_eigen_3_recovers_values_and_rebuilds_the_tensor() {
        let rebuild = |vals: [f64; 3], n: [[f64; 3]; 3]| -> [f64; 6] {
            let c = |a: usize, b: usize| (0..3).map(|i| vals[i] * n[i][a] * n[i][b]).sum::<f64>();
            [c(0, 0), c(1, 1), c(2, 2), c(1, 2), c(0, 2), c(0, 1)]
        };
        // an orthonormal frame: rotations about z by 0.3 and about x by 1.1
        let (a, b) = (0.3f64, 1.1f64);
        let rz = [
            [a.cos(), -a.sin(), 0.0],
            [a.sin(), a.cos(), 0.0],
            [0.0, 0.0, 1.0],
        ];
        let rx = [
            [1.0, 0.0, 0.0],
            [0.0, b.cos(), -b.sin()],
            [0.0, b.sin(), b.cos()],
        ];
        let r: [[f64; 3]; 3] = std::array::from_fn(|i| {
            std::array::from_fn(|j| (0..3).map(|k| rz[i][k] * rx[k][j]).sum())
        });
        let frame = [
            [r[0][0], r[1][0], r[2][0]],
            [r[0][1], r[1][1], r[2][1]],
            [r[0][2], r[1][2], r[2][2]],
        ];
        for vals in [[3.0, -1.0, 0.5], [2.0, 2.0, -4.0], [1e6, 1e-3, -7.0]] {
            let s = rebuild(vals, frame);
            let (got, n) = sym_eigen3(s);
            let mut want = vals;
            want.sort_by(|x, y| y.total_cmp(x));
            let scale = vals.iter().map(|v| v.abs()).fold(0.0, f64::max);
            for i in 0..3 {
                assert!(
                    (got[i] - want[i]).abs() < 1e-13 * scale,
                    "{got:?} vs {want:?}"
                );
                let len: f64 = n[i].iter().map(|c| c * c).sum();
                assert!((len - 1.0).abs() < 1e-13);
            }
            let back = rebuild(got, n);
            for k in 0..6 {
                assert!((back[k] - s[k]).abs() < 1e-12 * scale, "{back:?} vs {s:?}");
            }
        }
        let (vals, n) = sym_eigen3([1.0, 5.0, -2.0, 0.0, 0.0, 0.0]);
        assert_eq!(vals, [5.0, 1.0, -2.0]);
        assert_eq!(n, [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]);
    }
}
