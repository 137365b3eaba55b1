//! Crack-tip position and speed, shared by the fracture models.
//!
//! The tip of a body's crack is the broken particle (phase field c < 0.1,
//! or damage D > 0.9 and connected to the origin, see
//! `fracture::damage::model::DamageState::crack_tips`) farthest from the body's crack
//! origin; its distance
//! from the origin is the crack length, and the change of that length
//! between two series rows over their time apart is the tip speed. In 3D
//! a crack has a front, not a tip: the "tip" is the point of the broken
//! region farthest from the origin, and its length that distance.

use rayon::prelude::*;

/// The crack tip of one body at one series row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrackTip<const D: usize = 2> {
    /// Tip position, m (NaN while no particle is broken, or before the
    /// model has a field to look at).
    pub x: [f64; D],
    /// Distance of the tip from the origin, m (0 while there is no crack;
    /// NaN before the model has a field).
    pub length: f64,
    /// Change of `length` per time since the last series row, m/s (NaN at
    /// the first measured row).
    pub speed: f64,
}

impl<const D: usize> CrackTip<D> {
    pub const UNKNOWN: CrackTip<D> = CrackTip {
        x: [f64::NAN; D],
        length: f64::NAN,
        speed: f64::NAN,
    };
}

/// Follows one body's crack tip from row to row.
///
/// Its checkpoint bytes are the origin's `D` numbers and the last row
/// (a 2D tracker's are what they were before the dimension was generic).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TipTracker<const D: usize = 2> {
    #[serde(with = "crate::tensor::serde_point")]
    pub origin: [f64; D],
    /// (time, crack length) at the last measured row.
    last: Option<(f64, f64)>,
}

impl<const D: usize> TipTracker<D> {
    pub fn new(origin: [f64; D]) -> TipTracker<D> {
        TipTracker { origin, last: None }
    }

    /// The tip among `particles` (indices into `x`) for which `broken(p)`
    /// holds, at `time`.
    pub fn measure(
        &mut self,
        x: &[[f64; D]],
        particles: &[u32],
        broken: impl Fn(usize) -> bool + Sync,
        time: f64,
    ) -> CrackTip<D> {
        let o = self.origin;
        let (d2, p) = particles
            .par_iter()
            .filter(|&&p| broken(p as usize))
            .map(|&p| {
                let x = x[p as usize];
                // `dot` sums in axis order from the first term (2D: the
                // bits it was)
                let d = crate::tensor::sub(x, o);
                (crate::tensor::dot(d, d), p)
            })
            // the farthest; the lowest index among equals (deterministic)
            .reduce(
                || (-1.0, u32::MAX),
                |a, b| {
                    if b.0 > a.0 || (b.0 == a.0 && b.1 < a.1) {
                        b
                    } else {
                        a
                    }
                },
            );
        let (tip, length) = if p == u32::MAX {
            ([f64::NAN; D], 0.0)
        } else {
            (x[p as usize], d2.sqrt())
        };
        let speed = match self.last {
            Some((t, l)) if time > t => (length - l) / (time - t),
            _ => f64::NAN,
        };
        self.last = Some((time, length));
        CrackTip {
            x: tip,
            length,
            speed,
        }
    }
}
