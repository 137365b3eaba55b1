//! Crack growth (Nairn & Aimene, section 3.5): after every step, each crack
//! tip's J on the first contour of `j_contours`, split into K_I and K_II;
//! the maximum-hoop-stress direction θ and K_I^max there (Erdogan & Sih,
//! the paper's equations for cos θ, sin θ and K_I^(max)); where
//! K_I^max ≥ K_Ic a new crack point ahead of the tip, one segment (about a
//! material point's diameter) along θ.
//!
//! Every tip is judged on the state the step left, before any tip grows;
//! the new segments are then added crack by crack, start before end, so
//! the result is the same for any thread count. A tip that has a crack
//! (another, or its own away from the tip) within two segments ahead
//! grows to it, stopping just short, instead of by one segment (which
//! would leave a ligament under a cell that the grid cannot resolve): the
//! tip then sits against that crack, joined to it, and is no longer a
//! tip (the paper's cracks "stopped propagating" where they met
//! another). A tip that comes within two segments of another crack's end
//! ahead of it (within 45°) joins it: its last segment ends on that end,
//! and neither is a tip any more (the paper's C4: two collinear cracks
//! "link into one"). A tip that leaves its body (an edge reached) is no
//! longer a tip and grows no more.
//!
//! The energy a growth event releases is the tip's J (the energy flux
//! into the tip per unit crack advance and thickness, eq. 9) times the
//! segment's length and the thickness; the sum over events is the
//! model's fracture energy (J), the crack-growth counterpart of the
//! dissipation the other models report.

use super::contour::{tip_j, tip_of, End, JOptions};
use super::j_integral::{hoop_direction, hoop_k};
use super::section::GrowthSpec;
use super::{Crack, Cramp};
use crate::grid::shape::Kernel;
use crate::grid::GridGeom;
use crate::material::Elastic;
use crate::particles::Particles;
use crate::tensor::norm;

/// The part of a cell a new segment must keep from any crack it stops at,
/// and the shortest segment still added (a tip against another crack adds
/// nothing).
const GAP: f64 = 1e-3;
const SHORTEST: f64 = 0.05;
/// How far ahead, in segments, a growing tip joins another crack (its
/// end, or a segment it would cross).
const JOIN: f64 = 2.0;

impl GrowthSpec {
    /// K_Ic, Pa·√m, for a material of effective modulus `e_star`
    /// (K_Ic = √(J_Ic E*) when the toughness is given as J_Ic).
    pub fn k_ic(&self, e_star: f64) -> f64 {
        match (self.k_ic, self.j_ic) {
            (Some(k), _) => k,
            (None, Some(j)) => (j * e_star).sqrt(),
            (None, None) => f64::INFINITY,
        }
    }
}

/// One tip that grows this step: its crack, end and direction (radians
/// from the grid's x axis).
#[derive(Debug, Clone, Copy)]
struct Event {
    crack: usize,
    end: End,
    angle: f64,
    /// The tip's J on the first contour, J/m².
    j: f64,
}

impl Cramp {
    /// The `crack_growth` stage: judges every tip and adds the segments,
    /// adding each one's released energy (J × length × thickness) to
    /// `released`; returns how many it added.
    pub fn grow<K: Kernel, const V: usize>(
        &mut self,
        geom: &GridGeom<2>,
        parts: &Particles<2, V>,
        mats: &[Elastic],
        time: f64,
    ) -> usize {
        let Some(growth) = self.growth.clone() else {
            return 0;
        };
        let first = [self.j_contours[0]];
        let pressures = self.pressures(time);
        let mut events = Vec::new();
        for c in 0..self.cracks.len() {
            for end in End::BOTH {
                let how = JOptions {
                    before: self.before_row.as_ref(),
                    method: self.j_method,
                    split: self.k_split,
                    pressure: &pressures,
                };
                let tip = (c, end);
                let js = tip_j::<K, V>(geom, parts, mats, &self.cracks, how, tip, &first);
                let Some(Ok(t)) = js.first() else {
                    continue;
                };
                let theta = hoop_direction(t.k1, t.k2);
                let k_ic = growth.k_ic(t.e_star);
                if hoop_k(t.k1, t.k2, theta) >= k_ic {
                    let (_, dir) = tip_of(&self.cracks[c], end);
                    events.push(Event {
                        crack: c,
                        end,
                        angle: dir[1].atan2(dir[0]) + theta,
                        j: t.j,
                    });
                }
            }
        }
        let step = growth.segment * geom.h;
        let mut added = 0;
        for e in events {
            // a tip joined this step by another crack's growth grows no more
            if self.cracks[e.crack].is_joined(e.end) {
                continue;
            }
            let (tip, _) = tip_of(&self.cracks[e.crack], e.end);
            let d = [e.angle.cos(), e.angle.sin()];
            if let Some((other, end, x)) = self.tip_ahead(&e, tip, d, JOIN * step) {
                self.cracks[e.crack].extend(e.end, x);
                self.cracks[e.crack].joined[e.end as usize] = true;
                self.cracks[other].joined[end as usize] = true;
                let len = norm([x[0] - tip[0], x[1] - tip[1]]);
                self.released += e.j * len * self.thickness;
                added += 1;
                continue;
            }
            // a crack within reach ahead (a ligament under a cell, which
            // the grid cannot resolve, would be left by a regular segment):
            // the segment ends at it, short by GAP, and the tip is joined
            let reach = JOIN * step;
            let q = [tip[0] + reach * d[0], tip[1] + reach * d[1]];
            let hit = self.first_crossing(&e, None, tip, q);
            let len = if hit < 1.0 {
                self.cracks[e.crack].joined[e.end as usize] = true;
                hit * reach - GAP * geom.h
            } else {
                step
            };
            if len < SHORTEST * geom.h {
                continue;
            }
            let q = [tip[0] + len * d[0], tip[1] + len * d[1]];
            // keep the crack two cells inside the grid (its hash and the
            // particles' supports)
            let xi = geom.xi(q);
            let inside = (0..2).all(|a| xi[a] >= 2.0 && xi[a] <= (geom.nodes[a] - 3) as f64);
            if !inside {
                continue;
            }
            self.cracks[e.crack].extend(e.end, q);
            self.released += e.j * len * self.thickness;
            added += 1;
        }
        added
    }

    /// The nearest end of another crack that the growing tip at `tip`
    /// (direction `d`) joins: an end not yet joined, within `reach` of the
    /// tip and within 45° of the direction, which a segment from the tip
    /// reaches without crossing a crack. Two tips that run at each other
    /// (Nairn & Aimene's C4, where they "link into one") would otherwise
    /// stop a fraction of a cell apart with nothing to split the nodes
    /// between them, or overlap.
    fn tip_ahead(
        &self,
        e: &Event,
        tip: [f64; 2],
        d: [f64; 2],
        reach: f64,
    ) -> Option<(usize, End, [f64; 2])> {
        let mut best: Option<(f64, usize, End, [f64; 2])> = None;
        for (c, crack) in self.cracks.iter().enumerate() {
            if c == e.crack {
                continue;
            }
            for end in End::BOTH {
                if crack.is_joined(end) {
                    continue;
                }
                let (x, _) = tip_of(crack, end);
                let r = [x[0] - tip[0], x[1] - tip[1]];
                let dist = norm(r);
                let ahead = r[0] * d[0] + r[1] * d[1] >= dist * std::f64::consts::FRAC_1_SQRT_2;
                if dist <= reach && dist > 0.0 && ahead && best.is_none_or(|b| dist < b.0) {
                    best = Some((dist, c, end, x));
                }
            }
        }
        let (_, c, end, x) = best?;
        (self.first_crossing(e, Some((c, end)), tip, x) >= 1.0).then_some((c, end, x))
    }

    /// The first place, as a fraction of the way from `p` to `q`, where
    /// the segment crosses a crack (1 if nowhere), leaving out the growing
    /// tip's own segment and, if given, the end segment of the crack end it
    /// joins.
    fn first_crossing(
        &self,
        e: &Event,
        joins: Option<(usize, End)>,
        p: [f64; 2],
        q: [f64; 2],
    ) -> f64 {
        self.cracks
            .iter()
            .enumerate()
            .filter_map(|(c, crack)| {
                let skip = if c == e.crack {
                    Some(e.end)
                } else {
                    joins.filter(|j| j.0 == c).map(|j| j.1)
                };
                first_hit(crack, skip, p, q)
            })
            .fold(1.0, f64::min)
    }
}

impl Crack {
    /// A new crack point `q` beyond the tip at `end`, its surfaces closed
    /// there and moving with the old tip's mean surface velocity.
    pub fn extend(&mut self, end: End, q: [f64; 2]) {
        let k = match end {
            End::Start => 0,
            End::End => self.plane.len() - 1,
        };
        let v = [0, 1].map(|a| 0.5 * (self.v_above[k][a] + self.v_below[k][a]));
        let at = match end {
            End::Start => 0,
            End::End => self.plane.len(),
        };
        self.plane.insert(at, q);
        self.above.insert(at, q);
        self.below.insert(at, q);
        self.v_above.insert(at, v);
        self.v_below.insert(at, v);
    }
}

/// The first place, as a fraction of the way from `p` to `q`, where the
/// segment crosses a segment of `crack`'s plane, leaving out the segment
/// at its `skip` end (the tip's own segment, which `p` lies on).
fn first_hit(crack: &Crack, skip: Option<End>, p: [f64; 2], q: [f64; 2]) -> Option<f64> {
    let n = crack.plane.len();
    let segs = match skip {
        None => 0..n - 1,
        Some(End::Start) => 1..n - 1,
        Some(End::End) => 0..n - 2,
    };
    let e = [q[0] - p[0], q[1] - p[1]];
    let cross = |a: [f64; 2], b: [f64; 2]| a[0] * b[1] - a[1] * b[0];
    segs.filter_map(|k| {
        let (a, b) = (crack.plane[k], crack.plane[k + 1]);
        let d = [b[0] - a[0], b[1] - a[1]];
        let den = cross(e, d);
        if den == 0.0 {
            return None;
        }
        let ap = [a[0] - p[0], a[1] - p[1]];
        let s = cross(ap, d) / den; // along p → q
        let u = cross(ap, e) / den; // along a → b
        ((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&u)).then_some(s)
    })
    .reduce(f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn crack(points: Vec<[f64; 2]>) -> Crack {
        Crack::new(0, 0.0, points)
    }

    #[test]
    fn a_new_segment_is_stopped_by_the_crack_it_meets() {
        let wall = crack(vec![[1.0, -1.0], [1.0, 1.0]]);
        assert_eq!(first_hit(&wall, None, [0.0, 0.0], [2.0, 0.0]), Some(0.5));
        assert_eq!(first_hit(&wall, None, [0.0, 0.0], [0.5, 0.0]), None);
        // the tip's own segment is left out, the rest of its crack is not
        let hook = crack(vec![[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0]]);
        assert_eq!(
            first_hit(&hook, Some(End::End), [1.0, 1.0], [1.5, 1.0]),
            None
        );
        let s = first_hit(&hook, Some(End::End), [1.0, 1.0], [1.0, -1.0]).unwrap();
        assert!((s - 0.5).abs() < 1e-12, "{s}");
    }

    #[test]
    fn a_crack_extends_at_either_end_with_closed_surfaces() {
        let mut c = crack(vec![[0.0, 0.0], [1.0, 0.0]]);
        c.v_above[1] = [2.0, 1.0];
        c.v_below[1] = [0.0, -1.0];
        c.extend(End::End, [1.5, 0.0]);
        c.extend(End::Start, [-0.5, 0.1]);
        assert_eq!(c.plane, [[-0.5, 0.1], [0.0, 0.0], [1.0, 0.0], [1.5, 0.0]]);
        assert_eq!(c.above, c.plane);
        assert_eq!(c.below, c.plane);
        assert_eq!(c.v_above[3], [1.0, 0.0]);
        assert_eq!(c.v_below[0], [0.0, 0.0]);
    }

    /// Two collinear cracks whose facing tips are `gap` apart, crack 0's
    /// end growing along +x.
    fn facing(gap: f64) -> (Cramp, Event) {
        let a = crack(vec![[-2.0, 0.0], [0.0, 0.0]]);
        let b = crack(vec![[gap, 0.0], [gap + 2.0, 0.0]]);
        let cramp = Cramp::new(vec![a, b], Default::default(), vec![4]);
        let e = Event {
            crack: 0,
            end: End::End,
            angle: 0.0,
            j: 1.0,
        };
        (cramp, e)
    }

    #[test]
    fn a_tip_joins_the_crack_end_ahead_of_it_within_reach() {
        let (mut cramp, e) = facing(0.8);
        let ahead = cramp.tip_ahead(&e, [0.0, 0.0], [1.0, 0.0], 1.0);
        assert_eq!(ahead, Some((1, End::Start, [0.8, 0.0])));
        // beyond reach, behind, or more than 45° off the direction: none
        assert_eq!(cramp.tip_ahead(&e, [0.0, 0.0], [1.0, 0.0], 0.7), None);
        assert_eq!(cramp.tip_ahead(&e, [0.0, 0.0], [-1.0, 0.0], 1.0), None);
        let steep = [0.6f64.cos(), 0.6f64.sin()];
        assert!(cramp.tip_ahead(&e, [0.0, 0.0], steep, 1.0).is_some());
        let off = [0.9f64.cos(), 0.9f64.sin()];
        assert_eq!(cramp.tip_ahead(&e, [0.0, 0.0], off, 1.0), None);
        // an end already joined is not joined again
        cramp.cracks[1].joined[End::Start as usize] = true;
        assert_eq!(cramp.tip_ahead(&e, [0.0, 0.0], [1.0, 0.0], 1.0), None);
        // a third crack between the tips keeps them apart
        let (mut cramp, e) = facing(0.8);
        cramp.cracks.push(crack(vec![[0.4, -1.0], [0.4, 1.0]]));
        assert_eq!(cramp.tip_ahead(&e, [0.0, 0.0], [1.0, 0.0], 1.0), None);
        assert_eq!(cramp.first_crossing(&e, None, [0.0, 0.0], [0.8, 0.0]), 0.5);
        // the joined end's own segment is left out of the crossings (here
        // a segment across the way, from the joined end up)
        let (mut cramp, e) = facing(0.8);
        cramp.cracks[1] = crack(vec![[0.8, 0.0], [0.8, 2.0]]);
        assert_eq!(cramp.first_crossing(&e, None, [0.0, 0.0], [1.6, 0.0]), 0.5);
        let skip = Some((1, End::Start));
        assert_eq!(cramp.first_crossing(&e, skip, [0.0, 0.0], [1.6, 0.0]), 1.0);
    }

    #[test]
    fn toughness_as_j_or_k() {
        let g = |j_ic, k_ic| GrowthSpec {
            j_ic,
            k_ic,
            segment: 0.5,
        };
        assert_eq!(g(None, Some(5e5)).k_ic(1e9), 5e5);
        // the paper's section 3.5: E = 2500 MPa plane stress, J_Ic = 1000 J/m²
        let k = g(Some(1000.0), None).k_ic(2.5e9);
        assert!((k / 1.58114e6 - 1.0).abs() < 1e-5, "{k}");
    }
}
