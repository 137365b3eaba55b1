//! The pieces of the dynamic J integral and of growth that need no grid
//! (Nairn & Aimene, section 2.2 and 3.5): the contour term of eq. 9 on a
//! path of points, J along a crack's growth direction (eq. 10), the split
//! of J into K_I and K_II, and the maximum-hoop-stress direction. The
//! contours on the grid and their fields (nodal W, K, σ, ∇u per crack
//! velocity field, virtual nodes where cracks cross) build on these.

/// The fields at one point of a J contour: the strain and kinetic energy
/// densities, J/m³, the Cauchy stress (xx, yy, xy), Pa, and the
/// displacement gradient ∂u_i/∂x_k, row i.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContourPoint {
    pub x: [f64; 2],
    pub w: f64,
    pub k: f64,
    pub stress: [f64; 3],
    pub grad_u: [[f64; 2]; 2],
}

impl ContourPoint {
    /// The integrand of eq. 9's first term for outward normal `n`:
    /// (W + K) n_k − σ_ij n_j ∂u_i/∂x_k, for k = 1, 2.
    fn integrand(&self, n: [f64; 2]) -> [f64; 2] {
        let s = [
            [self.stress[0], self.stress[2]],
            [self.stress[2], self.stress[1]],
        ];
        let t = [
            s[0][0] * n[0] + s[0][1] * n[1],
            s[1][0] * n[0] + s[1][1] * n[1],
        ];
        std::array::from_fn(|k| {
            (self.w + self.k) * n[k] - (t[0] * self.grad_u[0][k] + t[1] * self.grad_u[1][k])
        })
    }
}

/// The contour term of the J integral (Nairn & Aimene eq. 9, first
/// term), J_1 and J_2 in the grid's axes, J/m², along the open path
/// through `points`: counter-clockwise about the crack tip, from a point
/// on the crack's lower face round to one on its upper face. Each
/// interval is integrated by the trapezoid rule (the mean of its two
/// ends' integrands times its length) with the outward normal of a
/// counter-clockwise path, n = (t_y, −t_x) for the unit tangent t.
pub fn contour_term(points: &[ContourPoint]) -> [f64; 2] {
    let mut j = [0.0; 2];
    for w in points.windows(2) {
        let (a, b) = (&w[0], &w[1]);
        let d = [b.x[0] - a.x[0], b.x[1] - a.x[1]];
        let len = (d[0] * d[0] + d[1] * d[1]).sqrt();
        if len == 0.0 {
            continue;
        }
        let n = [d[1] / len, -d[0] / len];
        let (fa, fb) = (a.integrand(n), b.integrand(n));
        for k in 0..2 {
            j[k] += 0.5 * (fa[k] + fb[k]) * len;
        }
    }
    j
}

/// The energy release rate for growth along the direction at angle θ
/// (radians, from the grid's x axis): J = J_1 cos θ + J_2 sin θ
/// (Nairn & Aimene eq. 10).
pub fn along(j: [f64; 2], theta: f64) -> f64 {
    j[0] * theta.cos() + j[1] * theta.sin()
}

/// K_I and K_II, Pa·√m, from J and the crack-opening displacement near the
/// tip in the crack's axes (δ_n normal opening, δ_t sliding, m), for an
/// isotropic material of effective modulus E* (E in plane stress,
/// E/(1 − ν²) in plane strain). Near the tip both openings grow as √r
/// with the same factor, δ_t/δ_n = K_II/K_I (the crack-opening
/// displacement method of Guo & Nairn, which CRAMP's tracked surfaces
/// give directly), and J = (K_I² + K_II²)/E*. K_I takes the sign of the
/// opening (a closed, pressed crack has none: K_I = 0 there and J is all
/// mode II); K_II the sign of the sliding. Non-positive J gives zeros.
pub fn decompose(j: f64, e_star: f64, cod_n: f64, cod_t: f64) -> (f64, f64) {
    if !(j > 0.0 && e_star > 0.0) {
        return (0.0, 0.0);
    }
    let k = (j * e_star).sqrt();
    if cod_n <= 0.0 {
        return (0.0, k.copysign(cod_t));
    }
    let r = cod_t / cod_n;
    let k1 = k / (1.0 + r * r).sqrt();
    (k1, r * k1)
}

/// The direction of growth by the maximum hoop stress (Erdogan & Sih),
/// radians from the crack's own direction: with R = K_II/|K_I|,
/// cos θ = (3R² + √(1 + 8R²))/(1 + 9R²), θ on the side opposite to K_II's
/// sign (pure mode II: ∓70.5°). Without K_I (a crack closed in shear)
/// the limit R → ∞.
pub fn hoop_direction(k1: f64, k2: f64) -> f64 {
    if k2 == 0.0 {
        return 0.0;
    }
    let c = if k1.abs() > 0.0 {
        let r = k2 / k1.abs();
        let r2 = r * r;
        (3.0 * r2 + (1.0 + 8.0 * r2).sqrt()) / (1.0 + 9.0 * r2)
    } else {
        1.0 / 3.0
    };
    -c.clamp(-1.0, 1.0).acos().copysign(k2)
}

/// The hoop stress at angle θ ahead of a tip with K_I, K_II, times
/// √(2πr): what the maximum-hoop-stress criterion compares with K_Ic
/// (K_I^max = cos(θ/2)·(K_I cos²(θ/2) − 1.5 K_II sin θ)).
pub fn hoop_k(k1: f64, k2: f64, theta: f64) -> f64 {
    let h = 0.5 * theta;
    h.cos() * (k1 * h.cos() * h.cos() - 1.5 * k2 * theta.sin())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// Williams' near-tip field of a crack along −x with its tip at the
    /// origin, modes I and II, plane strain (Anderson, Fracture Mechanics,
    /// tables 2.1–2.2): stress and displacement at `x`.
    pub(crate) fn williams(k1: f64, k2: f64, e: f64, nu: f64, x: [f64; 2]) -> ([f64; 3], [f64; 2]) {
        let r = (x[0] * x[0] + x[1] * x[1]).sqrt();
        let t = x[1].atan2(x[0]);
        let (s2, c2) = (0.5 * t).sin_cos();
        let (s32, c32) = (1.5 * t).sin_cos();
        let f = 1.0 / (2.0 * PI * r).sqrt();
        let sxx = f * (k1 * c2 * (1.0 - s2 * s32) - k2 * s2 * (2.0 + c2 * c32));
        let syy = f * (k1 * c2 * (1.0 + s2 * s32) + k2 * s2 * c2 * c32);
        let sxy = f * (k1 * c2 * s2 * c32 + k2 * c2 * (1.0 - s2 * s32));
        let mu = e / (2.0 * (1.0 + nu));
        let kappa = 3.0 - 4.0 * nu;
        let g = (r / (2.0 * PI)).sqrt() / (2.0 * mu);
        let ux =
            g * (k1 * c2 * (kappa - 1.0 + 2.0 * s2 * s2) + k2 * s2 * (kappa + 1.0 + 2.0 * c2 * c2));
        let uy =
            g * (k1 * s2 * (kappa + 1.0 - 2.0 * c2 * c2) - k2 * c2 * (kappa - 1.0 - 2.0 * s2 * s2));
        ([sxx, syy, sxy], [ux, uy])
    }

    pub(crate) fn point(k1: f64, k2: f64, e: f64, nu: f64, x: [f64; 2]) -> ContourPoint {
        let (s, _) = williams(k1, k2, e, nu, x);
        let h = 1e-7;
        let mut grad_u = [[0.0; 2]; 2];
        for k in 0..2 {
            let mut p = x;
            let mut m = x;
            p[k] += h;
            m[k] -= h;
            let (_, up) = williams(k1, k2, e, nu, p);
            let (_, um) = williams(k1, k2, e, nu, m);
            for i in 0..2 {
                grad_u[i][k] = (up[i] - um[i]) / (2.0 * h);
            }
        }
        let eps = [grad_u[0][0], grad_u[1][1], grad_u[0][1] + grad_u[1][0]];
        ContourPoint {
            x,
            w: 0.5 * (s[0] * eps[0] + s[1] * eps[1] + s[2] * eps[2]),
            k: 0.0,
            stress: s,
            grad_u,
        }
    }

    /// A square path of side 2L about the tip, `n` intervals per side,
    /// counter-clockwise from the lower face (−L, −0) to the upper (−L, +0).
    fn square(l: f64, n: usize) -> Vec<[f64; 2]> {
        let mut pts = vec![[-l, -1e-12]];
        let corners = [[-l, -l], [l, -l], [l, l], [-l, l], [-l, 1e-12]];
        let mut from = [-l, -1e-12];
        for (c, to) in corners.iter().enumerate() {
            let steps = if c == 0 || c == 4 { n / 2 } else { n };
            for s in 1..=steps {
                let f = s as f64 / steps as f64;
                pts.push([
                    from[0] + f * (to[0] - from[0]),
                    from[1] + f * (to[1] - from[1]),
                ]);
            }
            from = *to;
        }
        pts
    }

    /// On Williams' field, the contour term J_1 is path independent and
    /// equals (K_I² + K_II²)/E*, on paths of the spacing a J contour on
    /// the grid has (8 and 16 intervals a side: within 1 %). (J_2 needs
    /// the crack faces' part as well, which a contour from face to face
    /// leaves out: not checked here.)
    #[test]
    fn the_contour_term_gives_j_of_the_near_tip_field() {
        let (e, nu) = (1.0e9, 0.3);
        let e_star = e / (1.0 - nu * nu);
        for (k1, k2) in [(1.0e6, 0.0), (1.0e6, 0.5e6), (0.3e6, -1.0e6)] {
            let want = (k1 * k1 + k2 * k2) / e_star;
            for (l, n) in [(0.002, 8), (0.008, 16)] {
                let pts: Vec<_> = square(l, n)
                    .into_iter()
                    .map(|x| point(k1, k2, e, nu, x))
                    .collect();
                let j = contour_term(&pts);
                assert!(
                    (j[0] / want - 1.0).abs() < 0.01,
                    "K = ({k1}, {k2}), L = {l}: J1 {} vs {want}",
                    j[0]
                );
                assert!((along(j, 0.0) - j[0]).abs() == 0.0);
            }
        }
    }

    /// The openings of Williams' field behind the tip give K_II/K_I, and
    /// with J the two factors come back.
    #[test]
    fn j_and_the_crack_opening_give_k1_and_k2() {
        let (e, nu) = (1.0e9, 0.3);
        let e_star = e / (1.0 - nu * nu);
        for (k1, k2) in [(1.0e6, 0.0), (1.0e6, 0.5e6), (0.3e6, -1.0e6)] {
            let r = 5e-4;
            let (_, up) = williams(k1, k2, e, nu, [-r, 1e-12]);
            let (_, down) = williams(k1, k2, e, nu, [-r, -1e-12]);
            let (cod_n, cod_t) = (up[1] - down[1], up[0] - down[0]);
            let j = (k1 * k1 + k2 * k2) / e_star;
            let (a, b) = decompose(j, e_star, cod_n, cod_t);
            assert!(
                (a - k1).abs() < 1e-6 * k1.abs().max(k2.abs()),
                "{a} vs {k1}"
            );
            assert!(
                (b - k2).abs() < 1e-6 * k1.abs().max(k2.abs()),
                "{b} vs {k2}"
            );
        }
        assert_eq!(decompose(-1.0, 1e9, 1e-6, 0.0), (0.0, 0.0));
    }

    /// Mode I grows straight ahead, mode II at ∓70.53° (cos θ = 1/3), and
    /// the direction maximises the hoop stress.
    #[test]
    fn the_hoop_stress_direction() {
        assert_eq!(hoop_direction(1.0, 0.0), 0.0);
        let t = hoop_direction(0.0, 1.0);
        assert!((t + (1.0f64 / 3.0).acos()).abs() < 1e-12, "{t}");
        assert!((hoop_direction(0.0, -1.0) - (1.0f64 / 3.0).acos()).abs() < 1e-12);
        for (k1, k2) in [(1.0, 0.3), (1.0, -0.7), (0.2, 1.0)] {
            let t = hoop_direction(k1, k2);
            let best = hoop_k(k1, k2, t);
            for d in [-1e-3, 1e-3] {
                assert!(hoop_k(k1, k2, t + d) < best, "({k1}, {k2}): θ = {t}");
            }
            assert!(t * k2 < 0.0);
        }
    }
}
