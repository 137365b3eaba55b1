//! Plots of a run: energies against time, the crack tip against time, and
//! a particle field as an image.
//!
//! Text is set in a subset of DejaVu Sans that the binary carries
//! (`assets/fonts/`, drawn by plotters' pure-Rust `ab_glyph` renderer), so
//! that a plot needs no font installed on the machine and the build no
//! fontconfig or freetype: a container or a headless node draws the same
//! pictures as a desktop.

use super::OutputError;
use crate::diagnostics::{FieldData, SeriesRow, Snapshot};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

/// The family name every plot asks for; [`embedded_font`] registers the
/// carried font under it.
const FONT: &str = "sans-serif";

/// DejaVu Sans 2.37 cut down to Latin-1, Greek, punctuation, super- and
/// subscripts, arrows and mathematical operators (µ, ², θ, −, ≈ …):
/// 60 kB instead of 740 kB. Licence and how it was cut:
/// `assets/fonts/README.md`.
static FONT_BYTES: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans-subset.ttf");

/// Registers the carried font with plotters (once per process); an Err
/// says the font could not be parsed, and no text can be drawn then.
fn embedded_font() -> Result<(), String> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err("the embedded font could not be loaded".to_string())
    }
}

/// The root of a bitmap being drawn.
type Root<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// Draws a `size` PNG at `path` through `paint`, atomically: into a
/// `.tmp.png` beside it, renamed over `path` once whole, and removed when
/// anything fails, so that a failed plot leaves no file behind.
fn render(
    path: &Path,
    size: (u32, u32),
    paint: impl FnOnce(&Root<'_>) -> Result<(), String>,
) -> Result<(), OutputError> {
    let err = |e: String| OutputError::new(path, std::io::Error::other(e));
    embedded_font().map_err(err)?;
    let tmp = path.with_extension("png.tmp.png");
    let drawn = (|| {
        let root = BitMapBackend::new(&tmp, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        paint(&root)?;
        root.present().map_err(|e| e.to_string())
    })();
    let result = drawn
        .map_err(err)
        .and_then(|()| std::fs::rename(&tmp, path).map_err(|e| OutputError::new(path, e)));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// One line of a chart: name, colour, points (non-finite ones are skipped).
type Line = (String, RGBColor, Vec<(f64, f64)>);

/// One panel of [`plot_log_x`]: its title and its named lines of points.
pub type Panel = (String, Vec<(String, Vec<(f64, f64)>)>);

const BLUE_: RGBColor = RGBColor(31, 119, 180);
const ORANGE: RGBColor = RGBColor(255, 127, 14);
const GREEN_: RGBColor = RGBColor(44, 160, 44);
const GREY: RGBColor = RGBColor(120, 120, 120);
const PURPLE: RGBColor = RGBColor(148, 103, 189);

/// Draws `points` as a line of width 2 in `colour` with a legend entry
/// `name`, on any chart with f64 axes (linear or logarithmic).
fn draw_line<DB: DrawingBackend, X: Ranged<ValueType = f64>, Y: Ranged<ValueType = f64>>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<X, Y>>,
    name: &str,
    colour: RGBColor,
    points: Vec<(f64, f64)>,
) -> Result<(), String> {
    chart
        .draw_series(LineSeries::new(points, colour.stroke_width(2)))
        .map_err(|e| e.to_string())?
        .label(name)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], colour.stroke_width(2)));
    Ok(())
}

/// A tick label: up to four significant digits in plain notation between
/// 1e-3 and 1e5 (`0.1255`, `7`, `100`), scientific outside.
fn tick(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        return "0".to_string(); // also for −0
    }
    if !v.is_finite() {
        return format!("{v}");
    }
    if !(1e-3..1e5).contains(&a) {
        // 2.50e-5 → 2.5e-5, 1.00e-4 → 1e-4
        let s = format!("{v:.2e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        return format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.'));
    }
    // digits after the point for four significant digits
    let d = 3 - a.log10().floor() as i32;
    let r = if d >= 0 {
        let s = 10f64.powi(d);
        (v * s).round() / s
    } else {
        let s = 10f64.powi(-d);
        (v / s).round() * s
    };
    format!("{r}")
}

/// The unit in which to show times up to `t_max` seconds: (factor from
/// seconds, name), so that the axis reads in µs for a fracture run.
fn time_unit(t_max: f64) -> (f64, &'static str) {
    if t_max < 1e-3 {
        (1e6, "µs")
    } else if t_max < 1.0 {
        (1e3, "ms")
    } else {
        (1.0, "s")
    }
}

/// Draws one chart of `lines` against time (seconds) into `area`, with the
/// time axis in µs, ms or s as fits the range.
fn chart<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    y_desc: &str,
    lines: &[Line],
) -> Result<(), String> {
    let pts = || {
        lines
            .iter()
            .flat_map(|l| l.2.iter())
            .filter(|p| p.0.is_finite() && p.1.is_finite())
    };
    let t_end = pts().map(|p| p.0).fold(0.0f64, f64::max);
    let (scale, unit) = time_unit(t_end);
    let t_max = (scale * t_end).max(f64::MIN_POSITIVE);
    let (lo, mut hi) = pts().fold((0.0f64, 0.0f64), |(lo, hi), p| (lo.min(p.1), hi.max(p.1)));
    if hi - lo <= 0.0 {
        hi = lo + 1.0;
    }
    let pad = 0.05 * (hi - lo);
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FONT, 22))
        .margin(12)
        .margin_right(30)
        .x_label_area_size(45)
        .y_label_area_size(80)
        .build_cartesian_2d(0.0..t_max, (lo - pad)..(hi + pad))
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc(format!("time in {unit}"))
        .y_desc(y_desc)
        .axis_desc_style((FONT, 17))
        .label_style((FONT, 14))
        .x_label_formatter(&|x| tick(*x))
        .y_label_formatter(&|y| tick(*y))
        .draw()
        .map_err(|e| e.to_string())?;
    for (name, colour, points) in lines {
        let p: Vec<(f64, f64)> = points
            .iter()
            .map(|p| (scale * p.0, p.1))
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .collect();
        draw_line(&mut chart, name, *colour, p)?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperLeft)
        .draw()
        .map_err(|e| e.to_string())
}

/// Draws `charts` stacked vertically into a PNG at `path` (atomically).
fn draw(path: &Path, charts: &[(&str, &str, Vec<Line>)]) -> Result<(), OutputError> {
    render(path, (900, 520 * charts.len() as u32), |root| {
        for (area, (title, y_desc, lines)) in
            root.split_evenly((charts.len(), 1)).iter().zip(charts)
        {
            chart(area, title, y_desc, lines)?;
        }
        Ok(())
    })
}

/// Side-by-side panels of lines against a logarithmic x axis with a
/// shared y range (e.g. cumulative fragment-size distributions): each
/// panel is (title, lines as (name, points)); `x_desc`, `y_desc` label the
/// axes. Points with x <= 0 or non-finite values are skipped.
pub fn plot_log_x(
    path: &Path,
    x_desc: &str,
    y_desc: &str,
    panels: &[Panel],
) -> Result<(), OutputError> {
    let ok = |p: &&(f64, f64)| p.0 > 0.0 && p.0.is_finite() && p.1.is_finite();
    let all = || {
        panels
            .iter()
            .flat_map(|p| p.1.iter())
            .flat_map(|l| l.1.iter())
            .filter(ok)
    };
    let (mut x0, mut x1) = all().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    if !(x0 < x1) {
        (x0, x1) = (1.0, 10.0);
    }
    let (y0, mut y1) = all().fold((0.0f64, 0.0f64), |(a, b), p| (a.min(p.1), b.max(p.1)));
    if y1 <= y0 {
        y1 = y0 + 1.0;
    }
    let colours = [BLUE_, ORANGE, GREEN_, PURPLE, GREY];
    let size = (620 * panels.len().max(1) as u32, 520);
    render(path, size, |root| {
        for (area, (title, lines)) in root
            .split_evenly((1, panels.len().max(1)))
            .iter()
            .zip(panels)
        {
            let mut chart = ChartBuilder::on(area)
                .caption(title, (FONT, 22))
                .margin(12)
                .x_label_area_size(45)
                .y_label_area_size(70)
                .build_cartesian_2d((0.8 * x0..1.25 * x1).log_scale(), y0..1.05 * y1)
                .map_err(|e| e.to_string())?;
            chart
                .configure_mesh()
                .x_desc(x_desc)
                .y_desc(y_desc)
                .x_label_formatter(&|x| format!("{x:.2}"))
                .draw()
                .map_err(|e| e.to_string())?;
            for (k, (name, points)) in lines.iter().enumerate() {
                let colour = colours[k % colours.len()];
                let p: Vec<(f64, f64)> = points.iter().filter(ok).copied().collect();
                draw_line(&mut chart, name, colour, p)?;
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .position(SeriesLabelPosition::UpperLeft)
                .draw()
                .map_err(|e| e.to_string())?;
        }
        Ok(())
    })
}

/// Error against cost on log–log axes (a study's accuracy against wall
/// time): every point as a circle with its label, the points of the
/// Pareto front filled and joined. Points that are not positive and
/// finite on both axes are left out; Ok(false) when none is left.
pub fn plot_pareto(
    path: &Path,
    title: &str,
    x_desc: &str,
    y_desc: &str,
    points: &[(f64, f64, String)],
    front: &[bool],
) -> Result<bool, OutputError> {
    let ok = |p: &(f64, f64)| p.0 > 0.0 && p.1 > 0.0 && p.0.is_finite() && p.1.is_finite();
    let shown: Vec<(f64, f64, &str, bool)> = points
        .iter()
        .zip(front.iter().chain(std::iter::repeat(&false)))
        .filter(|(p, _)| ok(&(p.0, p.1)))
        .map(|(p, f)| (p.0, p.1, p.2.as_str(), *f))
        .collect();
    if shown.is_empty() {
        return Ok(false);
    }
    let range = |v: &mut dyn Iterator<Item = f64>, right: f64| {
        let (lo, hi) = v.fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(x), b.max(x)));
        // whole decades, so that the log axes have labelled ticks
        (
            0.99 * 10f64.powf((lo / 1.2).log10().floor()),
            1.01 * 10f64.powf((hi * right).log10().ceil()),
        )
    };
    // room on the right for the labels
    let (x0, x1) = range(&mut shown.iter().map(|p| p.0), 5.0);
    let (y0, y1) = range(&mut shown.iter().map(|p| p.1), 1.2);
    render(path, (900, 640), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, (FONT, 22))
            .margin(16)
            .x_label_area_size(45)
            .y_label_area_size(80)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .x_labels(6)
            .y_labels(6)
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .draw()
            .map_err(|e| e.to_string())?;
        let mut line: Vec<(f64, f64)> = shown.iter().filter(|p| p.3).map(|p| (p.0, p.1)).collect();
        line.sort_by(|a, b| a.0.total_cmp(&b.0));
        draw_line(&mut chart, "Pareto front", ORANGE, line)?;
        chart
            .draw_series(shown.iter().map(|p| {
                let style = if p.3 {
                    ORANGE.filled()
                } else {
                    BLUE_.stroke_width(2)
                };
                EmptyElement::at((p.0, p.1))
                    + Circle::new((0, 0), 5, style)
                    + Text::new(p.2.to_string(), (8, -6), (FONT, 13).into_font())
            }))
            .map_err(|e| e.to_string())?;
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| e.to_string())
    })?;
    Ok(true)
}

/// Draws `energies.png`: kinetic, strain, their sum, the external work and
/// (when there is one) the fracture energy. Returns Ok(false) and writes
/// nothing when there is nothing to plot (fewer than two rows).
pub fn plot_energies(path: &Path, rows: &[SeriesRow]) -> Result<bool, OutputError> {
    let rows: Vec<&SeriesRow> = rows.iter().filter(|r| r.time.is_finite()).collect();
    if rows.len() < 2 {
        return Ok(false);
    }
    let line = |name: &str, colour, f: fn(&SeriesRow) -> f64| -> Line {
        (
            name.to_string(),
            colour,
            rows.iter().map(|r| (r.time, f(r))).collect(),
        )
    };
    let mut lines = vec![
        line("kinetic", BLUE_, |r| r.kinetic_energy),
        line("strain", ORANGE, |r| r.strain_energy),
        line("kinetic + strain", GREEN_, |r| {
            r.kinetic_energy + r.strain_energy
        }),
        line("external work", GREY, |r| r.external_work),
    ];
    if rows.iter().any(|r| r.fracture_energy != 0.0) {
        lines.push(line("fracture", PURPLE, |r| r.fracture_energy));
    }
    // In plane strain the thickness is 1 m unless the scene says
    // otherwise, so the values are then J per metre of thickness.
    draw(path, &[("Energies", "energy in J", lines)])?;
    Ok(true)
}

/// Draws `crack.png` from a series with the crack-tip columns: crack
/// length (mm) and tip speed (m/s) against time, one line per tracked body.
/// Returns Ok(false) and writes nothing without such columns.
pub fn plot_crack(
    path: &Path,
    columns: &[String],
    rows: &[SeriesRow],
) -> Result<bool, OutputError> {
    if rows.len() < 2 {
        return Ok(false);
    }
    let colours = [BLUE_, ORANGE, GREEN_, PURPLE, GREY];
    let (mut length, mut speed) = (Vec::new(), Vec::new());
    for (k, name) in columns
        .iter()
        .filter(|c| c.starts_with("crack_length"))
        .enumerate()
    {
        let suffix = &name["crack_length".len()..];
        let label = if suffix.is_empty() {
            "tip".to_string()
        } else {
            format!("tip{suffix}")
        };
        let colour = colours[k % colours.len()];
        let at = |col: &str, scale: f64| -> Vec<(f64, f64)> {
            rows.iter()
                .filter_map(|r| Some((r.time, scale * r.get(columns, col)?)))
                .collect()
        };
        length.push((label.clone(), colour, at(name, 1e3)));
        speed.push((label, colour, at(&format!("crack_speed{suffix}"), 1.0)));
    }
    if length.is_empty() {
        return Ok(false);
    }
    draw(
        path,
        &[
            (
                "Crack length (tip distance from the crack origin)",
                "length in mm",
                length,
            ),
            ("Crack-tip speed", "speed in m/s", speed),
        ],
    )?;
    Ok(true)
}

/// The crack tips whose J the series gives on the first contour: each
/// `crack{c}_{start|end}_J` column with its legend, `crack{c} {end}`
/// (the further contours' `…_J{N}` columns are left to the series).
fn j_columns(columns: &[String]) -> Vec<(&str, String)> {
    columns
        .iter()
        .filter_map(|name| {
            let rest = name.strip_prefix("crack")?.strip_suffix("_J")?;
            let (c, end) = rest.split_once('_')?;
            let numbered = !c.is_empty() && c.bytes().all(|b| b.is_ascii_digit());
            (numbered && (end == "start" || end == "end"))
                .then(|| (name.as_str(), format!("crack{c} {end}")))
        })
        .collect()
}

/// Draws `j_integral.png` from the series of a scene with explicit
/// cracks: J (J/m², on each tip's first contour) against time, one line
/// per tip that has a finite J in some row; the rows where a tip's J is
/// NaN (an end that is not a tip, a contour off the grid) are left out
/// of its line rather than breaking the plot. Returns Ok(false) and
/// writes nothing without such a tip or with fewer than two rows, so a
/// scene without cracks gets no file.
pub fn plot_j_integral(
    path: &Path,
    columns: &[String],
    rows: &[SeriesRow],
) -> Result<bool, OutputError> {
    let lines = j_lines(columns, rows);
    if rows.len() < 2 || lines.is_empty() {
        return Ok(false);
    }
    draw(
        path,
        &[("J integral at the crack tips", "J in J/m²", lines)],
    )?;
    Ok(true)
}

/// The lines of [`plot_j_integral`]: per tip of [`j_columns`] with a
/// finite J somewhere, its finite (time, J) points.
fn j_lines(columns: &[String], rows: &[SeriesRow]) -> Vec<Line> {
    let colours = [BLUE_, ORANGE, GREEN_, PURPLE, GREY];
    j_columns(columns)
        .into_iter()
        .map(|(col, label)| {
            let points: Vec<(f64, f64)> = rows
                .iter()
                .filter_map(|r| Some((r.time, r.get(columns, col)?)))
                .filter(|p| p.0.is_finite() && p.1.is_finite())
                .collect();
            (label, points)
        })
        .filter(|(_, points)| !points.is_empty())
        .enumerate()
        .map(|(k, (label, points))| (label, colours[k % colours.len()], points))
        .collect()
}

/// A polar plot of r(θ) (degrees) as a closed curve, one panel per series,
/// side by side, equal axes.
pub fn plot_polar(path: &Path, panels: &[(&str, Vec<(f64, f64)>)]) -> Result<(), OutputError> {
    let width = 480 * panels.len().max(1) as u32;
    render(path, (width, 500), |root| {
        let areas = root.split_evenly((1, panels.len().max(1)));
        for (area, (title, pts)) in areas.iter().zip(panels) {
            let rmax = pts
                .iter()
                .map(|p| p.1)
                .filter(|r| r.is_finite())
                .fold(0.0f64, f64::max)
                .max(f64::MIN_POSITIVE)
                * 1.1;
            let mut chart = ChartBuilder::on(area)
                .caption(*title, (FONT, 20))
                .margin(10)
                .x_label_area_size(35)
                .y_label_area_size(60)
                .build_cartesian_2d(-rmax..rmax, -rmax..rmax)
                .map_err(|e| e.to_string())?;
            chart
                .configure_mesh()
                .x_labels(5)
                .y_labels(5)
                .x_label_formatter(&|x| format!("{x:.2e}"))
                .y_label_formatter(&|y| format!("{y:.2e}"))
                .draw()
                .map_err(|e| e.to_string())?;
            let mut curve: Vec<(f64, f64)> = pts
                .iter()
                .filter(|p| p.1.is_finite())
                .map(|&(deg, r)| (r * deg.to_radians().cos(), r * deg.to_radians().sin()))
                .collect();
            if let Some(&first) = curve.first() {
                curve.push(first);
            }
            chart
                .draw_series(LineSeries::new(curve, BLUE_.stroke_width(2)))
                .map_err(|e| e.to_string())?;
        }
        Ok(())
    })
}

/// What an image of the particle field `name` calls it on its colour bar
/// (with the unit: both fields are fractions without one), and whether
/// its high values are the broken material: the phase field c is 1 where
/// the material is intact and 0 in a crack (Borden et al. 2012),
/// damage the other way round.
fn field_label(name: &str) -> (String, bool) {
    match name {
        "phase_field" => ("phase field (dimensionless, 0 = broken)".to_string(), false),
        "damage" => ("damage (dimensionless, 1 = broken)".to_string(), true),
        "chi" => ("χ (dimensionless, 1 = eroded)".to_string(), true),
        other => (format!("{} (dimensionless)", other.replace('_', " ")), true),
    }
}

/// The viridis colour map (van der Walt & Smith, matplotlib) at `t` in
/// [0, 1], interpolated between nine of its colours: it reads from dark to
/// light without passing through the white of the background, and stays
/// ordered in grey scale and for colour-blind readers.
fn viridis(t: f64) -> RGBColor {
    const STOPS: [(u8, u8, u8); 9] = [
        (68, 1, 84),
        (71, 44, 122),
        (59, 81, 139),
        (44, 113, 142),
        (33, 144, 141),
        (39, 173, 129),
        (92, 200, 99),
        (170, 220, 50),
        (253, 231, 37),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * (STOPS.len() - 1) as f64;
    let k = (x.floor() as usize).min(STOPS.len() - 2);
    let u = x - k as f64;
    let (a, b) = (STOPS[k], STOPS[k + 1]);
    let mix = |p: u8, q: u8| (p as f64 + u * (q as f64 - p as f64)).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// The spacing of particles spread over a region of the plane, in the
/// units of `positions`: the square root of the area they cover per
/// particle, the area counted in cells of the bounding box's spacing that
/// hold a particle (so that the holes between two bodies do not count).
fn particle_spacing(positions: &[[f64; 2]], x0: f64, y0: f64, w: f64, h: f64) -> f64 {
    let n = positions.len().max(1) as f64;
    let cell = (w * h / n).sqrt().max(f64::MIN_POSITIVE);
    let (nx, ny) = ((w / cell) as usize + 1, (h / cell) as usize + 1);
    if nx.saturating_mul(ny) > 16 * positions.len().max(1) {
        return cell; // a degenerate box (a line of particles)
    }
    let mut occupied = vec![false; nx * ny];
    for p in positions {
        let i = (((p[0] - x0) / cell) as usize).min(nx - 1);
        let j = (((p[1] - y0) / cell) as usize).min(ny - 1);
        occupied[i + nx * j] = true;
    }
    let cells = occupied.iter().filter(|&&o| o).count() as f64;
    (cells * cell * cell / n).sqrt()
}

/// The side of a particle's square in a picture of `snap` (mm, as
/// `positions`): in 2D [`particle_spacing`]; a 3D snapshot is seen along z,
/// where its particles' columns overlap, so there it is the mean cube root
/// of their volume.
fn view_spacing(snap: &Snapshot, positions: &[[f64; 2]], x0: f64, y0: f64, w: f64, h: f64) -> f64 {
    match (snap.dimension, snap.field("volume")) {
        (3, Some(FieldData::F64(vol))) if !vol.is_empty() => {
            1e3 * vol.iter().map(|v| v.abs().cbrt()).sum::<f64>() / vol.len() as f64
        }
        _ => particle_spacing(positions, x0, y0, w, h),
    }
}

/// An image of one scalar particle field (the phase field, the damage) on
/// the deformed particles: each particle a square of its spacing coloured
/// from `lo` to `hi` ([`viridis`]), the most broken drawn last so that a
/// thin crack is not hidden under intact neighbours, on axes in mm, with
/// a colour bar naming the field and the range of its values. A 3D
/// snapshot is drawn seen along z (x across, y up): each column of
/// particles shows its most broken one. Ok(false) and nothing written when
/// the snapshot has no such field or no particle.
pub fn plot_particle_field(
    path: &Path,
    snap: &Snapshot,
    field: &str,
    lo: f64,
    hi: f64,
) -> Result<bool, OutputError> {
    let Some(values) = snap
        .fields
        .iter()
        .find(|f| f.name == field && f.components == 1)
        .and_then(|f| match &f.data {
            FieldData::F64(v) => Some(v),
            _ => None,
        })
    else {
        return Ok(false);
    };
    // positions in mm; particles with a non-finite position are left out
    let pts: Vec<([f64; 2], f64)> = snap
        .positions
        .iter()
        .zip(values)
        .map(|(p, &v)| ([1e3 * p[0], 1e3 * p[1]], v))
        .filter(|(p, _)| p[0].is_finite() && p[1].is_finite())
        .collect();
    if pts.is_empty() {
        return Ok(false);
    }
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for (p, _) in &pts {
        x0 = x0.min(p[0]);
        x1 = x1.max(p[0]);
        y0 = y0.min(p[1]);
        y1 = y1.max(p[1]);
    }
    let positions: Vec<[f64; 2]> = pts.iter().map(|(p, _)| *p).collect();
    let spacing = view_spacing(snap, &positions, x0, y0, x1 - x0, y1 - y0)
        .max(1e-6 * (x1 - x0).max(y1 - y0))
        .max(f64::MIN_POSITIVE);
    // the particles' squares reach half a spacing beyond their centres
    let (x0, x1, y0, y1) = (
        x0 - 0.5 * spacing,
        x1 + 0.5 * spacing,
        y0 - 0.5 * spacing,
        y1 + 0.5 * spacing,
    );
    let (w, h) = (x1 - x0, y1 - y0);

    // The plotting area in pixels, in the particles' aspect ratio: at most
    // 900 wide and 900 high, at least 240 either way (a slender bar gets
    // room around it rather than a sliver of an image).
    const SIDE: f64 = 900.0;
    const MIN: f64 = 240.0;
    let (pw, ph) = if w >= h {
        (SIDE, (SIDE * h / w).max(MIN))
    } else {
        ((SIDE * w / h).max(MIN), SIDE)
    };
    // widen the shorter range so that a mm is as long across as up
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let mm_per_px = (w / pw).max(h / ph);
    let (hw, hh) = (0.5 * mm_per_px * pw, 0.5 * mm_per_px * ph);
    let (pw, ph) = (pw.round() as u32, ph.round() as u32);

    // around the plotting area: margins, tick labels and axis names
    const MARGIN: u32 = 15;
    const Y_LABELS: u32 = 85;
    const X_LABELS: u32 = 60;
    const TITLE: u32 = 60;
    const BAR: u32 = 170;
    let width = MARGIN + Y_LABELS + pw + MARGIN + BAR;
    let height = TITLE + MARGIN + ph + X_LABELS + MARGIN;

    let (vmin, vmax) = values
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let (scale, unit) = time_unit(snap.time.abs());
    let (label, broken_high) = field_label(field);
    let name = label.split(" (").next().unwrap_or(field).to_string();
    let title = format!("{name} at t = {} {unit}", tick(scale * snap.time));
    let subtitle = if vmin <= vmax {
        format!(
            "{} particles; values from {} to {}",
            pts.len(),
            tick(vmin),
            tick(vmax)
        )
    } else {
        format!("{} particles; no finite value", pts.len())
    };
    let (lo, hi) = if hi > lo { (lo, hi) } else { (lo, lo + 1.0) };

    render(path, (width, height), |root| {
        let e = |e: DrawingAreaErrorKind<_>| e.to_string();
        root.draw(&Text::new(title, (MARGIN as i32, 8), (FONT, 24)))
            .map_err(e)?;
        root.draw(&Text::new(
            subtitle,
            (MARGIN as i32, 36),
            (FONT, 16).into_font().color(&GREY),
        ))
        .map_err(e)?;
        let body = root.margin(TITLE, MARGIN, MARGIN, MARGIN);
        let (left, right) = body.split_horizontally(Y_LABELS + pw + MARGIN);
        let mut chart = ChartBuilder::on(&left)
            .margin_top(MARGIN)
            .margin_right(MARGIN)
            .x_label_area_size(X_LABELS)
            .y_label_area_size(Y_LABELS)
            .build_cartesian_2d((cx - hw)..(cx + hw), (cy - hh)..(cy + hh))
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc("x in mm")
            .y_desc("y in mm")
            .axis_desc_style((FONT, 18))
            .label_style((FONT, 15))
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .draw()
            .map_err(|e| e.to_string())?;
        // one square per particle, in pixels so that neighbours touch
        let r = ((spacing / mm_per_px) * 0.5).max(0.5);
        let (r0, r1) = (r.floor() as i32, (r.ceil() as i32).max(1));
        let mut order: Vec<usize> = (0..pts.len()).collect();
        order.sort_by(|&a, &b| {
            let o = pts[a].1.total_cmp(&pts[b].1);
            if broken_high {
                o
            } else {
                o.reverse()
            }
        });
        for k in order {
            let (p, v) = pts[k];
            // pixels of the whole image, which are the root's coordinates
            let (px, py) = chart.backend_coord(&(p[0], p[1]));
            let colour = viridis((v - lo) / (hi - lo));
            root.draw(&Rectangle::new(
                [(px - r0, py - r0), (px + r1, py + r1)],
                colour.filled(),
            ))
            .map_err(e)?;
        }

        // the colour bar: the scale from lo to hi, its axis on the right
        let mut bar = ChartBuilder::on(&right)
            .margin_top(MARGIN)
            .margin_left(10)
            .x_label_area_size(X_LABELS)
            .right_y_label_area_size(BAR - 70)
            .build_cartesian_2d(0.0..1.0, lo..hi)
            .map_err(|e| e.to_string())?;
        bar.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_desc(label.as_str())
            .axis_desc_style((FONT, 16))
            .label_style((FONT, 15))
            .y_label_formatter(&|v| tick(*v))
            .draw()
            .map_err(|e| e.to_string())?;
        const STEPS: usize = 256;
        bar.draw_series((0..STEPS).map(|k| {
            let (a, b) = (k as f64 / STEPS as f64, (k + 1) as f64 / STEPS as f64);
            Rectangle::new(
                [(0.0, lo + a * (hi - lo)), (1.0, lo + b * (hi - lo))],
                viridis(0.5 * (a + b)).filled(),
            )
        }))
        .map_err(|e| e.to_string())?;
        bar.plotting_area()
            .draw(&Rectangle::new(
                [(0.0, lo), (1.0, hi)],
                BLACK.stroke_width(1),
            ))
            .map_err(e)?;
        Ok(())
    })?;
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnostics::Field;

    #[test]
    fn plots_survive_nan_and_flat_data() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("e.png");
        let mut rows = vec![SeriesRow::default(); 3];
        rows[1].time = 1.0;
        rows[2].time = 2.0;
        rows[2].kinetic_energy = f64::NAN;
        assert!(plot_energies(&p, &rows).unwrap());
        assert!(std::fs::metadata(&p).unwrap().len() > 1000);
        assert!(!plot_energies(&dir.path().join("one.png"), &rows[..1]).unwrap());
    }

    /// A 3D block seen along z: each particle's square is its spacing
    /// (the cube root of its volume), not the far smaller side the area
    /// per particle of the overlapping columns gives; the picture is drawn.
    #[test]
    fn a_3d_snapshot_is_drawn_along_z_with_squares_of_its_spacing() {
        let (n, h) = (6, 1e-3);
        let mut positions = Vec::new();
        let mut damage = Vec::new();
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    positions.push([i as f64 * h, j as f64 * h, k as f64 * h]);
                    damage.push(if i == 3 { 1.0 } else { 0.0 });
                }
            }
        }
        let count = positions.len();
        let snap = Snapshot {
            index: 0,
            step: 0,
            time: 0.0,
            dimension: 3,
            positions,
            fields: vec![
                Field {
                    name: "damage".into(),
                    components: 1,
                    data: FieldData::F64(damage),
                },
                Field {
                    name: "volume".into(),
                    components: 1,
                    data: FieldData::F64(vec![h * h * h; count]),
                },
            ],
            grid: None,
            lines: Vec::new(),
        };
        let mm: Vec<[f64; 2]> = snap
            .positions
            .iter()
            .map(|p| [1e3 * p[0], 1e3 * p[1]])
            .collect();
        let side = 1e3 * h * (n - 1) as f64;
        let s = view_spacing(&snap, &mm, 0.0, 0.0, side, side);
        assert!((s - 1.0).abs() < 1e-12, "{s}");
        let flat = Snapshot {
            dimension: 2,
            ..snap.clone()
        };
        assert!(view_spacing(&flat, &mm, 0.0, 0.0, side, side) < 0.5);
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("d.png");
        assert!(plot_particle_field(&p, &snap, "damage", 0.0, 1.0).unwrap());
        assert!(std::fs::metadata(&p).unwrap().len() > 1000);
    }

    /// Only the first contour's `crack{c}_{end}_J` columns make lines,
    /// one per tip with a finite J (a tip that is NaN throughout has
    /// none); NaN rows do not stop the picture; a series without such a
    /// column, or with one that is never finite, draws nothing.
    #[test]
    fn j_is_drawn_per_tip_with_a_finite_j() {
        let columns: Vec<String> = SeriesRow::COLUMNS
            .iter()
            .map(|c| c.to_string())
            .chain(
                [
                    "crack0_start_J",
                    "crack0_start_KI",
                    "crack0_end_J",
                    "crack0_end_J8",
                    "crack12_end_J",
                    "crack_length",
                    "crackx_end_J",
                ]
                .map(String::from),
            )
            .collect();
        assert_eq!(
            j_columns(&columns),
            [
                ("crack0_start_J", "crack0 start".to_string()),
                ("crack0_end_J", "crack0 end".to_string()),
                ("crack12_end_J", "crack12 end".to_string()),
            ]
        );
        let nan = f64::NAN;
        let rows: Vec<SeriesRow> = (0..4)
            .map(|k| SeriesRow {
                time: [0.0, 1e-6, 2e-6, 3e-6][k],
                // start never a tip, end NaN at t = 0, crack 12's end a
                // tip in one row only
                extra: vec![
                    nan,
                    1.0,
                    [nan, 3.0, 5.0, 4.0][k],
                    2.0,
                    [nan, nan, 7.0, nan][k],
                    0.5,
                    0.0,
                ],
                ..SeriesRow::default()
            })
            .collect();
        let lines = j_lines(&columns, &rows);
        let got: Vec<(&str, &[(f64, f64)])> = lines
            .iter()
            .map(|(name, _, points)| (name.as_str(), points.as_slice()))
            .collect();
        assert_eq!(
            got,
            [
                ("crack0 end", &[(1e-6, 3.0), (2e-6, 5.0), (3e-6, 4.0)][..]),
                ("crack12 end", &[(2e-6, 7.0)][..]),
            ]
        );
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("j_integral.png");
        assert!(plot_j_integral(&p, &columns, &rows).unwrap());
        assert!(std::fs::metadata(&p).unwrap().len() > 1000);

        let never: Vec<SeriesRow> = rows
            .iter()
            .map(|r| SeriesRow {
                extra: vec![nan; 7],
                ..r.clone()
            })
            .collect();
        let q = dir.path().join("none.png");
        assert!(!plot_j_integral(&q, &columns, &never).unwrap());
        let core = &columns[..SeriesRow::COLUMNS.len()];
        assert!(!plot_j_integral(&q, core, &rows).unwrap());
        assert!(!plot_j_integral(&q, &columns, &rows[..1]).unwrap());
        assert!(!q.exists());
    }

    #[test]
    fn ticks_read_as_plain_numbers_in_range() {
        assert_eq!(tick(0.0), "0");
        assert_eq!(tick(-0.0), "0");
        assert_eq!(tick(7.0), "7");
        assert_eq!(tick(100.0), "100");
        assert_eq!(tick(0.1255), "0.1255");
        assert_eq!(tick(0.30000000000000004), "0.3");
        assert_eq!(tick(-12345.0), "-12350");
        assert_eq!(tick(2.5e-5), "2.5e-5");
        assert_eq!(tick(1e-4), "1e-4");
        assert_eq!(tick(3.0e6), "3e6");
        assert_eq!(time_unit(8e-5), (1e6, "µs"));
        assert_eq!(time_unit(0.05), (1e3, "ms"));
        assert_eq!(time_unit(2.0), (1.0, "s"));
    }
}
