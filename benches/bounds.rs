//! Time per instance of each position-error bound (Gholami 2015) on an N = 8 disc
//! instance and an 8-ellipse instance (`upp_exact`, beyond the paper, also on
//! an intersection already checked). Criterion prints absolute times; the
//! ratios to `upp_rbbox` are printed once at the end (median of 200 runs).

use criterion::{Criterion, criterion_group, criterion_main};
use sonarnet::estimators::bounds::{
    Intersection, Region, pocs, upp_bbox, upp_exact, upp_maxdis, upp_minball, upp_rbbox,
};
use sonarnet::model::geometry::Vec2;
use std::hint::black_box;
use std::time::Instant;

fn ring(n: usize, r: f64, phase: f64) -> Vec<Vec2> {
    (0..n)
        .map(|k| {
            let th = phase + k as f64 * std::f64::consts::TAU / n as f64;
            Vec2::new(r * th.cos(), r * th.sin())
        })
        .collect()
}

fn instances() -> Vec<(&'static str, Vec<Region>, Vec2)> {
    let x_true = Vec2::new(7.0, -4.0);
    // Deterministic positive errors (exponential-like spread, one NLOS bias).
    let err = [0.3, 1.1, 0.05, 2.4, 0.7, 6.5, 0.2, 1.6];
    let discs: Vec<Region> = ring(8, 100.0, 0.1)
        .into_iter()
        .zip(err)
        .map(|(a, e)| Region::from_range(a, (x_true - a).norm() + e, 0.0))
        .collect();
    let txs = ring(2, 120.0, 0.5);
    let rxs = ring(4, 90.0, 0.0);
    let mut ells = vec![];
    for (k, (t, r)) in txs
        .iter()
        .flat_map(|t| rxs.iter().map(move |r| (t, r)))
        .enumerate()
    {
        ells.push(Region::from_bistatic(
            *t,
            *r,
            (x_true - t).norm() + (x_true - r).norm() + err[k],
            0.0,
        ));
    }
    let x_d = pocs(&discs, Vec2::zeros(), 10_000, 1e-9).expect("finite").x;
    let x_e = pocs(&ells, Vec2::zeros(), 10_000, 1e-9).expect("finite").x;
    vec![("8 discs", discs, x_d), ("8 ellipses", ells, x_e)]
}

type BoundFn = fn(
    &[Region],
    &Vec2,
) -> Result<
    sonarnet::estimators::bounds::BoundOutcome,
    sonarnet::estimators::bounds::BoundError,
>;

fn bench(c: &mut Criterion) {
    let fns: [(&str, BoundFn); 5] = [
        ("upp_rbbox", upp_rbbox),
        ("upp_bbox", upp_bbox),
        ("upp_minball", upp_minball),
        ("upp_maxdis", upp_maxdis),
        ("upp_exact", upp_exact),
    ];
    let mut summary = vec![];
    for (label, regions, x_hat) in instances() {
        let mut g = c.benchmark_group(label);
        for (name, f) in fns {
            g.bench_function(name, |b| {
                b.iter(|| f(black_box(&regions), black_box(&x_hat)))
            });
        }
        g.bench_function("intersection_check", |b| {
            b.iter(|| Intersection::new(black_box(&regions)))
        });
        let inter = Intersection::new(&regions)
            .expect("solver")
            .expect("nonempty");
        g.bench_function("rbbox_on_checked_intersection", |b| {
            b.iter(|| inter.upp_rbbox(black_box(&x_hat)))
        });
        // The exact bound alone (the emptiness check done once, as in scoring).
        g.bench_function("exact_on_checked_intersection", |b| {
            b.iter(|| inter.upp_exact(black_box(&x_hat)))
        });
        g.finish();
        // Median wall time per call, for the ratio table.
        let med = |f: &dyn Fn()| {
            let mut t: Vec<f64> = (0..200)
                .map(|_| {
                    let s = Instant::now();
                    f();
                    s.elapsed().as_secs_f64()
                })
                .collect();
            t.sort_by(f64::total_cmp);
            t[t.len() / 2]
        };
        let times: Vec<(&str, f64, f64)> = fns
            .iter()
            .map(|(n, f)| {
                let v = f(&regions, &x_hat)
                    .expect("bound")
                    .value()
                    .unwrap_or(f64::NAN);
                (
                    *n,
                    med(&|| {
                        black_box(f(&regions, &x_hat).ok());
                    }),
                    v,
                )
            })
            .collect();
        summary.push((label, times));
    }
    for (label, times) in summary {
        let base = times[0].1;
        eprintln!("\n{label}: median time per instance (ratio to upp_rbbox), bound value");
        for (n, t, v) in times {
            eprintln!(
                "  {n:12} {:9.1} us  x{:6.2}   bound {v:.3}",
                t * 1e6,
                t / base
            );
        }
    }
}

/// The bounds in 3-D on eight balls (the cube corners of Gholami 2015
/// Table 2, scaled to a 100 m cube), at the POCS estimate; then `upp_bbox`
/// and `upp_exact` on eight spheroids (the same receivers, one transmitter).
fn bench_3d(c: &mut Criterion) {
    type P3 = sonarnet::model::geometry::Point<3>;
    let x_true = P3::new(37.0, 61.0, 22.0);
    let err = [0.3, 1.1, 0.05, 2.4, 0.7, 6.5, 0.2, 1.6];
    let balls: Vec<Region<3>> = (0..8)
        .map(|k| {
            let a = P3::new(
                100.0 * f64::from(k & 1),
                100.0 * f64::from((k >> 1) & 1),
                100.0 * f64::from((k >> 2) & 1),
            );
            Region::from_range(a, (x_true - a).norm() + err[k as usize], 0.0)
        })
        .collect();
    let x_hat = pocs(&balls, P3::repeat(50.0), 10_000, 1e-9)
        .expect("finite")
        .x;
    let mut g = c.benchmark_group("8 balls (3-D)");
    g.bench_function("upp_rbbox", |b| {
        b.iter(|| upp_rbbox(black_box(&balls), black_box(&x_hat)))
    });
    g.bench_function("upp_bbox", |b| {
        b.iter(|| upp_bbox(black_box(&balls), black_box(&x_hat)))
    });
    g.bench_function("upp_minball", |b| {
        b.iter(|| upp_minball(black_box(&balls), black_box(&x_hat)))
    });
    g.bench_function("upp_maxdis", |b| {
        b.iter(|| upp_maxdis(black_box(&balls), black_box(&x_hat)))
    });
    g.bench_function("upp_exact", |b| {
        b.iter(|| upp_exact(black_box(&balls), black_box(&x_hat)))
    });
    let inter = Intersection::new(&balls)
        .expect("solver")
        .expect("nonempty");
    g.bench_function("exact_on_checked_intersection", |b| {
        b.iter(|| inter.upp_exact(black_box(&x_hat)))
    });
    g.finish();

    // The same receivers with a transmitter above the cube: eight bistatic
    // ranges, eight spheroids; `upp_exact` is the certified search over
    // directions (a cone program per direction).
    let tx = P3::new(50.0, 50.0, 130.0);
    let spheroids: Vec<Region<3>> = (0..8)
        .map(|k| {
            let a = P3::new(
                100.0 * f64::from(k & 1),
                100.0 * f64::from((k >> 1) & 1),
                100.0 * f64::from((k >> 2) & 1),
            );
            let rho = (x_true - tx).norm() + (x_true - a).norm() + err[k as usize];
            Region::from_bistatic(tx, a, rho, 0.0)
        })
        .collect();
    let x_hat = pocs(&spheroids, P3::repeat(50.0), 10_000, 1e-9)
        .expect("finite")
        .x;
    let mut g = c.benchmark_group("8 spheroids (3-D)");
    g.sample_size(10);
    g.bench_function("upp_bbox", |b| {
        b.iter(|| upp_bbox(black_box(&spheroids), black_box(&x_hat)))
    });
    let inter = Intersection::new(&spheroids)
        .expect("solver")
        .expect("nonempty");
    g.bench_function("exact_on_checked_intersection", |b| {
        b.iter(|| inter.upp_exact(black_box(&x_hat)))
    });
    g.finish();
}

criterion_group!(benches, bench, bench_3d);
criterion_main!(benches);
