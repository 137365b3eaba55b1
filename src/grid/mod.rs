//! The uniform background grid: geometry, nodal field arrays, multi-field
//! bookkeeping, and the tile colouring that makes the scatter parallel and
//! deterministic.
//!
//! Nodes are stored for the user's domain plus [`PAD`] ghost nodes on each
//! side, so that every kernel's support stays inside the arrays for any
//! particle inside the domain. Boundary conditions act on the wall node and
//! the ghost nodes beyond it.
//!
//! **Velocity fields.** Every node has one field (slot = node index). When a
//! scene has several contact groups, a node touched by `k > 1` groups gets
//! `k − 1` extra slots appended after the node slots; the first field of a
//! node belongs to its lowest group present. Single-field nodes pay nothing.

pub mod shape;
pub mod support;

use crate::particles::Particles;
use rayon::prelude::*;
use shape::Kernel;
pub use support::{Support, SupportCache, SupportNode};

use std::marker::PhantomData;
use std::ops::Range;

/// Ghost nodes beyond the domain on each side.
pub const PAD: usize = 2;
/// Tile edge in cells for the coloured scatter. Tiles of one colour are two
/// tiles apart, so their stencils (at most cells c−1..c+2) never overlap as
/// long as TILE ≥ 3.
pub const TILE: usize = 8;

/// Geometry of the padded node lattice, in `D` = 2 or 3 dimensions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridGeom<const D: usize = 2> {
    /// Cell size, m.
    pub h: f64,
    pub inv_h: f64,
    /// Coordinates of node (0, 0(, 0)) (a ghost node), m.
    pub origin: [f64; D],
    /// Node counts along each axis, including ghosts.
    pub nodes: [usize; D],
    /// The user's domain, m (particles must stay inside).
    pub domain_min: [f64; D],
    pub domain_max: [f64; D],
    /// Tiles along each axis.
    pub tiles: [usize; D],
    /// Per axis, whether its low and its high side (left/right,
    /// bottom/top, back/front) are walls (fixed or roller): particles are
    /// kept on the domain's side of them ([`GridGeom::keep_inside`]).
    pub walls: [[bool; 2]; D],
    /// The LME locality γ = βh² of the grid's shape functions
    /// ([`shape::Lme`]; the other kernels ignore it).
    pub lme_gamma: f64,
}

impl<const D: usize> GridGeom<D> {
    pub fn new(min: [f64; D], h: f64, cells: [usize; D]) -> GridGeom<D> {
        let nodes = cells.map(|c| c + 1 + 2 * PAD);
        GridGeom {
            h,
            inv_h: 1.0 / h,
            origin: std::array::from_fn(|d| min[d] - PAD as f64 * h),
            nodes,
            domain_min: min,
            domain_max: std::array::from_fn(|d| min[d] + cells[d] as f64 * h),
            tiles: nodes.map(|n| n.div_ceil(TILE)),
            walls: [[false; 2]; D],
            lme_gamma: shape::LME_GAMMA_DEFAULT,
        }
    }

    /// A particle that crossed a wall in its move is put back on it, and
    /// its velocity's component out through the wall is dropped. The wall
    /// nodes hold zero normal velocity, but a particle within a cell of
    /// them interpolates some of its inner neighbours' velocity and, under
    /// sustained pressure (a block squeezed on a roller floor), creeps
    /// through. Free and traction sides are left alone: there leaving the
    /// grid is a job failure.
    #[inline(always)]
    pub fn keep_inside(&self, x: &mut [f64; D], v: &mut [f64; D]) {
        for a in 0..D {
            if self.walls[a][0] && x[a] < self.domain_min[a] {
                x[a] = self.domain_min[a];
                v[a] = v[a].max(0.0);
            }
            if self.walls[a][1] && x[a] > self.domain_max[a] {
                x[a] = self.domain_max[a];
                v[a] = v[a].min(0.0);
            }
        }
    }

    pub fn node_count(&self) -> usize {
        self.nodes.iter().product()
    }

    pub fn tile_count(&self) -> usize {
        self.tiles.iter().product()
    }

    /// Node-index strides of the axes: `[1, nx(, nx·ny)]`.
    #[inline(always)]
    pub fn strides(&self) -> [usize; D] {
        let mut s = [1; D];
        for d in 1..D {
            s[d] = s[d - 1] * self.nodes[d - 1];
        }
        s
    }

    /// Position in node units.
    #[inline(always)]
    pub fn xi(&self, x: [f64; D]) -> [f64; D] {
        std::array::from_fn(|d| (x[d] - self.origin[d]) * self.inv_h)
    }

    /// Index of the node at lattice coordinates `at`:
    /// `i + nx·(j + ny·k)`.
    #[inline(always)]
    pub fn node(&self, at: [usize; D]) -> usize {
        let mut n = at[D - 1];
        for d in (0..D - 1).rev() {
            n = n * self.nodes[d] + at[d];
        }
        n
    }

    /// Lattice coordinates of node `n` ([`GridGeom::node`]'s inverse).
    #[inline(always)]
    pub fn node_coords(&self, n: usize) -> [usize; D] {
        let mut rest = n;
        std::array::from_fn(|d| {
            let c = rest % self.nodes[d];
            rest /= self.nodes[d];
            c
        })
    }

    pub fn node_position(&self, n: usize) -> [f64; D] {
        let at = self.node_coords(n);
        std::array::from_fn(|d| self.origin[d] + at[d] as f64 * self.h)
    }

    /// Tile of a particle at node-unit position `xi` (clamped into the grid).
    #[inline(always)]
    pub fn tile_of(&self, xi: [f64; D]) -> u32 {
        let mut t = 0;
        for d in (0..D).rev() {
            let c = (xi[d].max(0.0) as usize).min(self.nodes[d] - 1) / TILE;
            t = t * self.tiles[d] + c;
        }
        t as u32
    }

    /// Which of the (TILE + 1)^D supports that start in or next to the
    /// particle's tile ([`GridGeom::tile_of`]) a kernel of `support` nodes
    /// ([`shape::Kernel::N`]) has there: particles with the same support
    /// get the same number. ⌊ξ + shift⌋ names the support, with shift ½
    /// for odd supports (GIMP, quadratic B-spline: it starts at
    /// ⌊ξ + ½⌋ − 1) and 0 for even (linear, cubic: ⌊ξ⌋ − k).
    #[inline(always)]
    pub fn support_in_tile(&self, xi: [f64; D], support: usize) -> u32 {
        let shift = if support % 2 == 1 { 0.5 } else { 0.0 };
        let local = |d: usize| {
            let cell = (xi[d].max(0.0) as usize).min(self.nodes[d] - 1);
            let support = ((xi[d] + shift).max(0.0) as usize).min(self.nodes[d] - 1);
            (support as isize - (cell / TILE * TILE) as isize).clamp(0, TILE as isize) as u32
        };
        let mut key = 0;
        for d in (0..D).rev() {
            key = key * (TILE as u32 + 1) + local(d);
        }
        key
    }

    pub fn inside_domain(&self, x: [f64; D]) -> bool {
        (0..D).all(|d| x[d] >= self.domain_min[d] && x[d] <= self.domain_max[d])
    }
}

/// Nodal quantities per velocity-field slot.
#[derive(Debug, Clone, Default)]
pub struct GridFields<const D: usize = 2> {
    /// Σ N m_p, kg.
    pub mass: Vec<f64>,
    /// Σ N m_p v_p (APIC: plus the affine term), kg·m/s.
    pub momentum: Vec<[f64; D]>,
    /// Internal + external force, N.
    pub force: Vec<[f64; D]>,
    /// Velocity at the start of the step (momentum / mass), m/s.
    pub vel_old: Vec<[f64; D]>,
    /// Velocity at the end of the step (after forces, contact, BCs), m/s.
    pub vel: Vec<[f64; D]>,
    /// Σ m_p ∇N (contact normals); empty without contact.
    pub mass_grad: Vec<[f64; D]>,
    /// Newmark with contact: the contacted predictor velocities, with
    /// which the particles move (`vel_old` keeps the uncontacted one the
    /// accelerations are measured from); empty otherwise.
    pub vel_moved: Vec<[f64; D]>,
}

/// Heap bytes of a vector (capacity × element size).
fn vec_bytes<T>(v: &Vec<T>) -> usize {
    v.capacity() * std::mem::size_of::<T>()
}

impl<const D: usize> GridFields<D> {
    /// Bytes the nodal arrays hold on the heap (capacity × element size).
    pub fn heap_bytes(&self) -> usize {
        vec_bytes(&self.mass)
            + vec_bytes(&self.momentum)
            + vec_bytes(&self.force)
            + vec_bytes(&self.vel_old)
            + vec_bytes(&self.vel)
            + vec_bytes(&self.mass_grad)
            + vec_bytes(&self.vel_moved)
    }

    /// Prepares the arrays for a scatter into `nodes` node slots plus
    /// `slots − nodes` extra field slots: zeroes the node ranges the last
    /// scatter wrote (`written`; every other node is still zero) and the
    /// extra slots. Only active tiles cost anything.
    pub fn reset(
        &mut self,
        nodes: usize,
        slots: usize,
        with_mass_grad: bool,
        written: &[Range<usize>],
    ) {
        fn clear<T: Copy + Send + Sync>(
            v: &mut Vec<T>,
            nodes: usize,
            slots: usize,
            zero: T,
            written: &[Range<usize>],
        ) {
            if v.len() < nodes {
                v.clear();
                v.resize(nodes, zero);
            } else {
                v.truncate(nodes);
                for r in written {
                    v[r.clone()].fill(zero);
                }
            }
            v.resize(slots, zero);
        }
        clear(&mut self.mass, nodes, slots, 0.0, written);
        clear(&mut self.momentum, nodes, slots, [0.0; D], written);
        clear(&mut self.force, nodes, slots, [0.0; D], written);
        self.vel_old.resize(slots, [0.0; D]);
        self.vel.resize(slots, [0.0; D]);
        if with_mass_grad {
            clear(&mut self.mass_grad, nodes, slots, [0.0; D], written);
        }
    }
}

/// Which velocity fields exist at each node this step (contact scenes only).
#[derive(Debug, Clone, Default)]
pub struct MultiField {
    /// Bit g set if contact group g has mass at the node.
    pub mask: Vec<u32>,
    /// For node n, its extra slots are `nodes + offset[n] .. nodes + offset[n+1]`.
    pub offset: Vec<u32>,
    /// The node of every extra slot.
    pub extra_node: Vec<u32>,
    /// Nodes with more than one field.
    pub multi_nodes: Vec<u32>,
}

/// Maps a (node, particle) pair to the velocity-field slot the particle
/// maps to at that node.
pub trait FieldSlots: Sync {
    fn slot(&self, node: usize, particle: usize) -> usize;
}

/// Every particle in one field: the slot is the node.
pub struct SingleField;

impl FieldSlots for SingleField {
    #[inline(always)]
    fn slot(&self, node: usize, _particle: usize) -> usize {
        node
    }
}

/// One field per contact group present at a node.
pub struct GroupFields<'a> {
    pub nodes: usize,
    pub multi: &'a MultiField,
    /// Dense contact group of each particle.
    pub group: &'a [u8],
}

impl MultiField {
    /// The slot of field bit `field` at `node` (the bit must be set).
    #[inline(always)]
    pub fn slot_of(&self, nodes: usize, node: usize, field: u32) -> usize {
        let rank = (self.mask[node] & ((1u32 << field) - 1)).count_ones() as usize;
        if rank == 0 {
            node
        } else {
            nodes + self.offset[node] as usize + rank - 1
        }
    }

    /// Lays out the extra slots for the current masks; returns the number
    /// of slots (nodes + extra).
    pub fn layout(&mut self) -> usize {
        let nodes = self.mask.len();
        self.offset.clear();
        self.offset.reserve(nodes + 1);
        self.extra_node.clear();
        self.multi_nodes.clear();
        let mut total = 0u32;
        for (n, &m) in self.mask.iter().enumerate() {
            self.offset.push(total);
            let k = m.count_ones();
            if k > 1 {
                self.multi_nodes.push(n as u32);
                for _ in 1..k {
                    self.extra_node.push(n as u32);
                }
                total += k - 1;
            }
        }
        self.offset.push(total);
        nodes + total as usize
    }
}

impl FieldSlots for GroupFields<'_> {
    #[inline(always)]
    fn slot(&self, node: usize, particle: usize) -> usize {
        self.multi
            .slot_of(self.nodes, node, self.group[particle] as u32)
    }
}

/// Fewest particles [`Bins::rebuild`] gives a thread: below, the sort runs
/// on fewer threads (the counts per tile of each chunk cost more than they
/// save).
pub const REBIN_CHUNK: usize = 16_384;
/// Tiles one task of [`Bins::rebuild`]'s sort by support takes.
const REBIN_TILES: usize = 16;
/// (TILE + 1)^3: the supports that start in or next to a tile in 3D
/// ([`GridGeom::support_in_tile`]).
const SUPPORTS_IN_TILE_3D: usize = (TILE + 1) * (TILE + 1) * (TILE + 1);

/// Particles binned by tile, and the tiles of each of the 2^D colours.
#[derive(Debug, Clone, Default)]
pub struct Bins {
    /// Tile of each particle.
    pub tile_of: Vec<u32>,
    /// Particle indices sorted by tile, and in a tile by support
    /// ([`GridGeom::support_in_tile`]; stable: ascending index among
    /// particles of one support).
    pub order: Vec<u32>,
    /// `order[start[t]..start[t+1]]` are the particles of tile t.
    pub start: Vec<u32>,
    /// Non-empty tiles of each colour (tile x parity + 2·(y parity)
    /// + 4·(z parity)): four colours in 2D, eight in 3D.
    pub colours: Vec<Vec<u32>>,
    /// The active nodes, as ascending runs of node indices along rows: the
    /// nodes of every tile that holds particles or touches one that does
    /// (a particle's support reaches one node below and two above its
    /// cell, so into the neighbouring tiles). Runs go along x, row by row
    /// (y, then z), in ascending node order.
    pub active: Vec<Range<usize>>,
    /// Scratch of [`Bins::rebuild`]: each particle's support in its tile,
    /// each chunk's cursor per tile, and the particles sorted by tile alone.
    key: Vec<u32>,
    cursor: Vec<u32>,
    by_tile: Vec<u32>,
}

impl Bins {
    /// Bytes the bins hold on the heap (capacity × element size).
    pub fn heap_bytes(&self) -> usize {
        vec_bytes(&self.tile_of)
            + vec_bytes(&self.order)
            + vec_bytes(&self.start)
            + vec_bytes(&self.colours)
            + self.colours.iter().map(vec_bytes).sum::<usize>()
            + vec_bytes(&self.active)
            + vec_bytes(&self.key)
            + vec_bytes(&self.cursor)
            + vec_bytes(&self.by_tile)
    }

    /// The bins of particles at `x` for a kernel of `support` nodes.
    pub fn new<const D: usize>(geom: &GridGeom<D>, x: &[[f64; D]], support: usize) -> Bins {
        let mut bins = Bins {
            tile_of: x.iter().map(|&x| geom.tile_of(geom.xi(x))).collect(),
            ..Default::default()
        };
        bins.rebuild(geom, x, support);
        bins
    }

    /// Counting sort of particles (at `x`) by `tile_of` and, in a tile, by
    /// the support a kernel of `support` nodes has there: stable, so a
    /// particle's place follows from (tile, support, index) alone and the
    /// order is the same for any thread count. Consecutive particles of one
    /// support let the phase-field assembly add a whole run to K at once
    /// (`CellBlock`); sorted by tile alone, a tile's particles came row by
    /// row and a run was one row of the support, a third of it with 3 × 3
    /// particles per cell. Particles that change support but not tile keep
    /// their place until the next rebuild: the order is then a little
    /// slower, never wrong.
    ///
    /// In parallel, in two stable passes (issue 37: the serial sort took
    /// 55 % of a spinning disk's step on 16 threads). The particles, cut
    /// into one contiguous chunk per thread (at least [`REBIN_CHUNK`]
    /// each), are counted per tile and placed by tile, each chunk from
    /// cursors of its own that put its particles of a tile after those of
    /// the chunks before it; then each tile's run is sorted by support by
    /// a counting sort of its own. The result is the one stable sort by
    /// (tile, support), whatever the chunks.
    pub fn rebuild<const D: usize>(&mut self, geom: &GridGeom<D>, x: &[[f64; D]], support: usize) {
        let n = self.tile_of.len();
        assert_eq!(n, x.len(), "Bins::rebuild: tile_of and x differ in length");
        let ntiles = geom.tile_count();
        let chunks = n
            .div_ceil(REBIN_CHUNK)
            .clamp(1, rayon::current_num_threads());
        let len = n.div_ceil(chunks).max(1);
        // each particle's support in its tile; each chunk's count per tile
        self.key.resize(n, 0);
        self.cursor.clear();
        self.cursor.resize(chunks * ntiles, 0);
        self.key
            .par_chunks_mut(len)
            .zip(self.tile_of.par_chunks(len))
            .zip(x.par_chunks(len))
            .zip(self.cursor.par_chunks_mut(ntiles))
            .for_each(|(((key, tiles), x), count)| {
                for ((k, &t), &x) in key.iter_mut().zip(tiles).zip(x) {
                    *k = geom.support_in_tile(geom.xi(x), support);
                    count[t as usize] += 1;
                }
            });
        // tile by tile, chunk by chunk: where each chunk's run of a tile starts
        self.start.clear();
        self.start.reserve(ntiles + 1);
        let mut total = 0u32;
        for t in 0..ntiles {
            self.start.push(total);
            for c in 0..chunks {
                let count = std::mem::replace(&mut self.cursor[c * ntiles + t], total);
                total += count;
            }
        }
        self.start.push(total);
        // by tile, into `by_tile`
        self.by_tile.resize(n, 0);
        let by_tile = SyncPtr::new(&mut self.by_tile);
        self.tile_of
            .par_chunks(len)
            .zip(self.cursor.par_chunks_mut(ntiles))
            .enumerate()
            .for_each(|(c, (tiles, cursor))| {
                for (i, &t) in tiles.iter().enumerate() {
                    let at = &mut cursor[t as usize];
                    // SAFETY: the cursors of all chunks and tiles hand out
                    // disjoint places in 0..n, each once
                    unsafe { *by_tile.at(*at as usize) = (c * len + i) as u32 };
                    *at += 1;
                }
            });
        // each tile's run by support, into `order`
        self.order.resize(n, 0);
        let order = SyncPtr::new(&mut self.order);
        let (key, by_tile, start) = (&self.key, &self.by_tile, &self.start);
        let per_tile = (TILE + 1).pow(D as u32);
        (0..ntiles.div_ceil(REBIN_TILES))
            .into_par_iter()
            .for_each(|g| {
                let mut at = [0u32; SUPPORTS_IN_TILE_3D];
                let at = &mut at[..per_tile];
                for t in g * REBIN_TILES..((g + 1) * REBIN_TILES).min(ntiles) {
                    let (a, b) = (start[t] as usize, start[t + 1] as usize);
                    let run = &by_tile[a..b];
                    at.fill(0);
                    for &p in run {
                        at[key[p as usize] as usize] += 1;
                    }
                    let mut sum = a as u32;
                    for c in at.iter_mut() {
                        sum += std::mem::replace(c, sum);
                    }
                    for &p in run {
                        let c = &mut at[key[p as usize] as usize];
                        // SAFETY: tile t's cursors hand out the places a..b,
                        // which no other tile's do
                        unsafe { *order.at(*c as usize) = p };
                        *c += 1;
                    }
                }
            });
        self.tiles_from_start(geom);
    }

    /// The bins of particles at `x` in a saved `order` (a checkpoint's:
    /// within a tile the order depends on where the particles were at the
    /// last rebuild, and it sets the order of the sums into the grid).
    /// Fails if `order` does not list every particle once, tile by tile.
    pub fn restore<const D: usize>(
        &mut self,
        geom: &GridGeom<D>,
        x: &[[f64; D]],
        order: Vec<u32>,
    ) -> Result<(), String> {
        let ntiles = geom.tile_count();
        self.tile_of = x.iter().map(|&x| geom.tile_of(geom.xi(x))).collect();
        let mut seen = vec![false; x.len()];
        let sorted = order.len() == x.len()
            && order.iter().all(|&p| {
                (p as usize) < x.len() && !std::mem::replace(&mut seen[p as usize], true)
            })
            && order
                .windows(2)
                .all(|w| self.tile_of[w[0] as usize] <= self.tile_of[w[1] as usize]);
        if !sorted {
            return Err("the saved particle order does not sort the particles by tile".into());
        }
        self.start.clear();
        self.start.resize(ntiles + 1, 0);
        for &t in &self.tile_of {
            self.start[t as usize + 1] += 1;
        }
        for t in 0..ntiles {
            self.start[t + 1] += self.start[t];
        }
        self.order = order;
        self.tiles_from_start(geom);
        Ok(())
    }

    /// The colours and the active node runs of the tiles `start` fills.
    fn tiles_from_start<const D: usize>(&mut self, geom: &GridGeom<D>) {
        let ntiles = geom.tile_count();
        self.colours.resize(1 << D, Vec::new());
        for c in &mut self.colours {
            c.clear();
        }
        let tiles = geom.tiles;
        let mut tile_stride = [1; D];
        for d in 1..D {
            tile_stride[d] = tile_stride[d - 1] * tiles[d - 1];
        }
        let mut live = vec![false; ntiles];
        for t in 0..ntiles {
            if self.start[t + 1] > self.start[t] {
                let tc: [usize; D] = std::array::from_fn(|d| t / tile_stride[d] % tiles[d]);
                let colour = (0..D).map(|d| (tc[d] % 2) << d).sum::<usize>();
                self.colours[colour].push(t as u32);
                // the tile and its neighbours along every axis (3^D tiles)
                'next: for around in 0..3usize.pow(D as u32) {
                    let mut n = 0;
                    let mut rest = around;
                    for d in 0..D {
                        let c = (tc[d] + rest % 3).checked_sub(1);
                        rest /= 3;
                        match c {
                            Some(c) if c < tiles[d] => n += c * tile_stride[d],
                            _ => continue 'next,
                        }
                    }
                    live[n] = true;
                }
            }
        }
        // Runs of active nodes along x, row by row, merging neighbouring
        // tiles.
        self.active.clear();
        let nx = geom.nodes[0];
        let ntx = tiles[0];
        let rows: usize = geom.nodes[1..].iter().product();
        for r in 0..rows {
            // the row's first tile: its (y, z) node coordinates over TILE
            let mut first_tile = 0;
            let mut rest = r;
            for d in 1..D {
                first_tile += (rest % geom.nodes[d]) / TILE * tile_stride[d];
                rest /= geom.nodes[d];
            }
            let row = &live[first_tile..first_tile + ntx];
            let mut tx = 0;
            while tx < ntx {
                if !row[tx] {
                    tx += 1;
                    continue;
                }
                let first = tx;
                while tx < ntx && row[tx] {
                    tx += 1;
                }
                let (a, b) = (first * TILE, (tx * TILE).min(nx));
                self.active.push(r * nx + a..r * nx + b);
            }
        }
    }

    pub fn particles_of(&self, tile: u32) -> &[u32] {
        &self.order[self.start[tile as usize] as usize..self.start[tile as usize + 1] as usize]
    }
}

/// The support of particle `p` (GIMP uses the particle's half-width), the
/// kept one where the step keeps supports ([`Support::kept`]).
#[inline(always)]
pub fn particle_support<K: Kernel, const D: usize, const V: usize>(
    geom: &GridGeom<D>,
    parts: &Particles<D, V>,
    p: usize,
) -> Support<K, D> {
    let lp = parts.half_size.get(p).copied().unwrap_or(0.0);
    Support::kept(geom, parts.x[p], lp, &parts.supports, p)
}

/// Runs `scatter(p, support)` for every particle: colour by colour, the
/// tiles of one colour in parallel, the particles of a tile in ascending
/// order. Writes from one tile never meet writes from another tile of the
/// same colour (see [`crate::grid::TILE`]), so `scatter` may add into the
/// nodes of the particle's support through a [`SyncPtr`], and the order of
/// the additions at every node is the same for any number of threads.
///
/// A tile's loop runs in [`crate::cpu::wide`]'s copy, so callers mark
/// `scatter` and every closure it passes on (the per-node one of
/// [`Support::for_each`]) `#[inline(always)]`: only code inlined into that
/// copy gets the wider instructions (see [`crate::cpu`]).
pub fn scatter_coloured<K: Kernel, const D: usize, const V: usize>(
    geom: &GridGeom<D>,
    parts: &Particles<D, V>,
    bins: &Bins,
    scatter: impl Fn(usize, &Support<K, D>) + Sync,
) {
    scatter_tiles::<K, D, V>(geom, parts, bins, |_| true, scatter);
}

/// [`scatter_coloured`] over the particles of the tiles `t` for which
/// `take(t)`, the others left out (in the same order).
pub fn scatter_tiles<K: Kernel, const D: usize, const V: usize>(
    geom: &GridGeom<D>,
    parts: &Particles<D, V>,
    bins: &Bins,
    take: impl Fn(u32) -> bool + Sync,
    scatter: impl Fn(usize, &Support<K, D>) + Sync,
) {
    for colour in &bins.colours {
        colour.par_iter().filter(|&&t| take(t)).for_each(|&tile| {
            // a tile's loop, compiled wide where the CPU allows (same bits)
            crate::cpu::wide(
                #[inline(always)]
                || {
                    for &p in bins.particles_of(tile) {
                        let p = p as usize;
                        scatter(p, &particle_support::<K, D, V>(geom, parts, p));
                    }
                },
            )
        });
    }
}

/// A slice's elements for rayon tasks to write, each task its own:
/// shared between tasks, it hands out `&mut` to single elements. Used only
/// where the colouring (or disjoint index ranges) guarantees that no two
/// tasks touch the same element. It borrows the slice mutably for `'a`, so
/// the slice can neither be read nor moved while it is in use; in debug
/// builds every access is bounds-checked.
pub struct SyncPtr<'a, T> {
    ptr: *mut T,
    len: usize,
    slice: PhantomData<&'a mut [T]>,
}

// (no `T: Copy` bound, which a derive would add)
impl<T> Clone for SyncPtr<'_, T> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<T> Copy for SyncPtr<'_, T> {}

// SAFETY: callers guarantee that concurrent tasks access disjoint elements.
unsafe impl<T: Send> Send for SyncPtr<'_, T> {}
unsafe impl<T: Send> Sync for SyncPtr<'_, T> {}

impl<'a, T> SyncPtr<'a, T> {
    pub fn new(v: &'a mut [T]) -> Self {
        SyncPtr {
            ptr: v.as_mut_ptr(),
            len: v.len(),
            slice: PhantomData,
        }
    }

    /// The slice has no elements (an optional particle array not in use).
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Element `i`.
    ///
    /// # Safety
    /// `i` is in bounds and no other task accesses element `i` concurrently.
    #[inline(always)]
    #[allow(clippy::mut_from_ref)]
    pub unsafe fn at(&self, i: usize) -> &mut T {
        debug_assert!(i < self.len, "SyncPtr: index {i} out of {}", self.len);
        unsafe { &mut *self.ptr.add(i) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fixed pseudo-random sequence of numbers in [0, 1) (a 64-bit LCG,
    /// the top 53 bits) from `seed`: the particles of the grid's tests.
    pub(in crate::grid) fn uniform(mut seed: u64) -> impl FnMut() -> f64 {
        move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// A debug build stops an access past the end of the slice.
    #[test]
    #[cfg(debug_assertions)]
    #[should_panic(expected = "SyncPtr: index 3 out of 3")]
    fn sync_ptr_checks_bounds_in_debug_builds() {
        let mut v = vec![0u32; 3];
        let p = SyncPtr::new(&mut v);
        // SAFETY: in a debug build the check panics before the access.
        unsafe { *p.at(3) = 1 };
    }

    /// Within each tile, the particles of one kernel support come as one
    /// run (what the phase-field assembly's `CellBlock` needs), for odd and
    /// even supports.
    #[test]
    fn bins_keep_a_tiles_particles_of_one_support_together() {
        let mut next = uniform(12345);
        let x: Vec<[f64; 2]> = (0..5000).map(|_| [30.0 * next(), 30.0 * next()]).collect();
        // (support width, first node of the support) of the kernels
        type FirstNode = fn(f64) -> isize;
        let kernels: [(usize, FirstNode); 5] = [
            (shape::Linear::N, |xi| {
                shape::Linear::eval(xi, 0.25, 0.0).base
            }),
            (shape::Gimp::N, |xi| shape::Gimp::eval(xi, 0.25, 0.0).base),
            (shape::QuadraticBspline::N, |xi| {
                shape::QuadraticBspline::eval(xi, 0.0, 0.0).base
            }),
            (shape::CubicBspline::N, |xi| {
                shape::CubicBspline::eval(xi, 0.0, 0.0).base
            }),
            (shape::Lme::N, |xi| shape::Lme::eval(xi, 0.0, 4.0).base),
        ];
        let geom = GridGeom::new([0.0, 0.0], 1.0, [30, 30]);
        for (n, base) in kernels {
            let bins = Bins::new(&geom, &x, n);
            let mut seen = vec![false; x.len()];
            for &p in &bins.order {
                assert!(
                    !std::mem::replace(&mut seen[p as usize], true),
                    "particle {p} twice"
                );
            }
            assert!(seen.iter().all(|&s| s));
            for t in 0..(geom.tiles[0] * geom.tiles[1]) as u32 {
                let run = bins.particles_of(t);
                assert!(run.iter().all(|&p| bins.tile_of[p as usize] == t));
                let support = |p: u32| {
                    let xi = geom.xi(x[p as usize]);
                    (base(xi[0]), base(xi[1]))
                };
                let mut done = std::collections::HashSet::new();
                for (k, &p) in run.iter().enumerate() {
                    if k > 0 && support(run[k - 1]) == support(p) {
                        assert!(run[k - 1] < p, "stable within a support");
                        continue;
                    }
                    assert!(
                        done.insert(support(p)),
                        "support {:?} split in tile {t} ({n}-node kernel)",
                        support(p)
                    );
                }
            }
        }
    }

    /// The parallel re-binning gives the one stable sort by (tile, support
    /// in the tile, index), on any number of threads, in 2D and 3D, for an
    /// odd and an even support, with enough particles for several chunks.
    #[test]
    fn rebinning_is_the_stable_sort_on_any_thread_count() {
        fn check<const D: usize>(cells: [usize; D], count: usize, support: usize) {
            let mut next = uniform(4242);
            let geom = GridGeom::<D>::new([0.0; D], 1.0, cells);
            // a quarter of the particles in one corner, so tiles differ in
            // their counts and some are empty
            let x: Vec<[f64; D]> = (0..count)
                .map(|i| {
                    let f = if i % 4 == 0 { 0.2 } else { 1.0 };
                    std::array::from_fn(|d| f * cells[d] as f64 * next())
                })
                .collect();
            let per_tile = (TILE + 1).pow(D as u32) as u64;
            let mut expected: Vec<u32> = (0..count as u32).collect();
            expected.sort_by_key(|&p| {
                let xi = geom.xi(x[p as usize]);
                geom.tile_of(xi) as u64 * per_tile + geom.support_in_tile(xi, support) as u64
            });
            let mut first: Option<Bins> = None;
            for threads in [1, 2, 3, 4] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let bins = pool.install(|| Bins::new(&geom, &x, support));
                assert_eq!(bins.order, expected, "{D}D, {threads} threads");
                match &first {
                    None => first = Some(bins),
                    Some(b) => {
                        assert_eq!(bins.start, b.start);
                        assert_eq!(bins.colours, b.colours);
                        assert_eq!(bins.active, b.active);
                    }
                }
            }
            assert!(count > 2 * REBIN_CHUNK, "several chunks");
        }
        check::<2>([90, 70], 40_000, shape::QuadraticBspline::N);
        check::<2>([90, 70], 40_000, shape::CubicBspline::N);
        check::<3>([30, 20, 26], 40_000, shape::Linear::N);
        check::<3>([30, 20, 26], 40_000, shape::QuadraticBspline::N);
    }

    /// In 2D and 3D, for every kernel: the tiles of one colour reach
    /// disjoint nodes (so the coloured scatter needs no atomics), and every
    /// node a particle's support reaches lies in an active run.
    #[test]
    fn colours_keep_stencils_apart_and_active_runs_cover_them() {
        fn check<K: Kernel, const D: usize>(cells: [usize; D], count: usize) {
            let mut next = uniform(777);
            let geom = GridGeom::<D>::new([0.0; D], 1.0, cells);
            // particles anywhere in the domain, ghost nodes included in reach
            let x: Vec<[f64; D]> = (0..count)
                .map(|_| std::array::from_fn(|d| cells[d] as f64 * next()))
                .collect();
            let bins = Bins::new(&geom, &x, K::N);
            assert_eq!(bins.colours.len(), 1 << D);
            let mut active = vec![false; geom.node_count()];
            for r in &bins.active {
                assert!(r.start < r.end && r.end <= geom.node_count());
                active[r.clone()].iter_mut().for_each(|a| *a = true);
            }
            for w in bins.active.windows(2) {
                assert!(w[0].end <= w[1].start, "runs ascend: {w:?}");
            }
            let mut tiles_seen = 0;
            for colour in &bins.colours {
                let mut owner = vec![u32::MAX; geom.node_count()];
                for &t in colour {
                    tiles_seen += 1;
                    for &p in bins.particles_of(t) {
                        Support::<K, D>::new(&geom, x[p as usize], 0.25).for_each(|n| {
                            assert!(active[n.node], "node {:?} of particle {p} not active", n.at);
                            let o = &mut owner[n.node];
                            assert!(
                                *o == u32::MAX || *o == t,
                                "tiles {o} and {t} of one colour share node {:?}",
                                n.at
                            );
                            *o = t;
                        });
                    }
                }
            }
            let nonempty = (0..geom.tile_count() as u32)
                .filter(|&t| !bins.particles_of(t).is_empty())
                .count();
            assert_eq!(tiles_seen, nonempty);
        }
        check::<shape::Linear, 2>([40, 33], 3000);
        check::<shape::QuadraticBspline, 2>([40, 33], 3000);
        check::<shape::CubicBspline, 2>([40, 33], 3000);
        check::<shape::Lme, 2>([40, 33], 3000);
        check::<shape::Lme, 3>([27, 19, 22], 3000);
        check::<shape::Linear, 3>([27, 19, 22], 6000);
        check::<shape::Gimp, 3>([27, 19, 22], 6000);
        check::<shape::QuadraticBspline, 3>([27, 19, 22], 6000);
        check::<shape::CubicBspline, 3>([27, 19, 22], 6000);
        // particles in a corner only: the active runs stay near them
        check::<shape::CubicBspline, 3>([40, 40, 40], 1);
    }
}
