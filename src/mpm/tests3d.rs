//! The explicit core in 3D, driven directly (no scene yet): P2G, the grid
//! update and G2P on `Particles<3, 6>`, against what mechanics says.

use super::{g2p, grid_update, p2g};
use crate::grid::shape::{Kernel, QuadraticBspline};
use crate::grid::{Bins, GridFields, GridGeom, SingleField};
use crate::material::{Elastic, ElasticConstants, MaterialModel, PlaneKind};
use crate::particles::Particles;
use crate::tensor::norm;

/// A ball of radius `r` at `c`, seeded 2 × 2 × 2 per cell, spinning at `omega`
/// (rad/s) about `axis` (unit) and moving at `v0`.
#[allow(clippy::too_many_arguments)]
fn spinning_ball(
    geom: &GridGeom<3>,
    c: [f64; 3],
    r: f64,
    axis: [f64; 3],
    omega: f64,
    v0: [f64; 3],
    model: MaterialModel,
    apic: bool,
) -> Particles<3, 6> {
    let mut parts = Particles::<3, 6>::default();
    let n = 2;
    let sub = geom.h / n as f64;
    let cells = ((2.0 * r) / sub).ceil() as i64 + 2;
    let density = 1000.0;
    for k in -cells..cells {
        for j in -cells..cells {
            for i in -cells..cells {
                let x = [
                    c[0] + (i as f64 + 0.5) * sub,
                    c[1] + (j as f64 + 0.5) * sub,
                    c[2] + (k as f64 + 0.5) * sub,
                ];
                let d = [x[0] - c[0], x[1] - c[1], x[2] - c[2]];
                if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] > r * r {
                    continue;
                }
                // v = v0 + ω a × (x − c)
                let w = [omega * axis[0], omega * axis[1], omega * axis[2]];
                let v = [
                    v0[0] + w[1] * d[2] - w[2] * d[1],
                    v0[1] + w[2] * d[0] - w[0] * d[2],
                    v0[2] + w[0] * d[1] - w[1] * d[0],
                ];
                let vol = sub * sub * sub;
                parts.id.push(parts.id.len() as u32);
                parts.body.push(0);
                parts.material.push(0);
                parts.group.push(0);
                parts.x.push(x);
                parts.v.push(v);
                parts.mass.push(density * vol);
                parts.vol.push(vol);
                parts.vol0.push(vol);
                parts.stress.push([0.0; 6]);
                match model {
                    MaterialModel::LinearElastic => parts.strain.push([0.0; 6]),
                    MaterialModel::NeoHookean => parts.def_grad.push(crate::tensor::identity()),
                }
                if apic {
                    // the affine field of a rigid rotation is its velocity gradient
                    parts
                        .affine
                        .push([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]]);
                }
            }
        }
    }
    parts
}

fn material(model: MaterialModel) -> Elastic {
    let (e, nu, rho) = (1.0e7, 0.3, 1000.0);
    let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
    let mu = e / (2.0 * (1.0 + nu));
    Elastic::new(
        &ElasticConstants {
            model,
            density: rho,
            youngs_modulus: e,
            poissons_ratio: nu,
            lambda,
            mu,
            wave_speed: ((lambda + 2.0 * mu) / rho).sqrt(),
        },
        PlaneKind::PlaneStrain,
    )
}

/// Mass, momentum and angular momentum about the origin (with APIC's
/// affine spin m D (ε : Cᵀ), Jiang et al. 2015).
fn measures(parts: &Particles<3, 6>, apic_d: Option<f64>) -> (f64, [f64; 3], [f64; 3]) {
    let (mut m, mut p, mut l) = (0.0, [0.0; 3], [0.0; 3]);
    for k in 0..parts.len() {
        let (mk, x, v) = (parts.mass[k], parts.x[k], parts.v[k]);
        m += mk;
        for a in 0..3 {
            p[a] += mk * v[a];
        }
        l[0] += mk * (x[1] * v[2] - x[2] * v[1]);
        l[1] += mk * (x[2] * v[0] - x[0] * v[2]);
        l[2] += mk * (x[0] * v[1] - x[1] * v[0]);
        if let Some(d) = apic_d {
            let c = parts.affine[k];
            l[0] += mk * d * (c[2][1] - c[1][2]);
            l[1] += mk * d * (c[0][2] - c[2][0]);
            l[2] += mk * d * (c[1][0] - c[0][1]);
        }
    }
    (m, p, l)
}

/// `steps` explicit steps (USL) of the 3D core with quadratic B-splines.
fn run<const APIC: bool>(
    parts: &mut Particles<3, 6>,
    geom: &GridGeom<3>,
    mat: Elastic,
    steps: usize,
) {
    type K = QuadraticBspline;
    let mats = [mat];
    let mut bins = Bins::new(geom, &parts.x, K::N);
    let mut grid = GridFields::<3>::default();
    let dt = 0.3 * geom.h / mat.wave_speed;
    let mut written: Vec<std::ops::Range<usize>> = Vec::new();
    for _ in 0..steps {
        let nodes = geom.node_count();
        grid.reset(nodes, nodes, false, &written);
        p2g::p2g::<K, SingleField, APIC, false, 3, 6>(geom, parts, &bins, &SingleField, &mut grid);
        let (_, negative) = grid_update::update(&mut grid, &bins.active, nodes, dt, [0.0; 3], 0.0);
        assert!(negative.is_none());
        let stats = g2p::g2p::<K, SingleField, APIC, 3, 6>(
            geom,
            parts,
            &mut bins,
            &SingleField,
            &grid,
            &mats,
            g2p::Transfer {
                flip: 0.99,
                update: g2p::ParticleUpdate::Blend,
            },
            dt,
        );
        assert!(stats.bad.is_none(), "{:?}", stats.bad);
        written.clone_from(&bins.active);
        if stats.moved_tile {
            bins.rebuild(geom, &parts.x, K::N);
        }
    }
}

/// A free spinning ball (APIC, neo-Hookean): mass and linear momentum to
/// round-off, angular momentum within 1 % (issue 32's check; APIC keeps it
/// to round-off), about an axis that is none of the grid's. Nodes of any
/// positive mass take part (`m_min` = 0): the run's guard threshold drops
/// the momentum of nodes below it, about 1e-10 of it here.
#[test]
fn a_spinning_ball_keeps_its_momenta_in_3d() {
    let geom = GridGeom::<3>::new([0.0; 3], 0.01, [24, 24, 24]);
    let n = norm([1.0, 2.0, 3.0]);
    let axis = [1.0 / n, 2.0 / n, 3.0 / n];
    let mut parts = spinning_ball(
        &geom,
        [0.12, 0.12, 0.12],
        0.06,
        axis,
        20.0,
        [0.3, -0.2, 0.1],
        MaterialModel::NeoHookean,
        true,
    );
    let d = QuadraticBspline::APIC_DINV_H2.map(|d| geom.h * geom.h / d);
    let (m0, p0, l0) = measures(&parts, d);
    let start = parts.clone();
    run::<true>(&mut parts, &geom, material(MaterialModel::NeoHookean), 150);
    let (m1, p1, l1) = measures(&parts, d);
    assert_eq!(m0, m1);
    let scale = m0 * 0.4;
    for a in 0..3 {
        assert!(
            (p1[a] - p0[a]).abs() < 1e-12 * scale,
            "momentum {p0:?} → {p1:?}"
        );
    }
    let l0n = norm(l0);
    let dl = norm([l1[0] - l0[0], l1[1] - l0[1], l1[2] - l0[2]]);
    println!(
        "3D spinning ball: |L| {l0n:.6e} → ΔL {dl:.3e} ({:.3} %)",
        100.0 * dl / l0n
    );
    assert!(dl < 0.01 * l0n, "angular momentum {l0:?} → {l1:?}");
    // the centre of mass moved with the momentum: Δx_cm = v₀ t
    let dt = 0.3 * geom.h / material(MaterialModel::NeoHookean).wave_speed;
    let t = 150.0 * dt;
    let cm = |x: &[[f64; 3]]| {
        let mut c = [0.0; 3];
        for (k, x) in x.iter().enumerate() {
            for a in 0..3 {
                c[a] += parts.mass[k] * x[a] / m0;
            }
        }
        c
    };
    let (c0, c1) = (cm(&start.x), cm(&parts.x));
    for (a, v) in [0.3, -0.2, 0.1].into_iter().enumerate() {
        assert!(
            (c1[a] - c0[a] - v * t).abs() < 1e-12,
            "centre of mass {c0:?} → {c1:?}"
        );
    }
}

/// A ball in uniform motion (linear elastic, FLIP) stays unstrained and
/// keeps its velocity exactly.
#[test]
fn a_translating_ball_stays_unstrained_in_3d() {
    let geom = GridGeom::<3>::new([0.0; 3], 0.01, [20, 20, 20]);
    let v0 = [1.5, -0.75, 0.5];
    let mut parts = spinning_ball(
        &geom,
        [0.1, 0.1, 0.1],
        0.05,
        [0.0, 0.0, 1.0],
        0.0,
        v0,
        MaterialModel::LinearElastic,
        false,
    );
    run::<false>(
        &mut parts,
        &geom,
        material(MaterialModel::LinearElastic),
        40,
    );
    for k in 0..parts.len() {
        for a in 0..3 {
            assert!((parts.v[k][a] - v0[a]).abs() < 1e-12, "v {:?}", parts.v[k]);
        }
        assert!(
            parts.stress[k].iter().all(|s| s.abs() < 1e-3),
            "σ {:?}",
            parts.stress[k]
        );
    }
}

/// 1 and 2 threads give the same bits in 3D (the 8-colour scatter).
#[test]
fn three_d_results_do_not_depend_on_the_thread_count() {
    let geom = GridGeom::<3>::new([0.0; 3], 0.01, [24, 24, 24]);
    let go = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut parts = spinning_ball(
                &geom,
                [0.12, 0.12, 0.12],
                0.06,
                [0.0, 0.6, 0.8],
                30.0,
                [0.2, 0.0, 0.0],
                MaterialModel::LinearElastic,
                true,
            );
            run::<true>(
                &mut parts,
                &geom,
                material(MaterialModel::LinearElastic),
                30,
            );
            parts
        })
    };
    let (a, b) = (go(1), go(2));
    assert!(a == b, "1 and 2 threads differ");
}

/// A 3D snapshot: positions (x, y, z), the velocity as a 3-vector, and
/// stress and strain as six components in VTK's order (xx, yy, zz, xy, yz,
/// xz), the strain of a neo-Hookean particle its Green–Lagrange ½(FᵀF − I).
#[test]
fn a_3d_snapshot_has_z_and_its_tensors_in_vtk_order() {
    let mut parts = Particles::<3, 6>::default();
    let f = [[1.1, 0.2, 0.0], [0.0, 1.0, 0.3], [0.1, 0.0, 0.9]];
    for p in 0..2 {
        parts.id.push(p as u32);
        parts.body.push(0);
        parts.material.push(p as u16);
        parts.group.push(0);
        parts.x.push([1.0, 2.0, 3.0 + p as f64]);
        parts.v.push([4.0, 5.0, 6.0]);
        parts.mass.push(1.0);
        parts.vol.push(1.0);
        parts.vol0.push(1.0);
        // xx yy zz yz xz xy
        parts.stress.push([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        // a run with both laws keeps both arrays for every particle
        parts.strain.push([0.1, 0.2, 0.3, 0.4, 0.5, 0.6]);
        parts.def_grad.push(f);
    }
    let mats = [
        material(MaterialModel::LinearElastic),
        material(MaterialModel::NeoHookean),
    ];
    let snap = crate::diagnostics::measure::snapshot(0, 0, 0.0, &parts, &mats, None);
    assert_eq!(snap.dimension, 3);
    assert_eq!(snap.positions, [[1.0, 2.0, 3.0], [1.0, 2.0, 4.0]]);
    let field = |name: &str| {
        let f = snap.fields.iter().find(|f| f.name == name).unwrap();
        match &f.data {
            crate::diagnostics::FieldData::F64(v) => (f.components, v.clone()),
            _ => panic!("{name} is not f64"),
        }
    };
    assert_eq!(field("velocity"), (3, vec![4.0, 5.0, 6.0, 4.0, 5.0, 6.0]));
    let (c, stress) = field("stress");
    assert_eq!(c, 6);
    assert_eq!(stress[..6], [1.0, 2.0, 3.0, 6.0, 4.0, 5.0]);
    let (c, strain) = field("strain");
    assert_eq!(c, 6);
    assert_eq!(strain[..6], [0.1, 0.2, 0.3, 0.6, 0.4, 0.5]);
    // C = FᵀF, E = ½(C − I), in VTK's order
    let cc = |a: usize, b: usize| (0..3).map(|k| f[k][a] * f[k][b]).sum::<f64>();
    let e = [
        0.5 * (cc(0, 0) - 1.0),
        0.5 * (cc(1, 1) - 1.0),
        0.5 * (cc(2, 2) - 1.0),
        0.5 * cc(0, 1),
        0.5 * cc(1, 2),
        0.5 * cc(0, 2),
    ];
    for (a, b) in strain[6..].iter().zip(e) {
        assert!((a - b).abs() < 1e-15, "{a} vs {b}");
    }
}
