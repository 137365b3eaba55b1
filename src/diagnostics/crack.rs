//! Crack-tip position and speed, shared by the fracture models.
//!
//! The tip of a body's crack is the broken particle (phase field c < 0.1,
//! or damage D > 0.9 and connected to the origin, see
//! `fracture::damage::model::DamageState::crack_tips`) farthest from the body's crack
//! origin; its distance
//! from the origin is the crack length, and the change of that length
//! between two series rows over their time apart is the tip speed.

use rayon::prelude::*;

/// The crack tip of one body at one series row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrackTip {
    /// Tip position, m (NaN while no particle is broken, or before the
    /// model has a field to look at).
    pub x: [f64; 2],
    /// Distance of the tip from the origin, m (0 while there is no crack;
    /// NaN before the model has a field).
    pub length: f64,
    /// Change of `length` per time since the last series row, m/s (NaN at
    /// the first measured row).
    pub speed: f64,
}

impl CrackTip {
    pub const UNKNOWN: CrackTip = CrackTip {
        x: [f64::NAN; 2],
        length: f64::NAN,
        speed: f64::NAN,
    };
}

/// Follows one body's crack tip from row to row.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TipTracker {
    pub origin: [f64; 2],
    /// (time, crack length) at the last measured row.
    last: Option<(f64, f64)>,
}

impl TipTracker {
    pub fn new(origin: [f64; 2]) -> TipTracker {
        TipTracker { origin, last: None }
    }

    /// The tip among `particles` (indices into `x`) for which `broken(p)`
    /// holds, at `time`.
    pub fn measure(
        &mut self,
        x: &[[f64; 2]],
        particles: &[u32],
        broken: impl Fn(usize) -> bool + Sync,
        time: f64,
    ) -> CrackTip {
        let o = self.origin;
        let (d2, p) = particles
            .par_iter()
            .filter(|&&p| broken(p as usize))
            .map(|&p| {
                let x = x[p as usize];
                ((x[0] - o[0]).powi(2) + (x[1] - o[1]).powi(2), p)
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
            ([f64::NAN; 2], 0.0)
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
