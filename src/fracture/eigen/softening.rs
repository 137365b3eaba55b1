//! The eigensoftening law of one material point: when softening starts,
//! and how much stress the point then carries.
//!
//! **The paper's law and why it is not used as written.** Molinos et al.
//! start softening when the ε-neighbourhood's mean principal stress
//! passes the tensile strength f_t (eq. 15, Algorithm 2), remember the
//! principal strain ε_f at that moment, and set
//! χ = (ε_I − ε_f)·h_ε/w_c (eqs. 19–20) with the stress (1 − χ)σ (eq. 17),
//! σ the elastic stress of the total strain. In uniaxial tension
//! σ = (1 − χ)·E·ε_I; with x = ε_I − ε_f and Δ = w_c/h_ε that is
//! E(ε_f + x)(1 − x/Δ), which *rises* after softening starts whenever
//! Δ > ε_f, to a peak E(Δ + ε_f)²/(4Δ) at x = (Δ − ε_f)/2
//! ([`literal_peak`]). For concrete (E = 30 GPa, f_t = 3 MPa so
//! ε_f = 10⁻⁴, G_F = 100 J/m², linear softening w_c = 2G_F/f_t = 67 µm,
//! h_ε = 30 mm so Δ = 2.2·10⁻³) the peak is 18 MPa, six times f_t, and
//! the energy dissipated is far from G_F.
//!
//! **The law used.** The same χ (the crack opening w = h_ε(ε_I − ε_f)
//! over w_c, never decreasing), but the cohesive traction it stands for
//! is what caps the stress: the point carries (1 − d)σ with d the least
//! damage that keeps the principal stress at or below (1 − χ)·f_t,
//! d = max(d_old, 1 − (1 − χ)f_t/σ_I), never decreasing either. Loading
//! in tension then follows the linear cohesive law σ = f_t(1 − w/w_c),
//! so a band of width h_ε dissipates ∫σ dw = f_t·w_c/2 = G_F per unit
//! area, plus the elastic energy it held at the onset, ½f_t·ε_f·h_ε
//! (4.5 % of G_F for the concrete above: eq. 19 measures the opening by
//! the total strain past the onset); unloading goes back along the secant
//! (1 − d)σ; at χ = 1 the point carries no stress (eroded, its mass
//! kept).

pub use crate::particles::Softening;

/// A material's softening parameters, SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SofteningLaw {
    /// Tensile strength f_t, Pa.
    pub strength: f64,
    /// Critical opening w_c, m (linear softening: 2G_F/f_t).
    pub critical_opening: f64,
    /// Band width h_ε, m.
    pub band_width: f64,
}

impl SofteningLaw {
    /// Linear softening with fracture energy `gf` (J/m²): w_c = 2G_F/f_t.
    pub fn linear(strength: f64, gf: f64, band_width: f64) -> SofteningLaw {
        SofteningLaw {
            strength,
            critical_opening: 2.0 * gf / strength,
            band_width,
        }
    }

    /// Advances `s` to the present step (Algorithm 2 with the capped
    /// stress above): `mean_stress` is the ε-neighbourhood's mean
    /// principal stress σ_ε (eq. 15), `strain` the point's principal
    /// strain ε_I and `stress` the principal stress σ_I of its undamaged
    /// (elastic) stress. Returns the stress scale 1 − d.
    pub fn update(&self, s: &mut Softening, mean_stress: f64, strain: f64, stress: f64) -> f64 {
        match s.onset {
            None => {
                if mean_stress > self.strength {
                    s.onset = Some(strain);
                }
            }
            Some(onset) => {
                let opening = (strain - onset) * self.band_width / self.critical_opening;
                s.chi = s.chi.max(opening).min(1.0);
            }
        }
        if s.chi >= 1.0 {
            s.d = 1.0;
        } else if stress > 0.0 && s.onset.is_some() {
            let cap = (1.0 - s.chi) * self.strength;
            s.d = s.d.max(1.0 - cap / stress).clamp(0.0, 1.0);
        }
        1.0 - s.d
    }
}

/// The uniaxial peak stress of the paper's law taken literally
/// (σ = (1 − χ)Eε_I with eq. 20's χ), E(Δ + ε_f)²/(4Δ) with Δ = w_c/h_ε,
/// for Δ > ε_f; f_t otherwise (the stress then falls at once).
pub fn literal_peak(youngs: f64, law: &SofteningLaw) -> f64 {
    let onset = law.strength / youngs;
    let delta = law.critical_opening / law.band_width;
    if delta > onset {
        youngs * (delta + onset) * (delta + onset) / (4.0 * delta)
    } else {
        law.strength
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Concrete of the module's note: E 30 GPa, f_t 3 MPa, G_F 100 J/m²,
    /// h_ε 30 mm.
    fn concrete() -> (f64, SofteningLaw) {
        (30e9, SofteningLaw::linear(3e6, 100.0, 0.03))
    }

    /// The calculation of the module's note, against a walk along the
    /// literal law's curve.
    #[test]
    fn the_literal_law_peaks_at_six_times_the_strength() {
        let (e, law) = concrete();
        let peak = literal_peak(e, &law);
        assert!((peak / law.strength - 6.0).abs() < 0.2, "{peak}");
        let onset = law.strength / e;
        let delta = law.critical_opening / law.band_width;
        let walked = (0..=100_000)
            .map(|k| {
                let x = delta * k as f64 / 100_000.0;
                e * (onset + x) * (1.0 - x / delta)
            })
            .fold(0.0, f64::max);
        assert!((walked - peak).abs() < 1e-6 * peak, "{walked} vs {peak}");
    }

    /// Uniaxial tension to failure, unloading half-way once: the stress
    /// never exceeds (1 − χ)f_t, χ and d never fall, unloading is secant,
    /// and the band dissipates G_F per unit area (h_ε∫σ dε).
    #[test]
    fn the_capped_law_follows_the_cohesive_line_and_dissipates_gf() {
        let (e, law) = concrete();
        let gf = 100.0;
        let mut s = Softening::default();
        let onset = law.strength / e;
        let end = onset + 1.05 * law.critical_opening / law.band_width;
        let n = 200_000;
        // up to mid-softening, down to zero strain, up to failure
        let mid = onset + 0.5 * law.critical_opening / law.band_width;
        let path: Vec<f64> = (0..=n)
            .map(|k| mid * k as f64 / n as f64)
            .chain((0..=n).map(|k| mid * (1.0 - k as f64 / n as f64)))
            .chain((0..=2 * n).map(|k| end * k as f64 / (2 * n) as f64))
            .collect();
        let (mut work, mut last_eps, mut last_sigma) = (0.0, 0.0, 0.0);
        let (mut chi, mut d) = (0.0, 0.0);
        for &eps in &path {
            let trial = e * eps;
            let scale = law.update(&mut s, trial, eps, trial);
            let sigma = scale * trial;
            assert!(s.chi >= chi && s.d >= d, "χ or d fell at ε = {eps}");
            (chi, d) = (s.chi, s.d);
            assert!(
                // 1 − (1 − c) rounds to c within 1e-16 of 1, not of c
                sigma <= (1.0 - s.chi) * law.strength + 1e-9 * law.strength || s.onset.is_none(),
                "σ {sigma} above (1 − χ)f_t at ε = {eps}"
            );
            work += 0.5 * (sigma + last_sigma) * (eps - last_eps) * law.band_width;
            (last_eps, last_sigma) = (eps, sigma);
        }
        assert_eq!(s.d, 1.0);
        assert_eq!(last_sigma, 0.0);
        // the band's work: G_F, plus the elastic energy of the band up to
        // the onset, which the stress carried before softening (returned
        // at failure, so it also ends as dissipation)
        let elastic = 0.5 * law.strength * onset * law.band_width;
        assert!(
            ((work - elastic) / gf - 1.0).abs() < 5e-3,
            "dissipated {work} J/m², G_F {gf} + elastic {elastic}"
        );
        // the peak of the whole path is f_t, not the literal law's 6 f_t
        assert!(literal_peak(e, &law) > 5.0 * law.strength);
    }

    /// Compression never starts softening, and an eroded point carries
    /// nothing, in compression too.
    #[test]
    fn compression_and_erosion() {
        let (_, law) = concrete();
        let mut s = Softening::default();
        assert_eq!(law.update(&mut s, -1e8, -1e-3, -3e7), 1.0);
        assert_eq!(s, Softening::default());
        s = Softening {
            onset: Some(1e-4),
            chi: 1.0,
            d: 1.0,
        };
        assert_eq!(law.update(&mut s, -1e8, -1e-3, -3e7), 0.0);
    }
}
