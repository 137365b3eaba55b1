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
//! The nodes come row by row: `j` (along y) outer, `i` (along x) inner, the
//! order of the sums into every node and of every per-particle sum over its
//! nodes. The values are the tensor products of the two 1D evaluations,
//! always formed in the same order, so any two sites that take them agree
//! to the bit:
//!
//! - `w = wx[i]·wy[j]`;
//! - `grad = [wx'[i]·wy[j]·(1/h), wx[i]·wy'[j]·(1/h)]` (per metre);
//! - `hess = [wx''[i]·wy[j]·(1/h²), wx[i]·wy''[j]·(1/h²), wx'[i]·wy'[j]·(1/h²)]`
//!   (`[N,xx, N,yy, N,xy]` per m², only from [`Support::with_hessian`]).
//!
//! **Zero cost.** [`Support`] is a few arrays on the stack and
//! [`Support::for_each`] is an inlined pair of loops of constant trip
//! count [`Kernel::N`] that calls the closure once per node: after
//! inlining it is the hand-written double loop it replaced. Whatever of a
//! [`SupportNode`] a caller does not read (the gradient where only the
//! weight is used, say) is dead code and compiled away. No allocation, no
//! dynamic dispatch.
//!
//! **Per-particle arrays.** [`SupportNode::a`] is the node's local index
//! `i + j·N` in `0..Support::<K>::LEN`; [`Support::local_offset`] turns it
//! back into the node's offset from [`Support::first_node`] (what a stored
//! footprint mask needs).
//!
//! **3D.** A third axis adds a third 1D evaluation `wz` and an outermost
//! loop over `k` in `for_each` (`k` outer, then `j`, then `i`); a
//! `SupportNode` gets `local: [usize; 3]`, `at: [isize; 3]`, a 3-vector
//! gradient (`wx'·wy·wz/h` and so on, in that factor order) and the six
//! second derivatives, and `a = i + N·(j + N·k)`. Callers keep their shape:
//! one closure per node.
//!
//! **A support of runtime width** (LME shape functions, whose support is
//! every node within a cut-off radius that depends on the locality
//! parameter and the particle): not a tensor product, so no 1D evaluations.
//! Such a kernel builds its support with the same interface — a
//! constructor from the particle's position, `for_each` handing out
//! `SupportNode`s, `len()` — but stores its node list and values in
//! fixed-capacity arrays sized by the widest support a scene allows (known
//! after validation), fills them by its own solve, and visits them in its
//! list's order; `a` is then the position in that list and `local`/`at`
//! the node's lattice coordinates. When the two exist side by side, the
//! methods shared here become a trait (`ParticleSupport`) implemented by
//! both, with the grid transfers generic over it as they are over
//! [`Kernel`] today.

use super::shape::{Kernel, Weights1, MAX_SUPPORT};
use super::GridGeom;
use std::marker::PhantomData;

/// One node of a particle's support, as [`Support::for_each`] hands it out.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SupportNode {
    /// Local index `i + j·N` of the node in the support (for per-particle
    /// arrays of [`Support::LEN`] entries).
    pub a: usize,
    /// Local position `[i, j]` in the support, each in `0..N`.
    pub local: [usize; 2],
    /// Lattice coordinates of the node (`[base_x + i, base_y + j]`).
    pub at: [isize; 2],
    /// Node index `at[0] + at[1]·nodes[0]`.
    pub node: usize,
    /// N(x_p).
    pub w: f64,
    /// ∇N(x_p), per metre.
    pub grad: [f64; 2],
    /// [N,xx, N,yy, N,xy] at x_p, per m²; zero unless the support was made
    /// by [`Support::with_hessian`] (and where the kernel is not C¹).
    pub hess: [f64; 3],
}

/// The support of a particle for kernel `K`: its two 1D evaluations and
/// what turns them into nodes. With `HESS`, the kernel's second derivatives
/// too ([`Kernel::eval2`]).
#[derive(Debug, Clone, Copy)]
pub struct Support<K: Kernel, const HESS: bool = false> {
    xi: [f64; 2],
    wx: Weights1,
    wy: Weights1,
    d2x: [f64; MAX_SUPPORT],
    d2y: [f64; MAX_SUPPORT],
    inv_h: f64,
    row: usize,
    kernel: PhantomData<K>,
}

impl<K: Kernel> Support<K> {
    /// Nodes in the support.
    pub const LEN: usize = K::N * K::N;

    /// The support of a particle at `x` (m) with GIMP half-width `lp`
    /// (cells; other kernels ignore it): weights and gradients.
    #[inline(always)]
    pub fn new(geom: &GridGeom, x: [f64; 2], lp: f64) -> Self {
        Self::eval(geom, x, lp)
    }

    /// Offset of the node of local index `a` from [`Support::first_node`]
    /// on a grid of `geom`.
    #[inline(always)]
    pub fn local_offset(geom: &GridGeom, a: usize) -> usize {
        a % K::N + (a / K::N) * geom.nodes[0]
    }
}

impl<K: Kernel> Support<K, true> {
    /// As [`Support::new`], with second derivatives.
    #[inline(always)]
    pub fn with_hessian(geom: &GridGeom, x: [f64; 2], lp: f64) -> Self {
        Self::eval(geom, x, lp)
    }
}

impl<K: Kernel, const HESS: bool> Support<K, HESS> {
    /// The support at `x` (m): [`Support::new`] or
    /// [`Support::with_hessian`] as `HESS` says.
    #[inline(always)]
    pub fn eval(geom: &GridGeom, x: [f64; 2], lp: f64) -> Self {
        let xi = geom.xi(x);
        let (wx, d2x, wy, d2y) = if HESS {
            let (wx, d2x) = K::eval2(xi[0], lp);
            let (wy, d2y) = K::eval2(xi[1], lp);
            (wx, d2x, wy, d2y)
        } else {
            let zero = [0.0; MAX_SUPPORT];
            (K::eval(xi[0], lp), zero, K::eval(xi[1], lp), zero)
        };
        Support {
            xi,
            wx,
            wy,
            d2x,
            d2y,
            inv_h: geom.inv_h,
            row: geom.nodes[0],
            kernel: PhantomData,
        }
    }

    /// The particle's position in node units ([`GridGeom::xi`]).
    #[inline(always)]
    pub fn xi(&self) -> [f64; 2] {
        self.xi
    }

    /// Lattice coordinates of the support's first node (local `[0, 0]`).
    #[inline(always)]
    pub fn base(&self) -> [isize; 2] {
        [self.wx.base, self.wy.base]
    }

    /// Index of the support's first node (local index 0).
    #[inline(always)]
    pub fn first_node(&self) -> usize {
        self.wx.base as usize + self.wy.base as usize * self.row
    }

    /// Calls `f` for every node of the support: `j` outer, `i` inner
    /// (local index `a = i + j·N` ascending), every node even where its
    /// weight is zero.
    #[inline(always)]
    pub fn for_each(&self, mut f: impl FnMut(SupportNode)) {
        let (wx, wy) = (&self.wx, &self.wy);
        let ih = self.inv_h;
        let ih2 = ih * ih;
        for j in 0..K::N {
            let y = wy.base + j as isize;
            let row = y as usize * self.row;
            for i in 0..K::N {
                let x = wx.base + i as isize;
                f(SupportNode {
                    a: i + j * K::N,
                    local: [i, j],
                    at: [x, y],
                    node: x as usize + row,
                    w: wx.w[i] * wy.w[j],
                    grad: [wx.dw[i] * wy.w[j] * ih, wx.w[i] * wy.dw[j] * ih],
                    hess: if HESS {
                        [
                            self.d2x[i] * wy.w[j] * ih2,
                            wx.w[i] * self.d2y[j] * ih2,
                            wx.dw[i] * wy.dw[j] * ih2,
                        ]
                    } else {
                        [0.0; 3]
                    },
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::shape::{CubicBspline, Gimp, Linear, QuadraticBspline};
    use super::*;

    /// What the hand-written double loop computed at every site before
    /// there was a `Support`: (node, w, grad, hess) in its order.
    fn double_loop<K: Kernel>(
        geom: &GridGeom,
        x: [f64; 2],
        lp: f64,
        hess: bool,
    ) -> Vec<(usize, f64, [f64; 2], [f64; 3])> {
        let xi = geom.xi(x);
        let (ih, ih2) = (geom.inv_h, geom.inv_h * geom.inv_h);
        let ((wx, d2x), (wy, d2y)) = if hess {
            (K::eval2(xi[0], lp), K::eval2(xi[1], lp))
        } else {
            (
                (K::eval(xi[0], lp), [0.0; MAX_SUPPORT]),
                (K::eval(xi[1], lp), [0.0; MAX_SUPPORT]),
            )
        };
        let mut out = Vec::new();
        for j in 0..K::N {
            for i in 0..K::N {
                let node = (wx.base + i as isize) as usize
                    + (wy.base + j as isize) as usize * geom.nodes[0];
                let h = if hess {
                    [
                        d2x[i] * wy.w[j] * ih2,
                        wx.w[i] * d2y[j] * ih2,
                        wx.dw[i] * wy.dw[j] * ih2,
                    ]
                } else {
                    [0.0; 3]
                };
                out.push((
                    node,
                    wx.w[i] * wy.w[j],
                    [wx.dw[i] * wy.w[j] * ih, wx.w[i] * wy.dw[j] * ih],
                    h,
                ));
            }
        }
        out
    }

    fn check<K: Kernel>(lp: f64) {
        let geom = GridGeom::new([-0.3, 0.2], 0.07, [40, 30]);
        let mut seed = 99u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..500 {
            let x = [
                geom.domain_min[0] + next() * (geom.domain_max[0] - geom.domain_min[0]),
                geom.domain_min[1] + next() * (geom.domain_max[1] - geom.domain_min[1]),
            ];
            let plain = Support::<K>::new(&geom, x, lp);
            let second = Support::<K, true>::with_hessian(&geom, x, lp);
            for (hess, nodes) in [
                (false, collect(|f| plain.for_each(f))),
                (true, collect(|f| second.for_each(f))),
            ] {
                let old = double_loop::<K>(&geom, x, lp, hess);
                assert_eq!(nodes.len(), Support::<K>::LEN);
                assert_eq!(nodes.len(), old.len());
                let (mut w, mut g, mut h) = (0.0, [0.0; 2], [0.0; 3]);
                for (a, (n, o)) in nodes.iter().zip(&old).enumerate() {
                    // the old loop's nodes and values, in its order, to the bit
                    assert_eq!((n.node, n.w, n.grad, n.hess), *o, "node {a} at {x:?}");
                    assert_eq!(n.a, a);
                    assert_eq!(n.local, [a % K::N, a / K::N]);
                    assert_eq!(
                        n.node,
                        plain.first_node() + Support::<K>::local_offset(&geom, a)
                    );
                    assert_eq!(
                        n.at,
                        [
                            plain.base()[0] + n.local[0] as isize,
                            plain.base()[1] + n.local[1] as isize
                        ]
                    );
                    assert_eq!(n.node, geom.node(n.at[0] as usize, n.at[1] as usize));
                    w += n.w;
                    g = [g[0] + n.grad[0], g[1] + n.grad[1]];
                    for r in 0..3 {
                        h[r] += n.hess[r];
                    }
                }
                // partition of unity; gradients and Hessians sum to zero
                let gs = geom.inv_h * 1e-12;
                assert!((w - 1.0).abs() < 1e-12, "Σw = {w} at {x:?}");
                assert!(g[0].abs() < gs && g[1].abs() < gs, "Σ∇N = {g:?}");
                let hs = geom.inv_h * geom.inv_h * 1e-12;
                assert!(h.iter().all(|v| v.abs() < hs), "Σ∇∇N = {h:?}");
            }
        }
    }

    fn collect(visit: impl FnOnce(&mut dyn FnMut(SupportNode))) -> Vec<SupportNode> {
        let mut out = Vec::new();
        visit(&mut |n| out.push(n));
        out
    }

    #[test]
    fn support_visits_the_double_loops_nodes_with_its_values() {
        check::<Linear>(0.0);
        check::<Gimp>(0.25);
        check::<Gimp>(0.5);
        check::<QuadraticBspline>(0.0);
        check::<CubicBspline>(0.0);
    }
}
