//! Geometric multigrid for the phase-field system `K c = F` (eq. 57 of
//! Kakouris & Triantafyllou): one V-cycle preconditions conjugate gradients, in place of the
//! Cholesky factor of [`super::system`]'s "pcg" method.
//!
//! Why: the factor must be made again whenever the active-node set changes
//! (a free body whose edges cross the grid, fragments that fly apart) and
//! whenever the history has grown enough that the old factor no longer
//! preconditions well; at h = l₀/4 on `p3_sphere_beam.toml` that was 0.8 s of a ~2 s step
//! (`docs/phase-field.md`). A multigrid hierarchy costs a few operator
//! products to build and nothing symbolic.
//!
//! The levels. The grid's kernels are refinable: a kernel on a grid of
//! spacing 2h is a fixed combination of kernels of spacing h
//! ([`Kernel::REFINE`], the B-splines' two-scale relation), so the coarse
//! space is a subspace of the fine one and the prolongation P takes coarse
//! control values to fine ones with those weights along each axis (tensor
//! product). The coarse operator is Galerkin's `Pᵀ K P`: the same particle
//! quadrature of eq. 57 with the coarse functions, no reassembly. Coarsening
//! stops at [`COARSEST`] unknowns, solved by a dense Cholesky factor.
//!
//! Smoothing: a Chebyshev polynomial of degree [`DEGREE`] in D⁻¹K (D the
//! diagonal) before and after the coarse correction, the same polynomial
//! both times, so the V-cycle is a symmetric operator as CG needs. Its
//! interval is [λ/20, λ] with λ a bound on the largest eigenvalue of D⁻¹K,
//! so the smoother damps every mode and the V-cycle is positive definite
//! for any positive definite coarse levels. On the finest level the
//! operator is always the system's current matrix (refreshed per solve);
//! the coarse levels are those of the matrix the hierarchy was built from,
//! which only makes the preconditioner older, not wrong: CG still takes the
//! residual of the current system to its tolerance.
//!
//! Where it does poorly: broken material. Where the reaction term of eq. 57
//! outweighs the diffusion (4l₀H/Ḡc ≫ 4(l₀/h)²), K is a B-spline mass matrix
//! row for row. Scaled by its diagonal, that matrix's smallest eigenvalues
//! (1/56 of its largest for quadratic B-splines in 2D) belong to the highest
//! frequencies. No coarse level holds them and the smoother's interval does
//! not reach them, so CG needs three times the iterations. The system then
//! hands over to the factor (`PhaseFieldSystem`'s multigrid solve;
//! `docs/phase-field-performance.md`, "Multigrid", with a model in
//! `docs/scripts/mg_reaction_model.py`).
//!
//! Everything is summed in a fixed order, so a run repeats bit for bit with
//! any number of threads.

#[cfg(doc)]
use crate::grid::shape::Kernel;
use rayon::prelude::*;

/// Unknowns at or below which a level is solved directly.
pub const COARSEST: usize = 400;
/// Degree of the Chebyshev smoother. On `p3_sphere_beam.toml` at h = l₀/4 (from one
/// checkpoint, 30 steps each) degrees 2, 3 and 4 cost the same per step
/// (8.5, 6.1 and 5.1 iterations per solve); 3 needs a quarter fewer
/// iterations than 2 on the 4th-order and cubic systems of the tests.
pub const DEGREE: usize = 3;
/// The Chebyshev interval's lower end, as a fraction of its upper end.
const LOWER: f64 = 0.05;
/// Rows below which an operator product runs serially.
const PAR_ROWS: usize = 16_384;

/// A sparse matrix in compressed rows, both triangles.
#[derive(Debug, Clone, Default)]
struct Csr {
    cols: usize,
    ptr: Vec<usize>,
    col: Vec<u32>,
    val: Vec<f64>,
}

impl Csr {
    fn rows(&self) -> usize {
        self.ptr.len() - 1
    }

    #[inline]
    fn row(&self, i: usize) -> (&[u32], &[f64]) {
        let r = self.ptr[i]..self.ptr[i + 1];
        (&self.col[r.clone()], &self.val[r])
    }

    #[inline]
    fn row_dot(&self, i: usize, x: &[f64]) -> f64 {
        let (c, v) = self.row(i);
        c.iter()
            .zip(v)
            .fold(0.0, |s, (&j, &a)| s + a * x[j as usize])
    }

    /// y = A x, or y += A x with `add`, row by row (in parallel for large
    /// matrices; the same sums).
    fn product(&self, x: &[f64], y: &mut [f64], add: bool) {
        let row = |(i, yi): (usize, &mut f64)| {
            let v = self.row_dot(i, x);
            *yi = if add { *yi + v } else { v };
        };
        if y.len() >= PAR_ROWS {
            y.par_iter_mut()
                .enumerate()
                .with_min_len(2048)
                .for_each(row);
        } else {
            y.iter_mut().enumerate().for_each(row);
        }
    }

    /// y = A x.
    fn mul(&self, x: &[f64], y: &mut [f64]) {
        self.product(x, y, false);
    }

    /// y += A x.
    fn mul_add(&self, x: &[f64], y: &mut [f64]) {
        self.product(x, y, true);
    }

    fn transpose(&self) -> Csr {
        let mut count = vec![0usize; self.cols + 1];
        for &c in &self.col {
            count[c as usize + 1] += 1;
        }
        for k in 0..self.cols {
            count[k + 1] += count[k];
        }
        let ptr = count.clone();
        let mut col = vec![0u32; self.col.len()];
        let mut val = vec![0.0; self.val.len()];
        for i in 0..self.rows() {
            let (c, v) = self.row(i);
            for (&j, &a) in c.iter().zip(v) {
                let at = &mut count[j as usize];
                col[*at] = i as u32;
                val[*at] = a;
                *at += 1;
            }
        }
        Csr {
            cols: self.rows(),
            ptr,
            col,
            val,
        }
    }

    /// self · b, row by row (Gustavson), in parallel blocks of rows.
    fn matmul(&self, b: &Csr) -> Csr {
        const BLOCK: usize = 1024;
        let blocks: Vec<(Vec<usize>, Vec<u32>, Vec<f64>)> = (0..self.rows().div_ceil(BLOCK))
            .into_par_iter()
            .map_init(
                || (vec![0.0; b.cols], vec![u32::MAX; b.cols]),
                |(acc, mark), blk| {
                    let (mut len, mut col, mut val) = (Vec::new(), Vec::new(), Vec::new());
                    for i in blk * BLOCK..((blk + 1) * BLOCK).min(self.rows()) {
                        let start = col.len();
                        let (ci, vi) = self.row(i);
                        for (&k, &a) in ci.iter().zip(vi) {
                            let (cj, vj) = b.row(k as usize);
                            for (&j, &w) in cj.iter().zip(vj) {
                                let j = j as usize;
                                if mark[j] != i as u32 {
                                    mark[j] = i as u32;
                                    acc[j] = 0.0;
                                    col.push(j as u32);
                                }
                                acc[j] += a * w;
                            }
                        }
                        val.extend(col[start..].iter().map(|&j| acc[j as usize]));
                        len.push(col.len() - start);
                    }
                    (len, col, val)
                },
            )
            .collect();
        let mut out = Csr {
            cols: b.cols,
            ptr: vec![0],
            col: Vec::new(),
            val: Vec::new(),
        };
        for (len, col, val) in blocks {
            for l in len {
                out.ptr.push(out.ptr.last().copied().unwrap_or(0) + l);
            }
            out.col.extend(col);
            out.val.extend(val);
        }
        out
    }

    /// Position of each row's diagonal entry (usize::MAX where it has none).
    fn diagonal_positions(&self) -> Vec<usize> {
        (0..self.rows())
            .map(|i| {
                (self.ptr[i]..self.ptr[i + 1])
                    .find(|&k| self.col[k] as usize == i)
                    .unwrap_or(usize::MAX)
            })
            .collect()
    }
}

/// One level of the hierarchy.
#[derive(Debug, Default)]
struct Level {
    a: Csr,
    diag: Vec<usize>,
    inv_diag: Vec<f64>,
    /// √(1/a_ii), for the bound ([`Level::refresh`] computes both).
    sqrt_inv_diag: Vec<f64>,
    /// Upper end of the Chebyshev interval, ≥ λmax(D⁻¹A) ([`Level::bound`]).
    lambda: f64,
    /// Prolongation from the next coarser level to this one (rows: this
    /// level's unknowns) and its transpose, the restriction.
    p: Csr,
    r: Csr,
    /// Right-hand side, iterate, residual and Chebyshev direction.
    b: Vec<f64>,
    x: Vec<f64>,
    res: Vec<f64>,
    d: Vec<f64>,
}

impl Level {
    fn new(a: Csr) -> Result<Level, String> {
        let n = a.rows();
        let diag = a.diagonal_positions();
        let mut lv = Level {
            a,
            diag,
            b: vec![0.0; n],
            x: vec![0.0; n],
            res: vec![0.0; n],
            d: vec![0.0; n],
            ..Default::default()
        };
        lv.refresh()?;
        Ok(lv)
    }

    /// The diagonal's inverse and the smoother's bound, from the present
    /// values of `a`.
    fn refresh(&mut self) -> Result<(), String> {
        self.inv_diag.clear();
        self.sqrt_inv_diag.clear();
        for (i, &k) in self.diag.iter().enumerate() {
            let d = if k == usize::MAX { 0.0 } else { self.a.val[k] };
            if !(d > 0.0 && d.is_finite()) {
                return Err(format!(
                    "multigrid: diagonal entry {i} is {d}, not positive"
                ));
            }
            self.inv_diag.push(1.0 / d);
            self.sqrt_inv_diag.push(1.0 / d.sqrt());
        }
        self.bound();
        Ok(())
    }

    /// The smoother's interval's upper end: Gershgorin's bound on the
    /// eigenvalues of the symmetric D^{-1/2} A D^{-1/2}, which has those of
    /// D⁻¹A, `max_i Σ_j |a_ij| / √(a_ii a_jj)`. A bound, not an estimate: with
    /// it the smoother damps every mode, so the V-cycle is positive definite
    /// whatever the (possibly older) coarse levels hold. (The row-wise bound
    /// `Σ_j |a_ij| / a_ii` is useless here: a node at the fringe of the
    /// particles' supports has a tiny diagonal and gave 10⁴; the power
    /// method's estimate, 1.4× below this one, missed the top of the
    /// spectrum on a disk's fringe and left the V-cycle indefinite.)
    fn bound(&mut self) {
        let (a, d) = (&self.a, &self.sqrt_inv_diag);
        self.lambda = (0..a.rows())
            .map(|i| {
                let (c, v) = a.row(i);
                c.iter()
                    .zip(v)
                    .fold(0.0, |s, (&j, x)| s + x.abs() * d[j as usize])
                    * d[i]
            })
            .fold(0.0, f64::max);
    }

    /// `DEGREE` steps of Chebyshev iteration on `A x = b` from the present
    /// `x` (Saad, *Iterative Methods for Sparse Linear Systems*, 2nd ed.,
    /// Algorithm 12.1, preconditioned by D⁻¹); `zero` says x = 0, which
    /// saves the first product.
    fn smooth(&mut self, zero: bool) {
        let n = self.a.rows();
        let (upper, lower) = (self.lambda, LOWER * self.lambda);
        let (theta, delta) = ((upper + lower) / 2.0, (upper - lower) / 2.0);
        let sigma = theta / delta;
        let mut rho = 1.0 / sigma;
        if zero {
            self.res.copy_from_slice(&self.b);
        } else {
            self.residual();
        }
        for i in 0..n {
            self.d[i] = self.inv_diag[i] * self.res[i] / theta;
        }
        for k in 1..=DEGREE {
            for i in 0..n {
                self.x[i] += self.d[i];
            }
            if k == DEGREE {
                break;
            }
            self.residual();
            let rho_new = 1.0 / (2.0 * sigma - rho);
            let (s, t) = (rho_new * rho, 2.0 * rho_new / delta);
            for i in 0..n {
                self.d[i] = s * self.d[i] + t * self.inv_diag[i] * self.res[i];
            }
            rho = rho_new;
        }
    }

    /// res = b − A x.
    fn residual(&mut self) {
        self.a.mul(&self.x, &mut self.res);
        for (r, b) in self.res.iter_mut().zip(&self.b) {
            *r = b - *r;
        }
    }
}

/// A dense Cholesky factor (the coarsest level), lower triangle by rows.
#[derive(Debug, Default)]
struct Dense {
    n: usize,
    l: Vec<f64>,
}

impl Dense {
    fn factor(a: &Csr) -> Result<Dense, String> {
        let n = a.rows();
        let mut l = vec![0.0; n * n];
        for i in 0..n {
            let (c, v) = a.row(i);
            for (&j, &x) in c.iter().zip(v) {
                l[i * n + j as usize] = x;
            }
        }
        for j in 0..n {
            let mut d = l[j * n + j];
            for k in 0..j {
                d -= l[j * n + k] * l[j * n + k];
            }
            if !(d > 0.0) {
                return Err(format!(
                    "multigrid: the coarsest matrix ({n} unknowns) is not positive definite"
                ));
            }
            let d = d.sqrt();
            l[j * n + j] = d;
            for i in j + 1..n {
                let mut s = l[i * n + j];
                for k in 0..j {
                    s -= l[i * n + k] * l[j * n + k];
                }
                l[i * n + j] = s / d;
            }
        }
        for i in 0..n {
            for j in i + 1..n {
                l[i * n + j] = 0.0;
            }
        }
        Ok(Dense { n, l })
    }

    /// x ← A⁻¹ x.
    fn solve(&self, x: &mut [f64]) {
        let (n, l) = (self.n, &self.l);
        for i in 0..n {
            let s = (0..i).fold(x[i], |s, k| s - l[i * n + k] * x[k]);
            x[i] = s / l[i * n + i];
        }
        for i in (0..n).rev() {
            let s = (i + 1..n).fold(x[i], |s, k| s - l[k * n + i] * x[k]);
            x[i] = s / l[i * n + i];
        }
    }
}

/// The hierarchy for one phase-field system.
#[derive(Debug, Default)]
pub struct Multigrid {
    levels: Vec<Level>,
    coarsest: Dense,
    /// For each entry of the system's lower triangle, its two places in the
    /// finest level's rows (the same place twice on the diagonal).
    map: Vec<[u32; 2]>,
}

impl Multigrid {
    /// Builds the hierarchy for the system whose unknowns are the grid
    /// nodes `dofs` (ascending; node = i + nodes[0]·(j + nodes[1]·k)) of a
    /// `D`-dimensional grid and whose matrix is the lower triangle
    /// `col_ptr`/`row_idx`/`values` (compressed columns), with the kernel's
    /// two-scale `mask` ([`Kernel::REFINE`]).
    pub fn build<const D: usize>(
        mask: &[f64],
        nodes: [usize; D],
        dofs: &[u32],
        col_ptr: &[usize],
        row_idx: &[usize],
        values: &[f64],
    ) -> Result<Multigrid, String> {
        if mask.len() < 2 {
            return Err(format!(
                "multigrid: a two-scale mask of {} weights",
                mask.len()
            ));
        }
        let n = dofs.len();
        // the finest level's rows from the lower triangle
        let mut count = vec![0usize; n + 1];
        for c in 0..n {
            for &r in &row_idx[col_ptr[c]..col_ptr[c + 1]] {
                count[r + 1] += 1;
                if r != c {
                    count[c + 1] += 1;
                }
            }
        }
        for i in 0..n {
            count[i + 1] += count[i];
        }
        let ptr = count.clone();
        let nnz = ptr[n];
        let (mut col, mut val) = (vec![0u32; nnz], vec![0.0; nnz]);
        let mut map = Vec::with_capacity(row_idx.len());
        for c in 0..n {
            for k in col_ptr[c]..col_ptr[c + 1] {
                let r = row_idx[k];
                let at_r = count[r];
                col[at_r] = c as u32;
                val[at_r] = values[k];
                count[r] += 1;
                let at_c = if r == c {
                    at_r
                } else {
                    let at = count[c];
                    col[at] = r as u32;
                    val[at] = values[k];
                    count[c] += 1;
                    at
                };
                map.push([at_r as u32, at_c as u32]);
            }
        }
        let fine = Csr {
            cols: n,
            ptr,
            col,
            val,
        };
        // coarsen
        let mut levels = Vec::new();
        let mut a = fine;
        let mut dims = nodes;
        let mut at: Vec<[u32; D]> = dofs
            .iter()
            .map(|&d| {
                let mut rest = d as usize;
                std::array::from_fn(|k| {
                    let c = rest % nodes[k];
                    rest /= nodes[k];
                    c as u32
                })
            })
            .collect();
        loop {
            let rows = a.rows();
            if rows <= COARSEST {
                break;
            }
            let Some((p, coarse_at, coarse_dims)) = prolongation(mask, dims, &at) else {
                break;
            };
            if p.cols * 10 > rows * 7 {
                break; // coarsening stalls (a body a node or two thick)
            }
            let r = p.transpose();
            let coarse = r.matmul(&a.matmul(&p));
            let mut lv = Level::new(a)?;
            lv.p = p;
            lv.r = r;
            levels.push(lv);
            a = coarse;
            at = coarse_at;
            dims = coarse_dims;
        }
        if a.rows() > 4 * COARSEST {
            return Err(format!(
                "multigrid: coarsening stopped at {} unknowns",
                a.rows()
            ));
        }
        let coarsest = Dense::factor(&a)?;
        levels.push(Level::new(a)?);
        Ok(Multigrid {
            levels,
            coarsest,
            map,
        })
    }

    /// Unknowns per level, finest first.
    pub fn sizes(&self) -> Vec<usize> {
        self.levels.iter().map(|l| l.a.rows()).collect()
    }

    /// Takes the system's present matrix (same pattern as at the build) as
    /// the finest level's operator.
    pub fn refresh(&mut self, values: &[f64]) -> Result<(), String> {
        let Some(fine) = self.levels.first_mut() else {
            return Ok(());
        };
        for (&[a, b], &v) in self.map.iter().zip(values) {
            fine.a.val[a as usize] = v;
            fine.a.val[b as usize] = v;
        }
        fine.refresh()?;
        Ok(())
    }

    /// y = K x with the finest level's operator (the system's matrix).
    pub fn multiply(&self, x: &[f64], y: &mut [f64]) {
        if let Some(fine) = self.levels.first() {
            fine.a.mul(x, y);
        }
    }

    /// z ← M⁻¹ z: one V-cycle from zero on the residual `z`.
    pub fn apply(&mut self, z: &mut [f64]) {
        if self.levels.is_empty() {
            return;
        }
        self.levels[0].b.copy_from_slice(z);
        self.cycle(0);
        z.copy_from_slice(&self.levels[0].x);
    }

    fn cycle(&mut self, l: usize) {
        if l + 1 == self.levels.len() {
            let lv = &mut self.levels[l];
            lv.x.copy_from_slice(&lv.b);
            self.coarsest.solve(&mut lv.x);
            return;
        }
        {
            let lv = &mut self.levels[l];
            lv.x.fill(0.0);
            lv.smooth(true);
            lv.residual();
        }
        let (fine, coarse) = self.levels.split_at_mut(l + 1);
        let (lv, next) = (&mut fine[l], &mut coarse[0]);
        lv.r.mul(&lv.res, &mut next.b);
        self.cycle(l + 1);
        let (fine, coarse) = self.levels.split_at_mut(l + 1);
        let (lv, next) = (&mut fine[l], &coarse[0]);
        lv.p.mul_add(&next.x, &mut lv.x);
        lv.smooth(false);
    }
}

/// The prolongation from the coarse grid to the unknowns at grid positions
/// `at` (on a grid of `dims` nodes), with the two-scale `mask` along each
/// axis: fine node i takes coarse node I with weight mask[i + m − 1 − 2I],
/// and the tensor product of the axes' weights, multiplied from x on (the
/// coarse nodes visited with x fastest). Coarse nodes that carry less than
/// a quarter of a full column (the fine nodes under them mostly outside the
/// body) are left out; they would only add near-dependent columns. Returns
/// P, the coarse unknowns' positions and the coarse grid's size, or None
/// if no coarse node is kept.
fn prolongation<const D: usize>(
    mask: &[f64],
    dims: [usize; D],
    at: &[[u32; D]],
) -> Option<(Csr, Vec<[u32; D]>, [usize; D])> {
    let m = mask.len();
    let cdims: [usize; D] = std::array::from_fn(|k| (dims[k] + m - 2) / 2 + 1);
    // the coarse parents of fine index i along one axis: at most
    // MAX_PARENTS, (coarse index, weight)
    const MAX_PARENTS: usize = 4;
    let parents = |i: u32| {
        let i = i as usize;
        let mut out = [(0usize, 0.0); MAX_PARENTS];
        let mut n = 0;
        for c in i.div_ceil(2)..=(i + m - 1) / 2 {
            out[n] = (c, mask[i + m - 1 - 2 * c]);
            n += 1;
        }
        (out, n)
    };
    // every (coarse node, weight) of the tensor product for fine position
    // `p`, the last axis outermost
    let each = |p: &[u32; D], f: &mut dyn FnMut(usize, f64)| {
        let axes: [([(usize, f64); MAX_PARENTS], usize); D] =
            std::array::from_fn(|k| parents(p[k]));
        let total: usize = axes.iter().map(|a| a.1).product();
        for t in 0..total {
            let (mut rest, mut node, mut stride) = (t, 0, 1);
            let mut w = 1.0;
            for (k, (list, n)) in axes.iter().enumerate() {
                let (c, wk) = list[rest % n];
                rest /= n;
                node += c * stride;
                stride *= cdims[k];
                w = if k == 0 { wk } else { w * wk };
            }
            f(node, w);
        }
    };
    let full: f64 = mask.iter().sum::<f64>().powi(D as i32);
    let mut weight = vec![0.0; cdims.iter().product()];
    for p in at {
        each(p, &mut |node, w| weight[node] += w);
    }
    let mut index = vec![u32::MAX; weight.len()];
    let mut coarse_at = Vec::new();
    for (k, &w) in weight.iter().enumerate() {
        if w >= 0.25 * full {
            index[k] = coarse_at.len() as u32;
            let mut rest = k;
            coarse_at.push(std::array::from_fn(|a| {
                let c = rest % cdims[a];
                rest /= cdims[a];
                c as u32
            }));
        }
    }
    if coarse_at.is_empty() {
        return None;
    }
    let mut p = Csr {
        cols: coarse_at.len(),
        ptr: vec![0],
        col: Vec::new(),
        val: Vec::new(),
    };
    for q in at {
        each(q, &mut |node, w| {
            let c = index[node];
            if c != u32::MAX {
                p.col.push(c);
                p.val.push(w);
            }
        });
        p.ptr.push(p.col.len());
    }
    Some((p, coarse_at, cdims))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::shape::{CubicBspline, Kernel, Linear, QuadraticBspline};

    /// The mask is the kernels' two-scale relation: with fine node i at
    /// x = i (h = 1), the coarse function of node I, the kernel stretched by
    /// 2 about X_I = 2I − (m − 1)/2, equals Σ_k mask[k]·N(x − i_k) over the
    /// fine nodes i_k = 2I + k − (m − 1), at every x.
    fn two_scale<K: Kernel>() {
        let m = K::REFINE.len() as isize;
        for s in 0..400 {
            let x = -3.0 + s as f64 * 0.0371;
            for big in -1..4isize {
                let centre = 2.0 * big as f64 - (m as f64 - 1.0) / 2.0;
                let coarse = value_centred::<K>((x - centre) / 2.0);
                let fine: f64 = (0..m)
                    .map(|k| {
                        K::REFINE[k as usize]
                            * value_centred::<K>(x - (2 * big + k - (m - 1)) as f64)
                    })
                    .sum();
                assert!(
                    (coarse - fine).abs() < 1e-12,
                    "x = {x}, I = {big}: coarse {coarse}, masked fine {fine}"
                );
            }
        }
    }

    /// The kernel's function of node 0 at position t (in cells).
    fn value_centred<K: Kernel>(t: f64) -> f64 {
        let w = K::eval(t, 0.0, 0.0);
        let k = -w.base;
        if (0..K::N as isize).contains(&k) {
            w.w[k as usize]
        } else {
            0.0
        }
    }

    /// A 5-point Laplacian plus a small reaction term on the nodes of a
    /// disk in a 96 × 96 grid (zero outside), as the lower triangle in
    /// compressed columns: the dofs, col_ptr, row_idx, values.
    fn disk_system() -> (Vec<u32>, Vec<usize>, Vec<usize>, Vec<f64>) {
        let n = 96usize;
        let inside = |i: usize, j: usize| (i as f64 - 47.3).hypot(j as f64 - 48.1) < 43.0;
        let dofs: Vec<u32> = (0..n * n)
            .filter(|&k| inside(k % n, k / n))
            .map(|k| k as u32)
            .collect();
        let index = |i: usize, j: usize| dofs.binary_search(&((i + j * n) as u32)).ok();
        let (mut col_ptr, mut row_idx, mut values) = (vec![0], Vec::new(), Vec::new());
        for &d in &dofs {
            let (i, j) = (d as usize % n, d as usize / n);
            let me = index(i, j).unwrap();
            row_idx.push(me);
            values.push(4.1);
            for (a, b) in [(i + 1, j), (i, j + 1)] {
                if let Some(k) = index(a, b) {
                    row_idx.push(k);
                    values.push(-1.0);
                }
            }
            col_ptr.push(row_idx.len());
        }
        (dofs, col_ptr, row_idx, values)
    }

    /// The V-cycle is a symmetric positive definite operator (what CG
    /// needs of a preconditioner), and it preconditions well: CG takes the
    /// residual down by 10¹⁰ in a few iterations.
    #[test]
    fn the_v_cycle_is_symmetric_positive_definite_and_converges() {
        let (dofs, col_ptr, row_idx, values) = disk_system();
        let mut mg = Multigrid::build(
            &[0.5, 1.0, 0.5],
            [96, 96],
            &dofs,
            &col_ptr,
            &row_idx,
            &values,
        )
        .unwrap();
        let n = dofs.len();
        assert!(mg.sizes().len() >= 3, "levels {:?}", mg.sizes());
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let vector = |seed: usize| {
            (0..n)
                .map(|i| ((i * 7919 + seed * 104729) % 1000) as f64 / 500.0 - 1.0)
                .collect::<Vec<f64>>()
        };
        let (u, v) = (vector(1), vector(2));
        let (mut mu, mut mv) = (u.clone(), v.clone());
        mg.apply(&mut mu);
        mg.apply(&mut mv);
        let (a, b) = (dot(&u, &mv), dot(&v, &mu));
        assert!(
            (a - b).abs() <= 1e-12 * a.abs().max(b.abs()),
            "uᵀMv = {a}, vᵀMu = {b}"
        );
        assert!(dot(&u, &mu) > 0.0 && dot(&v, &mv) > 0.0);
        // CG with the V-cycle on A x = 1
        let b: Vec<f64> = vec![1.0; n];
        let (mut x, mut r, mut ap) = (vec![0.0; n], b.clone(), vec![0.0; n]);
        let mut z = r.clone();
        mg.apply(&mut z);
        let mut p = z.clone();
        let mut rz = dot(&r, &z);
        let mut iterations = 0;
        while dot(&r, &r).sqrt() > 1e-10 * dot(&b, &b).sqrt() {
            iterations += 1;
            assert!(
                iterations <= 12,
                "CG with the V-cycle did not converge in 12 iterations"
            );
            mg.multiply(&p, &mut ap);
            let alpha = rz / dot(&p, &ap);
            for i in 0..n {
                x[i] += alpha * p[i];
                r[i] -= alpha * ap[i];
            }
            z.copy_from_slice(&r);
            mg.apply(&mut z);
            let rz_new = dot(&r, &z);
            for i in 0..n {
                p[i] = z[i] + rz_new / rz * p[i];
            }
            rz = rz_new;
        }
        println!("levels {:?}: {iterations} iterations", mg.sizes());
    }

    #[test]
    fn the_masks_are_the_kernels_two_scale_relations() {
        two_scale::<Linear>();
        two_scale::<QuadraticBspline>();
        two_scale::<CubicBspline>();
    }
}
