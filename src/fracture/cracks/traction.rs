//! Pressure-loaded crack faces (Nairn & Aimene, section 2.1.4): the nodal
//! forces of a crack's face pressure (eqs. 7–8 with T_n = −P, T_t = 0) and
//! the pressure's term in the target crack's J (step 9, eqs. 11–12).
//!
//! A crack's `pressure` P(t) acts on its points from the first that lies
//! inside its body to the last (an edge crack's mouth, outside the
//! material, carries none); points grown at a tip are inside and carry it.

use super::contour::End;
use super::{Crack, Cramp, ABOVE, BELOW, MAX_LEN};
use crate::geometry::{contains, ShapeSpec};
use crate::grid::shape::Kernel;
use crate::grid::{GridFields, GridGeom, MultiField};

impl Crack {
    /// Crack point `k`'s share of the crack's length (half of each
    /// segment beside it), m, and its unit normal (the mean of those
    /// segments' normals, toward "above").
    fn point_share(&self, k: usize) -> (f64, [f64; 2]) {
        let n = self.plane.len();
        let seg = |s: usize| {
            let (a, b) = (self.plane[s], self.plane[s + 1]);
            ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt()
        };
        let (mut len, mut nrm) = (0.0, [0.0; 2]);
        for s in [k.checked_sub(1), (k + 1 < n).then_some(k)]
            .into_iter()
            .flatten()
        {
            let l = seg(s);
            let m = self.normal(s);
            len += 0.5 * l;
            nrm = [nrm[0] + l * m[0], nrm[1] + l * m[1]];
        }
        let norm = (nrm[0] * nrm[0] + nrm[1] * nrm[1]).sqrt();
        if norm > 0.0 {
            nrm = [nrm[0] / norm, nrm[1] / norm];
        }
        (len, nrm)
    }
}

/// How many of a crack's `points` at its start and at its end lie outside
/// its body (`shape` less its `holes`): the faces there carry no pressure.
pub(crate) fn outside_ends(
    points: &[[f64; 2]],
    shape: &ShapeSpec,
    holes: &[ShapeSpec],
) -> (usize, usize) {
    let inside = |p: [f64; 2]| contains(shape, p) && !holes.iter().any(|h| contains(h, p));
    let first = points.iter().position(|&p| inside(p));
    let last = points.iter().rposition(|&p| inside(p));
    match (first, last) {
        (Some(a), Some(b)) => (a, points.len() - 1 - b),
        // validation has checked the crack touches its body; a crack with
        // no point inside (only a segment's middle) is loaded throughout
        _ => (0, 0),
    }
}

impl Cramp {
    /// The face pressure of crack `c` at time `t`, Pa (0 without one).
    pub fn pressure_at(&self, c: usize, t: f64) -> f64 {
        self.pressure
            .get(c)
            .and_then(|p| p.as_ref())
            .map_or(0.0, |f| f.eval(t))
    }

    /// Every crack's face pressure at time `t`, Pa.
    pub fn pressures(&self, t: f64) -> Vec<f64> {
        (0..self.cracks.len())
            .map(|c| self.pressure_at(c, t))
            .collect()
    }

    /// The points of crack `c` that carry its pressure.
    fn loaded(&self, c: usize) -> std::ops::Range<usize> {
        let n = self.cracks[c].plane.len();
        let (a, b) = self.outside.get(c).copied().unwrap_or((0, 0));
        a..n.saturating_sub(b)
    }

    /// The `crack_traction` stage (eqs. 7–8): at each loaded crack point k
    /// the force P·A_k n̂_k on the surface above and its opposite on the
    /// surface below (A_k: the point's share of the crack's length times
    /// the thickness), each spread over the nodes of its own side's
    /// velocity field (the appendix's v(s, i), as the surfaces' velocities
    /// take them) in proportion to N_I m_I, the weights of the surface's
    /// own velocity (eq. 5): f_I = F N_I m_I / Σ N m. Every such node then
    /// accelerates by F N_I / Σ N m, so a node that holds a sliver of its
    /// field's mass (the gap of an opened face) is not flung, and the
    /// forces' power Σ f_I·v_I is F·v_s with v_s the velocity eq. 5 gives
    /// the surface from those nodes, the work the step counts. (The
    /// shape function renormalised over the nodes with mass, eq. 4's S*,
    /// which this code used first, put a node's full share of F on a
    /// node of any mass: a growing pressed crack crushed a particle at
    /// its mouth, docs/cracks.md.) Returns the forces' work over the
    /// step, F·v_s Δt with the surfaces' last velocities, J.
    pub fn face_forces<K: Kernel>(
        &self,
        geom: &GridGeom<2>,
        grid: &mut GridFields<2>,
        multi: &MultiField,
        t: f64,
        dt: f64,
    ) -> f64 {
        let mut work = 0.0;
        for (c, crack) in self.cracks.iter().enumerate() {
            let p = self.pressure_at(c, t);
            if p == 0.0 {
                continue;
            }
            for k in self.loaded(c) {
                let (len, nrm) = crack.point_share(k);
                let f = p * len * self.thickness;
                for side in [ABOVE, BELOW] {
                    let (x, v, sign) = if side == ABOVE {
                        (crack.above[k], crack.v_above[k], 1.0)
                    } else {
                        (crack.below[k], crack.v_below[k], -1.0)
                    };
                    let force = [sign * f * nrm[0], sign * f * nrm[1]];
                    let mut to = [(0usize, 0.0f64); MAX_LEN];
                    let (mut n, mut sum) = (0, 0.0);
                    self.own_side::<K>(geom, multi, (c, k, side), x, |slot, w| {
                        if n < MAX_LEN && grid.mass[slot] > 0.0 {
                            let wm = w * grid.mass[slot];
                            to[n] = (slot, wm);
                            n += 1;
                            sum += wm;
                        }
                    });
                    if sum <= 0.0 {
                        continue;
                    }
                    for &(slot, w) in &to[..n] {
                        for d in 0..2 {
                            grid.force[slot][d] += force[d] * w / sum;
                        }
                    }
                    work += (force[0] * v[0] + force[1] * v[1]) * dt;
                }
            }
        }
        work
    }
}

/// The target crack's pressure term of J (step 9): J_T = ∫ T·dδ/dx dx
/// from where the crack enters the contour's box (`lo`, `hi`) to its tip
/// (eq. 11), T = −P n̂ relative to the lower face and δ the faces'
/// opening, so J_T = P δ_n(x₀) with the faces closed at the tip, per unit
/// thickness. It is summed segment by segment with each segment's own
/// normal, from the tip's opening taken as zero, and a
/// segment that another crack crosses is left out: the opening jumps
/// there, and the sum over the continuous pieces is eq. 12's
/// W_Z(x_root) − Σ (W_Z(x_j) − W_Z(x_j+1)).
pub(crate) fn traction_j(
    cracks: &[Crack],
    (target, end): (usize, End),
    pressure: f64,
    (lo, hi): ([f64; 2], [f64; 2]),
) -> f64 {
    let crack = &cracks[target];
    let n = crack.plane.len();
    // the segments from the tip outward, as (segment, the tip's side is
    // its end `t = 1`)
    let segs = super::contour::segments_from_tip(n, end);
    // the faces meet at the tip (eq. 11's W_Z(x_root) = ∫₀^δ(x_root) T·dδ):
    // the tracked surfaces there, which take their velocities from the
    // material a kernel's reach about them, do not (they open by about
    // 40 % of the crack's middle on a centre crack), so the sum starts
    // from a closed tip
    let (k_tip, s_tip) = match end {
        End::End => (n - 1, n - 2),
        End::Start => (0, 0),
    };
    let mut jt = pressure * crack.opening_at(k_tip, crack.normal(s_tip));
    for (s, tip_at_one) in segs {
        let (a, b) = (crack.plane[s], crack.plane[s + 1]);
        let Some((t0, t1)) = super::contour::clip(a, b, lo, hi) else {
            break;
        };
        let crossed = cracks
            .iter()
            .enumerate()
            .any(|(c, other)| c != target && super::crossing(&other.plane, a, b).is_some());
        if !crossed {
            // from the tip's side of the clipped part to the far side
            let (inner, outer) = if tip_at_one { (t1, t0) } else { (t0, t1) };
            jt += pressure * (crack.opening(s, outer) - crack.opening(s, inner));
        }
        // the crack leaves the box inside this segment: x₀ reached
        let left = if tip_at_one { t0 > 0.0 } else { t1 < 1.0 };
        if left {
            break;
        }
    }
    jt
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight crack along x with its faces opened by `open(x)`.
    fn opened(xs: &[f64], open: impl Fn(f64) -> f64) -> Crack {
        let pts: Vec<[f64; 2]> = xs.iter().map(|&x| [x, 0.0]).collect();
        let mut c = Crack::new(0, 0.0, pts);
        let n = c.normal(0);
        for (k, &x) in xs.iter().enumerate() {
            for d in 0..2 {
                c.above[k][d] += 0.5 * open(x) * n[d];
                c.below[k][d] -= 0.5 * open(x) * n[d];
            }
        }
        c
    }

    #[test]
    fn the_pressure_term_is_p_times_the_opening_where_the_crack_enters() {
        // a parabolic opening closing at the tip x = 1; the box's edge at x = 0.45
        let xs: Vec<f64> = (0..=10).map(|k| k as f64 * 0.1).collect();
        let open = |x: f64| 1e-3 * (1.0 - x * x);
        let c = opened(&xs, open);
        let cracks = [c];
        let b = ([0.45, -1.0], [2.0, 1.0]);
        let jt = traction_j(&cracks, (0, End::End), 2.0, b);
        // the opening at x₀ by linear interpolation between the points
        let want = 2.0 * (0.5 * open(0.4) + 0.5 * open(0.5));
        assert!((jt - want).abs() < 1e-15, "{jt} vs {want}");
        // the start end: the crack runs the other way, the same number
        let rev: Vec<f64> = xs.iter().rev().copied().collect();
        let c = opened(&rev, open);
        let cracks = [c];
        let jt_start = traction_j(&cracks, (0, End::Start), 2.0, b);
        assert!((jt_start - want).abs() < 1e-15, "{jt_start} vs {want}");
    }

    #[test]
    fn a_crossing_crack_takes_out_its_segment() {
        let xs: Vec<f64> = (0..=10).map(|k| k as f64 * 0.1).collect();
        // the faces open by 1 behind x = 0.55 and close toward the tip
        let open = |x: f64| if x < 0.55 { 1.0 } else { 1.0 - x };
        let c = opened(&xs, open);
        let v = Crack::new(0, 0.0, vec![[0.55, -1.0], [0.55, 1.0]]);
        let b = ([-1.0, -1.0], [2.0, 1.0]);
        let jt = traction_j(&[c.clone(), v], (0, End::End), 1.0, b);
        // the pieces 0–0.5 (no change) and 0.6–1.0 (0.4 to 0): 0.4
        assert!((jt - 0.4).abs() < 1e-12, "{jt}");
        // without the crossing crack, eq. 11 over the whole crack: 1
        let jt = traction_j(&[c], (0, End::End), 1.0, b);
        assert!((jt - 1.0).abs() < 1e-12, "{jt}");
    }

    #[test]
    fn a_point_shares_half_of_each_segment_beside_it() {
        let c = Crack::new(0, 0.0, vec![[0.0, 0.0], [1.0, 0.0], [1.0, 2.0]]);
        let (l, n) = c.point_share(0);
        assert_eq!((l, n), (0.5, [0.0, 1.0]));
        let (l, n) = c.point_share(1);
        assert_eq!(l, 1.5);
        // the normals (0, 1) and (−1, 0) weighted 1 : 2
        let m = (1.0f64 + 4.0).sqrt();
        assert!((n[0] + 2.0 / m).abs() < 1e-15 && (n[1] - 1.0 / m).abs() < 1e-15);
        let (l, _) = c.point_share(2);
        assert_eq!(l, 1.0);
    }

    #[test]
    fn an_edge_cracks_mouth_outside_its_body_carries_no_pressure() {
        let shape = ShapeSpec::Box {
            min: [0.0, 0.0].into(),
            max: [1.0, 1.0].into(),
        };
        let pts = [[-0.2, 0.5], [-0.1, 0.5], [0.1, 0.5], [0.3, 0.5]];
        assert_eq!(outside_ends(&pts, &shape, &[]), (2, 0));
        let pts = [[0.2, 0.5], [0.5, 0.5], [1.1, 0.5]];
        assert_eq!(outside_ends(&pts, &shape, &[]), (0, 1));
    }
}
