//! Explicit cracks in the material point method: CRAMP extended to two
//! interacting cracks per node (Nairn & Aimene, "J-integral methods for
//! interacting cracks", section 2.1 and the appendix).
//!
//! A crack is a polyline of massless crack points ([`Crack`]); each point
//! also tracks the crack's two surfaces, above and below its plane
//! ("above" is the left of the polyline's direction, where its normal
//! n̂ = (−t_y, t_x) points). Every step:
//!
//! 1. **Velocity fields** (`field_partition`, [`Cramp::partition`]): the
//!    line from each particle to each node of its support is traced
//!    against the cracks its grid cell sees (the appendix's crack hash:
//!    a cell sees the cracks with a segment within one cell of it); it
//!    crosses none (field 0), one (fields 1 and 2, one crack each, by
//!    side) or two (field 3). The fields of a node are allocated first
//!    come, first served in particle order, with the appendix's fallbacks
//!    for unexpected geometry (warnings #1 and #2, counted in the
//!    summary), and the crack normals at the crossings are summed per
//!    field for contact. The merge is serial in particle order, so the
//!    fields are the same for any thread count.
//! 2. **Momentum per field** (eq. 1): the step's P2G and G2P with the
//!    slots of [`CrampFields`].
//! 3. **Crack contact** (section 2.1.3, [`Cramp::contact`]): between the
//!    fields either side of one crack at a node, Coulomb friction with the
//!    crack's normal, where the faces approach and the tracked surfaces
//!    say the crack is closed there.
//! 4. **Crack surfaces** (`crack_surfaces`, [`Cramp::move_surfaces`],
//!    eqs. 3–6): each surface point takes the mass-weighted velocity of
//!    the fields on its own side (eq. 5) and moves by XPIC(1) (or FLIP);
//!    the plane point moves by the mean of its two surfaces' moves.
//! 5. **Growth** (`crack_growth`, only with `[cramp] growth`,
//!    [`Cramp::grow`], section 3.5): each tip's J and K_I, K_II; a new
//!    segment in the maximum-hoop-stress direction where K_I^max ≥ K_Ic.
//!
//! A crack may carry a face pressure (`crack_traction`, after the scatter,
//! [`traction`], section 2.1.4): nodal forces on the fields either side,
//! and its term in J.

pub mod contour;
pub mod growth;
pub mod j_integral;
pub mod model;
pub mod section;
pub mod snapshot;
pub mod traction;

use crate::grid::shape::Kernel;
use crate::grid::{particle_support, Bins, FieldSlots, GridFields, GridGeom, MultiField, Support};
use crate::particles::Particles;
use rayon::prelude::*;
use section::SurfaceUpdate;
use serde::{Deserialize, Serialize};

/// The line runs from a particle above the crack to a node below it.
pub const ABOVE: u8 = 1;
/// The line runs from a particle below the crack to a node above it.
pub const BELOW: u8 = 2;

/// Nodes of the widest 2D support (cubic B-spline, 4 × 4).
const MAX_LEN: usize = 16;
const NONE: u32 = u32::MAX;

/// One explicit crack: its plane points and surfaces, m, and the
/// surfaces' velocities, m/s.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Crack {
    /// Index of the body whose `explicit_cracks` list it came from.
    pub body: u16,
    /// Coulomb friction between its faces.
    pub friction: f64,
    pub plane: Vec<[f64; 2]>,
    pub above: Vec<[f64; 2]>,
    pub below: Vec<[f64; 2]>,
    pub v_above: Vec<[f64; 2]>,
    pub v_below: Vec<[f64; 2]>,
    /// Per end (start, end): whether growth has joined it to another
    /// crack (`Cramp::grow`): it is then no longer a tip (no J, no
    /// growth).
    pub joined: [bool; 2],
}

impl Crack {
    /// A crack along `points` with closed surfaces at rest.
    pub fn new(body: u16, friction: f64, points: Vec<[f64; 2]>) -> Crack {
        let n = points.len();
        Crack {
            body,
            friction,
            above: points.clone(),
            below: points.clone(),
            plane: points,
            v_above: vec![[0.0; 2]; n],
            v_below: vec![[0.0; 2]; n],
            joined: [false; 2],
        }
    }

    /// Whether `end` has been joined to another crack.
    pub fn is_joined(&self, end: contour::End) -> bool {
        self.joined[end as usize]
    }

    /// Unit normal of segment `k` (its left, the "above" side).
    pub fn normal(&self, k: usize) -> [f64; 2] {
        let (a, b) = (self.plane[k], self.plane[k + 1]);
        let d = [b[0] - a[0], b[1] - a[1]];
        let l = (d[0] * d[0] + d[1] * d[1]).sqrt();
        if l > 0.0 {
            [-d[1] / l, d[0] / l]
        } else {
            [0.0, 0.0]
        }
    }

    /// Normal opening of the faces at parameter `t` of segment `k`:
    /// (x_above − x_below)·n̂, m (positive: open).
    pub fn opening(&self, k: usize, t: f64) -> f64 {
        let lerp = |p: &[[f64; 2]], a: usize| p[k][a] + t * (p[k + 1][a] - p[k][a]);
        let n = self.normal(k);
        (0..2)
            .map(|a| (lerp(&self.above, a) - lerp(&self.below, a)) * n[a])
            .sum()
    }

    /// Normal opening of the faces at point `q` along `n`:
    /// (x_above − x_below)·n, m (positive: open).
    pub fn opening_at(&self, q: usize, n: [f64; 2]) -> f64 {
        (0..2)
            .map(|a| (self.above[q][a] - self.below[q][a]) * n[a])
            .sum()
    }

    /// Length along the plane, m.
    pub fn length(&self) -> f64 {
        self.plane
            .windows(2)
            .map(|w| ((w[1][0] - w[0][0]).powi(2) + (w[1][1] - w[0][1]).powi(2)).sqrt())
            .sum()
    }
}

/// Where a line crosses a crack.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Crossing {
    /// [`ABOVE`] or [`BELOW`]: the side of the line's start.
    pub side: u8,
    /// The segment crossed first, and the parameter along it.
    pub seg: u32,
    pub t: f64,
    /// The crack's unit normal there (pointing above).
    pub normal: [f64; 2],
}

fn cross2(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// Whether the segment from `p` to `q` crosses the polyline `plane`: an
/// odd number of crossings is a crossing (a line that crosses a wavy crack
/// twice, or touches a vertex where the crack turns back, ends on the side
/// it started). Each test is half-open (a point on a segment's line
/// counts as below it, a vertex on the line as off the side its segment
/// leaves to), so a line through a vertex crosses exactly one of the two
/// segments that meet there. The side and normal are the first
/// crossing's.
pub fn crossing(plane: &[[f64; 2]], p: [f64; 2], q: [f64; 2]) -> Option<Crossing> {
    let e = [q[0] - p[0], q[1] - p[1]];
    let mut count = 0u32;
    let mut first = None;
    for (k, w) in plane.windows(2).enumerate() {
        let (a, b) = (w[0], w[1]);
        let d = [b[0] - a[0], b[1] - a[1]];
        let op = cross2(d, [p[0] - a[0], p[1] - a[1]]);
        let oq = cross2(d, [q[0] - a[0], q[1] - a[1]]);
        if (op > 0.0) == (oq > 0.0) {
            continue;
        }
        let oa = cross2(e, [a[0] - p[0], a[1] - p[1]]);
        let ob = cross2(e, [b[0] - p[0], b[1] - p[1]]);
        if (oa > 0.0) == (ob > 0.0) {
            continue;
        }
        count += 1;
        if first.is_none() {
            let l = (d[0] * d[0] + d[1] * d[1]).sqrt();
            first = Some(Crossing {
                side: if op > 0.0 { ABOVE } else { BELOW },
                seg: k as u32,
                t: oa / (oa - ob),
                normal: [-d[1] / l, d[0] / l],
            });
        }
    }
    if count % 2 == 1 {
        first
    } else {
        None
    }
}

/// The cracks one particle–node line crosses (at most two: a node holds
/// the fields of two cracks).
#[derive(Debug, Clone, Copy, Default)]
struct PairCross {
    n: u8,
    crack: [u8; 2],
    at: [Option<Crossing>; 2],
}

/// One crack of a node's velocity field: which crack, the side its
/// particles are on (the node is on the other), where it was first
/// crossed, and the sum of the crack normals at its crossings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FieldCrack {
    pub crack: u8,
    pub side: u8,
    pub seg: u32,
    pub t: f64,
    pub normal: [f64; 2],
}

impl FieldCrack {
    fn of(crack: u8, c: &Crossing) -> FieldCrack {
        FieldCrack {
            crack,
            side: c.side,
            seg: c.seg,
            t: c.t,
            normal: c.normal,
        }
    }

    fn add(&mut self, n: [f64; 2]) {
        self.normal[0] += n[0];
        self.normal[1] += n[1];
    }
}

/// The crack velocity fields of one node: fields 1 and 2 (one crack each)
/// and field 3 (two cracks). Field 0 (no crack crossed) is always there.
#[derive(Debug, Clone, Copy)]
pub struct NodeCracks {
    pub node: u32,
    pub one: [Option<FieldCrack>; 2],
    pub both: Option<[FieldCrack; 2]>,
}

impl NodeCracks {
    /// The cracks of field `j` (0–3) and their sides.
    fn set(&self, j: usize) -> ([Option<FieldCrack>; 2], usize) {
        match j {
            1 | 2 => (
                [self.one[j - 1], None],
                usize::from(self.one[j - 1].is_some()),
            ),
            3 => match self.both {
                Some(b) => ([Some(b[0]), Some(b[1])], 2),
                None => ([None, None], 0),
            },
            _ => ([None, None], 0),
        }
    }

    /// The field whose cracks and sides are exactly `cracks` (crack,
    /// side), if the node has one.
    fn field_of(&self, cracks: &[(u8, u8)]) -> Option<u32> {
        match cracks.len() {
            0 => Some(0),
            1 => (0..2)
                .find(|&f| self.one[f].is_some_and(|r| (r.crack, r.side) == cracks[0]))
                .map(|f| f as u32 + 1),
            _ => {
                let b = self.both?;
                let has = |c: (u8, u8)| b.iter().any(|r| (r.crack, r.side) == c);
                (has(cracks[0]) && has(cracks[1])).then_some(3)
            }
        }
    }

    /// The side of crack `c` that the particles across it from this node
    /// are on, if the node has a field of that crack.
    fn side_of(&self, c: u8) -> Option<u8> {
        self.one
            .iter()
            .flatten()
            .chain(self.both.iter().flatten())
            .find(|r| r.crack == c)
            .map(|r| r.side)
    }
}

/// Unexpected crack geometry the field allocation got round (Nairn &
/// Aimene's appendix): #1, a line that crosses a crack from the side
/// opposite to the node's field (a point on the crack plane, usually);
/// #2, a node that sees a third crack (ignored).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Warnings {
    pub wrong_side: u64,
    pub third_crack: u64,
}

/// Allocates or finds the velocity field of a particle–node pair whose
/// line crosses `pc` (steps A–C of the appendix); returns the field.
fn assign(rec: &mut NodeCracks, pc: &PairCross, warn: &mut Warnings) -> u8 {
    let mut cr: [(u8, Crossing); 2] = [(0, CROSS0); 2];
    for (k, c) in cr.iter_mut().enumerate().take(pc.n as usize) {
        *c = (pc.crack[k], pc.at[k].unwrap_or(CROSS0));
    }
    let mut alpha = pc.n;
    if alpha == 2 {
        match rec.both.as_mut() {
            None => {
                rec.both = Some([
                    FieldCrack::of(cr[0].0, &cr[0].1),
                    FieldCrack::of(cr[1].0, &cr[1].1),
                ]);
                return 3;
            }
            Some(b) => {
                let m0 = b.iter().position(|r| r.crack == cr[0].0);
                let m1 = b.iter().position(|r| r.crack == cr[1].0);
                match (m0, m1) {
                    (Some(i), Some(j)) => {
                        let s0 = b[i].side == cr[0].1.side;
                        let s1 = b[j].side == cr[1].1.side;
                        if s0 && s1 {
                            b[i].add(cr[0].1.normal);
                            b[j].add(cr[1].1.normal);
                            return 3;
                        }
                        warn.wrong_side += 1;
                        if !s0 && !s1 {
                            return 0;
                        }
                        if !s0 {
                            cr[0] = cr[1];
                        }
                    }
                    (None, None) => {
                        warn.third_crack += 1;
                        return 0;
                    }
                    (m0, _) => {
                        warn.third_crack += 1;
                        if m0.is_none() {
                            cr[0] = cr[1];
                        }
                    }
                }
                alpha = 1;
            }
        }
    }
    debug_assert_eq!(alpha, 1);
    let (c, at) = cr[0];
    for f in 0..2 {
        match rec.one[f].as_mut() {
            None => {
                rec.one[f] = Some(FieldCrack::of(c, &at));
                return f as u8 + 1;
            }
            Some(r) if r.crack == c => {
                if r.side == at.side {
                    r.add(at.normal);
                    return f as u8 + 1;
                }
                warn.wrong_side += 1;
                return 0;
            }
            Some(_) => {}
        }
    }
    warn.third_crack += 1;
    0
}

const CROSS0: Crossing = Crossing {
    side: 0,
    seg: 0,
    t: 0.0,
    normal: [0.0; 2],
};

/// The explicit cracks of a scene and the per-step state of their
/// velocity fields.
#[derive(Debug, Clone, Default)]
pub struct Cramp {
    pub cracks: Vec<Crack>,
    pub update: SurfaceUpdate,
    /// The sides of the J contours, cells (`[cramp] j_contours`).
    pub j_contours: Vec<u32>,
    /// The particles' velocities and ∇u at the start of a step whose end
    /// needs J (on a series row; with growth, every step), and its Δt:
    /// the accelerations and velocity gradients of J's volume term
    /// (eq. 9). None in other steps.
    before_row: Option<contour::BeforeRow>,
    /// The 2D thickness, m (`analysis.thickness`).
    pub thickness: f64,
    /// How J treats other cracks at its contour (`[cramp] j_method`).
    pub j_method: section::JMethod,
    /// How J is split into K_I and K_II (`[cramp] k_split`).
    pub k_split: section::KSplit,
    /// Crack growth (`[cramp] growth`), if the scene asks for it.
    pub growth: Option<section::GrowthSpec>,
    /// Per crack, its face pressure (`explicit_cracks[k].pressure`), Pa.
    pub pressure: Vec<Option<crate::scene::schema::TimeFunction>>,
    /// Per crack, how many of its points at the start and at the end lie
    /// outside its body (no pressure there); growth adds points only at
    /// tips, inside, so the counts hold as the crack grows.
    pub outside: Vec<(usize, usize)>,
    /// The scene's crack points (those beyond them were grown).
    initial_points: usize,
    /// The energy released by growth so far, J: Σ J Δa t over the
    /// segments added (`Cramp::grow`).
    pub released: f64,

    /// The surfaces have moved at least once (their velocities are set).
    pub started: bool,
    pub warnings: Warnings,
    /// Per cell (by its lower-left node), the cracks it sees (bit c).
    cell_cracks: Vec<u64>,
    marked: Vec<u32>,
    /// The tiles that hold a cell that sees a crack.
    tiles: Vec<u32>,
    /// Particles in cells that see a crack, and each one's entry.
    near: Vec<u32>,
    entry: Vec<u32>,
    cross: Vec<PairCross>,
    /// Per entry: the support's first node, and each support node's field.
    node0: Vec<u32>,
    fields: Vec<[u8; MAX_LEN]>,
    /// The nodes with crack fields this step, and each node's record.
    pub recs: Vec<NodeCracks>,
    rec_of: Vec<u32>,
    /// The grid's node strides and the kernel's nodes per axis, from the
    /// last partition.
    stride: [usize; 2],
    support: usize,
}

impl Cramp {
    pub fn new(cracks: Vec<Crack>, update: SurfaceUpdate, j_contours: Vec<u32>) -> Cramp {
        Cramp {
            initial_points: cracks.iter().map(|c| c.plane.len()).sum(),
            cracks,
            update,
            j_contours,
            ..Cramp::default()
        }
    }

    /// Marks every cell within one cell of a crack segment (the appendix's
    /// crack hash: a particle's support reaches one cell beyond its own).
    fn hash(&mut self, geom: &GridGeom<2>) {
        let cells = geom.node_count();
        if self.cell_cracks.len() != cells {
            self.cell_cracks = vec![0; cells];
            self.marked.clear();
        }
        for &c in &self.marked {
            self.cell_cracks[c as usize] = 0;
        }
        self.marked.clear();
        let top = [geom.nodes[0] - 2, geom.nodes[1] - 2];
        for (c, crack) in self.cracks.iter().enumerate() {
            for w in crack.plane.windows(2) {
                let (a, b) = (geom.xi(w[0]), geom.xi(w[1]));
                let range = |d: usize| {
                    let lo = (a[d].min(b[d]).floor() - 1.0).max(0.0) as usize;
                    let hi = ((a[d].max(b[d]).floor() + 1.0).max(0.0) as usize).min(top[d]);
                    lo..=hi
                };
                for j in range(1) {
                    for i in range(0) {
                        let cell = geom.node([i, j]);
                        if self.cell_cracks[cell] == 0 {
                            self.marked.push(cell as u32);
                        }
                        self.cell_cracks[cell] |= 1 << c;
                    }
                }
            }
        }
    }

    /// The cracks the cell holding `x` sees.
    fn seen(&self, geom: &GridGeom<2>, x: [f64; 2]) -> u64 {
        let xi = geom.xi(x);
        if !(xi[0] >= 0.0 && xi[1] >= 0.0) {
            return 0;
        }
        let (i, j) = (xi[0] as usize, xi[1] as usize);
        if i + 1 >= geom.nodes[0] || j + 1 >= geom.nodes[1] {
            return 0;
        }
        self.cell_cracks[geom.node([i, j])]
    }

    /// The cracks (of `seen`, but `skip`) that the line from `p` to `q`
    /// crosses, two at most.
    fn trace(&self, seen: u64, skip: Option<usize>, p: [f64; 2], q: [f64; 2]) -> PairCross {
        let mut out = PairCross::default();
        let mut bits = seen;
        while bits != 0 && out.n < 2 {
            let c = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            if Some(c) == skip {
                continue;
            }
            if let Some(x) = crossing(&self.cracks[c].plane, p, q) {
                out.crack[out.n as usize] = c as u8;
                out.at[out.n as usize] = Some(x);
                out.n += 1;
            }
        }
        out
    }

    /// The `field_partition` stage: every particle–node pair's crack
    /// velocity field and the nodes' fields (`multi`'s masks, bit j for
    /// field j; field 0 at every node), laid out; returns the slot count.
    /// Only the particles of the tiles (`bins`) that hold a cell seeing a
    /// crack are looked at; the fields are allocated in their tile order.
    pub fn partition<K: Kernel, const V: usize>(
        &mut self,
        geom: &GridGeom<2>,
        parts: &Particles<2, V>,
        bins: &Bins,
        multi: &mut MultiField,
    ) -> usize {
        assert!(
            Support::<K, 2>::LEN <= MAX_LEN,
            "a 2D support has at most 16 nodes"
        );
        self.hash(geom);
        self.stride = geom.strides();
        self.support = K::N;
        let nodes = geom.node_count();
        // the last step's crack nodes back to field 0 alone
        if multi.mask.len() != nodes {
            multi.mask = vec![1; nodes];
        }
        if self.rec_of.len() != nodes {
            self.rec_of = vec![NONE; nodes];
        }
        for r in &self.recs {
            multi.mask[r.node as usize] = 1;
            self.rec_of[r.node as usize] = NONE;
        }
        self.recs.clear();
        // the particles whose cell sees a crack, from the tiles that hold
        // such cells (in tile order: the same for any thread count)
        self.tiles.clear();
        self.tiles.extend(self.marked.iter().map(|&c| {
            let at = geom.node_coords(c as usize);
            geom.tile_of([at[0] as f64, at[1] as f64])
        }));
        self.tiles.sort_unstable();
        self.tiles.dedup();
        if self.entry.len() != parts.len() {
            self.entry.clear();
            self.entry.resize(parts.len(), NONE);
        } else {
            for &p in &self.near {
                self.entry[p as usize] = NONE;
            }
        }
        self.near.clear();
        for &t in &self.tiles {
            for &p in bins.particles_of(t) {
                if self.seen(geom, parts.x[p as usize]) != 0 {
                    self.entry[p as usize] = self.near.len() as u32;
                    self.near.push(p);
                }
            }
        }
        // their lines to their support nodes, traced in parallel
        let len = Support::<K, 2>::LEN;
        // (and each support's first node)
        let mut cross = std::mem::take(&mut self.cross);
        cross.clear();
        cross.resize(self.near.len() * len, PairCross::default());
        let mut node0 = std::mem::take(&mut self.node0);
        node0.clear();
        node0.resize(self.near.len(), 0);
        let me = &*self;
        cross
            .par_chunks_mut(len)
            .zip(node0.par_iter_mut())
            .zip(me.near.par_iter())
            .for_each(|((out, first), &p)| {
                let p = p as usize;
                let x = parts.x[p];
                let seen = me.seen(geom, x);
                let sup = particle_support::<K, 2, V>(geom, parts, p);
                *first = sup.first_node() as u32;
                sup.for_each(|sn| {
                    out[sn.a] = me.trace(seen, None, x, geom.node_position(sn.node));
                });
            });
        self.node0 = node0;
        // the fields, first come first served in particle order (serial)
        self.fields.clear();
        let mut warn = self.warnings;
        for e in 0..self.near.len() {
            let first = self.node0[e] as usize;
            let mut f = [0u8; MAX_LEN];
            for a in 0..len {
                let pc = &cross[e * len + a];
                if pc.n == 0 {
                    continue;
                }
                let node = first + Support::<K, 2>::local_offset(geom, a);
                let r = match self.rec_of[node] {
                    NONE => {
                        self.rec_of[node] = self.recs.len() as u32;
                        self.recs.push(NodeCracks {
                            node: node as u32,
                            one: [None; 2],
                            both: None,
                        });
                        self.recs.len() - 1
                    }
                    r => r as usize,
                };
                let j = assign(&mut self.recs[r], pc, &mut warn);
                f[a] = j;
                multi.mask[node] |= 1 << j;
            }
            self.fields.push(f);
        }
        self.warnings = warn;
        self.cross = cross;
        multi.layout()
    }

    /// The step's slots ([`CrampFields`]).
    pub fn slots<'a>(&'a self, nodes: usize, multi: &'a MultiField) -> CrampFields<'a, 2> {
        CrampFields {
            nodes,
            multi,
            entry: &self.entry,
            node0: &self.node0,
            fields: &self.fields,
            stride: self.stride,
            n: self.support,
        }
    }

    /// Crack contact (Nairn & Aimene, section 2.1.3) after the grid update:
    /// at each node with crack fields, every pair of fields either side of
    /// one crack (0–1 and 2–3 across field 1's crack, 0–2 and 1–3 across
    /// field 2's, for two cracks as in their Fig. 1B) that both hold more
    /// than `floor` kg. The pair is in contact where the tracked faces are
    /// closed at the crack's first crossing there, (x_above − x_below)·n̂
    /// ≤ 0, and the fields approach along the crack normal (the average of
    /// the normals at the field's crossings); then both move toward their
    /// centre-of-mass velocity along the normal, and tangentially as far as
    /// Coulomb friction μ|Δv_n| allows (Bardenhagen et al. 2001). Momentum
    /// is conserved pair by pair. Returns the nodes where contact acted.
    ///
    /// With `momenta`, the paper's first pass (p + Δp right after the
    /// scatter): the test and the change act on the scattered velocities
    /// v⁰ = p/m, and the change is added to the updated ones v̄ too, so the
    /// particles' FLIP increment v̄ − v⁰ leaves it out while their
    /// positions and the second pass see it (eq. after 8: the
    /// acceleration holds Δp̃ but not Δp, so that a perfect interface
    /// reverts to no crack).
    pub fn contact(
        &self,
        grid: &mut GridFields<2>,
        multi: &MultiField,
        floor: f64,
        momenta: bool,
    ) -> usize {
        let nodes = grid.mass.len() - multi.extra_node.len();
        let mut touched = 0;
        for r in &self.recs {
            let node = r.node as usize;
            let mask = multi.mask[node];
            let mut hit = false;
            for (a, b) in [(0usize, 1usize), (0, 2), (1, 3), (2, 3)] {
                if mask >> a & 1 == 0 || mask >> b & 1 == 0 {
                    continue;
                }
                // the crack b has beyond a's cracks
                let (sa, na) = r.set(a);
                let (sb, nb) = r.set(b);
                if nb != na + 1 {
                    continue;
                }
                let extra = sb.iter().flatten().find(|x| {
                    !sa.iter()
                        .flatten()
                        .any(|y| y.crack == x.crack && y.side == x.side)
                });
                let shared = sa.iter().flatten().all(|y| {
                    sb.iter()
                        .flatten()
                        .any(|x| x.crack == y.crack && x.side == y.side)
                });
                let (Some(fc), true) = (extra, shared) else {
                    continue;
                };
                let (ia, ib) = (
                    multi.slot_of(nodes, node, a as u32),
                    multi.slot_of(nodes, node, b as u32),
                );
                let (ma, mb) = (grid.mass[ia], grid.mass[ib]);
                if ma <= floor || mb <= floor {
                    continue;
                }
                let crack = &self.cracks[fc.crack as usize];
                if crack.opening(fc.seg as usize, fc.t) > 0.0 {
                    continue;
                }
                let l = (fc.normal[0] * fc.normal[0] + fc.normal[1] * fc.normal[1]).sqrt();
                if !(l > 0.0) {
                    continue;
                }
                // from a's particles toward b's
                let s = if fc.side == ABOVE { 1.0 } else { -1.0 };
                let n = [s * fc.normal[0] / l, s * fc.normal[1] / l];
                let (va, vb) = if momenta {
                    (grid.vel_old[ia], grid.vel_old[ib])
                } else {
                    (grid.vel[ia], grid.vel[ib])
                };
                let rel = (vb[0] - va[0]) * n[0] + (vb[1] - va[1]) * n[1];
                if rel >= 0.0 {
                    continue; // separating
                }
                let m = ma + mb;
                let dva = [mb / m * (vb[0] - va[0]), mb / m * (vb[1] - va[1])];
                let dn = dva[0] * n[0] + dva[1] * n[1];
                let t = [dva[0] - dn * n[0], dva[1] - dn * n[1]];
                let tn = (t[0] * t[0] + t[1] * t[1]).sqrt();
                let mu = crack.friction;
                let dva = if tn <= mu * dn.abs() {
                    dva
                } else {
                    let f = mu * dn.abs() / tn;
                    [dn * n[0] + f * t[0], dn * n[1] + f * t[1]]
                };
                let k = ma / mb;
                for d in 0..2 {
                    grid.vel[ia][d] += dva[d];
                    grid.vel[ib][d] -= k * dva[d];
                }
                if momenta {
                    for d in 0..2 {
                        grid.vel_old[ia][d] += dva[d];
                        grid.vel_old[ib][d] -= k * dva[d];
                    }
                }
                hit = true;
            }
            touched += usize::from(hit);
        }
        touched
    }

    /// The velocity field of node `node` that crack `c`'s surface on side
    /// `side` at `x` (whose cell sees the cracks `seen`) takes its velocity
    /// from (the appendix's v(s, i)):
    /// across its own crack by the side of the node's field of that crack
    /// (by the node's side of the crack's nearest segment `k` where the
    /// node has none), across other cracks by tracing. None where the node
    /// has no such field.
    fn surface_field(
        &self,
        geom: &GridGeom<2>,
        (c, k, side): (usize, usize, u8),
        (x, seen): ([f64; 2], u64),
        node: usize,
    ) -> Option<u32> {
        let xn = geom.node_position(node);
        let rec = match self.rec_of.get(node) {
            Some(&r) if r != NONE => Some(&self.recs[r as usize]),
            _ => None,
        };
        let mut set: [(u8, u8); 2] = [(0, 0); 2];
        let mut n = 0;
        let own = match rec.and_then(|r| r.side_of(c as u8)) {
            Some(s) => s == side,
            None => {
                let crack = &self.cracks[c];
                let seg = k.min(crack.plane.len() - 2);
                let nrm = crack.normal(seg);
                let p = crack.plane[k];
                let up = (xn[0] - p[0]) * nrm[0] + (xn[1] - p[1]) * nrm[1] > 0.0;
                up != (side == ABOVE)
            }
        };
        if own {
            set[0] = (c as u8, side);
            n = 1;
        }
        let others = self.trace(seen, Some(c), x, xn);
        for q in 0..others.n as usize {
            if n < 2 {
                set[n] = (others.crack[q], others.at[q].map_or(0, |a| a.side));
                n += 1;
            }
        }
        match rec {
            Some(r) => r.field_of(&set[..n]),
            None => (n == 0).then_some(0),
        }
    }

    /// Visits the nodes of surface point `(c, k, side)` at `x` that its own
    /// side's velocity field reaches (the appendix's v(s, i), what a
    /// surface takes its velocity from and gives its forces to): for each
    /// node of positive weight whose field for that side exists, its
    /// field's slot and the weight N. Nodes in the support's order.
    pub(crate) fn own_side<K: Kernel>(
        &self,
        geom: &GridGeom<2>,
        multi: &MultiField,
        (c, k, side): (usize, usize, u8),
        x: [f64; 2],
        mut visit: impl FnMut(usize, f64),
    ) {
        let nodes = geom.node_count();
        let seen = self.seen(geom, x);
        Support::<K, 2>::new(geom, x, 0.0).for_each(|sn| {
            if sn.w <= 0.0 {
                return;
            }
            let Some(j) = self.surface_field(geom, (c, k, side), (x, seen), sn.node) else {
                return;
            };
            if multi.mask.get(sn.node).is_none_or(|m| m >> j & 1 == 0) {
                return;
            }
            visit(multi.slot_of(nodes, sn.node, j), sn.w);
        });
    }

    /// The `crack_surfaces` stage (Nairn & Aimene, eqs. 3–6): every
    /// surface point takes the velocities of its own side's fields,
    /// weighted by nodal mass (eq. 5: nodes without mass in that field
    /// drop out), ṽ from the step's final nodal velocities and v from its
    /// first ones, and moves by XPIC(1), x += (v + ½(ṽ − v_s)) Δt, v_s = ṽ
    /// (the first step takes v_s = v), or by FLIP, x += ½(ṽ + v) Δt (which
    /// is ṽΔt − ½aΔt² with a = (ṽ − v)/Δt). A crack plane point moves by
    /// the mean of its two surfaces' moves; a surface that no node of its
    /// side reaches moves with the other one.
    pub fn move_surfaces<K: Kernel>(
        &mut self,
        geom: &GridGeom<2>,
        grid: &GridFields<2>,
        multi: &MultiField,
        dt: f64,
    ) {
        let mut moves: Vec<Vec<[SurfaceMove; 2]>> = Vec::with_capacity(self.cracks.len());
        for (c, crack) in self.cracks.iter().enumerate() {
            let mut m = Vec::with_capacity(crack.plane.len());
            for k in 0..crack.plane.len() {
                let mut both = [None, None];
                for (s, side) in [ABOVE, BELOW].into_iter().enumerate() {
                    let (x, vs) = if side == ABOVE {
                        (crack.above[k], crack.v_above[k])
                    } else {
                        (crack.below[k], crack.v_below[k])
                    };
                    let (mut mw, mut pv, mut pv0) = (0.0, [0.0; 2], [0.0; 2]);
                    self.own_side::<K>(geom, multi, (c, k, side), x, |slot, n| {
                        let w = grid.mass[slot] * n;
                        if w > 0.0 {
                            mw += w;
                            for d in 0..2 {
                                pv[d] += w * grid.vel[slot][d];
                                pv0[d] += w * grid.vel_old[slot][d];
                            }
                        }
                    });
                    if mw > 0.0 {
                        let vt = [pv[0] / mw, pv[1] / mw];
                        let v0 = [pv0[0] / mw, pv0[1] / mw];
                        let prev = if self.started { vs } else { v0 };
                        let dx = match self.update {
                            SurfaceUpdate::Xpic1 => {
                                [0, 1].map(|d| (v0[d] + 0.5 * (vt[d] - prev[d])) * dt)
                            }
                            SurfaceUpdate::Flip => [0, 1].map(|d| 0.5 * (vt[d] + v0[d]) * dt),
                        };
                        both[s] = Some((dx, vt));
                    }
                }
                m.push(both);
            }
            moves.push(m);
        }
        for (crack, m) in self.cracks.iter_mut().zip(moves) {
            for (k, both) in m.into_iter().enumerate() {
                let (a, b) = match both {
                    [Some(a), Some(b)] => (a, b),
                    [Some(a), None] => (a, a),
                    [None, Some(b)] => (b, b),
                    [None, None] => continue,
                };
                for d in 0..2 {
                    crack.above[k][d] += a.0[d];
                    crack.below[k][d] += b.0[d];
                    crack.plane[k][d] += 0.5 * (a.0[d] + b.0[d]);
                }
                crack.v_above[k] = a.1;
                crack.v_below[k] = b.1;
            }
        }
        self.started = true;
    }
}

/// A surface point's move in a step and its new velocity, m and m/s (None
/// where no node of its side has mass).
type SurfaceMove = Option<([f64; 2], [f64; 2])>;

/// Slots of a step with explicit cracks: a particle–node pair's crack
/// velocity field, from the partition's table (field 0 for a particle
/// whose cell sees no crack, and at nodes with no crack field).
pub struct CrampFields<'a, const D: usize = 2> {
    pub nodes: usize,
    pub multi: &'a MultiField,
    entry: &'a [u32],
    node0: &'a [u32],
    fields: &'a [[u8; MAX_LEN]],
    stride: [usize; D],
    /// Support nodes per axis.
    n: usize,
}

impl<const D: usize> FieldSlots for CrampFields<'_, D> {
    #[inline(always)]
    fn slot(&self, node: usize, particle: usize) -> usize {
        // field 0 is bit 0 at every node, so it is the node's own slot
        if self.multi.mask[node] == 1 {
            return node;
        }
        let e = self.entry[particle];
        if e == NONE {
            return node;
        }
        let mut off = node - self.node0[e as usize] as usize;
        let mut local = 0;
        let mut scale = self.n.pow(D as u32 - 1);
        for d in (0..D).rev() {
            local += off / self.stride[d] * scale;
            off %= self.stride[d];
            scale /= self.n.max(1);
        }
        let field = self.fields[e as usize][local];
        self.multi.slot_of(self.nodes, node, field as u32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_crosses_a_crack_once_by_side() {
        let plane = [[0.0, 0.0], [1.0, 0.0]];
        let up = crossing(&plane, [0.5, 0.2], [0.5, -0.3]).expect("crosses");
        assert_eq!(up.side, ABOVE);
        assert_eq!(up.seg, 0);
        assert!((up.t - 0.5).abs() < 1e-15);
        assert_eq!(up.normal, [-0.0, 1.0]);
        let down = crossing(&plane, [0.25, -0.2], [0.25, 0.3]).expect("crosses");
        assert_eq!(down.side, BELOW);
        // beyond the tip, and on one side
        assert!(crossing(&plane, [1.5, 0.2], [1.5, -0.3]).is_none());
        assert!(crossing(&plane, [0.5, 0.2], [0.7, 0.1]).is_none());
    }

    #[test]
    fn a_line_through_a_vertex_crosses_once_and_a_turn_back_not_at_all() {
        // straight through the middle vertex
        let plane = [[0.0, 0.0], [0.5, 0.0], [1.0, 0.0]];
        assert!(crossing(&plane, [0.5, 0.3], [0.5, -0.3]).is_some());
        // a V whose bottom vertex touches the line: no crossing
        let v = [[0.0, 1.0], [0.5, 0.0], [1.0, 1.0]];
        assert!(crossing(&v, [0.0, 0.0], [1.0, 0.0]).is_none());
        // a U-shaped crack crossed twice: the line ends on its start's side
        let u = [[0.2, 1.0], [0.2, -1.0], [0.8, -1.0], [0.8, 1.0]];
        assert!(crossing(&u, [0.0, 0.0], [1.0, 0.0]).is_none());
        assert!(crossing(&u, [0.5, 0.0], [1.0, 0.0]).is_some());
    }

    fn pc(cracks: &[(u8, u8)]) -> PairCross {
        let mut p = PairCross::default();
        for (k, &(c, s)) in cracks.iter().enumerate() {
            p.crack[k] = c;
            p.at[k] = Some(Crossing {
                side: s,
                seg: 0,
                t: 0.5,
                normal: [0.0, 1.0],
            });
            p.n += 1;
        }
        p
    }

    /// The appendix's allocation: one crack per side fills fields 1 and 2,
    /// two cracks field 3, and the unexpected cases fall back with a
    /// warning.
    #[test]
    fn fields_are_allocated_as_the_appendix_says() {
        let mut rec = NodeCracks {
            node: 0,
            one: [None; 2],
            both: None,
        };
        let mut w = Warnings::default();
        assert_eq!(assign(&mut rec, &pc(&[(3, ABOVE)]), &mut w), 1);
        assert_eq!(assign(&mut rec, &pc(&[(3, ABOVE)]), &mut w), 1);
        assert_eq!(assign(&mut rec, &pc(&[(5, BELOW)]), &mut w), 2);
        assert_eq!(assign(&mut rec, &pc(&[(3, ABOVE), (5, BELOW)]), &mut w), 3);
        assert_eq!(assign(&mut rec, &pc(&[(5, BELOW), (3, ABOVE)]), &mut w), 3);
        assert_eq!(w, Warnings::default());
        // crack 3 from the other side: warning #1, field 0
        assert_eq!(assign(&mut rec, &pc(&[(3, BELOW)]), &mut w), 0);
        assert_eq!(w.wrong_side, 1);
        // a third crack: warning #2, field 0
        assert_eq!(assign(&mut rec, &pc(&[(7, ABOVE)]), &mut w), 0);
        assert_eq!(w.third_crack, 1);
        // two cracks, one of them a third: the known one alone
        assert_eq!(assign(&mut rec, &pc(&[(7, ABOVE), (5, BELOW)]), &mut w), 2);
        assert_eq!(w.third_crack, 2);
        // normals summed per field
        assert_eq!(rec.one[0].map(|r| r.normal), Some([0.0, 2.0]));
        assert_eq!(rec.field_of(&[(5, BELOW), (3, ABOVE)]), Some(3));
        assert_eq!(rec.field_of(&[(3, BELOW)]), None);
    }
}
