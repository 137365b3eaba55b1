//! Explicit central differences for the damage particle method (Wei &
//! Chen, eq. 40 and section 4: "the explicit central difference method is
//! adopted for time integration"): M d̈ = f_ext − f_int with the lumped
//! mass m_I = ρ V_I of each particle's smoothing cell, the internal force
//! of eq. 39 from the SCNI tables ([`Scni`]), and essential conditions on
//! particles that carry a singular kernel (their coefficient is their
//! displacement, [`super::rk::shape_values`]).
//!
//! The step is the velocity-Verlet form of central differences
//! (Belytschko, Liu & Moran, Nonlinear Finite Elements, box 6.1):
//! v ← v + Δt/2 a; prescribed components set; d ← d + Δt v; strain, stress
//! and force at the new d; a = (f_ext − f_int)/m + g; v ← v + Δt/2 a;
//! prescribed components set again. Stable for Δt below the highest
//! frequency's 2/ω_max; the caller picks Δt from the wave speed and the
//! spacing.

use super::damage::{ahead, chord_2d, damage, mazars, regularised_kappa_c, section_3d};
use super::scni::Scni;
use crate::material::{Elastic, PlaneKind};
use crate::tensor::{check_voigt, contract, resize, sym_eigen3};
use rayon::prelude::*;

/// Particles a task of the damage stage takes (fewer, and the fork costs
/// more than the work).
const PARTICLES_PER_TASK: usize = 1024;

/// A material's damage (Wei & Chen, eqs. 2–6 and 33).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DamageParams {
    /// Fracture energy G_F, J/m².
    pub g_f: f64,
    /// Tensile strength f_t, Pa (κ₀ = f_t/E).
    pub f_t: f64,
    /// κ_c by eq. 33 from each damaged cell (true: the method), or the
    /// constant `kappa_c` (false: the paper's unregularised contrast).
    pub regularised: bool,
    pub kappa_c: f64,
    /// Criterion (27)'s tolerance.
    pub tol: f64,
    /// The damage at which a particle's neighbours become candidates (0:
    /// when its damage starts, the paper's; `track_at`).
    pub track_at: f64,
}

/// The damage state of each particle.
#[derive(Debug, Clone)]
pub struct DamageState<const D: usize> {
    /// κ₀ of each particle (f_t/E, lowered on a weak plane).
    pub kappa_0: Vec<f64>,
    /// The history κ (eqs. 3–5), zero until the particle is damaged.
    pub kappa: Vec<f64>,
    /// κ_c, fixed when damage starts (zero before).
    pub kappa_c: Vec<f64>,
    /// The crack segment's normal, fixed when damage starts (the largest
    /// principal stress's direction).
    pub normal: Vec<[f64; D]>,
    pub damage: Vec<f64>,
    /// Whether a particle may start to damage (criterion 27).
    pub candidate: Vec<bool>,
    /// Particles whose damage started (or reached the material's
    /// `track_at`) in the last step: criterion 27 looks about them.
    started: Vec<bool>,
    /// Criterion 27's neighbourhoods when not the shape functions'
    /// (`tracking_radius`): `list[start[l]..start[l + 1]]` are l's.
    pub tracking: Option<(Vec<u32>, Vec<u32>)>,
    /// The neighbourhoods whose stress a starting segment's normal comes
    /// from (`normal_radius`; None: the particle's own), as `tracking`.
    pub averaging: Option<(Vec<u32>, Vec<u32>)>,
    /// Reference positions and cells (A_L and V_L of eq. 33).
    x: Vec<[f64; D]>,
    lo: Vec<[f64; D]>,
    hi: Vec<[f64; D]>,
    /// Scratch of [`Explicit::degrade`]: each particle's dissipation in
    /// the step, J (0 between calls), and whether a chunk of
    /// [`PARTICLES_PER_TASK`] particles has any.
    dissipated: Vec<f64>,
    live: Vec<bool>,
}

impl<const D: usize> DamageState<D> {
    /// Forgets which particles started to damage (a static step's trial
    /// that is not kept).
    pub(super) fn clear_started(&mut self) {
        self.started.iter_mut().for_each(|s| *s = false);
    }

    /// Undamaged particles at `x` with cells `lo..hi`, every one a
    /// candidate where `candidate` says.
    pub fn new(
        x: Vec<[f64; D]>,
        lo: Vec<[f64; D]>,
        hi: Vec<[f64; D]>,
        kappa_0: Vec<f64>,
        candidate: Vec<bool>,
    ) -> Self {
        let n = x.len();
        DamageState {
            kappa_0,
            kappa: vec![0.0; n],
            kappa_c: vec![0.0; n],
            normal: vec![[0.0; D]; n],
            damage: vec![0.0; n],
            candidate,
            started: vec![false; n],
            tracking: None,
            averaging: None,
            x,
            lo,
            hi,
            dissipated: vec![0.0; n],
            live: Vec::new(),
        }
    }
}

/// A velocity component held fixed: particle, axis, velocity (m/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Held {
    pub particle: u32,
    pub axis: u8,
    pub velocity: f64,
}

/// The state of an explicit run of the damage particle method.
#[derive(Debug, Clone)]
pub struct Explicit<const D: usize, const V: usize> {
    pub scni: Scni<D>,
    /// Lumped mass of each particle, kg (eq. 40: ρ V_I).
    pub mass: Vec<f64>,
    /// Each smoothing cell's volume, m³ (2D: area × thickness).
    pub vol: Vec<f64>,
    /// Each particle's material.
    pub material: Vec<u16>,
    pub materials: Vec<Elastic>,
    /// The coefficients d_I (eq. 17), their rates and accelerations.
    pub d: Vec<[f64; D]>,
    pub v: Vec<[f64; D]>,
    pub a: Vec<[f64; D]>,
    /// Smoothed strain and stress of each cell (Voigt, tensor shear).
    pub strain: Vec<[f64; V]>,
    pub stress: Vec<[f64; V]>,
    /// Internal force of the last step (eq. 39).
    pub force: Vec<[f64; D]>,
    /// External force on each particle, N (tractions).
    pub external: Vec<[f64; D]>,
    pub body_force: [f64; D],
    pub held: Vec<Held>,
    /// Each material's damage (None: elastic) and the particles' state
    /// (None when no material has damage).
    pub damage_params: Vec<Option<DamageParams>>,
    pub damage: Option<DamageState<D>>,
}

impl<const D: usize, const V: usize> Explicit<D, V> {
    /// A body at rest in its reference configuration.
    pub fn new(scni: Scni<D>, vol: Vec<f64>, material: Vec<u16>, materials: Vec<Elastic>) -> Self {
        check_voigt::<D, V>();
        let n = vol.len();
        let mass = vol
            .iter()
            .zip(&material)
            .map(|(v, &m)| materials[m as usize].density * v)
            .collect();
        Explicit {
            scni,
            mass,
            vol,
            material,
            materials,
            d: vec![[0.0; D]; n],
            v: vec![[0.0; D]; n],
            a: vec![[0.0; D]; n],
            strain: vec![[0.0; V]; n],
            stress: vec![[0.0; V]; n],
            force: vec![[0.0; D]; n],
            external: vec![[0.0; D]; n],
            body_force: [0.0; D],
            held: Vec::new(),
            damage_params: Vec::new(),
            damage: None,
        }
    }

    /// Strain, stress, internal force and acceleration at the present d
    /// (once before the first step, and inside every step).
    pub fn accelerations(&mut self) {
        self.stresses();
        if self.damage.is_some() {
            self.degrade();
        }
        self.forces();
    }

    /// The smoothed strain of every cell (eq. 37) and the elastic stress
    /// C ε (eq. 35 before damage).
    pub fn stresses(&mut self) {
        self.scni.strain(&self.d, &mut self.strain);
        let (mats, material) = (&self.materials, &self.material);
        self.stress
            .par_iter_mut()
            .zip(&self.strain)
            .zip(material)
            .for_each(|((s, e), &m)| *s = hooke::<D, V>(&mats[m as usize], *e));
    }

    /// The internal force of the stress (eq. 39) and the acceleration
    /// (f_ext − f_int)/m + g.
    pub fn forces(&mut self) {
        self.scni
            .internal_force(&self.stress, &self.vol, &mut self.force);
        let g = self.body_force;
        self.a
            .par_iter_mut()
            .zip(&self.force)
            .zip(&self.external)
            .zip(&self.mass)
            .for_each(|(((a, f), e), &m)| {
                for k in 0..D {
                    a[k] = (e[k] - f[k]) / m + g[k];
                }
            });
    }

    /// The highest angular frequency of the undamaged system with its
    /// held components, ω = √λ_max of M⁻¹K (K = Σ_L V_L B̃_Lᵀ C B̃_L, the
    /// stiffness of eq. 39), estimated by `iterations` of the power method
    /// from a fixed pseudo-random start; the Rayleigh quotient it returns
    /// approaches ω_max from below. Central differences are stable for
    /// Δt < 2/ω_max (Belytschko, Liu & Moran, section 6.3).
    pub fn highest_frequency(&self, iterations: usize) -> f64 {
        let n = self.d.len();
        let mut v: Vec<[f64; D]> = (0..n)
            .map(|i| {
                std::array::from_fn(|k| {
                    let s = super::mix(((i * D + k) as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
                    s as f64 / u64::MAX as f64 - 0.5
                })
            })
            .collect();
        let mut e = vec![[0.0; V]; n];
        let mut s = vec![[0.0; V]; n];
        let mut f = vec![[0.0; D]; n];
        let mut lambda = 0.0;
        for _ in 0..iterations {
            for c in &self.held {
                v[c.particle as usize][c.axis as usize] = 0.0;
            }
            let norm: f64 = v
                .iter()
                .zip(&self.mass)
                .map(|(x, &m)| m * x.iter().map(|c| c * c).sum::<f64>())
                .sum::<f64>()
                .sqrt();
            if norm == 0.0 {
                return 0.0;
            }
            v.iter_mut().flatten().for_each(|c| *c /= norm);
            self.scni.strain(&v, &mut e);
            for ((s, e), &m) in s.iter_mut().zip(&e).zip(&self.material) {
                *s = hooke::<D, V>(&self.materials[m as usize], *e);
            }
            self.scni.internal_force(&s, &self.vol, &mut f);
            lambda = v
                .iter()
                .zip(&f)
                .map(|(x, y)| x.iter().zip(y).map(|(a, b)| a * b).sum::<f64>())
                .sum();
            for ((x, y), &m) in v.iter_mut().zip(&f).zip(&self.mass) {
                for k in 0..D {
                    x[k] = y[k] / m;
                }
            }
        }
        lambda.max(0.0).sqrt()
    }

    /// The damage stage of a step: damage and the degraded stress
    /// ([`Explicit::degrade`]), then the candidates its new segments make
    /// (criterion 27). Returns the energy dissipated, J.
    pub fn damage_step(&mut self) -> f64 {
        if self.damage.is_none() {
            return 0.0;
        }
        let dissipated = self.degrade();
        self.track_candidates();
        dissipated
    }

    /// Criterion (27) for the particles whose damage started in the last
    /// [`Explicit::degrade`], with each material's tolerance.
    pub fn track_candidates(&mut self) {
        // the parameters lent out while the state changes (no copy)
        let params = std::mem::take(&mut self.damage_params);
        self.track(|m| params[m as usize].map_or(0.0, |p| p.tol));
        self.damage_params = params;
    }

    /// Damage from the smoothed strain (eqs. 2–6, 33) and the stress it
    /// leaves (eq. 35): a candidate starts to damage when its equivalent
    /// strain reaches κ₀, with its segment's normal along the largest
    /// principal stress and κ_c from its cell's section (or constant);
    /// then σ = (1 − D) C ε. Returns the energy the step's damage
    /// dissipated, Σ ½ ε:C:ε ΔD V (J): with D = 1 − (κ₀/κ)(κ_c − κ)/(κ_c − κ₀)
    /// this sums to ½ f_t κ_c V, the cell's G_F A_L under eq. 33.
    ///
    /// Particle by particle in parallel (each writes only its own state;
    /// the normals read the others' stress and damage of the last step,
    /// which this stage changes only after all normals are found); each
    /// particle's share of the dissipation is summed afterwards in
    /// particle order, so the result is the same for any thread count.
    pub(super) fn degrade(&mut self) -> f64 {
        let Some(st) = self.damage.as_mut() else {
            return 0.0;
        };
        let params = &self.damage_params;
        let (cell, material, materials) = (&self.scni.cell, &self.material, &self.materials);
        let (strain, vol) = (&self.strain, &self.vol);
        let DamageState {
            kappa_0,
            kappa,
            kappa_c,
            normal,
            damage: dmg,
            candidate,
            started,
            averaging,
            x,
            lo,
            hi,
            dissipated,
            live,
            ..
        } = st;
        if let Some((start, list)) = averaging {
            // the normals of the segments that start in this step, from the
            // stress about each at the last step's damage (before any of
            // this step's: the same for any order)
            let (stress, dmg) = (&self.stress, &*dmg);
            normal
                .par_iter_mut()
                .enumerate()
                .with_min_len(PARTICLES_PER_TASK)
                .for_each(|(l, normal)| {
                    let m = material[l] as usize;
                    if params[m].is_none()
                        || kappa_c[l] != 0.0
                        || !candidate[l]
                        || equivalent_strain::<D, V>(&materials[m], &strain[l]) < kappa_0[l]
                    {
                        return;
                    }
                    let mut sum = [0.0; V];
                    let around = &list[start[l] as usize..start[l + 1] as usize];
                    for i in std::iter::once(l).chain(around.iter().map(|&i| i as usize)) {
                        let w = vol[i] * (1.0 - dmg[i]);
                        for (a, s) in sum.iter_mut().zip(&stress[i]) {
                            *a += w * s;
                        }
                    }
                    *normal = principal_direction::<D, V>(&sum);
                });
        }
        let averaged = averaging.is_some();
        let per = PARTICLES_PER_TASK;
        live.resize(kappa_c.len().div_ceil(per), false);
        (
            kappa_c.par_chunks_mut(per),
            normal.par_chunks_mut(per),
            started.par_chunks_mut(per),
            kappa.par_chunks_mut(per),
            dmg.par_chunks_mut(per),
            self.stress.par_chunks_mut(per),
            dissipated.par_chunks_mut(per),
            live.par_iter_mut(),
        )
            .into_par_iter()
            .enumerate()
            .for_each(
                |(c, (kc, n, started, kappa, dmg, stress, dissipated, live))| {
                    for j in 0..kc.len() {
                        let l = c * per + j;
                        let Some(p) = params[material[l] as usize] else {
                            continue;
                        };
                        let m = &materials[material[l] as usize];
                        let eq = equivalent_strain::<D, V>(m, &strain[l]);
                        if kc[j] == 0.0 {
                            if !candidate[l] || eq < kappa_0[l] {
                                continue;
                            }
                            if !averaged {
                                n[j] = principal_direction::<D, V>(&stress[j]);
                            }
                            let k = if p.regularised {
                                let (x, n, lo, hi) = (x[l], n[j], lo[l], hi[l]);
                                let area = if D == 2 {
                                    chord_2d(resize(x), resize(n), resize(lo), resize(hi))
                                } else {
                                    section_3d(resize(x), resize(n), resize(lo), resize(hi))
                                };
                                regularised_kappa_c(p.g_f, p.f_t, area, cell[l])
                            } else {
                                p.kappa_c
                            };
                            // a cell too large for its fracture energy would
                            // snap back (κ_c ≤ κ₀): it breaks at once instead
                            kc[j] = k.max(kappa_0[l] * (1.0 + 1e-9));
                            started[j] = p.track_at == 0.0;
                        }
                        kappa[j] = kappa[j].max(eq);
                        let before = dmg[j];
                        dmg[j] = before.max(damage(kappa[j], kappa_0[l], kc[j]));
                        if p.track_at > 0.0 && before < p.track_at && dmg[j] >= p.track_at {
                            started[j] = true;
                        }
                        dissipated[j] = 0.5
                            * contract::<D, V>(&stress[j], &strain[l])
                            * (dmg[j] - before)
                            * vol[l];
                        *live = true;
                        let keep = 1.0 - dmg[j];
                        for c in stress[j].iter_mut() {
                            *c *= keep;
                        }
                    }
                },
            );
        // in particle order, over the chunks where a particle damaged (the
        // others' entries are 0, which would leave the sum's bits as they
        // are), leaving every entry 0 again
        let mut sum = 0.0;
        for (chunk, live) in dissipated.chunks_mut(per).zip(live.iter_mut()) {
            if std::mem::take(live) {
                for d in chunk {
                    sum += std::mem::take(d);
                }
            }
        }
        sum
    }

    /// Criterion (27) after a step: the neighbours of each particle whose
    /// damage started in it (those its shape functions cover, the cells
    /// about it, or those of `tracking`) that lie along its segment
    /// become candidates.
    fn track(&mut self, tol_of: impl Fn(u16) -> f64) {
        let Some(st) = self.damage.as_mut() else {
            return;
        };
        for l in 0..st.started.len() {
            if !std::mem::take(&mut st.started[l]) {
                continue;
            }
            let tol = tol_of(self.material[l]);
            let nodes = match &st.tracking {
                Some((start, list)) => &list[start[l] as usize..start[l + 1] as usize],
                None => self.scni.values(l).0,
            };
            for &i in nodes {
                let i = i as usize;
                if ahead(st.x[l], st.normal[l], st.x[i], tol) {
                    st.candidate[i] = true;
                }
            }
        }
    }

    /// One step of Δt = `dt`: [`Explicit::advance`], [`Explicit::stresses`],
    /// [`Explicit::damage_step`] (with damage), [`Explicit::finish`].
    pub fn step(&mut self, dt: f64) {
        self.advance(dt);
        self.stresses();
        self.damage_step();
        self.finish(dt);
    }

    /// The step's first half: v ← v + Δt/2 a, the held components, then
    /// d ← d + Δt v.
    pub fn advance(&mut self, dt: f64) {
        self.kick(0.5 * dt);
        self.d.par_iter_mut().zip(&self.v).for_each(|(d, v)| {
            for k in 0..D {
                d[k] += dt * v[k];
            }
        });
    }

    /// The step's second half: the forces and accelerations at the new d,
    /// v ← v + Δt/2 a, the held components.
    pub fn finish(&mut self, dt: f64) {
        self.forces();
        self.kick(0.5 * dt);
    }

    /// v ← v + h a, then the held components.
    pub fn kick(&mut self, h: f64) {
        self.v.par_iter_mut().zip(&self.a).for_each(|(v, a)| {
            for k in 0..D {
                v[k] += h * a[k];
            }
        });
        for c in &self.held {
            self.v[c.particle as usize][c.axis as usize] = c.velocity;
        }
    }

    /// Kinetic energy ½ Σ m |ḋ|², J (the lumped mass's).
    pub fn kinetic_energy(&self) -> f64 {
        self.v
            .iter()
            .zip(&self.mass)
            .map(|(v, m)| 0.5 * m * v.iter().map(|c| c * c).sum::<f64>())
            .sum()
    }

    /// Strain energy ½ Σ_L σ_L : ε_L V_L, J (eq. 34's nodal integration).
    pub fn strain_energy(&self) -> f64 {
        self.stress
            .iter()
            .zip(&self.strain)
            .zip(&self.vol)
            .map(|((s, e), v)| 0.5 * contract::<D, V>(s, e) * v)
            .sum()
    }
}

/// The unit direction of the largest principal value of a symmetric
/// tensor (Voigt).
fn principal_direction<const D: usize, const V: usize>(s: &[f64; V]) -> [f64; D] {
    if D == 2 {
        let th = 0.5 * (2.0 * s[2]).atan2(s[0] - s[1]);
        resize([th.cos(), th.sin()])
    } else {
        let (_, vectors) = sym_eigen3(resize(*s));
        resize(vectors[0])
    }
}

/// The Mazars equivalent strain (eq. 6) of a cell's strain `e`: plane
/// stress stretches or squeezes the thickness, ε_zz = −ν/(1 − ν)(ε_xx +
/// ε_yy); plane strain and 3D have none.
#[inline]
pub(super) fn equivalent_strain<const D: usize, const V: usize>(m: &Elastic, e: &[f64; V]) -> f64 {
    let e_zz = if D == 2 && m.plane == PlaneKind::PlaneStress {
        -m.poissons_ratio / (1.0 - m.poissons_ratio) * (e[0] + e[1])
    } else {
        0.0
    };
    mazars(e, e_zz)
}

/// Hooke's law of `m` for a small strain in D dimensions.
#[inline]
pub(super) fn hooke<const D: usize, const V: usize>(m: &Elastic, e: [f64; V]) -> [f64; V] {
    if D == 2 {
        resize(m.hooke(resize(e)))
    } else {
        resize(m.hooke_3d(resize(e)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dpm::section::{box_lattice, BoxLattice};
    use crate::material::ElasticConstants;

    /// Particles on the vertices of an `nx × ny` lattice of spacing `s`
    /// from the origin, each with its cell clipped to [0, size]: positions,
    /// cells' lower and upper corners.
    #[allow(clippy::type_complexity)]
    fn vertex_lattice(nx: usize, ny: usize, s: f64, size: [f64; 2]) -> BoxLattice<2> {
        let l = box_lattice([0.0, 0.0], size, s);
        assert_eq!(l.0.len(), (nx + 1) * (ny + 1));
        l
    }

    /// A column of material in uniaxial strain: nodes on the vertices of
    /// [0, L] × [0, H], rollers on the left (x held) and on the top and
    /// bottom (y held), the right end free; singular kernels on the held
    /// particles.
    fn column(nx: usize, ny: usize, l: f64) -> (Explicit<2, 3>, Vec<[f64; 2]>, f64) {
        let s = l / nx as f64;
        let h = ny as f64 * s;
        let (x, lo, hi) = vertex_lattice(nx, ny, s, [l, h]);
        let n = x.len();
        let singular: Vec<bool> = x
            .iter()
            .map(|p| p[0] == 0.0 || p[1] == 0.0 || p[1] == h)
            .collect();
        let scni = Scni::build(&x, &lo, &hi, &vec![1.5 * s; n], &singular, &vec![0; n]).unwrap();
        let consts = ElasticConstants::linear_elastic(2000.0, 2.0e9, 0.25);
        let c = consts.wave_speed;
        let m = Elastic::new(&consts, PlaneKind::PlaneStrain);
        let vol = scni.cell.clone();
        let mut run = Explicit::<2, 3>::new(scni, vol, vec![0; n], vec![m]);
        for (p, q) in x.iter().enumerate() {
            if q[0] == 0.0 {
                run.held.push(Held {
                    particle: p as u32,
                    axis: 0,
                    velocity: 0.0,
                });
            }
            if q[1] == 0.0 || q[1] == h {
                run.held.push(Held {
                    particle: p as u32,
                    axis: 1,
                    velocity: 0.0,
                });
            }
        }
        (run, x, c)
    }

    #[test]
    fn a_column_rings_at_its_first_mode_and_keeps_its_energy() {
        // u_x = A sin(πx/2L) cos(ωt), ω = πc/2L: half a period later the
        // free end is at −A; the energy stays (central differences are
        // symplectic: it oscillates by O(Δt²) without drift)
        let (nx, l, amp) = (40, 1.0, 1e-4);
        let (mut run, x, c) = column(nx, 4, l);
        let k = std::f64::consts::PI / (2.0 * l);
        for (d, p) in run.d.iter_mut().zip(&x) {
            d[0] = amp * (k * p[0]).sin();
        }
        run.accelerations();
        let e0 = run.kinetic_energy() + run.strain_energy();
        // the analytic strain energy of the mode at rest: ½ (λ+2μ) ∫ (∂u/∂x)² = (λ+2μ) A² k² L H / 4
        let m = run.materials[0];
        let analytic = m.c11 * amp * amp * k * k * l * (4.0 * l / nx as f64) / 4.0;
        assert!(
            (e0 / analytic - 1.0).abs() < 5e-3,
            "energy {e0} vs {analytic}"
        );
        let period = 4.0 * l / c;
        let dt = 0.3 * (l / nx as f64) / c;
        let steps = (0.5 * period / dt).round() as usize;
        let dt = 0.5 * period / steps as f64;
        let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
        for _ in 0..steps {
            run.step(dt);
            let e = run.kinetic_energy() + run.strain_energy();
            lo = lo.min(e);
            hi = hi.max(e);
        }
        let mut u = vec![[0.0; 2]; x.len()];
        run.scni.interpolate(&run.d, &mut u);
        let tip: Vec<f64> = x
            .iter()
            .zip(&u)
            .filter(|(p, _)| p[0] == l)
            .map(|(_, u)| u[0])
            .collect();
        for t in &tip {
            assert!((t / amp + 1.0).abs() < 5e-3, "free end at {} A", t / amp);
        }
        assert!(
            (hi - lo) / e0 < 2e-3,
            "energy between {lo} and {hi} of {e0}"
        );
        // the held components did not move; y stays near zero (the
        // corner cells' outline points lie between held particles, where
        // the second row's functions do not vanish: 1e-4 of A)
        for c in &run.held {
            assert_eq!(run.d[c.particle as usize][c.axis as usize], 0.0);
        }
        let uy = run.d.iter().map(|d| d[1].abs()).fold(0.0, f64::max);
        assert!(uy < 1e-3 * amp, "transverse motion {}", uy / amp);
    }

    #[test]
    fn the_power_method_finds_the_highest_frequency_and_it_bounds_the_step() {
        // a small column, particles moved off their vertices, held on the
        // left, at a support of 1.6 spacings: the power method against the dense
        // eigenvalues of M^-½ K M^-½ over the free components, and central
        // differences stable just below Δt = 2/ω_max, unstable just above
        let (nx, ny, l) = (6, 3, 1.0);
        let s = l / nx as f64;
        let (mut x, lo, hi) = vertex_lattice(nx, ny, s, [l, ny as f64 * s]);
        crate::dpm::section::jitter_lattice(&mut x, [0.0; 2], [l, ny as f64 * s], s, 0.25);
        let n = x.len();
        let singular: Vec<bool> = x.iter().map(|p| p[0] == 0.0).collect();
        let scni = Scni::build(&x, &lo, &hi, &vec![1.6 * s; n], &singular, &vec![0; n]).unwrap();
        let consts = ElasticConstants::linear_elastic(2000.0, 2.0e9, 0.25);
        let m = Elastic::new(&consts, PlaneKind::PlaneStrain);
        let vol = scni.cell.clone();
        let mut run = Explicit::<2, 3>::new(scni, vol, vec![0; n], vec![m]);
        for (p, q) in x.iter().enumerate() {
            if q[0] == 0.0 {
                for axis in 0..2 {
                    run.held.push(Held {
                        particle: p as u32,
                        axis,
                        velocity: 0.0,
                    });
                }
            }
        }
        let free: Vec<(usize, usize)> = (0..n)
            .flat_map(|p| (0..2).map(move |k| (p, k)))
            .filter(|&(p, _)| x[p][0] != 0.0)
            .collect();
        // K's columns: the internal force of each unit coefficient
        let mut k = faer::Mat::<f64>::zeros(free.len(), free.len());
        for (j, &(p, a)) in free.iter().enumerate() {
            run.d = vec![[0.0; 2]; n];
            run.d[p][a] = 1.0;
            run.stresses();
            run.forces();
            for (i, &(q, b)) in free.iter().enumerate() {
                k[(i, j)] = run.force[q][b] / (run.mass[q] * run.mass[p]).sqrt();
            }
        }
        let exact = k
            .self_adjoint_eigenvalues(faer::Side::Lower)
            .unwrap()
            .last()
            .unwrap()
            .sqrt();
        let omega = run.highest_frequency(300);
        assert!(
            omega <= exact * (1.0 + 1e-12) && omega > (1.0 - 1e-6) * exact,
            "power method {omega} against {exact}"
        );
        let grows = |factor: f64| {
            let mut r = run.clone();
            r.d = vec![[0.0; 2]; n];
            r.v = vec![[0.0; 2]; n];
            for (p, d) in r.d.iter_mut().enumerate() {
                if x[p][0] != 0.0 {
                    *d = [1e-6 * ((p % 7) as f64 - 3.0), 1e-6 * ((p % 5) as f64 - 2.0)];
                }
            }
            r.accelerations();
            let e0 = r.kinetic_energy() + r.strain_energy();
            let dt = factor * 2.0 / exact;
            for _ in 0..400 {
                r.step(dt);
            }
            (r.kinetic_energy() + r.strain_energy()) / e0
        };
        let (below, above) = (grows(0.95), grows(1.05));
        assert!(below < 10.0, "energy × {below} at 0.95 × 2/ω");
        assert!(above > 1e6, "energy × {above} at 1.05 × 2/ω");
    }

    /// What the bar of Wei & Chen's section 4.1 gives under slow explicit
    /// loading: peak force, the end displacement where the force is gone,
    /// the work done on it (∫ F du), and how many particles damaged.
    struct BarResult {
        peak: f64,
        u_zero: f64,
        work: f64,
        damaged: usize,
        /// (u, F) every 20 steps.
        curve: Vec<(f64, f64)>,
    }

    /// The bar: L = 100, A = 10, E = 2e6, ν = 0, G_F = 1.885, f_t = 200,
    /// `nodes` particles along it (three rows), κ₀ lowered by 0.1 % in the
    /// cells that touch the middle plane; the left end held, the right end
    /// pulled at a speed that takes 300 wave transits to reach u = 0.022.
    /// Whether the cell a..b touches the middle plane x = 50 (to
    /// round-off: the cells' edges are sums of spacings).
    fn weak_of(a: &[f64; 2], b: &[f64; 2]) -> bool {
        a[0] <= 50.0 + 1e-9 && b[0] >= 50.0 - 1e-9
    }

    /// `one_column`: only the cells right of the plane are weak (and
    /// candidates).
    fn bar(nodes: usize, regularised: bool, one_column: bool) -> BarResult {
        let (l, area, e, f_t, g_f, rho) = (100.0f64, 10.0f64, 2.0e6f64, 200.0f64, 1.885f64, 1.0f64);
        let nx = nodes - 1;
        let s = l / nx as f64;
        let h = 2.0 * s;
        let thick = area / h;
        let (x, lo, hi) = vertex_lattice(nx, 2, s, [l, h]);
        let n = x.len();
        let ends: Vec<bool> = x.iter().map(|p| p[0] == 0.0 || p[0] == l).collect();
        let scni = Scni::build(&x, &lo, &hi, &vec![1.5 * s; n], &ends, &vec![0; n]).unwrap();
        let vol: Vec<f64> = scni.cell.iter().map(|c| c * thick).collect();
        let m = Elastic::new(
            &ElasticConstants::linear_elastic(rho, e, 0.0),
            PlaneKind::PlaneStrain,
        );
        let mut run = Explicit::<2, 3>::new(scni, vol, vec![0; n], vec![m]);
        let k0 = f_t / e;
        let weak: Vec<bool> = lo
            .iter()
            .zip(&hi)
            .zip(&x)
            .map(|((a, b), p)| weak_of(a, b) && !(one_column && p[0] < 50.0))
            .collect();
        let kappa_0 = weak
            .iter()
            .map(|&w| if w { 0.999 * k0 } else { k0 })
            .collect();
        // the weak plane is where the crack is to be: its cells are the
        // first candidates (criterion 27 adds the cells along it)
        run.damage = Some(DamageState::new(
            x.clone(),
            lo.clone(),
            hi.clone(),
            kappa_0,
            weak,
        ));
        // the unregularised contrast: κ_c of the coarsest bar's cell
        let kappa_c = regularised_kappa_c(g_f, f_t, 1.0, 100.0 / 15.0);
        run.damage_params = vec![Some(DamageParams {
            g_f,
            f_t,
            regularised,
            kappa_c,
            tol: 0.3,
            track_at: 0.0,
        })];
        let c = (e / rho).sqrt();
        let speed = 0.022 / (300.0 * l / c);
        let right: Vec<usize> = (0..n).filter(|&p| x[p][0] == l).collect();
        for (p, q) in x.iter().enumerate() {
            if q[0] == 0.0 {
                run.held.push(Held {
                    particle: p as u32,
                    axis: 0,
                    velocity: 0.0,
                });
                run.held.push(Held {
                    particle: p as u32,
                    axis: 1,
                    velocity: 0.0,
                });
            }
            if q[0] == l {
                run.held.push(Held {
                    particle: p as u32,
                    axis: 0,
                    velocity: f64::MIN_POSITIVE,
                });
                run.held.push(Held {
                    particle: p as u32,
                    axis: 1,
                    velocity: 0.0,
                });
            }
        }
        run.accelerations();
        let dt = 0.5 * s / c;
        let steps = ((0.022 / speed + 15.0 * l / c) / dt).ceil() as usize;
        let (mut peak, mut work, mut u_zero) = (0.0f64, 0.0, f64::NAN);
        let (mut u_prev, mut f_prev) = (0.0, 0.0);
        let mut curve = vec![];
        // the speed ramps up over 30 transits, so that the bar does not
        // ring by more than the weak plane's 0.1 %
        let ramp = 30.0 * l / c;
        let mut u = 0.0;
        for k in 1..=steps {
            let v = speed * ((k as f64 - 0.5) * dt / ramp).min(1.0);
            for h in run
                .held
                .iter_mut()
                .filter(|h| h.axis == 0 && h.velocity != 0.0)
            {
                h.velocity = v;
            }
            run.step(dt);
            u += v * dt;
            let f: f64 = right.iter().map(|&p| run.force[p][0]).sum();
            work += 0.5 * (f + f_prev) * (u - u_prev);
            peak = peak.max(f);
            if u_zero.is_nan() && peak > 0.5 * f_t * area && f < 1e-3 * peak {
                u_zero = u;
            }
            (u_prev, f_prev) = (u, f);
            if k % 20 == 0 {
                curve.push((u, f));
            }
        }
        let st = run.damage.as_ref().unwrap();
        let damaged = st.damage.iter().filter(|&&d| d > 0.0).count();
        BarResult {
            peak,
            u_zero,
            work,
            damaged,
            curve,
        }
    }

    #[test]
    fn the_bar_dissipates_its_fracture_energy_at_every_resolution() {
        // Wei & Chen, section 4.1 (their Fig. 8): u_T where the force is
        // gone is 2 G_F A / (f_t A) = 1.885e-2 and the work G_F A = 18.85,
        // whatever the spacing; unregularised, the work falls with it
        let mut unreg = vec![];
        for nodes in [16, 64] {
            let r = bar(nodes, true, false);
            eprintln!(
                "{nodes} nodes: peak {:.2}, u at F = 0 {:.5e}, work {:.4}, {} damaged",
                r.peak, r.u_zero, r.work, r.damaged
            );
            // both cells that touch the plane, in each of the three rows
            assert_eq!(r.damaged, 6);
            assert!((r.peak / 2000.0 - 1.0).abs() < 5e-3, "peak {}", r.peak);
            assert!((r.u_zero / 1.885e-2 - 1.0).abs() < 5e-3, "u {}", r.u_zero);
            assert!((r.work / 18.85 - 1.0).abs() < 5e-3, "work {}", r.work);
            let u = bar(nodes, false, false);
            eprintln!(
                "  unregularised: u at F = 0 {:.5e}, work {:.4}",
                u.u_zero, u.work
            );
            unreg.push(u.work);
        }
        // κ_c of the 16-node cell: the same there, 46 % less at 64 nodes
        assert!(unreg[1] < 0.6 * unreg[0], "{unreg:?}");
    }

    #[test]
    fn a_crack_through_one_column_of_cells_does_not_cut_the_bar() {
        // one-point SCNI on a lattice: cell i's strain takes the
        // coefficients of columns i − 1 and i + 1 (its face values are
        // averages), so the odd and the even columns form two chains and a
        // broken cell cuts one of them; the other carries the load on,
        // elastic, past f_t A (docs/dpm.md)
        let r = bar(16, true, true);
        assert_eq!(r.damaged, 3);
        assert!(r.u_zero.is_nan(), "the force never fell");
        assert!(r.peak > 2000.0 * 1.05, "peak {}", r.peak);
    }

    /// The bar at the paper's four resolutions, regularised and not, with
    /// its force–displacement curves written to `$DPM_BAR_CSV` (default
    /// `target/dpm-bar.csv`): `cargo test --release --lib
    /// dpm::explicit::tests::the_bar_at_four_resolutions -- --ignored
    /// --nocapture`, then `python3 docs/scripts/dpm_bar.py` (docs/dpm.md).
    #[test]
    #[ignore]
    fn the_bar_at_four_resolutions() {
        use std::io::Write;
        let path = std::env::var("DPM_BAR_CSV").unwrap_or_else(|_| "target/dpm-bar.csv".into());
        let mut out = std::fs::File::create(&path).unwrap();
        writeln!(out, "nodes,regularised,u,force").unwrap();
        for nodes in [16, 32, 64, 128] {
            for regularised in [true, false] {
                let r = bar(nodes, regularised, false);
                println!(
                    "{nodes:4} nodes, {}: peak {:.2}, u at F = 0 {:.5e} ({:+.2} %), work {:.4} ({:+.2} %), {} damaged",
                    if regularised { "regularised  " } else { "unregularised" },
                    r.peak,
                    r.u_zero,
                    100.0 * (r.u_zero / 1.885e-2 - 1.0),
                    r.work,
                    100.0 * (r.work / 18.85 - 1.0),
                    r.damaged
                );
                for (u, f) in &r.curve {
                    writeln!(out, "{nodes},{},{u:.6e},{f:.6e}", regularised as u8).unwrap();
                }
            }
        }
        println!("curves in {path}");
    }

    #[test]
    fn plane_stress_counts_the_thickness_stretch() {
        // biaxial compression in plane stress stretches the thickness,
        // ε_zz = −ν/(1 − ν)(ε_xx + ε_yy) = ⅔ ε at ν = ¼: Mazars counts it
        // and damage starts; in plane strain it does not
        for (plane, starts) in [
            (PlaneKind::PlaneStress, true),
            (PlaneKind::PlaneStrain, false),
        ] {
            let s = 1.0;
            let (x, lo, hi) = vertex_lattice(3, 3, s, [3.0 * s; 2]);
            let n = x.len();
            let scni = Scni::build(&x, &lo, &hi, &vec![1.5 * s; n], &[], &vec![0; n]).unwrap();
            let e = 1e9;
            let m = Elastic::new(&ElasticConstants::linear_elastic(1000.0, e, 0.25), plane);
            let vol = scni.cell.clone();
            let mut run = Explicit::<2, 3>::new(scni, vol, vec![0; n], vec![m]);
            let k0 = 1e-4;
            run.damage = Some(DamageState::new(
                x.clone(),
                lo,
                hi,
                vec![k0; n],
                vec![true; n],
            ));
            run.damage_params = vec![Some(DamageParams {
                g_f: 100.0,
                f_t: e * k0,
                regularised: true,
                kappa_c: 0.0,
                tol: 0.3,
                track_at: 0.0,
            })];
            for (d, p) in run.d.iter_mut().zip(&x) {
                *d = [-2e-4 * p[0], -2e-4 * p[1]];
            }
            run.accelerations();
            let st = run.damage.as_ref().unwrap();
            let started = st.kappa_c.iter().filter(|&&k| k > 0.0).count();
            assert_eq!(started == n, starts, "{plane:?}: {started} of {n} started");
            if starts {
                // ε_eq = ⅔ · 2e-4, κ_c = (G_F/f_t)(A/V) of each cell
                assert!(st
                    .kappa
                    .iter()
                    .all(|&k| (k - 2e-4 * 2.0 / 3.0).abs() < 1e-15));
            }
        }
    }
}
