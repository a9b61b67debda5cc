//! 3-D scenarios through the library: read, checked and realized in the
//! dimension their receivers give, with the 2-D numbers untouched.

use crate::util::spiral_3d;
use sonarnet::model::measure;
use sonarnet::scenario::{AnyScenario, Scenario};
use std::path::Path;
use std::time::Duration;

fn space(text: &str) -> Scenario<3> {
    let all = AnyScenario::all_from_toml_str(text, Path::new("helix.toml")).expect("valid 3-D");
    match all.into_iter().next() {
        Some(AnyScenario::Space(sc)) => sc,
        other => panic!("expected one 3-D scenario, got {other:?}"),
    }
}

#[test]
fn a_3d_spiral_realizes_a_descending_helix_over_the_2d_spiral_in_plan_view() {
    let sc = space(&spiral_3d());
    assert_eq!(sc.geometry.receivers.len(), 6);
    assert!((sc.geometry.receivers[5][2] + 300.0).abs() < 1e-12);
    let real = sc.realize();
    let truth = real.truth.expect("synthetic");
    let flat = Scenario::load(&crate::util::scenario("mourya2017-spiral.toml"))
        .expect("2-D")
        .realize()
        .truth
        .expect("synthetic");
    for (k, (p, q)) in truth.iter().zip(&flat).enumerate() {
        assert_eq!(p[0].to_bits(), q[0].to_bits(), "sample {k}");
        assert_eq!(p[1].to_bits(), q[1].to_bits(), "sample {k}");
        assert!(
            (p[2] - (-100.0 - k as f64)).abs() < 1e-9,
            "sample {k}: {p:?}"
        );
    }
    // Nominal weights: the elevation has its own sigma.
    assert!((real.sigmas[0].elevation - 0.2).abs() < 1e-15);
    assert!(
        real.measurements[0]
            .nodes
            .iter()
            .all(|n| n.elevation.is_some())
    );
}

#[test]
fn noise_free_3d_measurements_are_the_geometry_of_the_3d_points_exactly() {
    let text = spiral_3d()
        .replace("sigma = 5.0", "sigma = 0.0")
        .replace("sigma = 0.5", "sigma = 0.0")
        .replace("sigma = 0.2", "sigma = 0.0");
    let sc = space(&text);
    let real = sc.realize();
    let truth = real.truth.expect("synthetic");
    let g = &sc.geometry;
    for (k, x) in truth.iter().enumerate().step_by(7) {
        for (n, r) in g.receivers.iter().enumerate() {
            let m = &real.measurements[k].nodes[n];
            for &(t, rho) in &m.bistatic {
                let want = measure::bistatic_range(x, &g.transmitters[t], r);
                assert_eq!(rho.to_bits(), want.to_bits(), "sample {k} node {n}");
                // Against the distances written out by hand.
                let by_hand = (x - g.transmitters[t]).norm() + (x - r).norm();
                assert!((rho - by_hand).abs() <= 1e-9 * by_hand);
            }
            let d = x - r;
            let az = m.doa.expect("doa");
            let el = m.elevation.expect("elevation");
            assert!((az - d[1].atan2(d[0])).abs() < 1e-12);
            assert!((el - d[2].atan2(d.xy().norm())).abs() < 1e-12);
        }
    }
}

#[test]
fn a_2d_scenario_read_as_either_dimension_is_the_same_scenario() {
    let path = crate::util::scenario("mourya2017-spiral.toml");
    let text = std::fs::read_to_string(&path).expect("read");
    let any = AnyScenario::all_from_toml_str(&text, &path).expect("valid");
    let plane = Scenario::from_toml_str(&text, &path).expect("valid");
    assert_eq!(any.len(), 1);
    assert_eq!(any[0].dim(), 2);
    assert!(matches!(&any[0], AnyScenario::Plane(sc) if *sc == plane));
}

/// The bits of every node's `theta` at every sample.
fn bits(rec: &sonarnet::protocol::RunRecord) -> Vec<Vec<Vec<u64>>> {
    rec.thetas
        .iter()
        .map(|s| {
            s.iter()
                .map(|t| t.iter().map(|v| v.to_bits()).collect())
                .collect()
        })
        .collect()
}

/// One implementation of the protocol serves both dimensions: a 3-D run
/// carries `theta~ = (x, y, z, d)` in every message and report, and on
/// logical clocks every engine (in-process, threads, discrete events, node
/// processes over iceoryx2) gives the same numbers bit for bit, in both
/// gossip modes; the network tracks the helix in depth as well as in plan.
#[test]
fn a_3d_run_gives_the_same_numbers_on_every_engine_and_tracks_the_helix() {
    use sonarnet::protocol::{Clock, EngineKind, RunConfig, RunPlan};
    use sonarnet::scenario::Mode;
    for mode in [Mode::Async, Mode::Sync] {
        let sc = space(&spiral_3d())
            .with_samples(12)
            .and_then(|s| s.with_mode(mode))
            .expect("valid");
        let real = sc.realize();
        let plan = RunPlan::new(&sc, Clock::Logical).expect("a 3-D plan");
        assert_eq!(plan.dim(), 3);
        let want = sonarnet::engine::run_inprocess(&plan, real.feed(), &mut |_, _| {});
        assert!(want.error.is_none(), "{mode:?}: {:?}", want.error);
        assert_eq!(want.record.thetas.len(), 12);
        assert!(want.record.thetas.iter().flatten().all(|t| t.len() == 4));
        let des = sonarnet::engine::des::run_des(&plan, real.feed(), &mut |_, _| {});
        assert_eq!(
            bits(&des.record),
            bits(&want.record),
            "{mode:?}: discrete events"
        );
        let (p, r) = (plan.clone(), real.clone());
        let threads =
            crate::util::with_watchdog("3-D threads run", Duration::from_secs(120), move || {
                sonarnet::engine::threads::run_threads(&p, r.feed(), &mut |_, _| {})
            });
        assert_eq!(
            bits(&threads.record),
            bits(&want.record),
            "{mode:?}: threads"
        );
        let cfg = RunConfig {
            engine: Some(EngineKind::Processes),
            clock: Some(Clock::Logical),
            ..RunConfig::default()
        };
        let plan = RunPlan::new(&sc, cfg).expect("a 3-D processes plan");
        let procs =
            crate::util::with_watchdog("3-D processes run", Duration::from_secs(180), move || {
                sonarnet::runtime::run(&plan, real.feed(), &Default::default(), &mut |_, _| {})
            });
        assert!(procs.error.is_none(), "{mode:?}: {:?}", procs.error);
        assert_eq!(
            bits(&procs.record),
            bits(&want.record),
            "{mode:?}: node processes"
        );
        assert_eq!(procs.driver, Some(sonarnet::protocol::Driver::Processes));
        let stats = procs.processes.as_ref().expect("node processes ran");
        crate::util::assert_nothing_left(&stats.run_id);
        // Tracking in 3-D: after a few samples the network mean is within
        // tens of metres of the target, depth included.
        let truth = sc.realize().truth.expect("synthetic");
        for (k, (thetas, x)) in want.record.thetas.iter().zip(&truth).enumerate().skip(6) {
            let e = sonarnet::model::metrics::theta_bar::<3>(thetas) - x;
            assert!(e.norm() < 60.0, "{mode:?} sample {k}: error {e:?}");
            assert!(
                e[2].abs() < 40.0,
                "{mode:?} sample {k}: depth error {}",
                e[2]
            );
        }
    }
}

/// Asserts that the ML track of `sc` is at every sample the global minimum
/// of the sample's cost, within a relative 1e-6 (along a flat direction
/// Levenberg-Marquardt stops millimetres short), against brute force: a
/// grid around the truth (`half[i]` steps of `step[i]` either side on axis
/// `i`) and Levenberg-Marquardt from the ten best points of a grid of
/// `coarse + 1` points a side over the box of the transmitters and
/// receivers, enlarged by half its size.
pub(crate) fn assert_the_ml_track_is_the_brute_force_minimum<const D: usize>(
    sc: &Scenario<D>,
    half: [i64; D],
    step: [f64; D],
    coarse: usize,
) {
    use sonarnet::estimators::central;
    use sonarnet::model::geometry::Point;
    let real = sc.realize();
    let truth = real.truth.expect("synthetic");
    let ml = central::ml_track(&sc.geometry, &real.measurements, &real.sigmas);
    let g = &sc.geometry;
    let all: Vec<Point<D>> = g.transmitters.iter().chain(&g.receivers).copied().collect();
    let lo = all
        .iter()
        .fold(Point::<D>::repeat(f64::INFINITY), |a, p| a.inf(p));
    let hi = all
        .iter()
        .fold(Point::<D>::repeat(f64::NEG_INFINITY), |a, p| a.sup(p));
    let (lo, hi) = (lo - (hi - lo) * 0.5, hi + (hi - lo) * 0.5);
    // The points of a grid with `sides[i]` points on axis `i`.
    let grid = |sides: [usize; D], at: &dyn Fn([usize; D]) -> Point<D>| -> Vec<Point<D>> {
        let count: usize = sides.iter().product();
        (0..count)
            .map(|flat| {
                let mut idx = [0; D];
                let mut rest = flat;
                for i in 0..D {
                    idx[i] = rest % sides[i];
                    rest /= sides[i];
                }
                at(idx)
            })
            .collect()
    };
    for (k, x) in truth.iter().enumerate() {
        let g = sc.geometry.at(k);
        let obs = central::observations(&g, &real.measurements[k]);
        let s = &real.sigmas[k];
        let cost = |p: &Point<D>| central::ml_cost(&obs, s, p);
        let near = grid(half.map(|h| (2 * h + 1) as usize), &|idx| {
            x + Point::<D>::from_fn(|i, _| (idx[i] as i64 - half[i]) as f64 * step[i])
        });
        let mut coarse_pts: Vec<(f64, Point<D>)> = grid([coarse + 1; D], &|idx| {
            lo + Point::<D>::from_fn(|i, _| (hi[i] - lo[i]) * idx[i] as f64 / coarse as f64)
        })
        .into_iter()
        .map(|p| (cost(&p), p))
        .collect();
        coarse_pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        let descents = coarse_pts
            .iter()
            .take(10)
            .map(|(_, p)| central::ml_estimate(&obs, s, *p));
        let best = near
            .into_iter()
            .chain(descents)
            .map(|p| (cost(&p), p))
            .fold((f64::INFINITY, *x), |b, c| if c.0 < b.0 { c } else { b });
        assert!(
            cost(&ml[k]) <= best.0 + 1e-6 * (1.0 + best.0),
            "sample {k}: the ML track's cost {} at {:?} is above {} at {:?} (truth {x:?})",
            cost(&ml[k]),
            ml[k],
            best.0,
            best.1
        );
    }
}

/// The centralised reference is the ML estimate, the global minimum of its
/// cost, at every sample of the 3-D spiral (±12 m across in steps of 2 m,
/// ±150 m in depth in steps of 2.5 m around the truth; a 31-point grid a
/// side over the box). The depth, weakly observed by receivers spanning
/// 250 m against 3.5 km across, has a second basin at some samples, where
/// a descent from the previous estimate can stay.
#[test]
fn the_3d_ml_track_is_the_global_minimum_of_its_cost_at_every_sample() {
    assert_the_ml_track_is_the_brute_force_minimum(
        &space(&spiral_3d()),
        [6, 6, 60],
        [2.0, 2.0, 2.5],
        30,
    );
}
