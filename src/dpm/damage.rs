//! The damage of the damage particle method (Wei & Chen, sections 2 and
//! 3.2–3.3): isotropic damage D(κ) with linear softening (eq. 2), the
//! history κ of the Mazars equivalent strain (eqs. 3–6), the energy
//! regularisation κ_c = (G_F/f_t)(A_L/V_L) that makes each damaged
//! particle dissipate the fracture energy of its crack segment (eqs.
//! 28–33), the segment's cross-section A_L of the particle's cell (Fig. 7)
//! and the tracking of candidate particles ahead of a crack (eq. 27).

use crate::tensor::sym_eigen3;

/// D(κ) of eq. 2: 0 below κ₀, 1 − (κ₀/κ)(κ_c − κ)/(κ_c − κ₀) between,
/// 1 beyond κ_c. The stress (1 − D)Eε on the loading path falls linearly
/// from f_t = Eκ₀ at κ₀ to zero at κ_c.
#[inline]
pub fn damage(kappa: f64, kappa_0: f64, kappa_c: f64) -> f64 {
    if kappa < kappa_0 {
        0.0
    } else if kappa >= kappa_c {
        1.0
    } else {
        1.0 - kappa_0 / kappa * (kappa_c - kappa) / (kappa_c - kappa_0)
    }
}

/// κ_c of eq. 33: (G_F/f_t)(A_L/V_L), so that the cell's dissipation
/// g_L V_L = ½ f_t κ_c V_L (eq. 32) is G_F A_L/2, the fracture energy of
/// the crack segment's effective area (eqs. 29, 31). `area` is A_L, the
/// cell's cross-section perpendicular to the crack normal, and `volume`
/// V_L (in 2D both per unit thickness, or both with it).
#[inline]
pub fn regularised_kappa_c(g_f: f64, f_t: f64, area: f64, volume: f64) -> f64 {
    g_f / f_t * area / volume
}

/// The Mazars equivalent strain of eq. 6, √Σ⟨ε_I⟩², of a strain in Voigt
/// order with tensor shear components: 2D (xx, yy, xy) with the
/// out-of-plane `e_zz` (zero in plane strain), or 3D.
pub fn mazars<const V: usize>(e: &[f64; V], e_zz: f64) -> f64 {
    let pos = |x: f64| x.max(0.0);
    if V == 3 {
        let (a, b, c) = (e[0], e[1], e[2]);
        let m = 0.5 * (a + b);
        let r = (0.25 * (a - b) * (a - b) + c * c).sqrt();
        (pos(m + r).powi(2) + pos(m - r).powi(2) + pos(e_zz).powi(2)).sqrt()
    } else {
        let (values, _) = sym_eigen3([e[0], e[1], e[2], e[3], e[4], e[5]]);
        values.iter().map(|&v| pos(v).powi(2)).sum::<f64>().sqrt()
    }
}

/// A_L of Fig. 7 in 2D: the length of the line through `x` with unit
/// normal `n` inside the box `lo..hi` (which holds x).
pub fn chord_2d(x: [f64; 2], n: [f64; 2], lo: [f64; 2], hi: [f64; 2]) -> f64 {
    // points x + t (−n_y, n_x); each axis bounds t
    let dir = [-n[1], n[0]];
    let (mut t0, mut t1) = (f64::NEG_INFINITY, f64::INFINITY);
    for a in 0..2 {
        if dir[a].abs() < 1e-300 {
            continue;
        }
        let (p, q) = ((lo[a] - x[a]) / dir[a], (hi[a] - x[a]) / dir[a]);
        t0 = t0.max(p.min(q));
        t1 = t1.min(p.max(q));
    }
    (t1 - t0).max(0.0)
}

/// A_L of Fig. 7 in 3D: the area of the plane through `x` with unit
/// normal `n` inside the box `lo..hi` (which holds x). The section is a
/// convex polygon whose corners are where the plane cuts the box's
/// edges; sorted by angle about their mean, its area is a fan's.
pub fn section_3d(x: [f64; 3], n: [f64; 3], lo: [f64; 3], hi: [f64; 3]) -> f64 {
    let corner = |k: usize| {
        [
            if k & 1 == 0 { lo[0] } else { hi[0] },
            if k & 2 == 0 { lo[1] } else { hi[1] },
            if k & 4 == 0 { lo[2] } else { hi[2] },
        ]
    };
    let side = |p: [f64; 3]| (0..3).map(|a| (p[a] - x[a]) * n[a]).sum::<f64>();
    let mut pts: Vec<[f64; 3]> = Vec::with_capacity(6);
    for k in 0..8usize {
        for a in 0..3 {
            let j = k | (1 << a);
            if j == k {
                continue;
            }
            let (p, q) = (corner(k), corner(j));
            let (sp, sq) = (side(p), side(q));
            if (sp <= 0.0 && sq > 0.0) || (sp > 0.0 && sq <= 0.0) {
                let t = sp / (sp - sq);
                pts.push(std::array::from_fn(|c| p[c] + t * (q[c] - p[c])));
            }
        }
    }
    if pts.len() < 3 {
        return 0.0;
    }
    let m = pts.len() as f64;
    let c: [f64; 3] = std::array::from_fn(|a| pts.iter().map(|p| p[a]).sum::<f64>() / m);
    // an orthonormal pair in the plane
    let helper = if n[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let u = normalise(cross(n, helper));
    let w = cross(n, u);
    let coord = |p: &[f64; 3]| {
        let r = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
        (dot3(r, u), dot3(r, w))
    };
    let mut ang: Vec<(f64, (f64, f64))> = pts
        .iter()
        .map(|p| {
            let (a, b) = coord(p);
            (b.atan2(a), (a, b))
        })
        .collect();
    ang.sort_by(|p, q| p.0.total_cmp(&q.0));
    let k = ang.len();
    0.5 * (0..k)
        .map(|i| {
            let (a, b) = (ang[i].1, ang[(i + 1) % k].1);
            a.0 * b.1 - b.0 * a.1
        })
        .sum::<f64>()
        .abs()
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot3(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalise(a: [f64; 3]) -> [f64; 3] {
    let l = dot3(a, a).sqrt();
    a.map(|c| c / l)
}

/// Criterion (27): whether a neighbour at `x_i` lies ahead of a damaged
/// particle at `x_l` whose crack segment has unit normal `n`, i.e. within
/// the angle whose cosine against the normal is below `tol`
/// (|n·(x_I − x_L)|/|x_I − x_L| < tol).
pub fn ahead<const D: usize>(x_l: [f64; D], n: [f64; D], x_i: [f64; D], tol: f64) -> bool {
    let r = crate::tensor::sub(x_i, x_l);
    let len = crate::tensor::norm(r);
    len > 0.0 && (crate::tensor::dot(n, r) / len).abs() < tol
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cell_dissipates_its_segment_s_fracture_energy() {
        // eqs. 31–33: the area under σ = (1 − D(κ)) E κ, κ from 0 to κ_c,
        // is ½ f_t κ_c, and with κ_c regularised it is G_F A_L / (2 V_L)
        // per unit volume — for a coarse and a fine cell alike
        let (e, f_t, g_f) = (2.0e6, 200.0, 1.885);
        let k0 = f_t / e;
        for h in [100.0 / 16.0, 100.0 / 128.0] {
            let (area, volume) = (10.0, 10.0 * h);
            let kc = regularised_kappa_c(g_f, f_t, area, volume);
            assert!(kc > k0, "a cell this size snaps back (κ_c ≤ κ₀)");
            let steps = 200_000;
            let mut w = 0.0;
            for i in 0..steps {
                let k = kc * (i as f64 + 0.5) / steps as f64;
                w += (1.0 - damage(k, k0, kc)) * e * k * kc / steps as f64;
            }
            let want = g_f * area / (2.0 * volume);
            assert!((w / want - 1.0).abs() < 1e-6, "h {h}: {w} vs {want}");
        }
        assert_eq!(damage(0.5e-4, 1e-4, 1e-2), 0.0);
        assert_eq!(damage(1e-4, 1e-4, 1e-2), 0.0);
        assert_eq!(damage(2e-2, 1e-4, 1e-2), 1.0);
    }

    #[test]
    fn mazars_counts_only_the_stretches() {
        assert!((mazars(&[1e-3, 0.0, 0.0], 0.0) - 1e-3).abs() < 1e-18);
        assert_eq!(mazars(&[-1e-3, -2e-4, 0.0], 0.0), 0.0);
        // pure shear γ: principal ±γ
        assert!((mazars(&[0.0, 0.0, 2e-4], 0.0) - 2e-4).abs() < 1e-18);
        // plane stress: a stretched ε_zz counts
        assert!((mazars(&[-1e-3, -1e-3, 0.0], 5e-4) - 5e-4).abs() < 1e-18);
        let e3 = [1e-3, 2e-3, -1e-3, 0.0, 0.0, 0.0];
        assert!((mazars(&e3, 0.0) - (1e-6f64 + 4e-6).sqrt()).abs() < 1e-15);
    }

    #[test]
    fn the_segment_cuts_the_cell_it_crosses() {
        let (lo, hi) = ([0.0, 0.0], [2.0, 1.0]);
        // vertical crack (normal x) across the 2 × 1 cell: length 1
        assert!((chord_2d([1.0, 0.5], [1.0, 0.0], lo, hi) - 1.0).abs() < 1e-15);
        assert!((chord_2d([1.0, 0.5], [0.0, 1.0], lo, hi) - 2.0).abs() < 1e-15);
        let s = std::f64::consts::FRAC_1_SQRT_2;
        assert!((chord_2d([1.0, 0.5], [s, s], lo, hi) - 2f64.sqrt()).abs() < 1e-14);
        // a clipped cell at the outline, the particle on its edge
        assert!((chord_2d([0.0, 0.5], [0.0, 1.0], [0.0, 0.0], [0.5, 1.0]) - 0.5).abs() < 1e-15);
        let (lo3, hi3) = ([0.0; 3], [1.0; 3]);
        let c = [0.5; 3];
        assert!((section_3d(c, [0.0, 0.0, 1.0], lo3, hi3) - 1.0).abs() < 1e-14);
        assert!((section_3d(c, [s, s, 0.0], lo3, hi3) - 2f64.sqrt()).abs() < 1e-14);
        // the regular hexagon through the centre, normal (1,1,1)/√3
        let t = 1.0 / 3f64.sqrt();
        let hex = 3.0 * 3f64.sqrt() / 4.0;
        assert!((section_3d(c, [t, t, t], lo3, hi3) - hex).abs() < 1e-14);
    }

    #[test]
    fn candidates_lie_along_the_segment() {
        // eq. 27 with tol 0.3 (about 17°): a crack with normal y grows
        // along x
        let (l, n) = ([0.0, 0.0], [0.0, 1.0]);
        assert!(ahead(l, n, [1.0, 0.0], 0.3));
        assert!(ahead(l, n, [-1.0, 0.2], 0.3));
        assert!(!ahead(l, n, [1.0, 1.0], 0.3));
        assert!(!ahead(l, n, [0.0, 1.0], 0.3));
        assert!(!ahead(l, n, l, 0.3));
    }
}
