//! `cleave gc-polar`: the effective surface energy Gc(θ) of the 4th-order
//! anisotropic phase field (eq. 8 of Kakouris & Triantafyllou) as a table and a polar plot.

use cleave::fracture::phase_field::anisotropy::{polar, Gamma};
use serde_json::json;
use std::path::Path;
use std::process::ExitCode;

fn invalid(msg: String) -> ExitCode {
    eprintln!("error: {msg}");
    ExitCode::from(2)
}

pub fn run(gamma: &str, gc_bar: f64, step: f64, json_out: bool, out: &Path) -> ExitCode {
    let values: Result<Vec<f64>, _> = gamma.split(',').map(|v| v.trim().parse::<f64>()).collect();
    let g = match values {
        Ok(v) if (v.len() == 4 || v.len() == 6) && v.iter().all(|x| x.is_finite()) => Gamma {
            g1111: v[0],
            g2222: v[1],
            g1122: v[2],
            g1212: v[3],
            g1112: v.get(4).copied().unwrap_or(0.0),
            g2212: v.get(5).copied().unwrap_or(0.0),
        },
        _ => return invalid(format!("--gamma: expected 4 or 6 finite numbers g1111,g2222,g1122,g1212[,g1112,g2212], got {gamma:?}")),
    };
    if !(gc_bar.is_finite() && gc_bar > 0.0) {
        return invalid(format!("--gc-bar: must be > 0, got {gc_bar}"));
    }
    if !(step.is_finite() && step > 0.0 && step <= 90.0) {
        return invalid(format!(
            "--angle-step: must be in (0, 90] degrees, got {step}"
        ));
    }
    let worst = g.min_along();
    if worst < 0.0 {
        return invalid(format!(
            "--gamma: the crack-profile coefficient a(n) = vᵀγv is negative ({worst:.3e}) for some direction, so the functional is unbounded below"
        ));
    }
    let table = polar(&g, gc_bar, step);
    let (mut lo, mut hi) = (table[0], table[0]);
    for &p in &table {
        if p.1 < lo.1 {
            lo = p;
        }
        if p.1 > hi.1 {
            hi = p;
        }
    }
    let inv: Vec<(f64, f64)> = table.iter().map(|&(t, v)| (t, 1.0 / v)).collect();
    let plot =
        cleave::output::plot_polar(out, &[("Gc(theta)", table.clone()), ("1/Gc(theta)", inv)]);
    if json_out {
        let rows: Vec<_> = table
            .iter()
            .map(|&(t, v)| json!({"theta_deg": t, "gc": v, "inverse": 1.0 / v}))
            .collect();
        println!(
            "{}",
            json!({
                "gamma": g, "gc_bar": gc_bar,
                "gc_min": lo.1, "theta_min_deg": lo.0, "gc_max": hi.1, "theta_max_deg": hi.0,
                "plot": plot.as_ref().ok().map(|_| out), "table": rows,
            })
        );
    } else {
        println!("{:>9} {:>14} {:>14}", "theta_deg", "Gc", "1/Gc");
        for &(t, v) in &table {
            println!("{t:>9.3} {v:>14.6e} {:>14.6e}", 1.0 / v);
        }
        println!(
            "Gc_min = {:.6e} at {:.2} deg, Gc_max = {:.6e} at {:.2} deg",
            lo.1, lo.0, hi.1, hi.0
        );
    }
    match plot {
        Ok(()) => {
            if !json_out {
                eprintln!("polar plot written to {}", out.display());
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}
