//! The explicit cracks in a snapshot: per crack, three polylines (its
//! plane, its `above` surface and its `below` surface), so that ParaView
//! shows them over the particles of the same instant and an opening crack
//! is seen as two faces parting about the plane between them.
//!
//! Each line carries two values (VTK cell data): `crack`, the crack's
//! index (the order of the bodies and their `explicit_cracks` lists, as in
//! the series' `crack{c}_…` columns), and `surface`: [`PLANE`], [`ABOVE`]
//! or [`BELOW`].

use super::{Crack, Cramp};
use crate::diagnostics::Polyline;

/// The `surface` value of a crack's plane.
pub const PLANE: u32 = 0;
/// The `surface` value of the surface above the plane (its left).
pub const ABOVE: u32 = 1;
/// The `surface` value of the surface below the plane.
pub const BELOW: u32 = 2;

impl Cramp {
    /// Every crack's plane, above and below surfaces, in that order, crack
    /// after crack, at z = 0 (explicit cracks are 2D).
    pub(crate) fn polylines(&self, out: &mut Vec<Polyline>) {
        for (c, crack) in self.cracks.iter().enumerate() {
            out.extend(crack_lines(c as u32, crack));
        }
    }
}

/// The three lines of crack `c`.
fn crack_lines(c: u32, crack: &Crack) -> [Polyline; 3] {
    let line = |points: &[[f64; 2]], surface: u32| Polyline {
        points: points.iter().map(|&[x, y]| [x, y, 0.0]).collect(),
        cell_data: vec![("crack".to_string(), c), ("surface".to_string(), surface)],
    };
    [
        line(&crack.plane, PLANE),
        line(&crack.above, ABOVE),
        line(&crack.below, BELOW),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fracture::cracks::section::SurfaceUpdate;

    /// Two cracks give six lines in the order plane, above, below, each
    /// with its crack's points (the surfaces where they have moved to).
    #[test]
    fn three_lines_per_crack_with_their_points() {
        let mut a = Crack::new(0, 0.0, vec![[0.0, 0.0], [1.0, 0.0], [2.0, 0.5]]);
        a.above[1] = [1.0, 0.25];
        a.below[1] = [1.0, -0.25];
        let b = Crack::new(1, 0.3, vec![[5.0, 5.0], [6.0, 6.0]]);
        let cramp = Cramp::new(vec![a.clone(), b], SurfaceUpdate::default(), vec![4]);
        let mut out = Vec::new();
        cramp.polylines(&mut out);
        assert_eq!(out.len(), 6);
        let tags: Vec<_> = out
            .iter()
            .map(|l| (l.value("crack"), l.value("surface")))
            .collect();
        assert_eq!(
            tags,
            [0, 0, 0, 1, 1, 1]
                .into_iter()
                .zip([PLANE, ABOVE, BELOW, PLANE, ABOVE, BELOW])
                .map(|(c, s)| (Some(c), Some(s)))
                .collect::<Vec<_>>()
        );
        assert_eq!(out[1].points[1], [1.0, 0.25, 0.0]);
        assert_eq!(out[2].points[1], [1.0, -0.25, 0.0]);
        assert_eq!(out[0].points.len(), 3);
        assert_eq!(out[5].points, [[5.0, 5.0, 0.0], [6.0, 6.0, 0.0]]);
    }
}
