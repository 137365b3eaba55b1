//! Accuracy against cost: the pieces of a parameter study (issue 6).
//!
//! A study runs one scene at every combination of a few settings and
//! measures one number of each run (a [`Metric`] of its series) against a
//! [`Reference`], to show what accuracy costs in wall time. This module
//! holds what does not depend on where the runs happen: the settings
//! ([`Axis`], dotted keys into the scene document, [`set_key`]), the
//! variants ([`variants`]), the metric, the error and the Pareto front.
//! The `cleave study` command runs the variants (in this process or on a
//! server) and writes the table and the plot.

use crate::diagnostics::SeriesRow;
use crate::scene::{Format, Scene, SceneError};
use serde_json::Value;

/// One varied setting: a dotted key into the scene and its values, as
/// written on the command line (`time.cfl=0.2,0.4`).
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    pub key: String,
    pub values: Vec<String>,
}

impl Axis {
    /// Parses `KEY=V1,V2,…`.
    pub fn parse(spec: &str) -> Result<Axis, String> {
        let (key, text) = spec.split_once('=').ok_or_else(|| {
            format!("--vary {spec:?}: expected KEY=V1,V2,… (e.g. grid.cell_size=1e-3,5e-4)")
        })?;
        let key = key.trim();
        if key.is_empty() {
            return Err(format!("--vary {spec:?}: the key is empty"));
        }
        // split on the commas outside brackets: `gamma=[1,1,0,2],[1,1,0,74]`
        let (mut values, mut depth, mut cur) = (Vec::new(), 0i32, String::new());
        for ch in text.chars() {
            match ch {
                '[' | '{' => depth += 1,
                ']' | '}' => depth -= 1,
                ',' if depth == 0 => {
                    values.push(std::mem::take(&mut cur).trim().to_string());
                    continue;
                }
                _ => {}
            }
            cur.push(ch);
        }
        values.push(cur.trim().to_string());
        if values.iter().any(String::is_empty) {
            return Err(format!("--vary {spec:?}: an empty value"));
        }
        Ok(Axis {
            key: key.to_string(),
            values,
        })
    }
}

/// The scene as a JSON document (a TOML scene is converted), which
/// [`set_key`] edits and [`Scene::from_text`] reads back.
pub fn scene_document(text: &str, format: Format) -> Result<Value, SceneError> {
    // the typed parse first: its errors name the field and the line
    crate::scene::parse(text, format)?;
    match format {
        Format::Toml => {
            toml::from_str::<Value>(text).map_err(|e| SceneError::single("", e.to_string()))
        }
        Format::Json => {
            serde_json::from_str::<Value>(text).map_err(|e| SceneError::single("", e.to_string()))
        }
    }
}

/// One step of a dotted key: a table key, then any number of array indices.
fn segments(key: &str) -> Result<Vec<(String, Vec<usize>)>, String> {
    key.split('.')
        .map(|seg| {
            let (name, rest) = seg.split_once('[').map_or((seg, ""), |(n, r)| (n, r));
            if name.is_empty() {
                return Err(format!("{key}: empty segment"));
            }
            let mut idx = Vec::new();
            if !rest.is_empty() {
                for part in format!("[{rest}").split('[').skip(1) {
                    let n = part
                        .strip_suffix(']')
                        .and_then(|n| n.parse::<usize>().ok())
                        .ok_or_else(|| format!("{key}: bad index in {seg:?} (write name[0])"))?;
                    idx.push(n);
                }
            }
            Ok((name.to_string(), idx))
        })
        .collect()
}

/// A value as written on the command line: a JSON literal (number, `true`,
/// `false`, a quoted string, an array such as `[1,1,0,2]`) or else a bare string (an enumerated setting
/// such as `quadratic_bspline`).
fn literal(raw: &str) -> Value {
    match serde_json::from_str::<Value>(raw) {
        Ok(v @ (Value::Number(_) | Value::Bool(_) | Value::String(_) | Value::Array(_))) => v,
        _ => Value::String(raw.to_string()),
    }
}

/// Sets `key` (dotted, e.g. `bodies[0].particles_per_cell`) in the scene
/// document to `raw`. Missing tables on the way are created. Two values
/// switch a whole table: `on` keeps it (or adds it with its defaults, e.g.
/// `dfg=on`) and `off` removes it (`dfg=off`: no DFG partitioning). The
/// scene's validation judges the result.
pub fn set_key(doc: &mut Value, key: &str, raw: &str) -> Result<(), SceneError> {
    let bad = |reason: String| SceneError::single(key, reason);
    let segs = segments(key).map_err(bad)?;
    let mut at = doc;
    for (k, (name, idx)) in segs.iter().enumerate() {
        let last = k + 1 == segs.len();
        let obj = at
            .as_object_mut()
            .ok_or_else(|| bad(format!("{name:?} is inside something that is not a table")))?;
        if last && idx.is_empty() {
            match raw {
                "off" => {
                    obj.remove(name);
                }
                "on" => {
                    let slot = obj
                        .entry(name.clone())
                        .or_insert_with(|| Value::Object(Default::default()));
                    if !slot.is_object() {
                        return Err(bad("`on`/`off` switch a table; this key is a value (use true/false or a number)".into()));
                    }
                }
                _ => {
                    obj.insert(name.clone(), literal(raw));
                }
            }
            return Ok(());
        }
        let mut here = obj
            .entry(name.clone())
            .or_insert_with(|| Value::Object(Default::default()));
        for (j, &i) in idx.iter().enumerate() {
            let arr = here
                .as_array_mut()
                .ok_or_else(|| bad(format!("{name} is not an array")))?;
            let len = arr.len();
            let item = arr
                .get_mut(i)
                .ok_or_else(|| bad(format!("index {i} out of range: {name} has {len} entries")))?;
            if last && j + 1 == idx.len() {
                *item = literal(raw);
                return Ok(());
            }
            here = item;
        }
        at = here;
    }
    Ok(())
}

/// One combination of settings, ready to run.
#[derive(Debug, Clone)]
pub struct Variant {
    /// (key, value) per axis, in axis order.
    pub settings: Vec<(String, String)>,
    /// The scene as JSON text (what a server is sent and a user can rerun).
    pub text: String,
    pub scene: Scene,
}

/// Every combination of the axes' values (the first axis varies slowest),
/// each validated. All problems of all variants are reported at once,
/// prefixed with the settings that cause them, before anything runs.
pub fn variants(doc: &Value, axes: &[Axis]) -> Result<Vec<Variant>, SceneError> {
    let total: usize = axes.iter().map(|a| a.values.len()).product();
    let mut out = Vec::with_capacity(total);
    let mut errors = Vec::new();
    for n in 0..total {
        let mut rest = n;
        let mut pick = vec![0; axes.len()];
        for (a, axis) in axes.iter().enumerate().rev() {
            pick[a] = rest % axis.values.len();
            rest /= axis.values.len();
        }
        let settings: Vec<(String, String)> = axes
            .iter()
            .zip(&pick)
            .map(|(a, &k)| (a.key.clone(), a.values[k].clone()))
            .collect();
        let mut d = doc.clone();
        let result = settings
            .iter()
            .try_for_each(|(k, v)| set_key(&mut d, k, v))
            .and_then(|_| {
                serde_json::to_string_pretty(&d).map_err(|e| SceneError::single("", e.to_string()))
            })
            .and_then(|text| {
                Scene::from_text(&text, Some(Format::Json)).map(|scene| (text, scene))
            });
        match result {
            Ok((text, scene)) => out.push(Variant {
                settings,
                text,
                scene,
            }),
            Err(e) => {
                let label = settings
                    .iter()
                    .map(|(k, v)| format!("{k}={v}"))
                    .collect::<Vec<_>>()
                    .join(" ");
                errors.extend(e.errors.into_iter().map(|mut f| {
                    f.reason = format!("{} (with {label})", f.reason);
                    f
                }));
            }
        }
    }
    if errors.is_empty() {
        Ok(out)
    } else {
        Err(SceneError { errors })
    }
}

/// The number a study measures in each run, from its `series.csv`.
#[derive(Debug, Clone, PartialEq)]
pub enum Metric {
    /// `COLUMN` or `final:COLUMN`: the last row's value.
    Final(String),
    /// `max:COLUMN`.
    Max(String),
    /// `min:COLUMN`.
    Min(String),
    /// `arrival:COLUMN=VALUE`: the first time the column reaches VALUE
    /// (from below or above, whichever way it starts), interpolated
    /// linearly between rows, s. E.g. a crack tip's arrival at x.
    Arrival(String, f64),
    /// `energy_loss`: the energy the system lost, kinetic + strain at the
    /// first row plus the external work done since, minus kinetic + strain
    /// at the last row, J: what Homel & Herbold measure as dissipation
    /// (it includes the scheme's numerical loss).
    EnergyLoss,
    /// `crack_angle:X0,Y0`: the angle of the crack tip (the `crack_tip_x`,
    /// `crack_tip_y` columns) seen from (X0, Y0), degrees from +x, at the
    /// last row with a tip.
    CrackAngle([f64; 2]),
    /// `propagation_energy[:ENERGY[,LENGTH]]`: the energy a crack dissipates
    /// while it runs, J. The increase of the ENERGY column (default
    /// `fracture_energy`) from the last row where the crack (LENGTH, default
    /// `crack_length`) is shorter than 10 % of its greatest length to the
    /// first row where it has 99 %. (Not "the last row without a crack": a
    /// speck of c < 0.1 at an impact face long before the crack runs would
    /// move the start.) Kakouris & Triantafyllou measure the sphere–beam impact (`scenes/p3_*`) this way: Ψ_f from its
    /// point (4), where the median crack starts, to (6), where it is
    /// through (Fig. 23a, 311.82 − 94.29 = 217.53 mJ against Ḡc·A_f).
    PropagationEnergy { energy: String, length: String },
}

impl Metric {
    pub fn parse(spec: &str) -> Result<Metric, String> {
        if spec == "energy_loss" {
            return Ok(Metric::EnergyLoss);
        }
        if let Some(rest) = spec.strip_prefix("propagation_energy") {
            let cols: Vec<&str> = match rest.strip_prefix(':') {
                Some(r) => r.split(',').map(str::trim).collect(),
                None if rest.is_empty() => Vec::new(),
                None => vec![""], // "propagation_energyX": rejected below
            };
            if cols.len() > 2 || cols.iter().any(|c| c.is_empty()) {
                return Err(format!(
                    "--metric {spec:?}: write propagation_energy[:ENERGY_COLUMN[,LENGTH_COLUMN]]"
                ));
            }
            return Ok(Metric::PropagationEnergy {
                energy: cols.first().unwrap_or(&"fracture_energy").to_string(),
                length: cols.get(1).unwrap_or(&"crack_length").to_string(),
            });
        }
        if let Some(at) = spec.strip_prefix("crack_angle:") {
            let v: Vec<f64> = at
                .split(',')
                .filter_map(|v| v.trim().parse().ok())
                .collect();
            return match v[..] {
                [x, y] if x.is_finite() && y.is_finite() => Ok(Metric::CrackAngle([x, y])),
                _ => Err(format!("--metric {spec:?}: write crack_angle:X0,Y0 (the point the angle is seen from, m)")),
            };
        }
        let (kind, rest) = spec.split_once(':').unwrap_or(("final", spec));
        let col = |c: &str| {
            if c.trim().is_empty() {
                Err(format!("--metric {spec:?}: no column"))
            } else {
                Ok(c.trim().to_string())
            }
        };
        match kind {
            "final" => Ok(Metric::Final(col(rest)?)),
            "max" => Ok(Metric::Max(col(rest)?)),
            "min" => Ok(Metric::Min(col(rest)?)),
            "arrival" => {
                let (c, v) = rest
                    .split_once('=')
                    .ok_or_else(|| format!("--metric {spec:?}: write arrival:COLUMN=VALUE"))?;
                let v: f64 = v.trim().parse().map_err(|_| format!("--metric {spec:?}: {v:?} is not a number"))?;
                Ok(Metric::Arrival(col(c)?, v))
            }
            _ => Err(format!(
                "--metric {spec:?}: unknown kind {kind:?} (final, max, min, arrival, crack_angle, propagation_energy or energy_loss)"
            )),
        }
    }

    /// The series column it reads.
    pub fn column(&self) -> &str {
        match self {
            Metric::Final(c) | Metric::Max(c) | Metric::Min(c) | Metric::Arrival(c, _) => c,
            Metric::EnergyLoss => "kinetic_energy",
            Metric::CrackAngle(_) => "crack_tip_x",
            Metric::PropagationEnergy { energy, .. } => energy,
        }
    }

    /// Its value for a run's series; an error says why there is none (no
    /// such column, no rows, never arrived).
    pub fn eval(&self, columns: &[String], rows: &[SeriesRow]) -> Result<f64, String> {
        self.measure(columns, rows).map(|(v, _)| v)
    }

    /// Its value and, for `propagation_energy`, the rows it spans, so a
    /// reader can see what was measured.
    pub fn measure(
        &self,
        columns: &[String],
        rows: &[SeriesRow],
    ) -> Result<(f64, Option<Window>), String> {
        // (time, value) of the column's finite values
        let series = |name: &str| -> Result<Vec<(f64, f64)>, String> {
            if !columns.iter().any(|c| c == name) {
                return Err(format!(
                    "the series has no column {name:?} (it has: {})",
                    columns.join(", ")
                ));
            }
            let v: Vec<(f64, f64)> = rows
                .iter()
                .filter_map(|r| Some((r.time, r.get(columns, name)?)))
                .filter(|v| v.1.is_finite())
                .collect();
            if v.is_empty() {
                return Err(format!("no finite values of {name:?}"));
            }
            Ok(v)
        };
        let value = match self {
            Metric::Final(c) => Ok(series(c)?.last().map_or(f64::NAN, |v| v.1)),
            Metric::Max(c) => Ok(series(c)?
                .iter()
                .map(|v| v.1)
                .fold(f64::NEG_INFINITY, f64::max)),
            Metric::Min(c) => Ok(series(c)?.iter().map(|v| v.1).fold(f64::INFINITY, f64::min)),
            Metric::EnergyLoss => {
                let (Some(a), Some(b)) = (rows.first(), rows.last()) else {
                    return Err("no rows".into());
                };
                let e = |r: &SeriesRow| r.kinetic_energy + r.strain_energy - r.external_work;
                let loss = e(a) - e(b);
                if loss.is_finite() {
                    Ok(loss)
                } else {
                    Err("the energies are not finite".into())
                }
            }
            Metric::CrackAngle(o) => {
                let (xs, ys) = (series("crack_tip_x")?, series("crack_tip_y")?);
                let (Some(x), Some(y)) = (xs.last(), ys.last()) else {
                    return Err("no crack tip".into());
                };
                Ok((y.1 - o[1]).atan2(x.1 - o[0]).to_degrees())
            }
            Metric::PropagationEnergy { energy, length } => {
                let len = series(length)?;
                let longest = len.iter().map(|v| v.1).fold(0.0, f64::max);
                if longest <= 0.0 {
                    return Err(format!("no crack formed ({length} stays 0)"));
                }
                let through = len
                    .iter()
                    .position(|v| v.1 >= 0.99 * longest)
                    .unwrap_or(len.len() - 1);
                let start = len[..through]
                    .iter()
                    .rposition(|v| v.1 <= 0.1 * longest)
                    .unwrap_or(0);
                let (t0, t1) = (len[start].0, len[through].0);
                let e = series(energy)?;
                let at = |t: f64| {
                    e.iter()
                        .find(|v| v.0 == t)
                        .map(|v| v.1)
                        .ok_or_else(|| format!("{energy} has no value at t = {t:e} s"))
                };
                let window = Window {
                    from: len[start],
                    to: len[through],
                };
                return Ok((at(t1)? - at(t0)?, Some(window)));
            }
            Metric::Arrival(c, target) => {
                let vals = series(c)?;
                let above = vals[0].1 >= *target;
                if vals[0].1 == *target {
                    Ok(vals[0].0)
                } else {
                    vals.windows(2)
                        .find(|w| (w[1].1 >= *target) != above || w[1].1 == *target)
                        .map(|w| {
                            let ((t0, a), (t1, b)) = (w[0], w[1]);
                            let s = if b == a { 1.0 } else { (target - a) / (b - a) };
                            t0 + s.clamp(0.0, 1.0) * (t1 - t0)
                        })
                        .ok_or_else(|| format!("{c} never reached {target}"))
                }
            }
        };
        value.map(|v| (v, None))
    }
}

/// The rows a `propagation_energy` spans: (time in s, crack length in the
/// length column's unit) where it starts and where it ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    pub from: (f64, f64),
    pub to: (f64, f64),
}

/// What a run's metric is compared with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Reference {
    /// The run with the most particle-steps (particles × steps; ties: the
    /// longest wall time): the finest discretization of the study.
    Finest,
    /// A known value.
    Analytic(f64),
}

impl Reference {
    pub fn parse(spec: &str) -> Result<Reference, String> {
        match spec.split_once(':') {
            None if spec == "finest" => Ok(Reference::Finest),
            Some(("analytic", v)) => v
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .map(Reference::Analytic)
                .ok_or_else(|| format!("--reference {spec:?}: {v:?} is not a finite number")),
            _ => Err(format!(
                "--reference {spec:?}: write finest or analytic:VALUE"
            )),
        }
    }
}

/// Relative error |m − r| / |r| (absolute when r = 0).
pub fn error(metric: f64, reference: f64) -> f64 {
    if reference == 0.0 {
        metric.abs()
    } else {
        ((metric - reference) / reference).abs()
    }
}

/// Which of the (cost, error) points are on the Pareto front: no other
/// point is at most as costly and at most as wrong, and better in one.
/// Non-finite points are never on it, and do not dominate.
pub fn pareto(points: &[(f64, f64)]) -> Vec<bool> {
    let ok = |p: &(f64, f64)| p.0.is_finite() && p.1.is_finite();
    points
        .iter()
        .map(|p| {
            ok(p)
                && !points
                    .iter()
                    .any(|q| ok(q) && q.0 <= p.0 && q.1 <= p.1 && (q.0 < p.0 || q.1 < p.1))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const SCENE: &str = r#"
[grid]
cell_size = 0.01
max = [0.1, 0.1]
[time]
end = 1e-4
[materials.m]
model = "linear_elastic"
density = 1000.0
youngs_modulus = 1e6
poissons_ratio = 0.3
[[bodies]]
shape = { type = "box", min = [0.02, 0.02], max = [0.08, 0.08] }
material = "m"
"#;

    #[test]
    fn keys_set_values_arrays_and_tables() {
        let mut d = scene_document(SCENE, Format::Toml).unwrap();
        set_key(&mut d, "grid.cell_size", "5e-3").unwrap();
        set_key(&mut d, "bodies[0].particles_per_cell", "9").unwrap();
        set_key(&mut d, "grid.shape_function", "cubic_bspline").unwrap();
        set_key(&mut d, "time.cfl", "0.3").unwrap();
        set_key(&mut d, "output", "on").unwrap();
        assert_eq!(d["grid"]["cell_size"], 5e-3);
        assert_eq!(d["bodies"][0]["particles_per_cell"], 9);
        assert_eq!(d["grid"]["shape_function"], "cubic_bspline");
        assert!(d["output"].is_object());
        set_key(&mut d, "output", "off").unwrap();
        assert!(d.get("output").is_none());
        let e = set_key(&mut d, "bodies[3].material", "m").unwrap_err();
        assert_eq!(e.errors[0].path, "bodies[3].material");
        assert!(e.errors[0].reason.contains("out of range"), "{e}");
        assert!(set_key(&mut d, "grid.cell_size", "on").is_err());
        let scene =
            Scene::from_text(&serde_json::to_string(&d).unwrap(), Some(Format::Json)).unwrap();
        assert_eq!(scene.file.grid.cell_size, 5e-3);
    }

    #[test]
    fn variants_are_the_product_and_bad_ones_name_their_setting() {
        let d = scene_document(SCENE, Format::Toml).unwrap();
        let axes = [
            Axis::parse("grid.cell_size=0.01,0.005").unwrap(),
            Axis::parse("time.cfl=0.2,0.3,0.4").unwrap(),
        ];
        let v = variants(&d, &axes).unwrap();
        assert_eq!(v.len(), 6);
        assert_eq!(
            v[1].settings,
            vec![
                ("grid.cell_size".into(), "0.01".into()),
                ("time.cfl".into(), "0.3".into())
            ]
        );
        assert_eq!(v[5].scene.file.grid.cell_size, 0.005);
        let bad = [Axis::parse("grid.cell_size=0.01,-1").unwrap()];
        let e = variants(&d, &bad).unwrap_err();
        assert_eq!(e.errors[0].path, "grid.cell_size");
        assert!(e.errors[0].reason.contains("grid.cell_size=-1"), "{e}");
        let g = Axis::parse("materials.m.phase_field.gamma=[1,1,0,2], [1,1,0,74]").unwrap();
        assert_eq!(g.values, vec!["[1,1,0,2]", "[1,1,0,74]"]);
        let mut d2 = d.clone();
        set_key(&mut d2, &g.key, &g.values[1]).unwrap();
        assert_eq!(
            d2["materials"]["m"]["phase_field"]["gamma"],
            serde_json::json!([1, 1, 0, 74])
        );
        assert!(Axis::parse("grid.cell_size").is_err());
        assert!(Axis::parse("a=1,,2").is_err());
    }

    #[test]
    fn metrics_read_the_series() {
        let cols: Vec<String> = SeriesRow::COLUMNS.iter().map(|s| s.to_string()).collect();
        let rows: Vec<SeriesRow> = (0..5)
            .map(|k| {
                let mut v = vec![0.0; cols.len()];
                v[0] = k as f64;
                v[1] = k as f64 * 0.1;
                v[2] = [0.0, 2.0, 4.0, 3.0, 1.0][k];
                SeriesRow::from_values(&v).unwrap()
            })
            .collect();
        let c = cols[2].clone();
        assert_eq!(Metric::parse(&c).unwrap().eval(&cols, &rows).unwrap(), 1.0);
        assert_eq!(
            Metric::parse(&format!("max:{c}"))
                .unwrap()
                .eval(&cols, &rows)
                .unwrap(),
            4.0
        );
        assert_eq!(
            Metric::parse(&format!("min:{c}"))
                .unwrap()
                .eval(&cols, &rows)
                .unwrap(),
            0.0
        );
        let t = Metric::parse(&format!("arrival:{c}=3"))
            .unwrap()
            .eval(&cols, &rows)
            .unwrap();
        assert!((t - 0.15).abs() < 1e-12, "{t}");
        assert!(Metric::parse(&format!("arrival:{c}=9"))
            .unwrap()
            .eval(&cols, &rows)
            .is_err());
        assert!(Metric::parse("final:nope")
            .unwrap()
            .eval(&cols, &rows)
            .unwrap_err()
            .contains("no column"));
        assert!(Metric::parse("median:x").is_err());
        // kinetic 0 → 1 (rows 0 and 4 have kinetic 0 and 1), no strain, no work
        assert_eq!(
            Metric::parse("energy_loss")
                .unwrap()
                .eval(&cols, &rows)
                .unwrap(),
            -1.0
        );
        assert_eq!(
            Reference::parse("analytic:2.5").unwrap(),
            Reference::Analytic(2.5)
        );
        assert!(Reference::parse("analytic:x").is_err());
        assert_eq!(
            Metric::parse("crack_angle:0.05,0.025").unwrap(),
            Metric::CrackAngle([0.05, 0.025])
        );
        assert!(Metric::parse("crack_angle:0.05").is_err());
        let mut tc = cols.clone();
        tc.extend(["crack_tip_x".to_string(), "crack_tip_y".to_string()]);
        let tip_rows: Vec<SeriesRow> = rows
            .iter()
            .map(|r| {
                let mut v = r.values();
                v.extend([1.0, 1.0 + r.time]);
                SeriesRow::from_values(&v).unwrap()
            })
            .collect();
        let a = Metric::CrackAngle([1.0, 0.0]).eval(&tc, &tip_rows).unwrap();
        assert!((a - 90.0).abs() < 1e-9, "{a}");
        assert!(Reference::parse("coarsest").is_err());
        // a crack that appears at row 2, is through at row 4 and stays
        let mut pc = cols.clone();
        pc.extend(["fracture_energy_b0".to_string(), "crack_length".to_string()]);
        let lengths = [0.0, 0.0, 0.5, 0.995, 1.0, 1.0];
        let energies = [0.0, 1.0, 2.0, 4.0, 5.0, 9.0];
        let crack_rows: Vec<SeriesRow> = (0..6)
            .map(|i| {
                let mut v = rows[i % rows.len()].values();
                v[0] = i as f64;
                v[1] = i as f64 * 0.1;
                v.extend([energies[i], lengths[i]]);
                SeriesRow::from_values(&v).unwrap()
            })
            .collect();
        let m = Metric::parse("propagation_energy:fracture_energy_b0").unwrap();
        assert_eq!(
            m,
            Metric::PropagationEnergy {
                energy: "fracture_energy_b0".into(),
                length: "crack_length".into()
            }
        );
        // from row 1 (the last under 10 % of the longest) to row 3 (99 %)
        assert_eq!(m.eval(&pc, &crack_rows).unwrap(), 3.0);
        assert_eq!(
            m.measure(&pc, &crack_rows).unwrap(),
            (
                3.0,
                Some(Window {
                    from: (0.1, 0.0),
                    to: (3.0 * 0.1, 0.995)
                })
            )
        );
        assert_eq!(
            Metric::parse(&c).unwrap().measure(&cols, &rows).unwrap(),
            (1.0, None)
        );
        let none: Vec<SeriesRow> = crack_rows
            .iter()
            .map(|r| {
                let mut v = r.values();
                let n = v.len();
                v[n - 1] = 0.0;
                SeriesRow::from_values(&v).unwrap()
            })
            .collect();
        assert!(m.eval(&pc, &none).unwrap_err().contains("no crack"));
        assert!(Metric::parse("propagation_energy:a,b,c").is_err());
        assert!(Metric::parse("propagation_energyx").is_err());
    }

    #[test]
    fn pareto_keeps_the_undominated() {
        let p = [
            (1.0, 0.5),
            (2.0, 0.1),
            (3.0, 0.2),
            (4.0, 0.01),
            (f64::NAN, 0.0),
        ];
        assert_eq!(pareto(&p), vec![true, true, false, true, false]);
        assert_eq!(error(1.1, 1.0), 0.10000000000000009);
        assert_eq!(error(0.5, 0.0), 0.5);
    }
}
