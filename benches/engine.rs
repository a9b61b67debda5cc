//! Engine benchmarks on `mourya2017-spiral` (N = 6): one DR iteration (async
//! pair or sync round, measured over one sample of 50 iterations), the same
//! in 3-D (`mourya2017-spiral-3d`), and the whole 100-sample run in-process.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use sonarnet::engine::run_inprocess;
use sonarnet::protocol::{Clock, RunPlan};
use sonarnet::scenario::{AnyScenario, Mode, Scenario};
use std::hint::black_box;
use std::path::Path;

fn spiral(mode: Mode, samples: usize) -> Scenario {
    Scenario::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenarios/mourya2017-spiral.toml"
    )))
    .expect("scenario")
    .with_mode(mode)
    .expect("mode")
    .with_samples(samples)
    .expect("samples")
}

fn iterations(c: &mut Criterion) {
    let mut g = c.benchmark_group("dr_iteration_n6");
    for mode in [Mode::Async, Mode::Sync] {
        let sc = spiral(mode, 11);
        let real = sc.realize();
        let plan = RunPlan::new(&sc, Clock::Logical).expect("plan");
        g.throughput(Throughput::Elements(sc.total_iterations() as u64));
        g.bench_function(mode.as_str(), |b| {
            b.iter(|| black_box(run_inprocess(&plan, real.feed(), &mut |_, _| {})))
        });
    }
    g.finish();
}

fn whole_run(c: &mut Criterion) {
    let mut g = c.benchmark_group("spiral_run_inprocess");
    g.sample_size(20);
    for mode in [Mode::Async, Mode::Sync] {
        let sc = spiral(mode, 100);
        g.bench_function(mode.as_str(), |b| {
            b.iter(|| {
                let real = sc.realize();
                let plan = RunPlan::new(&sc, Clock::Logical).expect("plan");
                black_box(run_inprocess(&plan, real.feed(), &mut |_, _| {}))
            })
        });
    }
    g.finish();
}

/// One DR iteration of the same network in 3-D (`mourya2017-spiral-3d`):
/// the nodes exchange `(x, y, z, d)` and each prox is the 3-D GTRS solve.
fn iterations_3d(c: &mut Criterion) {
    let file = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenarios/mourya2017-spiral-3d.toml"
    ));
    let Some(AnyScenario::Space(base)) = AnyScenario::load_all(file)
        .expect("scenario")
        .into_iter()
        .next()
    else {
        panic!("mourya2017-spiral-3d is 3-D");
    };
    let mut g = c.benchmark_group("dr_iteration_n6_3d");
    for mode in [Mode::Async, Mode::Sync] {
        let sc = base
            .clone()
            .with_mode(mode)
            .expect("mode")
            .with_samples(11)
            .expect("samples");
        let real = sc.realize();
        let plan = RunPlan::new(&sc, Clock::Logical).expect("plan");
        g.throughput(Throughput::Elements(sc.total_iterations() as u64));
        g.bench_function(mode.as_str(), |b| {
            b.iter(|| black_box(run_inprocess(&plan, real.feed(), &mut |_, _| {})))
        });
    }
    g.finish();
}

criterion_group!(benches, iterations, iterations_3d, whole_run);
criterion_main!(benches);
