//! The Cholesky factor of the phase-field matrix made in two halves at once
//! (`ordering = "dissection"` in `[phase_field_solver]`).
//!
//! faer's sparse numeric factorization is a sequential loop over the
//! supernodes, and its own parallel mode only reaches the dense kernels
//! inside one supernode (`docs/phase-field-performance.md`). The grid gives
//! a better cut: [`super::ordering::nested_dissection`] splits the unknowns
//! into two sides G₀, G₁ that no entry of K joins and the slab T between
//! them. Ordered G₀, G₁, T,
//!
//! ```text
//!     K = | K₀₀  0    K₀ₜ |        L = | L₀₀  0    0   |
//!         | 0    K₁₁  K₁ₜ |            | 0    L₁₁  0   |
//!         | Kₜ₀  Kₜ₁  Kₜₜ |            | Lₜ₀  Lₜ₁  Lₜₜ |
//! ```
//!
//! and the columns of each side depend on that side alone (the block
//! elimination of George & Liu, 1981, ch. 6). So each side is factorized on
//! its own thread, as the principal submatrix `[[Kₖₖ, Kₖₜ], [Kₜₖ, Kₜₜ]]`
//! by faer's supernodal Cholesky: its first columns are exactly Lₖₖ and
//! Lₜₖ, and its last block is the factor L'ₖ of Kₜₜ − Lₜₖ Lₜₖᵀ. The slab's
//! Schur complement is then
//! `S = Kₜₜ − Lₜ₀Lₜ₀ᵀ − Lₜ₁Lₜ₁ᵀ = L'₀L'₀ᵀ + L'₁L'₁ᵀ − Kₜₜ`, a dense matrix
//! of the slab's size, and Lₜₜ its dense Cholesky factor. The factor is
//! laid out as faer's supernodal one, so `trisolve` solves with it as
//! before, its two groups now the two sides.
//!
//! The work of each side is about half of one factorization of the whole,
//! so on two threads a factorization takes about half the time; the
//! arithmetic does not depend on the thread count (one thread does the
//! same two halves in turn). The slab of a 2D grid is two or three node
//! lines: [`MAX_SLAB`] keeps the dense part small (a 3D grid's slab is a
//! plane, which falls back to one factorization).

use super::ordering::nested_dissection;
use super::system::PhaseFieldError;
use super::trisolve::SupernodalSolve;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch};
use faer::linalg::matmul::triangular::{matmul, BlockStructure};
use faer::perm::PermRef;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymbolicCholeskyRaw,
    SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Accum, Mat, Par, Side};
use rayon::prelude::*;

/// The largest slab factorized as a dense matrix (its Schur complement
/// costs about MAX_SLAB³/3 multiply-adds, 0.36e9 at 1024).
pub const MAX_SLAB: usize = 1024;

/// One side's principal submatrix, its factor and the slab's block of it.
struct Half {
    /// The submatrix's lower triangle (the side's unknowns, then the
    /// slab's), and where each of its values lies in K's values.
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    src: Vec<usize>,
    values: Vec<f64>,
    sym: SymbolicCholesky<usize>,
    l: Vec<f64>,
    mem: MemBuffer,
    /// The prefix of `l` that belongs to the side's own columns.
    kept: usize,
    /// The slab's block of the factor: (position in `l`, position in the
    /// dense slab matrix), lower triangle.
    slab: Vec<(usize, usize)>,
    /// L'ₖ dense, and L'ₖL'ₖᵀ (lower triangles).
    dense: Mat<f64>,
    product: Mat<f64>,
}

/// A factorization in two halves and a slab; see the module's text.
pub struct SplitCholesky {
    sides: [Half; 2],
    /// Where the second side and the slab begin in the elimination order.
    cut: [usize; 2],
    /// K's slab block: (position in K's values, position in the dense
    /// slab matrix), lower triangle.
    k_slab: Vec<(usize, usize)>,
    /// S, then its factor Lₜₜ (lower triangle), column-major.
    top: Mat<f64>,
    top_mem: MemBuffer,
    /// The solves' structure of the whole factor.
    solve: SupernodalSolve,
}

impl SplitCholesky {
    /// The analysis: the dissection, the two sides' submatrices and their
    /// symbolic factorizations, and the whole factor's structure. None
    /// when the unknowns have no cut or the slab is over [`MAX_SLAB`] (then
    /// one factorization of the whole is made instead). `col_ptr`,
    /// `row_idx` are K's lower triangle over `dofs` (grid nodes, `nodes`
    /// per axis) whose couplings reach `reach` nodes along each axis.
    pub fn analyse<const D: usize>(
        col_ptr: &[usize],
        row_idx: &[usize],
        dofs: &[u32],
        nodes: [usize; D],
        reach: usize,
    ) -> Result<Option<Self>, PhaseFieldError> {
        let n = dofs.len();
        let (perm, cut) = nested_dissection(dofs, nodes, reach);
        let Some([a, b]) = cut else { return Ok(None) };
        let t = n - b;
        if t == 0 || t > MAX_SLAB {
            return Ok(None);
        }
        let mut pos = vec![0usize; n];
        for (i, &p) in perm.iter().enumerate() {
            pos[p] = i;
        }
        let mut k_slab = Vec::new();
        for c in 0..n {
            for q in col_ptr[c]..col_ptr[c + 1] {
                let (pc, pr) = (pos[c], pos[row_idx[q]]);
                if (pc < a && (a..b).contains(&pr)) || (pr < a && (a..b).contains(&pc)) {
                    return Err(PhaseFieldError::Solver(format!(
                        "nested dissection: unknowns {c} and {} couple across the cut",
                        row_idx[q]
                    )));
                }
                if pc >= b && pr >= b {
                    let (i, j) = (pc.max(pr) - b, pc.min(pr) - b);
                    k_slab.push((q, i + t * j));
                }
            }
        }
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        // the whole factor's structure: the sides' own supernodes, then the slab
        let mut begin = Vec::new();
        let mut val = vec![0usize];
        let mut row_ptr = Vec::new();
        let mut rows = Vec::new();
        let mut sides = Vec::with_capacity(2);
        for (off, own) in [(0, a), (a, b - a)] {
            let local = |p: usize| -> Option<usize> {
                if p >= b {
                    Some(own + p - b)
                } else if (off..off + own).contains(&p) {
                    Some(p - off)
                } else {
                    None
                }
            };
            let mut entries = Vec::new();
            for c in 0..n {
                for q in col_ptr[c]..col_ptr[c + 1] {
                    if let (Some(lc), Some(lr)) = (local(pos[c]), local(pos[row_idx[q]])) {
                        entries.push((lc.min(lr), lc.max(lr), q));
                    }
                }
            }
            entries.sort_unstable();
            let m = own + t;
            let mut cp = vec![0usize; m + 1];
            for &(c, _, _) in &entries {
                cp[c + 1] += 1;
            }
            for c in 0..m {
                cp[c + 1] += cp[c];
            }
            let ri: Vec<usize> = entries.iter().map(|e| e.1).collect();
            let src: Vec<usize> = entries.iter().map(|e| e.2).collect();
            let pattern = SymbolicSparseColMatRef::new_checked(m, m, &cp, None, &ri);
            // the order is already the dissection's; not `Identity`, which
            // faer 0.24 reads as an upper triangle whatever the side
            let id: Vec<usize> = (0..m).collect();
            let ordering = SymmetricOrdering::Custom(PermRef::new_checked(&id, &id, m));
            let sym = factorize_symbolic_cholesky(pattern, Side::Lower, ordering, params)
                .map_err(|e| PhaseFieldError::Solver(format!("symbolic analysis: {e:?}")))?;
            let req = sym.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default());
            let mem = MemBuffer::try_new(req)
                .map_err(|e| PhaseFieldError::Solver(format!("workspace: {e:?}")))?;
            let SymbolicCholeskyRaw::Supernodal(s) = sym.raw() else {
                return Err(PhaseFieldError::Solver(
                    "the analysis is not supernodal".into(),
                ));
            };
            let global = |r: usize| if r < own { off + r } else { b + r - own };
            let sb = s.supernode_begin();
            let sv = s.col_ptr_for_val();
            let sr = s.col_ptr_for_row_idx();
            let srows = s.row_idx();
            let mut kept = 0;
            let mut slab = Vec::new();
            for sn in 0..s.n_supernodes() {
                let c0 = sb[sn];
                let c1 = if sn + 1 < s.n_supernodes() {
                    sb[sn + 1]
                } else {
                    m
                };
                let w = c1 - c0;
                let height = (sv[sn + 1] - sv[sn]) / w;
                let pat = &srows[sr[sn]..sr[sn] + height - w];
                let row = |rr: usize| if rr < w { c0 + rr } else { pat[rr - w] };
                // the side's own columns of this supernode
                let mine = c1.min(own).saturating_sub(c0);
                if mine > 0 {
                    begin.push(off + c0);
                    row_ptr.push(rows.len());
                    rows.extend((mine..height).map(|rr| global(row(rr))));
                    val.push(val[val.len() - 1] + mine * height);
                    kept = sv[sn] + mine * height;
                }
                // the slab's columns: L'ₖ
                for i in mine..w {
                    let j = c0 + i - own;
                    for rr in i..height {
                        slab.push((sv[sn] + i * height + rr, row(rr) - own + t * j));
                    }
                }
            }
            sides.push(Half {
                col_ptr: cp,
                row_idx: ri,
                values: vec![0.0; src.len()],
                src,
                l: Vec::new(),
                sym,
                mem,
                kept,
                slab,
                dense: Mat::zeros(t, t),
                product: Mat::zeros(t, t),
            });
        }
        begin.push(b);
        row_ptr.push(rows.len());
        val.push(val[val.len() - 1] + t * t);
        begin.push(n);
        let mut inv = vec![0usize; n];
        for (i, &p) in perm.iter().enumerate() {
            inv[p] = i;
        }
        let solve = SupernodalSolve::from_parts(perm, inv, begin, val, row_ptr, rows);
        let top_mem = MemBuffer::try_new(cholesky_in_place_scratch::<f64>(
            t,
            Par::Seq,
            Default::default(),
        ))
        .map_err(|e| PhaseFieldError::Solver(format!("workspace: {e:?}")))?;
        let [s0, s1]: [Half; 2] = sides
            .try_into()
            .map_err(|_| PhaseFieldError::Solver("two sides".into()))?;
        Ok(Some(SplitCholesky {
            sides: [s0, s1],
            cut: [a, b],
            k_slab,
            top: Mat::zeros(t, t),
            top_mem,
            solve,
        }))
    }

    /// The structure the triangular solves use.
    pub fn solve(&self) -> &SupernodalSolve {
        &self.solve
    }

    /// Unknowns in the first side, the second and the slab.
    pub fn sizes(&self) -> [usize; 3] {
        let [a, b] = self.cut;
        [a, b - a, self.solve.len() - b]
    }

    /// The numeric factorization of K (`values` on the analysed pattern):
    /// the two sides at once, then the slab.
    pub fn factorize(&mut self, values: &[f64]) -> Result<(), PhaseFieldError> {
        let [s0, s1] = &mut self.sides;
        let (r0, r1) = rayon::join(|| s0.factorize(values), || s1.factorize(values));
        r0?;
        r1?;
        let t = self.top.nrows();
        let (p0, p1) = (&self.sides[0].product, &self.sides[1].product);
        for j in 0..t {
            for i in j..t {
                self.top[(i, j)] = p0[(i, j)] + p1[(i, j)];
            }
        }
        for &(q, at) in &self.k_slab {
            let (i, j) = (at % t, at / t);
            self.top[(i, j)] -= values[q];
        }
        cholesky_in_place(
            self.top.as_mut(),
            Default::default(),
            Par::Seq,
            MemStack::new(&mut self.top_mem),
            Default::default(),
        )
        .map_err(|e| PhaseFieldError::NotPositiveDefinite(format!("the slab: {e:?}")))?;
        Ok(())
    }

    /// The whole factor's values, each through `f`, into `dst` (laid out
    /// for [`Self::solve`]). In chunks on rayon's threads; each value on
    /// its own, so the bits do not depend on the thread count.
    pub fn write<T: Copy + Default + Send + Sync>(
        &self,
        dst: &mut Vec<T>,
        f: impl Fn(f64) -> T + Sync,
    ) {
        const CHUNK: usize = 1 << 16;
        let [k0, k1] = [self.sides[0].kept, self.sides[1].kept];
        let t = self.top.nrows();
        dst.resize(k0 + k1 + t * t, T::default());
        let (d0, rest) = dst.split_at_mut(k0);
        let (d1, d2) = rest.split_at_mut(k1);
        let copy = |d: &mut [T], s: &[f64]| {
            d.par_chunks_mut(CHUNK)
                .zip(s.par_chunks(CHUNK))
                .for_each(|(d, s)| d.iter_mut().zip(s).for_each(|(d, &s)| *d = f(s)));
        };
        copy(d0, &self.sides[0].l[..k0]);
        copy(d1, &self.sides[1].l[..k1]);
        for j in 0..t {
            for i in 0..t {
                d2[i + t * j] = f(if i >= j { self.top[(i, j)] } else { 0.0 });
            }
        }
    }

    /// Length of the whole factor's values.
    pub fn len_val(&self) -> usize {
        self.solve.len_val()
    }
}

impl Half {
    /// The side's submatrix factorized, and L'ₖL'ₖᵀ.
    fn factorize(&mut self, values: &[f64]) -> Result<(), PhaseFieldError> {
        for (v, &q) in self.values.iter_mut().zip(&self.src) {
            *v = values[q];
        }
        let m = self.col_ptr.len() - 1;
        let pattern =
            SymbolicSparseColMatRef::new_checked(m, m, &self.col_ptr, None, &self.row_idx);
        self.l.resize(self.sym.len_val(), 0.0);
        self.sym
            .factorize_numeric_llt::<f64>(
                &mut self.l,
                SparseColMatRef::new(pattern, &self.values),
                Side::Lower,
                Default::default(),
                Par::Seq,
                MemStack::new(&mut self.mem),
                Default::default(),
            )
            .map_err(|e| PhaseFieldError::NotPositiveDefinite(format!("{e:?}")))?;
        let t = self.dense.nrows();
        for j in 0..t {
            for i in 0..t {
                self.dense[(i, j)] = 0.0;
            }
        }
        for &(at, to) in &self.slab {
            self.dense[(to % t, to / t)] = self.l[at];
        }
        matmul(
            self.product.as_mut(),
            BlockStructure::TriangularLower,
            Accum::Replace,
            self.dense.as_ref(),
            BlockStructure::TriangularLower,
            self.dense.transpose(),
            BlockStructure::TriangularUpper,
            1.0,
            Par::Seq,
        );
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid's mass-plus-diffusion matrix: every pair of nodes within
    /// `w` along both axes coupled, diagonally dominant.
    fn grid_matrix(nodes: [usize; 2], w: usize) -> (Vec<u32>, Vec<usize>, Vec<usize>, Vec<f64>) {
        let dofs: Vec<u32> = (0..(nodes[0] * nodes[1]) as u32).collect();
        let (mut col_ptr, mut row_idx, mut values) = (vec![0], Vec::new(), Vec::new());
        for c in 0..dofs.len() {
            let (cx, cy) = (c % nodes[0], c / nodes[0]);
            for r in c..dofs.len() {
                let (rx, ry) = (r % nodes[0], r / nodes[0]);
                if rx.abs_diff(cx) <= w && ry.abs_diff(cy) <= w {
                    row_idx.push(r);
                    let off = ((r * 7 + c * 3) % 11) as f64 / 11.0;
                    values.push(if r == c { 60.0 } else { -0.5 - 0.5 * off });
                }
            }
            col_ptr.push(row_idx.len());
        }
        (dofs, col_ptr, row_idx, values)
    }

    #[test]
    fn the_two_halves_and_the_slab_solve_the_system() {
        let nodes = [31, 12];
        let w = 2;
        let (dofs, col_ptr, row_idx, values) = grid_matrix(nodes, w);
        let n = dofs.len();
        let mut split = SplitCholesky::analyse(&col_ptr, &row_idx, &dofs, nodes, w)
            .unwrap()
            .expect("a cut");
        let [a, b, t] = split.sizes();
        assert_eq!(a + b + t, n);
        split.factorize(&values).unwrap();
        let mut l = Vec::new();
        split.write(&mut l, |v| v);
        // K x for a known x, then the solve
        let x: Vec<f64> = (0..n).map(|i| ((i * 13) % 7) as f64 - 3.0).collect();
        let mut y = vec![0.0; n];
        for c in 0..n {
            for q in col_ptr[c]..col_ptr[c + 1] {
                let r = row_idx[q];
                y[r] += values[q] * x[c];
                if r != c {
                    y[c] += values[q] * x[r];
                }
            }
        }
        let mut scratch = Default::default();
        split.solve().solve(&l, &mut y, &mut scratch);
        for (i, (u, v)) in y.iter().zip(&x).enumerate() {
            assert!((u - v).abs() < 1e-12, "unknown {i}: {u} against {v}");
        }
    }
}
