//! Local prox cost on the paper's geometry (Mourya 2017 Sec. III-C): N = 6 receivers,
//! 2 transmitters, target near [500, 500], range sigma 5, DOA sigma 0.5, omega 1,
//! gamma 2e-8. Each iteration is ONE prox call; calls cycle through 6 nodes x 16 noisy
//! samples with Douglas-Rachford-like inputs `u` near the lifted target. `gtrs_l0` runs
//! on the same instances with `kappa = 1`.
//!
//! The GTRS prox in 3-D (`gtrs_prox_3d`) runs on the same geometry with
//! transmitters 10 m deep, receivers 100-600 m deep and the target at 300 m: two
//! bistatic rows and the azimuth and elevation rows of a DOA with 0.01 rad noise.
//!
//! The cone step alone (`min_quadratic_on_upper_nappe`, the core of the GTRS prox):
//! the 2-D angle solver and the any-dimension secular solver on the same 2-D
//! instances, and the secular solver on the 3-D instances.

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{Matrix4, Vector3, Vector4};
use sonarnet::estimators::local::LocalProblem;
use sonarnet::estimators::prox::gtrs::min_quadratic_on_upper_nappe;
use sonarnet::estimators::prox::gtrs::{prox_gtrs, prox_relaxed};
use sonarnet::estimators::prox::l0::prox_gtrs_l0;
use sonarnet::estimators::prox::nappe::min_quadratic_on_upper_nappe_n;
use sonarnet::model::geometry::{Mat3, Vec2, Vec3};
use sonarnet::model::measure::{Geometry, NodeMeasurements};
use sonarnet::model::noise::NoiseModel;
use sonarnet::model::rng::{Stream, stream_rng};
use std::hint::black_box;

fn instances() -> Vec<(LocalProblem, Vec3)> {
    let geometry = Geometry::mourya2017();
    let (tx, rx) = (&geometry.transmitters, &geometry.receivers);
    let range_noise = NoiseModel::gaussian(5.0);
    let doa_noise = NoiseModel::gaussian(0.5);
    let u_noise = NoiseModel::gaussian(20.0);
    let mut rng = stream_rng(2017, Stream::Aux, 0);
    let mut out = Vec::new();
    for k in 0..16 {
        let target = Vec2::new(500.0 + 2.5 * k as f64, 500.0 - 1.5 * k as f64);
        for &r in rx {
            let meas = NodeMeasurements {
                elevation: None,
                bistatic: tx
                    .iter()
                    .enumerate()
                    .map(|(m, t)| {
                        let rho = (target - t).norm() + (target - r).norm();
                        (m, rho + range_noise.sample(k, false, &mut rng))
                    })
                    .collect(),
                doa: Some(
                    (target.y - r.y).atan2(target.x - r.x) + doa_noise.sample(k, false, &mut rng),
                ),
                range: None,
            };
            let p = LocalProblem::build(r, tx, 1.0, &meas);
            let u = Vec3::new(
                target.x + u_noise.sample(k, false, &mut rng),
                target.y + u_noise.sample(k, false, &mut rng),
                (target - r).norm() + u_noise.sample(k, false, &mut rng),
            );
            out.push((p, u));
        }
    }
    out
}

/// The cone problem `(A, b)` of the GTRS prox of a 2-D instance, as `prox_gtrs`
/// forms it: `A = H + I/gamma`, `b = (c - H r~) + (u - r~)/gamma`.
fn cone_2d(p: &LocalProblem, u: &Vec3, gamma: f64) -> (Mat3, Vec3) {
    let r = Vec3::new(p.anchor.x, p.anchor.y, 0.0);
    let a = p.h + Mat3::identity() / gamma;
    let b = (p.c - p.h * r) + (u - r) / gamma;
    (a, b)
}

/// 3-D instances (see the module docs), 6 receivers x 16 samples: the local
/// problem with two bistatic rows and the azimuth and elevation rows of its DOA
/// (Mourya 2017 eq. 9 with 3-D vectors), and a Douglas-Rachford-like `u`.
fn instances_3d() -> Vec<(LocalProblem<3, 4>, Vector4<f64>)> {
    let tx = [
        Vector3::new(0.0, 0.0, -10.0),
        Vector3::new(2000.0, 2000.0, -10.0),
    ];
    let geometry = Geometry::mourya2017();
    let depths = [100.0, 200.0, 300.0, 400.0, 500.0, 600.0];
    let noise = NoiseModel::gaussian(5.0);
    let angle_noise = NoiseModel::gaussian(0.01);
    let mut rng = stream_rng(2017, Stream::Aux, 1);
    let mut out = Vec::new();
    for k in 0..16 {
        let target = Vector3::new(500.0 + 2.5 * k as f64, 500.0 - 1.5 * k as f64, -300.0);
        for (r2, depth) in geometry.receivers.iter().zip(depths) {
            let r = Vector3::new(r2.x, r2.y, -depth);
            let v = target - r;
            let meas = NodeMeasurements {
                bistatic: tx
                    .iter()
                    .enumerate()
                    .map(|(m, t)| {
                        let rho = (target - t).norm() + v.norm();
                        (m, rho + noise.sample(k, false, &mut rng))
                    })
                    .collect(),
                doa: Some(v.y.atan2(v.x) + angle_noise.sample(k, false, &mut rng)),
                elevation: Some(v.z.atan2(v.xy().norm()) + angle_noise.sample(k, false, &mut rng)),
                range: None,
            };
            let p = LocalProblem::<3, 4>::build(r, &tx, 1.0, &meas);
            let u = Vector4::new(
                target.x + 4.0 * noise.sample(k, false, &mut rng),
                target.y + 4.0 * noise.sample(k, false, &mut rng),
                target.z + 4.0 * noise.sample(k, false, &mut rng),
                v.norm() + 4.0 * noise.sample(k, false, &mut rng),
            );
            out.push((p, u));
        }
    }
    out
}

/// The cone problem `(A, b)` of the GTRS prox of a 3-D instance, as `prox_gtrs`
/// forms it.
fn cone_3d(p: &LocalProblem<3, 4>, u: &Vector4<f64>, gamma: f64) -> (Matrix4<f64>, Vector4<f64>) {
    let r = Vector4::new(p.anchor.x, p.anchor.y, p.anchor.z, 0.0);
    let a = p.h + Matrix4::identity() / gamma;
    let b = (p.c - p.h * r) + (u - r) / gamma;
    (a, b)
}

fn bench_prox(c: &mut Criterion) {
    let inst = instances();
    let gamma = 2e-8;
    let mut i = 0usize;
    c.bench_function("gtrs_prox", |b| {
        b.iter(|| {
            let (p, u) = &inst[i % inst.len()];
            i = i.wrapping_add(1);
            black_box(prox_gtrs(black_box(p), black_box(u), black_box(gamma)))
        })
    });
    // gtrs_l0 with kappa = 1 on the same 4-row instances: 4 supports enumerated,
    // one GTRS solve each (src/robust_prox.rs).
    let mut i = 0usize;
    c.bench_function("gtrs_l0_prox_kappa1", |b| {
        b.iter(|| {
            let (p, u) = &inst[i % inst.len()];
            i = i.wrapping_add(1);
            black_box(prox_gtrs_l0(
                black_box(p),
                black_box(u),
                black_box(gamma),
                black_box(1),
            ))
        })
    });
    let inst3 = instances_3d();
    let mut i = 0usize;
    c.bench_function("gtrs_prox_3d", |b| {
        b.iter(|| {
            let (p, u) = &inst3[i % inst3.len()];
            i = i.wrapping_add(1);
            black_box(prox_gtrs(black_box(p), black_box(u), black_box(gamma)))
        })
    });
    let mut i = 0usize;
    c.bench_function("relaxed_prox", |b| {
        b.iter(|| {
            let (p, u) = &inst[i % inst.len()];
            i = i.wrapping_add(1);
            black_box(prox_relaxed(black_box(p), black_box(u), black_box(gamma)))
        })
    });
}

fn bench_cone(c: &mut Criterion) {
    let gamma = 2e-8;
    let cones: Vec<(Mat3, Vec3)> = instances()
        .iter()
        .map(|(p, u)| cone_2d(p, u, gamma))
        .collect();
    let mut i = 0usize;
    c.bench_function("cone_2d_angle", |b| {
        b.iter(|| {
            let (a, bv) = &cones[i % cones.len()];
            i = i.wrapping_add(1);
            black_box(min_quadratic_on_upper_nappe(black_box(a), black_box(bv)))
        })
    });
    let mut i = 0usize;
    c.bench_function("cone_2d_secular", |b| {
        b.iter(|| {
            let (a, bv) = &cones[i % cones.len()];
            i = i.wrapping_add(1);
            black_box(min_quadratic_on_upper_nappe_n(black_box(a), black_box(bv)))
        })
    });
    let cones3: Vec<(Matrix4<f64>, Vector4<f64>)> = instances_3d()
        .iter()
        .map(|(p, u)| cone_3d(p, u, gamma))
        .collect();
    let mut i = 0usize;
    c.bench_function("cone_3d_secular", |b| {
        b.iter(|| {
            let (a, bv) = &cones3[i % cones3.len()];
            i = i.wrapping_add(1);
            black_box(min_quadratic_on_upper_nappe_n(black_box(a), black_box(bv)))
        })
    });
}

criterion_group!(benches, bench_prox, bench_cone);
criterion_main!(benches);
