//! Explicit cracks' scene sections: the per-body `explicit_cracks` list
//! (each crack a polyline of crack points) and the optional `[cramp]`
//! table of the model's options, their serde types and their checks,
//! which [`crate::scene::Scene::validate`] calls.

use crate::geometry::{contains, ShapeSpec, Vector};
use crate::scene::schema::TimeFunction;
use crate::scene::Checker;
use serde::{Deserialize, Serialize};

/// Most explicit cracks in one scene (the element hash keeps one bit per
/// crack).
pub const MAX_CRACKS: usize = 64;

/// An explicit crack (Nairn & Aimene's CRAMP): a polyline of massless
/// crack points, m, each with its two surface positions (above and below
/// the crack plane; "above" is the left of the direction from the first
/// point to the last). Particles on either side interact only through
/// crack contact.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ExplicitCrackSpec {
    /// At least two points, m (2D). A crack from an edge must start
    /// outside its body by at least the kernel's reach (two cells): a
    /// node is cut off from the far side only by lines that cross the
    /// crack, and a line from a particle at the body's corner to a node
    /// beyond the edge passes round a crack end that stops short.
    pub points: Vec<Vector>,
    /// Coulomb friction μ between the crack's faces where they touch
    /// (0: frictionless contact; the faces never interpenetrate).
    #[serde(default)]
    pub friction: f64,
    /// A pressure on the crack's faces, Pa, a function of time (a number
    /// or `{ table = [[t, p], ...] }`): the faces are pushed apart by it
    /// where they lie inside the body (Nairn & Aimene, eqs. 7–8 with
    /// T_n = −P, T_t = 0). None: traction-free faces.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pressure: Option<TimeFunction>,
}

impl ExplicitCrackSpec {
    /// The points as 2D coordinates (validation has checked their length).
    pub fn xy(&self) -> Vec<[f64; 2]> {
        self.points.iter().map(|p| p.get::<2>()).collect()
    }
}

/// How crack surfaces follow the material (Nairn & Aimene, section
/// 2.1.2).
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum SurfaceUpdate {
    /// XPIC(1): x += (v_g→s + ½(ṽ_g→s − v_s)) Δt, v_s = ṽ_g→s (the
    /// paper's recommendation).
    #[default]
    Xpic1,
    /// Second-order FLIP: x += ṽ_g→s Δt − ½ a_g→s Δt².
    Flip,
}

/// Options of the explicit-crack model (the `[cramp]` table; all have
/// defaults, and the table may be left out).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CrampSpec {
    /// How the crack surfaces move.
    #[serde(default)]
    pub surface_update: SurfaceUpdate,
    /// The J contours about each crack tip, by their side in cells (even,
    /// 2 to 64: a square of ±N/2 cells about the node nearest the tip,
    /// Nairn & Aimene's "N-cell contours"). The first gives the series'
    /// `_J`, `_KI`, `_KII` columns; each further one a `_J{N}` column.
    #[serde(default = "default_j_contours")]
    pub j_contours: Vec<u32>,
    /// How J treats other cracks that meet its contour.
    #[serde(default)]
    pub j_method: JMethod,
    /// How J is split into K_I and K_II.
    #[serde(default)]
    pub k_split: KSplit,
    /// Crack contact passes per step: 1 (default) after the grid update;
    /// 2 also corrects the fields' momenta right after the scatter, as
    /// Nairn & Aimene (§2.1.3) prescribe. Not the default: on their C3
    /// with the cracks crossing (b/w = 0.3) two passes give J = 1.63 G0
    /// where one gives 0.88 and the paper has J below G0
    /// (docs/cracks-c3.md).
    #[serde(default = "default_contact_passes")]
    pub contact_passes: u32,
    /// Crack growth by the maximum hoop stress against a toughness; left
    /// out, the cracks keep their length (J is still reported).
    #[serde(default)]
    pub growth: Option<GrowthSpec>,
}

/// How J treats other cracks that meet its contour (Nairn & Aimene,
/// section 2.2). All three give the same J where no other crack comes
/// near the contour.
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum JMethod {
    /// The full-interaction contour, adaptive (steps 1–9 of §2.2.2):
    /// PIJC's path plus integrals along both faces of every other crack
    /// inside the contour, and the contour's edge moved to leave out
    /// another crack's tip that is inside it or in a cell next to it.
    #[default]
    Fijc,
    /// FIJC without moving the contour (step 6 skipped): the faces of a
    /// crack whose tip is inside are integrated up to that tip.
    FijcFixed,
    /// The partially integrated contour: virtual nodes where other cracks
    /// cross it and nothing more (invalid where they do; for comparison).
    Pijc,
}

/// How J is split into K_I and K_II (J = (K_I² + K_II²)/E* either way;
/// the split sets the ratio K_II/K_I, so the series' `_KI`, `_KII` and
/// the direction a crack grows in).
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum KSplit {
    /// The interaction integral with Williams' fields on J's own contour
    /// (Yau, Wang & Corten 1980): K_II/K_I = M_II/M_I.
    #[default]
    Interaction,
    /// The crack-opening displacement of the tracked surfaces one to three
    /// cells behind the tip (Guo & Nairn): K_II/K_I = δ_t/δ_n. The first
    /// split built; 8 % and 25 % off tan β at the two tips of the
    /// inclined crack (docs/cracks.md).
    Cod,
}

/// Crack growth (Nairn & Aimene, section 3.5): after every step each
/// crack tip's J on the first of `j_contours` is split into K_I, K_II; a
/// tip grows by one segment in the maximum-hoop-stress direction when
/// K_I^max there reaches K_Ic. Give the toughness as `j_ic` (then
/// K_Ic = √(J_Ic E*) with the tip's material) or as `k_ic`, not both.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct GrowthSpec {
    /// Mode I toughness as a critical energy release rate, J/m².
    #[serde(default)]
    pub j_ic: Option<f64>,
    /// Mode I toughness as a critical stress intensity factor, Pa·√m.
    #[serde(default)]
    pub k_ic: Option<f64>,
    /// The length of a segment added by one growth event, cells (the
    /// paper: about a material point's diameter, half a cell with 2 × 2
    /// particles a cell).
    #[serde(default = "default_segment")]
    pub segment: f64,
}

fn default_contact_passes() -> u32 {
    1
}

fn default_segment() -> f64 {
    0.5
}

fn default_j_contours() -> Vec<u32> {
    vec![DEFAULT_J_CONTOUR]
}

/// The J contour when the scene names none: 4 cells, the smallest of the
/// paper's Table 1 (a contour 2 cells from the tip each way).
pub const DEFAULT_J_CONTOUR: u32 = 4;

impl Default for CrampSpec {
    fn default() -> CrampSpec {
        CrampSpec {
            surface_update: SurfaceUpdate::default(),
            j_contours: default_j_contours(),
            j_method: JMethod::default(),
            k_split: KSplit::default(),
            contact_passes: default_contact_passes(),
            growth: None,
        }
    }
}

/// Checks every body's `explicit_cracks` and the `[cramp]` table: 2D
/// only, one contact group, each crack a polyline of at least two
/// distinct points inside the grid that touches its body, at most
/// [`MAX_CRACKS`] cracks, and no node that sees three cracks at the start
/// (the velocity fields hold two cracks per node).
pub(crate) fn check(
    c: &mut Checker,
    bodies: &[(&ShapeSpec, &[ExplicitCrackSpec])],
    dim: usize,
    groups: usize,
    grid: ([f64; 2], [f64; 2], f64),
    cramp: Option<&CrampSpec>,
    dfg: bool,
) {
    let total: usize = bodies.iter().map(|(_, c)| c.len()).sum();
    if total == 0 {
        if cramp.is_some() {
            c.err(
                "cramp",
                "options for explicit cracks, but no body has explicit_cracks",
            );
        }
        return;
    }
    if let Some(spec) = cramp {
        check_contours(c, &spec.j_contours);
        if !matches!(spec.contact_passes, 1 | 2) {
            c.err(
                "cramp.contact_passes",
                format!(
                    "{} contact passes: 1 (after the grid update, the default) or 2 (after \
                     the scatter too, the paper's)",
                    spec.contact_passes
                ),
            );
        }
        if let Some(g) = &spec.growth {
            check_growth(c, g);
        }
    }
    if dim == 3 {
        let at = bodies.iter().position(|(_, c)| !c.is_empty()).unwrap_or(0);
        c.err(
            &format!("bodies[{at}].explicit_cracks"),
            "explicit cracks (CRAMP) are 2D, as in Nairn & Aimene; this grid is 3D \
             (grid.max has 3 components): use a 2D grid, or a phase field or DFG for 3D cracks",
        );
        return;
    }
    if dfg {
        c.err(
            "dfg",
            "DFG partitioning and explicit cracks both split the velocity fields; a scene \
             has one of them: remove [dfg] or the bodies' explicit_cracks",
        );
    }
    if groups > 1 {
        c.err(
            "bodies",
            format!(
                "explicit cracks need all bodies in one contact group (the crack velocity \
                 fields take the fields' place), but the scene has {groups}"
            ),
        );
    }
    if total > MAX_CRACKS {
        c.err(
            "bodies",
            format!("{total} explicit cracks; at most {MAX_CRACKS} are supported"),
        );
    }
    let (lo, hi, h) = grid;
    let mut all: Vec<(String, Vec<[f64; 2]>)> = Vec::new();
    for (b, (shape, cracks)) in bodies.iter().enumerate() {
        for (k, crack) in cracks.iter().enumerate() {
            let path = format!("bodies[{b}].explicit_cracks[{k}]");
            c.in_range(&format!("{path}.friction"), crack.friction, 0.0, 1e3);
            if let Some(p) = &crack.pressure {
                c.time_function(&format!("{path}.pressure"), p);
            }
            if crack.points.len() < 2 {
                c.err(
                    &format!("{path}.points"),
                    format!(
                        "a crack is a polyline of at least 2 points, got {}",
                        crack.points.len()
                    ),
                );
                continue;
            }
            let mut ok = true;
            for (q, pt) in crack.points.iter().enumerate() {
                let p = format!("{path}.points[{q}]");
                if pt.len() != 2 {
                    c.err(&p, format!("needs 2 components, got {}", pt.len()));
                    ok = false;
                    continue;
                }
                let xy = pt.get::<2>();
                if !xy.iter().all(|v| v.is_finite()) {
                    c.err(&p, "must be finite");
                    ok = false;
                } else if (0..2).any(|a| xy[a] < lo[a] || xy[a] > hi[a]) {
                    c.err(
                        &p,
                        format!(
                            "({}, {}) lies outside the grid [{}, {}] × [{}, {}]",
                            xy[0], xy[1], lo[0], hi[0], lo[1], hi[1]
                        ),
                    );
                    ok = false;
                }
            }
            if !ok {
                continue;
            }
            let pts = crack.xy();
            if let Some(q) = pts.windows(2).position(|w| w[0] == w[1]) {
                c.err(
                    &format!("{path}.points[{}]", q + 1),
                    "repeats the point before it: a crack segment needs length",
                );
                continue;
            }
            // touches its body: a point inside the shape, or a segment's
            // midpoint (an edge crack may start just outside)
            let inside = pts.iter().any(|&p| contains(shape, p))
                || pts.windows(2).any(|w| {
                    contains(
                        shape,
                        [(w[0][0] + w[1][0]) / 2.0, (w[0][1] + w[1][1]) / 2.0],
                    )
                });
            if !inside {
                c.err(
                    &path,
                    format!("lies outside its body (bodies[{b}].shape): no point of it is inside"),
                );
                continue;
            }
            all.push((path, pts));
        }
    }
    check_crowding(c, &all, lo, h);
}

/// `[cramp] j_contours`: one or more distinct even sides, 2 to 64 cells.
fn check_contours(c: &mut Checker, sides: &[u32]) {
    if sides.is_empty() {
        c.err(
            "cramp.j_contours",
            "needs at least one contour size (cells, even), e.g. [4, 8]",
        );
    }
    for (k, &n) in sides.iter().enumerate() {
        let at = format!("cramp.j_contours[{k}]");
        if !(2..=64).contains(&n) || n % 2 != 0 {
            c.err(
                &at,
                format!(
                    "a J contour's side is an even number of cells from 2 to 64 (a square \
                     centred on the node nearest the tip), got {n}"
                ),
            );
        } else if sides[..k].contains(&n) {
            c.err(&at, format!("the contour of {n} cells is listed twice"));
        }
    }
}

/// `[cramp] growth`: exactly one positive toughness, a segment of a
/// tenth of a cell to one cell (a longer one would step past the J
/// contour's tip cell; a shorter one is lost in the surfaces' noise).
fn check_growth(c: &mut Checker, g: &GrowthSpec) {
    match (g.j_ic, g.k_ic) {
        (Some(_), Some(_)) => c.err(
            "cramp.growth",
            "gives both j_ic and k_ic: the toughness is one of them (K_Ic = √(J_Ic E*))",
        ),
        (None, None) => c.err(
            "cramp.growth",
            "needs the toughness: j_ic (J/m²) or k_ic (Pa·√m)",
        ),
        (Some(j), None) => {
            c.positive("cramp.growth.j_ic", j);
        }
        (None, Some(k)) => {
            c.positive("cramp.growth.k_ic", k);
        }
    }
    c.in_range("cramp.growth.segment", g.segment, 0.1, 1.0);
}

/// No node may see more than two cracks at the start: a node sees a crack
/// passing within 1.5 cells of it (the reach of a quadratic B-spline or
/// uGIMP support), and the crack velocity fields of Nairn & Aimene hold
/// two cracks per node (their appendix; a third would be ignored).
fn check_crowding(c: &mut Checker, cracks: &[(String, Vec<[f64; 2]>)], lo: [f64; 2], h: f64) {
    if cracks.len() < 3 || !(h > 0.0) {
        return;
    }
    let mut seen: std::collections::BTreeMap<(i64, i64), u64> = Default::default();
    let reach = 1.5 * h;
    for (k, (_, pts)) in cracks.iter().enumerate().take(MAX_CRACKS) {
        for w in pts.windows(2) {
            let (a, b) = (w[0], w[1]);
            let cell = |v: f64, o: f64| ((v - o) / h).floor() as i64;
            let (i0, i1) = (
                cell(a[0].min(b[0]) - reach, lo[0]),
                cell(a[0].max(b[0]) + reach, lo[0]) + 1,
            );
            let (j0, j1) = (
                cell(a[1].min(b[1]) - reach, lo[1]),
                cell(a[1].max(b[1]) + reach, lo[1]) + 1,
            );
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let node = [lo[0] + i as f64 * h, lo[1] + j as f64 * h];
                    if crate::geometry::distance_to_polyline(node, &[a, b]) < reach {
                        *seen.entry((i, j)).or_default() |= 1 << k;
                    }
                }
            }
        }
    }
    if let Some((&(i, j), bits)) = seen.iter().find(|(_, b)| b.count_ones() > 2) {
        let names: Vec<&str> = (0..cracks.len())
            .filter(|k| bits >> k & 1 == 1)
            .map(|k| cracks[k].0.as_str())
            .collect();
        c.err(
            &names[2..].join(", "),
            format!(
                "the node at ({}, {}) sees {} cracks ({}): a node holds the velocity fields \
                 of two cracks at most (Nairn & Aimene's appendix); move the cracks apart or \
                 refine the grid",
                lo[0] + i as f64 * h,
                lo[1] + j as f64 * h,
                bits.count_ones(),
                names.join(", ")
            ),
        );
    }
}
