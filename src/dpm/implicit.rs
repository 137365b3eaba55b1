//! The static solve of the damage particle method (`integration =
//! "static"`): Wei & Chen solve the bar of their section 4.1 by "an
//! implicit incremental–iterative procedure"; this is one. Each load step
//! moves the held components and the loads to their values at the step's
//! end, then iterates to equilibrium f_int(d) = f_ext + m g on the free
//! components:
//!
//! 1. the strain of every cell (eq. 37), the damage it gives from the
//!    history of the last converged step (eqs. 2–6, 33: κ = max(κ_n, ε̃),
//!    so a trial that overshoots leaves nothing behind), the degraded
//!    stress (eq. 35) and the internal force (eq. 39);
//! 2. the out-of-balance force r on the free components; converged when
//!    its largest component is below `tolerance` × the force scale;
//! 3. else K Δd = r, d ← d + Δd, and back to 1, K the tangent
//!    Σ_L V_L [(1 − D_L) B̃_Lᵀ C B̃_L − D′(κ_L) (B̃_Lᵀ C ε_L)(∂ε̃/∂ε B̃_L)]
//!    (SCNI's smoothed gradients, eq. 38; the second term only on the
//!    cells whose damage grows in the trial), symmetrised: Newton's method
//!    (exact where ∂ε̃/∂ε is parallel to C ε, as in uniaxial tension).
//!    Where that matrix is not positive definite (a softening cell that
//!    the rest of the body cannot hold, near a snap-back), the secant
//!    stiffness K_s = Σ_L (1 − D_L) B̃_Lᵀ C B̃_L V_L instead for the
//!    iteration: the fixed-point method of damage mechanics, which
//!    converges linearly and slowly near a peak (docs/dpm.md measured it).
//!
//! Both are factored by faer's sparse Cholesky; their pattern (particles
//! sharing a cell) is fixed, the analysis (AMD ordering) is made once.
//! The secant stiffness is positive definite while every piece of a body
//! is held (a fully damaged cell adds nothing; a piece held by nothing
//! makes it singular: a clear error).
//!
//! The dissipation of a step is exact for linear softening under
//! proportional strain: with D(κ) of eq. 2, ψ₀(κ) dD/dκ is constant along
//! the path (ψ₀ = ½ ε:C:ε grows as κ²), so a cell dissipates
//! V ψ₀/κ² · κ₀κ_c/(κ_c − κ₀) · (κ_{n+1} − κ_n), which sums to ½ f_t κ_c V
//! (its G_F A_L under eq. 33) when it breaks, at any load step.

use super::explicit::{equivalent_strain, hooke, Explicit};
use crate::material::Elastic;
use crate::tensor::{contract, voigt};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::mat::MatMut;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, LltRef, SymbolicCholesky,
    SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, Par, Side};

/// No unknown: a held component.
const HELD: u32 = u32::MAX;

/// The damage state of the last converged step, restored before each
/// iteration's trial.
#[derive(Debug, Clone, Default)]
struct Committed<const D: usize> {
    kappa: Vec<f64>,
    kappa_c: Vec<f64>,
    normal: Vec<[f64; D]>,
    damage: Vec<f64>,
}

/// What a converged step did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Converged {
    pub iterations: u32,
    /// The energy the step's damage dissipated, J.
    pub dissipated: f64,
}

/// The static solve's matrices and scratch, made once for a run.
pub struct Equilibrium<const D: usize, const V: usize> {
    /// The unknown of each component (p D + a), or [`HELD`].
    unknown: Vec<u32>,
    /// The secant stiffness's lower triangle (CSC) on the unknowns.
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
    symbolic: SymbolicCholesky<usize>,
    factor: Vec<f64>,
    factor_mem: MemBuffer,
    solve_mem: MemBuffer,
    rhs: Vec<f64>,
    /// Per cell: each node's unit strains (node i, axis a at i D + a) and
    /// the stresses C gives them.
    eps: Vec<[f64; V]>,
    sig: Vec<[f64; V]>,
    pq: Vec<[f64; 2]>,
    committed: Committed<D>,
    tolerance: f64,
    max_iterations: u32,
    /// The smallest force scale, N: the strength on one cell face.
    floor: f64,
    /// The displacements and external forces at the start of the step
    /// (for the step's work).
    pub d_before: Vec<[f64; D]>,
    pub external_before: Vec<[f64; D]>,
    /// Iterations over the run so far.
    pub iterations: u64,
}

impl<const D: usize, const V: usize> Equilibrium<D, V> {
    /// The solve for `run`'s particles with its held components: the
    /// stiffness's pattern and its symbolic analysis. `floor` is the
    /// smallest force scale (N).
    pub fn new(
        run: &Explicit<D, V>,
        tolerance: f64,
        max_iterations: u32,
        floor: f64,
    ) -> Result<Self, String> {
        let n = run.d.len();
        let mut unknown = vec![0u32; n * D];
        for c in &run.held {
            unknown[c.particle as usize * D + c.axis as usize] = HELD;
        }
        let mut count = 0u32;
        for u in unknown.iter_mut() {
            if *u != HELD {
                *u = count;
                count += 1;
            }
        }
        // particles coupled by a cell: J's column holds the I ≥ J
        let mut adjacent: Vec<Vec<u32>> = vec![Vec::new(); n];
        let mut widest = 0;
        for l in 0..run.scni.len() {
            let (nodes, _) = run.scni.gradients(l);
            widest = widest.max(nodes.len());
            for &j in nodes {
                let list = &mut adjacent[j as usize];
                list.extend(nodes.iter().copied().filter(|&i| i >= j));
            }
        }
        let (mut col_ptr, mut row_idx) = (vec![0usize], Vec::new());
        for (j, list) in adjacent.iter_mut().enumerate() {
            list.sort_unstable();
            list.dedup();
            for b in 0..D {
                let col = unknown[j * D + b];
                if col == HELD {
                    continue;
                }
                for &i in list.iter() {
                    for a in 0..D {
                        let row = unknown[i as usize * D + a];
                        if row != HELD && row >= col {
                            row_idx.push(row as usize);
                        }
                    }
                }
                col_ptr.push(row_idx.len());
            }
        }
        let m = count as usize;
        let pattern = SymbolicSparseColMatRef::new_checked(m, m, &col_ptr, None, &row_idx);
        let symbolic = factorize_symbolic_cholesky(
            pattern,
            Side::Lower,
            SymmetricOrdering::Amd,
            CholeskySymbolicParams::default(),
        )
        .map_err(|e| format!("the static solve's symbolic analysis failed: {e:?}"))?;
        let factor_mem = MemBuffer::try_new(
            symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()),
        )
        .map_err(|e| format!("the static solve's workspace: {e:?}"))?;
        let solve_mem = MemBuffer::try_new(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq))
            .map_err(|e| format!("the static solve's workspace: {e:?}"))?;
        let nnz = row_idx.len();
        Ok(Equilibrium {
            unknown,
            col_ptr,
            row_idx,
            values: vec![0.0; nnz],
            factor: vec![0.0; symbolic.len_val()],
            symbolic,
            factor_mem,
            solve_mem,
            rhs: vec![0.0; m],
            eps: vec![[0.0; V]; widest * D],
            sig: vec![[0.0; V]; widest * D],
            pq: vec![[0.0; 2]; widest * D],
            committed: Committed::default(),
            tolerance,
            max_iterations,
            floor,
            d_before: vec![[0.0; D]; n],
            external_before: vec![[0.0; D]; n],
            iterations: 0,
        })
    }

    /// Keeps the state at the start of a step: its displacements and
    /// external forces (for the work) and the damage history.
    pub fn begin(&mut self, run: &Explicit<D, V>) {
        self.d_before.copy_from_slice(&run.d);
        self.external_before.copy_from_slice(&run.external);
        if let Some(st) = &run.damage {
            let c = &mut self.committed;
            if c.kappa.len() != st.kappa.len() {
                let n = st.kappa.len();
                *c = Committed {
                    kappa: vec![0.0; n],
                    kappa_c: vec![0.0; n],
                    normal: vec![[0.0; D]; n],
                    damage: vec![0.0; n],
                };
            }
            c.kappa.copy_from_slice(&st.kappa);
            c.kappa_c.copy_from_slice(&st.kappa_c);
            c.normal.copy_from_slice(&st.normal);
            c.damage.copy_from_slice(&st.damage);
        }
    }

    /// Iterates `run` (its held components and loads already at the step's
    /// end) to equilibrium; its damage state, stress and internal force are
    /// then the converged ones. Err: the reason, when a factorization fails
    /// or the iterations run out.
    pub fn solve(&mut self, run: &mut Explicit<D, V>) -> Result<Converged, String> {
        let mut worst = f64::INFINITY;
        for it in 0..=self.max_iterations {
            self.trial(run);
            let (residual, scale) = self.residual(run);
            if residual <= self.tolerance * scale {
                self.iterations += it as u64;
                return Ok(Converged {
                    iterations: it,
                    dissipated: self.dissipation(run),
                });
            }
            worst = residual / scale;
            if it == self.max_iterations {
                break;
            }
            // Newton with the (symmetrised) tangent where it is positive
            // definite, else the secant stiffness
            self.assemble(run, true);
            if self.factorize_and_solve().is_err() {
                // a failed factorization leaves the right-hand side as it was
                self.assemble(run, false);
                self.factorize_and_solve()?;
            }
            for (k, &u) in self.unknown.iter().enumerate() {
                if u != HELD {
                    run.d[k / D][k % D] += self.rhs[u as usize];
                }
            }
        }
        Err(format!(
            "the static solve did not reach equilibrium in damage_particle.equilibrium.max_iterations = {} iterations (out-of-balance force {worst:.3e} of the force scale, tolerance {:.1e}): take smaller steps (time.dt) or allow more iterations",
            self.max_iterations, self.tolerance
        ))
    }

    /// The strain, the damage from the committed history, the degraded
    /// stress and the internal force at the present d.
    fn trial(&mut self, run: &mut Explicit<D, V>) {
        if let Some(st) = run.damage.as_mut() {
            let c = &self.committed;
            st.kappa.copy_from_slice(&c.kappa);
            st.kappa_c.copy_from_slice(&c.kappa_c);
            st.normal.copy_from_slice(&c.normal);
            st.damage.copy_from_slice(&c.damage);
            st.clear_started();
        }
        run.stresses();
        run.degrade();
        run.forces();
    }

    /// The largest out-of-balance component of a free particle, and the
    /// force scale (the largest internal or external component, at least
    /// the floor), N.
    fn residual(&mut self, run: &Explicit<D, V>) -> (f64, f64) {
        let (mut worst, mut scale) = (0.0f64, self.floor);
        let g = run.body_force;
        for (k, &u) in self.unknown.iter().enumerate() {
            let (p, a) = (k / D, k % D);
            let load = run.external[p][a] + run.mass[p] * g[a];
            let f = run.force[p][a];
            scale = scale.max(f.abs()).max(load.abs());
            if u != HELD {
                let r = load - f;
                self.rhs[u as usize] = r;
                worst = worst.max(r.abs());
            }
        }
        (worst, scale)
    }

    /// The secant stiffness at the present damage:
    /// K_{Ia,Jb} = Σ_L (1 − D_L) V_L ε_{Ia} : C : ε_{Jb}, ε_{Ia} the smoothed
    /// strain of a unit d_I along a (eqs. 37–39).
    fn assemble(&mut self, run: &Explicit<D, V>, tangent: bool) {
        self.values.iter_mut().for_each(|v| *v = 0.0);
        for l in 0..run.scni.len() {
            let keep = run.damage.as_ref().map_or(1.0, |st| 1.0 - st.damage[l]);
            let w = keep * run.vol[l];
            if w <= 0.0 {
                continue;
            }
            let m = &run.materials[run.material[l] as usize];
            let (nodes, grads) = run.scni.gradients(l);
            // a cell whose damage grows in this trial: the tangent's
            // −D′(κ) (C ε) ⊗ ∂ε̃/∂ε, symmetrised
            let softening = match (&run.damage, tangent) {
                (Some(st), true) if st.damage[l] > self.committed.damage[l] => {
                    let (k, k0, kc) = (st.kappa[l], st.kappa_0[l], st.kappa_c[l]);
                    let slope = k0 * kc / ((kc - k0) * k * k);
                    let e = run.strain[l];
                    Some((
                        slope * run.vol[l],
                        hooke::<D, V>(m, e),
                        equivalent_gradient::<D, V>(m, &e),
                    ))
                }
                _ => None,
            };
            for (i, g) in grads.iter().enumerate() {
                for a in 0..D {
                    let mut e = [0.0; V];
                    for q in 0..D {
                        e[voigt::<D>(a, q)] += if q == a { g[q] } else { 0.5 * g[q] };
                    }
                    self.eps[i * D + a] = e;
                    self.sig[i * D + a] = hooke::<D, V>(m, e);
                    if let Some((_, s, dg)) = &softening {
                        // p = ε_Ia : C ε, q = ∂ε̃/∂ε · ε_Ia
                        let p = contract::<D, V>(s, &e);
                        let q: f64 = (0..V).map(|k| dg[k] * e[k]).sum();
                        self.pq[i * D + a] = [p, q];
                    }
                }
            }
            for (j, &pj) in nodes.iter().enumerate() {
                for b in 0..D {
                    let col = self.unknown[pj as usize * D + b];
                    if col == HELD {
                        continue;
                    }
                    let (start, end) = (self.col_ptr[col as usize], self.col_ptr[col as usize + 1]);
                    for (i, &pi) in nodes.iter().enumerate() {
                        for a in 0..D {
                            let row = self.unknown[pi as usize * D + a];
                            if row == HELD || row < col {
                                continue;
                            }
                            let mut k =
                                w * contract::<D, V>(&self.sig[i * D + a], &self.eps[j * D + b]);
                            if let Some((ws, _, _)) = &softening {
                                let (x, y) = (self.pq[i * D + a], self.pq[j * D + b]);
                                k -= ws * 0.5 * (x[0] * y[1] + y[0] * x[1]);
                            }
                            // the pattern holds every pair of a cell's nodes
                            if let Ok(at) = self.row_idx[start..end].binary_search(&(row as usize))
                            {
                                self.values[start + at] += k;
                            }
                        }
                    }
                }
            }
        }
    }

    /// K_s Δd = r in place (`rhs`).
    fn factorize_and_solve(&mut self) -> Result<(), String> {
        let m = self.rhs.len();
        let pattern =
            SymbolicSparseColMatRef::new_checked(m, m, &self.col_ptr, None, &self.row_idx);
        self.symbolic
            .factorize_numeric_llt::<f64>(
                &mut self.factor,
                SparseColMatRef::new(pattern, &self.values),
                Side::Lower,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(&mut self.factor_mem),
                Default::default(),
            )
            .map_err(|e| {
                format!(
                    "the static solve's secant stiffness is singular ({e:?}): a piece of a body is held by no wall or held region (every piece needs its rigid motions held), or broken free"
                )
            })?;
        LltRef::new(&self.symbolic, &self.factor).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(&mut self.rhs, m, 1),
            Par::Seq,
            MemStack::new(&mut self.solve_mem),
        );
        Ok(())
    }

    /// The energy the converged step's damage dissipated (the module's
    /// exact rule), J.
    fn dissipation(&self, run: &Explicit<D, V>) -> f64 {
        let Some(st) = &run.damage else {
            return 0.0;
        };
        let c = &self.committed;
        let mut total = 0.0;
        for l in 0..st.damage.len() {
            if st.damage[l] <= c.damage[l] {
                continue;
            }
            let m = &run.materials[run.material[l] as usize];
            let e = &run.strain[l];
            let eq = equivalent_strain::<D, V>(m, e);
            let (k0, kc) = (st.kappa_0[l], st.kappa_c[l]);
            let from = c.kappa[l].max(k0);
            let to = st.kappa[l].min(kc);
            if eq <= 0.0 || to <= from {
                continue;
            }
            let psi = 0.5 * contract::<D, V>(&hooke::<D, V>(m, *e), e);
            total += run.vol[l] * psi / (eq * eq) * k0 * kc / (kc - k0) * (to - from);
        }
        total
    }
}

/// ∂ε̃/∂ε of the Mazars equivalent strain (eq. 6) at `e` (Voigt, tensor
/// shear), by central differences in each stored component (the
/// out-of-plane strain of plane stress follows the in-plane ones).
fn equivalent_gradient<const D: usize, const V: usize>(m: &Elastic, e: &[f64; V]) -> [f64; V] {
    let scale = e.iter().fold(0.0f64, |a, c| a.max(c.abs())).max(1e-300);
    let step = 1e-6 * scale;
    std::array::from_fn(|k| {
        let (mut up, mut down) = (*e, *e);
        up[k] += step;
        down[k] -= step;
        (equivalent_strain::<D, V>(m, &up) - equivalent_strain::<D, V>(m, &down)) / (2.0 * step)
    })
}
