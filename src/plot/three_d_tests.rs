//! The plots of a 3-D run: `z` columns and `[x, y, z]` points are read,
//! distances and the disagreement are 3-D, `depth.svg` draws depth against
//! the sample and the x-z section, and 2-D runs get no depth figure.

use super::data::*;
use super::figures::*;
use super::tests::csv_of;
use approx::assert_relative_eq;
use serde_json::json;
use std::path::Path;

/// A 3-D track.csv: truth, theta_bar, ML and a baseline without error
/// columns (its error is computed from the positions).
const TRACK_3D: &str = "\
sample,true_x,true_y,true_z,est_x,est_y,est_z,error,ml_x,ml_y,ml_z,crlb,ctte,ogd_x,ogd_y,ogd_z,seed
0,500,500,-100,503,504,-112,13,501,500,-98,9,13,500,500,-88,1
1,502,501,-101,502,501,-111,10,500,501,-99,9,23,502,505,-98,1
";

/// A position's bits, for exact comparisons.
fn bits(p: Option<Pos>) -> Option<[u64; 3]> {
    p.map(|p| p.map(f64::to_bits))
}

fn run_json_3d() -> serde_json::Value {
    json!({
        "seed": 1, "engine": "inprocess", "mode": "async",
        "edges": [[0, 1]],
        "scenario": {
            "name": "helix",
            "geometry": {
                "transmitters": [[0.0, 0.0, -10.0]],
                "receivers": [[-1000.0, -1000.0, -50.0], [1500.0, -1000.0, -300.0]]
            }
        }
    })
}

fn data_3d() -> RunData {
    let info = parse_run_json(Path::new("run.json"), &run_json_3d()).unwrap();
    let track = parse_track_csv(Path::new("track.csv"), &csv_of(TRACK_3D)).unwrap();
    let nodes_csv = "sample,node,x,y,z,d,alive,seed\n\
                     0,0,500,500,-100,10,true,1\n0,1,500,500,-104,10,true,1\n\
                     1,0,502,501,-101,10,true,1\n1,1,505,505,-101,10,true,1\n";
    let nodes = parse_node_points(Path::new("nodes.csv"), &csv_of(nodes_csv), false).unwrap();
    RunData {
        dir: "unit".into(),
        info,
        track,
        nodes,
        ..RunData::default()
    }
}

#[test]
fn a_3d_run_json_gives_its_points_with_depth_and_mixed_dimensions_are_refused() {
    let info = parse_run_json(Path::new("run.json"), &run_json_3d()).unwrap();
    assert_eq!(info.dim, 3);
    assert_eq!(
        bits(Some(info.receivers[1])),
        bits(Some([1500.0, -1000.0, -300.0]))
    );
    assert_eq!(
        bits(Some(info.transmitters[0])),
        bits(Some([0.0, 0.0, -10.0]))
    );
    let mut mixed = run_json_3d();
    mixed["scenario"]["geometry"]["transmitters"] = json!([[0.0, 0.0]]);
    let e = parse_run_json(Path::new("run.json"), &mixed).unwrap_err();
    assert!(e.to_string().contains("2-D but the receivers 3-D"), "{e}");
    let mut ragged = run_json_3d();
    ragged["scenario"]["geometry"]["receivers"] = json!([[0.0, 0.0, 1.0], [1.0, 2.0]]);
    let e = parse_run_json(Path::new("run.json"), &ragged).unwrap_err();
    assert!(e.to_string().contains("receivers[1]"), "{e}");
}

#[test]
fn a_3d_track_csv_reads_depth_and_computes_missing_errors_in_three_dimensions() {
    let d = data_3d();
    assert_eq!(d.dim(), 3);
    assert_eq!(bits(d.track.truth[1]), bits(Some([502.0, 501.0, -101.0])));
    let est = d.track.track(THETA_BAR).unwrap();
    assert_eq!(bits(est.pos[0]), bits(Some([503.0, 504.0, -112.0])));
    let ogd = d.track.track("ogd").unwrap();
    assert_eq!(ogd.kind, TrackKind::Baseline);
    // No ogd_error column: the 3-D distance to the truth, (0, 0, 12) and
    // (0, 4, 3).
    assert_relative_eq!(ogd.error[0].unwrap(), 12.0, max_relative = 1e-15);
    assert_relative_eq!(ogd.error[1].unwrap(), 5.0, max_relative = 1e-15);
    assert_eq!(
        bits(Some(d.nodes[1].pos)),
        bits(Some([500.0, 500.0, -104.0]))
    );
}

#[test]
fn a_2d_run_has_no_depth_figure_and_its_points_have_zero_depth() {
    let text = "sample,true_x,true_y,est_x,est_y,error,ctte,seed\n0,1,2,1,5,3,3,0\n";
    let track = parse_track_csv(Path::new("track.csv"), &csv_of(text)).unwrap();
    assert_eq!(track.dim, 2);
    assert_eq!(bits(track.truth[0]), bits(Some([1.0, 2.0, 0.0])));
    let d = RunData {
        track,
        ..RunData::default()
    };
    assert_eq!(d.dim(), 2);
    assert!(depth_figure(&d).is_none());
    assert!(run_figures(&d).iter().all(|f| f.name != "depth"));
}

#[test]
fn the_depth_figure_draws_depth_against_the_sample_and_the_x_z_section() {
    let d = data_3d();
    let f = depth_figure(&d).expect("a 3-D run has a depth figure");
    assert_eq!(f.panels.len(), 2);
    let (zt, sec) = (&f.panels[0], &f.panels[1]);
    let series = |p: &super::Panel, name: &str| -> Vec<(f64, f64)> {
        p.series
            .iter()
            .find(|s| s.name == name)
            .unwrap_or_else(|| panic!("no series {name}"))
            .segments
            .concat()
    };
    assert_eq!(series(zt, "truth"), vec![(0.0, -100.0), (1.0, -101.0)]);
    assert_eq!(series(zt, THETA_BAR), vec![(0.0, -112.0), (1.0, -111.0)]);
    assert_eq!(series(sec, "truth"), vec![(500.0, -100.0), (502.0, -101.0)]);
    assert_eq!(
        series(sec, "receivers"),
        vec![(-1000.0, -50.0), (1500.0, -300.0)]
    );
    for p in [zt, sec] {
        assert!(p.points().iter().all(|q| p.contains(*q)), "{p:?}");
    }
    // Depth 10..300 m against 2.5 km across: the section is exaggerated.
    assert!(sec.caption.as_deref().unwrap().contains("vertical scale"));
    let names: Vec<String> = run_figures(&d).into_iter().map(|f| f.name).collect();
    assert_eq!(&names[..2], ["tracks", "depth"]);
}

#[test]
fn the_consensus_of_a_3d_run_has_a_depth_panel_and_a_3d_disagreement() {
    let d = data_3d();
    let f = consensus_figure(&d);
    // x, y, z and the disagreement.
    assert_eq!(f.panels.len(), 4);
    let dis = f.panels[3]
        .series
        .iter()
        .find(|s| s.name == "disagreement")
        .unwrap()
        .segments
        .concat();
    // Sample 0: nodes 4 m apart in z only; sample 1: (3, 4, 0) apart.
    assert_relative_eq!(dis[0].1, 2.0, max_relative = 1e-15);
    assert_relative_eq!(dis[1].1, 2.5, max_relative = 1e-15);
}
