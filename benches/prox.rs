//! Local prox cost on the paper's geometry (Mourya 2017 Sec. III-C): N = 6 receivers,
//! 2 transmitters, target near [500, 500], range sigma 5, DOA sigma 0.5, omega 1,
//! gamma 2e-8. Each iteration is ONE prox call; calls cycle through 6 nodes x 16 noisy
//! samples with Douglas-Rachford-like inputs `u` near the lifted target. `gtrs_l0` runs
//! on the same instances with `kappa = 1`.

use criterion::{Criterion, criterion_group, criterion_main};
use sonarnet::estimators::local::LocalProblem;
use sonarnet::estimators::prox::gtrs::{prox_gtrs, prox_relaxed};
use sonarnet::estimators::prox::l0::prox_gtrs_l0;
use sonarnet::model::geometry::{Vec2, Vec3};
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
    let mut i = 0usize;
    c.bench_function("relaxed_prox", |b| {
        b.iter(|| {
            let (p, u) = &inst[i % inst.len()];
            i = i.wrapping_add(1);
            black_box(prox_relaxed(black_box(p), black_box(u), black_box(gamma)))
        })
    });
}

criterion_group!(benches, bench_prox);
criterion_main!(benches);
