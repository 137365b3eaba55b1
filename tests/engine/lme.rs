//! Local maximum-entropy shape functions in runs (issue 34): what a scene
//! may ask of them, and what they buy over the linear hat.

use crate::common;

use common::{refused, shipped};

use cleave::grid::shape::{LME_GAMMA_MAX, LME_GAMMA_MIN};
use cleave::scene::Scene;

/// `shape_function = "lme"` with `lme_gamma`: accepted in range, in 2D
/// and 3D; refused, naming the field and the reason, out of range, without
/// LME, and with the 4th-order phase field (which needs second
/// derivatives the LME kernel does not give).
#[test]
fn lme_scenes_are_validated() {
    let bar = shipped("wave_bar.toml");
    let from = "shape_function = \"quadratic_bspline\"";
    assert!(bar.contains(from));
    let lme = |gamma: &str| bar.replace(from, &format!("shape_function = \"lme\"{gamma}"));
    for ok in [
        "",
        "\nlme_gamma = 4.0",
        "\nlme_gamma = 3.5",
        "\nlme_gamma = 100.0",
    ] {
        let s = Scene::from_text(&lme(ok), None).unwrap_or_else(|e| panic!("{ok}: {e}"));
        assert_eq!(
            s.file.grid.shape_function,
            cleave::scene::ShapeFunctionKind::Lme
        );
    }
    for bad in ["1.8", "3.45", "100.5", "-4.0", "nan", "inf"] {
        refused(
            &lme(&format!("\nlme_gamma = {bad}")),
            &[
                "grid.lme_gamma",
                "four-node support",
                &format!("{LME_GAMMA_MIN:.4}"),
                &format!("{LME_GAMMA_MAX}"),
            ],
        );
    }
    refused(
        &bar.replace(from, &format!("{from}\nlme_gamma = 4.0")),
        &["grid.lme_gamma", "applies to shape_function = \"lme\" only"],
    );
    // 3D
    let block = shipped("notched_bar_3d.toml");
    let from3 = block
        .lines()
        .find(|l| l.starts_with("shape_function"))
        .expect("the 3D scene names its shape function")
        .to_string();
    Scene::from_text(
        &block.replace(&from3, "shape_function = \"lme\"\nlme_gamma = 5.0"),
        None,
    )
    .expect("LME in 3D");
    // the 4th-order phase field
    let p1 = shipped("p1_plate_coarse.toml");
    let fourth = p1
        .replace(from, "shape_function = \"lme\"")
        .replace("k_f = 0.0 }", "k_f = 0.0, gamma = [1.0, 1.0, 0.0, 74.0] }");
    assert!(fourth.contains("shape_function = \"lme\"") && fourth.contains("74.0"));
    refused(
        &fourth,
        &[
            "grid.shape_function",
            "needs second derivatives",
            "not \"lme\"",
        ],
    );
    // the 2nd-order phase field takes LME
    Scene::from_text(&p1.replace(from, "shape_function = \"lme\""), None)
        .expect("2nd-order phase field with LME");
}

/// Kinetic + strain energy at every step of `text`'s run, or the error.
fn energy_history(text: &str) -> Result<Vec<f64>, String> {
    use cleave::diagnostics::Recorder;
    let scene = Scene::from_text(text, None).map_err(|e| e.to_string())?;
    let mut sim = cleave::mpm::Simulation::new(&scene);
    let mut rec = Recorder::default();
    sim.run(&mut rec).map_err(|e| e.to_string())?;
    Ok(rec
        .rows
        .iter()
        .map(|r| r.kinetic_energy + r.strain_energy)
        .collect())
}

/// The part of an energy history faster than 11 rows (its difference from
/// the running mean over 11 rows), root mean square, over the first
/// value: the cell-crossing noise.
fn noise(e: &[f64]) -> f64 {
    let w = 5;
    let dev: Vec<f64> = (w..e.len() - w)
        .map(|i| e[i] - e[i - w..=i + w].iter().sum::<f64>() / (2 * w + 1) as f64)
        .collect();
    (dev.iter().map(|d| d * d).sum::<f64>() / dev.len() as f64).sqrt() / e[0]
}

/// The cell-crossing noise of the linear hat, and what LME does to it
/// (Molinos et al.'s point, on a bar rather than their panel): the ringing
/// bar of `scenes/lme_ringing_bar.toml` (MUSL, FLIP; a row every step,
/// 250 steps, one period) keeps its energy to 2 % with LME at γ = 3.5 and
/// its fast part is 5× smaller than the hat's (measured 3.1e-3 against
/// 1.66e-2; quadratic B-splines 2.2e-4). Under USL the hat does not finish
/// the period: the energy guard stops it (FLIP's ringing at the free
/// faces), where LME does.
#[test]
fn lme_quiets_the_cell_crossing_noise_of_the_linear_hat() {
    let bar = shipped("lme_ringing_bar.toml");
    let lme = energy_history(&bar).expect("the LME bar runs");
    let hat_text = bar.replace(
        "shape_function = \"lme\"\nlme_gamma = 3.5",
        "shape_function = \"linear\"",
    );
    assert!(hat_text.contains("\"linear\""));
    let hat = energy_history(&hat_text).expect("the linear bar runs under MUSL");
    assert_eq!(lme.len(), 251);
    assert_eq!(hat.len(), 251);
    let drift = lme
        .iter()
        .map(|e| (e / lme[0] - 1.0).abs())
        .fold(0.0, f64::max);
    assert!(drift < 0.07, "LME energy strays {:.2} %", 100.0 * drift);
    let (n_lme, n_hat) = (noise(&lme), noise(&hat));
    assert!(
        n_lme < n_hat / 4.0,
        "noise LME {n_lme:.3e}, linear {n_hat:.3e}"
    );
    // under USL
    let usl = |t: &str| t.replace("stress_update = \"musl\"", "stress_update = \"usl\"");
    let e = energy_history(&usl(&hat_text)).expect_err("the linear bar under USL");
    assert!(e.contains("runaway energy"), "{e}");
    let lme_usl = energy_history(&usl(&bar)).expect("the LME bar runs under USL");
    let drift = lme_usl
        .iter()
        .map(|e| (e / lme_usl[0] - 1.0).abs())
        .fold(0.0, f64::max);
    assert!(drift < 0.1, "LME under USL strays {:.2} %", 100.0 * drift);
}
