//! Shapes of bodies and the seeding of particles in them, in 2D and 3D.
//!
//! Entry points: [`seed`], which places `n × n` particles on a regular
//! sub-grid of every background cell whose sub-cell centre lies inside the
//! body's shape and outside its holes, and [`seed_3d`], which places
//! `n × n × n` the same way in a 3D grid's cells.

mod shapes3;
mod vector;

pub use shapes3::{bounds_3d, contains_3d, seed_3d, seed_cost_3d, volume, CrackFace};
pub use vector::{Matrix, Point2, Vector};

use crate::tensor;
use serde::{Deserialize, Serialize};

/// A region of the plane or of space: a body's `shape` and its `holes` in
/// a scene. `disk`, `ring`, `polygon` and `slot` are 2D shapes; `sphere`,
/// `cylinder` and `prism` are 3D; a `box` is either, by the length of its
/// points ([`ShapeSpec::dimension`]).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum ShapeSpec {
    /// Axis-aligned rectangle (2D) or box (3D).
    Box {
        min: Vector,
        max: Vector,
    },
    Disk {
        center: Vector,
        radius: f64,
    },
    Ring {
        center: Vector,
        inner_radius: f64,
        outer_radius: f64,
    },
    /// Simple polygon, vertices in order (either orientation).
    Polygon {
        vertices: Vec<[f64; 2]>,
    },
    /// A straight slot of the given width from `start` to `end` (a notch
    /// when subtracted from a body).
    Slot {
        start: Vector,
        end: Vector,
        width: f64,
    },
    /// A ball (3D).
    Sphere {
        center: Vector,
        radius: f64,
    },
    /// A circular cylinder with flat ends from `start` to `end`, along any
    /// direction (3D).
    Cylinder {
        start: Vector,
        end: Vector,
        radius: f64,
    },
    /// A simple polygon of the xy-plane extruded along z from `z_min` to
    /// `z_max` (3D).
    Prism {
        vertices: Vec<[f64; 2]>,
        z_min: f64,
        z_max: f64,
    },
}

impl ShapeSpec {
    /// The dimension the shape belongs to: 2 for the plane shapes, 3 for
    /// the solid ones, and for a box the length of its `min` (validation
    /// checks that `max` has as many).
    pub fn dimension(&self) -> usize {
        match self {
            ShapeSpec::Box { min, .. } => min.len(),
            ShapeSpec::Disk { .. }
            | ShapeSpec::Ring { .. }
            | ShapeSpec::Polygon { .. }
            | ShapeSpec::Slot { .. } => 2,
            ShapeSpec::Sphere { .. } | ShapeSpec::Cylinder { .. } | ShapeSpec::Prism { .. } => 3,
        }
    }

    /// The name the scene writes as its `type`.
    pub fn type_name(&self) -> &'static str {
        match self {
            ShapeSpec::Box { .. } => "box",
            ShapeSpec::Disk { .. } => "disk",
            ShapeSpec::Ring { .. } => "ring",
            ShapeSpec::Polygon { .. } => "polygon",
            ShapeSpec::Slot { .. } => "slot",
            ShapeSpec::Sphere { .. } => "sphere",
            ShapeSpec::Cylinder { .. } => "cylinder",
            ShapeSpec::Prism { .. } => "prism",
        }
    }
}

/// Axis-aligned bounding box (2D by default; [`bounds_3d`] gives 3D ones).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb<const D: usize = 2> {
    pub min: [f64; D],
    pub max: [f64; D],
}

/// Bounding box of a 2D shape (a 3D shape's is its footprint in the
/// xy-plane; validation keeps 3D shapes out of 2D scenes).
pub fn bounds(shape: &ShapeSpec) -> Aabb {
    match shape {
        ShapeSpec::Box { min, max } => Aabb {
            min: min.xy(),
            max: max.xy(),
        },
        ShapeSpec::Sphere { .. } | ShapeSpec::Cylinder { .. } | ShapeSpec::Prism { .. } => {
            let b = bounds_3d(shape);
            Aabb {
                min: [b.min[0], b.min[1]],
                max: [b.max[0], b.max[1]],
            }
        }
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

/// Whether point `p` lies inside the 2D `shape` (boundaries count as
/// inside for boxes; seeding points are sub-cell centres and never lie on
/// a box edge that is aligned with the grid). No point of the plane lies
/// in a 3D shape ([`contains_3d`] tests those).
pub fn contains(shape: &ShapeSpec, p: [f64; 2]) -> bool {
    match shape {
        ShapeSpec::Sphere { .. } | ShapeSpec::Cylinder { .. } | ShapeSpec::Prism { .. } => false,
        ShapeSpec::Box { min, max } => {
            p[0] >= min[0] && p[0] <= max[0] && p[1] >= min[1] && p[1] <= max[1]
        }
        ShapeSpec::Disk { center, radius } => dist2(p, center.xy()) <= radius * radius,
        ShapeSpec::Ring {
            center,
            inner_radius,
            outer_radius,
        } => {
            let d2 = dist2(p, center.xy());
            d2 <= outer_radius * outer_radius && d2 >= inner_radius * inner_radius
        }
        ShapeSpec::Polygon { vertices } => point_in_polygon(vertices, p),
        ShapeSpec::Slot { start, end, width } => {
            let (a, b) = (start.xy(), end.xy());
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
pub(crate) fn point_in_polygon(v: &[[f64; 2]], p: [f64; 2]) -> bool {
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
/// `n` particles per cell per direction (2D by default; a `Lattice<3>`
/// seeds a 3D grid's cells, [`seed_3d`]).
#[derive(Debug, Clone, Copy)]
pub struct Lattice<const D: usize = 2> {
    pub origin: [f64; D],
    pub h: f64,
    pub cells: [usize; D],
    pub per_dir: usize,
}

impl<const D: usize> Lattice<D> {
    /// The distance between neighbouring particles, `h / per_dir`.
    pub fn spacing(&self) -> f64 {
        self.h / self.per_dir.max(1) as f64
    }
}

/// The lattice cells `[lo, hi)` along axis `d` that overlap the box `b`
/// (clipped to the lattice).
fn cell_range<const D: usize>(b: &Aabb<D>, lat: &Lattice<D>, d: usize) -> (usize, usize) {
    let lo = ((b.min[d] - lat.origin[d]) / lat.h).floor().max(0.0) as usize;
    let hi = (((b.max[d] - lat.origin[d]) / lat.h).ceil().max(0.0) as usize).min(lat.cells[d]);
    (lo, hi)
}

/// Calls `emit(position)` for every particle of a body, in a fixed order
/// (cell rows bottom to top, then sub-rows, then left to right). Only the
/// cells overlapping the body's bounding box are visited; its cost is
/// [`seed_cost`].
pub fn seed(shape: &ShapeSpec, holes: &[ShapeSpec], lat: &Lattice, mut emit: impl FnMut([f64; 2])) {
    let b = bounds(shape);
    let n = lat.per_dir.max(1);
    let sub = lat.spacing();
    let (x0, x1) = cell_range(&b, lat, 0);
    let (y0, y1) = cell_range(&b, lat, 1);
    let mut inside = RowTest::new(shape);
    let mut cut: Vec<RowTest> = holes.iter().map(RowTest::new).collect();
    for cy in y0..y1 {
        for sy in 0..n {
            let y = lat.origin[1] + cy as f64 * lat.h + (sy as f64 + 0.5) * sub;
            inside.set_row(y);
            for hole in &mut cut {
                hole.set_row(y);
            }
            for cx in x0..x1 {
                for sx in 0..n {
                    let x = lat.origin[0] + cx as f64 * lat.h + (sx as f64 + 0.5) * sub;
                    let p = [x, y];
                    if inside.contains(p) && !cut.iter().any(|hole| hole.contains(p)) {
                        emit(p);
                    }
                }
            }
        }
    }
}

/// The work [`seed`] does for a body, in point tests: every lattice point
/// in the shape's bounding box is tested against the shape and each hole,
/// and every lattice row costs one pass over each polygon's edges. Known
/// from the scene alone, so that a scene can be refused before seeding.
pub fn seed_cost(shape: &ShapeSpec, holes: &[ShapeSpec], lat: &Lattice) -> f64 {
    let b = bounds(shape);
    let n = lat.per_dir.max(1) as f64;
    let (x0, x1) = cell_range(&b, lat, 0);
    let (y0, y1) = cell_range(&b, lat, 1);
    let rows = (y1.saturating_sub(y0)) as f64 * n;
    let points = rows * (x1.saturating_sub(x0)) as f64 * n;
    let per_row = polygon_edges(shape) + holes.iter().map(polygon_edges).sum::<f64>();
    rows * per_row + points * (1 + holes.len()) as f64
}

/// The edges a lattice row's [`RowTest`] passes over: a polygon's or a
/// prism's.
fn polygon_edges(s: &ShapeSpec) -> f64 {
    match s {
        ShapeSpec::Polygon { vertices } | ShapeSpec::Prism { vertices, .. } => {
            vertices.len() as f64
        }
        _ => 0.0,
    }
}

/// The area of a 2D shape, m² per unit thickness (a polygon's by the
/// shoelace formula, which a self-intersecting outline miscounts); 0 for
/// a 3D one ([`volume`] is its measure).
pub fn area(shape: &ShapeSpec) -> f64 {
    use std::f64::consts::PI;
    match shape {
        ShapeSpec::Box { min, max } => (max[0] - min[0]) * (max[1] - min[1]),
        ShapeSpec::Disk { radius, .. } => PI * radius * radius,
        ShapeSpec::Ring {
            inner_radius,
            outer_radius,
            ..
        } => PI * (outer_radius * outer_radius - inner_radius * inner_radius),
        ShapeSpec::Polygon { vertices } => 0.5 * polygon_area2(vertices).abs(),
        ShapeSpec::Slot { start, end, width } => dist2(start.xy(), end.xy()).sqrt() * width,
        // 3D shapes have no area; validation keeps them out of 2D scenes
        ShapeSpec::Sphere { .. } | ShapeSpec::Cylinder { .. } | ShapeSpec::Prism { .. } => 0.0,
    }
}

/// Point-in-shape tests along one lattice row: a polygon's edge crossings
/// with the row are found once per row (sorted), so that a point costs a
/// binary search instead of a pass over every edge. The answers are those
/// of [`contains`], bit for bit.
struct RowTest<'a> {
    shape: &'a ShapeSpec,
    /// The polygon's crossings with the present row, ascending.
    crossings: Vec<f64>,
}

impl<'a> RowTest<'a> {
    fn new(shape: &'a ShapeSpec) -> RowTest<'a> {
        RowTest {
            shape,
            crossings: Vec::new(),
        }
    }

    fn set_row(&mut self, y: f64) {
        let (ShapeSpec::Polygon { vertices: v } | ShapeSpec::Prism { vertices: v, .. }) =
            self.shape
        else {
            return;
        };
        self.crossings.clear();
        let n = v.len();
        let mut j = n.wrapping_sub(1);
        for i in 0..n {
            let (a, b) = (v[i], v[j]);
            // the same test and arithmetic as `point_in_polygon`
            if (a[1] > y) != (b[1] > y) {
                let x = a[0] + (y - a[1]) * (b[0] - a[0]) / (b[1] - a[1]);
                // `p[0] < NaN` never toggles there: leave it out here too
                if !x.is_nan() {
                    self.crossings.push(x);
                }
            }
            j = i;
        }
        self.crossings.sort_by(f64::total_cmp);
    }

    fn contains(&self, p: [f64; 2]) -> bool {
        match self.shape {
            ShapeSpec::Polygon { .. } => {
                // even-odd: the crossings to the right of p
                let right = self.crossings.len() - self.crossings.partition_point(|&x| x <= p[0]);
                right % 2 == 1
            }
            shape => contains(shape, p),
        }
    }

    /// [`contains_3d`] with a prism's crossings of the present row
    /// (`set_row(p[1])`): its outline in xy, then its extent in z.
    fn contains_3d(&self, p: [f64; 3]) -> bool {
        match self.shape {
            ShapeSpec::Prism { z_min, z_max, .. } => {
                let right = self.crossings.len() - self.crossings.partition_point(|&x| x <= p[0]);
                right % 2 == 1 && p[2] >= *z_min && p[2] <= *z_max
            }
            shape => contains_3d(shape, p),
        }
    }
}

/// Distance from `p` to the polyline through `pts`, m.
pub fn distance_to_polyline<P: Point2>(p: [f64; 2], pts: &[P]) -> f64 {
    pts.windows(2)
        .map(|w| distance_to_segment(p, w[0].xy(), w[1].xy()))
        .fold(f64::INFINITY, f64::min)
}

/// Distance from `p` to the segment `a`–`b` (to `a` when they coincide),
/// in any dimension: the polylines of 2D cracks and the edges of 3D ones.
pub fn distance_to_segment<const D: usize>(p: [f64; D], a: [f64; D], b: [f64; D]) -> f64 {
    let (ab, ap) = (tensor::sub(b, a), tensor::sub(p, a));
    let len2 = tensor::dot(ab, ab);
    let t = if len2 > 0.0 {
        (tensor::dot(ap, ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let d: [f64; D] = std::array::from_fn(|k| ap[k] - t * ab[k]);
    tensor::dot(d, d).sqrt()
}

/// An initial crack as the models place it: in 2D the polyline through
/// its points, in 3D the flat polygon they outline ([`CrackFace`]).
#[derive(Debug, Clone, PartialEq)]
pub enum CrackGeometry {
    Polyline(Vec<[f64; 2]>),
    Face(CrackFace),
}

impl CrackGeometry {
    /// A scene's crack in a scene of `dim` dimensions, or why its points
    /// make none in 3D ([`CrackFace::new`]).
    pub fn new(points: &[Vector], dim: usize) -> Result<CrackGeometry, String> {
        if dim == 3 {
            let pts: Vec<[f64; 3]> = points.iter().map(|p| p.xyz()).collect();
            CrackFace::new(&pts).map(CrackGeometry::Face)
        } else {
            Ok(CrackGeometry::Polyline(
                points.iter().map(|p| p.xy()).collect(),
            ))
        }
    }

    /// Distance from a point given by its 2 or 3 coordinates, m.
    pub fn distance(&self, x: &[f64]) -> f64 {
        match self {
            CrackGeometry::Polyline(pts) => distance_to_polyline([x[0], x[1]], pts),
            CrackGeometry::Face(f) => f.distance([x[0], x[1], x[2]]),
        }
    }

    /// Whether a particle at `x` with lattice spacing `spacing` lies on
    /// the crack: within 0.55 spacings of it (one particle row or layer
    /// for a crack along one, two for a crack between them).
    pub fn holds(&self, x: &[f64], spacing: f64) -> bool {
        self.distance(x) < 0.55 * spacing
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disk_seeding_area_converges() {
        let shape = ShapeSpec::Disk {
            center: [0.5, 0.5].into(),
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
            min: [0.0, 0.0].into(),
            max: [1.0, 1.0].into(),
        };
        let slot = ShapeSpec::Slot {
            start: [0.0, 0.5].into(),
            end: [0.5, 0.5].into(),
            width: 0.1,
        };
        let lat = Lattice {
            origin: [0.0, 0.0],
            h: 0.05,
            cells: [20, 20],
            per_dir: 2,
        };
        let mut pts = Vec::new();
        seed(&shape, std::slice::from_ref(&slot), &lat, |p| pts.push(p));
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

    /// The row-wise polygon test seeds exactly the points the edge-by-edge
    /// even-odd rule accepts, for a shape with concave and crossing edges.
    #[test]
    fn row_tests_agree_with_point_tests() {
        let star = ShapeSpec::Polygon {
            vertices: (0..11)
                .map(|k| {
                    let a = k as f64 * 4.0 * std::f64::consts::PI / 11.0;
                    let r = if k % 2 == 0 { 0.4 } else { 0.23 };
                    [0.5 + r * a.cos(), 0.5 + r * a.sin()]
                })
                .collect(),
        };
        let hole = ShapeSpec::Polygon {
            vertices: vec![[0.45, 0.45], [0.6, 0.47], [0.5, 0.62]],
        };
        let lat = Lattice {
            origin: [0.0, 0.0],
            h: 0.013,
            cells: [77, 77],
            per_dir: 3,
        };
        let mut seeded = Vec::new();
        seed(&star, std::slice::from_ref(&hole), &lat, |p| seeded.push(p));
        let mut expected = Vec::new();
        let sub = lat.spacing();
        for cy in 0..77 {
            for sy in 0..3 {
                let y = cy as f64 * lat.h + (sy as f64 + 0.5) * sub;
                for cx in 0..77 {
                    for sx in 0..3 {
                        let p = [cx as f64 * lat.h + (sx as f64 + 0.5) * sub, y];
                        if contains(&star, p) && !contains(&hole, p) {
                            expected.push(p);
                        }
                    }
                }
            }
        }
        assert!(expected.len() > 1000);
        assert_eq!(seeded, expected);
    }

    #[test]
    fn areas_and_costs_come_from_the_shape_alone() {
        let disk = ShapeSpec::Disk {
            center: [0.5, 0.5].into(),
            radius: 0.25,
        };
        assert!((area(&disk) - std::f64::consts::PI / 16.0).abs() < 1e-15);
        let slot = ShapeSpec::Slot {
            start: [0.0, 0.0].into(),
            end: [3.0, 4.0].into(),
            width: 0.5,
        };
        assert_eq!(area(&slot), 2.5);
        let lat = Lattice {
            origin: [0.0, 0.0],
            h: 0.01,
            cells: [100, 100],
            per_dir: 2,
        };
        // the disk's box is 50 x 50 cells, 100 x 100 lattice points
        assert_eq!(seed_cost(&disk, &[], &lat), 1e4);
        let tri = ShapeSpec::Polygon {
            vertices: vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
        };
        // 200 rows of 200 points, one hole; 3 edges per row
        assert_eq!(seed_cost(&tri, &[disk], &lat), 200.0 * 3.0 + 4e4 * 2.0);
    }
}
