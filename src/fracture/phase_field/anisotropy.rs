//! Surface-energy anisotropy of the 4th-order phase field (Kakouris &
//! Triantafyllou, section 2.2).
//!
//! The 2D Voigt tensor γ (eq. 6) acts on the second derivatives
//! `[c,11, c,22, c,12]`, so along a unit normal n the crack-profile term of
//! the functional (eq. 4) is `l₀³ a(n) c''²` with
//! `a(n) = γ1111 n1⁴ + γ2222 n2⁴ + (2γ1122 + γ1212) n1²n2² + 2γ1112 n1³n2 + 2γ2212 n1n2³`.
//!
//! [`surface_energy`] evaluates eq. 8, the effective surface energy of a
//! straight crack at angle θ: the functional integrated across the optimal
//! 1D profile. Minimising `∫ (c−1)²/(4l₀) + l₀c'² + l₀³ a c''² ds` with
//! c(0) = 0 gives the Euler–Lagrange equation of eq. 20 (with H = 0),
//! `(c−1) − 4l₀²c'' + 4l₀⁴ a c'''' = 0`, whose decaying solution for s > 0 is
//! `1 − c = A e^{−λ₁s} + B e^{−λ₂s}`, `λ² = (1 ± √(1−a)) / (2l₀²a)`, with
//! c'(0) = 0 for a > 0 (the profile is smooth at the crack). The integral is
//! then a finite sum of `1/(λᵢ+λⱼ)` terms, in complex arithmetic when
//! a > 1. The result does not depend on l₀: `Gc(θ) = Ḡc · G(a(n(θ)))`, with
//! G(0) = 1 (2nd order) and G(1) = √2 (4th-order isotropic).

use std::f64::consts::PI;

/// The anisotropy tensor in 2D Voigt form (all six independent entries).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Gamma {
    pub g1111: f64,
    pub g2222: f64,
    pub g1122: f64,
    pub g1212: f64,
    #[serde(default)]
    pub g1112: f64,
    #[serde(default)]
    pub g2212: f64,
}

impl Gamma {
    /// γ = 0: the 2nd-order isotropic model.
    pub fn is_zero(&self) -> bool {
        [
            self.g1111, self.g2222, self.g1122, self.g1212, self.g1112, self.g2212,
        ]
        .iter()
        .all(|&g| g == 0.0)
    }

    /// The 3×3 Voigt matrix acting on `[c,11, c,22, c,12]`.
    pub fn voigt(&self) -> [[f64; 3]; 3] {
        [
            [self.g1111, self.g1122, self.g1112],
            [self.g1122, self.g2222, self.g2212],
            [self.g1112, self.g2212, self.g1212],
        ]
    }

    /// a(n) for a unit normal n.
    pub fn along(&self, n: [f64; 2]) -> f64 {
        let v = [n[0] * n[0], n[1] * n[1], n[0] * n[1]];
        let m = self.voigt();
        (0..3)
            .map(|i| (0..3).map(|j| v[i] * m[i][j] * v[j]).sum::<f64>())
            .sum()
    }

    /// The full 4th-order tensor T with Σ T_ijkl c,ij c,kl = vᵀ M v for the
    /// Voigt matrix M on v = [c,11, c,22, c,12] (so T_1112 = M13/2,
    /// T_1212 = M33/4, with all minor and major symmetries).
    fn tensor(&self) -> [[[[f64; 2]; 2]; 2]; 2] {
        let m = self.voigt();
        // Voigt index of the pair (i, j) and the weight of each of its
        // tensor slots: (1,1) → 0, (2,2) → 1, (1,2) and (2,1) → 2 (halved).
        let idx = |i: usize, j: usize| if i == j { (i, 1.0) } else { (2, 0.5) };
        let mut t = [[[[0.0; 2]; 2]; 2]; 2];
        for i in 0..2 {
            for j in 0..2 {
                for k in 0..2 {
                    for l in 0..2 {
                        let ((a, wa), (b, wb)) = (idx(i, j), idx(k, l));
                        t[i][j][k][l] = m[a][b] * wa * wb;
                    }
                }
            }
        }
        t
    }

    /// The tensor of a material whose principal axes are turned by φ
    /// counter-clockwise: T'_ijkl = R_ia R_jb R_kc R_ld T_abcd with R = R(φ),
    /// so that a'(n) = a(R(−φ) n).
    pub fn rotated(&self, phi: f64) -> Gamma {
        let (c, s) = (phi.cos(), phi.sin());
        let r = [[c, -s], [s, c]];
        let t = self.tensor();
        let rot = |i: usize, j: usize, k: usize, l: usize| {
            let mut sum = 0.0;
            for a in 0..2 {
                for b in 0..2 {
                    for cc in 0..2 {
                        for d in 0..2 {
                            sum += r[i][a] * r[j][b] * r[k][cc] * r[l][d] * t[a][b][cc][d];
                        }
                    }
                }
            }
            sum
        };
        Gamma {
            g1111: rot(0, 0, 0, 0),
            g2222: rot(1, 1, 1, 1),
            g1122: rot(0, 0, 1, 1),
            g1212: 4.0 * rot(0, 1, 0, 1),
            g1112: 2.0 * rot(0, 0, 0, 1),
            g2212: 2.0 * rot(1, 1, 0, 1),
        }
    }

    /// The smallest a(n) over directions (sampled every 0.1°); the
    /// functional is bounded below only if it is ≥ 0.
    pub fn min_along(&self) -> f64 {
        (0..1800)
            .map(|k| {
                let t = k as f64 * PI / 1800.0;
                self.along([t.cos(), t.sin()])
            })
            .fold(f64::INFINITY, f64::min)
    }
}

/// The anisotropy tensor in 3D Voigt form: the symmetric 6×6 matrix M on
/// `[c,11, c,22, c,33, c,23, c,13, c,12]` (the engine's Voigt order), as
/// [`Gamma::voigt`] acts on `[c,11, c,22, c,12]` in 2D, so that the
/// crack-profile term of eq. 4 is `l₀³ (∇²c)ᵀ M (∇²c)` and along a unit
/// normal n, `a(n) = vᵀ M v` with `v = [n1², n2², n3², n2n3, n1n3, n1n2]`
/// (eq. 6's γ, 3D: Kakouris & Triantafyllou leave its form "beyond the
/// scope"; this is the one whose restriction to c(x, y) is the 2D Voigt
/// tensor on the indices 11, 22, 12). A scene gives it as 9 numbers
/// (orthotropic: γ1111, γ2222, γ3333, γ1122, γ1133, γ2233, γ2323, γ1313,
/// γ1212, with the same weights as the 2D γ1212) or as the 21 entries of
/// M's upper triangle, row by row.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Gamma3 {
    pub m: [[f64; 6]; 6],
}

impl Gamma3 {
    /// From a scene's list: 9 (orthotropic) or 21 (upper triangle) numbers;
    /// None for another length. An empty list is γ = 0.
    pub fn from_list(g: &[f64]) -> Option<Gamma3> {
        let mut m = [[0.0; 6]; 6];
        match g.len() {
            0 => {}
            9 => {
                m[0][0] = g[0];
                m[1][1] = g[1];
                m[2][2] = g[2];
                (m[0][1], m[0][2], m[1][2]) = (g[3], g[4], g[5]);
                (m[1][0], m[2][0], m[2][1]) = (g[3], g[4], g[5]);
                m[3][3] = g[6];
                m[4][4] = g[7];
                m[5][5] = g[8];
            }
            21 => {
                let mut k = 0;
                for i in 0..6 {
                    for j in i..6 {
                        m[i][j] = g[k];
                        m[j][i] = g[k];
                        k += 1;
                    }
                }
            }
            _ => return None,
        }
        Some(Gamma3 { m })
    }

    /// γ = 0: the 2nd-order isotropic model.
    pub fn is_zero(&self) -> bool {
        self.m.iter().flatten().all(|&g| g == 0.0)
    }

    /// a(n) for a unit normal n.
    pub fn along(&self, n: [f64; 3]) -> f64 {
        let v = [
            n[0] * n[0],
            n[1] * n[1],
            n[2] * n[2],
            n[1] * n[2],
            n[0] * n[2],
            n[0] * n[1],
        ];
        (0..6)
            .map(|i| (0..6).map(|j| v[i] * self.m[i][j] * v[j]).sum::<f64>())
            .sum()
    }

    /// The smallest and the largest a(n) over the unit sphere, with their
    /// normals: the best of 20 000 directions of a Fibonacci lattice on the
    /// half sphere (a(−n) = a(n); neighbours about 1.4° apart), each
    /// refined by a local search on a shrinking pattern.
    pub fn extremes(&self) -> ((f64, [f64; 3]), (f64, [f64; 3])) {
        const N: usize = 20_000;
        let golden = PI * (3.0 - 5f64.sqrt());
        let dir = |k: usize| {
            let z = 1.0 - (k as f64 + 0.5) / N as f64; // (0, 1]: half sphere
            let r = (1.0 - z * z).max(0.0).sqrt();
            let t = golden * k as f64;
            [r * t.cos(), r * t.sin(), z]
        };
        let refine = |mut n: [f64; 3], sign: f64| {
            let mut best = sign * self.along(n);
            let mut step = 0.02;
            while step > 1e-9 {
                let mut moved = false;
                for axis in 0..3 {
                    for d in [-step, step] {
                        let mut m = n;
                        m[axis] += d;
                        let len = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
                        let m = m.map(|c| c / len);
                        let v = sign * self.along(m);
                        if v > best {
                            (best, n, moved) = (v, m, true);
                        }
                    }
                }
                if !moved {
                    step *= 0.5;
                }
            }
            (sign * best, n)
        };
        let (mut lo, mut hi) = ((f64::INFINITY, [0.0; 3]), (f64::NEG_INFINITY, [0.0; 3]));
        for k in 0..N {
            let n = dir(k);
            let a = self.along(n);
            if a < lo.0 {
                lo = (a, n);
            }
            if a > hi.0 {
                hi = (a, n);
            }
        }
        (refine(lo.1, -1.0), refine(hi.1, 1.0))
    }
}

/// Gc of a planar crack with unit normal `n` in 3D: eq. 8 with a(n) of the
/// 3D tensor (the same 1D profile across the crack).
pub fn surface_energy_3d(gamma: &Gamma3, gc_bar: f64, n: [f64; 3]) -> f64 {
    gc_bar * profile_factor(gamma.along(n))
}

/// A minimal complex number for the profile roots.
#[derive(Debug, Clone, Copy, PartialEq)]
struct C(f64, f64);

impl C {
    fn add(self, o: C) -> C {
        C(self.0 + o.0, self.1 + o.1)
    }
    fn sub(self, o: C) -> C {
        C(self.0 - o.0, self.1 - o.1)
    }
    fn mul(self, o: C) -> C {
        C(self.0 * o.0 - self.1 * o.1, self.0 * o.1 + self.1 * o.0)
    }
    fn div(self, o: C) -> C {
        let d = o.0 * o.0 + o.1 * o.1;
        C(
            (self.0 * o.0 + self.1 * o.1) / d,
            (self.1 * o.0 - self.0 * o.1) / d,
        )
    }
    fn sqrt(self) -> C {
        let r = (self.0 * self.0 + self.1 * self.1).sqrt();
        let re = ((r + self.0) / 2.0).max(0.0).sqrt();
        let im = ((r - self.0) / 2.0)
            .max(0.0)
            .sqrt()
            .copysign(if self.1 == 0.0 { 1.0 } else { self.1 });
        C(re, im)
    }
    fn re(x: f64) -> C {
        C(x, 0.0)
    }
}

/// G(a) = Gc/Ḡc for the profile coefficient a ≥ 0 (l₀ = 1 without loss of
/// generality).
pub fn profile_factor(a: f64) -> f64 {
    if a <= 0.0 {
        return 1.0;
    }
    // Double root (a = 1): 1 − c = (1 + λs) e^{−λs}, λ = 1/√2; the integrals
    // are 5/(4λ), λ/4 and λ³/4 (see the module docs).
    if (a - 1.0).abs() < 1e-7 {
        let l = std::f64::consts::FRAC_1_SQRT_2;
        return 2.0 * (5.0 / (16.0 * l) + l / 4.0 + a * l * l * l / 4.0);
    }
    let disc = C::re(1.0 - a).sqrt();
    let denom = 2.0 * a;
    let l1 = C::re(1.0).sub(disc).div(C::re(denom)).sqrt();
    let l2 = C::re(1.0).add(disc).div(C::re(denom)).sqrt();
    // A + B = 1, λ1 A + λ2 B = 0
    let d = l2.sub(l1);
    let coef = [l2.div(d), C::re(0.0).sub(l1.div(d))];
    let lam = [l1, l2];
    let mut total = C::re(0.0);
    for i in 0..2 {
        for j in 0..2 {
            let (li, lj) = (lam[i], lam[j]);
            let lilj = li.mul(lj);
            let term = C::re(0.25).add(lilj).add(C::re(a).mul(lilj).mul(lilj));
            total = total.add(coef[i].mul(coef[j]).mul(term).div(li.add(lj)));
        }
    }
    2.0 * total.0
}

/// Eq. 8: Gc(θ) of a straight crack whose tangent makes the angle θ with
/// the x axis (its normal is (−sin θ, cos θ)).
pub fn surface_energy(gamma: &Gamma, gc_bar: f64, theta: f64) -> f64 {
    gc_bar * profile_factor(gamma.along([-theta.sin(), theta.cos()]))
}

/// Gc(θ) for θ = 0, step, 2·step, ... < 360°, with its min and max.
pub fn polar(gamma: &Gamma, gc_bar: f64, step_deg: f64) -> Vec<(f64, f64)> {
    let n = (360.0 / step_deg).round().max(1.0) as usize;
    (0..n)
        .map(|k| {
            let deg = k as f64 * 360.0 / n as f64;
            (deg, surface_energy(gamma, gc_bar, deg.to_radians()))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Numerical check of the closed form: the Euler–Lagrange profile's
    /// energy integrated on a fine grid with finite-difference derivatives.
    fn quadrature(a: f64) -> f64 {
        // evaluate 1 − c and its derivatives from the closed-form profile by
        // finite differences of the complex expression
        let u = |s: f64| -> f64 {
            if (a - 1.0).abs() < 1e-7 {
                let l = std::f64::consts::FRAC_1_SQRT_2;
                return (1.0 + l * s) * (-l * s).exp();
            }
            let disc = C::re(1.0 - a).sqrt();
            let l1 = C::re(1.0).sub(disc).div(C::re(2.0 * a)).sqrt();
            let l2 = C::re(1.0).add(disc).div(C::re(2.0 * a)).sqrt();
            let d = l2.sub(l1);
            let e = |l: C| {
                let x = C(-l.0 * s, -l.1 * s);
                let m = x.0.exp();
                C(m * x.1.cos(), m * x.1.sin())
            };
            l2.div(d).mul(e(l1)).sub(l1.div(d).mul(e(l2))).0
        };
        // to 300 l₀: for large a the profile decays slowly (a = 2900:
        // Re λ ≈ 0.068/l₀) and 50 l₀ would drop 0.1 % of the energy
        let (h, n) = (2e-3, 150_000);
        let mut total = 0.0;
        for k in 0..n {
            let s = (k as f64 + 0.5) * h;
            let (um, u0, up) = (u(s - h), u(s), u(s + h));
            let d1 = (up - um) / (2.0 * h);
            let d2 = (up - 2.0 * u0 + um) / (h * h);
            total += (u0 * u0 / 4.0 + d1 * d1 + a * d2 * d2) * h;
        }
        2.0 * total
    }

    #[test]
    fn closed_form_matches_quadrature_and_known_values() {
        assert_eq!(profile_factor(0.0), 1.0);
        assert!((profile_factor(1.0) - 2f64.sqrt()).abs() < 1e-12);
        for a in [0.01, 0.3, 0.999, 1.001, 2.0, 19.0, 80.0, 2900.0] {
            let (c, q) = (profile_factor(a), quadrature(a));
            assert!(
                (c - q).abs() < 1e-4 * c,
                "a = {a}: closed form {c}, quadrature {q}"
            );
        }
        // continuous through the double root
        assert!((profile_factor(1.0 - 2e-7) - profile_factor(1.0 + 2e-7)).abs() < 1e-6);
    }

    #[test]
    fn paper_polar_extremes() {
        let extremes = |g: Gamma, gc: f64| {
            let p = polar(&g, gc, 0.05);
            let min = p.iter().map(|x| x.1).fold(f64::INFINITY, f64::min);
            let max = p.iter().map(|x| x.1).fold(0.0, f64::max);
            (min, max)
        };
        let cubic = Gamma {
            g1111: 1.0,
            g2222: 1.0,
            g1212: 74.0,
            ..Default::default()
        };
        let (lo, hi) = extremes(cubic, 0.002121);
        assert!(
            (lo / 0.003 - 1.0).abs() < 0.01 && (hi / 0.0049 - 1.0).abs() < 0.01,
            "cubic {lo} {hi}"
        );
        let ortho = Gamma {
            g1111: 1.0,
            g2222: 80.0,
            g1212: 74.0,
            ..Default::default()
        };
        let (lo, hi) = extremes(ortho, 0.002121);
        assert!(
            (lo / 0.003 - 1.0).abs() < 0.01 && (hi / 0.0067 - 1.0).abs() < 0.01,
            "orthotropic {lo} {hi}"
        );
        let composite = Gamma {
            g1111: 1.0,
            g2222: 2900.0,
            g1212: 74.0,
            ..Default::default()
        };
        let (lo, hi) = extremes(composite, 4.175);
        assert!(
            (lo / 5.9067 - 1.0).abs() < 0.01 && (hi / 30.9044 - 1.0).abs() < 0.01,
            "composite {lo} {hi}"
        );
    }

    #[test]
    fn rotation_turns_the_polar_plot() {
        let g = Gamma {
            g1111: 1.0,
            g2222: 80.0,
            g1122: 3.0,
            g1212: 74.0,
            g1112: 5.0,
            g2212: -2.0,
        };
        let phi = 0.7;
        let r = g.rotated(phi);
        // a full turn and the identity give the tensor back
        let back = g.rotated(2.0 * PI);
        for (x, y) in [
            (back.g1111, g.g1111),
            (back.g1122, g.g1122),
            (back.g1212, g.g1212),
            (back.g2212, g.g2212),
        ] {
            assert!((x - y).abs() < 1e-9);
        }
        // the 4th-order isotropic tensor is invariant
        let iso = Gamma {
            g1111: 1.0,
            g2222: 1.0,
            g1212: 2.0,
            ..Default::default()
        }
        .rotated(0.3);
        assert!(
            (iso.g1111 - 1.0).abs() < 1e-12
                && iso.g1122.abs() < 1e-12
                && (iso.g1212 - 2.0).abs() < 1e-12
                && iso.g1112.abs() < 1e-12
        );
        for k in 0..36 {
            let t = k as f64 * 0.17;
            let want = g.along([(t - phi).cos(), (t - phi).sin()]);
            let got = r.along([t.cos(), t.sin()]);
            assert!(
                (want - got).abs() < 1e-9 * want.abs().max(1.0),
                "t = {t}: {got} vs {want}"
            );
        }
    }

    /// The 3D tensor: 9 orthotropic numbers and their 21-entry form agree;
    /// a c(x, y) sees the 2D tensor (a(n) of a normal in the xy plane is
    /// the 2D one's); the isotropic 4th order is a = 1 in every direction;
    /// the extremes over the sphere are found where they are.
    #[test]
    fn the_3d_tensor_restricts_to_the_2d_one_and_finds_its_extremes() {
        let ortho = [1.0, 80.0, 5.0, 0.5, 0.25, 2.0, 3.0, 4.0, 74.0];
        let g = Gamma3::from_list(&ortho).unwrap();
        let m = g.m;
        let mut upper = Vec::new();
        for i in 0..6 {
            for j in i..6 {
                upper.push(m[i][j]);
            }
        }
        assert_eq!(Gamma3::from_list(&upper).unwrap(), g);
        assert!(Gamma3::from_list(&[1.0; 4]).is_none());
        let g2 = Gamma {
            g1111: 1.0,
            g2222: 80.0,
            g1122: 0.5,
            g1212: 74.0,
            ..Default::default()
        };
        for deg in [0.0, 17.0, 45.0, 100.0] {
            let t: f64 = f64::to_radians(deg);
            let (a3, a2) = (
                g.along([t.cos(), t.sin(), 0.0]),
                g2.along([t.cos(), t.sin()]),
            );
            assert!(
                (a3 - a2).abs() < 1e-12 * a2.abs().max(1.0),
                "{deg}°: {a3} vs {a2}"
            );
        }
        // the isotropic 4th order: γ_ijkl c,ij c,kl = (∇²c)·(∇²c), shear
        // entries weighted 2 as in 2D's γ1212 = 2
        let iso = Gamma3::from_list(&[1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 2.0, 2.0, 2.0]).unwrap();
        for n in [[1.0, 0.0, 0.0], [0.6, 0.0, 0.8], [0.48, 0.6, 0.64]] {
            assert!(
                (iso.along(n) - 1.0).abs() < 1e-12,
                "{n:?}: {}",
                iso.along(n)
            );
        }
        // a(n) = 1 + 3 n3⁴: least (1) where n3 = 0, largest (4) along z
        let z = Gamma3::from_list(&[1.0, 1.0, 4.0, 0.0, 0.0, 0.0, 2.0, 2.0, 2.0]).unwrap();
        let ((lo, nlo), (hi, nhi)) = z.extremes();
        assert!(
            (lo - 1.0).abs() < 1e-9 && nlo[2].abs() < 1e-4,
            "{lo} at {nlo:?}"
        );
        assert!(
            (hi - 4.0).abs() < 1e-9 && nhi[2].abs() > 1.0 - 1e-6,
            "{hi} at {nhi:?}"
        );
        assert!((surface_energy_3d(&iso, 1.0, [0.0, 0.0, 1.0]) - 2f64.sqrt()).abs() < 1e-9);
    }
}
