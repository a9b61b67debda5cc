//! `network.svg`: the gossip graph, each node coloured by its share of the work.

use crate::plot::Figure;
use crate::plot::Label;
use crate::plot::LegendItem;
use crate::plot::Marker;
use crate::plot::Panel;
use crate::plot::Rgb;
use crate::plot::Series;
use crate::plot::Style;
use crate::plot::Swatch;
use crate::plot::data::RunData;
use crate::plot::figures::WIDTH;
use crate::plot::figures::draw_geometry;
use crate::plot::figures::fit_map;
use crate::plot::figures::geometry_points;
use crate::plot::figures::linear_range;

/// Sequential light-to-dark blue for `t` in `[0, 1]`.
pub(super) fn heat(t: f64) -> Rgb {
    let t = t.clamp(0.0, 1.0);
    let lerp = |a: f64, b: f64| (a + (b - a) * t).round() as u8;
    Rgb(lerp(222.0, 8.0), lerp(235.0, 69.0), lerp(247.0, 148.0))
}

/// Most nodes drawn with a label each.
pub const MAX_LABELLED_NODES: usize = 256;

/// `network.svg`: the graph to scale, each node coloured by its prox solves
/// and labelled with its counters (prox solves, messages out/in, declines;
/// one line past ten nodes, none past [`MAX_LABELLED_NODES`]). Linear in the
/// nodes and edges.
pub fn network_figure(data: &RunData) -> Figure {
    let mut panel = Panel::new(700, "x (m)", "y (m)");
    let mut legend = Vec::new();
    let rx = &data.info.receivers;
    let counters = data.node_counters();
    // Edges and transmitters, without the plain receiver markers.
    let mut geo = Vec::new();
    draw_geometry(data, &mut panel, &mut geo, true);
    panel.series.retain(|s| s.name != "receivers");
    panel.labels.retain(|l| !l.lines[0].starts_with('R'));
    geo.retain(|g| !g.label.starts_with("receiver"));
    legend.extend(geo);
    // Every node's counters by id, in one pass (linear in the nodes).
    let mut by_node = vec![None; rx.len()];
    for c in counters {
        if let Some(slot) = by_node.get_mut(c.node) {
            *slot = Some(c.counters);
        }
    }
    let prox: Vec<Option<u64>> = by_node.iter().map(|c| c.map(|c| c.prox_solves)).collect();
    let lo = prox.iter().flatten().copied().min().unwrap_or(0) as f64;
    let hi = prox.iter().flatten().copied().max().unwrap_or(0) as f64;
    // Four-line counter labels need room: with many or crowded nodes, one
    // line (id and prox solves) each.
    let span = {
        let pts = geometry_points(data);
        let x = linear_range(pts.iter().map(|p| p.0), 0.0);
        let y = linear_range(pts.iter().map(|p| p.1), 0.0);
        (x.1 - x.0).max(y.1 - y.0)
    };
    // The closest pair decides only for ten nodes or fewer.
    let closest = || {
        rx.iter()
            .enumerate()
            .flat_map(|(i, a)| {
                rx[i + 1..]
                    .iter()
                    .map(move |b| (a[0] - b[0]).hypot(a[1] - b[1]))
            })
            .fold(f64::INFINITY, f64::min)
    };
    let compact = rx.len() > 10 || closest() < 0.15 * span;
    // Past this many nodes a label per node is unreadable: the markers
    // (coloured by prox solves) stand alone.
    let labelled = rx.len() <= MAX_LABELLED_NODES;
    for (i, p) in rx.iter().enumerate() {
        let c = by_node[i];
        let color = match prox[i] {
            Some(v) if hi > lo => heat(0.15 + 0.85 * (v as f64 - lo) / (hi - lo)),
            Some(_) => heat(0.6),
            None => Rgb(200, 200, 200),
        };
        panel.series.push(Series {
            name: format!("node {i}"),
            segments: vec![vec![(p[0], p[1])]],
            style: Style::markers(color, Marker::Circle, 11),
        });
        let mut lines = vec![format!("R{i}")];
        if let Some(c) = c {
            if compact {
                lines[0] = format!("R{i} · {}", c.prox_solves);
            } else {
                lines.push(format!("prox {}", c.prox_solves));
                lines.push(format!("msg {}↑ {}↓", c.messages_out, c.messages_in));
                lines.push(format!("declines {}", c.declines));
            }
        }
        if labelled {
            panel.labels.push(Label {
                at: (p[0], p[1]),
                offset: (15, -8),
                lines,
                size: 15,
            });
        }
    }
    legend.push(LegendItem {
        label: if hi > lo {
            format!("node: prox solves {lo:.0} (light) – {hi:.0} (dark)")
        } else {
            "node (receiver)".into()
        },
        swatch: Swatch::Line(Style::markers(heat(0.6), Marker::Circle, 6)),
    });
    if compact && labelled && !counters.is_empty() {
        legend.push(LegendItem {
            label: "label: R<node> · prox solves (all counters in the report's table)".into(),
            swatch: Swatch::Line(Style::line(Rgb(255, 255, 255), 0)),
        });
    }
    let pts = geometry_points(data);
    // Room on the right for the counter labels.
    let x = linear_range(pts.iter().map(|p| p.0), 0.08);
    let x = (x.0, x.1 + 0.25 * (x.1 - x.0));
    let y = linear_range(pts.iter().map(|p| p.1), 0.1);
    let y = (y.0 - 0.12 * (y.1 - y.0), y.1);
    fit_map(&mut panel, x, y, 420, 820);
    place_labels(&mut panel, &data.info.transmitters, rx);
    if rx.is_empty() {
        panel.note = Some("run.json has no receiver positions".into());
    } else if counters.is_empty() {
        panel.note = Some("metrics.json has no per-node counters".into());
    }
    Figure {
        name: "network".into(),
        title: format!("Network and per-node counters — {}", data.title()),
        width: WIDTH,
        panels: vec![panel],
        legend,
    }
}

/// A label's box in pixels relative to its anchor: `(x0, y0, x1, y1)`, y
/// down (the text's top-left corner is at the label's offset).
fn label_box(l: &Label, offset: (i32, i32)) -> (f64, f64, f64, f64) {
    let chars = l.lines.iter().map(|t| t.chars().count()).max().unwrap_or(0) as f64;
    // DejaVu Sans averages about 0.56 em per character on these labels
    // (digits, arrows): a wider guess leaves a left-hand label floating
    // away from its marker.
    let w = chars * 0.56 * l.size as f64;
    let h = l.lines.len() as f64 * 1.25 * l.size as f64;
    let (x, y) = (offset.0 as f64, offset.1 as f64);
    (x, y, x + w, y + h)
}

/// Put each receiver's label on the side of its marker where it covers no
/// transmitter or receiver marker and no label placed before it (right,
/// then left, above or below); the first side if none is free.
pub(crate) fn place_labels(
    panel: &mut Panel,
    transmitters: &[crate::plot::data::Pos],
    receivers: &[crate::plot::data::Pos],
) {
    let (pw, ph) = crate::plot::render::plot_area(WIDTH, panel.height);
    let sx = pw / (panel.x_range.1 - panel.x_range.0).max(1e-300);
    let sy = ph / (panel.y_range.1 - panel.y_range.0).max(1e-300);
    let px = |p: (f64, f64)| ((p.0 - panel.x_range.0) * sx, (panel.y_range.1 - p.1) * sy);
    let markers: Vec<(f64, f64)> = transmitters
        .iter()
        .chain(receivers)
        .map(|p| px((p[0], p[1])))
        .collect();
    let mut placed: Vec<(f64, f64, f64, f64)> = Vec::new();
    let overlaps = |a: (f64, f64, f64, f64), b: (f64, f64, f64, f64)| {
        a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
    };
    for l in panel
        .labels
        .iter_mut()
        .filter(|l| !l.lines.is_empty() && l.lines[0].starts_with('R'))
    {
        let at = px(l.at);
        let (w, h) = {
            let b = label_box(l, (0, 0));
            (b.2, b.3)
        };
        let (w, h) = (w as i32, h as i32);
        let candidates = [
            (15, -8),
            (-w - 12, -8),
            (15, -h - 10),
            (-w - 12, -h - 10),
            (-w / 2, 12),
            (-w / 2, -h - 14),
        ];
        let free = |o: (i32, i32)| {
            let b = label_box(l, o);
            let b = (b.0 + at.0, b.1 + at.1, b.2 + at.0, b.3 + at.1);
            let r = 9.0;
            markers
                .iter()
                .all(|m| !overlaps(b, (m.0 - r, m.1 - r, m.0 + r, m.1 + r)))
                && placed.iter().all(|q| !overlaps(b, *q))
        };
        let o = candidates
            .iter()
            .copied()
            .find(|o| free(*o))
            .unwrap_or(candidates[0]);
        let b = label_box(l, o);
        placed.push((b.0 + at.0, b.1 + at.1, b.2 + at.0, b.3 + at.1));
        l.offset = o;
    }
}
