//! Pre-existing cracks of the damage particle method by the diffraction
//! method of Organ, Fleming, Terry & Belytschko (1996), as Wei & Chen
//! model them (section 4: "by modifying the support domain of the nodes,
//! which cover the initial cracks").
//!
//! A crack is a polyline in a body (2D). Where the straight line from a
//! particle x_I to a point x crosses a crack, the kernel of x_I at x is
//! evaluated not at the distance s₀ = |x − x_I| but at the diffracted one
//!
//! d_I(x) = ((s₁ + s₂(x)) / s₀(x))^λ s₀(x),
//!
//! with s₁ = |x_I − x_c| and s₂ = |x − x_c| the distances to the crack's tip
//! x_c (Organ et al., eq. 13): the support bends around the tip, so that
//! near it the shape functions are continuous and far from it the two
//! faces do not see each other (the visibility criterion's cut). We take
//! λ = 2. A crack end outside its body or on its boundary (an edge crack's
//! mouth) is not a tip: a line that crosses such a crack and has no
//! interior tip to go around is cut outright. Where a crack has two
//! interior tips the shorter way around counts. Only the kernel's
//! distance changes; the basis H(x − x_I) keeps the straight one, so the
//! functions still reproduce linear fields (Wei & Chen, eq. 22) on each
//! side of the crack.
//!
//! A particle on a crack would belong to neither face: [`Cuts::on_crack`]
//! finds one for the setup to refuse. A smoothing cell's face may lie on
//! a crack (the crack is then a boundary of the cells on both sides, as it
//! should be); its point is judged from a hair inside the cell
//! ([`Cuts::inside`], [`Cuts::distance_seen_from`]) and evaluated where it
//! is, so that each cell integrates its own face of the crack and the
//! face rule stays exact for linear fields.

/// λ of Organ et al.'s diffracted distance.
const LAMBDA: i32 = 2;

/// The cracks of a set of particles: segments with the body they cut and
/// their polyline's interior tips.
#[derive(Debug, Clone, Default)]
pub struct Cuts<const D: usize> {
    segments: Vec<Segment<D>>,
    /// Each polyline's interior tips (zero, one or two points).
    tips: Vec<Vec<[f64; D]>>,
}

#[derive(Debug, Clone, Copy)]
struct Segment<const D: usize> {
    a: [f64; D],
    b: [f64; D],
    /// The body whose particles it separates.
    body: u16,
    /// Its polyline (an index into `tips`).
    line: usize,
}

impl<const D: usize> Cuts<D> {
    /// No cracks.
    pub fn none() -> Self {
        Cuts::default()
    }

    /// Whether there are no cracks.
    pub fn is_empty(&self) -> bool {
        self.segments.is_empty()
    }

    /// Adds the polyline `points` to `body`; `interior(p)` says whether an
    /// end lies strictly inside the body (a tip).
    pub fn add(&mut self, body: u16, points: &[[f64; D]], interior: impl Fn([f64; D]) -> bool) {
        debug_assert!(D == 2, "diffraction cracks are 2D");
        if points.len() < 2 {
            return;
        }
        let line = self.tips.len();
        let ends = [points[0], points[points.len() - 1]];
        self.tips
            .push(ends.into_iter().filter(|&p| interior(p)).collect());
        for w in points.windows(2) {
            self.segments.push(Segment {
                a: w[0],
                b: w[1],
                body,
                line,
            });
        }
    }

    /// The kernel distance of a particle of `body` at `xi` seen from `x`
    /// (`s0` = |x − xi|): s0 when no crack of the body lies between them,
    /// the diffracted distance around the nearest tip of the crossed
    /// cracks, or infinity when a crossed crack has no interior tip.
    pub fn distance(&self, body: u16, x: [f64; D], xi: [f64; D], s0: f64) -> f64 {
        self.distance_seen_from(body, x, x, xi, s0)
    }

    /// [`Cuts::distance`] with the crossing judged from `seen_from` (a
    /// point a hair from `x` on the side it belongs to, [`Cuts::inside`])
    /// and the distances measured from `x`: a face point on a crack is
    /// then of its cell's side without moving it.
    pub fn distance_seen_from(
        &self,
        body: u16,
        x: [f64; D],
        seen_from: [f64; D],
        xi: [f64; D],
        s0: f64,
    ) -> f64 {
        let mut d = s0;
        if s0 == 0.0 {
            return d;
        }
        for seg in &self.segments {
            if seg.body != body || !crosses(xi, seen_from, seg.a, seg.b) {
                continue;
            }
            let around = self.tips[seg.line]
                .iter()
                .map(|&c| {
                    let s1 = crate::tensor::norm(crate::tensor::sub(xi, c));
                    let s2 = crate::tensor::norm(crate::tensor::sub(x, c));
                    ((s1 + s2) / s0).powi(LAMBDA) * s0
                })
                .fold(f64::INFINITY, f64::min);
            d = d.max(around);
        }
        d
    }

    /// The first crack of `body` that passes within `tol` of `x`, if any
    /// (as its polyline's index).
    pub fn on_crack(&self, body: u16, x: [f64; D], tol: f64) -> Option<usize> {
        self.segments
            .iter()
            .find(|s| s.body == body && distance_to_segment(x, s.a, s.b) <= tol)
            .map(|s| s.line)
    }

    /// The first crack of `body` that the segment p–q meets, if any (as
    /// its polyline's index).
    pub fn between(&self, body: u16, p: [f64; D], q: [f64; D]) -> Option<usize> {
        self.segments
            .iter()
            .find(|s| s.body == body && crosses(p, q, s.a, s.b))
            .map(|s| s.line)
    }

    /// `x` (a point of a cell's face) moved a hair (`tol`) towards `centre`
    /// when it lies within `tol` of a crack of `body`, so that it is seen
    /// from the cell's side; else `x` itself.
    pub fn inside(&self, body: u16, x: [f64; D], centre: [f64; D], tol: f64) -> [f64; D] {
        if self.is_empty() || self.on_crack(body, x, tol).is_none() {
            return x;
        }
        let r = crate::tensor::sub(centre, x);
        let len = crate::tensor::norm(r);
        if len == 0.0 {
            return x;
        }
        std::array::from_fn(|k| x[k] + 10.0 * tol * r[k] / len)
    }
}

/// Whether the segment p–q meets the segment a–b (2D; touching counts).
fn crosses<const D: usize>(p: [f64; D], q: [f64; D], a: [f64; D], b: [f64; D]) -> bool {
    let orient = |o: [f64; D], u: [f64; D], v: [f64; D]| {
        (u[0] - o[0]) * (v[1] - o[1]) - (u[1] - o[1]) * (v[0] - o[0])
    };
    let (d1, d2) = (orient(a, b, p), orient(a, b, q));
    let (d3, d4) = (orient(p, q, a), orient(p, q, b));
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    // collinear or touching: an end on the other segment
    let on = |o: [f64; D], u: [f64; D], v: [f64; D], d: f64| {
        d == 0.0
            && o[0].min(u[0]) <= v[0]
            && v[0] <= o[0].max(u[0])
            && o[1].min(u[1]) <= v[1]
            && v[1] <= o[1].max(u[1])
    };
    on(a, b, p, d1) || on(a, b, q, d2) || on(p, q, a, d3) || on(p, q, b, d4)
}

/// The distance from `x` to the segment a–b.
fn distance_to_segment<const D: usize>(x: [f64; D], a: [f64; D], b: [f64; D]) -> f64 {
    let ab = crate::tensor::sub(b, a);
    let ax = crate::tensor::sub(x, a);
    let l2 = crate::tensor::dot(ab, ab);
    let t = if l2 > 0.0 {
        (crate::tensor::dot(ax, ab) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let c: [f64; D] = std::array::from_fn(|k| a[k] + t * ab[k]);
    crate::tensor::norm(crate::tensor::sub(x, c))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An edge crack from x = −1 (outside) to the tip (0, 0).
    fn edge() -> Cuts<2> {
        let mut c = Cuts::none();
        c.add(0, &[[-1.0, 0.0], [0.0, 0.0]], |p| p[0] > -0.5);
        c
    }

    #[test]
    fn a_line_that_misses_the_crack_keeps_its_distance() {
        let c = edge();
        let (x, xi) = ([0.5, 0.2], [0.5, -0.2]);
        assert_eq!(c.distance(0, x, xi, 0.4), 0.4);
        // another body's particles do not see the crack
        let (x, xi) = ([-0.5, 0.2], [-0.5, -0.2]);
        assert_eq!(c.distance(1, x, xi, 0.4), 0.4);
    }

    #[test]
    fn the_support_bends_around_the_tip() {
        let c = edge();
        let (x, xi) = ([-0.3, 0.4], [-0.3, -0.4]);
        let s0 = 0.8;
        let s = 0.5; // both 0.5 from the tip
        let d = c.distance(0, x, xi, s0);
        assert!((d - ((s + s) / s0).powi(2) * s0).abs() < 1e-15, "{d}");
        assert!(d > s0);
        // continuous at the tip: a line through the tip itself is not bent
        let (x, xi) = ([0.0, 1e-12], [0.0, -0.5]);
        let d = c.distance(0, x, xi, 0.5 + 1e-12);
        assert!((d - (0.5 + 1e-12)).abs() < 1e-12, "{d}");
    }

    #[test]
    fn a_crack_without_an_interior_tip_cuts_outright() {
        let mut c = Cuts::<2>::none();
        c.add(0, &[[-1.0, 0.0], [1.0, 0.0]], |_| false);
        assert_eq!(c.distance(0, [0.0, 0.1], [0.0, -0.1], 0.2), f64::INFINITY);
    }

    #[test]
    fn a_face_point_on_a_crack_is_seen_from_its_cell() {
        let c = edge();
        assert_eq!(c.on_crack(0, [-0.3, 0.0], 1e-9), Some(0));
        assert_eq!(c.on_crack(0, [-0.3, 0.1], 1e-9), None);
        let p = c.inside(0, [-0.3, 0.0], [-0.3, 0.5], 1e-9);
        assert!(p[1] > 0.0 && p[1] < 1e-7);
        // from that point, a particle below is behind the crack
        assert!(c.distance(0, p, [-0.3, -0.1], 0.1) > 0.1);
        assert_eq!(c.distance(0, p, [-0.3, 0.1], 0.1), 0.1);
    }
}
