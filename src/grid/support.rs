//! A particle's support: the nodes its kernel reaches, with the weight,
//! gradient and (where the kernel has them) second derivatives at each.
//!
//! Every transfer between particles and grid visits supports the same way:
//!
//! ```ignore
//! let s = Support::<K>::new(geom, x, lp);
//! s.for_each(|n| grid[n.node] += n.w * m);
//! ```
//!
//! The same code serves 2D and 3D (`Support<K, D>`, `D` = 2 or 3). The
//! nodes come row by row: the last axis outermost, `i` (along x)
//! innermost, the order of the sums into every node and of every
//! per-particle sum over its nodes. The values are the tensor products of
//! the 1D evaluations, always formed in axis order (x first), so any two
//! sites that take them agree to the bit. In 2D:
//!
//! - `w = wx[i]·wy[j]`;
//! - `grad = [wx'[i]·wy[j]·(1/h), wx[i]·wy'[j]·(1/h)]` (per metre);
//! - `hess = [[wx''[i]·wy[j], wx'[i]·wy'[j]], [·, wx[i]·wy''[j]]]·(1/h²)`
//!   (per m², only from [`Support::with_hessian`]).
//!
//! In 3D each product has the third factor `wz[k]` (or its derivative)
//! last: `w = wx·wy·wz`, `grad[0] = wx'·wy·wz/h`, `hess[0][2] = wx'·wy·wz'/h²`.
//!
//! **Zero cost.** [`Support`] is a few arrays on the stack and
//! [`Support::for_each`] is an inlined nest of `D` loops of constant trip
//! count [`Kernel::N`] that calls the closure once per node: after
//! inlining it is the hand-written double loop it replaced (`D` is a
//! constant, so the other dimension's branch is compiled away). Whatever of a
//! [`SupportNode`] a caller does not read (the gradient where only the
//! weight is used, say) is dead code and compiled away. No allocation, no
//! dynamic dispatch.
//!
//! **Per-particle arrays.** [`SupportNode::a`] is the node's local index
//! `i + N·(j + N·k)` in `0..Support::<K, D>::LEN`; [`Support::local_offset`] turns it
//! back into the node's offset from [`Support::first_node`] (what a stored
//! footprint mask needs).
//!
//! **LME shape functions** ([`crate::grid::shape::Lme`]) are one more
//! [`Kernel`]: on a Cartesian grid, with the box of nodes as their node
//! set, local maximum-entropy approximants are a tensor product of 1D ones
//! (the partition function separates by axis), so they need no support of
//! their own. Their locality γ comes from [`GridGeom::lme_gamma`]. A
//! support wider than four nodes per axis (γ below
//! [`crate::grid::shape::LME_GAMMA_MIN`]) would need more ghost nodes and a
//! larger [`MAX_SUPPORT`].

use super::shape::{Kernel, Weights1, MAX_SUPPORT};
use super::GridGeom;
use rayon::prelude::*;
use std::marker::PhantomData;

/// One node of a particle's support, as [`Support::for_each`] hands it out.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupportNode<const D: usize = 2> {
    /// Local index `i + N·(j + N·k)` of the node in the support (for
    /// per-particle arrays of [`Support::LEN`] entries).
    pub a: usize,
    /// Local position `[i, j(, k)]` in the support, each in `0..N`.
    pub local: [usize; D],
    /// Lattice coordinates of the node (`[base_x + i, base_y + j, …]`).
    pub at: [isize; D],
    /// Node index ([`GridGeom::node`] of `at`).
    pub node: usize,
    /// N(x_p).
    pub w: f64,
    /// ∇N(x_p), per metre.
    pub grad: [f64; D],
    /// The Hessian ∇∇N(x_p), per m² (symmetric); zero unless the support
    /// was made by [`Support::with_hessian`] (and where the kernel is not
    /// C¹).
    pub hess: [[f64; D]; D],
}

impl SupportNode<2> {
    /// The 2D Hessian as `[N,xx, N,yy, N,xy]`.
    #[inline(always)]
    pub fn hess_voigt(&self) -> [f64; 3] {
        [self.hess[0][0], self.hess[1][1], self.hess[0][1]]
    }
}

impl<const D: usize> SupportNode<D> {
    /// The Hessian in Voigt order, in the first `D(D+1)/2` of six entries
    /// (the rest zero): 2D `[N,xx, N,yy, N,xy]`, 3D `[N,xx, N,yy, N,zz,
    /// N,yz, N,xz, N,xy]` (the engine's Voigt order, [`crate::tensor`]).
    /// One width for both dimensions, so the phase-field assembly has one
    /// code path.
    #[inline(always)]
    pub fn hess_voigt6(&self) -> [f64; 6] {
        let h = &self.hess;
        if D == 2 {
            [h[0][0], h[1][1], h[0][1], 0.0, 0.0, 0.0]
        } else {
            [h[0][0], h[1][1], h[2][2], h[1][2], h[0][2], h[0][1]]
        }
    }
}

/// The support of a particle for kernel `K` in `D` dimensions (2 or 3):
/// its 1D evaluations along each axis and what turns them into nodes.
/// With `HESS`, the kernel's second derivatives too ([`Kernel::eval2`]).
#[derive(Debug, Clone, Copy)]
pub struct Support<K: Kernel, const D: usize = 2, const HESS: bool = false> {
    xi: [f64; D],
    w: [Weights1; D],
    d2: [[f64; MAX_SUPPORT]; D],
    inv_h: f64,
    /// Node-index strides of the axes: `[1, nx(, nx·ny)]`.
    stride: [usize; D],
    kernel: PhantomData<K>,
}

impl<K: Kernel, const D: usize> Support<K, D> {
    /// Nodes in the support.
    pub const LEN: usize = K::N.pow(D as u32);

    /// The support of a particle at `x` (m) with GIMP half-width `lp`
    /// (cells; other kernels ignore it): weights and gradients.
    #[inline(always)]
    pub fn new(geom: &GridGeom<D>, x: [f64; D], lp: f64) -> Self {
        Self::eval(geom, x, lp)
    }

    /// Offset of the node of local index `a` from [`Support::first_node`]
    /// on a grid of `geom`.
    #[inline(always)]
    pub fn local_offset(geom: &GridGeom<D>, a: usize) -> usize {
        let mut rest = a;
        let mut offset = 0;
        let mut stride = 1;
        for d in 0..D {
            offset += rest % K::N * stride;
            rest /= K::N;
            stride *= geom.nodes[d];
        }
        offset
    }
}

impl<K: Kernel, const D: usize> Support<K, D, true> {
    /// As [`Support::new`], with second derivatives.
    #[inline(always)]
    pub fn with_hessian(geom: &GridGeom<D>, x: [f64; D], lp: f64) -> Self {
        Self::eval(geom, x, lp)
    }
}

impl<K: Kernel, const D: usize, const HESS: bool> Support<K, D, HESS> {
    /// The support at `x` (m): [`Support::new`] or
    /// [`Support::with_hessian`] as `HESS` says.
    #[inline(always)]
    pub fn eval(geom: &GridGeom<D>, x: [f64; D], lp: f64) -> Self {
        let xi = geom.xi(x);
        let mut w = [Weights1::default(); D];
        let mut d2 = [[0.0; MAX_SUPPORT]; D];
        for d in 0..D {
            if HESS {
                (w[d], d2[d]) = K::eval2(xi[d], lp, geom.lme_gamma);
            } else {
                w[d] = K::eval(xi[d], lp, geom.lme_gamma);
            }
        }
        Support {
            xi,
            w,
            d2,
            inv_h: geom.inv_h,
            stride: geom.strides(),
            kernel: PhantomData,
        }
    }

    /// The support of particle `p` at `x` with half-width `lp`: read back
    /// from `kept` where the kernel keeps its supports
    /// ([`Kernel::KEPT`]) and `kept` holds particle `p`'s evaluation at
    /// this very `xi`, `lp` and γ; evaluated otherwise. Either way the
    /// same bits as [`Support::eval`] (the 1D evaluations are a function
    /// of `xi`, `lp` and γ alone), so a stale or missing entry costs time,
    /// never a result.
    #[inline(always)]
    pub fn kept(
        geom: &GridGeom<D>,
        x: [f64; D],
        lp: f64,
        kept: &SupportCache<D>,
        p: usize,
    ) -> Self {
        if K::KEPT && !HESS {
            let xi = geom.xi(x);
            if let Some(e) = kept.entries.get(p) {
                if e.xi == xi && e.lp == lp && e.gamma == geom.lme_gamma {
                    return Support {
                        xi,
                        w: e.w,
                        d2: [[0.0; MAX_SUPPORT]; D],
                        inv_h: geom.inv_h,
                        stride: geom.strides(),
                        kernel: PhantomData,
                    };
                }
            }
        }
        Self::eval(geom, x, lp)
    }

    /// The particle's position in node units ([`GridGeom::xi`]).
    #[inline(always)]
    pub fn xi(&self) -> [f64; D] {
        self.xi
    }

    /// Lattice coordinates of the support's first node (local `[0, 0(, 0)]`).
    #[inline(always)]
    pub fn base(&self) -> [isize; D] {
        std::array::from_fn(|d| self.w[d].base)
    }

    /// Index of the support's first node (local index 0).
    #[inline(always)]
    pub fn first_node(&self) -> usize {
        let mut n = 0;
        for d in 0..D {
            n += self.w[d].base as usize * self.stride[d];
        }
        n
    }

    /// Calls `f` for every node of the support: the last axis outermost
    /// and x innermost (local index `a = i + N·(j + N·k)` ascending), every
    /// node even where its weight is zero.
    ///
    /// The products are always formed in axis order, x first, as the
    /// module doc says: in 2D `w = wx·wy`, in 3D `w = wx·wy·wz`, and each
    /// derivative replaces its axis' factor.
    #[inline(always)]
    pub fn for_each(&self, mut f: impl FnMut(SupportNode<D>)) {
        const { assert!(D == 2 || D == 3, "a support has 2 or 3 axes") };
        let ih = self.inv_h;
        let ih2 = ih * ih;
        let wx = &self.w[0];
        let wy = &self.w[1];
        let (d2x, d2y) = (&self.d2[0], &self.d2[1]);
        if D == 2 {
            for j in 0..K::N {
                let y = wy.base + j as isize;
                let row = y as usize * self.stride[1];
                for i in 0..K::N {
                    let x = wx.base + i as isize;
                    let mut n = SupportNode {
                        a: i + j * K::N,
                        local: [0; D],
                        at: [0; D],
                        node: x as usize + row,
                        w: wx.w[i] * wy.w[j],
                        grad: [0.0; D],
                        hess: [[0.0; D]; D],
                    };
                    (n.local[0], n.local[1]) = (i, j);
                    (n.at[0], n.at[1]) = (x, y);
                    n.grad[0] = wx.dw[i] * wy.w[j] * ih;
                    n.grad[1] = wx.w[i] * wy.dw[j] * ih;
                    if HESS {
                        n.hess[0][0] = d2x[i] * wy.w[j] * ih2;
                        n.hess[1][1] = wx.w[i] * d2y[j] * ih2;
                        n.hess[0][1] = wx.dw[i] * wy.dw[j] * ih2;
                        n.hess[1][0] = n.hess[0][1];
                    }
                    f(n);
                }
            }
        } else {
            let wz = &self.w[D - 1];
            let d2z = &self.d2[D - 1];
            for k in 0..K::N {
                let z = wz.base + k as isize;
                let plane = z as usize * self.stride[D - 1];
                for j in 0..K::N {
                    let y = wy.base + j as isize;
                    let row = plane + y as usize * self.stride[1];
                    for i in 0..K::N {
                        let x = wx.base + i as isize;
                        let mut n = SupportNode {
                            a: i + K::N * (j + K::N * k),
                            local: [0; D],
                            at: [0; D],
                            node: x as usize + row,
                            w: wx.w[i] * wy.w[j] * wz.w[k],
                            grad: [0.0; D],
                            hess: [[0.0; D]; D],
                        };
                        (n.local[0], n.local[1], n.local[D - 1]) = (i, j, k);
                        (n.at[0], n.at[1], n.at[D - 1]) = (x, y, z);
                        n.grad[0] = wx.dw[i] * wy.w[j] * wz.w[k] * ih;
                        n.grad[1] = wx.w[i] * wy.dw[j] * wz.w[k] * ih;
                        n.grad[D - 1] = wx.w[i] * wy.w[j] * wz.dw[k] * ih;
                        if HESS {
                            let h = &mut n.hess;
                            h[0][0] = d2x[i] * wy.w[j] * wz.w[k] * ih2;
                            h[1][1] = wx.w[i] * d2y[j] * wz.w[k] * ih2;
                            h[D - 1][D - 1] = wx.w[i] * wy.w[j] * d2z[k] * ih2;
                            h[0][1] = wx.dw[i] * wy.dw[j] * wz.w[k] * ih2;
                            h[0][D - 1] = wx.dw[i] * wy.w[j] * wz.dw[k] * ih2;
                            h[1][D - 1] = wx.w[i] * wy.dw[j] * wz.dw[k] * ih2;
                            h[1][0] = h[0][1];
                            h[D - 1][0] = h[0][D - 1];
                            h[D - 1][1] = h[1][D - 1];
                        }
                        f(n);
                    }
                }
            }
        }
    }
}

/// One particle's kept support: its 1D evaluations and what they are a
/// function of.
#[derive(Debug, Clone, Copy)]
struct KeptSupport<const D: usize> {
    xi: [f64; D],
    lp: f64,
    gamma: f64,
    w: [Weights1; D],
}

/// The supports of a step's particles, evaluated once by the `supports`
/// stage and read back by every transfer of the step until the particle
/// moves ([`Support::kept`]). Only for kernels whose evaluation is dear
/// ([`Kernel::KEPT`]: LME, two Newton solves per support): a MUSL or
/// Newmark step of LME builds each particle's support four times at the
/// same position (scatter, gather, remap or force, gather), a USL step
/// twice.
///
/// Scratch, not state: a checkpoint does not hold it, two particle sets
/// compare equal whatever their caches hold, and a clone starts empty (an
/// entry is only ever a shortcut to the same bits).
#[derive(Default)]
pub struct SupportCache<const D: usize> {
    entries: Vec<KeptSupport<D>>,
}

impl<const D: usize> SupportCache<D> {
    /// Evaluates the support of every particle at `x` (GIMP half-widths
    /// `half_size`, empty for a point kernel) and keeps it; for a kernel
    /// that does not keep supports, frees what an earlier kernel kept.
    /// Each entry depends on its particle alone, so any number of threads
    /// gives the same entries.
    pub fn fill<K: Kernel>(&mut self, geom: &GridGeom<D>, x: &[[f64; D]], half_size: &[f64]) {
        if !K::KEPT {
            self.entries = Vec::new();
            return;
        }
        let gamma = geom.lme_gamma;
        // into the same allocation, step after step
        (0..x.len())
            .into_par_iter()
            .with_min_len(1024)
            .map(|p| {
                let lp = half_size.get(p).copied().unwrap_or(0.0);
                let xi = geom.xi(x[p]);
                KeptSupport {
                    xi,
                    lp,
                    gamma,
                    w: std::array::from_fn(|d| K::eval(xi[d], lp, gamma)),
                }
            })
            .collect_into_vec(&mut self.entries);
    }

    /// Particles with a kept support.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Heap bytes held.
    pub fn heap_bytes(&self) -> usize {
        self.entries.capacity() * std::mem::size_of::<KeptSupport<D>>()
    }
}

impl<const D: usize> Clone for SupportCache<D> {
    /// Empty: the copy's particles refill it at their next step.
    fn clone(&self) -> Self {
        SupportCache::default()
    }
}

impl<const D: usize> PartialEq for SupportCache<D> {
    /// Always: what is kept never changes a result.
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl<const D: usize> std::fmt::Debug for SupportCache<D> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "SupportCache({} kept)", self.entries.len())
    }
}

#[cfg(test)]
mod tests {
    use super::super::shape::{self, CubicBspline, Gimp, Linear, Lme, QuadraticBspline};
    use super::*;

    type Hess<const D: usize> = [[f64; D]; D];

    /// What nested loops over the axes compute, written out per dimension
    /// (for 2D: the hand-written double loop every site had before there
    /// was a `Support`): (node, w, grad, hess) in their order.
    fn nested_loops<K: Kernel, const D: usize>(
        geom: &GridGeom<D>,
        x: [f64; D],
        lp: f64,
        hess: bool,
    ) -> Vec<(usize, f64, [f64; D], Hess<D>)> {
        let xi = geom.xi(x);
        let (ih, ih2) = (geom.inv_h, geom.inv_h * geom.inv_h);
        let e: Vec<_> = (0..D)
            .map(|d| {
                if hess {
                    K::eval2(xi[d], lp, geom.lme_gamma)
                } else {
                    (K::eval(xi[d], lp, geom.lme_gamma), [0.0; MAX_SUPPORT])
                }
            })
            .collect();
        let mut out = Vec::new();
        let nz = if D == 3 { K::N } else { 1 };
        for k in 0..nz {
            for j in 0..K::N {
                for i in 0..K::N {
                    let idx = [i, j, k];
                    let mut at = [0usize; D];
                    for d in 0..D {
                        at[d] = (e[d].0.base + idx[d] as isize) as usize;
                    }
                    let node = geom.node(at);
                    // Π over the axes, x first, with axis `da` (and `db`)
                    // differentiated `order` times in total
                    let prod = |da: usize, db: usize, order: usize| {
                        let mut v = 1.0;
                        for d in 0..D {
                            let (w, dw, d2) = (e[d].0.w[idx[d]], e[d].0.dw[idx[d]], e[d].1[idx[d]]);
                            v *= match (order, d == da, d == db) {
                                (1, true, _) => dw,
                                (2, true, true) => d2,
                                (2, true, false) | (2, false, true) => dw,
                                _ => w,
                            };
                        }
                        v
                    };
                    let w = prod(D, D, 0);
                    let grad: [f64; D] = std::array::from_fn(|d| prod(d, d, 1) * ih);
                    let mut h = [[0.0; D]; D];
                    if hess {
                        for a in 0..D {
                            for b in 0..D {
                                h[a][b] = prod(a.min(b), a.max(b), 2) * ih2;
                            }
                        }
                    }
                    out.push((node, w, grad, h));
                }
            }
        }
        out
    }

    fn check<K: Kernel, const D: usize>(lp: f64) {
        let min: [f64; D] = std::array::from_fn(|d| [-0.3, 0.2, 0.05][d]);
        let cells: [usize; D] = std::array::from_fn(|d| [40, 30, 20][d]);
        let geom = GridGeom::<D>::new(min, 0.07, cells);
        let mut next = crate::grid::tests::uniform(99);
        for _ in 0..300 {
            let x: [f64; D] = std::array::from_fn(|d| {
                geom.domain_min[d] + next() * (geom.domain_max[d] - geom.domain_min[d])
            });
            let plain = Support::<K, D>::new(&geom, x, lp);
            let second = Support::<K, D, true>::with_hessian(&geom, x, lp);
            for (hess, nodes) in [
                (false, collect(|f| plain.for_each(f))),
                (true, collect(|f| second.for_each(f))),
            ] {
                let old = nested_loops::<K, D>(&geom, x, lp, hess);
                assert_eq!(nodes.len(), Support::<K, D>::LEN);
                assert_eq!(nodes.len(), old.len());
                let (mut w, mut g, mut h) = (0.0, [0.0; D], [[0.0; D]; D]);
                for (a, (n, o)) in nodes.iter().zip(&old).enumerate() {
                    // the loops' nodes and values, in their order, to the bit
                    assert_eq!((n.node, n.w, n.grad, n.hess), *o, "node {a} at {x:?}");
                    assert_eq!(n.a, a);
                    let local: [usize; D] = std::array::from_fn(|d| a / K::N.pow(d as u32) % K::N);
                    assert_eq!(n.local, local);
                    assert_eq!(
                        n.node,
                        plain.first_node() + Support::<K, D>::local_offset(&geom, a)
                    );
                    let at: [isize; D] =
                        std::array::from_fn(|d| plain.base()[d] + n.local[d] as isize);
                    assert_eq!(n.at, at);
                    assert_eq!(n.node, geom.node(n.at.map(|c| c as usize)));
                    assert_eq!(geom.node_coords(n.node), n.at.map(|c| c as usize));
                    w += n.w;
                    for r in 0..D {
                        g[r] += n.grad[r];
                        for c in 0..D {
                            h[r][c] += n.hess[r][c];
                        }
                    }
                }
                // partition of unity; gradients and Hessians sum to zero
                let gs = geom.inv_h * 1e-12;
                assert!((w - 1.0).abs() < 1e-12, "Σw = {w} at {x:?}");
                assert!(g.iter().all(|v| v.abs() < gs), "Σ∇N = {g:?}");
                let hs = geom.inv_h * geom.inv_h * 1e-12;
                assert!(h.iter().flatten().all(|v| v.abs() < hs), "Σ∇∇N = {h:?}");
            }
        }
    }

    fn collect<const D: usize>(
        visit: impl FnOnce(&mut dyn FnMut(SupportNode<D>)),
    ) -> Vec<SupportNode<D>> {
        let mut out = Vec::new();
        visit(&mut |n| out.push(n));
        out
    }

    #[test]
    fn support_visits_the_double_loops_nodes_with_its_values() {
        check::<Linear, 2>(0.0);
        check::<Gimp, 2>(0.25);
        check::<Gimp, 2>(0.5);
        check::<QuadraticBspline, 2>(0.0);
        check::<CubicBspline, 2>(0.0);
        check::<Lme, 2>(0.0);
    }

    /// In 3D: the triple loop's nodes and values (x innermost), the
    /// partition of unity, gradients and Hessians that sum to zero.
    #[test]
    fn support_visits_the_triple_loops_nodes_with_its_values() {
        check::<Linear, 3>(0.0);
        check::<Gimp, 3>(0.25);
        check::<QuadraticBspline, 3>(0.0);
        check::<CubicBspline, 3>(0.0);
        check::<Lme, 3>(0.0);
    }

    /// A linear field is reproduced exactly by every kernel in 3D, and its
    /// gradient too: Σ N_I x_I = x, Σ ∇N_I ⊗ x_I = I (LME at the least,
    /// the default and a large locality).
    #[test]
    fn supports_reproduce_linear_fields_in_3d() {
        fn linear<K: Kernel>(lp: f64, gamma: f64) {
            let mut geom = GridGeom::<3>::new([0.1, -0.2, 0.3], 0.05, [12, 10, 8]);
            geom.lme_gamma = gamma;
            for x in [
                [0.23, 0.04, 0.41],
                [0.5, 0.2, 0.66],
                [0.1001, -0.1999, 0.3001],
            ] {
                let (mut r, mut g) = ([0.0; 3], [[0.0; 3]; 3]);
                Support::<K, 3>::new(&geom, x, lp).for_each(|n| {
                    let xn = geom.node_position(n.node);
                    for a in 0..3 {
                        r[a] += n.w * xn[a];
                        for b in 0..3 {
                            g[a][b] += n.grad[a] * xn[b];
                        }
                    }
                });
                for a in 0..3 {
                    assert!((r[a] - x[a]).abs() < 1e-12, "{r:?} at {x:?}");
                    for b in 0..3 {
                        let want = if a == b { 1.0 } else { 0.0 };
                        assert!((g[a][b] - want).abs() < 1e-10, "{g:?} at {x:?}");
                    }
                }
            }
        }
        linear::<Linear>(0.0, 0.0);
        linear::<Gimp>(0.25, 0.0);
        linear::<QuadraticBspline>(0.0, 0.0);
        linear::<CubicBspline>(0.0, 0.0);
        for gamma in [shape::LME_GAMMA_MIN, shape::LME_GAMMA_DEFAULT, 30.0] {
            linear::<Lme>(0.0, gamma);
        }
    }

    /// Every node a support visits, as bits.
    fn visits<K: Kernel, const D: usize>(s: &Support<K, D>) -> Vec<(usize, u64, Vec<u64>)> {
        let mut out = Vec::new();
        s.for_each(|n| out.push((n.node, n.w.to_bits(), n.grad.map(f64::to_bits).to_vec())));
        out
    }

    /// A kept LME support is the evaluated one to the bit; a particle that
    /// moved, a changed locality or a particle the cache does not hold
    /// gets a fresh evaluation (the same bits again), and a kernel that
    /// keeps nothing frees the cache.
    #[test]
    fn a_kept_support_is_the_evaluated_one() {
        fn check<const D: usize>(origin: [f64; D], n: [usize; D]) {
            let mut geom = GridGeom::<D>::new(origin, 0.05, n);
            let mut next = super::super::tests::uniform(7);
            let x: Vec<[f64; D]> = (0..500)
                .map(|_| std::array::from_fn(|d| origin[d] + 0.1 + 0.3 * next()))
                .collect();
            let mut cache = SupportCache::<D>::default();
            cache.fill::<Lme>(&geom, &x, &[]);
            assert_eq!(cache.len(), x.len());
            for (p, &xp) in x.iter().enumerate() {
                let fresh = visits(&Support::<Lme, D>::new(&geom, xp, 0.0));
                assert_eq!(
                    visits(&Support::<Lme, D>::kept(&geom, xp, 0.0, &cache, p)),
                    fresh
                );
                // the entry is a shortcut only where it was made
                let moved: [f64; D] = std::array::from_fn(|d| xp[d] + 1e-3);
                assert_eq!(
                    visits(&Support::<Lme, D>::kept(&geom, moved, 0.0, &cache, p)),
                    visits(&Support::<Lme, D>::new(&geom, moved, 0.0))
                );
                let other = (p + 1) % x.len();
                assert_eq!(
                    visits(&Support::<Lme, D>::kept(&geom, xp, 0.0, &cache, other)),
                    fresh
                );
            }
            let beyond = x.len() + 3;
            assert_eq!(
                visits(&Support::<Lme, D>::kept(&geom, x[0], 0.0, &cache, beyond)),
                visits(&Support::<Lme, D>::new(&geom, x[0], 0.0))
            );
            geom.lme_gamma *= 1.5;
            assert_eq!(
                visits(&Support::<Lme, D>::kept(&geom, x[0], 0.0, &cache, 0)),
                visits(&Support::<Lme, D>::new(&geom, x[0], 0.0))
            );
            // a B-spline reads nothing back, and a kernel change frees the cache
            assert_eq!(
                visits(&Support::<QuadraticBspline, D>::kept(
                    &geom, x[0], 0.0, &cache, 0
                )),
                visits(&Support::<QuadraticBspline, D>::new(&geom, x[0], 0.0))
            );
            cache.fill::<QuadraticBspline>(&geom, &x, &[]);
            assert!(cache.is_empty());
        }
        check::<2>([0.0, -0.1], [12, 12]);
        check::<3>([0.1, -0.2, 0.3], [12, 10, 8]);
    }
}
