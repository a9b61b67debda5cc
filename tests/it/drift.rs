//! Receivers that drift (`[[geometry.drift]]`): the measurements are taken
//! from where each receiver is at each sample, each node builds its cost
//! there, every engine agrees, and the positions are written, plotted and
//! replayed.

use crate::util::{TempDir, header, read_rows, run_file, scenario};
use sonarnet::model::measure::SampleMeasurements;
use sonarnet::model::metrics::theta_bar;
use sonarnet::model::synth::synthesize;
use sonarnet::protocol::{Clock, RunPlan};
use sonarnet::scenario::{AnyScenario, Scenario};
use std::path::Path;
use std::time::Duration;

const LIMIT: Duration = Duration::from_secs(120);

fn buoys() -> Scenario<3> {
    match AnyScenario::load_all(&scenario("sonobuoy-drift-3d.toml"))
        .expect("load")
        .remove(0)
    {
        AnyScenario::Space(sc) => sc,
        AnyScenario::Plane(_) => panic!("the drift scenario is 3-D"),
    }
}

/// The rms distance of the nodes' mean to the truth after the burn-in, on
/// the in-process engine.
fn rmse_after_burn_in(sc: &Scenario<3>, plan: &RunPlan) -> f64 {
    let real = sc.realize();
    let out = sonarnet::engine::run_inprocess(plan, real.feed(), &mut |_, _| {});
    assert!(out.error.is_none(), "{:?}", out.error);
    let truth = real.truth.expect("synthetic truth");
    let burn = sc.algorithm.burn_in;
    let sq: Vec<f64> = (burn..sc.samples)
        .map(|k| (theta_bar::<3>(&out.record.thetas[k]) - truth[k]).norm_squared())
        .collect();
    (sq.iter().sum::<f64>() / sq.len() as f64).sqrt()
}

#[test]
fn a_drifting_receiver_measures_from_where_it_is_at_each_sample() {
    let sc = buoys();
    let g = &sc.geometry;
    assert!(g.drifts());
    // Noise-free synthesis along a static target.
    let mut cfg = sc.measurements.clone();
    cfg.range_noise = None;
    cfg.doa_noise = None;
    cfg.elevation_noise = None;
    let x = nalgebra::Vector3::new(500.0, 500.0, -120.0);
    let truth = vec![x; 40];
    let nlos = sonarnet::model::noise::NlosMask::all_los(2, 6);
    let meas = synthesize(g, &truth, &cfg, &nlos, 0);
    for k in [0, 1, 17, 39] {
        let want = SampleMeasurements::noise_free(&g.at(k), &x, true, false);
        assert_eq!(meas[k], want, "sample {k}");
    }
    // The buoy 0 moves 5 m a sample: its bistatic range at sample 39 is not
    // the one of its moored position.
    let moored = SampleMeasurements::noise_free(g, &x, true, false);
    let (got, was) = (
        meas[39].nodes[0].bistatic[0].1,
        moored.nodes[0].bistatic[0].1,
    );
    assert!((got - was).abs() > 50.0, "{got} vs {was}");
    // Receiver 3 is moored: it measures the same at every sample.
    assert_eq!(meas[39].nodes[3], moored.nodes[3]);
}

#[test]
fn nodes_track_the_target_by_building_their_costs_where_they_are() {
    let sc = buoys();
    let plan = RunPlan::new(&sc, Clock::Logical).expect("plan");
    assert!(plan.nodes[0].drift.is_some() && plan.nodes[3].drift.is_none());
    let with = rmse_after_burn_in(&sc, &plan);
    // The same run with nodes that believe they are still where they
    // started: the measurements drift away from their costs.
    let mut blind = plan.clone();
    for c in &mut blind.nodes {
        c.drift = None;
    }
    let without = rmse_after_burn_in(&sc, &blind);
    assert!(with < 40.0, "with drift {with} m");
    assert!(
        without > 3.0 * with,
        "blind {without} m, with drift {with} m"
    );
}

#[test]
fn receivers_that_do_not_move_change_no_number() {
    let sc = buoys();
    let mut still = sc.clone();
    for d in still.geometry.drift.iter_mut().flatten() {
        *d = sonarnet::model::drift::Drift::Velocity {
            velocity: sonarnet::model::xy::Pt::xyz(0.0, 0.0, 0.0),
        };
    }
    let mut moored = sc.clone();
    moored.geometry.drift.clear();
    let (a, b) = (still.realize(), moored.realize());
    assert_eq!(a.measurements, b.measurements);
    let run = |sc: &Scenario<3>| {
        let plan = RunPlan::new(sc, Clock::Logical).expect("plan");
        sonarnet::engine::run_inprocess(&plan, sc.realize().feed(), &mut |_, _| {})
            .record
            .thetas
    };
    assert_eq!(run(&still), run(&moored));
}

fn csv_bytes(dir: &Path, name: &str) -> Vec<u8> {
    std::fs::read(dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

#[test]
fn a_drift_run_writes_the_receivers_plots_their_paths_and_replays_on_every_engine() {
    let tmp = TempDir::new("drift");
    let file = scenario("sonobuoy-drift-3d.toml");
    let (a, b) = (tmp.path().join("inprocess"), tmp.path().join("processes"));
    for (out, engine) in [(&a, "inprocess"), (&b, "processes")] {
        let o = run_file(&file, out, &["--engine", engine, "--samples", "30"], LIMIT);
        assert!(
            o.status.success(),
            "{engine}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
    for name in ["track.csv", "nodes.csv", "receivers.csv"] {
        assert_eq!(csv_bytes(&a, name), csv_bytes(&b, name), "{name}");
    }
    let rx = a.join("receivers.csv");
    assert_eq!(header(&rx), ["sample", "node", "x", "y", "z", "drifts"]);
    let rows = read_rows(&rx);
    assert_eq!(rows.len(), 30 * 6);
    // Buoy 0 at sample 29: 29 steps of [4, 3, 0] from (-1000, -1000, -50).
    let r = rows
        .iter()
        .find(|r| r[0] == "29" && r[1] == "0")
        .expect("row");
    let p: Vec<f64> = r[2..5].iter().map(|v| v.parse().expect("number")).collect();
    assert_eq!(p, [-884.0, -913.0, -50.0]);
    assert_eq!(r[5], "true");
    let svg = std::fs::read_to_string(a.join("tracks.svg")).expect("tracks.svg");
    assert!(svg.contains("receiver drift"), "tracks.svg draws the paths");
    // A replay of the results directory recomputes every file, receivers.csv
    // included, identically.
    let o = crate::util::sonarnet(&["replay", a.to_str().expect("utf-8")], LIMIT);
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{said}");
    assert!(said.contains("identical results"), "{said}");
}

#[test]
fn a_2d_network_drifts_too() {
    let tmp = TempDir::new("drift-2d");
    let text = std::fs::read_to_string(scenario("mourya2017-spiral.toml"))
        .expect("read")
        .replace(
            "[network]",
            "[[geometry.drift]]\nreceiver = 5\nwaypoints = [[2500.0, 500.0]]\nspeed = 20.0\n\n[network]",
        );
    let file = tmp.write("drift-2d.toml", &text);
    let out = tmp.path().join("run");
    let o = run_file(&file, &out, &["--engine", "inprocess"], LIMIT);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rows = read_rows(&out.join("receivers.csv"));
    assert_eq!(
        header(&out.join("receivers.csv")),
        ["sample", "node", "x", "y", "drifts"]
    );
    let last = rows
        .iter()
        .find(|r| r[0] == "99" && r[1] == "5")
        .expect("row");
    // 1000 m of path at 20 m a sample: there by sample 50, held after.
    assert_eq!(last[2..4], ["2500.0", "500.0"]);
    let m = crate::util::metrics(&out);
    let rmse = m["rmse_after_burn_in"].as_f64().expect("rmse");
    assert!(rmse < 20.0, "{rmse}");
}

#[test]
fn a_bad_drift_entry_is_refused_naming_its_key() {
    let tmp = TempDir::new("drift-bad");
    let base = std::fs::read_to_string(scenario("mourya2017-spiral.toml")).expect("read");
    let cases = [
        (
            "[[geometry.drift]]\nreceiver = 6\nvelocity = [1.0, 0.0]\n",
            "geometry.drift[0].receiver",
        ),
        (
            "[[geometry.drift]]\nreceiver = 1\nwaypoints = [[0.0, 0.0]]\n",
            "geometry.drift[0].speed",
        ),
        (
            "[[geometry.drift]]\nreceiver = 1\nvelocity = [1.0, 0.0, 2.0]\n",
            "geometry.drift[0].velocity",
        ),
    ];
    for (i, (extra, key)) in cases.iter().enumerate() {
        let text = base.replace("[network]", &format!("{extra}\n[network]"));
        let file = tmp.write(&format!("bad{i}.toml"), &text);
        let o = crate::util::sonarnet(&["validate", file.to_str().expect("utf-8")], LIMIT);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "case {i}: {err}");
        assert!(err.contains(key), "case {i}: {err}");
        assert!(err.contains(&format!("bad{i}.toml")), "case {i}: {err}");
    }
}

#[test]
fn on_the_acoustic_channel_each_frame_travels_between_the_positions_of_its_sample() {
    let tmp = TempDir::new("drift-acoustic");
    let text = std::fs::read_to_string(scenario("mourya2017-spiral-3d-acoustic.toml"))
        .expect("read")
        .replace(
            "[network]",
            "[[geometry.drift]]\nreceiver = 0\nvelocity = [20.0, 15.0, 0.0]\n\n\
             [[geometry.drift]]\nreceiver = 3\nwaypoints = [[1500.0, 0.0, -200.0], [0.0, 0.0, -100.0]]\nspeed = 60.0\n\n[network]",
        );
    let file = tmp.write("drift-acoustic.toml", &text);
    let out = tmp.path().join("run");
    let o = run_file(&file, &out, &["--samples", "30"], LIMIT);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let rx = read_rows(&out.join("receivers.csv"));
    let at = |k: usize, n: usize| -> [f64; 3] {
        let r = rx
            .iter()
            .find(|r| r[0] == k.to_string() && r[1] == n.to_string())
            .expect("row");
        [0, 1, 2].map(|i| r[2 + i].parse::<f64>().expect("number"))
    };
    let dist = |a: [f64; 3], b: [f64; 3]| {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    let period = 60.0;
    let (mut checked, mut moved) = (0, 0);
    for r in read_rows(&out.join("messages.csv"))
        .iter()
        .filter(|r| r[6] == "delivered")
    {
        let (t0, t1): (f64, f64) = (r[0].parse().unwrap(), r[1].parse().unwrap());
        let (from, to): (usize, usize) = (r[2].parse().unwrap(), r[3].parse().unwrap());
        let airtime = r[5].parse::<f64>().unwrap() / 1000.0;
        let took = t1 - t0 - airtime;
        // The positions in force are those of the sample running when the
        // frame was sent (the medium moves as each sample completes).
        let k = ((t0 / period).floor() as usize).min(29);
        let candidates: Vec<usize> = [k.saturating_sub(1), k, (k + 1).min(29)].into();
        let fits = |k: usize| (took - dist(at(k, from), at(k, to)) / 1500.0).abs() < 2e-9;
        assert!(
            candidates.iter().any(|&k| fits(k)),
            "{r:?}: {took} s fits no position of samples {candidates:?}"
        );
        checked += 1;
        moved += usize::from(!fits(0) && k > 1);
    }
    assert!(checked > 100, "{checked} frames");
    assert!(
        moved > checked / 3,
        "{moved} of {checked} frames saw the drift"
    );
}
