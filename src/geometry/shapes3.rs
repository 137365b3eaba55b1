//! The 3D side of the shapes: bounds, point tests, volumes and the seeding
//! of `n × n × n` particles per cell, the same lattice as 2D's `n × n`
//! with a third axis (particles at the sub-cell centres).

use super::{cell_range, polygon_area2, polygon_edges, Aabb, Lattice, RowTest, ShapeSpec};
use crate::tensor::{dot, sub};

/// Bounding box of a 3D shape (a 2D shape's is its own in xy, flat at
/// z = 0: validation keeps 2D shapes out of 3D scenes).
pub fn bounds_3d(shape: &ShapeSpec) -> Aabb<3> {
    match shape {
        ShapeSpec::Box { min, max } => Aabb {
            min: min.xyz(),
            max: max.xyz(),
        },
        ShapeSpec::Sphere { center, radius } => {
            let c = center.xyz();
            Aabb {
                min: c.map(|x| x - radius),
                max: c.map(|x| x + radius),
            }
        }
        ShapeSpec::Cylinder { start, end, radius } => {
            let (a, b) = (start.xyz(), end.xyz());
            let axis = sub(b, a);
            let len2 = dot(axis, axis);
            // the end disks reach r·sin(angle between the axis and e_d)
            // beyond the axis along d
            let reach = |d: usize| {
                if len2 > 0.0 {
                    radius * (1.0 - axis[d] * axis[d] / len2).max(0.0).sqrt()
                } else {
                    *radius
                }
            };
            Aabb {
                min: std::array::from_fn(|d| a[d].min(b[d]) - reach(d)),
                max: std::array::from_fn(|d| a[d].max(b[d]) + reach(d)),
            }
        }
        ShapeSpec::Prism {
            vertices,
            z_min,
            z_max,
        } => {
            let xy = super::bounds(&ShapeSpec::Polygon {
                vertices: vertices.clone(),
            });
            Aabb {
                min: [xy.min[0], xy.min[1], *z_min],
                max: [xy.max[0], xy.max[1], *z_max],
            }
        }
        ShapeSpec::Disk { .. }
        | ShapeSpec::Ring { .. }
        | ShapeSpec::Polygon { .. }
        | ShapeSpec::Slot { .. } => {
            let b = super::bounds(shape);
            Aabb {
                min: [b.min[0], b.min[1], 0.0],
                max: [b.max[0], b.max[1], 0.0],
            }
        }
    }
}

/// Whether point `p` lies inside the 3D `shape` (boundaries count as
/// inside, as in 2D). No point of space lies in a 2D shape.
pub fn contains_3d(shape: &ShapeSpec, p: [f64; 3]) -> bool {
    match shape {
        ShapeSpec::Box { min, max } => (0..3).all(|d| p[d] >= min[d] && p[d] <= max[d]),
        ShapeSpec::Sphere { center, radius } => {
            let d = sub(p, center.xyz());
            dot(d, d) <= radius * radius
        }
        ShapeSpec::Cylinder { start, end, radius } => {
            let (a, b) = (start.xyz(), end.xyz());
            let axis = sub(b, a);
            let len2 = dot(axis, axis);
            let ap = sub(p, a);
            // flat ends: the projection must fall on the axis segment
            let t = if len2 > 0.0 {
                dot(ap, axis) / len2
            } else {
                0.0
            };
            if !(0.0..=1.0).contains(&t) {
                return false;
            }
            let off = sub(ap, axis.map(|x| t * x));
            dot(off, off) <= radius * radius
        }
        ShapeSpec::Prism {
            vertices,
            z_min,
            z_max,
        } => p[2] >= *z_min && p[2] <= *z_max && super::point_in_polygon(vertices, [p[0], p[1]]),
        ShapeSpec::Disk { .. }
        | ShapeSpec::Ring { .. }
        | ShapeSpec::Polygon { .. }
        | ShapeSpec::Slot { .. } => false,
    }
}

/// The volume of a 3D shape, m³ (a prism's from its outline's shoelace
/// area); 0 for a 2D one ([`super::area`] is its measure).
pub fn volume(shape: &ShapeSpec) -> f64 {
    use std::f64::consts::PI;
    match shape {
        ShapeSpec::Box { min, max } => (0..3).map(|d| max[d] - min[d]).product(),
        ShapeSpec::Sphere { radius, .. } => 4.0 / 3.0 * PI * radius.powi(3),
        ShapeSpec::Cylinder { start, end, radius } => {
            let axis = sub(end.xyz(), start.xyz());
            PI * radius * radius * dot(axis, axis).sqrt()
        }
        ShapeSpec::Prism {
            vertices,
            z_min,
            z_max,
        } => 0.5 * polygon_area2(vertices).abs() * (z_max - z_min),
        ShapeSpec::Disk { .. }
        | ShapeSpec::Ring { .. }
        | ShapeSpec::Polygon { .. }
        | ShapeSpec::Slot { .. } => 0.0,
    }
}

/// Calls `emit(position)` for every particle of a 3D body, in a fixed
/// order (cell layers bottom to top in z, then sub-layers, then as
/// [`super::seed`] does each layer: rows in y, then x). Only the cells
/// overlapping the body's bounding box are visited; its cost is
/// [`seed_cost_3d`].
pub fn seed_3d(
    shape: &ShapeSpec,
    holes: &[ShapeSpec],
    lat: &Lattice<3>,
    mut emit: impl FnMut([f64; 3]),
) {
    let b = bounds_3d(shape);
    let n = lat.per_dir.max(1);
    let sub = lat.spacing();
    let (x0, x1) = cell_range(&b, lat, 0);
    let (y0, y1) = cell_range(&b, lat, 1);
    let (z0, z1) = cell_range(&b, lat, 2);
    let mut inside = RowTest::new(shape);
    let mut cut: Vec<RowTest> = holes.iter().map(RowTest::new).collect();
    let at = |axis: usize, cell: usize, s: usize| {
        lat.origin[axis] + cell as f64 * lat.h + (s as f64 + 0.5) * sub
    };
    for cz in z0..z1 {
        for sz in 0..n {
            let z = at(2, cz, sz);
            for cy in y0..y1 {
                for sy in 0..n {
                    let y = at(1, cy, sy);
                    // a prism's crossings depend on y alone; found again
                    // per layer, which seed_cost_3d counts
                    inside.set_row(y);
                    for hole in &mut cut {
                        hole.set_row(y);
                    }
                    for cx in x0..x1 {
                        for sx in 0..n {
                            let p = [at(0, cx, sx), y, z];
                            if inside.contains_3d(p) && !cut.iter().any(|h| h.contains_3d(p)) {
                                emit(p);
                            }
                        }
                    }
                }
            }
        }
    }
}

/// The work [`seed_3d`] does for a body, in point tests (as
/// [`super::seed_cost`]: every lattice point in the shape's bounding box
/// against the shape and each hole, and a pass over each prism's edges
/// per lattice row), known from the scene alone.
pub fn seed_cost_3d(shape: &ShapeSpec, holes: &[ShapeSpec], lat: &Lattice<3>) -> f64 {
    let b = bounds_3d(shape);
    let n = lat.per_dir.max(1) as f64;
    let span = |d: usize| {
        let (lo, hi) = cell_range(&b, lat, d);
        hi.saturating_sub(lo) as f64 * n
    };
    let rows = span(1) * span(2);
    let points = rows * span(0);
    let per_row = polygon_edges(shape) + holes.iter().map(polygon_edges).sum::<f64>();
    rows * per_row + points * (1 + holes.len()) as f64
}

/// A 3D initial crack: the flat polygon its points outline (in order;
/// convex or not, read by the even–odd rule), with the frame in which
/// distances to it are measured.
#[derive(Debug, Clone, PartialEq)]
pub struct CrackFace {
    points: Vec<[f64; 3]>,
    /// The points' mean, on the plane.
    origin: [f64; 3],
    /// The plane's unit normal and two unit axes in it.
    normal: [f64; 3],
    u: [f64; 3],
    v: [f64; 3],
    /// The outline in (u, v) about `origin`.
    outline: Vec<[f64; 2]>,
}

impl CrackFace {
    /// The face through `points`, or why they outline none: fewer than
    /// three, no area (all on one line), or a point off the plane of the
    /// others by more than 10⁻⁹ of the outline's size.
    pub fn new(points: &[[f64; 3]]) -> Result<CrackFace, String> {
        let n = points.len();
        if n < 3 {
            return Err(format!(
                "a 3D crack is a flat polygon and needs at least 3 points, got {n}"
            ));
        }
        // Newell's normal: twice the vector area, exact for a flat polygon
        let mut normal = [0.0; 3];
        for i in 0..n {
            let (a, b) = (points[i], points[(i + 1) % n]);
            let c = cross(a, b);
            (0..3).for_each(|k| normal[k] += c[k]);
        }
        let size = points
            .iter()
            .flat_map(|a| points.iter().map(move |b| dot(sub(*a, *b), sub(*a, *b))))
            .fold(0.0, f64::max)
            .sqrt();
        let twice_area = dot(normal, normal).sqrt();
        if !(twice_area > 1e-12 * size * size) {
            return Err("its points enclose no area (they lie on one line)".into());
        }
        normal = normal.map(|c| c / twice_area);
        let mut origin = [0.0; 3];
        for p in points {
            (0..3).for_each(|k| origin[k] += p[k] / n as f64);
        }
        for (q, p) in points.iter().enumerate() {
            let off = dot(sub(*p, origin), normal).abs();
            if off > 1e-9 * size {
                return Err(format!(
                    "point {q} lies {off:e} m off the plane of the others: a 3D crack is a flat polygon"
                ));
            }
        }
        // u along the first edge (not degenerate: some edge is not, and
        // the first that is not is taken)
        let edge = (0..n)
            .map(|i| sub(points[(i + 1) % n], points[i]))
            .find(|e| dot(*e, *e) > 0.0)
            .unwrap_or([1.0, 0.0, 0.0]);
        let along = sub(edge, normal.map(|c| c * dot(edge, normal)));
        let u = along.map(|c| c / dot(along, along).sqrt());
        let v = cross(normal, u);
        let outline = points
            .iter()
            .map(|p| {
                let w = sub(*p, origin);
                [dot(w, u), dot(w, v)]
            })
            .collect();
        Ok(CrackFace {
            points: points.to_vec(),
            origin,
            normal,
            u,
            v,
            outline,
        })
    }

    /// Distance from `p` to the face (its inside and its edges), m.
    pub fn distance(&self, p: [f64; 3]) -> f64 {
        let w = sub(p, self.origin);
        if super::point_in_polygon(&self.outline, [dot(w, self.u), dot(w, self.v)]) {
            return dot(w, self.normal).abs();
        }
        let n = self.points.len();
        (0..n)
            .map(|i| super::distance_to_segment(p, self.points[i], self.points[(i + 1) % n]))
            .fold(f64::INFINITY, f64::min)
    }
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` particles per direction in cells of `h` over the unit cube.
    fn lattice(h: f64, per_dir: usize) -> Lattice<3> {
        let cells = (1.0 / h).round() as usize;
        Lattice {
            origin: [0.0; 3],
            h,
            cells: [cells; 3],
            per_dir,
        }
    }

    /// The seeded volume (count × spacing³) and the number seeded.
    fn seeded(shape: &ShapeSpec, holes: &[ShapeSpec], lat: &Lattice<3>) -> (f64, usize) {
        let mut n = 0usize;
        seed_3d(shape, holes, lat, |p| {
            assert!(contains_3d(shape, p) && !holes.iter().any(|h| contains_3d(h, p)));
            n += 1;
        });
        (n as f64 * lat.spacing().powi(3), n)
    }

    /// The seeded volume (count × s³) of a shape is its volume to within
    /// the particles its surface cuts: each lattice row (along x) that
    /// crosses the surface gains or loses a fraction of a particle at each
    /// crossing. For a surface not aligned with the lattice those
    /// fractions are as if uniform on (−½, ½), independent from row to
    /// row: variance 1/12 particle² per crossing, and at most A/s²
    /// crossings (the surface's area over a row's cross-section), so the
    /// standard deviation of the seeded volume is at most s³·√(A/(12 s²))
    /// = s²·√(A/12). The tolerance is 5 of those. A face parallel to a
    /// lattice plane breaks that independence (all its crossings are off
    /// alike): such faces are put between lattice planes, where they are
    /// seeded exactly. (The worst case, every
    /// crossing off by the most, is A·s√3/2: twenty to a hundred times
    /// larger, too loose to notice a volume off by a few per cent.)
    fn assert_volume(shape: &ShapeSpec, holes: &[ShapeSpec], area: f64, exact: f64) {
        let lat = lattice(0.02, 2);
        let s = lat.spacing();
        let (v, n) = seeded(shape, holes, &lat);
        let tolerance = 5.0 * s * s * (area / 12.0).sqrt();
        assert!(n > 1000, "{n} particles");
        assert!(
            (v - exact).abs() <= tolerance,
            "{}: seeded {v:e} m³ vs exact {exact:e} m³, off by {:e}, tolerance {tolerance:e}",
            shape.type_name(),
            (v - exact).abs()
        );
    }

    #[test]
    fn a_sphere_seeds_its_volume() {
        let r = 0.3;
        let sphere = ShapeSpec::Sphere {
            center: [0.5, 0.5, 0.5].into(),
            radius: r,
        };
        let exact = volume(&sphere);
        assert!((exact - 4.0 / 3.0 * std::f64::consts::PI * 0.027).abs() < 1e-15);
        // 5σ is 0.14 % of the volume here
        assert_volume(&sphere, &[], 4.0 * std::f64::consts::PI * r * r, exact);
    }

    #[test]
    fn a_skew_cylinder_seeds_its_volume() {
        let (r, start, end) = (0.12, [0.2, 0.25, 0.3], [0.8, 0.7, 0.65]);
        let cyl = ShapeSpec::Cylinder {
            start: start.into(),
            end: end.into(),
            radius: r,
        };
        let len = sub(end, start).map(|x| x * x).iter().sum::<f64>().sqrt();
        let exact = std::f64::consts::PI * r * r * len;
        assert!((volume(&cyl) - exact).abs() < 1e-15);
        let area = 2.0 * std::f64::consts::PI * r * (r + len);
        assert_volume(&cyl, &[], area, exact);
        // its box holds it: no particle is missed by the bounds
        let b = bounds_3d(&cyl);
        let mut all = 0usize;
        let lat = lattice(0.02, 2);
        let s = lat.spacing();
        for k in 0..50 * 50 * 50 * 8 {
            let (i, j, l) = (k % 100, (k / 100) % 100, k / 10000);
            let p = [i, j, l].map(|c| (c as f64 + 0.5) * s);
            if contains_3d(&cyl, p) {
                all += 1;
                assert!((0..3).all(|d| p[d] >= b.min[d] && p[d] <= b.max[d]));
            }
        }
        assert_eq!(seeded(&cyl, &[], &lat).1, all);
    }

    #[test]
    fn a_prism_seeds_its_volume() {
        // an L-shaped (concave) outline
        let vertices = vec![
            [0.1, 0.1],
            [0.9, 0.1],
            [0.9, 0.4],
            [0.45, 0.4],
            [0.45, 0.9],
            [0.1, 0.9],
        ];
        let (z_min, z_max) = (0.21, 0.77);
        let prism = ShapeSpec::Prism {
            vertices: vertices.clone(),
            z_min,
            z_max,
        };
        let outline = 0.8 * 0.3 + 0.35 * 0.5;
        let exact = outline * (z_max - z_min);
        assert!((volume(&prism) - exact).abs() < 1e-15);
        // its faces all lie between lattice planes (the vertices on
        // multiples of 0.05, z_min and z_max of 0.01, the particles at
        // 0.005 + 0.01 k): it is seeded exactly
        let (v, _) = seeded(&prism, &[], &lattice(0.02, 2));
        assert!((v - exact).abs() < 1e-12 * exact, "{v} vs {exact}");
        // a triangle off the lattice, z_min and z_max on lattice planes:
        // the seeded volume is the triangle's seeded area times the height,
        // and every z layer repeats the same rows. So the tolerance is
        // assert_volume's reasoning in the plane: P/s row crossings of the
        // outline, each off by a uniform fraction, σ_area = s²·√(P/(12 s)),
        // times the height, 5σ of it
        let tri = [[0.13, 0.17], [0.86, 0.29], [0.35, 0.81]];
        let (z_min, z_max) = (0.12, 0.88);
        let skew = ShapeSpec::Prism {
            vertices: tri.to_vec(),
            z_min,
            z_max,
        };
        let top = 0.5 * polygon_area2(&tri).abs();
        let height = z_max - z_min;
        let side =
            |a: [f64; 2], b: [f64; 2]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
        let perimeter = side(tri[0], tri[1]) + side(tri[1], tri[2]) + side(tri[2], tri[0]);
        let exact = top * height;
        assert!((volume(&skew) - exact).abs() < 1e-15);
        let lat = lattice(0.02, 2);
        let s = lat.spacing();
        let (v, _) = seeded(&skew, &[], &lat);
        let tolerance = 5.0 * s * s * (perimeter / (12.0 * s)).sqrt() * height;
        assert!(
            (v - exact).abs() <= tolerance,
            "seeded {v:e} vs {exact:e}, tolerance {tolerance:e}"
        );
        // the row-wise test agrees with the point test
        let lat = lattice(0.02, 2);
        let mut n = 0;
        seed_3d(&prism, &[], &lat, |p| {
            assert!(contains_3d(&prism, p));
            n += 1;
        });
        assert_eq!(n, {
            let s = lat.spacing();
            (0..100usize.pow(3))
                .filter(|k| {
                    let p = [k % 100, (k / 100) % 100, k / 10000].map(|c| (c as f64 + 0.5) * s);
                    contains_3d(&prism, p)
                })
                .count()
        });
    }

    #[test]
    fn a_box_with_a_spherical_hole_seeds_the_difference() {
        let block = ShapeSpec::Box {
            min: [0.1, 0.2, 0.1].into(),
            max: [0.9, 0.8, 0.7].into(),
        };
        let hole = ShapeSpec::Sphere {
            center: [0.5, 0.5, 0.4].into(),
            radius: 0.2,
        };
        // grid-aligned faces: the box itself is seeded exactly
        let lat = lattice(0.02, 2);
        let (v, _) = seeded(&block, &[], &lat);
        assert!((v - volume(&block)).abs() < 1e-12, "{v}");
        let exact = volume(&block) - volume(&hole);
        // only the hole's surface is cut by the lattice
        assert_volume(
            &block,
            std::slice::from_ref(&hole),
            4.0 * std::f64::consts::PI * 0.04,
            exact,
        );
        assert_eq!(
            seed_cost_3d(&block, &[hole], &lat),
            // 40 x 30 x 30 cells, 2 per direction: 80 x 60 x 60 points, twice
            2.0 * 80.0 * 60.0 * 60.0
        );
    }

    /// A crack face's distance: to the plane over the face, to the nearest
    /// edge (or corner) beside it, for a triangle and an L-shaped
    /// (non-convex) hexagon turned out of every coordinate plane.
    #[test]
    fn a_crack_face_measures_distance_to_its_inside_and_its_edges() {
        // a frame: the face's plane is spanned by e1, e2; n = e1 × e2
        let (a, b) = (0.3f64, 0.7f64);
        let e1 = [a.cos() * b.cos(), a.sin() * b.cos(), b.sin()];
        let e2 = [-a.sin(), a.cos(), 0.0];
        let n = cross(e1, e2);
        let c = [0.5, 0.4, 0.6];
        let at = |u: f64, v: f64, w: f64| -> [f64; 3] {
            std::array::from_fn(|k| c[k] + u * e1[k] + v * e2[k] + w * n[k])
        };
        // the L: the unit square less its upper right quarter
        let l = [
            (0.0, 0.0),
            (1.0, 0.0),
            (1.0, 0.5),
            (0.5, 0.5),
            (0.5, 1.0),
            (0.0, 1.0),
        ];
        let pts: Vec<[f64; 3]> = l.iter().map(|&(u, v)| at(u, v, 0.0)).collect();
        let face = CrackFace::new(&pts).unwrap();
        let close = |x: f64, y: f64| assert!((x - y).abs() < 1e-12, "{x} vs {y}");
        close(face.distance(at(0.25, 0.25, 0.1)), 0.1);
        close(face.distance(at(0.25, 0.75, -0.2)), 0.2);
        // over the notch (not on the face): to its nearest edge
        close(face.distance(at(0.75, 0.75, 0.0)), 0.25);
        close(face.distance(at(0.6, 0.9, 0.0)), 0.1);
        close(face.distance(at(0.75, 0.6, 0.0)), 0.1);
        close(face.distance(at(0.75, 0.6, 0.3)), 0.1f64.hypot(0.3));
        // beyond an outer corner
        close(face.distance(at(-0.3, -0.4, 0.0)), 0.5);
        // the same points in reverse order make the same face
        let rev: Vec<[f64; 3]> = pts.iter().rev().copied().collect();
        let face2 = CrackFace::new(&rev).unwrap();
        close(face2.distance(at(0.25, 0.25, 0.1)), 0.1);
        close(face2.distance(at(0.75, 0.6, 0.3)), 0.1f64.hypot(0.3));
        // a triangle
        let tri =
            CrackFace::new(&[at(0.0, 0.0, 0.0), at(1.0, 0.0, 0.0), at(0.0, 1.0, 0.0)]).unwrap();
        close(tri.distance(at(0.2, 0.2, -0.05)), 0.05);
        close(tri.distance(at(1.0, 1.0, 0.0)), 0.5f64.sqrt());
    }

    #[test]
    fn a_crack_face_refuses_points_that_make_no_flat_polygon() {
        let few = CrackFace::new(&[[0.0; 3], [1.0, 0.0, 0.0]]).unwrap_err();
        assert!(few.contains("at least 3 points, got 2"), "{few}");
        let line = CrackFace::new(&[[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]).unwrap_err();
        assert!(line.contains("no area"), "{line}");
        let bent = CrackFace::new(&[[0.0; 3], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 1e-3]])
            .unwrap_err();
        assert!(
            bent.contains("off the plane") && bent.contains("point "),
            "{bent}"
        );
    }
}
