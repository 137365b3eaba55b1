//! Shapes of bodies and the seeding of particles in them.
//!
//! Entry point: [`seed`], which places `n × n` particles on a regular
//! sub-grid of every background cell whose sub-cell centre lies inside the
//! body's shape and outside its holes.

use crate::scene::ShapeSpec;

/// Axis-aligned bounding box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    pub min: [f64; 2],
    pub max: [f64; 2],
}

/// Bounding box of a shape.
pub fn bounds(shape: &ShapeSpec) -> Aabb {
    match shape {
        ShapeSpec::Box { min, max } => Aabb {
            min: *min,
            max: *max,
        },
        ShapeSpec::Disk { center, radius } => Aabb {
            min: [center[0] - radius, center[1] - radius],
            max: [center[0] + radius, center[1] + radius],
        },
        ShapeSpec::Ring {
            center,
            outer_radius,
            ..
        } => Aabb {
            min: [center[0] - outer_radius, center[1] - outer_radius],
            max: [center[0] + outer_radius, center[1] + outer_radius],
        },
        ShapeSpec::Polygon { vertices } => {
            let mut b = Aabb {
                min: [f64::INFINITY; 2],
                max: [f64::NEG_INFINITY; 2],
            };
            for v in vertices {
                for d in 0..2 {
                    b.min[d] = b.min[d].min(v[d]);
                    b.max[d] = b.max[d].max(v[d]);
                }
            }
            b
        }
        ShapeSpec::Slot { start, end, width } => {
            let r = 0.5 * width;
            Aabb {
                min: [start[0].min(end[0]) - r, start[1].min(end[1]) - r],
                max: [start[0].max(end[0]) + r, start[1].max(end[1]) + r],
            }
        }
    }
}

/// Whether point `p` lies inside `shape` (boundaries count as inside for
/// boxes; seeding points are sub-cell centres and never lie on a box edge
/// that is aligned with the grid).
pub fn contains(shape: &ShapeSpec, p: [f64; 2]) -> bool {
    match shape {
        ShapeSpec::Box { min, max } => {
            p[0] >= min[0] && p[0] <= max[0] && p[1] >= min[1] && p[1] <= max[1]
        }
        ShapeSpec::Disk { center, radius } => dist2(p, *center) <= radius * radius,
        ShapeSpec::Ring {
            center,
            inner_radius,
            outer_radius,
        } => {
            let d2 = dist2(p, *center);
            d2 <= outer_radius * outer_radius && d2 >= inner_radius * inner_radius
        }
        ShapeSpec::Polygon { vertices } => point_in_polygon(vertices, p),
        ShapeSpec::Slot { start, end, width } => {
            let (a, b) = (*start, *end);
            let ab = [b[0] - a[0], b[1] - a[1]];
            let len2 = ab[0] * ab[0] + ab[1] * ab[1];
            let ap = [p[0] - a[0], p[1] - a[1]];
            // A slot is a rectangle: the projection must fall on the segment
            // (no rounded ends: notches have square ends).
            let t = if len2 > 0.0 {
                (ap[0] * ab[0] + ap[1] * ab[1]) / len2
            } else {
                0.0
            };
            if !(0.0..=1.0).contains(&t) {
                return false;
            }
            let q = [a[0] + t * ab[0], a[1] + t * ab[1]];
            dist2(p, q) <= 0.25 * width * width
        }
    }
}

fn dist2(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)
}

/// Even–odd rule.
fn point_in_polygon(v: &[[f64; 2]], p: [f64; 2]) -> bool {
    let mut inside = false;
    let n = v.len();
    let mut j = n.wrapping_sub(1);
    for i in 0..n {
        let (a, b) = (v[i], v[j]);
        if (a[1] > p[1]) != (b[1] > p[1]) {
            let x = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
            if p[0] < x {
                inside = !inside;
            }
        }
        j = i;
    }
    inside
}

/// Twice the signed area of a polygon (positive counter-clockwise).
pub fn polygon_area2(v: &[[f64; 2]]) -> f64 {
    let n = v.len();
    (0..n)
        .map(|i| {
            let (a, b) = (v[i], v[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum()
}

/// Regular seeding lattice: the background cells (origin, cell size `h`) and
/// `n` particles per cell per direction.
#[derive(Debug, Clone, Copy)]
pub struct Lattice {
    pub origin: [f64; 2],
    pub h: f64,
    pub cells: [usize; 2],
    pub per_dir: usize,
}

impl Lattice {
    /// The distance between neighbouring particles, `h / per_dir`.
    pub fn spacing(&self) -> f64 {
        self.h / self.per_dir.max(1) as f64
    }
}

/// Calls `emit(position)` for every particle of a body, in a fixed order
/// (cell rows bottom to top, then sub-rows, then left to right). Only the
/// cells overlapping the body's bounding box are visited.
pub fn seed(shape: &ShapeSpec, holes: &[ShapeSpec], lat: &Lattice, mut emit: impl FnMut([f64; 2])) {
    let b = bounds(shape);
    let n = lat.per_dir.max(1);
    let sub = lat.spacing();
    let cell_range = |d: usize| {
        let lo = ((b.min[d] - lat.origin[d]) / lat.h).floor().max(0.0) as usize;
        let hi = (((b.max[d] - lat.origin[d]) / lat.h).ceil().max(0.0) as usize).min(lat.cells[d]);
        (lo, hi)
    };
    let (x0, x1) = cell_range(0);
    let (y0, y1) = cell_range(1);
    for cy in y0..y1 {
        for sy in 0..n {
            let y = lat.origin[1] + cy as f64 * lat.h + (sy as f64 + 0.5) * sub;
            for cx in x0..x1 {
                for sx in 0..n {
                    let x = lat.origin[0] + cx as f64 * lat.h + (sx as f64 + 0.5) * sub;
                    let p = [x, y];
                    if contains(shape, p) && !holes.iter().any(|hole| contains(hole, p)) {
                        emit(p);
                    }
                }
            }
        }
    }
}

/// Distance from `p` to the polyline through `pts`, m.
pub fn distance_to_polyline(p: [f64; 2], pts: &[[f64; 2]]) -> f64 {
    pts.windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            let ab = [b[0] - a[0], b[1] - a[1]];
            let len2 = ab[0] * ab[0] + ab[1] * ab[1];
            let t = if len2 > 0.0 {
                (((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            ((p[0] - a[0] - t * ab[0]).powi(2) + (p[1] - a[1] - t * ab[1]).powi(2)).sqrt()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Whether a particle at `p` with lattice spacing `spacing` lies on one of
/// the initial cracks: within 0.55 spacings of its polyline (one particle
/// row for a crack along a row, two for a crack between rows).
pub fn on_cracks(p: [f64; 2], cracks: &[crate::scene::CrackSpec], spacing: f64) -> bool {
    cracks
        .iter()
        .any(|c| distance_to_polyline(p, &c.points) < 0.55 * spacing)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disk_seeding_area_converges() {
        let shape = ShapeSpec::Disk {
            center: [0.5, 0.5],
            radius: 0.3,
        };
        let lat = Lattice {
            origin: [0.0, 0.0],
            h: 0.01,
            cells: [100, 100],
            per_dir: 2,
        };
        let mut count = 0usize;
        seed(&shape, &[], &lat, |_| count += 1);
        let area = count as f64 * (0.005f64).powi(2);
        let exact = std::f64::consts::PI * 0.09;
        assert!(
            (area - exact).abs() / exact < 0.01,
            "area {area} vs {exact}"
        );
    }

    #[test]
    fn holes_and_slots_remove_particles() {
        let shape = ShapeSpec::Box {
            min: [0.0, 0.0],
            max: [1.0, 1.0],
        };
        let slot = ShapeSpec::Slot {
            start: [0.0, 0.5],
            end: [0.5, 0.5],
            width: 0.1,
        };
        let lat = Lattice {
            origin: [0.0, 0.0],
            h: 0.05,
            cells: [20, 20],
            per_dir: 2,
        };
        let mut pts = Vec::new();
        seed(&shape, &[slot.clone()], &lat, |p| pts.push(p));
        assert!(pts.iter().all(|p| !contains(&slot, *p)));
        // 40 x 40 particles minus a 0.5 x 0.1 slot = 20 x 4 particles
        assert_eq!(pts.len(), 1600 - 80);
    }

    #[test]
    fn polygon_contains_and_area() {
        let tri = vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        assert!(point_in_polygon(&tri, [0.2, 0.2]));
        assert!(!point_in_polygon(&tri, [0.8, 0.8]));
        assert_eq!(polygon_area2(&tri), 1.0);
    }
}
