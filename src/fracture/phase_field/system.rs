//! The phase-field system `K c = F` on the active grid nodes of one discrete
//! field (eq. 57 of seed 001), its sparse Cholesky solve, and the fracture
//! energy.
//!
//! Weak form of eq. 20 (the phase-field equation):
//! `∫ [(4l₀(1−k_f)H/Ḡc + 1) c w + 4l₀² ∇c·∇w + 4l₀⁴ (∇²c)ᵀ M (∇²w)] dV = ∫ w dV`
//! with `∇²c = [c,11, c,22, c,12]` and M the (rotated) Voigt tensor γ, so
//! `K_IJ = Σ_p V_p [(4l₀(1−k_f)H_p/Ḡc + 1) N_I N_J + 4l₀² ∇N_I·∇N_J
//! + 4l₀⁴ h_Iᵀ M h_J]` and `F_I = Σ_p V_p N_I`, with `h_I = [N_I,xx, N_I,yy, N_I,xy]`.
//!
//! The matrix is symmetric positive definite (mass-like term with a
//! positive coefficient, plus two positive semi-definite terms when a(n) ≥ 0
//! for all n). Only the lower triangle is stored. The symbolic analysis
//! (AMD ordering, elimination tree) is kept while the set of active nodes
//! is unchanged; faer does not check that a reused analysis matches the
//! matrix, so the node set itself is compared before every reuse.

use super::anisotropy::Gamma;
use crate::grid::shape::{Kernel, MAX_SUPPORT};
use crate::grid::GridGeom;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{factorize_symbolic_cholesky, SymbolicCholesky, SymmetricOrdering};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use std::time::Instant;

/// Material parameters of one discrete field's phase field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhaseFieldParams {
    /// Ḡc of the functional, N/m (J/m²).
    pub gc_bar: f64,
    /// Length scale l₀, m.
    pub l0: f64,
    /// Residual stiffness k_f in g(c) = (1 − k_f)c² + k_f.
    pub k_f: f64,
    /// The anisotropy tensor, already rotated by the material angle
    /// (zero: the 2nd-order isotropic model).
    pub gamma: Gamma,
}

/// What can go wrong in a solve.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PhaseFieldError {
    #[error("the phase-field matrix is not positive definite ({0}); check the anisotropy tensor and l0")]
    NotPositiveDefinite(String),
    #[error("phase-field solver: {0}")]
    Solver(String),
}

/// Wall time spent in each part of the solves so far, s.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct SolveStats {
    pub assembly: f64,
    pub analysis: f64,
    pub factorization: f64,
    pub solve: f64,
    /// Symbolic analyses (the active-node set changed) and numeric
    /// factorizations done.
    pub analyses: u64,
    pub factorizations: u64,
}

/// The particles of one discrete field, as the assembly reads them.
#[derive(Debug, Clone, Copy)]
pub struct FieldParticles<'a> {
    pub x: &'a [[f64; 2]],
    /// Volumes (area × thickness), m³.
    pub vol: &'a [f64],
    /// History field H = max ψ⁺, J/m³.
    pub history: &'a [f64],
}

/// Shape-function values, gradients and Hessians of one particle's support.
struct Support {
    n: usize,
    node: [usize; MAX_SUPPORT * MAX_SUPPORT],
    w: [f64; MAX_SUPPORT * MAX_SUPPORT],
    g: [[f64; 2]; MAX_SUPPORT * MAX_SUPPORT],
    /// [N,xx, N,yy, N,xy]
    hess: [[f64; 3]; MAX_SUPPORT * MAX_SUPPORT],
}

fn support<K: Kernel>(geom: &GridGeom, x: [f64; 2]) -> Support {
    let xi = geom.xi(x);
    let (wx, d2x) = K::eval2(xi[0], 0.0);
    let (wy, d2y) = K::eval2(xi[1], 0.0);
    let (ih, ih2) = (geom.inv_h, geom.inv_h * geom.inv_h);
    let mut s = Support {
        n: K::N * K::N,
        node: [0; MAX_SUPPORT * MAX_SUPPORT],
        w: [0.0; MAX_SUPPORT * MAX_SUPPORT],
        g: [[0.0; 2]; MAX_SUPPORT * MAX_SUPPORT],
        hess: [[0.0; 3]; MAX_SUPPORT * MAX_SUPPORT],
    };
    for j in 0..K::N {
        for i in 0..K::N {
            let k = i + j * K::N;
            s.node[k] = (wx.base + i as isize) as usize + (wy.base + j as isize) as usize * geom.nodes[0];
            s.w[k] = wx.w[i] * wy.w[j];
            s.g[k] = [wx.dw[i] * wy.w[j] * ih, wx.w[i] * wy.dw[j] * ih];
            s.hess[k] = [d2x[i] * wy.w[j] * ih2, wx.w[i] * d2y[j] * ih2, wx.dw[i] * wy.dw[j] * ih2];
        }
    }
    s
}

/// The assembled system and the factorization kept between solves.
pub struct PhaseFieldSystem {
    /// Active nodes (ascending); the unknowns, in this order.
    dofs: Vec<u32>,
    /// Dof of every grid node, or u32::MAX.
    dof_of: Vec<u32>,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
    rhs: Vec<f64>,
    /// The analysis and the node set it was made for.
    symbolic: Option<SymbolicCholesky<usize>>,
    l_values: Vec<f64>,
    mem: MemBuffer,
    pub stats: SolveStats,
}

impl Default for PhaseFieldSystem {
    fn default() -> Self {
        Self::new()
    }
}

impl PhaseFieldSystem {
    pub fn new() -> Self {
        PhaseFieldSystem {
            dofs: Vec::new(),
            dof_of: Vec::new(),
            col_ptr: Vec::new(),
            row_idx: Vec::new(),
            values: Vec::new(),
            rhs: Vec::new(),
            symbolic: None,
            l_values: Vec::new(),
            mem: MemBuffer::new(faer::dyn_stack::StackReq::empty()),
            stats: SolveStats::default(),
        }
    }

    /// Number of unknowns of the last assembly.
    pub fn len(&self) -> usize {
        self.dofs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.dofs.is_empty()
    }

    /// Nonzeros of the stored lower triangle.
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// Sets the unknowns to the nodes the particles' supports cover and
    /// rebuilds the sparsity pattern if that set changed. Returns whether
    /// it changed (the analysis must then be redone).
    fn set_active<K: Kernel>(&mut self, geom: &GridGeom, parts: &FieldParticles) -> bool {
        let nodes = geom.node_count();
        let mut active = vec![false; nodes];
        // A node is an unknown only if some particle gives it weight: the
        // GIMP window and the knots of B-splines include nodes at exactly
        // zero weight, whose rows would be singular.
        for &x in parts.x {
            let s = support::<K>(geom, x);
            for k in 0..s.n {
                if s.w[k] > 0.0 {
                    active[s.node[k]] = true;
                }
            }
        }
        let dofs: Vec<u32> = (0..nodes as u32).filter(|&n| active[n as usize]).collect();
        if dofs == self.dofs && self.dof_of.len() == nodes {
            return false;
        }
        self.dof_of.clear();
        self.dof_of.resize(nodes, u32::MAX);
        for (d, &n) in dofs.iter().enumerate() {
            self.dof_of[n as usize] = d as u32;
        }
        self.dofs = dofs;
        // Lower triangle: node b couples with node a ≥ b when both lie in
        // one support, i.e. within K::N − 1 nodes along each axis.
        let w = K::N as isize - 1;
        let [nx, ny] = [geom.nodes[0] as isize, geom.nodes[1] as isize];
        self.col_ptr.clear();
        self.row_idx.clear();
        self.col_ptr.push(0);
        for &node in &self.dofs {
            let (ix, iy) = (node as isize % nx, node as isize / nx);
            for dy in -w..=w {
                for dx in -w..=w {
                    let (x, y) = (ix + dx, iy + dy);
                    if x < 0 || y < 0 || x >= nx || y >= ny {
                        continue;
                    }
                    let other = (x + y * nx) as usize;
                    let d = self.dof_of[other];
                    if d != u32::MAX && other >= node as usize {
                        self.row_idx.push(d as usize);
                    }
                }
            }
            self.col_ptr.push(self.row_idx.len());
        }
        self.symbolic = None;
        true
    }

    #[inline]
    fn position(&self, row: usize, col: usize) -> usize {
        let (a, b) = (self.col_ptr[col], self.col_ptr[col + 1]);
        match self.row_idx[a..b].binary_search(&row) {
            Ok(k) => a + k,
            // unreachable: every pair within one support is in the pattern
            Err(_) => usize::MAX,
        }
    }

    /// Assembles K and F (eq. 57) from the particles.
    pub fn assemble<K: Kernel>(&mut self, geom: &GridGeom, parts: &FieldParticles, p: &PhaseFieldParams) {
        let t0 = Instant::now();
        self.set_active::<K>(geom, parts);
        self.values.clear();
        self.values.resize(self.row_idx.len(), 0.0);
        self.rhs.clear();
        self.rhs.resize(self.dofs.len(), 0.0);
        let m = p.gamma.voigt();
        let fourth = !p.gamma.is_zero();
        let (c2, c4) = (4.0 * p.l0 * p.l0, 4.0 * p.l0.powi(4));
        for (k, &x) in parts.x.iter().enumerate() {
            let v = parts.vol[k];
            let reaction = v * (4.0 * p.l0 * (1.0 - p.k_f) * parts.history[k] / p.gc_bar + 1.0);
            let s = support::<K>(geom, x);
            let mut mh = [[0.0; 3]; MAX_SUPPORT * MAX_SUPPORT];
            if fourth {
                for a in 0..s.n {
                    for r in 0..3 {
                        mh[a][r] = (0..3).map(|q| m[r][q] * s.hess[a][q]).sum();
                    }
                }
            }
            for a in 0..s.n {
                let da = self.dof_of[s.node[a]];
                if da == u32::MAX {
                    continue; // zero weight from every particle: not an unknown
                }
                let da = da as usize;
                self.rhs[da] += v * s.w[a];
                for b in 0..s.n {
                    let db = self.dof_of[s.node[b]];
                    if db == u32::MAX || da < db as usize {
                        continue; // inactive, or the upper triangle (row < col)
                    }
                    let db = db as usize;
                    let mut kab = reaction * s.w[a] * s.w[b] + v * c2 * (s.g[a][0] * s.g[b][0] + s.g[a][1] * s.g[b][1]);
                    if fourth {
                        kab += v * c4 * (s.hess[b][0] * mh[a][0] + s.hess[b][1] * mh[a][1] + s.hess[b][2] * mh[a][2]);
                    }
                    let pos = self.position(da, db);
                    self.values[pos] += kab;
                }
            }
        }
        self.stats.assembly += t0.elapsed().as_secs_f64();
    }

    /// The assembled matrix as dense rows (tests and diagnostics only).
    pub fn dense(&self) -> Vec<Vec<f64>> {
        let n = self.dofs.len();
        let mut d = vec![vec![0.0; n]; n];
        for col in 0..n {
            for k in self.col_ptr[col]..self.col_ptr[col + 1] {
                let row = self.row_idx[k];
                d[row][col] = self.values[k];
                d[col][row] = self.values[k];
            }
        }
        d
    }

    /// The right-hand side F.
    pub fn rhs(&self) -> &[f64] {
        &self.rhs
    }

    /// The unknowns' grid nodes.
    pub fn dofs(&self) -> &[u32] {
        &self.dofs
    }

    /// Factorizes K (reusing the analysis while the node set is unchanged)
    /// and solves for c. Returns c at every grid node (1 where inactive).
    pub fn solve(&mut self, nodes: usize) -> Result<Vec<f64>, PhaseFieldError> {
        let n = self.dofs.len();
        let mut c = vec![1.0; nodes];
        if n == 0 {
            return Ok(c);
        }
        let pattern = SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
        let t0 = Instant::now();
        if self.symbolic.as_ref().is_none_or(|s| s.nrows() != n) {
            let sym = factorize_symbolic_cholesky(pattern, Side::Lower, SymmetricOrdering::Amd, Default::default())
                .map_err(|e| PhaseFieldError::Solver(format!("symbolic analysis: {e:?}")))?;
            self.l_values.resize(sym.len_val(), 0.0);
            let req = sym
                .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default())
                .or(sym.solve_in_place_scratch::<f64>(1, Par::Seq));
            self.mem = MemBuffer::try_new(req).map_err(|e| PhaseFieldError::Solver(format!("workspace: {e:?}")))?;
            self.symbolic = Some(sym);
            self.stats.analyses += 1;
        }
        let t1 = Instant::now();
        self.stats.analysis += (t1 - t0).as_secs_f64();
        let sym = self.symbolic.as_ref().ok_or_else(|| PhaseFieldError::Solver("no analysis".into()))?;
        let a = SparseColMatRef::new(pattern, &self.values);
        let llt = sym
            .factorize_numeric_llt::<f64>(
                &mut self.l_values,
                a,
                Side::Lower,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(&mut self.mem),
                Default::default(),
            )
            .map_err(|e| PhaseFieldError::NotPositiveDefinite(format!("{e:?}")))?;
        self.stats.factorizations += 1;
        let t2 = Instant::now();
        self.stats.factorization += (t2 - t1).as_secs_f64();
        let mut x = self.rhs.clone();
        llt.solve_in_place_with_conj(Conj::No, MatMut::from_column_major_slice_mut(&mut x, n, 1), Par::Seq, MemStack::new(&mut self.mem));
        self.stats.solve += t2.elapsed().as_secs_f64();
        for (d, &node) in self.dofs.iter().enumerate() {
            c[node as usize] = x[d];
        }
        Ok(c)
    }
}

/// c, ∇c and ∇²c = [c,11, c,22, c,12] at a point from nodal values.
pub fn field_at<K: Kernel>(geom: &GridGeom, c: &[f64], x: [f64; 2]) -> (f64, [f64; 2], [f64; 3]) {
    let s = support::<K>(geom, x);
    let (mut v, mut g, mut h) = (0.0, [0.0; 2], [0.0; 3]);
    for k in 0..s.n {
        let ci = c[s.node[k]];
        v += s.w[k] * ci;
        g[0] += s.g[k][0] * ci;
        g[1] += s.g[k][1] * ci;
        for r in 0..3 {
            h[r] += s.hess[k][r] * ci;
        }
    }
    (v, g, h)
}

/// The crack density Z of eq. 4 at a point:
/// (c−1)²/(4l₀) + l₀|∇c|² + l₀³ (∇²c)ᵀ M (∇²c).
pub fn crack_density(p: &PhaseFieldParams, c: f64, g: [f64; 2], h: [f64; 3]) -> f64 {
    let m = p.gamma.voigt();
    let quad: f64 = (0..3).map(|i| (0..3).map(|j| h[i] * m[i][j] * h[j]).sum::<f64>()).sum();
    (c - 1.0).powi(2) / (4.0 * p.l0) + p.l0 * (g[0] * g[0] + g[1] * g[1]) + p.l0.powi(3) * quad
}

/// Ψ_f = Σ_p V_p Ḡc Z_p over the particles for which `keep` holds, J.
pub fn fracture_energy<K: Kernel>(
    geom: &GridGeom,
    c: &[f64],
    parts: &FieldParticles,
    p: &PhaseFieldParams,
    keep: impl Fn([f64; 2]) -> bool,
) -> f64 {
    parts
        .x
        .iter()
        .zip(parts.vol)
        .filter(|(x, _)| keep(**x))
        .map(|(&x, &v)| {
            let (cv, g, h) = field_at::<K>(geom, c, x);
            v * p.gc_bar * crack_density(p, cv, g, h)
        })
        .fold(0.0, |a, b| a + b) // (an empty f64 sum is −0.0)
}
