//! Stabilized conforming nodal integration (SCNI; Chen et al. 2001) of the
//! reproducing-kernel approximation, as the damage particle method uses it
//! (Wei & Chen, eqs. 23–26 and 34–40), in 2D and 3D.
//!
//! Each particle L owns a smoothing cell Ω_L (Wei & Chen: its Voronoi
//! cell). The particles sit on a regular lattice, so the Voronoi cells
//! are the lattice's squares (cubes) about them, clipped to the body:
//! boxes, which is what [`Scni::build`] takes. The smoothed gradient of
//! eq. 38,
//!
//! b̃_iI(x_L) = (1/V_L) ∮_{Γ_L} N_I n_i dΓ,
//!
//! is integrated with one point per face, as the paper does: the face
//! centres, so that on a box lo..hi
//! b̃_iI(x_L) = (N_I(face centre at hi_i) − N_I(face centre at lo_i)) / (hi_i − lo_i).
//! Neighbouring cells share a face and its point, so the integration
//! constraint Σ_L b̃_I(x_L) V_L = ∮_Γ N_I n dΓ holds to round-off and a
//! linear displacement field gives its exact constant strain in every
//! cell (the patch test; linear reproduction of eq. 22 makes the one-point
//! rule exact for it).
//!
//! From b̃ come the smoothed strain (eqs. 26, 36), the internal force
//! (eq. 39) and, with the values N_I(x_J) at the particles, the
//! displacement at a particle. All three are fixed sparse tables built
//! once in the reference configuration (the method is total Lagrangian
//! with small strains): a step is two sparse products, with no
//! neighbour search and no allocation.
//!
//! One-point SCNI on a regular lattice has a known weakness (Puso, Chen,
//! Zywicz & Elmer 2008): the checkerboard mode d_I = (−1)^(i+j) gives zero
//! smoothed strain in every cell whose face points see a symmetric
//! neighbourhood, so only the boundary resists it. docs/dpm.md records
//! it; a stabilization is for a later slice.

use super::crack::Cuts;
use super::rk::{shape_values_cut, RkError};
use crate::neighbours::Neighbours;
use crate::tensor::{check_voigt, sym_times, voigt};
use rayon::prelude::*;

/// The SCNI tables of a set of particles.
#[derive(Debug, Clone, Default)]
pub struct Scni<const D: usize> {
    /// `grad[start[L]..start[L+1]]` are b̃_I(x_L) for the particles
    /// `node[..]` of the same range.
    start: Vec<u32>,
    node: Vec<u32>,
    grad: Vec<[f64; D]>,
    /// The same entries by I: `by_node_entry[by_node_start[I]..]` index
    /// `grad` (ascending L, the cell in `by_node_cell`), for the internal
    /// force as a gather.
    by_node_start: Vec<u32>,
    by_node_entry: Vec<u32>,
    by_node_cell: Vec<u32>,
    /// `value[vstart[J]..vstart[J+1]]` are N_I(x_J) for `vnode[..]`.
    vstart: Vec<u32>,
    vnode: Vec<u32>,
    value: Vec<f64>,
    /// The measure of each smoothing cell: its area (2D) or volume (3D).
    pub cell: Vec<f64>,
}

/// Where the tables could not be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("particle {particle}: {source}")]
pub struct ScniError {
    /// The particle whose cell (a face point or its centre) has the
    /// singular moment matrix.
    pub particle: u32,
    #[source]
    pub source: RkError,
}

/// One particle's rows, built in parallel and joined in particle order.
#[derive(Default)]
struct Rows<const D: usize> {
    node: Vec<u32>,
    grad: Vec<[f64; D]>,
    vnode: Vec<u32>,
    value: Vec<f64>,
}

impl<const D: usize> Scni<D> {
    /// Builds the tables of particles at `x` (reference positions), each
    /// with its smoothing cell, the box `lo[L]..hi[L]` (which holds x_L),
    /// and its support radius `radius`, singular kernels where `singular`
    /// says ([`super::rk::shape_values`]; empty: none); particles see one another's shape
    /// functions only within the same `key` (a body). The cells must tile
    /// each body (neighbouring cells share whole faces). The same tables
    /// for any thread count.
    pub fn build(
        x: &[[f64; D]],
        lo: &[[f64; D]],
        hi: &[[f64; D]],
        radius: &[f64],
        singular: &[bool],
        key: &[u16],
    ) -> Result<Scni<D>, ScniError> {
        Scni::build_cut(&Cells {
            x,
            lo,
            hi,
            radius,
            singular,
            key,
            cuts: &Cuts::none(),
        })
    }

    /// [`Scni::build`] of [`Cells`] with pre-existing cracks in the
    /// bodies (`key`): the shape functions are diffracted about them
    /// ([`super::crack`]), and a face point on a crack is taken from its
    /// own cell's side.
    pub fn build_cut(cells: &Cells<'_, D>) -> Result<Scni<D>, ScniError> {
        let Cells {
            x,
            lo,
            hi,
            radius,
            singular,
            key,
            cuts,
        } = *cells;
        let n = x.len();
        let cracked = !cuts.is_empty();
        let lists = cells.candidates();
        let rows: Vec<Result<Rows<D>, ScniError>> = (0..n)
            .into_par_iter()
            .map_init(Vec::new, |vals, l| {
                let cand = lists.of(l);
                vals.clear();
                vals.resize(cand.len(), 0.0);
                let mut row = Rows::<D>::default();
                let mut grad = vec![[0.0; D]; cand.len()];
                let err = |source| ScniError {
                    particle: l as u32,
                    source,
                };
                // the face centres: the cell's centre moved to each face;
                // b̃_a += ± N_I(x_f) |f| / V = ± N_I(x_f) / (hi_a − lo_a)
                for a in 0..D {
                    let width = hi[l][a] - lo[l][a];
                    for (side, far) in [(-1.0, false), (1.0, true)] {
                        cells.face_values((l, a, far), cand, vals).map_err(err)?;
                        for (g, &v) in grad.iter_mut().zip(vals.iter()) {
                            g[a] += side * v / width;
                        }
                    }
                }
                for (k, g) in grad.iter().enumerate() {
                    if g.iter().any(|&c| c != 0.0) {
                        row.node.push(cand[k]);
                        row.grad.push(*g);
                    }
                }
                let cut = cracked.then_some((cuts, key, x[l]));
                shape_values_cut(x[l], cand, x, radius, singular, cut, radius[l], vals)
                    .map_err(err)?;
                for (k, &v) in vals.iter().enumerate() {
                    if v != 0.0 {
                        row.vnode.push(cand[k]);
                        row.value.push(v);
                    }
                }
                Ok(row)
            })
            .collect();
        let mut t = Scni::<D> {
            start: vec![0],
            vstart: vec![0],
            cell: (0..n)
                .map(|l| (0..D).map(|d| hi[l][d] - lo[l][d]).product())
                .collect(),
            ..Default::default()
        };
        for r in rows {
            let r = r?;
            t.node.extend_from_slice(&r.node);
            t.grad.extend_from_slice(&r.grad);
            t.start.push(t.node.len() as u32);
            t.vnode.extend_from_slice(&r.vnode);
            t.value.extend_from_slice(&r.value);
            t.vstart.push(t.vnode.len() as u32);
        }
        // the transpose, entries in ascending L (counting sort by node)
        let mut count = vec![0u32; n + 1];
        for &i in &t.node {
            count[i as usize + 1] += 1;
        }
        for i in 0..n {
            count[i + 1] += count[i];
        }
        let mut cursor = count.clone();
        t.by_node_entry = vec![0; t.node.len()];
        t.by_node_cell = vec![0; t.node.len()];
        for l in 0..n {
            for e in t.start[l] as usize..t.start[l + 1] as usize {
                let i = t.node[e] as usize;
                t.by_node_entry[cursor[i] as usize] = e as u32;
                t.by_node_cell[cursor[i] as usize] = l as u32;
                cursor[i] += 1;
            }
        }
        t.by_node_start = count;
        Ok(t)
    }

    /// The loads of tractions on cell faces, by the one-point rule the
    /// smoothed gradients use: for each face (cell `l`, `axis`, `far`: the
    /// face at `hi` rather than `lo`), the particles I and N_I(x_f)·|f|,
    /// x_f the face's centre and |f| its measure (2D: its length). A
    /// traction t on the face puts N_I(x_f)|f| t on particle I. On the
    /// same points as b̃, a constant stress σ and the tractions σn on the
    /// outline are in equilibrium to round-off (the integration
    /// constraint, Chen et al. 2001: Σ_L b̃_I(x_L) V_L = ∮ N_I n dΓ).
    #[allow(clippy::too_many_arguments)]
    pub fn face_loads(
        cells: &Cells<'_, D>,
        faces: &[(usize, usize, bool)],
    ) -> Result<Vec<Vec<(u32, f64)>>, ScniError> {
        let lists = cells.candidates();
        faces
            .par_iter()
            .map(|&(l, axis, far)| {
                let cand = lists.of(l);
                let mut vals = vec![0.0; cand.len()];
                cells
                    .face_values((l, axis, far), cand, &mut vals)
                    .map_err(|source| ScniError {
                        particle: l as u32,
                        source,
                    })?;
                let measure: f64 = (0..D)
                    .filter(|&d| d != axis)
                    .map(|d| cells.hi[l][d] - cells.lo[l][d])
                    .product();
                Ok(cand
                    .iter()
                    .zip(&vals)
                    .filter(|(_, &v)| v != 0.0)
                    .map(|(&i, &v)| (i, v * measure))
                    .collect())
            })
            .collect()
    }

    /// How many particles the tables are for.
    pub fn len(&self) -> usize {
        self.cell.len()
    }

    pub fn is_empty(&self) -> bool {
        self.cell.is_empty()
    }

    /// The particles I and their b̃_I(x_L) (eq. 38) of cell `l`.
    pub fn gradients(&self, l: usize) -> (&[u32], &[[f64; D]]) {
        let r = self.start[l] as usize..self.start[l + 1] as usize;
        (&self.node[r.clone()], &self.grad[r])
    }

    /// The particles I and their N_I(x_J) at particle `j`.
    pub fn values(&self, j: usize) -> (&[u32], &[f64]) {
        let r = self.vstart[j] as usize..self.vstart[j + 1] as usize;
        (&self.vnode[r.clone()], &self.value[r])
    }

    /// The smoothed strain of each cell (eqs. 26 and 36, tensor shear
    /// components, Voigt order) of the coefficients `d`.
    pub fn strain<const V: usize>(&self, d: &[[f64; D]], out: &mut [[f64; V]]) {
        check_voigt::<D, V>();
        out.par_iter_mut().enumerate().for_each(|(l, e)| {
            let (nodes, grads) = self.gradients(l);
            let mut g = [[0.0; D]; D];
            for (&i, b) in nodes.iter().zip(grads) {
                let di = d[i as usize];
                for p in 0..D {
                    for q in 0..D {
                        g[p][q] += di[p] * b[q];
                    }
                }
            }
            let mut s = [0.0; V];
            for p in 0..D {
                for q in p..D {
                    s[voigt::<D>(p, q)] = 0.5 * (g[p][q] + g[q][p]);
                }
            }
            *e = s;
        });
    }

    /// The internal force of each particle, f_I = Σ_L b̃_I(x_L)·σ_L V_L
    /// (eq. 39, as a vector: B̃ᵀΣ of the paper), for cell stresses
    /// `stress` (Voigt) and cell volumes `vol` (2D: the cell's area times
    /// the thickness). A gather over each particle's cells in ascending
    /// order: the same sums for any thread count.
    pub fn internal_force<const V: usize>(
        &self,
        stress: &[[f64; V]],
        vol: &[f64],
        out: &mut [[f64; D]],
    ) {
        check_voigt::<D, V>();
        out.par_iter_mut().enumerate().for_each(|(i, f)| {
            let r = self.by_node_start[i] as usize..self.by_node_start[i + 1] as usize;
            let mut acc = [0.0; D];
            for (&e, &l) in self.by_node_entry[r.clone()]
                .iter()
                .zip(&self.by_node_cell[r])
            {
                let (e, l) = (e as usize, l as usize);
                let t = sym_times::<D, V>(&stress[l], self.grad[e]);
                for d in 0..D {
                    acc[d] += t[d] * vol[l];
                }
            }
            *f = acc;
        });
    }

    /// The field of coefficients `d` at each particle: Σ_I N_I(x_J) d_I.
    pub fn interpolate(&self, d: &[[f64; D]], out: &mut [[f64; D]]) {
        out.par_iter_mut().enumerate().for_each(|(j, u)| {
            let (nodes, vals) = self.values(j);
            let mut acc = [0.0; D];
            for (&i, &v) in nodes.iter().zip(vals) {
                for k in 0..D {
                    acc[k] += v * d[i as usize][k];
                }
            }
            *u = acc;
        });
    }
}

/// Particles and their smoothing cells, as [`Scni::build_cut`] and
/// [`Scni::face_loads`] take them.
#[derive(Clone, Copy)]
pub struct Cells<'a, const D: usize> {
    /// Reference positions.
    pub x: &'a [[f64; D]],
    /// Each particle's smoothing cell, the box `lo..hi` (which holds its
    /// particle); the cells tile each body.
    pub lo: &'a [[f64; D]],
    pub hi: &'a [[f64; D]],
    /// Support radii.
    pub radius: &'a [f64],
    /// Which particles carry singular kernels (empty: none).
    pub singular: &'a [bool],
    /// Each particle's body: particles see one another's shape functions
    /// only within the same key.
    pub key: &'a [u16],
    /// Pre-existing cracks, diffracting the supports.
    pub cuts: &'a Cuts<D>,
}

impl<const D: usize> Cells<'_, D> {
    /// Each particle's candidates: the particles of its `key` whose
    /// support may reach a point of its smoothing cell (within a_I plus
    /// the farthest corner of any cell), sorted.
    fn candidates(&self) -> Neighbours<D> {
        let (x, lo, hi) = (self.x, self.lo, self.hi);
        let n = x.len();
        let mut min = [f64::INFINITY; D];
        let mut max = [f64::NEG_INFINITY; D];
        for p in x {
            for d in 0..D {
                min[d] = min[d].min(p[d]);
                max[d] = max[d].max(p[d]);
            }
        }
        let a_max = self.radius.iter().cloned().fold(0.0, f64::max);
        let far = (0..n)
            .map(|l| {
                let mut r2 = 0.0;
                for d in 0..D {
                    let e = (x[l][d] - lo[l][d]).max(hi[l][d] - x[l][d]);
                    r2 += e * e;
                }
                r2.sqrt()
            })
            .fold(0.0, f64::max);
        let reach = a_max + far;
        let mut lists = Neighbours::<D>::default();
        if n > 0 {
            for d in 0..D {
                min[d] -= reach;
                max[d] += reach;
            }
            lists.build(x, self.key, reach * (1.0 + 1e-12), min, max);
            lists.sort();
        }
        lists
    }

    /// The shape functions N_I (of the candidates `cand`, into `vals`) at
    /// the centre of a face of cell `l` (`face`: the cell, the axis, the
    /// face at `hi` rather than `lo`); with cracks, judged from a hair
    /// inside the cell.
    fn face_values(
        &self,
        (l, a, far): (usize, usize, bool),
        cand: &[u32],
        vals: &mut [f64],
    ) -> Result<usize, RkError> {
        let (lo, hi, cuts) = (self.lo, self.hi, self.cuts);
        let centre: [f64; D] = std::array::from_fn(|d| 0.5 * (lo[l][d] + hi[l][d]));
        let mut xf = centre;
        xf[a] = if far { hi[l][a] } else { lo[l][a] };
        let width = hi[l][a] - lo[l][a];
        let cut = (!cuts.is_empty()).then(|| {
            (
                cuts,
                self.key,
                cuts.inside(self.key[l], xf, centre, 1e-9 * width),
            )
        });
        shape_values_cut(
            xf,
            cand,
            self.x,
            self.radius,
            self.singular,
            cut,
            self.radius[l],
            vals,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Particles, cells and supports of one body.
    struct Body {
        x: Vec<[f64; 2]>,
        lo: Vec<[f64; 2]>,
        hi: Vec<[f64; 2]>,
        radius: Vec<f64>,
    }

    impl Body {
        fn tables(&self) -> Scni<2> {
            let key = vec![0; self.x.len()];
            Scni::build(&self.x, &self.lo, &self.hi, &self.radius, &[], &key).unwrap()
        }
    }

    /// The plate [0, nx s] × [0, ny s] with a particle on every lattice
    /// vertex (the outline included) and its cell clipped to the plate,
    /// supports 1.5 s (the paper's discretisation).
    fn vertex_plate(nx: usize, ny: usize, s: f64) -> Body {
        let (w, h) = (nx as f64 * s, ny as f64 * s);
        let mut b = Body {
            x: vec![],
            lo: vec![],
            hi: vec![],
            radius: vec![],
        };
        for j in 0..=ny {
            for i in 0..=nx {
                let x = [i as f64 * s, j as f64 * s];
                b.x.push(x);
                b.lo.push([(x[0] - 0.5 * s).max(0.0), (x[1] - 0.5 * s).max(0.0)]);
                b.hi.push([(x[0] + 0.5 * s).min(w), (x[1] + 0.5 * s).min(h)]);
                b.radius.push(1.5 * s);
            }
        }
        b
    }

    /// `nx × ny` particles at the centres of the lattice's squares (the
    /// grid MPM's seeding), minus a 3 × 3 block in the middle when `hole`;
    /// the cells are the squares. Supports of 2 s: at 1.5 s a point of the
    /// outline, half a spacing beyond the outermost particles, is covered
    /// by one row of them only (a singular moment matrix).
    fn centred_plate(nx: usize, ny: usize, s: f64, hole: bool) -> Body {
        let mut b = Body {
            x: vec![],
            lo: vec![],
            hi: vec![],
            radius: vec![],
        };
        for j in 0..ny {
            for i in 0..nx {
                let (ci, cj) = (i as isize - nx as isize / 2, j as isize - ny as isize / 2);
                if hole && ci.abs() <= 1 && cj.abs() <= 1 {
                    continue;
                }
                let x = [(i as f64 + 0.5) * s, (j as f64 + 0.5) * s];
                b.x.push(x);
                b.lo.push([x[0] - 0.5 * s, x[1] - 0.5 * s]);
                b.hi.push([x[0] + 0.5 * s, x[1] + 0.5 * s]);
                b.radius.push(2.0 * s);
            }
        }
        b
    }

    #[test]
    fn a_linear_field_gives_its_exact_strain_in_every_cell() {
        // the patch test: d_I = G x_I + c is reproduced exactly (eq. 22),
        // and the one-point face rule integrates a linear u exactly, at
        // the outline and around a hole as inside
        let s = 2e-3;
        // and particles moved off their vertices inside the same cells
        // (`damage_particle.jitter`), at a support of 2 spacings
        let mut jittered = vertex_plate(12, 9, s);
        super::super::section::jitter_lattice(
            &mut jittered.x,
            [0.0; 2],
            [12.0 * s, 9.0 * s],
            s,
            0.3,
        );
        jittered.radius.iter_mut().for_each(|r| *r = 2.0 * s);
        assert!(jittered
            .x
            .iter()
            .zip(&vertex_plate(12, 9, s).x)
            .any(|(a, b)| a != b));
        for body in [
            vertex_plate(12, 9, s),
            centred_plate(12, 9, s, true),
            jittered,
        ] {
            let t = body.tables();
            let g = [[1e-3, -4e-4], [2.5e-4, 7e-4]];
            let d: Vec<[f64; 2]> = body
                .x
                .iter()
                .map(|x| {
                    [
                        g[0][0] * x[0] + g[0][1] * x[1] + 1e-5,
                        g[1][0] * x[0] + g[1][1] * x[1] - 3e-6,
                    ]
                })
                .collect();
            let mut e = vec![[0.0; 3]; d.len()];
            t.strain(&d, &mut e);
            let want = [g[0][0], g[1][1], 0.5 * (g[0][1] + g[1][0])];
            for (l, e) in e.iter().enumerate() {
                for k in 0..3 {
                    assert!(
                        (e[k] - want[k]).abs() < 1e-12 * 1e-3,
                        "cell {l}: {e:?} vs {want:?}"
                    );
                }
            }
            // and the displacement at a particle is the field there
            let mut u = vec![[0.0; 2]; d.len()];
            t.interpolate(&d, &mut u);
            for (ui, di) in u.iter().zip(&d) {
                assert!((ui[0] - di[0]).abs() < 1e-15 && (ui[1] - di[1]).abs() < 1e-15);
            }
        }
    }

    #[test]
    fn the_paper_support_fails_on_the_outline_of_a_centred_lattice() {
        // why the method puts particles on the outline: with the grid
        // MPM's seeding and the paper's 1.5 spacings, a face point of the
        // outline sees one row of particles
        let mut b = centred_plate(5, 5, 1.0, false);
        b.radius.iter_mut().for_each(|r| *r = 1.5);
        let key = vec![0; b.x.len()];
        let e = Scni::build(&b.x, &b.lo, &b.hi, &b.radius, &[], &key).unwrap_err();
        assert_eq!(e.particle, 0);
        assert_eq!(e.source.covering, 2);
        assert!(
            e.to_string()
                .starts_with("particle 0: the reproducing-kernel moment matrix"),
            "{e}"
        );
    }

    #[test]
    fn a_constant_stress_loads_only_the_outline_and_sums_to_zero() {
        // the integration constraint: Σ_L b̃_I(x_L) V_L = ∮_Γ N_I n dΓ, zero
        // for a particle whose support does not reach the outline; and
        // Σ_I b̃_I(x_L) = 0 in every cell (Σ N_I = 1), so the forces balance
        let (nx, ny) = (14, 10);
        let body = vertex_plate(nx, ny, 1.0);
        let t = body.tables();
        let sigma = vec![[3.0, -1.0, 0.5]; body.x.len()];
        let mut f = vec![[0.0; 2]; body.x.len()];
        t.internal_force(&sigma, &t.cell, &mut f);
        let mut total = [0.0; 2];
        let mut loaded = 0;
        for (p, (x, f)) in body.x.iter().zip(&f).enumerate() {
            total[0] += f[0];
            total[1] += f[1];
            // support 1.5: a particle 1.5 or more inside the outline
            // reaches no point of it
            let inside =
                x[0] >= 1.5 && x[0] <= nx as f64 - 1.5 && x[1] >= 1.5 && x[1] <= ny as f64 - 1.5;
            if inside {
                assert!(
                    f[0].abs() < 1e-13 && f[1].abs() < 1e-13,
                    "particle {p} at {x:?}: {f:?}"
                );
            } else if f[0].abs() + f[1].abs() > 1e-9 {
                loaded += 1;
            }
        }
        assert!(
            total[0].abs() < 1e-12 && total[1].abs() < 1e-12,
            "{total:?}"
        );
        assert!(
            loaded >= 2 * (nx + ny),
            "the outline carries the traction ({loaded} loaded)"
        );
        // the left half's particles: ∮ (Σ_left N_I) σ·n dΓ, which is σ·n
        // over the left edge (Σ_left N_I = 1 there, 0 on the right edge;
        // the top and bottom edges cancel by symmetry): −σ_xx ny in x,
        // −σ_xy ny in y
        let half = |c: usize| -> f64 {
            body.x
                .iter()
                .zip(&f)
                .filter(|(x, _)| x[0] < 0.5 * nx as f64)
                .map(|(_, f)| f[c])
                .sum()
        };
        assert!((half(0) + 3.0 * ny as f64).abs() < 1e-11, "{}", half(0));
        assert!((half(1) + 0.5 * ny as f64).abs() < 1e-11, "{}", half(1));
    }

    #[test]
    fn outline_tractions_balance_a_constant_stress_particle_by_particle() {
        // the traction σn on every outline face, spread by face_loads, is
        // each particle's internal force under the constant stress σ
        let (nx, ny) = (14, 10);
        let body = vertex_plate(nx, ny, 0.5);
        let t = body.tables();
        let n = body.x.len();
        let sigma = [3.0, -1.0, 0.5];
        let mut f = vec![[0.0; 2]; n];
        t.internal_force(&vec![sigma; n], &t.cell, &mut f);
        let (w, h) = (nx as f64 * 0.5, ny as f64 * 0.5);
        let mut faces = Vec::new();
        let mut normals = Vec::new();
        for l in 0..n {
            for (axis, far, edge) in [(0, false, 0.0), (0, true, w), (1, false, 0.0), (1, true, h)]
            {
                let at = if far {
                    body.hi[l][axis]
                } else {
                    body.lo[l][axis]
                };
                if at == edge {
                    faces.push((l, axis, far));
                    let mut nrm = [0.0; 2];
                    nrm[axis] = if far { 1.0 } else { -1.0 };
                    normals.push(nrm);
                }
            }
        }
        assert_eq!(faces.len(), 2 * (nx + 1) + 2 * (ny + 1));
        let key = vec![0; n];
        let cells = Cells {
            x: &body.x,
            lo: &body.lo,
            hi: &body.hi,
            radius: &body.radius,
            singular: &[],
            key: &key,
            cuts: &Cuts::none(),
        };
        let loads = Scni::face_loads(&cells, &faces).unwrap();
        let mut ext = vec![[0.0; 2]; n];
        for (load, nrm) in loads.iter().zip(&normals) {
            // σn with tensor shear
            let tr = [
                sigma[0] * nrm[0] + sigma[2] * nrm[1],
                sigma[2] * nrm[0] + sigma[1] * nrm[1],
            ];
            for &(i, wgt) in load {
                ext[i as usize][0] += wgt * tr[0];
                ext[i as usize][1] += wgt * tr[1];
            }
        }
        for p in 0..n {
            for c in 0..2 {
                assert!(
                    (ext[p][c] - f[p][c]).abs() < 1e-12,
                    "particle {p} at {:?}: external {:?}, internal {:?}",
                    body.x[p],
                    ext[p],
                    f[p]
                );
            }
        }
    }

    #[test]
    fn the_tables_are_the_same_for_any_thread_count() {
        let body = centred_plate(20, 15, 0.5, true);
        let one = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        let a = one.install(|| body.tables());
        let b = body.tables();
        assert_eq!(a.node, b.node);
        assert_eq!(a.grad, b.grad);
        assert_eq!(a.value, b.value);
        let d: Vec<[f64; 2]> = body
            .x
            .iter()
            .map(|x| [(x[0] * 3.1).sin(), (x[1] * 1.7).cos()])
            .collect();
        let mut e = vec![[0.0; 3]; d.len()];
        a.strain(&d, &mut e);
        let mut fa = vec![[0.0; 2]; d.len()];
        let mut fb = fa.clone();
        one.install(|| a.internal_force(&e, &a.cell, &mut fa));
        b.internal_force(&e, &b.cell, &mut fb);
        assert_eq!(fa, fb);
    }

    #[test]
    fn bodies_do_not_share_shape_functions() {
        // two plates that share an edge: a field that jumps between them
        // has each plate's own constant strain (zero), none smeared
        let mut b = vertex_plate(6, 6, 1.0);
        let n1 = b.x.len();
        let right = vertex_plate(6, 6, 1.0);
        let shift = |p: &[f64; 2]| [p[0] + 6.0, p[1]];
        b.x.extend(right.x.iter().map(shift));
        b.lo.extend(right.lo.iter().map(shift));
        b.hi.extend(right.hi.iter().map(shift));
        b.radius.extend(right.radius);
        let n = b.x.len();
        let key: Vec<u16> = (0..n).map(|p| (p >= n1) as u16).collect();
        let t = Scni::build(&b.x, &b.lo, &b.hi, &b.radius, &[], &key).unwrap();
        let d: Vec<[f64; 2]> = (0..n)
            .map(|p| if p < n1 { [0.0, 0.0] } else { [1.0, 0.0] })
            .collect();
        let mut e = vec![[0.0; 3]; n];
        t.strain(&d, &mut e);
        for e in &e {
            assert!(e.iter().all(|c| c.abs() < 1e-13), "{e:?}");
        }
    }

    #[test]
    fn an_edge_crack_keeps_the_patch_test_and_separates_its_faces() {
        // a crack along the cells' faces at y = 4.5 from outside the left
        // edge to a tip at x = 6 (diffraction, Organ et al.): a linear
        // field still gives its exact strain in every cell (the kernels
        // change, the basis does not); the upper half slid rigidly over
        // the lower gives no strain in a cell far from the tip (its faces
        // see one side only) and strain at the tip's cells, where the
        // material is whole
        let mut b = vertex_plate(12, 10, 1.0);
        // at 1.5 the mouth's corner cells see two particles (the crack
        // face lies half a spacing from the rows there)
        b.radius.iter_mut().for_each(|r| *r = 1.6);
        let key = vec![0; b.x.len()];
        let mut cuts = Cuts::none();
        cuts.add(0, &[[-1.0, 4.5], [6.0, 4.5]], |p| p[0] > 0.0);
        let t = Scni::build_cut(&Cells {
            x: &b.x,
            lo: &b.lo,
            hi: &b.hi,
            radius: &b.radius,
            singular: &[],
            key: &key,
            cuts: &cuts,
        })
        .unwrap();
        let g = [[1e-3, -4e-4], [2.5e-4, 7e-4]];
        let d: Vec<[f64; 2]> =
            b.x.iter()
                .map(|x| {
                    [
                        g[0][0] * x[0] + g[0][1] * x[1],
                        g[1][0] * x[0] + g[1][1] * x[1],
                    ]
                })
                .collect();
        let mut e = vec![[0.0; 3]; d.len()];
        t.strain(&d, &mut e);
        let want = [g[0][0], g[1][1], 0.5 * (g[0][1] + g[1][0])];
        for (l, e) in e.iter().enumerate() {
            for k in 0..3 {
                assert!((e[k] - want[k]).abs() < 1e-15, "cell {l}: {e:?}");
            }
        }
        let d: Vec<[f64; 2]> =
            b.x.iter()
                .map(|x| if x[1] > 4.5 { [1.0, 0.0] } else { [0.0, 0.0] })
                .collect();
        t.strain(&d, &mut e);
        for (l, x) in b.x.iter().enumerate() {
            if x[0] <= 2.0 {
                assert!(
                    e[l].iter().all(|c| c.abs() < 1e-12),
                    "cell {l} at {x:?}: {:?}",
                    e[l]
                );
            }
            if x[0] >= 7.0 && (x[1] == 4.0 || x[1] == 5.0) {
                assert!(e[l][2].abs() > 0.1, "cell {l} at {x:?}: {:?}", e[l]);
            }
        }
        // without the crack the slid half strains every cell beside the
        // line
        let whole = b.tables();
        whole.strain(&d, &mut e);
        let at = b.x.iter().position(|x| *x == [1.0, 4.0]).unwrap();
        assert!(e[at][2].abs() > 0.1);
    }

    #[test]
    fn the_3d_tables_pass_the_patch_test() {
        let (n, s) = (4, 0.1);
        let w = n as f64 * s;
        let (mut x, mut lo, mut hi) = (vec![], vec![], vec![]);
        for k in 0..=n {
            for j in 0..=n {
                for i in 0..=n {
                    let p = [i as f64 * s, j as f64 * s, k as f64 * s];
                    x.push(p);
                    lo.push(p.map(|c| (c - 0.5 * s).max(0.0)));
                    hi.push(p.map(|c| (c + 0.5 * s).min(w)));
                }
            }
        }
        let m = x.len();
        let t = Scni::<3>::build(&x, &lo, &hi, &vec![1.5 * s; m], &[], &vec![0; m]).unwrap();
        let total: f64 = t.cell.iter().sum();
        assert!((total - w * w * w).abs() < 1e-15);
        let d: Vec<[f64; 3]> = x
            .iter()
            .map(|p| [2e-3 * p[1], -1e-3 * p[2], 5e-4 * p[0] + 3e-4 * p[2]])
            .collect();
        let mut e = vec![[0.0; 6]; m];
        t.strain(&d, &mut e);
        // Voigt (xx, yy, zz, yz, xz, xy)
        let want = [0.0, 0.0, 3e-4, -0.5e-3, 0.25e-3, 1e-3];
        for e in &e {
            for k in 0..6 {
                assert!((e[k] - want[k]).abs() < 1e-15, "{e:?}");
            }
        }
    }
}
