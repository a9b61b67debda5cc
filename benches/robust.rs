//! Per-solve time of the robust estimators on Shi 2024 Sec. IV-C instances
//! (m = n = 8, target [400, 200], Gaussian variance 100 m^2, exponential NLOS
//! bias with standard deviation 1e3 m on all links of one random transmitter
//! or receiver, p = 15%). Each estimator runs on the same 64 instances; after
//! the criterion groups the mean per-solve time is printed as a ratio to `ls`.

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, criterion_group};
use sonarnet::estimators::robust::{
    BistaticLink, IrlsConfig, L0osConfig, LsConfig, kappa_from_fraction, l0os, lad, lq_irls, ls,
    shi2024_geometry,
};
use sonarnet::model::geometry::Vec2;
use sonarnet::model::measure::{Geometry, bistatic_range};
use sonarnet::model::noise::{NlosLinks, NoiseModel, SigmaSchedule};
use sonarnet::model::rng::{Stream, stream_rng};

const INSTANCES: usize = 64;

fn instances() -> (Geometry, Vec<Vec<BistaticLink>>) {
    let g = shi2024_geometry();
    let target = Vec2::new(400.0, 200.0);
    let noise = NoiseModel::NlosExponential {
        sigma: 10.0,
        nlos_mean: 1e3,
        schedule: SigmaSchedule::Constant,
    };
    let sets = (0..INSTANCES as u64)
        .map(|i| {
            let mut lr = stream_rng(1, Stream::Links, i);
            let mask = NlosLinks::OneRandomTransmitterOrReceiver {}
                .draw(8, 8, &mut lr)
                .expect("8 x 8 network");
            let mut nr = stream_rng(1, Stream::Measurement, i);
            let mut links = Vec::with_capacity(64);
            for (tx, t) in g.transmitters.iter().enumerate() {
                for (rx, r) in g.receivers.iter().enumerate() {
                    let rho = bistatic_range(&target, t, r)
                        + noise.sample(0, mask.is_nlos(tx, rx), &mut nr);
                    links.push(BistaticLink { tx, rx, rho });
                }
            }
            links
        })
        .collect();
    (g, sets)
}

type Solver = Box<dyn Fn(&Geometry, &[BistaticLink]) -> Vec2>;

fn solvers() -> Vec<(&'static str, Solver)> {
    let kappa = kappa_from_fraction(0.15, 64).expect("valid fraction");
    vec![
        (
            "l0os",
            Box::new(move |g, l| l0os(g, l, &L0osConfig::new(kappa)).expect("solve").position),
        ),
        (
            "lq_irls",
            Box::new(|g, l| {
                lq_irls(g, l, &IrlsConfig::default())
                    .expect("solve")
                    .position
            }),
        ),
        (
            "lad",
            Box::new(|g, l| lad(g, l, &IrlsConfig::default()).expect("solve").position),
        ),
        (
            "ls",
            Box::new(|g, l| ls(g, l, &LsConfig::default()).expect("solve").position),
        ),
    ]
}

fn bench_robust(c: &mut Criterion) {
    let (g, sets) = instances();
    let mut group = c.benchmark_group("robust_shi2024_64_instances");
    for (name, solve) in solvers() {
        group.bench_function(name, |b| {
            b.iter(|| {
                for links in &sets {
                    black_box(solve(black_box(&g), black_box(links)));
                }
            })
        });
    }
    group.finish();
}

/// Mean per-solve time of each estimator, and its ratio to `ls`.
fn ratio_summary() {
    let (g, sets) = instances();
    let reps = 50;
    let mut times = Vec::new();
    for (name, solve) in solvers() {
        for links in &sets {
            black_box(solve(&g, links));
        }
        let start = Instant::now();
        for _ in 0..reps {
            for links in &sets {
                black_box(solve(black_box(&g), black_box(links)));
            }
        }
        let per_solve = start.elapsed().as_secs_f64() / (reps * sets.len()) as f64;
        times.push((name, per_solve));
    }
    let ls_time = times
        .iter()
        .find(|(n, _)| *n == "ls")
        .map_or(f64::NAN, |t| t.1);
    println!(
        "\nper-solve time (mean of {} solves), ratio to ls:",
        reps * sets.len()
    );
    for (name, t) in times {
        println!("  {name:8} {:9.2} us   x{:.2}", t * 1e6, t / ls_time);
    }
}

criterion_group!(benches, bench_robust);

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
    ratio_summary();
}
