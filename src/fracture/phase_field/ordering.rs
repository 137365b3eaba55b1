//! A fill-reducing ordering of the phase-field unknowns that uses the grid:
//! geometric nested dissection (George 1973; George & Liu, *Computer
//! Solution of Large Sparse Positive Definite Systems*, 1981, ch. 8).
//!
//! The unknowns are grid nodes, and two of them couple only when they lie
//! within `w` nodes of each other along every axis (`w = K::N − 1`, the
//! kernel's support). So a slab of `w` node planes across the box of a set
//! of nodes separates the nodes on its two sides: no entry of K joins them.
//! Ordering the two sides first (each by the same rule, recursively) and
//! the slab last keeps the factor's fill inside the sides' own blocks and
//! the slab's rows, where the approximate minimum degree ordering, which
//! sees only the graph, lets it spread on a regular grid. The two halves
//! are also two independent subtrees of the elimination tree of equal
//! work, which the triangular solves of `trisolve` run on two threads.

/// Sets of at most this many nodes are not cut further: they are ordered
/// as they come (ascending node index, x fastest).
const LEAF: usize = 8;

/// The nested-dissection order of the unknowns `dofs` (node indices of a
/// grid of `nodes` nodes per axis, x fastest, ascending) whose couplings
/// reach `w` nodes along each axis: `perm[i]` is the unknown (an index into
/// `dofs`) placed i-th. With it, the first cut `[a, b]` where there is
/// one: `perm[..a]` and `perm[a..b]` are the two sides, no unknown of one
/// coupled to an unknown of the other, and `perm[b..]` the slab between.
pub fn nested_dissection<const D: usize>(
    dofs: &[u32],
    nodes: [usize; D],
    w: usize,
) -> (Vec<usize>, Option<[usize; 2]>) {
    let mut items: Vec<([u32; D], u32)> = dofs
        .iter()
        .enumerate()
        .map(|(i, &node)| {
            let mut rest = node as usize;
            let at = std::array::from_fn(|d| {
                let c = rest % nodes[d];
                rest /= nodes[d];
                c as u32
            });
            (at, i as u32)
        })
        .collect();
    let mut perm = Vec::with_capacity(dofs.len());
    let cut = dissect(&mut items, w.max(1) as u32, &mut perm);
    (perm, cut)
}

/// Orders `items` (coordinates and unknown) into `perm`: the part below a
/// slab, the part above it, then the slab; returns where in `perm` the
/// second part and the slab begin (None: not cut).
fn dissect<const D: usize>(
    items: &mut [([u32; D], u32)],
    w: u32,
    perm: &mut Vec<usize>,
) -> Option<[usize; 2]> {
    if items.len() <= LEAF {
        leaf(items, perm);
        return None;
    }
    let mut lo = [u32::MAX; D];
    let mut hi = [0u32; D];
    for (at, _) in items.iter() {
        for d in 0..D {
            lo[d] = lo[d].min(at[d]);
            hi[d] = hi[d].max(at[d]);
        }
    }
    // the longest axis first; a thinner one if the slab would take a whole side
    let mut axes: [usize; D] = std::array::from_fn(|d| d);
    axes.sort_by_key(|&d| std::cmp::Reverse(hi[d] - lo[d]));
    for axis in axes {
        if hi[axis] - lo[axis] < w + 1 {
            continue;
        }
        // the slab [m, m + w) centred on the median node along the axis
        let mid = items.len() / 2;
        items.select_nth_unstable_by_key(mid, |(at, _)| at[axis]);
        let m = items[mid].0[axis]
            .saturating_sub(w / 2)
            .clamp(lo[axis] + 1, hi[axis] - w);
        // below | slab | above, in place; each part keeps no particular order
        let below = partition(items, |at| at[axis] < m);
        let slab = below + partition(&mut items[below..], |at| at[axis] < m + w);
        if below == 0 || slab == items.len() {
            continue;
        }
        let (low, rest) = items.split_at_mut(below);
        let (sep, high) = rest.split_at_mut(slab - below);
        dissect(low, w, perm);
        let a = perm.len();
        dissect(high, w, perm);
        let b = perm.len();
        leaf(sep, perm);
        return Some([a, b]);
    }
    leaf(items, perm);
    None
}

/// Moves the items for which `left` holds to the front; returns how many.
fn partition<const D: usize>(
    items: &mut [([u32; D], u32)],
    left: impl Fn(&[u32; D]) -> bool,
) -> usize {
    let mut k = 0;
    for i in 0..items.len() {
        if left(&items[i].0) {
            items.swap(i, k);
            k += 1;
        }
    }
    k
}

/// A set not cut further, in ascending unknown (node) order.
fn leaf<const D: usize>(items: &mut [([u32; D], u32)], perm: &mut Vec<usize>) {
    items.sort_unstable_by_key(|&(_, i)| i);
    perm.extend(items.iter().map(|&(_, i)| i as usize));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every unknown once, and the first cut's two sides never within `w`
    /// nodes of each other along every axis, on an ellipse's nodes (not a
    /// box) and a box in 3D.
    #[test]
    fn a_permutation_whose_sides_do_not_couple() {
        fn check<const D: usize>(nodes: [usize; D], keep: impl Fn([usize; D]) -> bool) {
            let total: usize = nodes.iter().product();
            let at = |n: usize| -> [usize; D] {
                let mut rest = n;
                std::array::from_fn(|d| {
                    let c = rest % nodes[d];
                    rest /= nodes[d];
                    c
                })
            };
            let dofs: Vec<u32> = (0..total as u32)
                .filter(|&n| keep(at(n as usize)))
                .collect();
            for w in [1, 2, 3] {
                let (perm, cut) = nested_dissection(&dofs, nodes, w);
                let mut seen = vec![false; dofs.len()];
                for &p in &perm {
                    assert!(!seen[p], "unknown {p} twice");
                    seen[p] = true;
                }
                assert!(seen.iter().all(|&s| s), "an unknown missing");
                let [a, b] = cut.expect("a cut");
                assert!(
                    0 < a && a < b && b < perm.len(),
                    "cut {a} {b} of {}",
                    perm.len()
                );
                for &p in &perm[..a] {
                    for &q in &perm[a..b] {
                        let (x, y) = (at(dofs[p] as usize), at(dofs[q] as usize));
                        assert!(
                            (0..D).any(|d| x[d].abs_diff(y[d]) > w),
                            "nodes {x:?} and {y:?} couple across the slab (w = {w})"
                        );
                    }
                }
            }
        }
        check([40, 17], |[x, y]| {
            let (x, y) = (x as f64 - 20.0, y as f64 - 8.0);
            x * x / 400.0 + y * y / 64.0 <= 1.0
        });
        check([9, 7, 11], |_| true);
    }
}
