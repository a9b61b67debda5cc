//! The acoustic channel's figures: `messages.svg`, a
//! message-sequence diagram of the first frames, and `channel.svg`, the
//! delivery ratio against link length.

use crate::plot::Figure;
use crate::plot::Label;
use crate::plot::LegendItem;
use crate::plot::Marker;
use crate::plot::Panel;
use crate::plot::Rgb;
use crate::plot::Series;
use crate::plot::Style;
use crate::plot::Swatch;
use crate::plot::data::MessageRow;
use crate::plot::data::RunData;
use crate::plot::figures::BLACK;
use crate::plot::figures::PALETTE;
use crate::plot::figures::WIDTH;
use crate::plot::figures::linear_range;
use std::collections::BTreeMap;

/// Frames drawn in `messages.svg` (the first ones, by send time).
pub const SEQUENCE_FRAMES: usize = 80;

const LOST: Rgb = Rgb(214, 39, 40);

/// The colour of a message kind.
fn kind_color(kind: &str) -> Rgb {
    match kind {
        "request" => PALETTE[0],
        "accept" => PALETTE[2],
        "decline" => PALETTE[9],
        "reflect" => PALETTE[4],
        "average" => PALETTE[1],
        _ => BLACK,
    }
}

/// Where a lost frame would have ended its arrival: the delay of a delivered
/// frame of the same size on the same link (the channel's delay depends on
/// nothing else), else of any frame delivered on that link, else the mean
/// delay of the run.
fn planned_delays(msgs: &[MessageRow]) -> impl Fn(&MessageRow) -> f64 {
    let mut exact: BTreeMap<(usize, usize, u64), f64> = BTreeMap::new();
    let mut link: BTreeMap<(usize, usize), f64> = BTreeMap::new();
    let (mut sum, mut n) = (0.0, 0.0);
    for m in msgs {
        if let Some(t) = m.t_recv {
            let d = t - m.t_send;
            exact.entry((m.from, m.to, m.bits)).or_insert(d);
            link.entry((m.from, m.to)).or_insert(d);
            sum += d;
            n += 1.0;
        }
    }
    let mean = if n > 0.0 { sum / n } else { 1.0 };
    move |m: &MessageRow| {
        exact
            .get(&(m.from, m.to, m.bits))
            .or_else(|| link.get(&(m.from, m.to)))
            .copied()
            .unwrap_or(mean)
    }
}

/// `messages.svg`: the first [`SEQUENCE_FRAMES`] frames of the run as a
/// message-sequence diagram: one horizontal line per node, time to the
/// right, each frame an arrow from its sender at the start of its
/// transmission to its addressee at the end of its arrival (a triangle at
/// the head), coloured by kind; a lost frame is a dashed red line to where
/// it would have arrived, ending in a cross, labelled with the reason.
/// `None` without `messages.csv`.
pub fn messages_figure(data: &RunData) -> Option<Figure> {
    let msgs = data.messages.as_ref()?;
    let n_nodes = data
        .info
        .receivers
        .len()
        .max(msgs.iter().map(|m| m.from.max(m.to) + 1).max().unwrap_or(0));
    let mut first: Vec<&MessageRow> = msgs.iter().collect();
    first.sort_by(|a, b| a.t_send.total_cmp(&b.t_send));
    first.truncate(SEQUENCE_FRAMES);
    let delay = planned_delays(msgs);
    let height = (120 + 40 * n_nodes as u32).clamp(300, 900);
    let mut panel = Panel::new(height, "emulated time (s)", "node");
    let mut legend = Vec::new();
    let t_end = first
        .iter()
        .map(|m| m.t_recv.unwrap_or(m.t_send + delay(m)))
        .fold(0.0f64, f64::max);
    let t0 = first.first().map_or(0.0, |m| m.t_send).min(0.0);
    node_lanes(&mut panel, n_nodes, (t0, t_end));
    let mut kinds: Vec<&str> = Vec::new();
    let mut reasons: Vec<&str> = Vec::new();
    for m in &first {
        let (x0, y0, y1) = (m.t_send, m.from as f64, m.to as f64);
        match (m.t_recv, &m.reason) {
            (Some(t), None) => {
                let c = kind_color(&m.kind);
                panel.series.push(Series {
                    name: m.kind.clone(),
                    segments: vec![vec![(x0, y0), (t, y1)]],
                    style: Style::line(c, 2),
                });
                panel.series.push(Series {
                    name: format!("{} head", m.kind),
                    segments: vec![vec![(t, y1)]],
                    style: Style::markers(c, Marker::Triangle, 5),
                });
                if !kinds.contains(&m.kind.as_str()) {
                    kinds.push(&m.kind);
                }
            }
            (_, reason) => {
                let t = x0 + delay(m);
                let why = reason.as_deref().unwrap_or("lost");
                panel.series.push(Series {
                    name: format!("lost {}", m.kind),
                    segments: vec![vec![(x0, y0), (t, y1)]],
                    style: Style::line(LOST, 1).dashed(),
                });
                panel.series.push(Series {
                    name: format!("lost {} head", m.kind),
                    segments: vec![vec![(t, y1)]],
                    style: Style::markers(LOST, Marker::Cross, 6),
                });
                // A label is about a tenth of the axis wide.
                let near = (t_end - t0).abs().max(1e-9) * 0.12;
                label_loss(&mut panel, n_nodes, (t, y1), why, near);
                if !reasons.contains(&why) {
                    reasons.push(why);
                }
            }
        }
    }
    for k in kinds {
        legend.push(LegendItem {
            label: format!("{k} (delivered)"),
            swatch: Swatch::Line(Style::line(kind_color(k), 2)),
        });
    }
    if !reasons.is_empty() {
        legend.push(LegendItem {
            label: format!("lost: {}", reasons.join(", ")),
            swatch: Swatch::Line(Style::line(LOST, 1).dashed()),
        });
    }
    super::fault_spans(data, &mut panel, &mut legend, |f| {
        (f.t_s, f.until_s.unwrap_or(f.t_s))
    });
    panel.x_range = (t0, t_end.max(t0 + 1e-3));
    panel.y_range = (-0.6, n_nodes as f64 - 0.4);
    if msgs.is_empty() {
        panel.note = Some("no frame was sent".into());
    }
    // What is shown goes in the title: a caption in the plot's corner would
    // sit on the top lane's label.
    Some(Figure {
        name: "messages".into(),
        title: format!(
            "Messages on the acoustic channel, first {} of {} frames ({:.1}-{:.1} s) — {}",
            first.len(),
            msgs.len(),
            t0,
            t_end,
            data.title()
        ),
        width: WIDTH,
        panels: vec![panel],
        legend,
    })
}

/// One grey lane per node from `t0` to `t_end`, labelled `R<i>` at its
/// left (the first `n_nodes` labels of the panel).
fn node_lanes(panel: &mut Panel, n_nodes: usize, (t0, t_end): (f64, f64)) {
    for i in 0..n_nodes {
        panel.series.push(Series {
            name: format!("node {i}"),
            segments: vec![vec![(t0, i as f64), (t_end, i as f64)]],
            style: Style::line(Rgb(200, 200, 200), 1),
        });
        panel.labels.push(Label {
            at: (t0, i as f64),
            offset: (4, -18),
            lines: vec![format!("R{i}")],
            size: 13,
        });
    }
}

/// Label a loss `why` at `at`: losses closer than `near` on one lane share
/// a label, a line per reason, instead of printing over each other.
fn label_loss(panel: &mut Panel, n_nodes: usize, at: (f64, f64), why: &str, near: f64) {
    let (t, lane) = at;
    match panel
        .labels
        .iter_mut()
        .skip(n_nodes)
        .find(|l| (l.at.1 - lane).abs() < 0.5 && (l.at.0 - t).abs() < near)
    {
        Some(l) => {
            if !l.lines.iter().any(|x| x == why) {
                l.lines.push(why.to_string());
            }
        }
        None => panel.labels.push(Label {
            at,
            offset: (5, 2),
            lines: vec![why.to_string()],
            size: 11,
        }),
    }
}

/// `channel.svg`: every directed link's delivery ratio (`metrics.json`
/// `channel.links`) against its length (from `run.json`'s receivers), each
/// link labelled `i→j` with its frame count. `None` off the acoustic channel.
pub fn channel_figure(data: &RunData) -> Option<Figure> {
    let ch = data.metrics.as_ref()?.channel.as_ref()?;
    let rx = &data.info.receivers;
    let mut panel = Panel::new(500, "link length (m)", "delivery ratio");
    let mut pts = Vec::new();
    for l in &ch.links {
        let (Some(a), Some(b)) = (rx.get(l.from as usize), rx.get(l.to as usize)) else {
            continue;
        };
        let d = (a[0] - b[0]).hypot(a[1] - b[1]);
        pts.push((d, l.delivery_ratio));
        panel.labels.push(Label {
            at: (d, l.delivery_ratio),
            offset: (7, -6),
            lines: vec![format!("{}→{} ({})", l.from, l.to, l.frames)],
            size: 11,
        });
    }
    panel.series.push(Series {
        name: "links".into(),
        segments: vec![pts.clone()],
        style: Style::markers(PALETTE[0], Marker::Circle, 6),
    });
    let x = linear_range(pts.iter().map(|p| p.0), 0.1);
    panel.x_range = (x.0.min(0.0), x.1 + 0.15 * (x.1 - x.0));
    panel.y_range = (0.0, 1.05);
    panel.caption = Some(format!(
        "all frames: {:.1} % delivered of {}",
        100.0 * ch.delivery_ratio,
        ch.frames
    ));
    if pts.is_empty() {
        panel.note = Some("no link carried a frame".into());
    }
    Some(Figure {
        name: "channel".into(),
        title: format!("Delivery ratio against link length — {}", data.title()),
        width: WIDTH,
        panels: vec![panel],
        legend: vec![LegendItem {
            label: "directed link i→j (frames sent)".into(),
            swatch: Swatch::Line(Style::markers(PALETTE[0], Marker::Circle, 6)),
        }],
    })
}
