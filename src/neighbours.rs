//! Neighbour lists of particles by cell binning, in 2D and 3D: for each
//! particle, every particle of the same key closer than a reach (itself
//! included). Homel & Herbold's DFG partitioning (section 2.5) builds them
//! for its damage field; the ε-neighbourhoods of eigenerosion and
//! eigensoftening (Molinos et al., eqs. 11–14) are the same search.
//!
//! The bins are squares (cubes) of the reach (larger where a reach far
//! below the particles' spacing would make more than about four bins per
//! particle); a particle's list is the particles of its own key in the
//! 3^D bins around its own, in bin order.
//! Lists are built in parallel (each chunk of particles its lists, joined
//! in particle order), the same for any thread count.

use crate::tensor::{dot, sub};
use rayon::prelude::*;

/// Neighbour lists by cell binning, in 2D or 3D.
#[derive(Debug, Clone, Default)]
pub struct Neighbours<const D: usize = 2> {
    /// `list[start[p]..start[p+1]]` are the particles within the build
    /// reach of p (p included), in bin order.
    start: Vec<u32>,
    list: Vec<u32>,
    /// Positions at the last build.
    x_built: Vec<[f64; D]>,
    /// Lists built so far.
    pub builds: u64,
}

impl<const D: usize> Neighbours<D> {
    /// The key of particles that take no part.
    pub const NONE: u16 = u16::MAX;

    /// The positions the lists were last built at (what a checkpoint
    /// keeps to build the same lists again).
    pub fn built_at(&self) -> &[[f64; D]] {
        &self.x_built
    }

    pub fn of(&self, p: usize) -> &[u32] {
        &self.list[self.start[p] as usize..self.start[p + 1] as usize]
    }

    /// Builds the lists: pairs closer than `reach` with the same `key`.
    /// Particles keyed [`Neighbours::NONE`] get no list and are in none.
    pub fn build(&mut self, x: &[[f64; D]], key: &[u16], reach: f64, min: [f64; D], max: [f64; D]) {
        let n = x.len();
        // Bins of the reach, or larger where that would make more bins
        // than about four per particle (a reach far below the spacing):
        // a pair closer than the reach is still in adjacent bins.
        let bins_of = |size: f64| -> [usize; D] {
            std::array::from_fn(|a| ((max[a] - min[a]) / size).ceil().min(1e9) as usize + 1)
        };
        let cap = 4.0 * n.max(1) as f64 + 64.0;
        let mut size = reach;
        while bins_of(size).iter().map(|&b| b as f64).product::<f64>() > cap {
            size *= 2.0;
        }
        let nb = bins_of(size);
        let bins: usize = nb.iter().product();
        // counting sort by bin (stable: ascending index inside a bin)
        let mut bin_start = vec![0u32; bins + 1];
        let bin_of: Vec<u32> = x
            .iter()
            .map(|&p| bin_index(bin_cell(p, min, size, nb), nb) as u32)
            .collect();
        for &b in &bin_of {
            bin_start[b as usize + 1] += 1;
        }
        for b in 0..bins {
            bin_start[b + 1] += bin_start[b];
        }
        let mut order = vec![0u32; n];
        let mut cursor = bin_start.clone();
        for (p, &b) in bin_of.iter().enumerate() {
            order[cursor[b as usize] as usize] = p as u32;
            cursor[b as usize] += 1;
        }
        // positions and keys in bin order: a visit reads consecutive memory
        let xs: Vec<[f64; D]> = order.iter().map(|&p| x[p as usize]).collect();
        let ks: Vec<u16> = order.iter().map(|&p| key[p as usize]).collect();
        let grid = BinGrid {
            x,
            key,
            order: &order,
            xs: &xs,
            ks: &ks,
            bin_start: &bin_start,
            nb,
            min,
            size,
            reach,
        };
        // One pass: each chunk of particles collects its lists, and the
        // chunks are joined in particle order.
        let chunks: Vec<(Vec<u32>, Vec<u32>)> = (0..n.div_ceil(BUILD_CHUNK))
            .into_par_iter()
            .map(|c| {
                let range = c * BUILD_CHUNK..((c + 1) * BUILD_CHUNK).min(n);
                let mut counts = Vec::with_capacity(range.len());
                let mut list = Vec::new();
                for p in range {
                    let before = list.len();
                    grid.visit(p, |q| list.push(q));
                    counts.push((list.len() - before) as u32);
                }
                (counts, list)
            })
            .collect();
        self.start.clear();
        self.start.reserve(n + 1);
        let mut total = 0u32;
        self.start.push(0);
        for &k in chunks.iter().flat_map(|c| &c.0) {
            total += k;
            self.start.push(total);
        }
        self.list.clear();
        self.list.reserve(total as usize);
        for (_, l) in &chunks {
            self.list.extend_from_slice(l);
        }
        self.x_built.clear();
        self.x_built.extend_from_slice(x);
        self.builds += 1;
    }

    /// Sorts each list by particle index, so that a sum over a list runs
    /// in an order that depends on who is in it, not on where the bins
    /// were when it was built.
    pub fn sort(&mut self) {
        let mut rest: &mut [u32] = &mut self.list;
        let mut lists = Vec::with_capacity(self.start.len().saturating_sub(1));
        for w in self.start.windows(2) {
            let (l, r) = std::mem::take(&mut rest).split_at_mut((w[1] - w[0]) as usize);
            lists.push(l);
            rest = r;
        }
        lists.into_par_iter().for_each(|l| l.sort_unstable());
    }

    /// Whether some particle with a list moved more than `limit` since
    /// the last build.
    pub fn stale(&self, x: &[[f64; D]], limit: f64) -> bool {
        if self.x_built.len() != x.len() {
            return true;
        }
        let l2 = limit * limit;
        x.par_iter()
            .zip(&self.x_built)
            .enumerate()
            .any(|(p, (a, b))| {
                let d = sub(*a, *b);
                self.start[p + 1] > self.start[p] && dot(d, d) > l2
            })
    }
}

/// The bin of a point (clamped into the bin grid).
#[inline(always)]
fn bin_cell<const D: usize>(p: [f64; D], min: [f64; D], size: f64, nb: [usize; D]) -> [usize; D] {
    std::array::from_fn(|a| (((p[a] - min[a]) / size).max(0.0) as usize).min(nb[a] - 1))
}

/// The index of bin `c`: x fastest, then y, then z.
#[inline(always)]
pub(crate) fn bin_index<const D: usize>(c: [usize; D], nb: [usize; D]) -> usize {
    let mut b = c[D - 1];
    for a in (0..D - 1).rev() {
        b = b * nb[a] + c[a];
    }
    b
}

/// Particles per rayon task of [`Neighbours::build`].
const BUILD_CHUNK: usize = 1024;

/// Particles sorted into square (cubic) bins of the search reach.
struct BinGrid<'a, const D: usize> {
    x: &'a [[f64; D]],
    key: &'a [u16],
    order: &'a [u32],
    /// `x` and `key` in `order`.
    xs: &'a [[f64; D]],
    ks: &'a [u16],
    bin_start: &'a [u32],
    nb: [usize; D],
    min: [f64; D],
    /// The bins' side, at least the reach.
    size: f64,
    reach: f64,
}

impl<const D: usize> BinGrid<'_, D> {
    /// Calls `f(q)` for every q closer than the reach to p with p's key, in
    /// bin order (the 3^D bins around p's, x fastest).
    #[inline(always)]
    fn visit(&self, p: usize, mut f: impl FnMut(u32)) {
        if self.key[p] == Neighbours::<D>::NONE {
            return;
        }
        let (xp, kp, r2) = (self.x[p], self.key[p], self.reach * self.reach);
        let c = bin_cell(xp, self.min, self.size, self.nb);
        let lo: [usize; D] = std::array::from_fn(|a| c[a].saturating_sub(1));
        let hi: [usize; D] = std::array::from_fn(|a| (c[a] + 2).min(self.nb[a]));
        let mut at = lo;
        loop {
            // the bins lo[0]..hi[0] of this row are consecutive
            let b = bin_index(at, self.nb);
            let row = self.bin_start[b] as usize..self.bin_start[b + hi[0] - lo[0]] as usize;
            for ((&q, &xq), &kq) in self.order[row.clone()]
                .iter()
                .zip(&self.xs[row.clone()])
                .zip(&self.ks[row])
            {
                let d = sub(xq, xp);
                if kq == kp && dot(d, d) < r2 {
                    f(q);
                }
            }
            let mut a = 1;
            loop {
                if a == D {
                    return;
                }
                at[a] += 1;
                if at[a] < hi[a] {
                    break;
                }
                at[a] = lo[a];
                a += 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn neighbour_lists_hold_every_close_pair_of_the_same_key() {
        let mut x = Vec::new();
        let mut key = Vec::new();
        for i in 0..30 {
            for j in 0..20 {
                x.push([0.013 * i as f64 + 0.001 * (j % 3) as f64, 0.011 * j as f64]);
                key.push(u16::from(i >= 15));
            }
        }
        check_neighbours(&x, &key, [0.0, 0.0], [0.4, 0.25], 0, 0.03);
        // a reach far below the spacing in a vast domain: bins of the
        // reach would be 10^30 of them; the lists are each point alone,
        // sorted by index after `sort`
        let mut nb = check_neighbours(&x, &key, [0.0, 0.0], [1.0e6, 1.0e6], 0, 1.0e-12);
        nb.sort();
        assert!((0..x.len()).all(|p| nb.of(p) == [p as u32]));
        let mut nb = check_neighbours(&x, &key, [0.0, 0.0], [0.4, 0.25], 1, 0.05);
        nb.sort();
        assert!((0..x.len()).all(|p| nb.of(p).windows(2).all(|w| w[0] < w[1])));
    }

    /// Builds the lists with `reach` and compares every particle's with a
    /// search of all pairs (same key, not [`Neighbours::NONE`], closer
    /// than the reach); a move of 2 mm along `axis` makes them stale, none
    /// does not. Returns the lists.
    fn check_neighbours<const D: usize>(
        x: &[[f64; D]],
        key: &[u16],
        min: [f64; D],
        max: [f64; D],
        axis: usize,
        reach: f64,
    ) -> Neighbours<D> {
        let mut nb = Neighbours::<D>::default();
        nb.build(x, key, reach, min, max);
        for p in 0..x.len() {
            let mut want: Vec<u32> = (0..x.len() as u32)
                .filter(|&q| {
                    let d = sub(x[q as usize], x[p]);
                    key[p] != Neighbours::<D>::NONE
                        && key[q as usize] == key[p]
                        && dot(d, d) < reach * reach
                })
                .collect();
            let mut got = nb.of(p).to_vec();
            got.sort();
            want.sort();
            assert_eq!(got, want, "particle {p}");
        }
        assert!(!nb.stale(x, 0.001));
        let mut y = x.to_vec();
        y[7][axis] += 0.002;
        assert!(nb.stale(&y, 0.001));
        nb
    }

    /// The same in 3D: cubic bins, the 27 around a particle's.
    #[test]
    fn neighbour_lists_hold_every_close_pair_of_the_same_key_in_3d() {
        let mut x = Vec::new();
        let mut key = Vec::new();
        for i in 0..14 {
            for j in 0..10 {
                for k in 0..8 {
                    let wobble = 0.001 * ((i + 2 * j + 3 * k) % 4) as f64;
                    x.push([
                        0.013 * i as f64 + wobble,
                        0.011 * j as f64,
                        0.012 * k as f64,
                    ]);
                    key.push(if i == 3 {
                        Neighbours::<3>::NONE
                    } else {
                        u16::from(k >= 4)
                    });
                }
            }
        }
        check_neighbours(&x, &key, [0.0; 3], [0.2, 0.12, 0.1], 2, 0.03);
    }
}
