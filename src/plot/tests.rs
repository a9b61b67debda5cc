//! Unit tests on the plot data: axis ranges include every point, every track
//! of the outputs appears in the plots, the loader reads the generic column
//! conventions and rejects bad input with clear messages.

use super::data::*;
use super::figures::*;
use super::*;
use approx::assert_abs_diff_eq;
use serde_json::json;
use std::path::Path;

/// A track.csv with truth, theta_bar, ML, two baselines (one with its own
/// error/ctte/regret columns, one without) and two bounds.
const TRACK: &str = "\
sample,true_x,true_y,est_x,est_y,error,ml_x,ml_y,crlb,ctte,ogd_x,ogd_y,ogd_error,ogd_ctte,ogd_regret,onm_x,onm_y,bound_minball,bound_bbox,seed
0,500,500,0,0,707.1067811865476,505,498,3.2,707.1067811865476,480,510,22.360679774997898,22.360679774997898,5,490,490,800,,7
1,502,501,300,320,271.39,503,500,3.1,978.4967811865476,500,505,4.47213595499958,26.83281572999748,6,500,500,300,420,7
2,505,504,499,503,6.08276253029822,505,503,3.0,984.5795437168458,504,503,1.4142135623730951,28.24703,6.5,,,12,15,7
3,509,508,507,509,2.23606797749979,509,509,3.0,986.8156116943456,508,508,1,29.24703,7,510,509,9,,7
";

pub(super) fn csv_of(text: &str) -> Csv {
    let mut rdr = csv::Reader::from_reader(text.as_bytes());
    Csv {
        header: rdr.headers().unwrap().iter().map(str::to_owned).collect(),
        rows: rdr
            .records()
            .map(|r| r.unwrap().iter().map(str::to_owned).collect())
            .collect(),
    }
}

fn run_json() -> crate::pipeline::RunJson {
    crate::pipeline::RunJson {
        seed: Some(7),
        engine: Some("inprocess".into()),
        mode: Some("async".into()),
        ..Default::default()
    }
}

fn info() -> RunInfo {
    RunInfo {
        name: "unit".into(),
        run: run_json(),
        transmitters: vec![[0.0, 0.0, 0.0], [2000.0, 2000.0, 0.0]],
        receivers: vec![
            [-1000.0, -1000.0, 0.0],
            [1500.0, -1000.0, 0.0],
            [-1000.0, 1000.0, 0.0],
        ],
        edges: vec![(0, 1), (0, 2)],
        burn_in: Some(1),
        ..RunInfo::default()
    }
}

fn nodes() -> Vec<NodePoint> {
    let mut v = Vec::new();
    for s in 0..4 {
        for n in 0..3 {
            v.push(NodePoint {
                sample: s,
                iteration: None,
                node: n,
                pos: [500.0 + s as f64 + n as f64 * 3.0, 490.0 - n as f64, 0.0],
            });
        }
    }
    v
}

fn data() -> RunData {
    let metrics = json!({
        "rmse": 400.0, "ctte": 986.8, "iterations": 200, "prox_solves": 400,
        "nodes": [
            {"node": 0, "prox_solves": 100, "messages_out": 50, "messages_in": 50, "declines": 0},
            {"node": 1, "prox_solves": 200, "messages_out": 80, "messages_in": 70, "declines": 2},
            {"node": 2, "prox_solves": 100, "messages_out": 40, "messages_in": 50, "declines": 1}
        ],
        "baselines": {"ogd": {"rmse": 11.0, "dynamic_regret": 7.0}}
    });
    RunData {
        dir: "unit".into(),
        info: info(),
        metrics: Some(crate::pipeline::RunMetrics::from_json(metrics).unwrap()),
        track: parse_track_csv(Path::new("track.csv"), &csv_of(TRACK)).unwrap(),
        nodes: nodes(),
        iterations: None,
        monte_carlo: None,
        messages: None,
        receivers: None,
    }
}

fn mc_data() -> RunData {
    let mut d = data();
    let band = |base: f64| json!({"mean": [base, base / 2.0, null], "p5": [base / 2.0, 0.0, null], "p95": [base * 2.0, base, null]});
    let summary = json!({
        "trials": 50,
        "sample": [0, 1, 2],
        "curves": {
            "ogd": {"error": band(30.0), "ctte": band(30.0)},
            "theta_bar": {"error": band(500.0), "ctte": band(500.0), "regret": band(3.0)},
            "ml": {"error": band(4.0)}
        },
        "crlb": band(3.0)
    });
    let mut mc = parse_summary(Path::new("summary.json"), &summary).unwrap();
    mc.trial_columns = vec!["trial".into(), "seed".into(), "rmse".into()];
    mc.trial_rows = vec![
        vec![Some(0.0), Some(1.0), Some(10.0)],
        vec![Some(1.0), Some(2.0), Some(12.0)],
    ];
    d.monte_carlo = Some(mc);
    d
}

fn assert_ranges_cover(fig: &Figure) {
    for (i, p) in fig.panels.iter().enumerate() {
        assert!(
            p.x_range.0 < p.x_range.1,
            "{} panel {i}: empty x range",
            fig.name
        );
        assert!(
            p.y_range.0 < p.y_range.1,
            "{} panel {i}: empty y range",
            fig.name
        );
        if p.log_y {
            assert!(
                p.y_range.0 > 0.0,
                "{} panel {i}: log axis must start above 0",
                fig.name
            );
        }
        for q in p.points() {
            assert!(
                p.contains(q),
                "{} panel {i}: point {q:?} outside x {:?} y {:?}",
                fig.name,
                p.x_range,
                p.y_range
            );
        }
    }
}

#[test]
fn track_csv_columns_become_generic_tracks() {
    let d = data();
    let names: Vec<&str> = d.track.tracks.iter().map(|t| t.name.as_str()).collect();
    assert_eq!(names, ["theta_bar", "ml", "ogd", "onm"]);
    let b: Vec<&str> = d.track.bounds.iter().map(|b| b.name.as_str()).collect();
    assert_eq!(b, ["minball", "bbox"]);
    assert_eq!(
        d.track.bounds[1].radius,
        vec![None, Some(420.0), Some(15.0), None]
    );
    // ML has no error column: computed from the truth.
    let ml = d.track.track("ml").unwrap();
    assert_abs_diff_eq!(ml.error[0].unwrap(), 5.0f64.hypot(2.0), epsilon = 1e-12);
    // onm has neither error nor ctte columns: error from truth, ctte the running sum,
    // and the missing row is a gap.
    let onm = d.track.track("onm").unwrap();
    assert_eq!(onm.pos[2], None);
    assert_eq!(onm.error[2], None);
    let e0 = 10.0f64.hypot(10.0);
    let e1 = 2.0f64.hypot(1.0);
    assert_abs_diff_eq!(onm.ctte[1].unwrap(), e0 + e1, epsilon = 1e-12);
    // ogd's own columns are used as written.
    let ogd = d.track.track("ogd").unwrap();
    assert_abs_diff_eq!(ogd.ctte[2].unwrap(), 28.24703, epsilon = 1e-12);
    assert_eq!(ogd.regret.as_ref().unwrap()[3], Some(7.0));
    assert!(d.track.track("theta_bar").unwrap().regret.is_none());
}

#[test]
fn every_track_appears_in_the_tracks_error_and_ctte_plots() {
    let d = data();
    for fig in [tracks_figure(&d), error_figure(&d), ctte_figure(&d)] {
        let drawn = fig.drawn_names();
        for t in &d.track.tracks {
            assert!(
                drawn.contains(&t.name.as_str()),
                "{} lacks track {}",
                fig.name,
                t.name
            );
            assert!(
                fig.legend.iter().any(|l| l.label == t.label()),
                "{} legend lacks {}",
                fig.name,
                t.label()
            );
        }
    }
    assert!(tracks_figure(&d).drawn_names().contains(&"truth"));
    assert!(error_figure(&d).drawn_names().contains(&"crlb"));
}

/// A results directory holding the figure is recognised as a run's, so the
/// next run into it may replace it.
fn assert_recognised(f: &Figure) {
    for ext in ["svg", "png"] {
        let file = format!("{}.{ext}", f.name);
        assert!(
            crate::pipeline::outdir::is_sonarnet_output(&file, false),
            "{file} is not recognised as a plot sonarnet writes"
        );
    }
}

#[test]
fn axis_ranges_include_every_point_of_every_figure() {
    for d in [data(), mc_data(), snapshot_data()] {
        for fig in run_figures(&d) {
            assert_ranges_cover(&fig);
            assert_recognised(&fig);
        }
    }
    for fig in comparison_figures(&data(), &mc_data(), "A", "B") {
        assert_ranges_cover(&fig);
    }
}

#[test]
fn tracks_and_network_maps_have_equal_aspect_and_show_the_geometry() {
    let d = data();
    for fig in [tracks_figure(&d), network_figure(&d)] {
        let p = &fig.panels[0];
        assert!(p.equal_aspect);
        let (w, h) = super::render::plot_area(fig.width, p.height);
        let sx = (p.x_range.1 - p.x_range.0) / w;
        let sy = (p.y_range.1 - p.y_range.0) / h;
        assert_abs_diff_eq!(sx / sy, 1.0, epsilon = 1e-9);
        for r in &d.info.receivers {
            assert!(p.contains((r[0], r[1])));
        }
        for t in &d.info.transmitters {
            assert!(p.contains((t[0], t[1])));
        }
        let edges = p.series.iter().filter(|s| s.name == "edge").count();
        assert_eq!(edges, d.info.edges.len(), "{}", fig.name);
    }
}

#[test]
fn the_equal_aspect_layout_matches_what_plotters_draws() {
    for (w, h) in [(1000, 700), (1000, 420), (1200, 900)] {
        let (pw, ph) = super::render::plot_area(w, h);
        let (mw, mh) = super::render::measured_plot_area(w, h);
        assert!((pw - mw as f64).abs() <= 1.0, "width {pw} vs {mw}");
        assert!((ph - mh as f64).abs() <= 1.0, "height {ph} vs {mh}");
    }
}

#[test]
fn bound_discs_surround_theta_bar_where_the_bound_exists() {
    let d = data();
    let fig = tracks_figure(&d);
    let discs = &fig.panels[0].discs;
    let est = d.track.track(THETA_BAR).unwrap();
    // 4 samples: every sample gets a disc where the radius is given.
    let minball: Vec<&Disc> = discs.iter().filter(|x| x.name == "bound_minball").collect();
    let bbox: Vec<&Disc> = discs.iter().filter(|x| x.name == "bound_bbox").collect();
    assert_eq!(minball.len(), 4);
    assert_eq!(bbox.len(), 2);
    let p = est.pos[1].unwrap();
    assert_eq!(bbox[0].center, (p[0], p[1]));
    assert_abs_diff_eq!(bbox[0].radius, 420.0);
}

#[test]
fn error_plot_marks_the_burn_in_and_uses_a_log_axis_for_wide_ranges() {
    let fig = error_figure(&data());
    let p = &fig.panels[0];
    assert_eq!(p.vlines.len(), 1);
    assert_abs_diff_eq!(p.vlines[0].x, 1.0);
    // Errors span 1 .. 707 m: log scale.
    assert!(p.log_y);
}

#[test]
fn monte_carlo_runs_draw_mean_curves_with_percentile_bands() {
    let d = mc_data();
    for fig in [error_figure(&d), ctte_figure(&d)] {
        let p = &fig.panels[0];
        let bands: Vec<&str> = p.bands.iter().map(|b| b.name.as_str()).collect();
        assert!(
            bands.contains(&"theta_bar") && bands.contains(&"ogd"),
            "{}: {bands:?}",
            fig.name
        );
        // Order: theta_bar, ml, then the others.
        let mc = d.monte_carlo.as_ref().unwrap();
        assert_eq!(mc.curves[0].name, "theta_bar");
        assert_eq!(mc.curves[1].name, "ml");
        // The null at sample 2 ends every curve at sample 1.
        for s in &p.series {
            for seg in &s.segments {
                assert!(seg.iter().all(|q| q.0 <= 1.0));
            }
        }
    }
    // theta_bar has regret curves: a second panel.
    assert_eq!(ctte_figure(&d).panels.len(), 2);
}

#[test]
fn consensus_plot_uses_iterations_when_traced() {
    let mut d = data();
    let by_sample = consensus_figure(&d);
    assert_eq!(by_sample.panels[0].x_label, "sample k");
    assert_eq!(by_sample.panels.len(), 3);
    let nodes: Vec<&str> = by_sample.panels[0]
        .series
        .iter()
        .map(|s| s.name.as_str())
        .filter(|n| n.starts_with("node "))
        .collect();
    assert_eq!(nodes, ["node 0", "node 1", "node 2"]);
    // Two samples x 3 iterations x 3 nodes, iteration counted per sample.
    let mut it = Vec::new();
    for s in 0..2 {
        for i in 0..3u64 {
            for n in 0..3 {
                it.push(NodePoint {
                    sample: s,
                    iteration: Some(i),
                    node: n,
                    pos: [i as f64, n as f64, 0.0],
                });
            }
        }
    }
    d.iterations = Some(it);
    let fig = consensus_figure(&d);
    assert!(fig.panels[0].x_label.starts_with("iteration"));
    // 6 distinct (sample, iteration) keys -> x in 0..=5.
    let xs: Vec<f64> = fig.panels[0].series[0].segments[0]
        .iter()
        .map(|q| q.0)
        .collect();
    assert_eq!(xs, [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
    assert_ranges_cover(&fig);
}

#[test]
fn a_run_without_samples_still_renders_every_figure_with_a_note() {
    let mut d = data();
    d.track = parse_track_csv(
        Path::new("track.csv"),
        &csv_of("sample,true_x,true_y,est_x,est_y,error,ml_x,ml_y,crlb,ctte,seed\n"),
    )
    .unwrap();
    d.nodes.clear();
    d.metrics = None;
    for fig in run_figures(&d) {
        assert_ranges_cover(&fig);
        let svg = render_svg(&fig).unwrap();
        assert!(svg.contains("<svg"), "{}", fig.name);
        if fig.name != "tracks" {
            assert!(
                fig.panels.iter().any(|p| p.note.is_some()),
                "{} has no note",
                fig.name
            );
        }
    }
}

#[test]
fn svg_and_png_rendering_produce_images_with_titles_and_axis_labels() {
    let d = data();
    let dir = std::env::temp_dir().join(format!("sonarnet-plot-unit-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for fig in run_figures(&d) {
        let svg = render_svg(&fig).unwrap();
        assert!(svg.trim_start().starts_with("<svg"), "{}", fig.name);
        assert!(svg.contains(&format!("width=\"{}\"", fig.width)));
        for p in &fig.panels {
            assert!(
                svg.contains(&super::super::report::esc(&p.x_label)),
                "{}: {}",
                fig.name,
                p.x_label
            );
        }
        let png = dir.join(format!("{}.png", fig.name));
        render_png(&fig, &png).unwrap();
        let bytes = std::fs::read(&png).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn summary_json_with_a_curve_of_the_wrong_length_is_rejected_naming_the_key() {
    let v = json!({"sample": [0, 1], "curves": {"ogd": {"error": {"mean": [1], "p5": [1, 2], "p95": [1, 2]}}}});
    let e = parse_summary(Path::new("summary.json"), &v).unwrap_err();
    assert_eq!(e.location.as_deref(), Some("curves.ogd.error.mean"));
    assert!(e.reason.contains("has 1 entries but `sample` has 2"), "{e}");
}

#[test]
fn track_csv_with_a_bad_number_names_line_and_column() {
    let e = parse_track_csv(
        Path::new("track.csv"),
        &csv_of("sample,est_x,est_y\n0,1,2\n1,abc,2\n"),
    )
    .unwrap_err();
    assert_eq!(e.location.as_deref(), Some("line 3, column est_x"));
    assert!(e.reason.contains("`abc`"));
}

#[test]
fn load_run_rejects_a_directory_that_is_not_a_run_and_names_missing_files() {
    let dir = std::env::temp_dir().join(format!("sonarnet-plot-load-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let e = load_run(&dir).unwrap_err();
    assert!(e.reason.contains("no run.json"), "{e}");
    std::fs::write(dir.join("run.json"), r#"{"scenario": {"name": "x"}}"#).unwrap();
    std::fs::write(dir.join("metrics.json"), "{}").unwrap();
    let e = load_run(&dir).unwrap_err();
    assert_eq!(e.file, dir.join("track.csv"));
    assert!(e.reason.contains("missing file"), "{e}");
    let e = load_run(&dir.join("nope")).unwrap_err();
    assert!(e.reason.contains("no such directory"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn discs_are_clipped_to_the_drawn_ranges() {
    let d = Disc {
        name: "b".into(),
        center: (0.0, 0.0),
        radius: 10.0,
        color: Rgb(0, 0, 0),
    };
    let poly = super::render::disc_polygon_for_test(&d, (-5.0, 20.0), (-20.0, 3.0));
    assert!(!poly.is_empty());
    for (x, y) in poly {
        assert!((-5.0 - 1e-9..=20.0 + 1e-9).contains(&x));
        assert!((-20.0 - 1e-9..=3.0 + 1e-9).contains(&y));
        assert!(x.hypot(y) <= 10.0 + 1e-9);
    }
}

#[test]
fn tick_labels_are_compact() {
    use super::render::tick;
    assert_eq!(tick(1500.0), "1500");
    assert_eq!(tick(2.5), "2.5");
    assert_eq!(tick(-0.0), "0");
    assert_eq!(tick(1e7), "1.0e7");
}

/// A messages.csv: two requests delivered on link 0 -> 1 and 1 -> 0, the
/// same request size lost on 0 -> 1 (collision), and an accept lost late.
const MESSAGES: &str = "\
t_send,t_recv,from,to,kind,bits,fate,reason,seed
1.0,3.0,0,1,request,240,delivered,,7
2.5,4.0,1,0,accept,240,delivered,,7
5.0,,0,1,request,240,lost,collision,7
6.0,,1,0,decline,48,lost,late,7
";

/// `messages.svg`: one line per node, an arrow per delivered frame from
/// (send, sender) to (arrival, addressee), and a lost frame drawn to where it
/// would have arrived (the delay of a delivered frame of its size on its
/// link, else of its link) with a cross and its reason; `channel.svg` puts
/// each link at its length. Neither exists off the acoustic channel.
#[test]
fn the_channel_figures_draw_each_frame_where_the_channel_put_it() {
    let mut d = data();
    assert!(messages_figure(&d).is_none() && channel_figure(&d).is_none());
    let msgs = parse_messages(Path::new("messages.csv"), &csv_of(MESSAGES)).unwrap();
    assert_eq!(msgs[2].reason.as_deref(), Some("collision"));
    d.messages = Some(msgs);
    let f = messages_figure(&d).unwrap();
    let p = &f.panels[0];
    let seg = |name: &str| -> Vec<Vec<(f64, f64)>> {
        p.series
            .iter()
            .filter(|s| s.name == name)
            .map(|s| s.segments[0].clone())
            .collect()
    };
    assert_eq!(seg("node 0").len(), 1);
    assert_eq!(seg("request"), vec![vec![(1.0, 0.0), (3.0, 1.0)]]);
    // Lost at 5.0: the delay of the delivered 240-bit request on 0 -> 1 (2 s).
    assert_eq!(seg("lost request head"), vec![vec![(7.0, 1.0)]]);
    // Lost at 6.0: no 48-bit frame delivered on 1 -> 0; that link's 1.5 s.
    assert_eq!(seg("lost decline head"), vec![vec![(7.5, 0.0)]]);
    assert!(p.labels.iter().any(|l| l.lines == ["late"]));
    for pt in p.points() {
        assert!(p.contains(pt), "{pt:?} outside the ranges");
    }
    // channel.svg from metrics.json's links: 0 -> 1 is 2500 m long.
    d.metrics = Some(
        crate::pipeline::RunMetrics::from_json(json!({"channel": {
            "frames": 4, "delivered": 2, "delivery_ratio": 0.5, "lost": {},
            "links": [{"from": 0, "to": 1, "frames": 2, "delivery_ratio": 0.5}],
            "delay_mean_s": 1.75, "delay_p99_s": 2.0, "exchanges_attempted": 2,
            "exchanges_completed": 1, "exchanges_timed_out": 0, "bits_sent": 768,
            "emulated_seconds": 10.0, "realtime_factor": 1.0, "events": 0,
            "events_per_second": 0.0}}))
        .unwrap(),
    );
    let c = channel_figure(&d).unwrap();
    assert_eq!(c.panels[0].series[0].segments, vec![vec![(2500.0, 0.5)]]);
    assert!(c.panels[0].contains((2500.0, 0.5)));
    // A bad cell names its line and column.
    let bad = MESSAGES.replace("6.0,,1,0,decline", "6.0,,1,x,decline");
    let e = parse_messages(Path::new("messages.csv"), &csv_of(&bad)).unwrap_err();
    assert!(e.to_string().contains("line 5, column to"), "{e}");
}

mod clipping {
    use super::render::clip_polyline;
    use proptest::prelude::*;

    #[test]
    fn a_polyline_inside_the_plot_is_drawn_whole_and_one_leaving_it_is_cut_at_the_edge() {
        let inside = vec![(0.1, 0.1), (0.5, 0.9), (0.9, 0.2)];
        assert_eq!(
            clip_polyline(&inside, (0.0, 1.0), (0.0, 1.0), false),
            vec![inside.clone()]
        );
        // Out through the top at x = 0.5, back in at x = 1.5.
        let out = clip_polyline(
            &[(0.0, 0.5), (1.0, 1.5), (2.0, 0.5)],
            (0.0, 2.0),
            (0.0, 1.0),
            false,
        );
        assert_eq!(
            out,
            vec![vec![(0.0, 0.5), (0.5, 1.0)], vec![(1.5, 1.0), (2.0, 0.5)]]
        );
        // Entirely outside: nothing.
        assert!(clip_polyline(&[(5.0, 5.0), (6.0, 7.0)], (0.0, 1.0), (0.0, 1.0), false).is_empty());
        // A log axis cuts where the straight line in log y meets the edge.
        let l = clip_polyline(&[(0.0, 1.0), (1.0, 1000.0)], (0.0, 1.0), (1.0, 100.0), true);
        approx::assert_relative_eq!(l[0][1].0, 2.0 / 3.0, max_relative = 1e-12);
        approx::assert_relative_eq!(l[0][1].1, 100.0, max_relative = 1e-12);
    }

    proptest! {
        #[test]
        fn every_clipped_point_lies_in_the_plot_and_on_the_polyline(
            pts in proptest::collection::vec((-3.0f64..3.0, -3.0f64..3.0), 2..12)
        ) {
            let pieces = clip_polyline(&pts, (-1.0, 1.0), (-1.0, 1.0), false);
            for piece in &pieces {
                prop_assert!(piece.len() >= 2);
                for q in piece {
                    prop_assert!(q.0.abs() <= 1.0 + 1e-9 && q.1.abs() <= 1.0 + 1e-9, "{q:?}");
                    // On some segment of the input.
                    let on = pts.windows(2).any(|w| {
                        let (a, b) = (w[0], w[1]);
                        let cross = (b.0 - a.0) * (q.1 - a.1) - (b.1 - a.1) * (q.0 - a.0);
                        let within = q.0 >= a.0.min(b.0) - 1e-9 && q.0 <= a.0.max(b.0) + 1e-9
                            && q.1 >= a.1.min(b.1) - 1e-9 && q.1 <= a.1.max(b.1) + 1e-9;
                        cross.abs() <= 1e-9 * (1.0 + (b.0 - a.0).hypot(b.1 - a.1)) && within
                    });
                    prop_assert!(on, "{q:?} not on {pts:?}");
                }
            }
            // Points inside stay: each inside vertex appears in some piece.
            for p in pts.iter().filter(|p| p.0.abs() < 1.0 && p.1.abs() < 1.0) {
                prop_assert!(pieces.iter().flatten().any(|q| q == p), "{p:?} lost");
            }
        }
    }

    #[test]
    fn log_ticks_label_one_two_five_on_short_axes_and_decades_on_long_ones() {
        use super::render::log_ticks;
        assert_eq!(
            log_ticks((0.3, 60.0)),
            vec![0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0]
        );
        assert_eq!(log_ticks((1e-9, 1e3)).len(), 13);
        assert!(log_ticks((0.0, 1.0)).is_empty());
    }
}

#[test]
fn a_diverging_track_is_clipped_at_the_scene_and_named_not_allowed_to_rescale_the_map() {
    let mut d = data();
    let ogd = d.track.tracks.iter_mut().find(|t| t.name == "ogd").unwrap();
    ogd.pos[3] = Some([1.3e89, -2.0e88, 0.0]);
    let fig = tracks_figure(&d);
    let p = &fig.panels[0];
    // The scene is a few km: the axes stay within a few scene sizes.
    assert!(p.x_range.1 - p.x_range.0 < 1e5, "{:?}", p.x_range);
    assert!(
        p.caption
            .as_deref()
            .unwrap_or("")
            .contains("ogd (1 samples)"),
        "{:?}",
        p.caption
    );
    assert!(fig.legend.iter().any(|l| l.label.contains("off the map")));
    // Drawn lines stay in the plot area.
    for s in &p.series {
        for seg in &s.segments {
            for piece in super::render::clip_polyline(seg, p.x_range, p.y_range, p.log_y) {
                assert!(piece.iter().all(|q| p.contains(*q)));
            }
        }
    }
}

#[test]
fn a_png_of_a_track_that_doubles_back_draws_nothing_outside_its_plot() {
    // A noisy track reversing at sharp angles: the bitmap backend's wide
    // path joins would spike across the title and the margins.
    let mut seg = Vec::new();
    for k in 0..400 {
        let t = k as f64;
        seg.push((1.0 + 0.3 * (t * 2.1).sin(), 1.0 + 0.3 * (t * 3.7).cos()));
    }
    let mut panel = Panel::new(500, "x", "y");
    panel.x_range = (0.0, 2.0);
    panel.y_range = (0.0, 2.0);
    panel.series.push(Series {
        name: "zigzag".into(),
        segments: vec![seg],
        style: Style::line(Rgb(200, 0, 0), 3),
    });
    let fig = Figure {
        name: "zigzag".into(),
        title: String::new(),
        width: 800,
        panels: vec![panel],
        legend: vec![],
    };
    let dir = std::env::temp_dir().join(format!("sonarnet-png-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("zigzag.png");
    render_png(&fig, &path).unwrap();
    let mut r = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()))
        .read_info()
        .unwrap();
    let mut buf = vec![0; r.output_buffer_size()];
    let info = r.next_frame(&mut buf).unwrap();
    let bpp = info.color_type.samples();
    let red = |x: usize, y: usize| {
        let i = (y * info.width as usize + x) * bpp;
        buf[i] > 150 && buf[i + 1] < 100 && buf[i + 2] < 100
    };
    // The title band and the legend column hold no red.
    let title_h = super::render::TITLE_H as usize;
    for y in 0..title_h {
        for x in 0..info.width as usize {
            assert!(!red(x, y), "red at ({x}, {y}) in the title band");
        }
    }
    let legend_x = 800 - super::render::LEGEND_W as usize;
    for y in 0..info.height as usize {
        for x in legend_x..800 {
            assert!(!red(x, y), "red at ({x}, {y}) in the legend column");
        }
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn monte_carlo_bands_are_few_and_each_has_a_swatch_in_its_own_colour() {
    let mut d = mc_data();
    let mc = d.monte_carlo.as_mut().unwrap();
    // Seven tracks with bands.
    let ogd = mc.curves.iter().find(|c| c.name == "ogd").unwrap().clone();
    for i in 0..4 {
        let mut c = ogd.clone();
        c.name = format!("b{i}");
        mc.curves.push(c);
    }
    let fig = error_figure(&d);
    let p = &fig.panels[0];
    assert_eq!(p.bands.len(), super::figures::MAX_BANDS);
    assert_eq!(p.bands[0].name, "theta_bar");
    for b in &p.bands {
        assert!(
            fig.legend
                .iter()
                .any(|l| l.swatch == Swatch::Area(b.color) && l.label.contains("percentile")),
            "no swatch for the {} band",
            b.name
        );
    }
    assert!(
        p.caption
            .as_deref()
            .unwrap_or("")
            .contains("first 3 tracks")
    );
}

#[test]
fn the_comparison_tells_run_b_from_run_a_by_colour_as_well_as_dashes() {
    let (a, b) = (data(), data());
    for f in comparison_figures(&a, &b, "A", "B") {
        let s = &f.panels[0].series;
        for sa in s.iter().filter(|x| x.name.starts_with("A: ")) {
            let name = &sa.name[3..];
            let sb = s.iter().find(|x| x.name == format!("B: {name}")).unwrap();
            assert!(sb.style.dashed && !sa.style.dashed);
            assert_ne!(sa.style.color, sb.style.color, "{name} in {}", f.name);
        }
    }
}

#[test]
fn network_labels_move_off_a_transmitter_beside_their_node() {
    let mut d = data();
    // A transmitter just right of R1, where its label would go.
    d.info.transmitters.push([1700.0, -1050.0, 0.0]);
    let fig = network_figure(&d);
    let p = &fig.panels[0];
    let r1 = p
        .labels
        .iter()
        .find(|l| l.lines[0].starts_with("R1"))
        .unwrap();
    assert_ne!(
        r1.offset,
        (15, -8),
        "the label still covers the transmitter"
    );
}

/// A Monte Carlo run of one snapshot per trial (Gholami 2015 style): three
/// trials, with bounds on `pocs`.
fn snapshot_data() -> RunData {
    let mut d = data();
    let band = |v: f64| json!({"mean": [v], "p5": [v], "p95": [v]});
    let summary = json!({
        "trials": 3,
        "sample": [0],
        "curves": {"theta_bar": {"error": band(1.0)}, "ml": {"error": band(1.2)}, "pocs": {"error": band(0.9)}},
    });
    let mut mc = parse_summary(Path::new("summary.json"), &summary).unwrap();
    mc.trial_columns = [
        "trial",
        "seed",
        "crlb_rms",
        "theta_bar.rmse",
        "theta_bar.error_x",
        "theta_bar.error_y",
        "ml.rmse",
        "pocs.rmse",
        "pocs.bounds.upp_rbbox.rel_tightness_median",
        "pocs.bounds.upp_maxdis.rel_tightness_median",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    mc.trial_rows = [
        [0.0, 0.0, 0.7, 0.5, 0.3, -0.4, 0.6, 0.4, 1.2, 0.8],
        [1.0, 1.0, 0.7, 1.0, -0.6, 0.8, 1.1, 0.9, 2.0, 1.1],
        [2.0, 2.0, 0.7, 2.0, 1.2, 1.6, 1.9, 1.5, 0.9, 0.4],
    ]
    .iter()
    .map(|r| r.iter().map(|v| Some(*v)).collect())
    .collect();
    d.monte_carlo = Some(mc);
    d
}

#[test]
fn a_snapshot_monte_carlo_run_draws_error_cdfs_tightness_cdfs_and_a_scatter_not_empty_time_series()
{
    let d = snapshot_data();
    let figs = run_figures(&d);
    let names: Vec<&str> = figs.iter().map(|f| f.name.as_str()).collect();
    assert!(
        !names.contains(&"error") && !names.contains(&"ctte"),
        "{names:?}"
    );
    for f in &figs {
        assert_recognised(f);
    }
    for want in ["error-cdf", "tightness", "scatter"] {
        let f = figs
            .iter()
            .find(|f| f.name == want)
            .unwrap_or_else(|| panic!("no {want} in {names:?}"));
        assert!(
            f.panels.iter().all(|p| p.note.is_none()),
            "{want}: {:?}",
            f.panels[0].note
        );
        assert!(!f.legend.is_empty(), "{want}");
        assert_ranges_cover(f);
    }
    let cdf = figs.iter().find(|f| f.name == "error-cdf").unwrap();
    let tb = cdf.panels[0]
        .series
        .iter()
        .find(|s| s.name == "theta_bar")
        .expect("theta_bar's CDF");
    // The staircase of three errors ends at (2.0, 1.0) and climbs in thirds.
    assert_eq!(tb.segments[0].last(), Some(&(2.0, 1.0)));
    assert!(tb.segments[0].contains(&(1.0, 2.0 / 3.0)));
    let scatter = figs.iter().find(|f| f.name == "scatter").unwrap();
    let pts = &scatter.panels[0]
        .series
        .iter()
        .find(|s| s.name == "theta_bar")
        .unwrap()
        .segments[0];
    assert_eq!(pts, &vec![(0.3, -0.4), (-0.6, 0.8), (1.2, 1.6)]);
    let tight = figs.iter().find(|f| f.name == "tightness").unwrap();
    assert_eq!(tight.panels[0].series.len(), 2);
}

#[test]
fn the_title_of_a_monte_carlo_run_names_its_seeds_not_seed_0() {
    let d = snapshot_data();
    assert!(d.title().contains("seeds 7..9"), "{}", d.title());
    assert!(!d.title().contains("seed 7)"), "{}", d.title());
}
