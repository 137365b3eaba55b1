//! The two triangular solves with a supernodal Cholesky factor `P A Pᵀ = L Lᵀ`
//! made by faer, x ← A⁻¹ x, on two threads where the elimination tree
//! allows.
//!
//! PCG spends nearly all of an iteration here (docs/phase-field-performance.md:
//! 0.069 s for the two solves against 0.0045 s for the product with K at
//! `p1_plate.toml` size). faer's solve walks the supernodes one by one and calls its
//! general dense kernels for each; most supernodes of a 2D grid's factor
//! are a few columns wide, so the calls cost more than the arithmetic, and
//! the walk runs on one thread. Here each supernode is one pass over its
//! values in the order they are stored, and the elimination tree is cut
//! into a top part and two groups of independent subtrees of about equal
//! work: the forward solve does the two groups at once and then the top,
//! the backward solve the top and then the two groups at once. Both are
//! the textbook column-oriented substitutions (e.g. Davis, *Direct Methods
//! for Sparse Linear Systems*, 2006, §4.1–4.2), by supernodes.

use faer::sparse::linalg::cholesky::{SymbolicCholesky, SymbolicCholeskyRaw};
use std::collections::BinaryHeap;
use std::ops::{Add, Div, Mul, Sub};

/// The two floating-point types a factor is kept in.
pub trait Real:
    Copy
    + Send
    + Sync
    + Default
    + PartialEq
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + 'static
{
    fn of(v: f64) -> Self;
    fn to(self) -> f64;
}

impl Real for f64 {
    #[inline]
    fn of(v: f64) -> Self {
        v
    }
    #[inline]
    fn to(self) -> f64 {
        self
    }
}

impl Real for f32 {
    #[inline]
    fn of(v: f64) -> Self {
        v as f32
    }
    #[inline]
    fn to(self) -> f64 {
        self as f64
    }
}

/// The structure of a supernodal factor, and how its tree is shared out.
#[derive(Debug, Clone)]
pub struct SupernodalSolve {
    n: usize,
    /// `perm[i]`: the original index of permuted unknown i; `inv` its inverse.
    perm: Vec<usize>,
    inv: Vec<usize>,
    /// Supernode s holds columns `begin[s]..begin[s + 1]`.
    begin: Vec<usize>,
    /// Its values, column-major (the diagonal block, then the rows of its
    /// pattern), are `l[val[s]..val[s + 1]]`.
    val: Vec<usize>,
    /// Its pattern (the rows below the diagonal block) starts at `rows[row_ptr[s]]`.
    row_ptr: Vec<usize>,
    rows: Vec<usize>,
    /// Supernodes of the top of the tree and of the two groups of
    /// subtrees, each ascending (children before parents).
    top: Vec<usize>,
    groups: [Vec<usize>; 2],
    /// The longest pattern: the scratch a supernode needs.
    max_pattern: usize,
    /// The widest supernode (the backward solve's dot products).
    max_width: usize,
    /// A top supernode with at least this many values below its diagonal
    /// block is itself split over two threads ([`TOP_SPLIT`]; tests
    /// lower it).
    split_min: usize,
}

/// Below-diagonal values from which a supernode of the top part is split
/// over two threads: the top runs after (forward) or before (backward) the
/// two groups, alone, and its supernodes are the separators of the
/// largest subtrees, hundreds of columns wide with long patterns (`p1_plate.toml` at
/// the paper's size: 12.6 % of the factor's values, all of them serial
/// before). A join costs a few microseconds, the split pays from some
/// thousands of multiply-adds.
const TOP_SPLIT: usize = 16_384;

/// Work vectors of [`SupernodalSolve::solve`], kept between calls.
#[derive(Debug, Default)]
pub struct SolveScratch<T> {
    x: Vec<T>,
    other: Vec<T>,
    tmp: [Vec<T>; 2],
    /// A split top supernode's dot products (backward solve).
    dots: Vec<T>,
}

impl SupernodalSolve {
    /// Reads the structure of faer's analysis; None if it is not
    /// supernodal (the analysis must ask for `SupernodalThreshold::FORCE_SUPERNODAL`).
    pub fn new(sym: &SymbolicCholesky<usize>) -> Option<Self> {
        let SymbolicCholeskyRaw::Supernodal(s) = sym.raw() else {
            return None;
        };
        let n = s.nrows();
        let ns = s.n_supernodes();
        let (perm, inv) = match sym.perm() {
            Some(p) => (p.arrays().0.to_vec(), p.arrays().1.to_vec()),
            None => ((0..n).collect(), (0..n).collect()),
        };
        let mut begin = s.supernode_begin().to_vec();
        begin.push(n);
        let val = s.col_ptr_for_val().to_vec();
        let row_ptr = s.col_ptr_for_row_idx()[..ns].to_vec();
        let rows = s.row_idx().to_vec();
        Some(Self::from_parts(perm, inv, begin, val, row_ptr, rows))
    }

    /// The structure of a factor assembled elsewhere (`super::split`), laid
    /// out as faer's supernodal one: `perm[i]` the original index of
    /// permuted unknown i and `inv` its inverse; supernode s holds columns
    /// `begin[s]..begin[s + 1]` (`begin` ends with n), its values are
    /// `val[s]..val[s + 1]` (column-major, the diagonal block then the
    /// pattern's rows), its pattern ascending from `rows[row_ptr[s]]`;
    /// children before parents.
    pub fn from_parts(
        perm: Vec<usize>,
        inv: Vec<usize>,
        begin: Vec<usize>,
        val: Vec<usize>,
        row_ptr: Vec<usize>,
        rows: Vec<usize>,
    ) -> Self {
        let n = perm.len();
        let ns = begin.len() - 1;
        let mut this = SupernodalSolve {
            n,
            perm,
            inv,
            begin,
            val,
            row_ptr,
            rows,
            top: Vec::new(),
            groups: [Vec::new(), Vec::new()],
            max_pattern: 0,
            max_width: 0,
            split_min: TOP_SPLIT,
        };
        this.max_pattern = (0..ns).map(|k| this.pattern(k).len()).max().unwrap_or(0);
        this.max_width = (0..ns).map(|k| this.width(k)).max().unwrap_or(0);
        this.share_out();
        this
    }

    pub fn len(&self) -> usize {
        self.n
    }

    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Length of the values of a factor with this structure.
    pub fn len_val(&self) -> usize {
        self.val.last().copied().unwrap_or(0)
    }

    /// Multiply-adds of one numeric factorization with this structure:
    /// Σ over the columns of (entries below the diagonal)².
    pub fn multiply_adds(&self) -> f64 {
        (0..self.begin.len() - 1)
            .map(|s| {
                let (k, m) = (self.width(s), self.pattern(s).len());
                (0..k)
                    .map(|i| ((k - i - 1 + m) as f64).powi(2))
                    .sum::<f64>()
            })
            .sum()
    }

    fn width(&self, s: usize) -> usize {
        self.begin[s + 1] - self.begin[s]
    }

    fn pattern(&self, s: usize) -> &[usize] {
        let m = (self.val[s + 1] - self.val[s]) / self.width(s) - self.width(s);
        &self.rows[self.row_ptr[s]..self.row_ptr[s] + m]
    }

    /// The supernodes of the top part and of the two groups, as
    /// (top, group 0, group 1), for tests and reports.
    pub fn shares(&self) -> (&[usize], &[usize], &[usize]) {
        (&self.top, &self.groups[0], &self.groups[1])
    }

    /// Values in the top part and in each group.
    pub fn share_work(&self) -> [usize; 3] {
        let w = |set: &[usize]| set.iter().map(|&s| self.val[s + 1] - self.val[s]).sum();
        [w(&self.top), w(&self.groups[0]), w(&self.groups[1])]
    }

    /// Cuts the elimination tree of the supernodes (the parent of s is the
    /// supernode holding the first row of its pattern) into a top part
    /// and two groups of whole subtrees. Starting from the roots, the
    /// subtree of most work is opened (its root joins the top, its
    /// children become subtrees) until the subtrees, dealt largest first to
    /// the lighter group, balance; the cut of least estimated time (top
    /// plus the heavier group) is kept.
    fn share_out(&mut self) {
        let ns = self.begin.len() - 1;
        let mut owner = vec![0usize; self.n];
        for s in 0..ns {
            owner[self.begin[s]..self.begin[s + 1]].fill(s);
        }
        let mut parent = vec![usize::MAX; ns];
        let mut work: Vec<usize> = (0..ns).map(|s| self.val[s + 1] - self.val[s]).collect();
        let mut children: Vec<Vec<usize>> = vec![Vec::new(); ns];
        for s in 0..ns {
            if let Some(&first) = self.pattern(s).iter().min() {
                parent[s] = owner[first];
                children[owner[first]].push(s);
            }
        }
        // a parent's columns come after its children's
        for s in 0..ns {
            if parent[s] != usize::MAX {
                work[parent[s]] += work[s];
            }
        }
        let total: usize = (0..ns)
            .filter(|&s| parent[s] == usize::MAX)
            .map(|s| work[s])
            .sum();
        let mut frontier: BinaryHeap<(usize, usize)> = (0..ns)
            .filter(|&s| parent[s] == usize::MAX)
            .map(|s| (work[s], s))
            .collect();
        let mut top_work = 0usize;
        let mut opened: Vec<usize> = Vec::new();
        let mut best = (usize::MAX, 0usize);
        for step in 0..=256 {
            // deal the frontier's subtrees, largest first, to the lighter group
            let mut loads = [0usize; 2];
            for &(w, _) in frontier.clone().into_sorted_vec().iter().rev() {
                let g = if loads[0] <= loads[1] { 0 } else { 1 };
                loads[g] += w;
            }
            let estimate = top_work + loads[0].max(loads[1]);
            if estimate < best.0 {
                best = (estimate, step);
            }
            let Some((_, s)) = frontier.pop() else { break };
            if top_work > total / 4 {
                break;
            }
            top_work += self.val[s + 1] - self.val[s];
            opened.push(s);
            for &c in &children[s] {
                frontier.push((work[c], c));
            }
        }
        // replay the best cut
        let opened = &opened[..best.1];
        let mut is_top = vec![false; ns];
        for &s in opened {
            is_top[s] = true;
        }
        let mut roots: Vec<usize> = (0..ns)
            .filter(|&s| !is_top[s] && (parent[s] == usize::MAX || is_top[parent[s]]))
            .collect();
        roots.sort_by_key(|&s| std::cmp::Reverse(work[s]));
        let mut group_of = vec![usize::MAX; ns];
        let mut loads = [0usize; 2];
        for &r in &roots {
            let g = if loads[0] <= loads[1] { 0 } else { 1 };
            loads[g] += work[r];
            group_of[r] = g;
        }
        // every other supernode belongs where its parent does; parents come
        // after children, so walk down from the roots
        for s in (0..ns).rev() {
            if !is_top[s] && group_of[s] == usize::MAX {
                group_of[s] = group_of[parent[s]];
            }
        }
        self.top = (0..ns).filter(|&s| is_top[s]).collect();
        self.groups = [
            (0..ns).filter(|&s| group_of[s] == 0).collect(),
            (0..ns).filter(|&s| group_of[s] == 1).collect(),
        ];
    }

    /// x ← A⁻¹ x with the factor `l` (values laid out as faer's supernodal
    /// LLᵀ), the two groups of subtrees on two threads (rayon's pool;
    /// with one thread the same order serially, the same result).
    pub fn solve<T: Real>(&self, l: &[T], x: &mut [f64], scratch: &mut SolveScratch<T>) {
        assert_eq!(x.len(), self.n, "solve: vector length");
        assert_eq!(l.len(), self.len_val(), "solve: factor length");
        let SolveScratch {
            x: xp,
            other,
            tmp,
            dots,
        } = scratch;
        xp.clear();
        xp.extend(self.perm.iter().map(|&i| T::of(x[i])));
        other.resize(self.n, T::default());
        for t in tmp.iter_mut() {
            t.resize(self.max_pattern, T::default());
        }
        dots.resize(self.max_width, T::default());
        let [tmp0, tmp1] = tmp;
        // L y = b: the groups at once; the second group works on a copy
        // whose top entries start at zero, so its updates of the top are
        // added afterwards
        other.copy_from_slice(xp);
        for &s in &self.top {
            other[self.begin[s]..self.begin[s + 1]].fill(T::default());
        }
        rayon::join(
            || {
                self.groups[0]
                    .iter()
                    .for_each(|&s| self.forward(s, l, xp, tmp0))
            },
            || {
                self.groups[1]
                    .iter()
                    .for_each(|&s| self.forward(s, l, other, tmp1))
            },
        );
        self.take_group(xp, other);
        for &s in &self.top {
            for c in self.begin[s]..self.begin[s + 1] {
                xp[c] = xp[c] + other[c];
            }
        }
        for &s in &self.top {
            if self.split(s) {
                self.forward_split(s, l, xp, tmp0);
            } else {
                self.forward(s, l, xp, tmp0);
            }
        }
        // Lᵀ x = y: the top, then the groups at once, which only read it
        for &s in self.top.iter().rev() {
            if self.split(s) {
                self.backward_split(s, l, xp, tmp0, dots);
            } else {
                self.backward(s, l, xp, tmp0);
            }
        }
        other.copy_from_slice(xp);
        rayon::join(
            || {
                self.groups[0]
                    .iter()
                    .rev()
                    .for_each(|&s| self.backward(s, l, xp, tmp0))
            },
            || {
                self.groups[1]
                    .iter()
                    .rev()
                    .for_each(|&s| self.backward(s, l, other, tmp1))
            },
        );
        self.take_group(xp, other);
        for (v, &i) in x.iter_mut().zip(&self.inv) {
            *v = xp[i].to();
        }
    }

    /// Copies the second group's columns from `other` into `x`.
    fn take_group<T: Real>(&self, x: &mut [T], other: &[T]) {
        for &s in &self.groups[1] {
            let (a, b) = (self.begin[s], self.begin[s + 1]);
            x[a..b].copy_from_slice(&other[a..b]);
        }
    }

    /// Supernode s: its first column, its width, its pattern and its
    /// values in `l` (column-major, `width + pattern` rows).
    #[inline]
    fn supernode<'a, T>(&'a self, s: usize, l: &'a [T]) -> (usize, usize, &'a [usize], &'a [T]) {
        (
            self.begin[s],
            self.width(s),
            self.pattern(s),
            &l[self.val[s]..self.val[s + 1]],
        )
    }

    /// Supernode s of the forward substitution L y = b: its columns in
    /// turn, each divided by its diagonal and subtracted from the rows
    /// below (inside the block directly, the pattern's rows summed in
    /// `tmp` and subtracted once). (Four columns at a time, as a blocked
    /// matrix-vector product, was no faster: `p1_plate.toml` at the paper's size.)
    #[inline]
    fn forward<T: Real>(&self, s: usize, l: &[T], x: &mut [T], tmp: &mut [T]) {
        let (f, w, pat, vals) = self.supernode(s, l);
        let rows = w + pat.len();
        let tmp = &mut tmp[..pat.len()];
        tmp.fill(T::default());
        let xt = &mut x[f..f + w];
        for j in 0..w {
            let col = &vals[j * rows..(j + 1) * rows];
            let xj = xt[j] / col[j];
            xt[j] = xj;
            for (v, &c) in xt[j + 1..].iter_mut().zip(&col[j + 1..w]) {
                *v = *v - c * xj;
            }
            for (t, &c) in tmp.iter_mut().zip(&col[w..]) {
                *t = *t + c * xj;
            }
        }
        for (&r, &t) in pat.iter().zip(tmp.iter()) {
            x[r] = x[r] - t;
        }
    }

    /// Whether top supernode s is split over two threads.
    #[inline]
    fn split(&self, s: usize) -> bool {
        self.pattern(s).len() * self.width(s) >= self.split_min
    }

    /// [`Self::forward`] with the rows of the pattern in two halves on two
    /// threads. The same operations in the same order for every entry (the
    /// block's columns in turn, then each pattern row's sum over the
    /// columns in their order, from zero), so the same bits as
    /// [`Self::forward`] on any number of threads.
    fn forward_split<T: Real>(&self, s: usize, l: &[T], x: &mut [T], tmp: &mut [T]) {
        let (f, w, pat, vals) = self.supernode(s, l);
        let rows = w + pat.len();
        let xt = &mut x[f..f + w];
        for j in 0..w {
            let col = &vals[j * rows..(j + 1) * rows];
            let xj = xt[j] / col[j];
            xt[j] = xj;
            for (v, &c) in xt[j + 1..].iter_mut().zip(&col[j + 1..w]) {
                *v = *v - c * xj;
            }
        }
        let xt = &x[f..f + w];
        let tmp = &mut tmp[..pat.len()];
        let half = pat.len() / 2;
        let (t0, t1) = tmp.split_at_mut(half);
        let sums = |t: &mut [T], first: usize| {
            t.fill(T::default());
            for (j, &xj) in xt.iter().enumerate() {
                let below = &vals[j * rows + w + first..j * rows + w + first + t.len()];
                for (t, &c) in t.iter_mut().zip(below) {
                    *t = *t + c * xj;
                }
            }
        };
        rayon::join(|| sums(t0, 0), || sums(t1, half));
        for (&r, &t) in pat.iter().zip(tmp.iter()) {
            x[r] = x[r] - t;
        }
    }

    /// [`Self::backward`] with the dot products of the columns with the
    /// pattern's rows (which do not depend on the block's unknowns) made
    /// first, the columns in two halves on two threads, into `dots`; then
    /// the block as before. The same operations in the same order, so the
    /// same bits as [`Self::backward`].
    fn backward_split<T: Real>(
        &self,
        s: usize,
        l: &[T],
        x: &mut [T],
        tmp: &mut [T],
        dots: &mut [T],
    ) {
        let (f, w, pat, vals) = self.supernode(s, l);
        let rows = w + pat.len();
        let tmp = &mut tmp[..pat.len()];
        for (t, &r) in tmp.iter_mut().zip(pat) {
            *t = x[r];
        }
        let tmp = &*tmp;
        let dots = &mut dots[..w];
        let half = w / 2;
        let (d0, d1) = dots.split_at_mut(half);
        let products = |d: &mut [T], first: usize| {
            for (k, d) in d.iter_mut().enumerate() {
                let j = first + k;
                *d = dot(&vals[j * rows + w..(j + 1) * rows], tmp);
            }
        };
        rayon::join(|| products(d0, 0), || products(d1, half));
        let xt = &mut x[f..f + w];
        for j in (0..w).rev() {
            let col = &vals[j * rows..(j + 1) * rows];
            let v = xt[j] - dots[j] - dot(&col[j + 1..w], &xt[j + 1..]);
            xt[j] = v / col[j];
        }
    }

    /// Supernode s of the backward substitution Lᵀ x = y: the pattern's
    /// rows gathered once, then its columns from the last, each a dot
    /// product with its column.
    #[inline]
    fn backward<T: Real>(&self, s: usize, l: &[T], x: &mut [T], tmp: &mut [T]) {
        let (f, w, pat, vals) = self.supernode(s, l);
        let rows = w + pat.len();
        let tmp = &mut tmp[..pat.len()];
        for (t, &r) in tmp.iter_mut().zip(pat) {
            *t = x[r];
        }
        let xt = &mut x[f..f + w];
        for j in (0..w).rev() {
            let col = &vals[j * rows..(j + 1) * rows];
            let v = xt[j] - dot(&col[w..], tmp) - dot(&col[j + 1..w], &xt[j + 1..]);
            xt[j] = v / col[j];
        }
    }
}

/// Σ aᵢbᵢ in eight interleaved sums (which the compiler keeps in vector
/// registers), then the rest.
#[inline]
fn dot<T: Real>(a: &[T], b: &[T]) -> T {
    let mut acc = [T::default(); 8];
    let (ac, bc) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ar, br) = (ac.remainder(), bc.remainder());
    for (x, y) in ac.zip(bc) {
        for k in 0..8 {
            acc[k] = acc[k] + x[k] * y[k];
        }
    }
    let mut s = ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7]));
    for (&x, &y) in ar.iter().zip(br) {
        s = s + x * y;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::dyn_stack::{MemBuffer, MemStack};
    use faer::linalg::cholesky::llt::factor::LltRegularization;
    use faer::sparse::linalg::cholesky::{
        factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymmetricOrdering,
    };
    use faer::sparse::linalg::SupernodalThreshold;
    use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
    use faer::{Conj, MatMut, Par, Side};

    /// The lower triangle of a mass + Laplacian-like SPD matrix on an
    /// nx × ny node grid with a 5 × 5 stencil (a quadratic B-spline's),
    /// as CSC (col_ptr, row_idx, values).
    fn grid_matrix(nx: usize, ny: usize) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
        let id = |i: usize, j: usize| j * nx + i;
        let n = nx * ny;
        let (mut cp, mut ri, mut v) = (vec![0], Vec::new(), Vec::new());
        for c in 0..n {
            let (ci, cj) = (c % nx, c / nx);
            let mut col = Vec::new();
            for dj in -2i64..=2 {
                for di in -2i64..=2 {
                    let (i, j) = (ci as i64 + di, cj as i64 + dj);
                    if i < 0 || j < 0 || i >= nx as i64 || j >= ny as i64 {
                        continue;
                    }
                    let r = id(i as usize, j as usize);
                    if r < c {
                        continue;
                    }
                    // diagonally dominant: 30 on the diagonal, up to 24 off it
                    let off = -1.0 / (1.0 + (di * di + dj * dj) as f64)
                        - 0.01 * ((r * 7 + c * 3) % 5) as f64;
                    col.push((r, if r == c { 30.0 } else { off }));
                }
            }
            col.sort_by_key(|e| e.0);
            for (r, x) in col {
                ri.push(r);
                v.push(x);
            }
            cp.push(ri.len());
        }
        (cp, ri, v)
    }

    fn factor<T: faer::traits::ComplexField + Real>(
        n: usize,
        cp: &[usize],
        ri: &[usize],
        v: &[f64],
    ) -> (SymbolicCholesky<usize>, Vec<T>) {
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, cp, None, ri);
        let params = CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        };
        let sym = factorize_symbolic_cholesky(pattern, Side::Lower, SymmetricOrdering::Amd, params)
            .unwrap();
        let vt: Vec<T> = v.iter().map(|&x| T::of(x)).collect();
        let mut l = vec![T::of(0.0); sym.len_val()];
        let mut mem =
            MemBuffer::new(sym.factorize_numeric_llt_scratch::<T>(Par::Seq, Default::default()));
        sym.factorize_numeric_llt::<T>(
            &mut l,
            SparseColMatRef::new(pattern, &vt),
            Side::Lower,
            LltRegularization::default(),
            Par::Seq,
            MemStack::new(&mut mem),
            Default::default(),
        )
        .unwrap();
        (sym, l)
    }

    fn rhs(n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| ((i * 37 % 101) as f64 - 50.0) / 7.0)
            .collect()
    }

    #[test]
    fn solves_as_faer_does_in_f64_and_f32() {
        let (nx, ny) = (61, 23);
        let n = nx * ny;
        let (cp, ri, v) = grid_matrix(nx, ny);
        let b = rhs(n);
        // f64: against faer's own solve with the same factor
        let (sym, l) = factor::<f64>(n, &cp, &ri, &v);
        let tri = SupernodalSolve::new(&sym).expect("supernodal");
        let mut x = b.clone();
        tri.solve(&l, &mut x, &mut SolveScratch::default());
        let mut y = b.clone();
        let mut mem = MemBuffer::new(sym.solve_in_place_scratch::<f64>(1, Par::Seq));
        LltRef::new(&sym, &l).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut y, n, 1),
            Par::Seq,
            MemStack::new(&mut mem),
        );
        let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (a, e) in x.iter().zip(&y) {
            assert!((a - e).abs() <= 1e-12 * scale, "{a} vs faer's {e}");
        }
        // and A x = b (A from its lower triangle)
        let mut ax = vec![0.0; n];
        for c in 0..n {
            for k in cp[c]..cp[c + 1] {
                ax[ri[k]] += v[k] * x[c];
                if ri[k] != c {
                    ax[c] += v[k] * x[ri[k]];
                }
            }
        }
        let bn = b.iter().map(|v| v * v).sum::<f64>().sqrt();
        let res = ax
            .iter()
            .zip(&b)
            .map(|(p, q)| (p - q) * (p - q))
            .sum::<f64>()
            .sqrt();
        assert!(res <= 1e-12 * bn, "residual {res}");
        // f32: within f32's accuracy of the f64 solution
        let (sym32, l32) = factor::<f32>(n, &cp, &ri, &v);
        let tri32 = SupernodalSolve::new(&sym32).expect("supernodal");
        let mut z = b.clone();
        tri32.solve(&l32, &mut z, &mut SolveScratch::default());
        for (a, e) in z.iter().zip(&y) {
            assert!((a - e).abs() <= 1e-5 * scale, "{a} vs {e}");
        }
    }

    #[test]
    fn the_tree_is_shared_out_whole_and_evenly_and_one_thread_gives_the_same() {
        let (nx, ny) = (120, 50);
        let n = nx * ny;
        let (cp, ri, v) = grid_matrix(nx, ny);
        let (sym, l) = factor::<f64>(n, &cp, &ri, &v);
        let tri = SupernodalSolve::new(&sym).expect("supernodal");
        // every supernode in exactly one share
        let (top, g0, g1) = tri.shares();
        let mut all: Vec<usize> = top.iter().chain(g0).chain(g1).copied().collect();
        all.sort();
        assert_eq!(all, (0..tri.begin.len() - 1).collect::<Vec<_>>());
        // no supernode of one group has its parent in the other
        let owner = |c: usize| tri.begin.partition_point(|&b| b <= c) - 1;
        for (g, other) in [(g0, g1), (g1, g0)] {
            for &s in g {
                if let Some(&r) = tri.pattern(s).iter().min() {
                    assert!(
                        !other.contains(&owner(r)),
                        "supernode {s}'s parent is in the other group"
                    );
                }
            }
        }
        // the groups carry most of the work, about evenly
        let [wt, w0, w1] = tri.share_work();
        let total = (wt + w0 + w1) as f64;
        assert!((wt as f64) < 0.2 * total, "top {wt} of {total}");
        assert!(
            (w0 as f64 - w1 as f64).abs() < 0.1 * total,
            "groups {w0} and {w1}"
        );
        // the same result on one thread as on two
        let b = rhs(n);
        let mut two = b.clone();
        rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap()
            .install(|| tri.solve(&l, &mut two, &mut SolveScratch::default()));
        let mut one = b.clone();
        rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| tri.solve(&l, &mut one, &mut SolveScratch::default()));
        assert_eq!(one, two);
    }
    #[test]
    fn splitting_the_top_supernodes_gives_the_same_bits() {
        fn run<T: Real>(tri: &SupernodalSolve, l: &[T], b: &[f64], threads: usize) -> Vec<f64> {
            let mut x = b.to_vec();
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| tri.solve(l, &mut x, &mut SolveScratch::default()));
            x
        }
        let (nx, ny) = (120, 50);
        let n = nx * ny;
        let (cp, ri, v) = grid_matrix(nx, ny);
        let b = rhs(n);
        let (sym, l) = factor::<f64>(n, &cp, &ri, &v);
        let (sym32, l32) = factor::<f32>(n, &cp, &ri, &v);
        let mut whole = SupernodalSolve::new(&sym).expect("supernodal");
        whole.split_min = usize::MAX;
        let mut split = whole.clone();
        split.split_min = 0;
        // the split path is taken (every top supernode)
        assert!(split.top.len() > 3, "top {:?}", split.top);
        let expect = run(&whole, &l, &b, 1);
        for threads in [1, 2] {
            assert_eq!(
                run(&split, &l, &b, threads),
                expect,
                "f64, {threads} threads"
            );
        }
        let mut whole32 = SupernodalSolve::new(&sym32).expect("supernodal");
        whole32.split_min = usize::MAX;
        let mut split32 = whole32.clone();
        split32.split_min = 0;
        let expect32 = run(&whole32, &l32, &b, 1);
        for threads in [1, 2] {
            assert_eq!(
                run(&split32, &l32, &b, threads),
                expect32,
                "f32, {threads} threads"
            );
        }
    }
}
