//! Reproducing-kernel shape functions with a linear basis (Wei & Chen,
//! eqs. 17–22, after Liu et al. 1995 and Chen et al. 1996), in 2D and 3D.
//!
//! N_I(x) = Hᵀ(0) A⁻¹(x) H(x − x_I) Φ_a(x − x_I) (eq. 18), with
//! H(x − x_I) = [1, x − x_I, y − y_I (, z − z_I)] (eq. 19, n = 1), the
//! moment matrix A(x) = Σ_I H Hᵀ Φ_a (eq. 20) and the cubic B-spline
//! kernel of eq. 21 on a circular (spherical) support of radius a_I. The
//! functions reproduce every linear field exactly (eq. 22): Σ N_I = 1 and
//! Σ N_I x_I = x.
//!
//! The basis is written in units of a reference length (the support of
//! the point being evaluated) so that A is of order one whatever the
//! scene's units; N_I does not depend on that choice. A is at most 4 × 4
//! and factorised by a Cholesky decomposition on the stack (no
//! allocation: it runs for every quadrature point); a point that too few
//! particles cover (fewer than D + 1 not on one line or plane) has a
//! singular A, and [`RkError`] says where instead of dividing by zero.

use super::crack::Cuts;
use crate::tensor::sub;

/// The cubic B-spline kernel of Wei & Chen's eq. 21 at `s = |x − x_I| / a_I`
/// (2/3 at the centre, zero from s = 1 on).
#[inline]
pub fn cubic_bspline(s: f64) -> f64 {
    if s <= 0.5 {
        2.0 / 3.0 - 4.0 * s * s + 4.0 * s * s * s
    } else if s <= 1.0 {
        let t = 1.0 - s;
        4.0 / 3.0 * t * t * t
    } else {
        0.0
    }
}

/// A point whose moment matrix cannot be inverted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error(
    "the reproducing-kernel moment matrix at {point:?} is singular ({covering} particles cover the point, \
     reciprocal condition {rcond:.1e}): the support is too small for the particle spacing there"
)]
pub struct RkError {
    /// The point, m (2 or 3 components).
    pub point: Vec<f64>,
    /// How many particles' supports contain it.
    pub covering: usize,
    /// The ratio of the smallest to the largest Cholesky pivot, squared
    /// (0 when a pivot was not positive).
    pub rcond: f64,
}

/// The smallest reciprocal condition of the moment matrix accepted: below
/// it, a linear field would be reproduced to fewer than about six digits.
pub const MIN_RCOND: f64 = 1e-10;

/// The values N_I(x) of the particles `nodes` (positions `xs`, support
/// radii `radius`, the caller's candidates: any superset of the particles
/// whose support contains x) at `x`, written to `out` (`out[k]` belongs to
/// `nodes[k]`; zero where x is outside a support). Returns how many
/// particles cover x. `scale` is the length the basis is written in
/// (any positive length of the order of the supports).
///
/// Particles flagged in `singular` (empty: none) carry the singular kernel
/// Φ_a(s)/s² of Chen & Wang (2000), the paper's technique for essential
/// boundary conditions (Wei & Chen, section 4): the kernel is infinite at
/// the particle, so there N_I(x_I) = 1 and every other N_K(x_I) = 0, and a
/// displacement prescribed at x_I is prescribed on the coefficient d_I.
/// Linear reproduction (eq. 22) holds with any positive kernel.
pub fn shape_values<const D: usize>(
    x: [f64; D],
    nodes: &[u32],
    xs: &[[f64; D]],
    radius: &[f64],
    singular: &[bool],
    scale: f64,
    out: &mut [f64],
) -> Result<usize, RkError> {
    shape_values_cut(x, nodes, xs, radius, singular, None, scale, out)
}

/// [`shape_values`] in a body with pre-existing cracks: `cut` holds the
/// cracks, each particle's body and the point the crossings are judged
/// from (x, or a hair inside the cell whose face point x is), and the
/// kernels are evaluated at the diffracted distances of
/// [`Cuts::distance_seen_from`] (Organ et al.'s diffraction method).
#[allow(clippy::too_many_arguments)]
pub fn shape_values_cut<const D: usize>(
    x: [f64; D],
    nodes: &[u32],
    xs: &[[f64; D]],
    radius: &[f64],
    singular: &[bool],
    cut: Option<(&Cuts<D>, &[u16], [f64; D])>,
    scale: f64,
    out: &mut [f64],
) -> Result<usize, RkError> {
    debug_assert!(D == 2 || D == 3);
    debug_assert_eq!(out.len(), nodes.len());
    let n = D + 1;
    // the moment matrix, eq. 20, in the scaled basis; and the same with
    // the plain kernel everywhere, whose condition says whether enough
    // particles cover x (the singular kernels' weights make A's condition
    // grow as the distance to their particle shrinks, which is no fault)
    let mut a = [[0.0f64; 4]; 4];
    let mut plain = [[0.0f64; 4]; 4];
    let mut covering = 0;
    let mut at_singular = None;
    for (k, &i) in nodes.iter().enumerate() {
        let i = i as usize;
        let r = sub(x, xs[i]);
        let mut dist = crate::tensor::norm(r);
        if let Some((cuts, body, seen_from)) = cut {
            dist = cuts.distance_seen_from(body[i], x, seen_from, xs[i], dist);
        }
        let s = dist / radius[i];
        let phi0 = cubic_bspline(s);
        let mut phi = phi0;
        if phi != 0.0 && singular.get(i) == Some(&true) {
            if s == 0.0 {
                at_singular = Some(k);
            } else {
                phi /= s * s;
            }
        }
        out[k] = phi;
        if phi == 0.0 {
            continue;
        }
        covering += 1;
        let h = basis(r, scale);
        for p in 0..n {
            for q in 0..=p {
                a[p][q] += h[p] * h[q] * phi;
                plain[p][q] += h[p] * h[q] * phi0;
            }
        }
    }
    let fail = |rcond: f64| RkError {
        point: x.to_vec(),
        covering,
        rcond,
    };
    match cholesky(&plain, n) {
        Some((_, rcond)) if rcond >= MIN_RCOND => {}
        Some((_, rcond)) => return Err(fail(rcond)),
        None => return Err(fail(0.0)),
    }
    if let Some(k) = at_singular {
        // the interpolating limit of the singular kernel
        out.fill(0.0);
        out[k] = 1.0;
        return Ok(covering);
    }
    let l = match cholesky(&a, n) {
        Some((l, _)) => l,
        None => return Err(fail(0.0)),
    };
    // c = A⁻¹ H(0), H(0) = e₁: forward then back substitution
    let mut c = [0.0f64; 4];
    for p in 0..n {
        let mut s = if p == 0 { 1.0 } else { 0.0 };
        for k in 0..p {
            s -= l[p][k] * c[k];
        }
        c[p] = s / l[p][p];
    }
    for p in (0..n).rev() {
        let mut s = c[p];
        for k in p + 1..n {
            s -= l[k][p] * c[k];
        }
        c[p] = s / l[p][p];
    }
    // N_I = cᵀ H(x − x_I) Φ_I, eq. 18
    for (k, &i) in nodes.iter().enumerate() {
        if out[k] == 0.0 {
            continue;
        }
        let h = basis(sub(x, xs[i as usize]), scale);
        let mut v = 0.0;
        for p in 0..n {
            v += c[p] * h[p];
        }
        out[k] *= v;
    }
    Ok(covering)
}

/// The Cholesky factor L (A = L Lᵀ, lower triangle) of the leading n × n
/// block of `a` (its lower triangle), and the ratio of the smallest to the
/// largest pivot (squared diagonal of L); None at a pivot that is not
/// positive.
fn cholesky(a: &[[f64; 4]; 4], n: usize) -> Option<([[f64; 4]; 4], f64)> {
    let mut l = [[0.0f64; 4]; 4];
    let (mut dmin, mut dmax) = (f64::INFINITY, 0.0f64);
    for p in 0..n {
        for q in 0..=p {
            let mut s = a[p][q];
            for k in 0..q {
                s -= l[p][k] * l[q][k];
            }
            if p == q {
                if !(s > 0.0) {
                    return None;
                }
                dmin = dmin.min(s);
                dmax = dmax.max(s);
                l[p][p] = s.sqrt();
            } else {
                l[p][q] = s / l[q][q];
            }
        }
    }
    Some((l, dmin / dmax))
}

/// H(r) of eq. 19 with n = 1, lengths in units of `scale`.
#[inline]
fn basis<const D: usize>(r: [f64; D], scale: f64) -> [f64; 4] {
    let mut h = [1.0, 0.0, 0.0, 0.0];
    for d in 0..D {
        h[d + 1] = r[d] / scale;
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square lattice of spacing `s` with `n × n` points (the first at
    /// the origin), its supports `factor · s`.
    fn lattice(n: usize, s: f64, factor: f64) -> (Vec<[f64; 2]>, Vec<f64>) {
        let mut xs = Vec::new();
        for j in 0..n {
            for i in 0..n {
                xs.push([i as f64 * s, j as f64 * s]);
            }
        }
        let r = vec![factor * s; xs.len()];
        (xs, r)
    }

    #[test]
    fn the_kernel_is_a_smooth_bump_of_unit_integral_shape() {
        // eq. 21: continuous at 1/2 and 1 with its slope, 2/3 at the centre
        assert_eq!(cubic_bspline(0.0), 2.0 / 3.0);
        let e = 1e-9;
        for s in [0.5, 1.0] {
            assert!((cubic_bspline(s - e) - cubic_bspline(s + e)).abs() < 1e-8);
            let slope = |t: f64| (cubic_bspline(t + e) - cubic_bspline(t - e)) / (2.0 * e);
            assert!(
                (slope(s - 1e-6) - slope(s + 1e-6)).abs() < 1e-4,
                "slope at {s}"
            );
        }
        assert_eq!(cubic_bspline(1.0), 0.0);
        assert_eq!(cubic_bspline(1.5), 0.0);
    }

    #[test]
    fn linear_fields_are_reproduced_exactly_in_2d_and_3d() {
        // eq. 22 at points inside, on the edge of and in the corners of the
        // lattice, in metres and in micrometres (the scaled basis)
        for s in [1e-2, 1e-6] {
            let (xs, r) = lattice(8, s, 1.5);
            let all: Vec<u32> = (0..xs.len() as u32).collect();
            let mut n = vec![0.0; all.len()];
            for p in [
                [0.31, 0.77],
                [0.0, 0.0],
                [7.0, 4.2],
                [3.5, 3.5],
                [6.9, 0.05],
            ] {
                let x = [p[0] * s, p[1] * s];
                shape_values(x, &all, &xs, &r, &[], 1.5 * s, &mut n).unwrap();
                let sum: f64 = n.iter().sum();
                let sx: f64 = n.iter().zip(&xs).map(|(n, x)| n * x[0]).sum();
                let sy: f64 = n.iter().zip(&xs).map(|(n, x)| n * x[1]).sum();
                assert!((sum - 1.0).abs() < 1e-12, "Σ N = {sum}");
                assert!((sx - x[0]).abs() < 1e-12 * s && (sy - x[1]).abs() < 1e-12 * s);
            }
        }
        let s = 0.1;
        let mut xs = Vec::new();
        for k in 0..5 {
            for j in 0..5 {
                for i in 0..5 {
                    xs.push([i as f64 * s, j as f64 * s, k as f64 * s]);
                }
            }
        }
        let r = vec![1.5 * s; xs.len()];
        let all: Vec<u32> = (0..xs.len() as u32).collect();
        let mut n = vec![0.0; all.len()];
        for x in [[0.123, 0.2, 0.37], [0.0, 0.4, 0.05]] {
            shape_values(x, &all, &xs, &r, &[], 0.15, &mut n).unwrap();
            assert!((n.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            for d in 0..3 {
                let m: f64 = n.iter().zip(&xs).map(|(n, p)| n * p[d]).sum();
                assert!((m - x[d]).abs() < 1e-13, "axis {d}: {m} vs {}", x[d]);
            }
        }
    }

    #[test]
    fn a_support_too_small_for_the_spacing_is_refused_not_divided_by() {
        // supports of 0.4 spacings: a point between particles is covered by
        // none
        let (xs, r) = lattice(4, 1.0, 0.4);
        let all: Vec<u32> = (0..xs.len() as u32).collect();
        let mut n = vec![0.0; all.len()];
        let e = shape_values([1.5, 1.5], &all, &xs, &r, &[], 1.0, &mut n).unwrap_err();
        assert_eq!(e.covering, 0);
        assert!(e.to_string().contains("singular"), "{e}");
        // three particles on one line cover a point: still singular
        let xs = vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]];
        let r = vec![1.5; 3];
        let mut n = vec![0.0; 3];
        let e = shape_values([1.0, 0.1], &[0, 1, 2], &xs, &r, &[], 1.5, &mut n).unwrap_err();
        assert_eq!(e.covering, 3);
    }

    #[test]
    fn a_singular_kernel_interpolates_at_its_particle_and_keeps_reproduction() {
        // the left column singular: N_I(x_I) = 1 there, the others zero;
        // near it the functions are continuous and still reproduce x
        let (xs, r) = lattice(6, 1.0, 1.5);
        let singular: Vec<bool> = xs.iter().map(|p| p[0] == 0.0).collect();
        let all: Vec<u32> = (0..xs.len() as u32).collect();
        let mut n = vec![0.0; all.len()];
        shape_values(xs[12], &all, &xs, &r, &singular, 1.5, &mut n).unwrap();
        assert_eq!(n[12], 1.0);
        assert_eq!(n.iter().filter(|&&v| v != 0.0).count(), 1);
        // a regular particle is not interpolating
        shape_values(xs[14], &all, &xs, &r, &singular, 1.5, &mut n).unwrap();
        assert!(n[14] < 0.9);
        for x in [[1e-9, 2.0], [0.3, 2.2], [1e-3, 0.0]] {
            shape_values(x, &all, &xs, &r, &singular, 1.5, &mut n).unwrap();
            let sum: f64 = n.iter().sum();
            let sx: f64 = n.iter().zip(&xs).map(|(n, p)| n * p[0]).sum();
            let sy: f64 = n.iter().zip(&xs).map(|(n, p)| n * p[1]).sum();
            assert!(
                (sum - 1.0).abs() < 1e-12 && (sx - x[0]).abs() < 1e-12 && (sy - x[1]).abs() < 1e-12,
                "{x:?}: {sum} {sx} {sy}"
            );
        }
        // continuity towards the particle: at 1e-9 from x_12, N_12 ≈ 1
        shape_values([1e-9, 2.0], &all, &xs, &r, &singular, 1.5, &mut n).unwrap();
        assert!((n[12] - 1.0).abs() < 1e-6, "{}", n[12]);
    }
}
