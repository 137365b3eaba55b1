//! Fragments: connected components of undamaged material (Homel &
//! Herbold 2017, section 3.4: "a connected components algorithm to
//! identify fragments of undamaged material").
//!
//! A particle is undamaged when its damage is below the scene's
//! `output.fragment_damage` (0.5 by default). Two undamaged particles of the
//! same body are connected when they are at most 1.5 particle spacings
//! apart (the body's initial spacing, cell size / particles per direction): a particle
//! links to its eight lattice neighbours, including the diagonal ones at
//! √2 spacings, as long as the material between them has not stretched by
//! more than 6 %, and never across the one-particle-wide band that a
//! crack leaves damaged. A fragment is one connected set.
//!
//! In 3D (`D` = 3) the same rule: a particle links to its 18 face and
//! edge neighbours (1 and √2 spacings; the corner ones at √3 are beyond
//! 1.5), which connect a lattice as the 8 do in 2D, and never across a
//! damaged layer one particle thick. Positions, velocities and centroids
//! have `D` components; the sums over axes go in axis order, so 2D gives
//! the numbers it gave before 3D.
//!
//! Deterministic: union-find over particles in index order, every set
//! rooted at its smallest index, fragments numbered by decreasing
//! particle count and then by smallest particle index. The same particle
//! state gives the same labels, whatever the thread count.

/// Label of a particle that is in no fragment (damaged, or of a material
/// without damage).
pub const NONE: u32 = u32::MAX;

/// Link distance in particle spacings.
const LINK: f64 = 1.5;

/// One fragment.
#[derive(Debug, Clone, PartialEq)]
pub struct Fragment<const D: usize = 2> {
    pub particles: u32,
    /// Σ m_p, kg.
    pub mass: f64,
    /// Σ V_p, m³.
    pub volume: f64,
    /// Mass-weighted mean |v_p|, m/s.
    pub speed: f64,
    /// Centre of mass, m.
    pub centroid: [f64; D],
}

/// Fragments of one instant.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Fragments<const D: usize = 2> {
    /// Per particle: its fragment's number (0 = the largest), or [`NONE`].
    pub label: Vec<u32>,
    /// The fragments, largest first.
    pub list: Vec<Fragment<D>>,
}

/// Reusable work space of [`find`] (cell lists and the union-find forest).
#[derive(Debug, Clone, Default)]
pub struct FragmentFinder {
    parent: Vec<u32>,
    cell_of: Vec<u32>,
    start: Vec<u32>,
    order: Vec<u32>,
}

fn root(parent: &mut [u32], mut p: u32) -> u32 {
    while parent[p as usize] != p {
        let g = parent[parent[p as usize] as usize];
        parent[p as usize] = g; // path halving
        p = g;
    }
    p
}

impl FragmentFinder {
    /// The fragments among the particles for which `eligible(p)` holds
    /// (undamaged material of a damage model). `body` keeps bodies apart;
    /// `spacing[b]` is body b's initial particle spacing, m.
    // one argument per particle array it reads (struct of arrays)
    #[allow(clippy::too_many_arguments)]
    pub fn find<const D: usize>(
        &mut self,
        x: &[[f64; D]],
        v: &[[f64; D]],
        mass: &[f64],
        vol: &[f64],
        spacing: &[f64],
        body: &[u16],
        eligible: impl Fn(usize) -> bool,
    ) -> Fragments<D> {
        let n = x.len();
        let ok: Vec<bool> = (0..n)
            .map(|p| eligible(p) && x[p].iter().all(|c| c.is_finite()))
            .collect();
        let mut lo = [f64::INFINITY; D];
        let mut hi = [f64::NEG_INFINITY; D];
        let mut reach: f64 = 0.0;
        for p in (0..n).filter(|&p| ok[p]) {
            for k in 0..D {
                lo[k] = lo[k].min(x[p][k]);
                hi[k] = hi[k].max(x[p][k]);
            }
            reach = reach.max(LINK * spacing[body[p] as usize]);
        }
        self.parent.clear();
        self.parent.extend(0..n as u32);
        if reach > 0.0 && reach.is_finite() {
            // Cell lists with cells at least the largest link distance wide:
            // every link is between particles of the same or adjacent cells.
            // At most 2^15 cells along an axis and 2^24 in all (a stray
            // particle far away makes the cells larger, not more).
            let mut dims: [usize; D] = std::array::from_fn(|k| {
                (((hi[k] - lo[k]) / reach).floor() as usize + 1).min(1 << 15)
            });
            while dims.iter().product::<usize>() > 1 << 24 {
                dims = dims.map(|c| c.div_ceil(2));
            }
            let cell: [f64; D] =
                std::array::from_fn(|k| ((hi[k] - lo[k]) / dims[k] as f64).max(reach));
            let ncell: usize = dims.iter().product();
            let index =
                |p: usize, k: usize| (((x[p][k] - lo[k]) / cell[k]) as usize).min(dims[k] - 1);
            // the cell of p: x innermost
            let cell_index = |p: usize| {
                let mut c = index(p, D - 1);
                for k in (0..D - 1).rev() {
                    c = c * dims[k] + index(p, k);
                }
                c
            };
            self.cell_of.clear();
            self.cell_of.resize(n, u32::MAX);
            self.start.clear();
            self.start.resize(ncell + 1, 0);
            for p in (0..n).filter(|&p| ok[p]) {
                let c = cell_index(p);
                self.cell_of[p] = c as u32;
                self.start[c + 1] += 1;
            }
            for c in 0..ncell {
                self.start[c + 1] += self.start[c];
            }
            self.order.clear();
            self.order.resize(self.start[ncell] as usize, 0);
            let mut fill = self.start.clone();
            for p in (0..n).filter(|&p| ok[p]) {
                let c = self.cell_of[p] as usize;
                self.order[fill[c] as usize] = p as u32;
                fill[c] += 1;
            }
            for p in 0..n {
                if !ok[p] {
                    continue;
                }
                let mut rest = self.cell_of[p] as usize;
                let mut at = [0usize; D];
                for k in 0..D {
                    at[k] = rest % dims[k];
                    rest /= dims[k];
                }
                // the 3^D cells around p's (fewer at the edges), x innermost
                'around: for off in 0..3usize.pow(D as u32) {
                    let (mut c2, mut stride, mut o) = (0, 1, off);
                    for k in 0..D {
                        let a = at[k] + o % 3;
                        o /= 3;
                        if a == 0 || a > dims[k] {
                            continue 'around;
                        }
                        c2 += (a - 1) * stride;
                        stride *= dims[k];
                    }
                    for &q in &self.order[self.start[c2] as usize..self.start[c2 + 1] as usize] {
                        let q = q as usize;
                        if q <= p || body[q] != body[p] {
                            continue;
                        }
                        let l = LINK * spacing[body[p] as usize];
                        let mut d2 = 0.0;
                        for k in 0..D {
                            let d = x[q][k] - x[p][k];
                            d2 += d * d;
                        }
                        if d2 > l * l {
                            continue;
                        }
                        let (a, b) = (
                            root(&mut self.parent, p as u32),
                            root(&mut self.parent, q as u32),
                        );
                        if a != b {
                            // the smaller index is the root: labels do not
                            // depend on the order links are found in
                            let (r, s) = if a < b { (a, b) } else { (b, a) };
                            self.parent[s as usize] = r;
                        }
                    }
                }
            }
        }
        // Fragments by root, first seen = smallest index (roots are minima).
        let mut slot = vec![NONE; n];
        // per fragment: Σ m|v| and Σ m x
        let mut list: Vec<(u32, Fragment<D>, f64, [f64; D])> = Vec::new();
        let mut label = vec![NONE; n];
        for p in 0..n {
            if !ok[p] {
                continue;
            }
            let r = root(&mut self.parent, p as u32) as usize;
            if slot[r] == NONE {
                slot[r] = list.len() as u32;
                list.push((
                    r as u32,
                    Fragment {
                        particles: 0,
                        mass: 0.0,
                        volume: 0.0,
                        speed: 0.0,
                        centroid: [0.0; D],
                    },
                    0.0,
                    [0.0; D],
                ));
            }
            let k = slot[r] as usize;
            label[p] = k as u32;
            let (_, f, mv, mx) = &mut list[k];
            f.particles += 1;
            f.mass += mass[p];
            f.volume += vol[p];
            *mv += mass[p] * crate::tensor::norm(v[p]);
            for a in 0..D {
                mx[a] += mass[p] * x[p][a];
            }
        }
        for (_, f, mv, mx) in &mut list {
            if f.mass > 0.0 {
                f.speed = *mv / f.mass;
                f.centroid = mx.map(|s| s / f.mass);
            }
        }
        // Largest first; ties by smallest particle index.
        let mut rank: Vec<usize> = (0..list.len()).collect();
        rank.sort_by(|&a, &b| {
            list[b]
                .1
                .particles
                .cmp(&list[a].1.particles)
                .then(list[a].0.cmp(&list[b].0))
        });
        let mut new_of = vec![0u32; list.len()];
        for (new, &old) in rank.iter().enumerate() {
            new_of[old] = new as u32;
        }
        for l in label.iter_mut().filter(|l| **l != NONE) {
            *l = new_of[*l as usize];
        }
        Fragments {
            label,
            list: rank.into_iter().map(|k| list[k].1.clone()).collect(),
        }
    }
}

/// The fragment table of a snapshot from its `fragment` labels and its
/// `mass`, `volume` and `velocity` fields (what [`FragmentFinder::find`]
/// returned, rebuilt from what a snapshot carries, so a remote client can
/// write it too). None if the snapshot has no `fragment` field or is not
/// of dimension `D`.
pub fn from_snapshot<const D: usize>(snap: &super::Snapshot) -> Option<Vec<Fragment<D>>> {
    use super::FieldData;
    if snap.dimension != D {
        return None;
    }
    let field = |name: &str| snap.field(name);
    let Some(FieldData::U32(label)) = field("fragment") else {
        return None;
    };
    let (Some(FieldData::F64(mass)), Some(FieldData::F64(vol)), Some(FieldData::F64(vel))) =
        (field("mass"), field("volume"), field("velocity"))
    else {
        return None;
    };
    let count = label
        .iter()
        .filter(|&&l| l != NONE)
        .map(|&l| l as usize + 1)
        .max()
        .unwrap_or(0);
    let mut list = vec![
        Fragment {
            particles: 0,
            mass: 0.0,
            volume: 0.0,
            speed: 0.0,
            centroid: [0.0; D]
        };
        count
    ];
    for (p, &l) in label.iter().enumerate() {
        if l == NONE
            || p >= mass.len()
            || p >= vol.len()
            || D * (p + 1) > vel.len()
            || p >= snap.positions.len()
        {
            continue;
        }
        let f = &mut list[l as usize];
        let m = mass[p];
        f.particles += 1;
        f.mass += m;
        f.volume += vol[p];
        f.speed += m * vel[D * p..D * (p + 1)]
            .iter()
            .map(|v| v * v)
            .sum::<f64>()
            .sqrt();
        for a in 0..D {
            f.centroid[a] += m * snap.positions[p][a];
        }
    }
    for f in &mut list {
        if f.mass > 0.0 {
            f.speed /= f.mass;
            f.centroid = f.centroid.map(|c| c / f.mass);
        }
    }
    Some(list)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 10 x 4 lattice of spacing 1 cut by a damaged column at i = 4 and
    /// split between two bodies at j = 2: four fragments.
    #[test]
    fn a_damaged_column_and_a_body_boundary_cut_a_lattice_into_four() {
        let (nx, ny) = (10, 4);
        let mut x = Vec::new();
        let mut body = Vec::new();
        let mut damaged = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                x.push([i as f64, j as f64]);
                body.push(if j < 2 { 0 } else { 1 });
                damaged.push(i == 4);
            }
        }
        let n = x.len();
        let v: Vec<[f64; 2]> = (0..n)
            .map(|p| [if x[p][0] < 4.0 { -1.0 } else { 2.0 }, 0.0])
            .collect();
        let ones = vec![1.0; n];
        let f = FragmentFinder::default()
            .find(&x, &v, &ones, &ones, &[1.0, 1.0], &body, |p| !damaged[p]);
        let sizes: Vec<u32> = f.list.iter().map(|f| f.particles).collect();
        assert_eq!(sizes, vec![10, 10, 8, 8]);
        // ties by smallest particle index: the right half of body 0 (index
        // 5) before the right half of body 1 (index 25)
        assert_eq!(f.label[5], 0);
        assert_eq!(f.label[25], 1);
        assert_eq!(f.label[0], 2);
        assert_eq!(f.label[4], NONE);
        assert!((f.list[0].speed - 2.0).abs() < 1e-12 && (f.list[2].speed - 1.0).abs() < 1e-12);
        assert!(
            (f.list[0].centroid[0] - 7.0).abs() < 1e-12
                && (f.list[0].centroid[1] - 0.5).abs() < 1e-12
        );
    }

    /// Diagonal neighbours link, particles two spacings apart do not.
    #[test]
    fn diagonals_link_and_gaps_of_two_spacings_do_not() {
        let x = vec![[0.0, 0.0], [1.0, 1.0], [3.0, 1.0], [3.0, 3.0]];
        let n = x.len();
        let ones = vec![1.0; n];
        let f = FragmentFinder::default().find(
            &x,
            &vec![[0.0; 2]; n],
            &ones,
            &ones,
            &[1.0],
            &vec![0; n],
            |_| true,
        );
        assert_eq!(f.list.len(), 3);
        assert_eq!(f.label, vec![0, 0, 1, 2]);
    }
    /// In 3D: a 5 × 3 × 3 lattice of spacing 1 cut by a damaged layer at
    /// i = 2 is two fragments; particles that touch only across a cube's
    /// corner (√3 spacings) do not link.
    #[test]
    fn a_damaged_layer_cuts_a_3d_lattice_and_corners_do_not_link() {
        let mut x = Vec::new();
        for k in 0..3 {
            for j in 0..3 {
                for i in 0..5 {
                    x.push([i as f64, j as f64, k as f64]);
                }
            }
        }
        let n = x.len();
        let v: Vec<[f64; 3]> = (0..n).map(|p| [0.0, 0.0, x[p][0]]).collect();
        let ones = vec![1.0; n];
        let f = FragmentFinder::default().find(&x, &v, &ones, &ones, &[1.0], &vec![0; n], |p| {
            x[p][0] != 2.0
        });
        let sizes: Vec<u32> = f.list.iter().map(|f| f.particles).collect();
        assert_eq!(sizes, vec![18, 18]);
        assert_eq!(f.label[0], 0);
        assert_eq!(f.label[4], 1);
        assert_eq!(f.label[2], NONE);
        assert!((f.list[1].speed - 3.5).abs() < 1e-12);
        assert!((f.list[0].centroid[2] - 1.0).abs() < 1e-12);
        let corners = [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [2.0, 2.0, 1.0]];
        let g = FragmentFinder::default().find(
            &corners,
            &[[0.0; 3]; 3],
            &[1.0; 3],
            &[1.0; 3],
            &[1.0],
            &[0; 3],
            |_| true,
        );
        assert_eq!(g.label, vec![1, 0, 0]);
    }
}
