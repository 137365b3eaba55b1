//! Energies, momenta and snapshot fields computed from the particles.
//!
//! Sums are taken over fixed chunks of particles and the partial sums added
//! in chunk order, so they are bitwise the same for any thread count.

use super::{Field, FieldData, GridSnapshot, Snapshot};
use crate::grid::{GridFields, GridGeom, MultiField};
use crate::material::{Elastic, MaterialModel};
use crate::particles::Particles;
use crate::tensor::{dot, resize, resize_mat};
use rayon::prelude::*;

const CHUNK: usize = 4096;

/// Particle `p`'s strain energy density ψ, J/m³, and the volume it is
/// per: the current volume for the linear model (small strain: V ≈ V₀),
/// the reference volume for neo-Hookean.
pub(crate) fn strain_energy_density<const D: usize, const V: usize>(
    mats: &[Elastic],
    parts: &Particles<D, V>,
    p: usize,
) -> (f64, f64) {
    let mat = &mats[parts.material[p] as usize];
    match (mat.model, D) {
        (MaterialModel::LinearElastic, 2) => (
            Elastic::energy_linear(resize(parts.stress[p]), resize(parts.strain[p])),
            parts.vol[p],
        ),
        (MaterialModel::LinearElastic, _) => (
            Elastic::energy_linear_3d(resize(parts.stress[p]), resize(parts.strain[p])),
            parts.vol[p],
        ),
        (MaterialModel::NeoHookean, 2) => (
            mat.energy_neo_hookean(resize_mat(parts.def_grad[p])),
            parts.vol0[p],
        ),
        (MaterialModel::NeoHookean, _) => (
            mat.energy_neo_hookean_3d(resize_mat(parts.def_grad[p])),
            parts.vol0[p],
        ),
    }
}

/// Integral quantities of the particles.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Measures {
    pub kinetic: f64,
    pub strain: f64,
    pub mass: f64,
    /// Σ m v (z zero in 2D).
    pub momentum: [f64; 3],
    /// Σ m x × v about the origin (x and y zero in 2D: the 2D angular
    /// momentum is `angular[2]`).
    pub angular: [f64; 3],
}

/// Kinetic energy ½Σ m v², strain energy Σ V ψ, mass, linear momentum and
/// angular momentum about the origin, in 2D or 3D. `apic_d`: with APIC and
/// B-splines, the inertia scale D (h²/4 quadratic, h²/3 cubic) for the
/// affine spin term m D (ε : Cᵀ) of Jiang et al. (2015) (in 2D
/// m D (C₂₁ − C₁₂)).
pub fn measure<const D: usize, const V: usize>(
    parts: &Particles<D, V>,
    mats: &[Elastic],
    apic_d: Option<f64>,
) -> Measures {
    crate::tensor::check_voigt::<D, V>();
    let n = parts.len();
    let partial: Vec<Measures> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut m = Measures::default();
            for p in c * CHUNK..((c + 1) * CHUNK).min(n) {
                let (mass, v, x) = (parts.mass[p], parts.v[p], parts.x[p]);
                m.mass += mass;
                m.kinetic += 0.5 * mass * dot(v, v);
                for a in 0..D {
                    m.momentum[a] += mass * v[a];
                }
                if D == 2 {
                    m.angular[2] += mass * (x[0] * v[1] - x[1] * v[0]);
                    if let Some(d) = apic_d {
                        let a = parts.affine[p];
                        m.angular[2] += mass * d * (a[1][0] - a[0][1]);
                    }
                } else {
                    // (x × v)_a = x_b v_c − x_c v_b for (a, b, c) cyclic
                    for a in 0..3 {
                        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
                        m.angular[a] += mass * (x[b] * v[c] - x[c] * v[b]);
                        if let Some(d) = apic_d {
                            let cm = parts.affine[p];
                            m.angular[a] += mass * d * (cm[c][b] - cm[b][c]);
                        }
                    }
                }
                let (psi, v_ref) = strain_energy_density(mats, parts, p);
                m.strain += v_ref * psi;
            }
            m
        })
        .collect();
    let mut total = Measures::default();
    for m in partial {
        total.kinetic += m.kinetic;
        total.strain += m.strain;
        total.mass += m.mass;
        for a in 0..3 {
            total.momentum[a] += m.momentum[a];
            total.angular[a] += m.angular[a];
        }
    }
    total
}

fn f64_field(name: &str, components: usize, data: Vec<f64>) -> Field {
    Field {
        name: name.to_string(),
        components,
        data: FieldData::F64(data),
    }
}

fn u32_field(name: &str, data: Vec<u32>) -> Field {
    Field {
        name: name.to_string(),
        components: 1,
        data: FieldData::U32(data),
    }
}

/// Particle fields at this instant: velocity (`D` components), stress and
/// strain (2D: xx, yy, xy, zz; 3D: the six components in VTK's order, see
/// [`Field::components`]), mass, volume, material_id, body_id,
/// particle_id, and the phase field, history and damage where the run has
/// them. Positions go out as (x, y, z), z = 0 in 2D.
pub fn snapshot<const D: usize, const V: usize>(
    index: u32,
    step: u64,
    time: f64,
    parts: &Particles<D, V>,
    mats: &[Elastic],
    grid: Option<GridSnapshot>,
) -> Snapshot {
    let n = parts.len();
    let tensor = if D == 2 { 4 } else { 6 };
    let mut vel = Vec::with_capacity(D * n);
    let mut stress = Vec::with_capacity(tensor * n);
    let mut strain = Vec::with_capacity(tensor * n);
    for p in 0..n {
        vel.extend_from_slice(&parts.v[p]);
        let mat = &mats[parts.material[p] as usize];
        if D == 2 {
            let (s, small) = (resize::<V, 3>(parts.stress[p]), e_of(parts, p));
            let f = parts.def_grad.get(p).map(|&f| resize_mat::<D, 2>(f));
            let (e, ezz) = match mat.model {
                MaterialModel::LinearElastic => {
                    let e = small.unwrap_or([0.0; 3]);
                    (e, mat.strain_zz(e))
                }
                MaterialModel::NeoHookean => {
                    // Green–Lagrange strain E = ½(FᵀF − I)
                    let [[f11, f12], [f21, f22]] = f.unwrap_or([[1.0, 0.0], [0.0, 1.0]]);
                    let c11 = f11 * f11 + f21 * f21;
                    let c22 = f12 * f12 + f22 * f22;
                    let c12 = f11 * f12 + f21 * f22;
                    ([0.5 * (c11 - 1.0), 0.5 * (c22 - 1.0), 0.5 * c12], 0.0)
                }
            };
            let szz = mat.stress_zz(s, small, f);
            stress.extend_from_slice(&[s[0], s[1], s[2], szz]);
            strain.extend_from_slice(&[e[0], e[1], e[2], ezz]);
        } else {
            let s = resize::<V, 6>(parts.stress[p]);
            let e = match mat.model {
                MaterialModel::LinearElastic => {
                    parts.strain.get(p).map_or([0.0; 6], |&e| resize::<V, 6>(e))
                }
                MaterialModel::NeoHookean => {
                    let f = parts
                        .def_grad
                        .get(p)
                        .map_or(crate::tensor::identity::<3>(), |&f| resize_mat::<D, 3>(f));
                    green_lagrange_3d(f)
                }
            };
            stress.extend_from_slice(&vtk_order(s));
            strain.extend_from_slice(&vtk_order(e));
        }
    }
    Snapshot {
        index,
        step,
        time,
        dimension: D,
        positions: parts.x.iter().map(|&x| resize::<D, 3>(x)).collect(),
        fields: vec![
            f64_field("velocity", D, vel),
            f64_field("stress", tensor, stress),
            f64_field("strain", tensor, strain),
            f64_field("mass", 1, parts.mass.clone()),
            f64_field("volume", 1, parts.vol.clone()),
            u32_field(
                "material_id",
                parts.material.iter().map(|&m| m as u32).collect(),
            ),
            u32_field("body_id", parts.body.iter().map(|&b| b as u32).collect()),
            u32_field("particle_id", parts.id.clone()),
        ]
        .into_iter()
        .chain((!parts.phase.is_empty()).then(|| f64_field("phase_field", 1, parts.phase.clone())))
        .chain((!parts.history.is_empty()).then(|| f64_field("history", 1, parts.history.clone())))
        .chain((!parts.damage.is_empty()).then(|| f64_field("damage", 1, parts.damage.clone())))
        .collect(),
        grid,
        lines: Vec::new(),
    }
}

/// The 2D small strain of particle `p`, if the run keeps one.
fn e_of<const D: usize, const V: usize>(parts: &Particles<D, V>, p: usize) -> Option<[f64; 3]> {
    parts.strain.get(p).map(|&e| resize::<V, 3>(e))
}

/// A 3D symmetric tensor from the engine's Voigt order (xx, yy, zz, yz,
/// xz, xy) into VTK's (xx, yy, zz, xy, yz, xz).
fn vtk_order(a: [f64; 6]) -> [f64; 6] {
    [a[0], a[1], a[2], a[5], a[3], a[4]]
}

/// The Green–Lagrange strain E = ½(FᵀF − I) of a 3D F, in Voigt order.
fn green_lagrange_3d(f: [[f64; 3]; 3]) -> [f64; 6] {
    let c = |a: usize, b: usize| (0..3).map(|k| f[k][a] * f[k][b]).sum::<f64>();
    [
        0.5 * (c(0, 0) - 1.0),
        0.5 * (c(1, 1) - 1.0),
        0.5 * (c(2, 2) - 1.0),
        0.5 * c(1, 2),
        0.5 * c(0, 2),
        0.5 * c(0, 1),
    ]
}

/// Nodal mass and velocity (momentum-weighted over the velocity fields) of
/// the last step, on the whole padded lattice.
pub fn grid_snapshot<const D: usize>(
    geom: &GridGeom<D>,
    grid: &GridFields<D>,
    multi: Option<&MultiField>,
) -> GridSnapshot {
    let nodes = geom.node_count();
    let mut mass = grid.mass[..nodes].to_vec();
    let mut mom: Vec<f64> = (0..nodes)
        .flat_map(|s| grid.vel[s].map(|v| grid.mass[s] * v))
        .collect();
    if let Some(m) = multi {
        for (k, &n) in m.extra_node.iter().enumerate() {
            let (s, n) = (nodes + k, n as usize);
            mass[n] += grid.mass[s];
            for a in 0..D {
                mom[D * n + a] += grid.mass[s] * grid.vel[s][a];
            }
        }
    }
    let vel = (0..nodes)
        .flat_map(|n| {
            let mut v = [0.0; D];
            if mass[n] > 0.0 {
                for a in 0..D {
                    v[a] = mom[D * n + a] / mass[n];
                }
            }
            v
        })
        .collect();
    let mut dims = [1; 3];
    dims[..D].copy_from_slice(&geom.nodes);
    GridSnapshot {
        origin: resize::<D, 3>(geom.origin),
        spacing: geom.h,
        dims,
        fields: vec![f64_field("mass", 1, mass), f64_field("velocity", D, vel)],
    }
}
