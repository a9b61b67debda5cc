//! `consensus.svg`: every node's estimate against the consensus, sample by sample.

use super::finish_series_panel;
use crate::plot::Figure;
use crate::plot::LegendItem;
use crate::plot::Panel;
use crate::plot::Rgb;
use crate::plot::Series;
use crate::plot::Style;
use crate::plot::Swatch;
use crate::plot::data::NodePoint;
use crate::plot::data::Pos;
use crate::plot::data::RunData;
use crate::plot::data::THETA_BAR;
use crate::plot::figures::BLACK;
use crate::plot::figures::PALETTE;
use crate::plot::figures::WIDTH;
use crate::plot::figures::segments;
use crate::plot::figures::wants_log;

/// Node colours for the consensus plot.
pub(super) const NODE_COLORS: [Rgb; 8] = [
    Rgb(102, 194, 165),
    Rgb(252, 141, 98),
    Rgb(141, 160, 203),
    Rgb(231, 138, 195),
    Rgb(166, 216, 84),
    Rgb(229, 196, 148),
    Rgb(179, 179, 179),
    Rgb(255, 217, 47),
];

/// Thin out a long series to at most `max` points (keeps the last).
pub(super) fn decimate(v: Vec<(f64, f64)>, max: usize) -> Vec<(f64, f64)> {
    if v.len() <= max {
        return v;
    }
    let step = v.len().div_ceil(max);
    let last = v.last().copied();
    let mut out: Vec<(f64, f64)> = v.into_iter().step_by(step).collect();
    if let Some(l) = last
        && out.last() != Some(&l)
    {
        out.push(l);
    }
    out
}

/// `consensus.svg`: every node's position estimate against the sample (or
/// the iteration, from `iterations.csv`), with `theta_bar` and the truth,
/// as Mourya 2017 Fig. 2a; and the disagreement `max_v ||theta_v - theta_bar||`.
pub fn consensus_figure(data: &RunData) -> Figure {
    // Points keyed by a global x: the sample index, or the global iteration.
    let (pts, x_label, by_iteration): (&[NodePoint], &str, bool) = match &data.iterations {
        Some(it) if !it.is_empty() => (it, "iteration (global)", true),
        _ => (&data.nodes, "sample k", false),
    };
    // Global x for each distinct (sample, iteration) key, in order.
    let key = |p: &NodePoint| (p.sample as u64, p.iteration.unwrap_or(0));
    let mut keys: Vec<(u64, u64)> = pts.iter().map(key).collect();
    keys.sort_unstable();
    keys.dedup();
    let xpos = |p: &NodePoint| -> f64 {
        if by_iteration {
            keys.binary_search(&key(p)).unwrap_or(0) as f64
        } else {
            p.sample as f64
        }
    };
    let n_nodes = pts.iter().map(|p| p.node + 1).max().unwrap_or(0);
    let mut per_node: Vec<Vec<(f64, Pos)>> = vec![Vec::new(); n_nodes];
    for p in pts {
        per_node[p.node].push((xpos(p), p.pos));
    }
    for v in &mut per_node {
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    let xs: Vec<f64> = pts.iter().map(xpos).collect();
    let bar = mean_and_disagreement(pts, &xs, n_nodes, data.dim());
    let truth_pts = truth_points(data, &keys, by_iteration);
    let mut legend = Vec::new();
    let mut panels: Vec<Panel> = [(0usize, "x (m)"), (1, "y (m)"), (2, "z (m)")]
        .into_iter()
        .take(data.dim())
        .map(|(axis, label)| {
            let lines = Lines {
                per_node: &per_node,
                bar: &bar,
                truth: &truth_pts,
            };
            coordinate_panel(axis, label, x_label, &lines, &mut legend)
        })
        .collect();
    panels.push(disagreement_panel(x_label, &bar, &mut legend));
    if pts.is_empty() {
        for p in &mut panels {
            p.note = Some("no per-node estimates (nodes.csv is empty or absent)".into());
        }
    }
    Figure {
        name: "consensus".into(),
        title: format!(
            "Per-node estimates against {} — {}",
            if by_iteration {
                "iterations"
            } else {
                "samples"
            },
            data.title()
        ),
        width: WIDTH,
        panels,
        legend,
    }
}

/// At most this many points per line.
const MAX_PTS: usize = 4000;

/// `theta_bar` and the disagreement `max_v ||theta_v - theta_bar||` at each
/// x (`xs[i]` is point `i`'s) where all `n_nodes` nodes reported, in x order.
fn mean_and_disagreement(
    pts: &[NodePoint],
    xs: &[f64],
    n_nodes: usize,
    dim: usize,
) -> Vec<(f64, Pos, f64)> {
    let mut by_x: std::collections::BTreeMap<u64, Vec<Pos>> = Default::default();
    for (p, x) in pts.iter().zip(xs) {
        by_x.entry(x.to_bits()).or_default().push(p.pos);
    }
    let mut bar: Vec<(f64, Pos, f64)> = by_x
        .into_iter()
        .filter(|(_, v)| v.len() == n_nodes && n_nodes > 0)
        .map(|(x, v)| {
            let m: Pos =
                std::array::from_fn(|i| v.iter().map(|p| p[i]).sum::<f64>() / v.len() as f64);
            let d = v
                .iter()
                .map(|p| crate::plot::data::distance(p, &m, dim))
                .fold(0.0, f64::max);
            (f64::from_bits(x), m, d)
        })
        .collect();
    bar.sort_by(|a, b| a.0.total_cmp(&b.0));
    bar
}

/// The true position per sample; with iterations (`keys`: every
/// `(sample, iteration)` in order), a step over the sample's iterations.
fn truth_points(data: &RunData, keys: &[(u64, u64)], by_iteration: bool) -> Vec<(f64, Pos)> {
    let truth_at = |s: usize| -> Option<Pos> {
        data.track
            .sample
            .iter()
            .position(|k| (*k - s as f64).abs() < 0.5)
            .and_then(|i| data.track.truth[i])
    };
    let mut truth_pts: Vec<(f64, Pos)> = Vec::new();
    if by_iteration {
        for (i, k) in keys.iter().enumerate() {
            if let Some(t) = truth_at(k.0 as usize) {
                truth_pts.push((i as f64, t));
            }
        }
    } else {
        for (i, k) in data.track.sample.iter().enumerate() {
            if let Some(t) = data.track.truth[i] {
                truth_pts.push((*k, t));
            }
        }
    }
    truth_pts
}

/// The lines of a coordinate panel: every node's, `theta_bar`'s, the truth's.
struct Lines<'a> {
    per_node: &'a [Vec<(f64, Pos)>],
    bar: &'a [(f64, Pos, f64)],
    truth: &'a [(f64, Pos)],
}

/// The panel of coordinate `axis` (0: x, 1: y); the first one adds the
/// legend's entries.
fn coordinate_panel(
    axis: usize,
    label: &str,
    x_label: &str,
    lines: &Lines<'_>,
    legend: &mut Vec<LegendItem>,
) -> Panel {
    let (per_node, bar, truth_pts) = (lines.per_node, lines.bar, lines.truth);
    let mut p = Panel::new(330, x_label, &format!("node estimate {label}"));
    for (v, pts) in per_node.iter().enumerate() {
        let st = Style::line(NODE_COLORS[v % NODE_COLORS.len()], 1).alpha(0.9);
        p.series.push(Series {
            name: format!("node {v}"),
            segments: vec![decimate(
                pts.iter().map(|q| (q.0, q.1[axis])).collect(),
                MAX_PTS,
            )],
            style: st,
        });
        if axis == 0 {
            legend.push(LegendItem {
                label: format!("node {v}"),
                swatch: Swatch::Line(Style::line(st.color, 2)),
            });
        }
    }
    let bar_st = Style::line(PALETTE[0], 2);
    p.series.push(Series {
        name: THETA_BAR.into(),
        segments: vec![decimate(
            bar.iter().map(|q| (q.0, q.1[axis])).collect(),
            MAX_PTS,
        )],
        style: bar_st,
    });
    let tr_st = Style::line(BLACK, 2).dashed();
    if !truth_pts.is_empty() {
        p.series.push(Series {
            name: "truth".into(),
            segments: vec![decimate(
                truth_pts.iter().map(|q| (q.0, q.1[axis])).collect(),
                MAX_PTS,
            )],
            style: tr_st,
        });
    }
    if axis == 0 {
        legend.push(LegendItem {
            label: "mean of the nodes".into(),
            swatch: Swatch::Line(bar_st),
        });
        if !truth_pts.is_empty() {
            legend.push(LegendItem {
                label: "true position".into(),
                swatch: Swatch::Line(tr_st),
            });
        }
    }
    for s in &mut p.series {
        s.segments.retain(|g| !g.is_empty());
    }
    finish_series_panel(&mut p, false, false);
    p
}

/// The disagreement panel (log-scaled when it spans decades).
fn disagreement_panel(
    x_label: &str,
    bar: &[(f64, Pos, f64)],
    legend: &mut Vec<LegendItem>,
) -> Panel {
    let mut dis = Panel::new(300, x_label, "disagreement (m)");
    let dis_st = Style::line(Rgb(90, 90, 90), 2);
    dis.series.push(Series {
        name: "disagreement".into(),
        segments: segments(
            &bar.iter().map(|q| q.0).collect::<Vec<_>>(),
            &bar.iter().map(|q| Some(q.2)).collect::<Vec<_>>(),
            false,
        )
        .into_iter()
        .map(|s| decimate(s, MAX_PTS))
        .collect(),
        style: dis_st,
    });
    legend.push(LegendItem {
        label: "disagreement".into(),
        swatch: Swatch::Line(dis_st),
    });
    let log = wants_log(dis.points().into_iter().map(|p| p.1));
    if log {
        dis.y_label = "disagreement (m, log)".into();
    }
    finish_series_panel(&mut dis, log, !log);
    dis
}
