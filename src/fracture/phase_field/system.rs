//! The phase-field system `K c = F` on the active grid nodes of one discrete
//! field (eq. 57 of Kakouris & Triantafyllou), its sparse Cholesky solve, and the fracture
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

use super::anisotropy::{Gamma, Gamma3};
use super::multigrid::Multigrid;
use super::split::SplitCholesky;
use super::trisolve::{SolveScratch, SupernodalSolve};
use crate::grid::shape::{Kernel, MAX_SUPPORT};
use crate::grid::{Bins, GridGeom, Support, SyncPtr};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Par, Side};
use rayon::prelude::*;
use std::time::Instant;

/// Fresh multigrid hierarchies in a row that must each take more than
/// `rebuild_after` iterations before a system hands over to the factor.
const POOR_BUILDS: u32 = 3;

/// The diagonal penalty of [`PhaseFieldSystem::assemble`], relative to the
/// largest diagonal entry.
const PIVOT_FLOOR: f64 = 1e-12;

/// Material parameters of one discrete field's phase field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhaseFieldParams {
    /// Ḡc of the functional, N/m (J/m²).
    pub gc_bar: f64,
    /// Length scale l₀, m.
    pub l0: f64,
    /// Residual stiffness k_f in g(c) = (1 − k_f)c² + k_f.
    pub k_f: f64,
    /// The anisotropy tensor of a 2D field, already rotated by the
    /// material angle (zero: the 2nd-order isotropic model).
    pub gamma: Gamma,
    /// The anisotropy tensor of a 3D field (zero: the 2nd order).
    pub gamma3: Gamma3,
}

impl PhaseFieldParams {
    /// Whether the field in `D` dimensions has the 4th-order term.
    pub fn fourth<const D: usize>(&self) -> bool {
        if D == 2 {
            !self.gamma.is_zero()
        } else {
            !self.gamma3.is_zero()
        }
    }

    /// γ in Voigt form for `D` dimensions, in the first `D(D+1)/2` rows
    /// and columns of a 6 × 6 matrix.
    pub fn voigt6<const D: usize>(&self) -> [[f64; 6]; 6] {
        if D == 2 {
            let mut m = [[0.0; 6]; 6];
            for (row, g) in m.iter_mut().zip(self.gamma.voigt()) {
                row[..3].copy_from_slice(&g);
            }
            m
        } else {
            self.gamma3.m
        }
    }
}

/// What can go wrong in a solve.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PhaseFieldError {
    #[error(
        "the phase-field matrix is not positive definite ({0}); check the anisotropy tensor and l0"
    )]
    NotPositiveDefinite(String),
    #[error("phase-field solver: {0}")]
    Solver(String),
}

/// Wall time spent in each part of the solves so far, s.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SolveStats {
    pub assembly: f64,
    pub analysis: f64,
    pub factorization: f64,
    pub solve: f64,
    /// Symbolic analyses (the active-node set changed) and numeric
    /// factorizations done (method "multigrid": builds of the hierarchy,
    /// whose time is in `factorization`).
    pub analyses: u64,
    pub factorizations: u64,
    /// Preconditioned CG solves and their iterations (methods "pcg" and
    /// "multigrid").
    pub pcg_solves: u64,
    pub pcg_iterations: u64,
    /// The numeric factorizations above by kind, and their seconds (in
    /// `factorization` too): PCG's preconditioner (an f64 factor rounded
    /// to f32) and the f64 factor solved with directly (method "direct",
    /// and the fall-backs).
    pub preconditioner_factorizations: u64,
    pub preconditioner_factorization: f64,
    pub direct_factorizations: u64,
    pub direct_factorization: f64,
    /// Direct solves after PCG with a fresh preconditioner (or multigrid
    /// hierarchy) failed to converge: each one factorization more.
    pub fallbacks: u64,
    /// Method "auto": seconds spent in its trial solving with the method
    /// whose solutions were not used (the multigrid beside the factor; in
    /// no other figure above), and how many systems its trial gave to the
    /// factor and to the multigrid.
    #[serde(default)]
    pub auto_trial: f64,
    #[serde(default)]
    pub auto_factor: u64,
    #[serde(default)]
    pub auto_multigrid: u64,
}

/// The kinds of numeric factorization a run makes (see
/// [`SolveStats::preconditioner_factorizations`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FactorKind {
    /// PCG's preconditioner: the f64 factor rounded to f32.
    Preconditioner,
    /// The f64 factor of a direct solve.
    Direct,
}

/// The fill-reducing ordering of the Cholesky factorizations.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FactorOrdering {
    /// faer's approximate minimum degree: one factorization, on one thread.
    #[default]
    Amd,
    /// Geometric nested dissection on the grid, the two sides of its first
    /// cut factorized at once ([`SplitCholesky`]).
    Dissection,
}

/// How `K c = F` is solved each step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SolveMethod {
    /// Numeric Cholesky factorization every step (the analysis is reused).
    Direct,
    /// Conjugate gradients from the last solution, preconditioned by the
    /// last Cholesky factor (`refactor_after` is its cost in iterations);
    /// refactorizes when a solve costs more than the average since the last
    /// factorization or does not converge within `2·refactor_after`
    /// iterations, and falls back to a direct solve after `max_iterations`.
    /// Converged when ‖F − Kc‖ ≤ tolerance·‖F‖.
    Pcg {
        tolerance: f64,
        max_iterations: usize,
        refactor_after: usize,
    },
    /// Conjugate gradients from the last solution, preconditioned by one
    /// V-cycle of geometric multigrid ([`super::multigrid`]); the hierarchy
    /// is rebuilt by the same rule as `Pcg`'s factor (a build counts as
    /// `rebuild_after` iterations) and whenever the active nodes change,
    /// with no symbolic analysis. Falls back to a direct solve after
    /// `max_iterations`.
    Multigrid {
        tolerance: f64,
        max_iterations: usize,
        rebuild_after: usize,
    },
    /// Whichever of `Pcg` (with the factor) and `Multigrid` takes less
    /// wall time on this system and this machine: for its first
    /// [`AUTO_TRIAL_SOLVES`] solves, each system is solved by `Pcg`, whose
    /// solutions are used, and again by `Multigrid` from the same start,
    /// whose solutions are dropped; then the one whose solves took less
    /// time goes on alone (`refactor_after` is both methods' renewal cost).
    /// Until the choice, and whenever `Pcg` is chosen, the results are
    /// those of method `Pcg` bit for bit; the choice itself rests on
    /// seconds, so another machine or a busier one may choose otherwise.
    Auto {
        tolerance: f64,
        max_iterations: usize,
        refactor_after: usize,
    },
}

/// Solves of method "auto"'s trial (each made twice): enough for both
/// methods to amortise their first factorization / hierarchy over a few
/// steps and for the renewal rule to run, few enough that doubling the
/// solves costs a small part of a long run.
pub const AUTO_TRIAL_SOLVES: u32 = 12;

/// What method "auto"'s trial chose for one system.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AutoChoice {
    /// PCG preconditioned by the Cholesky factor (method "pcg").
    Factor,
    /// PCG preconditioned by the multigrid (method "multigrid").
    Multigrid,
}

/// The state of method "auto"'s trial (see [`SolveMethod::Auto`]).
#[derive(Debug, Default)]
struct AutoTrial {
    solves: u32,
    factor_seconds: f64,
    multigrid_seconds: f64,
    /// The multigrid's renewal rule (`cycle_cost`, `cycle_solves`,
    /// `refactor_next`) while the factor's is the system's.
    renewal: (f64, u32, bool),
    /// The multigrid's solution, dropped.
    x: Vec<f64>,
    choice: Option<AutoChoice>,
}

/// The particles of one discrete field, as the assembly reads them, in 2D
/// or 3D (`D`).
#[derive(Debug, Clone, Copy)]
pub struct FieldParticles<'a, const D: usize = 2> {
    pub x: &'a [[f64; D]],
    /// Volumes (area × thickness), m³.
    pub vol: &'a [f64],
    /// History field H = max ψ⁺, J/m³.
    pub history: &'a [f64],
    /// Only the particles p with `body.0[p] == body.1` (None: all).
    pub body: Option<(&'a [u16], u16)>,
    /// Visit the particles tile by tile in 2^D colours, in parallel (the
    /// simulation's bins); None: serially in index order.
    pub bins: Option<&'a Bins>,
}

impl<'a, const D: usize> FieldParticles<'a, D> {
    /// All of the given particles, visited serially.
    pub fn all(x: &'a [[f64; D]], vol: &'a [f64], history: &'a [f64]) -> Self {
        FieldParticles {
            x,
            vol,
            history,
            body: None,
            bins: None,
        }
    }

    #[inline]
    fn member(&self, p: usize) -> bool {
        self.body.is_none_or(|(b, id)| b[p] == id)
    }
}

/// Entries of a Hessian in Voigt order: 3 in 2D, 6 in 3D (the arrays hold
/// six, [`crate::grid::SupportNode::hess_voigt6`]).
const fn voigt_len(d: usize) -> usize {
    d * (d + 1) / 2
}

/// The largest support in `D` dimensions: the length of the per-particle
/// tables of the assembly (`S`).
const S2: usize = MAX_SUPPORT * MAX_SUPPORT;
const S3: usize = MAX_SUPPORT * MAX_SUPPORT * MAX_SUPPORT;

/// Shape-function values, gradients and Hessians of one particle's support,
/// by local index (the assembly pairs every two nodes of it); `S` entries,
/// at least the kernel's support in `D` dimensions.
struct SupportTable<const D: usize, const S: usize> {
    n: usize,
    node: [usize; S],
    w: [f64; S],
    g: [[f64; D]; S],
    /// The Hessians in Voigt order ([`crate::grid::SupportNode::hess_voigt6`]).
    hess: [[f64; 6]; S],
}

/// The support of a particle at `x`; with `HESS`, the Hessians too (the
/// 2nd-order system needs none, and they are left zero). Inlined into the
/// assembly's particle loop: called there as a function, returning the
/// table through memory cost the 2D assembly a quarter of its time.
#[inline(always)]
fn support<K: Kernel, const D: usize, const S: usize, const HESS: bool>(
    geom: &GridGeom<D>,
    x: [f64; D],
) -> SupportTable<D, S> {
    let mut s = SupportTable {
        n: Support::<K, D>::LEN,
        node: [0; S],
        w: [0.0; S],
        g: [[0.0; D]; S],
        hess: [[0.0; 6]; S],
    };
    Support::<K, D, HESS>::eval(geom, x, 0.0).for_each(|n| {
        s.node[n.a] = n.node;
        s.w[n.a] = n.w;
        s.g[n.a] = n.grad;
        if HESS {
            s.hess[n.a] = n.hess_voigt6();
        }
    });
    s
}

impl<const D: usize, const S: usize> SupportTable<D, S> {
    /// The particle's footprint key, as [`PhaseFieldSystem::update_keys`]
    /// makes it from the same support (the table made with `HESS`): the
    /// first node in the high 64 bits, the mask of the footprint nodes by
    /// local index in the low 64. The Voigt entries are all the distinct
    /// entries of the symmetric Hessian, so "one of them is non-zero" is
    /// the same test as on the full matrix.
    #[inline(always)]
    fn footprint_key<const HESS: bool>(&self) -> u128 {
        let mut mask = 0u64;
        for a in 0..self.n {
            if self.w[a] > 0.0 || (HESS && self.hess[a].iter().any(|&h| h != 0.0)) {
                mask |= 1 << a;
            }
        }
        ((self.node[0] as u128) << 64) | mask as u128
    }
}

/// Assemblies in a row that must keep the node set before
/// [`PhaseFieldSystem::assemble`] finds the footprint keys in the pass that
/// adds the terms, instead of in a pass of their own. That saves the keys'
/// pass over the particles (a fifth of P1's assembly); when the node set
/// then turns out new, the terms went onto the old pattern and are added
/// again, which costs a whole assembly more. So the single pass pays only
/// where the node set changes in fewer than about one assembly in five:
/// P1 never after the first, P3 every other step while the disk is in
/// contact, where this many kept assemblies in a row rarely come.
const SPECULATE_AFTER: u32 = 16;

/// What one particle's footprint key and contribution to K and F need.
struct Accumulate<'a, const D: usize> {
    geom: &'a GridGeom<D>,
    parts: &'a FieldParticles<'a, D>,
    params: &'a PhaseFieldParams,
    /// γ in Voigt form, in the first `voigt_len(D)` rows and columns.
    m: [[f64; 6]; 6],
    fourth: bool,
    dof_of: &'a [u32],
    nbr: &'a [u32],
    /// The footprint keys, written with `KEYS` only.
    keys: SyncPtr<'a, u128>,
    values: SyncPtr<'a, f64>,
    rhs: SyncPtr<'a, f64>,
}

// SAFETY: the raw pointers are written only under the colouring rule (a
// key: by the one task that visits its particle).
unsafe impl<const D: usize> Sync for Accumulate<'_, D> {}

/// One cell's block of K (lower triangle, `k[a·S + b]` for b ≤ a) and F:
/// the terms of the consecutive particles whose support starts at `base`,
/// summed here and added to the system once. Particles in a bin follow
/// the seeding lattice, so runs of a cell's particles are the rule; the
/// scattered additions into K, the assembly's bottleneck, drop by the
/// run length.
struct CellBlock<const S: usize> {
    /// First node of the support, or usize::MAX when the block is empty;
    /// support node a is `base + Support::local_offset(a)`.
    base: usize,
    k: [[f64; S]; S],
    f: [f64; S],
}

impl<const S: usize> CellBlock<S> {
    fn new() -> Self {
        CellBlock {
            base: usize::MAX,
            k: [[0.0; S]; S],
            f: [0.0; S],
        }
    }
}

impl<const D: usize> Accumulate<'_, D> {
    /// Adds particle q's terms of eq. 57 to the block of its cell, after
    /// adding the block to the system if it holds another cell; with
    /// `KEYS`, stores q's footprint key too. Returns whether the key
    /// changed (false without `KEYS`).
    ///
    /// # Safety
    /// No other task writes the entries of the support nodes of q or of
    /// the block's cell concurrently, nor (with `KEYS`) accesses q's key.
    #[inline]
    unsafe fn particle<K: Kernel, const S: usize, const KEYS: bool>(
        &self,
        q: usize,
        blk: &mut CellBlock<S>,
    ) -> bool {
        // SAFETY: passed on from the caller.
        unsafe {
            if self.fourth {
                self.particle_of::<K, S, true, KEYS>(q, blk)
            } else {
                self.particle_of::<K, S, false, KEYS>(q, blk)
            }
        }
    }

    /// Sets q's key; whether it changed. Written only when it changed: in
    /// a run whose particles keep their cells, the keys are only read.
    ///
    /// # Safety
    /// q is a particle index and no other task accesses its key.
    #[inline(always)]
    unsafe fn set_key(&self, q: usize, key: u128) -> bool {
        // SAFETY: passed on from the caller.
        let slot = unsafe { self.keys.at(q) };
        if *slot == key {
            return false;
        }
        *slot = key;
        true
    }

    /// [`Accumulate::particle`] for the 2nd-order (`FOURTH` false) or
    /// 4th-order system.
    ///
    /// # Safety
    /// As [`Accumulate::particle`].
    #[inline(always)]
    unsafe fn particle_of<K: Kernel, const S: usize, const FOURTH: bool, const KEYS: bool>(
        &self,
        q: usize,
        blk: &mut CellBlock<S>,
    ) -> bool {
        let parts = self.parts;
        if !parts.member(q) {
            // SAFETY: passed on from the caller.
            return KEYS && unsafe { self.set_key(q, KEY_NONE) };
        }
        let p = self.params;
        let v = parts.vol[q];
        let reaction = v * (4.0 * p.l0 * (1.0 - p.k_f) * parts.history[q] / p.gc_bar + 1.0);
        let (c2, c4) = (4.0 * p.l0 * p.l0, 4.0 * p.l0.powi(4));
        let s = support::<K, D, S, FOURTH>(self.geom, parts.x[q]);
        // SAFETY: passed on from the caller.
        let changed = KEYS && unsafe { self.set_key(q, s.footprint_key::<FOURTH>()) };
        if blk.base != s.node[0] {
            // SAFETY: the caller's colouring covers the block's cell.
            unsafe { self.flush::<K, S>(blk) };
            blk.base = s.node[0];
        }
        let nv = voigt_len(D);
        let mut mh = [[0.0; 6]; S];
        if FOURTH {
            for a in 0..s.n {
                for r in 0..nv {
                    mh[a][r] = (0..nv).map(|t| self.m[r][t] * s.hess[a][t]).sum();
                }
            }
        }
        for a in 0..s.n {
            blk.f[a] += v * s.w[a];
            let row = &mut blk.k[a][..a + 1];
            for (b, kab) in row.iter_mut().enumerate() {
                // ∇N_a·∇N_b summed from the first axis on, as in 2D
                let mut gg = s.g[a][0] * s.g[b][0];
                for d in 1..D {
                    gg += s.g[a][d] * s.g[b][d];
                }
                let mut t = reaction * s.w[a] * s.w[b] + v * c2 * gg;
                if FOURTH {
                    let mut hmh = s.hess[b][0] * mh[a][0];
                    for r in 1..nv {
                        hmh += s.hess[b][r] * mh[a][r];
                    }
                    t += v * c4 * hmh;
                }
                *kab += t;
            }
        }
        changed
    }

    /// Adds the block to K and F and empties it.
    ///
    /// # Safety
    /// No other task writes the entries of the block's nodes concurrently.
    unsafe fn flush<K: Kernel, const S: usize>(&self, blk: &mut CellBlock<S>) {
        if blk.base == usize::MAX {
            return;
        }
        let n = Support::<K, D>::LEN;
        let (w, side, cube) = stencil::<K, D>();
        let mut dof = [u32::MAX; S];
        for (a, d) in dof[..n].iter_mut().enumerate() {
            *d = self.dof_of[blk.base + Support::<K, D>::local_offset(self.geom, a)];
        }
        // The stencil offset of local node b from local node a is the
        // per-axis difference of their local positions, shifted by w, in
        // base `side`: code(a) + centre − code(b), with code the local
        // position in base `side`.
        let mut code = [0usize; S];
        let mut centre = 0;
        let mut place = 1;
        for _ in 0..D {
            centre += w as usize * place;
            place *= side;
        }
        for (a, k) in code[..n].iter_mut().enumerate() {
            let (mut rest, mut place) = (a, 1usize);
            for _ in 0..D {
                *k += (rest % K::N) * place;
                rest /= K::N;
                place *= side;
            }
        }
        for a in 0..n {
            let da = dof[a];
            if da == u32::MAX {
                continue; // zero weight from every particle: not an unknown
            }
            // SAFETY: the caller's colouring.
            unsafe { *self.rhs.at(da as usize) += blk.f[a] };
            let ka = code[a] + centre;
            // The lower triangle (row ≥ col): dofs are numbered in node
            // order and a support's local index i + N·(j + N·k) runs in
            // node order too (a row of the support is shorter than a grid
            // row), so db ≤ da exactly for b ≤ a.
            for b in 0..=a {
                let db = dof[b];
                if db == u32::MAX {
                    continue;
                }
                // per axis la − lb + w ≥ 0, so the difference of the
                // codes never borrows between places
                let k = ka - code[b];
                let pos = self.nbr[db as usize * cube + k] as usize;
                // SAFETY: the caller's colouring.
                unsafe { *self.values.at(pos) += blk.k[a][b] };
            }
        }
        for a in 0..n {
            blk.f[a] = 0.0;
            blk.k[a][..a + 1].fill(0.0);
        }
        blk.base = usize::MAX;
    }
}

/// The coupling stencil of kernel `K` in `D` dimensions: nodes of one
/// support lie within `w = N − 1` nodes of each other along every axis, so
/// node b's neighbours are the `side = 2w + 1` offsets per axis, `cube =
/// side^D` in all; offset index Σ (d_i + w)·side^i, x first.
fn stencil<K: Kernel, const D: usize>() -> (isize, usize, usize) {
    let w = K::N as isize - 1;
    let side = (2 * w + 1) as usize;
    (w, side, side.pow(D as u32))
}

/// Sentinels of [`PhaseFieldSystem`]'s footprint keys: a particle outside
/// the field, and one not yet seen.
const KEY_NONE: u128 = u128::MAX;
const KEY_FRESH: u128 = u128::MAX - 1;

/// The assembled system and the factorization kept between solves; `D`
/// is the grid's dimension.
pub struct PhaseFieldSystem<const D: usize = 2> {
    /// Active nodes (ascending); the unknowns, in this order.
    dofs: Vec<u32>,
    /// Dof of every grid node, or u32::MAX.
    dof_of: Vec<u32>,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// For column dof c and stencil offset k (see [`stencil`]), the
    /// position of the entry in `values`, or u32::MAX: O(1) assembly.
    nbr: Vec<u32>,
    /// Per particle: base node (high 64 bits) and mask of positive-weight
    /// support nodes (low 64: a 3D cubic support has 64) at the last
    /// assembly ([`KEY_NONE`] for non-members); the node set is rebuilt
    /// only when one changes.
    keys: Vec<u128>,
    /// Assemblies in a row that have kept the node set (a grid's first node
    /// set counts as kept); from [`SPECULATE_AFTER`] on, the keys are found
    /// in the pass that adds the terms.
    node_set_kept: u32,
    values: Vec<f64>,
    /// Position in `values` of each dof's diagonal entry.
    diag: Vec<u32>,
    rhs: Vec<f64>,
    /// The analysis and the node set it was made for.
    symbolic: Option<SymbolicCholesky<usize>>,
    /// The numeric Cholesky factor, always made in f64; when it only
    /// preconditions PCG (`single`) it is rounded to f32. The triangular
    /// solves are nearly all of a PCG iteration and stream the whole factor
    /// from memory; in f32 they stream half, while PCG still takes the f64
    /// residual to its tolerance.
    ///
    /// Not factorized in f32: the factor of this system decays by tens of
    /// orders of magnitude away from the diagonal (the entries of K are
    /// ~1e-7 in SI units, and a factor of a mass-dominated operator decays
    /// geometrically along the fill), so an f32 factorization holds ~1e5
    /// subnormal entries (0.2 % of `p1_plate.toml`'s 45.5 M at t = 0) and makes far more
    /// subnormal intermediate products. x86 cores without flush-to-zero
    /// handle those in microcode, tens of times slower: `p1_plate.toml`'s f32
    /// factorization took 3.1 s inside a run against 0.80 s for f64 on the
    /// same machine (issue 40; docs/phase-field-performance.md). In f64 the
    /// subnormal range (below 2.2e-308) is out of reach, and the rounding
    /// below flushes what would be subnormal in f32 to zero.
    l_values: Vec<f64>,
    l_single: Vec<f32>,
    /// The triangular solves with either factor (two threads), and their
    /// work vectors.
    trisolve: Option<SupernodalSolve>,
    /// The fill-reducing ordering asked for; with nested dissection, the
    /// factorization in two halves (its own analysis and solves' structure
    /// in place of `symbolic` and `trisolve`), or the finding that these
    /// unknowns have no cut. `l_values` holds its factor in f64 only when
    /// `double_current` (a preconditioner's factorization writes f32 alone,
    /// and a fall-back direct solve writes the f64 values then).
    ordering: FactorOrdering,
    split: Option<SplitCholesky>,
    split_declined: bool,
    double_current: bool,
    scratch_single: SolveScratch<f32>,
    scratch_double: SolveScratch<f64>,
    single: bool,
    /// The factor holds a factorization of a matrix with today's pattern.
    factored: bool,
    /// The last solution, per dof (PCG's starting point).
    last: Vec<f64>,
    /// The solution being computed, swapped into `last` when it is done,
    /// and PCG's work vectors: kept between steps, so a solve allocates
    /// nothing.
    x: Vec<f64>,
    work: PcgWork,
    /// PCG's renewal rule, in units of one PCG iteration: the cost of the
    /// solves since the last factorization (the factorization included)
    /// and their number; `refactor_next` asks for a fresh factor.
    cycle_cost: f64,
    cycle_solves: u32,
    refactor_next: bool,
    mem: MemBuffer,
    /// The multigrid hierarchy (method "multigrid"), for today's node set,
    /// and whether PCG is preconditioned by it rather than by the factor.
    multigrid: Option<Multigrid>,
    use_multigrid: bool,
    /// The multigrid did poorly on this system with fresh hierarchies (a
    /// grown, opened crack): how many times in a row, and whether PCG has
    /// gone on with the factor for good.
    multigrid_poor: u32,
    multigrid_declined: bool,
    auto: AutoTrial,
    /// The kernel's two-scale mask and the grid's nodes per axis, for the
    /// multigrid's levels.
    refine: &'static [f64],
    grid_nodes: [usize; D],
    /// How many nodes along each axis a coupling of K reaches (the
    /// kernel's support less one).
    reach: usize,
    /// Nodal scratch of [`PhaseFieldSystem::history_residual`] (all grid
    /// nodes, zero between calls).
    scratch: Vec<f64>,
    pub stats: SolveStats,
}

impl<const D: usize> Default for PhaseFieldSystem<D> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const D: usize> PhaseFieldSystem<D> {
    pub fn new() -> Self {
        PhaseFieldSystem {
            dofs: Vec::new(),
            dof_of: Vec::new(),
            col_ptr: Vec::new(),
            row_idx: Vec::new(),
            nbr: Vec::new(),
            keys: Vec::new(),
            node_set_kept: SPECULATE_AFTER,
            values: Vec::new(),
            diag: Vec::new(),
            rhs: Vec::new(),
            symbolic: None,
            l_values: Vec::new(),
            l_single: Vec::new(),
            trisolve: None,
            ordering: FactorOrdering::Amd,
            split: None,
            split_declined: false,
            double_current: false,
            scratch_single: SolveScratch::default(),
            scratch_double: SolveScratch::default(),
            single: false,
            factored: false,
            last: Vec::new(),
            x: Vec::new(),
            work: PcgWork::default(),
            cycle_cost: 0.0,
            cycle_solves: 0,
            refactor_next: false,
            mem: MemBuffer::new(faer::dyn_stack::StackReq::empty()),
            multigrid: None,
            use_multigrid: false,
            multigrid_poor: 0,
            multigrid_declined: false,
            auto: AutoTrial::default(),
            refine: &[],
            grid_nodes: [0; D],
            reach: 0,
            scratch: Vec::new(),
            stats: SolveStats::default(),
        }
    }

    /// The ordering of the factorizations from the next analysis on.
    pub fn set_ordering(&mut self, ordering: FactorOrdering) {
        if ordering != self.ordering {
            self.ordering = ordering;
            self.forget_analysis();
        }
    }

    /// Drops the analysis and the factor (a new node set, or a new
    /// ordering): the next factorization analyses again.
    fn forget_analysis(&mut self) {
        self.symbolic = None;
        self.trisolve = None;
        self.split = None;
        self.split_declined = false;
        self.factored = false;
    }

    /// With `ordering = "dissection"` and a factor made in two halves: the
    /// unknowns of its two sides and of the slab between them.
    pub fn dissection(&self) -> Option<[usize; 3]> {
        self.split
            .as_ref()
            .filter(|_| !self.split_declined)
            .map(|s| s.sizes())
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

    /// Recomputes the per-particle footprint keys; returns whether any
    /// changed (then the node set must be rebuilt). A node is in a
    /// particle's footprint where its weight there is positive, and with
    /// `fourth` also where one of its second derivatives is non-zero: a
    /// quadratic B-spline has N = N' = 0 but N'' ≠ 0 at the end of its
    /// support, where a particle on a knot sits (every third particle row
    /// with 3 × 3 per cell). Without such a node the Hessians at the
    /// particle do not sum to zero, c = 1 stops solving the undamaged
    /// system, and c drops near a body's edge with no history at all.
    fn update_keys<K: Kernel>(
        &mut self,
        geom: &GridGeom<D>,
        parts: &FieldParticles<D>,
        fourth: bool,
    ) -> bool {
        let n = parts.x.len();
        let fresh = self.keys.len() != n || self.dof_of.len() != geom.node_count();
        if fresh {
            self.keys.clear();
            self.keys.resize(n, KEY_FRESH);
        }
        const CHUNK: usize = 4096;
        let keys = SyncPtr::new(&mut self.keys);
        let changed = (0..n.div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let mut changed = false;
                for p in c * CHUNK..((c + 1) * CHUNK).min(n) {
                    let key = if parts.member(p) {
                        let mut mask = 0u64;
                        let node0 = if fourth {
                            let s = Support::<K, D, true>::with_hessian(geom, parts.x[p], 0.0);
                            s.for_each(|n| {
                                if n.w > 0.0 || n.hess.iter().flatten().any(|&h| h != 0.0) {
                                    mask |= 1 << n.a;
                                }
                            });
                            s.first_node()
                        } else {
                            // the weights alone: no second derivatives on
                            // the 2nd-order path
                            let s = Support::<K, D>::new(geom, parts.x[p], 0.0);
                            s.for_each(|n| {
                                if n.w > 0.0 {
                                    mask |= 1 << n.a;
                                }
                            });
                            s.first_node()
                        };
                        ((node0 as u128) << 64) | mask as u128
                    } else {
                        KEY_NONE
                    };
                    // SAFETY: particle p belongs to this chunk only.
                    let slot = unsafe { keys.at(p) };
                    if *slot != key {
                        *slot = key;
                        changed = true;
                    }
                }
                changed
            })
            .reduce(|| false, |a, b| a || b);
        changed || fresh
    }

    /// Sets the unknowns to the nodes the particles' supports reach with
    /// positive weight (the GIMP window and the knots of B-splines include
    /// nodes at exactly zero weight, whose rows would be singular) and, if
    /// they are not the unknowns already, rebuilds the sparsity pattern and
    /// the position table; returns whether it did.
    fn set_active<K: Kernel>(&mut self, geom: &GridGeom<D>) -> bool {
        let nodes = geom.node_count();
        let mut active = vec![false; nodes];
        for &key in &self.keys {
            if key >= KEY_FRESH {
                continue;
            }
            let base = (key >> 64) as usize;
            for a in 0..Support::<K, D>::LEN {
                if key & (1 << a) != 0 {
                    active[base + Support::<K, D>::local_offset(geom, a)] = true;
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
        // one support, i.e. within K::N − 1 nodes along each axis. The
        // offsets run x fastest, so the rows of a column come in ascending
        // node (and dof) order.
        let (w, side, cube) = stencil::<K, D>();
        self.reach = w as usize;
        self.col_ptr.clear();
        self.row_idx.clear();
        self.diag.clear();
        self.nbr.clear();
        self.nbr.resize(self.dofs.len() * cube, u32::MAX);
        self.col_ptr.push(0);
        for (col, &node) in self.dofs.iter().enumerate() {
            let at = geom.node_coords(node as usize);
            'offsets: for k in 0..cube {
                let (mut rest, mut other) = (k, 0isize);
                let mut stride = 1isize;
                for d in 0..D {
                    let c = at[d] as isize + (rest % side) as isize - w;
                    rest /= side;
                    if c < 0 || c >= geom.nodes[d] as isize {
                        continue 'offsets;
                    }
                    other += c * stride;
                    stride *= geom.nodes[d] as isize;
                }
                let other = other as usize;
                let d = self.dof_of[other];
                if d != u32::MAX && other >= node as usize {
                    if other == node as usize {
                        self.diag.push(self.row_idx.len() as u32);
                    }
                    self.nbr[col * cube + k] = self.row_idx.len() as u32;
                    self.row_idx.push(d as usize);
                }
            }
            self.col_ptr.push(self.row_idx.len());
        }
        self.forget_analysis();
        self.multigrid = None;
        self.last.clear();
        true
    }

    /// Assembles K and F (eq. 57) from the particles.
    ///
    /// The unknowns are the nodes of the particles' footprints. Each
    /// particle's footprint key (its support's first node and footprint
    /// mask) is compared with the last assembly's, and only when one changed
    /// is the node set made again; then the terms are added onto the
    /// pattern of that node set. Once the node set has held for
    /// [`SPECULATE_AFTER`] assemblies, the pass that adds the terms (onto
    /// the last pattern) finds the keys too, from the support it evaluates
    /// anyway, and the terms are added a second time only if the node set
    /// turns out new. Every entry of K and F receives the same terms in the
    /// same order either way, so the bits do not depend on the path.
    pub fn assemble<K: Kernel>(
        &mut self,
        geom: &GridGeom<D>,
        parts: &FieldParticles<D>,
        p: &PhaseFieldParams,
    ) {
        if D == 2 {
            self.assemble_in::<K, S2>(geom, parts, p)
        } else {
            self.assemble_in::<K, S3>(geom, parts, p)
        }
    }

    /// [`Self::assemble`] with per-particle tables of `S` ≥ N^D entries.
    fn assemble_in<K: Kernel, const S: usize>(
        &mut self,
        geom: &GridGeom<D>,
        parts: &FieldParticles<D>,
        p: &PhaseFieldParams,
    ) {
        assert!(Support::<K, D>::LEN <= S);
        let t0 = Instant::now();
        self.refine = K::REFINE;
        self.grid_nodes = geom.nodes;
        let n = parts.x.len();
        let fresh = self.keys.len() != n || self.dof_of.len() != geom.node_count();
        // The single pass writes the keys of the particles it visits: with
        // bins, those they list, which must be every particle once (they
        // are the simulation's, and `parts.x` all its particles).
        let one_pass = !fresh
            && self.node_set_kept >= SPECULATE_AFTER
            && parts.bins.is_none_or(|b| b.order.len() == n);
        if one_pass {
            let changed = self.add_terms::<K, S, true>(geom, parts, p);
            if changed && self.set_active::<K>(geom) {
                // the terms went onto the old pattern: add them again
                self.add_terms::<K, S, false>(geom, parts, p);
                self.node_set_kept = 0;
            } else {
                self.node_set_kept = self.node_set_kept.saturating_add(1);
            }
        } else {
            let renumbered =
                self.update_keys::<K>(geom, parts, p.fourth::<D>()) && self.set_active::<K>(geom);
            self.node_set_kept = if renumbered && !fresh {
                0
            } else {
                self.node_set_kept.saturating_add(1)
            };
            self.add_terms::<K, S, false>(geom, parts, p);
        }
        // A node at the fringe of the particles' supports sees only tiny
        // weights: its row is all but singular, and round-off in the
        // factorization can leave a negative pivot (seen on a fast disk in
        // contact). The penalty δ(c_I − 1) with δ = PIVOT_FLOOR·max K_II
        // holds such nodes at the undamaged c = 1 and changes c at
        // well-supported nodes by a relative 1e-12.
        let max_diag = self
            .diag
            .iter()
            .map(|&k| self.values[k as usize])
            .fold(0.0, f64::max);
        let delta = PIVOT_FLOOR * max_diag;
        for (d, &k) in self.diag.iter().enumerate() {
            self.values[k as usize] += delta;
            self.rhs[d] += delta;
        }
        self.stats.assembly += t0.elapsed().as_secs_f64();
    }

    /// One pass over the particles: K and F from zero on the present
    /// pattern and, with `KEYS`, the particles' footprint keys (the caller
    /// has checked that the pass visits every particle once). Returns
    /// whether a key changed (false without `KEYS`).
    fn add_terms<K: Kernel, const S: usize, const KEYS: bool>(
        &mut self,
        geom: &GridGeom<D>,
        parts: &FieldParticles<D>,
        p: &PhaseFieldParams,
    ) -> bool {
        self.values.clear();
        self.values.resize(self.row_idx.len(), 0.0);
        self.rhs.clear();
        self.rhs.resize(self.dofs.len(), 0.0);
        let ctx = Accumulate {
            geom,
            parts,
            params: p,
            m: p.voigt6::<D>(),
            fourth: p.fourth::<D>(),
            dof_of: &self.dof_of,
            nbr: &self.nbr,
            keys: SyncPtr::new(&mut self.keys),
            values: SyncPtr::new(&mut self.values),
            rhs: SyncPtr::new(&mut self.rhs),
        };
        match parts.bins {
            Some(bins) => {
                let mut changed = false;
                for colour in &bins.colours {
                    // whether a key changed: an `or`, the same for any
                    // split of the tiles among threads
                    changed |= colour
                        .par_iter()
                        .map(|&tile| {
                            let mut blk = CellBlock::<S>::new();
                            let mut changed = false;
                            for &q in bins.particles_of(tile) {
                                // SAFETY: particles of same-colour tiles
                                // share no node, hence no matrix entry, and
                                // the block holds one of the tile's cells;
                                // colours run in turn; the bins list each
                                // particle once, so its key is this task's.
                                changed |=
                                    unsafe { ctx.particle::<K, S, KEYS>(q as usize, &mut blk) };
                            }
                            // SAFETY: as above.
                            unsafe { ctx.flush::<K, S>(&mut blk) };
                            changed
                        })
                        .reduce(|| false, |a, b| a || b);
                }
                changed
            }
            None => {
                let mut blk = CellBlock::<S>::new();
                let mut changed = false;
                for q in 0..parts.x.len() {
                    // SAFETY: serial.
                    changed |= unsafe { ctx.particle::<K, S, KEYS>(q, &mut blk) };
                }
                // SAFETY: serial.
                unsafe { ctx.flush::<K, S>(&mut blk) };
                changed
            }
        }
    }

    /// The relative phase-field residual that a history update leaves,
    /// ‖ΔK c‖ / ‖F‖ with ΔK c = Σ_p w_p N_I(x_p) (Kakouris & Triantafyllou eq. 50 with the
    /// K of eq. 57: only its reaction term depends on H, so for a history
    /// increment ΔH_p the caller passes w_p = V_p·4l₀(1−k_f)ΔH_p/Ḡc·c_p,
    /// zero where H did not grow). ‖F‖ is that of the last assembly; 0 if
    /// there was none. Scattered over the bins' colours when `parts` has
    /// bins, serially otherwise.
    pub fn history_residual<K: Kernel>(
        &mut self,
        geom: &GridGeom<D>,
        parts: &FieldParticles<D>,
        w: &[f64],
    ) -> f64 {
        let norm_f = self
            .rhs
            .iter()
            .map(|f| f * f)
            .fold(0.0, |a, b| a + b)
            .sqrt();
        if norm_f == 0.0 {
            return 0.0;
        }
        self.scratch.resize(geom.node_count(), 0.0);
        let r = SyncPtr::new(&mut self.scratch);
        let add = |q: usize| {
            if w[q] == 0.0 || !parts.member(q) {
                return;
            }
            Support::<K, D>::new(geom, parts.x[q], 0.0).for_each(|n| {
                // SAFETY: the caller's colouring (or a serial loop).
                unsafe { *r.at(n.node) += w[q] * n.w };
            });
        };
        match parts.bins {
            Some(bins) => {
                for colour in &bins.colours {
                    // particles of same-colour tiles share no node
                    colour.par_iter().for_each(|&tile| {
                        bins.particles_of(tile)
                            .iter()
                            .for_each(|&q| add(q as usize))
                    });
                }
            }
            None => (0..parts.x.len()).for_each(add),
        }
        let mut sum = 0.0;
        for v in &mut self.scratch {
            sum += *v * *v;
            *v = 0.0;
        }
        sum.sqrt() / norm_f
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
        self.solve_with(nodes, SolveMethod::Direct)
    }

    /// Solves for c with the given method; c at every grid node (1 where
    /// inactive).
    pub fn solve_with(
        &mut self,
        nodes: usize,
        method: SolveMethod,
    ) -> Result<Vec<f64>, PhaseFieldError> {
        let mut c = Vec::new();
        self.solve_into(nodes, method, &mut c)?;
        Ok(c)
    }

    /// [`Self::solve_with`] into `c` (resized to `nodes`), which a caller
    /// keeps between steps.
    ///
    /// When the node set has changed since the last solve, PCG starts from
    /// the `c` the caller kept (last step's, at every grid node) rather than
    /// from zero.
    pub fn solve_into(
        &mut self,
        nodes: usize,
        method: SolveMethod,
        c: &mut Vec<f64>,
    ) -> Result<(), PhaseFieldError> {
        let n = self.dofs.len();
        if self.last.len() != n && c.len() == nodes && n > 0 {
            // A body whose edges cross the grid changes its node set every
            // few steps (`p3_sphere_beam.toml` at h = l0/4: every other step); its c has
            // barely changed.
            self.last.clear();
            self.last.extend(self.dofs.iter().map(|&d| c[d as usize]));
        }
        c.clear();
        c.resize(nodes, 1.0);
        if n == 0 {
            return Ok(());
        }
        match method {
            SolveMethod::Auto {
                tolerance,
                max_iterations,
                refactor_after,
            } => match self.auto.choice {
                Some(AutoChoice::Factor) => self.solve_method(SolveMethod::Pcg {
                    tolerance,
                    max_iterations,
                    refactor_after,
                })?,
                Some(AutoChoice::Multigrid) => self.solve_method(SolveMethod::Multigrid {
                    tolerance,
                    max_iterations,
                    rebuild_after: refactor_after,
                })?,
                None => self.auto_trial(tolerance, max_iterations, refactor_after)?,
            },
            m => self.solve_method(m)?,
        }
        // the solution is in `x`
        for (d, &node) in self.dofs.iter().enumerate() {
            c[node as usize] = self.x[d];
        }
        std::mem::swap(&mut self.last, &mut self.x);
        Ok(())
    }

    /// One solve by `method` (not `Auto`) from `last`, into `x`.
    fn solve_method(&mut self, method: SolveMethod) -> Result<(), PhaseFieldError> {
        let n = self.dofs.len();
        let method = match method {
            SolveMethod::Multigrid {
                tolerance,
                max_iterations,
                rebuild_after,
            } if self.multigrid_declined => SolveMethod::Pcg {
                tolerance,
                max_iterations,
                refactor_after: rebuild_after,
            },
            m => m,
        };
        self.use_multigrid = matches!(method, SolveMethod::Multigrid { .. });
        match method {
            SolveMethod::Multigrid {
                tolerance,
                max_iterations,
                rebuild_after,
            } => self.multigrid_solve(tolerance, max_iterations, rebuild_after)?,
            SolveMethod::Pcg {
                tolerance,
                max_iterations,
                refactor_after,
            } if self.factored && self.last.len() == n && !self.refactor_next => {
                // With the old factor PCG may spend up to two
                // factorizations' worth of iterations before a fresh
                // factor is made.
                let cap = max_iterations.min(2 * refactor_after.max(1));
                let (converged, iterations) = self.timed_pcg(tolerance, cap);
                // The renewal rule: as the history grows the old factor
                // preconditions worse and the iterations climb. Refactorize
                // when a solve costs more than the average per solve since
                // the last factorization (which counts as `refactor_after`
                // iterations): that keeps the average near its minimum.
                // Counted in iterations, not seconds, so runs repeat exactly.
                self.count_cycle(iterations);
                // A converged solve is kept however many iterations it
                // took: they are spent, and the rule above renews the factor
                // for the next step (redoing the slow ones costs more; the
                // measurement is in docs/phase-field.md). Without
                // convergence within the cap: a fresh factor, which also
                // preconditions the next steps.
                if !converged {
                    self.renew(tolerance, max_iterations, refactor_after)?;
                }
            }
            SolveMethod::Pcg {
                tolerance,
                max_iterations,
                refactor_after,
            } => self.renew(tolerance, max_iterations, refactor_after)?,
            SolveMethod::Direct => self.direct()?,
            SolveMethod::Auto { .. } => {
                return Err(PhaseFieldError::Solver(
                    "method auto resolves to pcg or multigrid before a solve".into(),
                ))
            }
        }
        Ok(())
    }

    /// One solve of method "auto"'s trial: PCG with the factor, whose
    /// solution is kept in `x`, then the multigrid on the same system from
    /// the same start, timed, with its own renewal rule and its solution and
    /// counts dropped (its seconds go to [`SolveStats::auto_trial`]). After
    /// [`AUTO_TRIAL_SOLVES`] solves, or once the multigrid has declined
    /// this system, the method that took less time is chosen.
    fn auto_trial(
        &mut self,
        tolerance: f64,
        max_iterations: usize,
        refactor_after: usize,
    ) -> Result<(), PhaseFieldError> {
        let t0 = Instant::now();
        self.solve_method(SolveMethod::Pcg {
            tolerance,
            max_iterations,
            refactor_after,
        })?;
        self.auto.factor_seconds += t0.elapsed().as_secs_f64();
        if !self.multigrid_declined {
            let kept = self.stats;
            std::mem::swap(&mut self.x, &mut self.auto.x);
            self.swap_renewal();
            self.use_multigrid = true;
            let t1 = Instant::now();
            let converged = self.multigrid_attempt(tolerance, max_iterations, refactor_after);
            let seconds = t1.elapsed().as_secs_f64();
            self.use_multigrid = false;
            self.swap_renewal();
            std::mem::swap(&mut self.x, &mut self.auto.x);
            self.stats = kept;
            self.stats.auto_trial += seconds;
            self.auto.multigrid_seconds += seconds;
            if !converged {
                // a fresh hierarchy that does not converge would have
                // cost a direct solve on top
                self.multigrid_declined = true;
                self.multigrid = None;
            }
        }
        self.auto.solves += 1;
        if self.multigrid_declined || self.auto.solves >= AUTO_TRIAL_SOLVES {
            self.auto_choose();
        }
        Ok(())
    }

    /// Ends method "auto"'s trial: the faster method goes on alone, and the
    /// other's memory (the factor's values, or the hierarchy) is freed.
    fn auto_choose(&mut self) {
        let a = &mut self.auto;
        let choice = if !self.multigrid_declined && a.multigrid_seconds < a.factor_seconds {
            AutoChoice::Multigrid
        } else {
            AutoChoice::Factor
        };
        tracing::info!(
            unknowns = self.dofs.len(),
            solves = a.solves,
            factor_s = a.factor_seconds,
            multigrid_s = a.multigrid_seconds,
            declined = self.multigrid_declined,
            ?choice,
            "phase-field method auto: chosen"
        );
        a.choice = Some(choice);
        a.x = Vec::new();
        match choice {
            AutoChoice::Multigrid => {
                self.swap_renewal();
                // should the multigrid decline later, PCG makes a factor anew
                self.factored = false;
                self.l_values = Vec::new();
                self.l_single = Vec::new();
                self.split = None;
                self.stats.auto_multigrid += 1;
            }
            AutoChoice::Factor => {
                self.multigrid = None;
                self.stats.auto_factor += 1;
            }
        }
    }

    /// Exchanges the live renewal rule with the one method "auto"'s trial
    /// keeps for the multigrid.
    fn swap_renewal(&mut self) {
        let (cost, solves, next) = self.auto.renewal;
        self.auto.renewal = (self.cycle_cost, self.cycle_solves, self.refactor_next);
        self.cycle_cost = cost;
        self.cycle_solves = solves;
        self.refactor_next = next;
    }

    /// What method "auto" chose for this system (None: still in its trial,
    /// or another method).
    pub fn auto_choice(&self) -> Option<AutoChoice> {
        self.auto.choice
    }

    /// Ends method "auto"'s trial now with `choice` rather than the one its
    /// seconds would make (a trial's choice rests on the machine's speed;
    /// this lets a test follow each hand-over). No effect after the choice.
    #[doc(hidden)]
    pub fn choose_auto(&mut self, choice: AutoChoice) {
        if self.auto.choice.is_some() {
            return;
        }
        let a = &mut self.auto;
        (a.factor_seconds, a.multigrid_seconds) = match choice {
            AutoChoice::Factor => (0.0, 1.0),
            AutoChoice::Multigrid => (1.0, 0.0),
        };
        self.auto_choose();
    }

    /// PCG's fresh start, which begins a new cycle of its renewal rule: a
    /// factorization (counted as `refactor_after` iterations) and PCG
    /// preconditioned by its f32 rounding, from the last solution. Should
    /// PCG not converge even so, a direct solve with the same factor in f64
    /// (no second factorization). The solution is left in `x`.
    fn renew(
        &mut self,
        tolerance: f64,
        max_iterations: usize,
        refactor_after: usize,
    ) -> Result<(), PhaseFieldError> {
        // the factorization is in f64: where it fails, a direct solve would too
        self.factorize(true)?;
        let (converged, iterations) = self.timed_pcg(tolerance, max_iterations);
        self.cycle_cost = (refactor_after + iterations.max(1)) as f64;
        self.cycle_solves = 1;
        if !converged {
            self.stats.fallbacks += 1;
            self.single = false;
            if let Some(split) = self.split.as_ref().filter(|_| !self.double_current) {
                split.write(&mut self.l_values, |v| v);
                self.double_current = true;
            }
            self.solve_with_factor();
        }
        Ok(())
    }

    /// The renewal rule's bookkeeping after a solve with an old
    /// preconditioner: renew for the next step when this solve cost more
    /// than the average since the last renewal (which counts as its cost
    /// in iterations). Counted in iterations, not seconds, so runs repeat
    /// exactly.
    fn count_cycle(&mut self, iterations: usize) {
        self.cycle_cost += iterations as f64;
        self.cycle_solves += 1;
        self.refactor_next = iterations as f64 > self.cycle_cost / self.cycle_solves as f64;
    }

    /// Method "multigrid": PCG with the hierarchy, refreshed with today's
    /// matrix, or built anew (new nodes, the renewal rule, or a solve that
    /// did not converge within `2·rebuild_after` iterations); a direct
    /// solve if even a fresh hierarchy does not converge within
    /// `max_iterations`. The solution is left in `x`.
    ///
    /// A fresh hierarchy that needs more than `rebuild_after` iterations
    /// from a warm start is not worth its build; after [`POOR_BUILDS`] such
    /// builds in a row this system goes on with PCG and the factor for
    /// good (one alone can be a large change of the history in one step:
    /// `p3_sphere_beam.toml` at h = l₀/4 handed over at 36.5 µs on a single one, and ran the
    /// next 10 steps from its checkpoint with 4.35 iterations per solve).
    /// Poor builds in a row happen once a crack has
    /// opened: its stretched particles push the reaction term 4l₀H/Ḡc orders
    /// of magnitude above the diffusion, K is a mass matrix there, and its
    /// high-frequency modes are the ones neither the smoother nor the coarse
    /// levels reach (`p1_plate.toml` at 42 µs: 16.7 iterations per solve with a fresh
    /// hierarchy every step, Gauss-Seidel smoothing no better; the module
    /// doc of [`super::multigrid`] and `docs/phase-field-performance.md`,
    /// "Multigrid").
    fn multigrid_solve(
        &mut self,
        tolerance: f64,
        max_iterations: usize,
        rebuild_after: usize,
    ) -> Result<(), PhaseFieldError> {
        if self.multigrid_attempt(tolerance, max_iterations, rebuild_after) {
            return Ok(());
        }
        let n = self.dofs.len();
        tracing::debug!(
            unknowns = n,
            "phase-field multigrid: PCG did not converge with a fresh hierarchy; solving directly"
        );
        self.use_multigrid = false;
        self.stats.fallbacks += 1;
        self.direct()
    }

    /// [`Self::multigrid_solve`] but its direct solve: whether PCG with
    /// the hierarchy (refreshed, or fresh) converged.
    fn multigrid_attempt(
        &mut self,
        tolerance: f64,
        max_iterations: usize,
        rebuild_after: usize,
    ) -> bool {
        let n = self.dofs.len();
        if let Some(mg) = self
            .multigrid
            .as_mut()
            .filter(|_| self.last.len() == n && !self.refactor_next)
        {
            let t0 = Instant::now();
            let refreshed = mg.refresh(&self.values);
            self.stats.solve += t0.elapsed().as_secs_f64();
            if refreshed.is_ok() {
                let (converged, iterations) =
                    self.timed_pcg(tolerance, max_iterations.min(2 * rebuild_after.max(1)));
                self.count_cycle(iterations);
                if converged {
                    return true;
                }
            }
        }
        let warm = self.last.len() == n;
        let t0 = Instant::now();
        let built = Multigrid::build(
            self.refine,
            self.grid_nodes,
            &self.dofs,
            &self.col_ptr,
            &self.row_idx,
            &self.values,
        );
        self.stats.factorization += t0.elapsed().as_secs_f64();
        self.stats.factorizations += 1;
        self.refactor_next = false;
        let (converged, iterations) = match built {
            Ok(mg) => {
                self.multigrid = Some(mg);
                self.timed_pcg(tolerance, max_iterations)
            }
            Err(e) => {
                // e.g. a body one or two nodes thick, whose levels stop
                // shrinking: the factor for good
                tracing::warn!(reason = %e, "phase-field multigrid: no hierarchy; PCG goes on with the factor");
                self.multigrid_declined = true;
                self.multigrid = None;
                (false, 0)
            }
        };
        self.cycle_cost = (rebuild_after + iterations.max(1)) as f64;
        self.cycle_solves = 1;
        if warm {
            self.multigrid_poor = if iterations > rebuild_after {
                self.multigrid_poor + 1
            } else {
                0
            };
        }
        if self.multigrid_poor >= POOR_BUILDS {
            tracing::info!(unknowns = n, iterations, "phase-field multigrid: fresh hierarchies took more iterations than they cost; PCG goes on with the factor");
            self.multigrid_declined = true;
            self.multigrid = None;
            self.refactor_next = true;
        }
        converged
    }

    fn timed_pcg(&mut self, tolerance: f64, max_iterations: usize) -> (bool, usize) {
        let t0 = Instant::now();
        let (converged, iterations) = self.pcg(tolerance, max_iterations);
        self.stats.solve += t0.elapsed().as_secs_f64();
        self.stats.pcg_solves += 1;
        self.stats.pcg_iterations += iterations as u64;
        (converged, iterations)
    }

    /// An f64 factorization and the solve with it, into `x`.
    fn direct(&mut self) -> Result<(), PhaseFieldError> {
        self.factorize(false)?;
        self.solve_with_factor();
        Ok(())
    }

    /// x = K⁻¹ F with the stored factor.
    fn solve_with_factor(&mut self) {
        let t0 = Instant::now();
        let mut x = std::mem::take(&mut self.x);
        x.clear();
        x.extend_from_slice(&self.rhs);
        self.apply_inverse(&mut x);
        self.x = x;
        self.stats.solve += t0.elapsed().as_secs_f64();
    }

    /// Analysis (if the pattern is new) and numeric factorization, in f32
    /// if `single`: in two halves at once with `ordering = "dissection"`
    /// where the unknowns have a cut ([`SplitCholesky`]), else one
    /// factorization with faer's AMD ordering.
    fn factorize(&mut self, single: bool) -> Result<(), PhaseFieldError> {
        let n = self.dofs.len();
        let t0 = Instant::now();
        let want_split = self.ordering == FactorOrdering::Dissection && !self.split_declined;
        if want_split && self.split.as_ref().is_none_or(|s| s.solve().len() != n) {
            self.split = SplitCholesky::analyse(
                &self.col_ptr,
                &self.row_idx,
                &self.dofs,
                self.grid_nodes,
                self.reach,
            )?;
            match &self.split {
                Some(split) => {
                    let [top, g0, g1] = split.solve().share_work();
                    tracing::debug!(
                        unknowns = n,
                        sides = ?split.sizes(),
                        factor_values = split.len_val(),
                        multiply_adds = split.solve().multiply_adds(),
                        top,
                        group0 = g0,
                        group1 = g1,
                        "phase-field analysis: nested dissection, two halves"
                    );
                    self.stats.analyses += 1;
                }
                None => {
                    tracing::debug!(unknowns = n, "phase-field analysis: no cut, one factor");
                    self.split_declined = true;
                }
            }
        }
        let split = self.split.is_some() && !self.split_declined;
        if !split && self.symbolic.as_ref().is_none_or(|s| s.nrows() != n) {
            let pattern =
                SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
            // supernodal always, for the solves of `trisolve`
            let params = CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                ..Default::default()
            };
            let sym =
                factorize_symbolic_cholesky(pattern, Side::Lower, SymmetricOrdering::Amd, params)
                    .map_err(|e| PhaseFieldError::Solver(format!("symbolic analysis: {e:?}")))?;
            let req = sym.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default());
            self.mem = MemBuffer::try_new(req)
                .map_err(|e| PhaseFieldError::Solver(format!("workspace: {e:?}")))?;
            let tri = SupernodalSolve::new(&sym)
                .ok_or_else(|| PhaseFieldError::Solver("the analysis is not supernodal".into()))?;
            let [top, g0, g1] = tri.share_work();
            tracing::debug!(
                unknowns = n,
                factor_values = tri.len_val(),
                multiply_adds = tri.multiply_adds(),
                top,
                group0 = g0,
                group1 = g1,
                "phase-field analysis: the triangular solves' shares"
            );
            self.trisolve = Some(tri);
            self.symbolic = Some(sym);
            self.stats.analyses += 1;
        }
        let t1 = Instant::now();
        self.stats.analysis += (t1 - t0).as_secs_f64();
        self.factored = false;
        let made = if let Some(split) = self.split.as_mut().filter(|_| split) {
            let made = split.factorize(&self.values);
            if made.is_ok() {
                if single {
                    split.write(&mut self.l_single, to_single);
                } else {
                    split.write(&mut self.l_values, |v| v);
                }
            }
            self.double_current = !single;
            made
        } else {
            let sym = self
                .symbolic
                .as_ref()
                .ok_or_else(|| PhaseFieldError::Solver("no analysis".into()))?;
            let pattern =
                SymbolicSparseColMatRef::new_checked(n, n, &self.col_ptr, None, &self.row_idx);
            let made = numeric_llt(
                sym,
                pattern,
                &self.values,
                &mut self.l_values,
                &mut self.mem,
            );
            if made.is_ok() && single {
                round_to_single(&self.l_values, &mut self.l_single);
            }
            self.double_current = true;
            made
        };
        let seconds = t1.elapsed().as_secs_f64();
        // a failed attempt's time is spent too
        self.stats.factorization += seconds;
        made?;
        self.single = single;
        self.factored = true;
        self.refactor_next = false;
        self.stats.factorizations += 1;
        if single {
            self.stats.preconditioner_factorizations += 1;
            self.stats.preconditioner_factorization += seconds;
        } else {
            self.stats.direct_factorizations += 1;
            self.stats.direct_factorization += seconds;
        }
        tracing::debug!(
            unknowns = n,
            preconditioner = single,
            seconds,
            "phase-field numeric factorization"
        );
        Ok(())
    }

    /// One numeric factorization of today's matrix of the given kind (the
    /// symbolic analysis first if the node set is new), counted in
    /// [`Self::stats`] like a run's: what `cleave bench-phase-field` times.
    /// Leaves the factor in place, so PCG goes on with it.
    pub fn factorize_kind(&mut self, kind: FactorKind) -> Result<(), PhaseFieldError> {
        if self.dofs.is_empty() {
            return Ok(());
        }
        self.factorize(kind == FactorKind::Preconditioner)
    }

    /// x ← (L Lᵀ)⁻¹ x with the stored factor, or one V-cycle.
    fn apply_inverse(&mut self, x: &mut [f64]) {
        if self.use_multigrid {
            if let Some(mg) = self.multigrid.as_mut() {
                mg.apply(x);
                return;
            }
        }
        let tri = match &self.split {
            Some(split) if !self.split_declined => split.solve(),
            _ => match &self.trisolve {
                Some(tri) => tri,
                None => return,
            },
        };
        if self.single {
            tri.solve(&self.l_single, x, &mut self.scratch_single);
        } else {
            tri.solve(&self.l_values, x, &mut self.scratch_double);
        }
    }

    /// y = K x with the stored lower triangle (with the multigrid: its
    /// finest level, the same matrix by rows).
    fn multiply(&self, x: &[f64], y: &mut [f64]) {
        if self.use_multigrid {
            if let Some(mg) = self.multigrid.as_ref() {
                mg.multiply(x, y);
                return;
            }
        }
        y.fill(0.0);
        for col in 0..x.len() {
            for k in self.col_ptr[col]..self.col_ptr[col + 1] {
                let (row, v) = (self.row_idx[k], self.values[k]);
                y[row] += v * x[col];
                if row != col {
                    y[col] += v * x[row];
                }
            }
        }
    }

    /// Preconditioned conjugate gradients from the last solution, into
    /// `x`. Returns whether it converged, and the iterations taken.
    fn pcg(&mut self, tolerance: f64, max_iterations: usize) -> (bool, usize) {
        let n = self.dofs.len();
        let mut x = std::mem::take(&mut self.x);
        let mut w = std::mem::take(&mut self.work);
        x.clear();
        if self.last.len() == n {
            x.extend_from_slice(&self.last);
        } else {
            x.resize(n, 0.0);
        }
        let result = self.pcg_iterate(&mut x, &mut w, tolerance, max_iterations);
        self.x = x;
        self.work = w;
        result
    }

    fn pcg_iterate(
        &mut self,
        x: &mut [f64],
        w: &mut PcgWork,
        tolerance: f64,
        max_iterations: usize,
    ) -> (bool, usize) {
        let n = x.len();
        let dot =
            |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).fold(0.0, |s, t| s + t);
        let norm_b = dot(&self.rhs, &self.rhs).sqrt();
        let PcgWork { ap, r, z, p } = w;
        for v in [&mut *ap, &mut *r, &mut *z, &mut *p] {
            v.clear();
            v.resize(n, 0.0);
        }
        self.multiply(x, ap);
        for i in 0..n {
            r[i] = self.rhs[i] - ap[i];
        }
        if dot(r, r).sqrt() <= tolerance * norm_b {
            return (true, 0);
        }
        z.copy_from_slice(r);
        self.apply_inverse(z);
        p.copy_from_slice(z);
        let mut rz = dot(r, z);
        if !(rz > 0.0) {
            return (false, 0);
        }
        for it in 1..=max_iterations {
            self.multiply(p, ap);
            let pap = dot(p, ap);
            if !(pap > 0.0) {
                return (false, it);
            }
            let alpha = rz / pap;
            for i in 0..n {
                x[i] += alpha * p[i];
                r[i] -= alpha * ap[i];
            }
            if dot(r, r).sqrt() <= tolerance * norm_b {
                return (true, it);
            }
            z.copy_from_slice(r);
            self.apply_inverse(z);
            let rz_new = dot(r, z);
            if !(rz_new > 0.0) {
                // Both preconditioners are positive definite; this is
                // round-off on a residual near zero, or a NaN.
                tracing::debug!(iteration = it, rz = rz_new, "PCG: rᵀz is not positive");
                return (false, it);
            }
            let beta = rz_new / rz;
            rz = rz_new;
            for i in 0..n {
                p[i] = z[i] + beta * p[i];
            }
        }
        (false, max_iterations)
    }
}

/// PCG's work vectors (the product K p, the residual, the preconditioned
/// residual and the search direction).
#[derive(Debug, Default)]
struct PcgWork {
    ap: Vec<f64>,
    r: Vec<f64>,
    z: Vec<f64>,
    p: Vec<f64>,
}

/// `l` rounded to f32 into `single`, with what would be subnormal in f32
/// (below `f32::MIN_POSITIVE` in magnitude, ~1.2e-38) flushed to zero, so
/// that the triangular solves meet no subnormal operand in the factor.
/// An entry that small is more than 30 orders of magnitude below the
/// factor's diagonal here: dropping it changes the preconditioner by far
/// less than the rounding to f32 does.
///
/// In chunks on rayon's threads (45.5 M values at `p1_plate.toml`'s size, once per
/// factorization); each value is rounded on its own, so the bits do not
/// depend on the thread count.
pub fn round_to_single(l: &[f64], single: &mut Vec<f32>) {
    const CHUNK: usize = 1 << 16;
    single.resize(l.len(), 0.0);
    single
        .par_chunks_mut(CHUNK)
        .zip(l.par_chunks(CHUNK))
        .for_each(|(s, l)| {
            for (s, &v) in s.iter_mut().zip(l) {
                *s = to_single(v);
            }
        });
}

/// One value of [`round_to_single`].
#[inline]
pub fn to_single(v: f64) -> f32 {
    if v.abs() < f32::MIN_POSITIVE as f64 {
        0.0
    } else {
        v as f32
    }
}

/// The numeric factorization of `values` (on `pattern`, lower triangle)
/// into `l`, in f64.
fn numeric_llt(
    sym: &SymbolicCholesky<usize>,
    pattern: SymbolicSparseColMatRef<'_, usize>,
    values: &[f64],
    l: &mut Vec<f64>,
    mem: &mut MemBuffer,
) -> Result<(), PhaseFieldError> {
    l.resize(sym.len_val(), 0.0);
    let a = SparseColMatRef::new(pattern, values);
    sym.factorize_numeric_llt::<f64>(
        l,
        a,
        Side::Lower,
        LltRegularization::default(),
        Par::Seq,
        MemStack::new(mem),
        Default::default(),
    )
    .map(|_| ())
    .map_err(|e| PhaseFieldError::NotPositiveDefinite(format!("{e:?}")))
}

/// c at a point from nodal values (what the particles take after a solve;
/// the same value as [`field_at`]'s, without the derivatives).
#[inline]
pub fn value_at<K: Kernel, const D: usize>(geom: &GridGeom<D>, c: &[f64], x: [f64; D]) -> f64 {
    let mut v = 0.0;
    Support::<K, D>::new(geom, x, 0.0).for_each(|n| v += n.w * c[n.node]);
    v
}

/// c, ∇c and ∇²c in Voigt order (2D `[c,11, c,22, c,12]`, 3D `[c,11,
/// c,22, c,33, c,23, c,13, c,12]`, in the first of six entries) at a point
/// from nodal values.
pub fn field_at<K: Kernel, const D: usize>(
    geom: &GridGeom<D>,
    c: &[f64],
    x: [f64; D],
) -> (f64, [f64; D], [f64; 6]) {
    let (mut v, mut g, mut h) = (0.0, [0.0; D], [0.0; 6]);
    Support::<K, D, true>::with_hessian(geom, x, 0.0).for_each(|n| {
        let ci = c[n.node];
        v += n.w * ci;
        for d in 0..D {
            g[d] += n.grad[d] * ci;
        }
        let nh = n.hess_voigt6();
        for r in 0..voigt_len(D) {
            h[r] += nh[r] * ci;
        }
    });
    (v, g, h)
}

/// The crack density Z of eq. 4 at a point:
/// (c−1)²/(4l₀) + l₀|∇c|² + l₀³ (∇²c)ᵀ M (∇²c), with ∇²c as
/// [`field_at`] gives it.
pub fn crack_density<const D: usize>(
    p: &PhaseFieldParams,
    c: f64,
    g: [f64; D],
    h: [f64; 6],
) -> f64 {
    let (m, k) = (p.voigt6::<D>(), voigt_len(D));
    let quad: f64 = (0..k)
        .map(|i| (0..k).map(|j| h[i] * m[i][j] * h[j]).sum::<f64>())
        .sum();
    let mut g2 = g[0] * g[0];
    for d in 1..D {
        g2 += g[d] * g[d];
    }
    (c - 1.0).powi(2) / (4.0 * p.l0) + p.l0 * g2 + p.l0.powi(3) * quad
}

/// The fracture energy density Ḡc·Z (eq. 4) of the nodal field `c` at
/// `x`, J/m³: the integrand of Ψ_f.
pub fn fracture_energy_density<K: Kernel, const D: usize>(
    geom: &GridGeom<D>,
    c: &[f64],
    p: &PhaseFieldParams,
    x: [f64; D],
) -> f64 {
    let (cv, g, h) = field_at::<K, D>(geom, c, x);
    p.gc_bar * crack_density(p, cv, g, h)
}

/// Ψ_f = Σ_p V_p Ḡc Z_p over the particles for which `keep` holds, J.
pub fn fracture_energy<K: Kernel, const D: usize>(
    geom: &GridGeom<D>,
    c: &[f64],
    parts: &FieldParticles<D>,
    p: &PhaseFieldParams,
    keep: impl Fn([f64; D]) -> bool,
) -> f64 {
    (0..parts.x.len())
        .filter(|&q| parts.member(q) && keep(parts.x[q]))
        .map(|q| parts.vol[q] * fracture_energy_density::<K, D>(geom, c, p, parts.x[q]))
        .fold(0.0, |a, b| a + b) // (an empty f64 sum is −0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::shape::{CubicBspline, Gimp, Linear, QuadraticBspline};

    /// Particles at every sixth of a cell along each axis (the knots and
    /// cell centres of every kernel, where nodes of zero weight or zero
    /// Hessian sit) and at a shifted lattice inside the cells; every third
    /// one outside the field.
    fn lattice<const D: usize>(cells: usize, h: f64) -> (Vec<[f64; D]>, Vec<u16>) {
        let per_axis = 6 * cells;
        let mut x = Vec::new();
        for shift in [0.0, 0.37] {
            for i in 0..per_axis.pow(D as u32) {
                let mut rest = i;
                x.push(std::array::from_fn(|_| {
                    let k = rest % per_axis;
                    rest /= per_axis;
                    (k as f64 + shift) * h / 6.0
                }));
            }
        }
        let body = (0..x.len()).map(|p| u16::from(p % 3 == 2)).collect();
        (x, body)
    }

    /// The single pass's keys (from the support table it assembles with)
    /// are [`PhaseFieldSystem::update_keys`]'s, bit for bit, and so are K
    /// and F: a system assembles once (its keys in their own pass), forgets
    /// its keys, and assembles again in one pass, serially and by the bins.
    fn one_pass_finds_the_same_keys<K: Kernel, const D: usize>(fourth: bool) {
        let h = 0.25;
        let cells = if D == 2 { 6 } else { 3 };
        let geom = GridGeom::<D>::new([0.0; D], h, [cells; D]);
        let (x, body) = lattice::<D>(cells, h);
        let vol = vec![h.powi(D as i32) / 36.0; x.len()];
        let history: Vec<f64> = (0..x.len()).map(|p| (p % 7) as f64).collect();
        let mut gamma3 = Gamma3::default();
        let mut gamma = Gamma::default();
        if fourth {
            gamma.g1111 = 1.0;
            gamma.g2222 = 1.0;
            gamma.g1212 = 74.0;
            for r in 0..6 {
                gamma3.m[r][r] = 1.0 + r as f64;
            }
        }
        let params = PhaseFieldParams {
            gc_bar: 2.0,
            l0: 0.4,
            k_f: 1e-3,
            gamma,
            gamma3,
        };
        assert_eq!(params.fourth::<D>(), fourth);
        let bins = Bins::new(&geom, &x, K::N);
        for binned in [false, true] {
            let parts = FieldParticles {
                x: &x,
                vol: &vol,
                history: &history,
                body: Some((&body, 0)),
                bins: binned.then_some(&bins),
            };
            let mut sys = PhaseFieldSystem::<D>::new();
            sys.assemble::<K>(&geom, &parts, &params);
            let keys = sys.keys.clone();
            let values: Vec<u64> = sys.values.iter().map(|v| v.to_bits()).collect();
            let rhs: Vec<u64> = sys.rhs.iter().map(|v| v.to_bits()).collect();
            assert!(sys.node_set_kept >= SPECULATE_AFTER);
            assert!(keys.contains(&KEY_NONE));
            sys.keys.fill(KEY_FRESH);
            sys.assemble::<K>(&geom, &parts, &params);
            assert!(
                sys.keys == keys,
                "the keys, fourth {fourth}, binned {binned}"
            );
            assert!(sys.node_set_kept > SPECULATE_AFTER, "the node set was kept");
            let again: Vec<u64> = sys.values.iter().map(|v| v.to_bits()).collect();
            assert!(again == values, "K");
            assert!(sys.rhs.iter().map(|v| v.to_bits()).eq(rhs), "F");
        }
    }

    #[test]
    fn the_assembly_finds_the_footprint_keys_of_update_keys() {
        for fourth in [false, true] {
            one_pass_finds_the_same_keys::<Linear, 2>(fourth);
            one_pass_finds_the_same_keys::<Gimp, 2>(fourth);
            one_pass_finds_the_same_keys::<QuadraticBspline, 2>(fourth);
            one_pass_finds_the_same_keys::<CubicBspline, 2>(fourth);
            one_pass_finds_the_same_keys::<QuadraticBspline, 3>(fourth);
            one_pass_finds_the_same_keys::<CubicBspline, 3>(fourth);
        }
    }
}
