//! `cleave gc-polar`: the effective surface energy Gc(θ) of the 4th-order
//! anisotropic phase field (eq. 8 of Kakouris & Triantafyllou) as a table and a polar plot;
//! given a 3D tensor (9 or 21 numbers), Gc of crack planes by their normal
//! and its extremes over the sphere, from the same 1D profile along n.

use cleave::fracture::phase_field::anisotropy::{
    polar, profile_factor, surface_energy_3d, Gamma, Gamma3,
};
use serde_json::json;
use std::path::Path;
use std::process::ExitCode;

fn invalid(msg: String) -> ExitCode {
    eprintln!("error: {msg}");
    ExitCode::from(2)
}

pub fn run(
    gamma: &str,
    gc_bar: f64,
    step: f64,
    normals: &[String],
    json_out: bool,
    out: &Path,
) -> ExitCode {
    let values: Result<Vec<f64>, _> = gamma.split(',').map(|v| v.trim().parse::<f64>()).collect();
    if let Ok(v) = &values {
        if v.len() == 9 || v.len() == 21 {
            return run_3d(v, gc_bar, normals, json_out);
        }
    }
    if !normals.is_empty() {
        return invalid("--normal: give a 3D tensor (9 or 21 numbers in --gamma)".into());
    }
    let g = match values {
        Ok(v) if (v.len() == 4 || v.len() == 6) && v.iter().all(|x| x.is_finite()) => Gamma {
            g1111: v[0],
            g2222: v[1],
            g1122: v[2],
            g1212: v[3],
            g1112: v.get(4).copied().unwrap_or(0.0),
            g2212: v.get(5).copied().unwrap_or(0.0),
        },
        _ => return invalid(format!("--gamma: expected 4 or 6 finite numbers g1111,g2222,g1122,g1212[,g1112,g2212] (2D), or 9 or 21 (3D), got {gamma:?}")),
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

/// The 3D mode: Gc(n) = Ḡc·G(a(n)) for each normal (default: the three
/// axes) and the extremes of a(n) over the sphere with their normals
/// ([`Gamma3::extremes`]). No plot: a polar plot is of one plane's normals.
fn run_3d(v: &[f64], gc_bar: f64, normals: &[String], json_out: bool) -> ExitCode {
    if !v.iter().all(|x| x.is_finite()) {
        return invalid("--gamma: the numbers must be finite".into());
    }
    if !(gc_bar.is_finite() && gc_bar > 0.0) {
        return invalid(format!("--gc-bar: must be > 0, got {gc_bar}"));
    }
    let Some(g) = Gamma3::from_list(v) else {
        return invalid(format!("--gamma: {} numbers", v.len()));
    };
    let ((a_lo, n_lo), (a_hi, n_hi)) = g.extremes();
    if a_lo < 0.0 {
        return invalid(format!(
            "--gamma: the crack-profile coefficient a(n) is negative ({a_lo:.3e} at n = {n_lo:?}) for some direction, so the functional is unbounded below"
        ));
    }
    let mut list = Vec::new();
    let texts: Vec<String> = if normals.is_empty() {
        vec!["1,0,0".into(), "0,1,0".into(), "0,0,1".into()]
    } else {
        normals.to_vec()
    };
    for t in &texts {
        let c: Result<Vec<f64>, _> = t.split(',').map(|x| x.trim().parse::<f64>()).collect();
        let n = match c {
            Ok(c) if c.len() == 3 && c.iter().all(|x| x.is_finite()) => [c[0], c[1], c[2]],
            _ => {
                return invalid(format!(
                    "--normal: expected three numbers nx,ny,nz, got {t:?}"
                ))
            }
        };
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        if !(len > 0.0) {
            return invalid(format!("--normal: {t:?} has no direction"));
        }
        let n = n.map(|x| x / len);
        list.push((n, g.along(n), surface_energy_3d(&g, gc_bar, n)));
    }
    let (gc_lo, gc_hi) = (gc_bar * profile_factor(a_lo), gc_bar * profile_factor(a_hi));
    if json_out {
        let rows: Vec<_> = list
            .iter()
            .map(|(n, a, gc)| json!({"normal": n, "a": a, "gc": gc}))
            .collect();
        println!(
            "{}",
            json!({
                "dimension": 3, "gamma": g.m, "gc_bar": gc_bar,
                "gc_min": gc_lo, "normal_min": n_lo, "gc_max": gc_hi, "normal_max": n_hi,
                "normals": rows,
            })
        );
    } else {
        println!("{:>30} {:>12} {:>14}", "normal", "a(n)", "Gc");
        for (n, a, gc) in &list {
            let n = format!("({:.4}, {:.4}, {:.4})", n[0], n[1], n[2]);
            println!("{n:>30} {a:>12.5} {gc:>14.6e}");
        }
        let f = |n: [f64; 3]| format!("({:.4}, {:.4}, {:.4})", n[0], n[1], n[2]);
        println!(
            "Gc_min = {gc_lo:.6e} at n = {}, Gc_max = {gc_hi:.6e} at n = {} (over the sphere)",
            f(n_lo),
            f(n_hi)
        );
    }
    ExitCode::SUCCESS
}
