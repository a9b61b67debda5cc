//! Seed 002 Sec. III-C behaviour on `mourya2017-spiral`, averaged over seeds 0-4
//! with a burn-in of 10 samples.

use crate::util::{TempDir, run_inprocess, scenario};
use sonarnet::estimators::prox::LocalSolver;
use sonarnet::scenario::{Mode, Scenario};

fn mean_rmse(mode: Mode, solver: LocalSolver) -> f64 {
    let mut s = 0.0;
    for seed in 0..5 {
        let sc = Scenario::load(&scenario("mourya2017-spiral.toml"))
            .unwrap()
            .with_seed(seed)
            .with_mode(mode)
            .unwrap()
            .with_local_solver(solver);
        let tmp = TempDir::new("paper");
        let out = run_inprocess(&sc, tmp.path());
        assert!(out.error.is_none());
        s += out.metrics.rmse_after_burn_in.unwrap();
    }
    s / 5.0
}

#[test]
fn sync_gtrs_tracks_the_spiral_within_5_m_and_relaxed_is_3x_worse() {
    let gtrs = mean_rmse(Mode::Sync, LocalSolver::Gtrs);
    let relaxed = mean_rmse(Mode::Sync, LocalSolver::Relaxed);
    eprintln!("sync: gtrs {gtrs:.3} m, relaxed {relaxed:.3} m");
    assert!(
        gtrs <= 5.0,
        "sync GTRS rmse_after_burn_in {gtrs:.3} m > 5 m"
    );
    assert!(
        relaxed >= 3.0 * gtrs,
        "relaxed {relaxed:.3} m is not 3x worse than GTRS {gtrs:.3} m"
    );
}

#[test]
fn async_gtrs_tracks_the_spiral_within_20_m_and_relaxed_is_3x_worse() {
    let gtrs = mean_rmse(Mode::Async, LocalSolver::Gtrs);
    let relaxed = mean_rmse(Mode::Async, LocalSolver::Relaxed);
    eprintln!("async: gtrs {gtrs:.3} m, relaxed {relaxed:.3} m");
    assert!(
        gtrs <= 20.0,
        "async GTRS rmse_after_burn_in {gtrs:.3} m > 20 m"
    );
    assert!(
        relaxed >= 3.0 * gtrs,
        "relaxed {relaxed:.3} m is not 3x worse than GTRS {gtrs:.3} m"
    );
}
