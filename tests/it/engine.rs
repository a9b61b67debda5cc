//! The message-driven engine equals a direct, sequential transcription of
//! Mourya 2017 eq. (11) (async) and of the sync consensus update, bit for bit.

use crate::util::scenario;
use sonarnet::estimators::gossip::ProxScaling;
use sonarnet::estimators::local::LocalProblem;
use sonarnet::estimators::prox::{LocalSolver, prox};
use sonarnet::model::geometry::{Vec2, Vec3};
use sonarnet::pipeline;
use sonarnet::protocol::{Clock, RunPlan};
use sonarnet::scenario::{InitMode, Mode, RowWeights, Scenario};

/// Mourya 2017 eq. (5)'s `p_v` for the drawn schedule, written out again from
/// the definition: `P(v draws) + sum_w P(neighbour w draws and calls v)`,
/// `1/N + sum_{w in N(v)} 1/(N deg(w))`, in that order of operations.
fn p_v(sc: &Scenario, v: usize) -> f64 {
    let n = sc.graph.len() as f64;
    let calls: f64 = sc
        .graph
        .neighbours(v)
        .iter()
        .map(|&w| 1.0 / (n * sc.graph.neighbours(w).len() as f64))
        .sum();
    1.0 / n + calls
}

/// The textbook loop: no messages, no actors. With `prox_scaling =
/// "inverse_probability"` each node's step is `gamma / p_v` (eq. 5); with
/// `init = "first_fix"` each node starts from its own fix of sample 0.
fn reference(sc: &Scenario) -> Vec<Vec<Vec3>> {
    let real = sc.realize();
    let n = sc.graph.len();
    let a = &sc.algorithm;
    let gamma: Vec<f64> = (0..n)
        .map(|v| match (a.prox_scaling, a.mode) {
            (ProxScaling::InverseProbability, Mode::Async) => a.gamma / p_v(sc, v),
            _ => a.gamma,
        })
        .collect();
    let mut u: Vec<Vec3> = (0..n).map(|i| a.init_u_of::<3>(i)).collect();
    if a.init == InitMode::FirstFix {
        for (i, ui) in u.iter_mut().enumerate() {
            let p = LocalProblem::build(
                sc.geometry.receivers[i],
                &sc.geometry.transmitters,
                sc.measurements.omega,
                &real.measurements[0].nodes[i],
            );
            *ui = p.first_fix(&sc.geometry.transmitters);
        }
    }
    let mut theta = u.clone();
    let plan = RunPlan::new(sc, Clock::Logical).unwrap();
    let mut sched = plan.scheduler();
    let mut out = Vec::new();
    for k in 0..sc.samples {
        let weights = (a.row_weights == RowWeights::Noise).then_some(&real.sigmas[k]);
        let probs: Vec<LocalProblem> = (0..n)
            .map(|i| {
                LocalProblem::build_weighted(
                    sc.geometry.receivers[i],
                    &sc.geometry.transmitters,
                    sc.measurements.omega,
                    &real.measurements[k].nodes[i],
                    weights,
                )
            })
            .collect();
        let solver = a.local_solver.with_kappa(a.kappa);
        for _ in 0..a.iterations_per_sample {
            match a.mode {
                Mode::Async => {
                    let (v, w) = sched.next_pair();
                    let tv = prox(solver, &probs[v], &u[v], gamma[v]).unwrap();
                    let tw = prox(solver, &probs[w], &u[w], gamma[w]).unwrap();
                    let rv = 2.0 * tv - u[v];
                    let rw = 2.0 * tw - u[w];
                    let avg = Vec2::new((rv[0] + rw[0]) / 2.0, (rv[1] + rw[1]) / 2.0);
                    for (i, t, r) in [(v, tv, rv), (w, tw, rw)] {
                        u[i] += Vec3::new(avg.x, avg.y, r[2]) - t;
                        theta[i] = t;
                    }
                }
                Mode::Sync => {
                    let ts: Vec<Vec3> = (0..n)
                        .map(|i| prox(solver, &probs[i], &u[i], gamma[i]).unwrap())
                        .collect();
                    let rs: Vec<Vec3> = (0..n).map(|i| 2.0 * ts[i] - u[i]).collect();
                    let mut s = Vec2::zeros();
                    for r in &rs {
                        s.x += r[0];
                        s.y += r[1];
                    }
                    let avg = s / n as f64;
                    for ((ui, t), r) in u.iter_mut().zip(&ts).zip(&rs) {
                        *ui += Vec3::new(avg.x, avg.y, r[2]) - t;
                    }
                    theta = ts;
                }
            }
        }
        out.push(theta.clone());
    }
    out
}

fn check(mode: Mode, file: &str) {
    check_with(mode, file, None);
}

fn load(mode: Mode, file: &str) -> Scenario {
    Scenario::load(&scenario(file))
        .unwrap()
        .with_mode(mode)
        .unwrap()
        .with_samples(25)
        .unwrap()
        .with_seed(11)
}

/// `check`, with the scenario's local solver replaced by `solver` if given.
fn check_with(mode: Mode, file: &str, solver: Option<LocalSolver>) {
    let mut sc = load(mode, file);
    if let Some(s) = solver {
        sc = sc.with_local_solver(s);
        sc.check_kappa().unwrap();
    }
    check_scenario(&sc, file);
}

/// The engine's `theta` of every node after every sample equals the
/// reference transcription's, bit for bit.
fn check_scenario(sc: &Scenario, file: &str) {
    let mode = sc.algorithm.mode;
    let real = sc.realize();
    let (rec, res) = crate::util::record(sc, &real);
    res.unwrap();
    let want = reference(sc);
    assert_eq!(rec.thetas.len(), want.len());
    for (k, (a, b)) in rec.thetas.iter().zip(&want).enumerate() {
        for (i, (x, y)) in a.iter().zip(b).enumerate() {
            assert!(
                x.iter()
                    .zip(y.iter())
                    .all(|(p, q)| p.to_bits() == q.to_bits()),
                "{file} {mode:?}: sample {k} node {i}: engine {x:?} != reference {y:?}"
            );
        }
    }
}

#[test]
fn async_engine_equals_the_sequential_transcription_of_eq_11_bit_for_bit() {
    check(Mode::Async, "mourya2017-spiral.toml");
    check(Mode::Async, "rgg16-waypoints.toml");
}

#[test]
fn async_engine_with_the_eq_5_prox_scaling_equals_its_transcription_bit_for_bit() {
    for file in ["mourya2017-spiral.toml", "rgg16-waypoints.toml"] {
        let sc = load(Mode::Async, file).with_prox_scaling(ProxScaling::InverseProbability);
        check_scenario(&sc, file);
        // The scaling is in force: node 0's first estimate differs from eq. 11's.
        let plain = load(Mode::Async, file);
        let (a, _) = crate::util::record(&sc, &sc.realize());
        let (b, _) = crate::util::record(&plain, &plain.realize());
        assert_ne!(a.thetas[0][0], b.thetas[0][0], "{file}");
    }
}

#[test]
fn noise_weighted_local_costs_equal_the_transcription_bit_for_bit() {
    for mode in [Mode::Async, Mode::Sync] {
        let mut sc =
            load(mode, "mourya2017-spiral.toml").with_prox_scaling(ProxScaling::InverseProbability);
        sc.algorithm.row_weights = RowWeights::Noise;
        sc.algorithm.gamma = 30.0;
        check_scenario(&sc, "mourya2017-spiral.toml");
    }
}

#[test]
fn nodes_started_from_their_first_fix_equal_the_transcription_bit_for_bit() {
    for mode in [Mode::Async, Mode::Sync] {
        let mut sc = load(mode, "mourya2017-spiral.toml");
        sc.algorithm.init = InitMode::FirstFix;
        check_scenario(&sc, "mourya2017-spiral.toml");
    }
    // Per-node init_u.
    let mut sc = load(Mode::Async, "mourya2017-spiral.toml");
    sc.algorithm.init_u = (0..6).map(|i| vec![100.0 * i as f64, 50.0, 10.0]).collect();
    check_scenario(&sc, "mourya2017-spiral.toml");
}

#[test]
fn sync_engine_equals_the_sequential_consensus_update_bit_for_bit() {
    check(Mode::Sync, "mourya2017-spiral.toml");
    check(Mode::Sync, "rgg16-waypoints.toml");
}

#[test]
fn async_engine_with_gtrs_l0_equals_the_sequential_transcription_bit_for_bit() {
    check_with(
        Mode::Async,
        "mourya2017-spiral.toml",
        Some(LocalSolver::GtrsL0),
    );
    check_with(
        Mode::Async,
        "rgg16-waypoints.toml",
        Some(LocalSolver::GtrsL0),
    );
}

#[test]
fn sync_engine_with_gtrs_l0_equals_the_sequential_consensus_update_bit_for_bit() {
    check_with(
        Mode::Sync,
        "mourya2017-spiral.toml",
        Some(LocalSolver::GtrsL0),
    );
    check_with(
        Mode::Sync,
        "rgg16-waypoints.toml",
        Some(LocalSolver::GtrsL0),
    );
}

#[test]
fn gtrs_l0_runs_in_process_in_both_modes_and_tracks_the_spiral() {
    for mode in [Mode::Sync, Mode::Async] {
        let sc = Scenario::load(&scenario("mourya2017-spiral.toml"))
            .unwrap()
            .with_mode(mode)
            .unwrap()
            .with_samples(40)
            .unwrap()
            .with_local_solver(LocalSolver::GtrsL0);
        sc.check_kappa().unwrap();
        assert_eq!(sc.algorithm.kappa, 1);
        let real = sc.realize();
        let (rec, res) = crate::util::record(&sc, &real);
        res.unwrap();
        assert_eq!(rec.thetas.len(), 40);
        let truth = real.truth.as_ref().unwrap();
        let errs: Vec<f64> = (20..40)
            .map(|k| (sonarnet::model::metrics::theta_bar(&rec.thetas[k]) - truth[k]).norm())
            .collect();
        let worst = errs.iter().cloned().fold(0.0, f64::max);
        assert!(
            errs.iter().all(|e| e.is_finite()) && worst < 100.0,
            "{mode:?}: errors {errs:?}"
        );
        // It is a different prox: the plain GTRS run differs.
        let plain = sc.clone().with_local_solver(LocalSolver::Gtrs);
        let (rec_g, res_g) = crate::util::record(&plain, &real);
        res_g.unwrap();
        assert_ne!(rec.thetas, rec_g.thetas, "{mode:?}");
    }
}

/// RMSE of theta_bar after the burn-in of `sc` run in-process.
fn rmse(sc: &Scenario) -> f64 {
    let real = sc.realize();
    let (rec, res) = crate::util::record(sc, &real);
    res.unwrap();
    let truth = real.truth.as_ref().unwrap();
    let burn = sc.algorithm.burn_in;
    let n = (burn..sc.samples).len() as f64;
    let sq: f64 = (burn..sc.samples)
        .map(|k| (sonarnet::model::metrics::theta_bar(&rec.thetas[k]) - truth[k]).norm_squared())
        .sum();
    (sq / n).sqrt()
}

#[test]
fn gtrs_l0_separates_one_nlos_bistatic_range_per_node_that_derails_gtrs() {
    // The spiral with one NLOS bistatic link at three of the six receivers, biased by
    // an exponential with mean 2 km: one outlier row among those nodes' four rows.
    let text = std::fs::read_to_string(scenario("mourya2017-spiral.toml"))
        .unwrap()
        .replace(
            "range_noise = { model = \"gaussian\", sigma = 5.0 }",
            "range_noise = { model = \"nlos_exponential\", sigma = 5.0, nlos_mean = 2000.0 }\n\
             nlos_links = { kind = \"list\", links = [[0, 1], [1, 2], [0, 4]] }",
        );
    assert!(text.contains("nlos_exponential"));
    let sc = Scenario::from_toml_str(&text, &scenario("nlos-spiral.toml"))
        .unwrap()
        .with_samples(40)
        .unwrap();
    for mode in [Mode::Sync, Mode::Async] {
        let sc = sc.clone().with_mode(mode).unwrap();
        let gtrs = rmse(&sc);
        let l0 = rmse(&sc.clone().with_local_solver(LocalSolver::GtrsL0));
        eprintln!("{mode:?}: rmse gtrs {gtrs:.1} m, gtrs_l0 {l0:.1} m");
        assert!(
            l0 < 50.0 && l0 < 0.5 * gtrs,
            "{mode:?}: gtrs_l0 {l0:.1} m vs gtrs {gtrs:.1} m"
        );
    }
}

/// The spiral of 15 samples in `mode`: its realization, its in-process
/// record on the logical clock, and its plan.
fn spiral15(
    mode: Mode,
) -> (
    sonarnet::model::synth::Realization,
    sonarnet::protocol::RunRecord,
    RunPlan,
) {
    let sc = Scenario::load(&scenario("mourya2017-spiral.toml"))
        .unwrap()
        .with_samples(15)
        .unwrap()
        .with_mode(mode)
        .unwrap();
    let real = sc.realize();
    let (want, res) = crate::util::record(&sc, &real);
    res.unwrap();
    let plan = RunPlan::new(&sc, Clock::Logical).unwrap();
    (real, want, plan)
}

#[test]
fn node_threads_over_the_in_memory_transport_give_the_in_process_numbers() {
    for mode in [Mode::Async, Mode::Sync] {
        let (real, want, plan) = spiral15(mode);
        let real2 = real.clone();
        let out = crate::util::with_watchdog(
            "threads run",
            std::time::Duration::from_secs(120),
            move || sonarnet::engine::threads::run_threads(&plan, real2.feed(), &mut |_, _| {}),
        );
        if let Some(e) = out.error {
            panic!("{mode:?}: {e}");
        }
        let got = out.record;
        assert_eq!(got.thetas.len(), 15, "{mode:?}");
        for (k, (a, b)) in got.thetas.iter().zip(&want.thetas).enumerate() {
            for (i, (x, y)) in a.iter().zip(b).enumerate() {
                assert!(
                    x.iter()
                        .zip(y.iter())
                        .all(|(p, q)| p.to_bits() == q.to_bits()),
                    "{mode:?} sample {k} node {i}: threads {x:?}, in-process {y:?}"
                );
            }
        }
        assert_eq!(got.schedule, want.schedule, "{mode:?}");
        assert_eq!(got.iterations, want.iterations, "{mode:?}");
    }
}

/// The discrete-event engine, given a logical clock on the
/// ideal channel, runs the same coordinator and node cores as the in-process
/// engine and gives its numbers bit for bit, in both modes.
#[test]
fn the_discrete_event_engine_on_a_logical_clock_gives_the_in_process_numbers() {
    for mode in [Mode::Async, Mode::Sync] {
        let (real, want, plan) = spiral15(mode);
        let out = sonarnet::engine::des::run_des(&plan, real.feed(), &mut |_, _| {});
        if let Some(e) = out.error {
            panic!("{mode:?}: {e}");
        }
        let got = out.record;
        assert_eq!(got.thetas.len(), 15, "{mode:?}");
        assert!(
            got.thetas
                .iter()
                .flatten()
                .zip(want.thetas.iter().flatten())
                .all(|(x, y)| x
                    .iter()
                    .zip(y.iter())
                    .all(|(p, q)| p.to_bits() == q.to_bits())),
            "{mode:?}: the discrete-event engine's thetas differ"
        );
        assert_eq!(got.schedule, want.schedule, "{mode:?}");
        assert_eq!(got.counters, want.counters, "{mode:?}");
    }
}

#[test]
fn the_library_pipeline_gives_the_command_lines_numbers_and_files() {
    let sc = Scenario::from_file(scenario("mourya2017-spiral.toml")).unwrap();
    let out = sc.run(&pipeline::RunOptions::inprocess());
    assert!(out.run.error.is_none());
    assert_eq!(out.run.record.thetas.len(), sc.samples);
    assert!(!out.metrics.expect.is_empty() && out.metrics.expect.iter().all(|c| c.holds));
    // Written, the results are the golden ones of `sonarnet run --engine inprocess`.
    let dir = crate::util::TempDir::new("library-pipeline");
    let written = sc
        .run_and_write(&pipeline::RunOptions::inprocess().with_out_dir(dir.path()))
        .unwrap();
    assert_eq!(written.metrics.rmse, out.metrics.rmse);
    let golden = crate::util::root().join("tests/golden/runs/spiral-async-inprocess");
    for f in ["nodes.csv", "track.csv"] {
        let now = crate::golden::canonical(&dir.path().join(f)).unwrap();
        let want = std::fs::read_to_string(golden.join(format!("{f}.golden"))).unwrap();
        assert!(now == want, "{f} differs from the golden run");
    }
    // The threads engine through the same entry point.
    let threads =
        sc.run(&pipeline::RunOptions::inprocess().with_engine(pipeline::EngineKind::Threads));
    assert_eq!(threads.run.record.thetas, out.run.record.thetas);
    assert_eq!(threads.metrics.rmse, out.metrics.rmse);
}

#[test]
fn realtime_clocks_on_the_threads_engine_are_refused_before_anything_runs() {
    let sc = Scenario::from_file(scenario("mourya2017-spiral.toml")).unwrap();
    let cfg = sonarnet::protocol::RunConfig {
        engine: Some(pipeline::EngineKind::Threads),
        clock: Some(Clock::Realtime),
        ..Default::default()
    };
    let e = RunPlan::new(&sc, cfg).expect_err("realtime on threads must be refused");
    assert!(
        matches!(
            &e,
            sonarnet::protocol::EngineError::Refused(r) if r.key == sonarnet::protocol::Key::Flag("--engine")
        ),
        "{e:?}"
    );
    assert!(e.to_string().contains("not threads"), "{e}");
    // The command line asks the same plan, before anything starts.
    let spiral = scenario("mourya2017-spiral.toml");
    let o = crate::util::sonarnet(
        &[
            "run",
            spiral.to_str().unwrap(),
            "--engine",
            "threads",
            "--clock",
            "realtime",
            "--samples",
            "20",
        ],
        std::time::Duration::from_secs(60),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("<command line>: --engine") && err.contains("not threads"),
        "{err}"
    );
}

/// The discrete-event engine runs the realtime protocol in virtual time: the
/// same seed gives the same numbers, and with the ideal channel every one of
/// the Poisson ticks (6 nodes x 2000 Hz x 20 ms = 240 per sample) is an
/// exchange that completes at once.
#[test]
fn the_discrete_event_engine_runs_the_realtime_protocol_deterministically_in_virtual_time() {
    let sc = Scenario::from_file(scenario("mourya2017-spiral.toml")).unwrap();
    let opts = pipeline::RunOptions::inprocess().with_clock(Clock::Realtime);
    let a = sc.run(&opts);
    let b = sc.run(&opts);
    assert!(a.run.error.is_none(), "{:?}", a.run.error);
    assert_eq!(a.run.record.thetas.len(), 100);
    let bits = |o: &pipeline::Outcome| -> Vec<u64> {
        o.run
            .record
            .thetas
            .iter()
            .flatten()
            .flat_map(|t| t.iter().map(|v| v.to_bits()).collect::<Vec<_>>())
            .collect()
    };
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(
        a.run.record.iterations_per_sample,
        b.run.record.iterations_per_sample
    );
    // Exchanges per sample: Poisson with mean 240; the mean over 100 samples
    // has a standard deviation of 1.55.
    let ips = &a.run.record.iterations_per_sample;
    let mean = ips.iter().sum::<u64>() as f64 / ips.len() as f64;
    assert!(
        (mean - 240.0).abs() < 5.0 * 1.55,
        "{mean} exchanges per sample"
    );
    // About 240 exchanges per sample track at the logical clock's floor
    // (sync 3.35 m, async eq. 11 at 200 iterations 3.45 m on seeds 0-4).
    let rmse = a.metrics.rmse_after_burn_in.unwrap();
    assert!(rmse < 5.0, "rmse after burn-in {rmse}");
    // Another seed, other numbers.
    let c = sc.clone().with_seed(1).run(&opts);
    assert_ne!(bits(&a), bits(&c));
}

#[test]
fn run_json_and_summary_json_are_exactly_their_typed_schemas() {
    let sc = Scenario::from_file(scenario("mourya2017-spiral.toml"))
        .unwrap()
        .with_samples(20)
        .unwrap();
    let dir = crate::util::TempDir::new("typed-results");
    let opts = pipeline::RunOptions::inprocess().with_out_dir(dir.path().join("mc"));
    sonarnet::pipeline::montecarlo::run_monte_carlo(&sc, 2, &opts, &|_| {}).unwrap();
    let read = |f: &str| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("mc").join(f)).unwrap())
            .unwrap()
    };
    // Every key written is a field of the type, and the type loses nothing.
    let run_json = read("run.json");
    let typed: pipeline::RunJson = serde_json::from_value(run_json.clone()).unwrap();
    assert_eq!(serde_json::to_value(&typed).unwrap(), run_json);
    assert_eq!(typed.seed, Some(sc.seed));
    let summary = read("summary.json");
    let typed: pipeline::McSummary = serde_json::from_value(summary.clone()).unwrap();
    assert_eq!(serde_json::to_value(&typed).unwrap(), summary);
    assert_eq!(typed.trials, Some(2));
    assert!(typed.curves.contains_key("theta_bar") && typed.curves.contains_key("ml"));
    // metrics.json likewise.
    let metrics = read("metrics.json");
    let typed = pipeline::RunMetrics::from_json(metrics.clone()).unwrap();
    assert_eq!(serde_json::to_value(&typed).unwrap(), metrics);
    // Every track's metrics are embedded: the top-level ones are theta_bar's,
    // ml_rmse is the ML reference's.
    assert!(typed.theta_bar.ctte_mid.is_some());
    assert_eq!(typed.rmse, typed.theta_bar.rmse);
    assert_eq!(typed.ctte, typed.theta_bar.ctte);
    assert_eq!(typed.ml_rmse, typed.ml.rmse);
    assert!(typed.ml.rmse_after_burn_in.is_some());
}

#[test]
fn run_json_and_the_summary_say_whether_the_lock_step_or_the_discrete_event_engine_ran() {
    let tmp = crate::util::TempDir::new("driver");
    for (file, extra, driver, words) in [
        (
            "mourya2017-spiral.toml",
            &[][..],
            "lock_step",
            "inprocess (lock-step)",
        ),
        (
            "mourya2017-spiral-acoustic.toml",
            &["--variant", "modem"][..],
            "discrete_event",
            "inprocess (discrete-event, virtual time)",
        ),
    ] {
        let out = tmp.path().join(driver);
        let path = scenario(file);
        let mut args = vec![
            "run",
            path.to_str().unwrap(),
            "--engine",
            "inprocess",
            "--samples",
            "12",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let o = crate::util::sonarnet(&args, std::time::Duration::from_secs(120));
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(stdout.contains(words), "{stdout}");
        let run: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("run.json")).unwrap()).unwrap();
        assert_eq!(run["engine"], "inprocess");
        assert_eq!(run["driver"], driver);
    }
}
