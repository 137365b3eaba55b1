//! Plots of a run: energies against time, the crack tip against time, and
//! a particle field as an image.

use super::OutputError;
use crate::diagnostics::SeriesRow;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// One line of a chart: name, colour, points (non-finite ones are skipped).
type Line = (String, RGBColor, Vec<(f64, f64)>);

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
        .caption(title, ("sans-serif", 22))
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
    // plotters reports its errors as its own type; keep the message.
    let err = |e: String| OutputError::new(path, std::io::Error::other(e));
    let tmp = path.with_extension("png.tmp.png");
    {
        let root = BitMapBackend::new(&tmp, (900, 520 * charts.len() as u32)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        for (area, (title, y_desc, lines)) in
            root.split_evenly((charts.len(), 1)).iter().zip(charts)
        {
            chart(area, title, y_desc, lines).map_err(err)?;
        }
        root.present().map_err(|e| err(e.to_string()))?;
    }
    std::fs::rename(&tmp, path).map_err(|e| OutputError::new(path, e))
}

/// Side-by-side panels of lines against a logarithmic x axis with a
/// shared y range (e.g. cumulative fragment-size distributions): each
/// panel is (title, lines as (name, points)); `x_desc`, `y_desc` label the
/// axes. Points with x <= 0 or non-finite values are skipped.
pub fn plot_log_x(
    path: &Path,
    x_desc: &str,
    y_desc: &str,
    panels: &[(String, Vec<(String, Vec<(f64, f64)>)>)],
) -> Result<(), OutputError> {
    let err = |e: String| OutputError::new(path, std::io::Error::other(e));
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
    let tmp = path.with_extension("png.tmp.png");
    {
        let root =
            BitMapBackend::new(&tmp, (620 * panels.len().max(1) as u32, 520)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        for (area, (title, lines)) in root
            .split_evenly((1, panels.len().max(1)))
            .iter()
            .zip(panels)
        {
            let mut chart = ChartBuilder::on(area)
                .caption(title, ("sans-serif", 22))
                .margin(12)
                .x_label_area_size(45)
                .y_label_area_size(70)
                .build_cartesian_2d((0.8 * x0..1.25 * x1).log_scale(), y0..1.05 * y1)
                .map_err(|e| err(e.to_string()))?;
            chart
                .configure_mesh()
                .x_desc(x_desc)
                .y_desc(y_desc)
                .x_label_formatter(&|x| format!("{x:.2}"))
                .draw()
                .map_err(|e| err(e.to_string()))?;
            for (k, (name, points)) in lines.iter().enumerate() {
                let colour = colours[k % colours.len()];
                let p: Vec<(f64, f64)> = points.iter().filter(ok).copied().collect();
                draw_line(&mut chart, name, colour, p).map_err(err)?;
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .position(SeriesLabelPosition::UpperLeft)
                .draw()
                .map_err(|e| err(e.to_string()))?;
        }
        root.present().map_err(|e| err(e.to_string()))?;
    }
    std::fs::rename(&tmp, path).map_err(|e| OutputError::new(path, e))
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
    let err = |e: String| OutputError::new(path, std::io::Error::other(e));
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
    let tmp = path.with_extension("png.tmp.png");
    {
        let root = BitMapBackend::new(&tmp, (900, 640)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 22))
            .margin(16)
            .x_label_area_size(45)
            .y_label_area_size(80)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|e| err(e.to_string()))?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc(y_desc)
            .x_labels(6)
            .y_labels(6)
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .draw()
            .map_err(|e| err(e.to_string()))?;
        let mut line: Vec<(f64, f64)> = shown.iter().filter(|p| p.3).map(|p| (p.0, p.1)).collect();
        line.sort_by(|a, b| a.0.total_cmp(&b.0));
        draw_line(&mut chart, "Pareto front", ORANGE, line).map_err(err)?;
        chart
            .draw_series(shown.iter().map(|p| {
                let style = if p.3 {
                    ORANGE.filled()
                } else {
                    BLUE_.stroke_width(2)
                };
                EmptyElement::at((p.0, p.1))
                    + Circle::new((0, 0), 5, style)
                    + Text::new(p.2.to_string(), (8, -6), ("sans-serif", 13).into_font())
            }))
            .map_err(|e| err(e.to_string()))?;
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(|e| err(e.to_string()))?;
        root.present().map_err(|e| err(e.to_string()))?;
    }
    std::fs::rename(&tmp, path).map_err(|e| OutputError::new(path, e))?;
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
    // The unit goes in the title: plotters draws a rotated J (or j) as a
    // speck. In plane strain the thickness is 1 m unless the scene says
    // otherwise, so the values are then J per metre.
    draw(path, &[("Energies in J", "energy", lines)])?;
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

/// A polar plot of r(θ) (degrees) as a closed curve, one panel per series,
/// side by side, equal axes.
pub fn plot_polar(path: &Path, panels: &[(&str, Vec<(f64, f64)>)]) -> Result<(), OutputError> {
    let err = |e: String| OutputError::new(path, std::io::Error::other(e));
    let tmp = path.with_extension("png.tmp.png");
    {
        let width = 480 * panels.len().max(1) as u32;
        let root = BitMapBackend::new(&tmp, (width, 500)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
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
                .caption(*title, ("sans-serif", 20))
                .margin(10)
                .x_label_area_size(35)
                .y_label_area_size(60)
                .build_cartesian_2d(-rmax..rmax, -rmax..rmax)
                .map_err(|e| err(e.to_string()))?;
            chart
                .configure_mesh()
                .x_labels(5)
                .y_labels(5)
                .x_label_formatter(&|x| format!("{x:.2e}"))
                .y_label_formatter(&|y| format!("{y:.2e}"))
                .draw()
                .map_err(|e| err(e.to_string()))?;
            let mut curve: Vec<(f64, f64)> = pts
                .iter()
                .filter(|p| p.1.is_finite())
                .map(|&(deg, r)| (r * deg.to_radians().cos(), r * deg.to_radians().sin()))
                .collect();
            if let Some(&first) = curve.first() {
                curve.push(first);
            }
            chart
                .draw_series(LineSeries::new(
                    curve,
                    RGBColor(31, 119, 180).stroke_width(2),
                ))
                .map_err(|e| err(e.to_string()))?;
        }
        root.present().map_err(|e| err(e.to_string()))?;
    }
    std::fs::rename(&tmp, path).map_err(|e| OutputError::new(path, e))
}

/// An image of one scalar particle field (e.g. the phase field) on the
/// deformed particles: each particle is a small square coloured from blue
/// (`lo`) to red (`hi`) through white.
pub fn plot_particle_field(
    path: &Path,
    snap: &crate::diagnostics::Snapshot,
    field: &str,
    lo: f64,
    hi: f64,
) -> Result<bool, OutputError> {
    let Some(values) = snap
        .fields
        .iter()
        .find(|f| f.name == field && f.components == 1)
        .and_then(|f| match &f.data {
            crate::diagnostics::FieldData::F64(v) => Some(v),
            _ => None,
        })
    else {
        return Ok(false);
    };
    if snap.positions.is_empty() {
        return Ok(false);
    }
    let err = |e: String| OutputError::new(path, std::io::Error::other(e));
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for p in &snap.positions {
        x0 = x0.min(p[0]);
        x1 = x1.max(p[0]);
        y0 = y0.min(p[1]);
        y1 = y1.max(p[1]);
    }
    let (w, h) = (
        (x1 - x0).max(f64::MIN_POSITIVE),
        (y1 - y0).max(f64::MIN_POSITIVE),
    );
    // at most 1000 × 2000 pixels, in the particles' aspect ratio
    let (width, height) = if h > 2.0 * w {
        (((2000.0 * w / h).round() as u32).max(50), 2000)
    } else {
        (1000, ((1000.0 * h / w).round() as u32).max(50))
    };
    let tmp = path.with_extension("png.tmp.png");
    {
        let root = BitMapBackend::new(&tmp, (width, height + 30)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        root.draw(&Text::new(
            format!("{field} at t = {:.3e} s", snap.time),
            (10, 5),
            ("sans-serif", 18),
        ))
        .map_err(|e| err(e.to_string()))?;
        // one square of about a particle's spacing
        let per = (snap.positions.len() as f64 / (w * h)).sqrt();
        let size = ((width as f64 / w / per).ceil() as i32).max(1);
        let span = (hi - lo).abs().max(f64::MIN_POSITIVE);
        for (p, &v) in snap.positions.iter().zip(values) {
            let t = ((v - lo) / span).clamp(0.0, 1.0);
            let colour = if t < 0.5 {
                let u = t * 2.0;
                RGBColor((255.0 * u) as u8, (255.0 * u) as u8, 255)
            } else {
                let u = (t - 0.5) * 2.0;
                RGBColor(255, (255.0 * (1.0 - u)) as u8, (255.0 * (1.0 - u)) as u8)
            };
            let px = ((p[0] - x0) / w * (width as f64 - size as f64)) as i32;
            let py = 30 + ((y1 - p[1]) / h * (height as f64 - size as f64)) as i32;
            root.draw(&Rectangle::new(
                [(px, py), (px + size, py + size)],
                colour.filled(),
            ))
            .map_err(|e| err(e.to_string()))?;
        }
        root.present().map_err(|e| err(e.to_string()))?;
    }
    std::fs::rename(&tmp, path).map_err(|e| OutputError::new(path, e))?;
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

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
