//! Figure builders: [`RunData`] in, backend-free [`Figure`]s out.

use super::data::{BandCurve, NodePoint, RunData, THETA_BAR, Track, TrackKind};
use super::render::plot_area;
use super::{
    Band, Disc, Figure, Label, LegendItem, Marker, Panel, Rgb, Series, Style, Swatch, VLine,
};

/// Default figure width (px).
pub const WIDTH: u32 = 1000;

/// Tableau-10 palette: tracks take colours in order (theta_bar blue, ML
/// orange, then the baselines).
pub const PALETTE: [Rgb; 10] = [
    Rgb(31, 119, 180),
    Rgb(255, 127, 14),
    Rgb(44, 160, 44),
    Rgb(214, 39, 40),
    Rgb(148, 103, 189),
    Rgb(140, 86, 75),
    Rgb(227, 119, 194),
    Rgb(188, 189, 34),
    Rgb(23, 190, 207),
    Rgb(127, 127, 127),
];

/// Colours of the bound discs.
const BOUND_COLORS: [Rgb; 4] = [
    Rgb(148, 103, 189),
    Rgb(23, 190, 207),
    Rgb(188, 189, 34),
    Rgb(140, 86, 75),
];

const BLACK: Rgb = Rgb(20, 20, 20);
const GREY: Rgb = Rgb(110, 110, 110);
const TX_COLOR: Rgb = Rgb(200, 30, 30);
const EDGE_COLOR: Rgb = Rgb(160, 160, 160);

/// The colour of track `name`: fixed for `theta_bar` and `ml`, otherwise
/// by position among the baselines of `names`.
pub fn track_color(name: &str, names: &[&str]) -> Rgb {
    match name {
        THETA_BAR => PALETTE[0],
        super::data::ML => PALETTE[1],
        _ => {
            let i = names
                .iter()
                .filter(|n| **n != THETA_BAR && **n != super::data::ML)
                .position(|n| *n == name)
                .unwrap_or(0);
            PALETTE[2 + i % 8]
        }
    }
}

fn track_style(t: &Track, names: &[&str]) -> Style {
    let c = track_color(&t.name, names);
    match t.kind {
        TrackKind::Distributed => Style::line(c, 2),
        TrackKind::Reference => Style::line(c, 2).dashed(),
        TrackKind::Baseline => Style::line(c, 2),
    }
}

fn curve_label(name: &str) -> String {
    match name {
        THETA_BAR => "distributed estimate".into(),
        super::data::ML => "centralised ML".into(),
        n => n.to_string(),
    }
}

fn curve_style(name: &str, names: &[&str]) -> Style {
    let s = Style::line(track_color(name, names), 2);
    if name == super::data::ML {
        s.dashed()
    } else {
        s
    }
}

/// Split `(x, y)` pairs at missing values into contiguous segments; with
/// `positive`, non-positive values count as missing (log axes).
pub fn segments(xs: &[f64], ys: &[Option<f64>], positive: bool) -> Vec<Vec<(f64, f64)>> {
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut cur = Vec::new();
    for (x, y) in xs.iter().zip(ys) {
        match y {
            Some(y) if !positive || *y > 0.0 => cur.push((*x, *y)),
            _ => {
                if !cur.is_empty() {
                    out.push(std::mem::take(&mut cur));
                }
            }
        }
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

fn point_segments(pos: &[Option<[f64; 2]>]) -> Vec<Vec<(f64, f64)>> {
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut cur = Vec::new();
    for p in pos {
        match p {
            Some(p) => cur.push((p[0], p[1])),
            None => {
                if !cur.is_empty() {
                    out.push(std::mem::take(&mut cur));
                }
            }
        }
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

/// Linear range covering `vals` with `pad` (fraction) on both sides; a
/// sensible default when empty or degenerate.
pub fn linear_range(vals: impl Iterator<Item = f64>, pad: f64) -> (f64, f64) {
    let (lo, hi) = vals.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    });
    if !lo.is_finite() || !hi.is_finite() {
        return (0.0, 1.0);
    }
    let span = hi - lo;
    if span <= 1e-12 * hi.abs().max(lo.abs()).max(1e-300) {
        let d = (lo.abs() * 0.05).max(1.0);
        return (lo - d, hi + d);
    }
    (lo - pad * span, hi + pad * span)
}

/// Range of non-negative quantities: starts at 0.
fn zero_based_range(vals: impl Iterator<Item = f64>) -> (f64, f64) {
    let (_, hi) = linear_range(vals, 0.05);
    (0.0, if hi > 0.0 { hi } else { 1.0 })
}

/// Log range covering the positive `vals` with a margin.
pub fn log_range(vals: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = vals
        .filter(|v| *v > 0.0)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() || !hi.is_finite() {
        return (0.1, 10.0);
    }
    let (lo, hi) = (lo / 1.25, hi * 1.25);
    if hi / lo < 10.0 {
        let m = (lo * hi).sqrt();
        (m / 3.2, m * 3.2)
    } else {
        (lo, hi)
    }
}

/// Whether positive values spanning `vals` are better shown on a log axis.
fn wants_log(vals: impl Iterator<Item = f64>) -> bool {
    let (lo, hi) = vals
        .filter(|v| *v > 0.0)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    lo.is_finite() && hi / lo > 30.0
}

/// Expand ranges so one data unit is as long on both axes in a plot area of
/// `w` x `h` pixels.
pub fn equal_aspect(x: (f64, f64), y: (f64, f64), w: f64, h: f64) -> ((f64, f64), (f64, f64)) {
    let (sx, sy) = (x.1 - x.0, y.1 - y.0);
    let scale = (sx / w).max(sy / h);
    let (nx, ny) = (scale * w, scale * h);
    let (cx, cy) = ((x.0 + x.1) / 2.0, (y.0 + y.1) / 2.0);
    (
        (cx - nx / 2.0, cx + nx / 2.0),
        (cy - ny / 2.0, cy + ny / 2.0),
    )
}

/// Make `panel` an equal-aspect map of the data box `x` x `y`: chooses the
/// panel height (within `[min_h, max_h]`) to fit the data, then expands the
/// ranges.
fn fit_map(panel: &mut Panel, x: (f64, f64), y: (f64, f64), min_h: u32, max_h: u32) {
    let (w, _) = plot_area(WIDTH, 500);
    let overhead = 500.0 - plot_area(WIDTH, 500).1;
    let want = w * (y.1 - y.0) / (x.1 - x.0);
    let h = (want + overhead).clamp(min_h as f64, max_h as f64).round() as u32;
    panel.height = h;
    let (pw, ph) = plot_area(WIDTH, h);
    let (xr, yr) = equal_aspect(x, y, pw, ph);
    panel.x_range = xr;
    panel.y_range = yr;
    panel.equal_aspect = true;
}

fn dedup_legend(items: &mut Vec<LegendItem>) {
    let mut seen = std::collections::HashSet::new();
    items.retain(|i| seen.insert(i.label.clone()));
}

fn sample_xs(data: &RunData) -> Vec<f64> {
    data.track.sample.clone()
}

fn names(data: &RunData) -> Vec<&str> {
    data.track.tracks.iter().map(|t| t.name.as_str()).collect()
}

fn mc_names(data: &RunData) -> Vec<&str> {
    data.monte_carlo
        .as_ref()
        .map(|m| m.curves.iter().map(|c| c.name.as_str()).collect())
        .unwrap_or_default()
}

fn geometry_points(data: &RunData) -> Vec<(f64, f64)> {
    data.info
        .transmitters
        .iter()
        .chain(&data.info.receivers)
        .map(|p| (p[0], p[1]))
        .collect()
}

/// Add transmitters, receivers and edges to a map panel.
fn draw_geometry(data: &RunData, panel: &mut Panel, legend: &mut Vec<LegendItem>, labels: bool) {
    let rx = &data.info.receivers;
    for &(a, b) in &data.info.edges {
        panel.series.push(Series {
            name: "edge".into(),
            segments: vec![vec![(rx[a][0], rx[a][1]), (rx[b][0], rx[b][1])]],
            style: Style::line(EDGE_COLOR, 2),
        });
    }
    if !data.info.edges.is_empty() {
        legend.push(LegendItem {
            label: "network link".into(),
            swatch: Swatch::Line(Style::line(EDGE_COLOR, 2)),
        });
    }
    if !data.info.transmitters.is_empty() {
        let st = Style::markers(TX_COLOR, Marker::Triangle, 8);
        panel.series.push(Series {
            name: "transmitters".into(),
            segments: vec![
                data.info
                    .transmitters
                    .iter()
                    .map(|p| (p[0], p[1]))
                    .collect(),
            ],
            style: st,
        });
        legend.push(LegendItem {
            label: "transmitter".into(),
            swatch: Swatch::Line(st),
        });
        if labels {
            for (i, p) in data.info.transmitters.iter().enumerate() {
                panel.labels.push(Label {
                    at: (p[0], p[1]),
                    offset: (9, 4),
                    lines: vec![format!("T{i}")],
                    size: 16,
                });
            }
        }
    }
    if !rx.is_empty() {
        let st = Style::markers(Rgb(40, 40, 40), Marker::Square, 6);
        panel.series.push(Series {
            name: "receivers".into(),
            segments: vec![rx.iter().map(|p| (p[0], p[1])).collect()],
            style: st,
        });
        legend.push(LegendItem {
            label: "receiver (node)".into(),
            swatch: Swatch::Line(st),
        });
        if labels {
            for (i, p) in rx.iter().enumerate() {
                panel.labels.push(Label {
                    at: (p[0], p[1]),
                    offset: (9, 4),
                    lines: vec![format!("R{i}")],
                    size: 16,
                });
            }
        }
    }
}

/// `tracks.svg`: the true track, every estimated track, the geometry to
/// scale (cf. seed 002 Fig. 2b) and the bound discs at every n-th sample.
/// When the tracks cover less than half of the scene, a second panel zooms
/// on them (same scale on both axes).
pub fn tracks_figure(data: &RunData) -> Figure {
    let tt = &data.track;
    let names = names(data);
    let mut panel = Panel::new(700, "x (m)", "y (m)");
    let mut legend = Vec::new();
    draw_geometry(data, &mut panel, &mut legend, true);
    let geometry = panel.clone();
    let mut tracks = Panel::new(700, "x (m)", "y (m)");
    // Bound discs around theta_bar at every n-th sample.
    let est = tt.track(THETA_BAR);
    let n = tt.sample.len();
    let every = (n / 12).max(1);
    for (bi, b) in tt.bounds.iter().enumerate() {
        let color = BOUND_COLORS[bi % BOUND_COLORS.len()];
        let mut any = false;
        for k in (0..n).step_by(every) {
            if let (Some(r), Some(Some(c))) = (b.radius[k], est.map(|e| e.pos[k])) {
                tracks.discs.push(Disc {
                    name: format!("bound_{}", b.name),
                    center: (c[0], c[1]),
                    radius: r,
                    color,
                });
                any = true;
            }
        }
        if any {
            legend.push(LegendItem {
                label: format!("bound {} (every {every} samples)", b.name),
                swatch: Swatch::Disc(color),
            });
        }
    }
    let truth = point_segments(&tt.truth);
    if !truth.is_empty() {
        let st = Style {
            marker: Some(Marker::Circle),
            marker_size: 2,
            ..Style::line(BLACK, 2)
        };
        tracks.series.push(Series {
            name: "truth".into(),
            segments: truth,
            style: st,
        });
        legend.push(LegendItem {
            label: "true track".into(),
            swatch: Swatch::Line(st),
        });
    }
    // Reference first (under), then baselines, then theta_bar on top.
    let mut order: Vec<&Track> = tt.tracks.iter().collect();
    order.sort_by_key(|t| match t.kind {
        TrackKind::Reference => 0,
        TrackKind::Baseline => 1,
        TrackKind::Distributed => 2,
    });
    for t in order {
        let st = track_style(t, &names);
        tracks.series.push(Series {
            name: t.name.clone(),
            segments: point_segments(&t.pos),
            style: st,
        });
        legend.push(LegendItem {
            label: t.label(),
            swatch: Swatch::Line(st),
        });
    }
    let track_pts = tracks.points();
    panel.discs.extend(tracks.discs.iter().cloned());
    panel.series.extend(tracks.series.iter().cloned());
    let mut extent: Vec<(f64, f64)> = geometry_points(data);
    extent.extend(track_pts.iter().copied());
    let x = linear_range(extent.iter().map(|p| p.0), 0.06);
    let y = linear_range(extent.iter().map(|p| p.1), 0.06);
    let mut panels = Vec::new();
    let (tx, ty) = (
        linear_range(track_pts.iter().map(|p| p.0), 0.08),
        linear_range(track_pts.iter().map(|p| p.1), 0.08),
    );
    let zoom = !track_pts.is_empty()
        && !geometry.series.is_empty()
        && (tx.1 - tx.0).max(ty.1 - ty.0) < 0.5 * (x.1 - x.0).max(y.1 - y.0);
    if zoom {
        fit_map(&mut panel, x, y, 400, 640);
        fit_map(&mut tracks, tx, ty, 400, 700);
        tracks.caption = Some("zoom on the tracks".into());
        panels.push(panel);
        panels.push(tracks);
    } else {
        fit_map(&mut panel, x, y, 420, 900);
        panels.push(panel);
    }
    if n == 0 {
        panels[0].note = Some("no samples in track.csv".into());
    }
    dedup_legend(&mut legend);
    Figure {
        name: "tracks".into(),
        title: format!("Tracks — {}", data.title()),
        width: WIDTH,
        panels,
        legend,
    }
}

fn add_band(
    panel: &mut Panel,
    legend: &mut Vec<LegendItem>,
    name: &str,
    label: &str,
    xs: &[f64],
    b: &BandCurve,
    style: Style,
) {
    let mut segs: Vec<Vec<(f64, f64, f64)>> = Vec::new();
    let mut cur = Vec::new();
    for ((x, lo), hi) in xs.iter().zip(&b.p5).zip(&b.p95) {
        match (lo, hi) {
            (Some(lo), Some(hi)) => cur.push((*x, *lo, *hi)),
            _ => {
                if !cur.is_empty() {
                    segs.push(std::mem::take(&mut cur));
                }
            }
        }
    }
    if !cur.is_empty() {
        segs.push(cur);
    }
    if !segs.is_empty() {
        panel.bands.push(Band {
            name: name.to_string(),
            segments: segs,
            color: style.color,
        });
    }
    panel.series.push(Series {
        name: name.to_string(),
        segments: segments(xs, &b.mean, false),
        style,
    });
    legend.push(LegendItem {
        label: format!("{label} (mean)"),
        swatch: Swatch::Line(style),
    });
}

/// Finish a time-series panel: ranges over all points (log if asked), bands
/// clamped to a log axis' floor, non-positive points dropped on log axes.
fn finish_series_panel(panel: &mut Panel, log: bool, zero_based: bool) {
    let pts = panel.points();
    panel.x_range = {
        let (lo, hi) = linear_range(pts.iter().map(|p| p.0), 0.0);
        if hi > lo {
            (lo, hi)
        } else {
            (lo - 0.5, hi + 0.5)
        }
    };
    panel.log_y = log;
    if log {
        for s in &mut panel.series {
            for seg in &mut s.segments {
                seg.retain(|p| p.1 > 0.0);
            }
            s.segments.retain(|seg| !seg.is_empty());
        }
        panel.y_range = log_range(panel.points().into_iter().map(|p| p.1));
        let floor = panel.y_range.0;
        for b in &mut panel.bands {
            for seg in &mut b.segments {
                for p in seg.iter_mut() {
                    p.1 = p.1.max(floor);
                    p.2 = p.2.max(floor);
                }
            }
        }
    } else if zero_based {
        panel.y_range = zero_based_range(pts.iter().map(|p| p.1));
    } else {
        panel.y_range = linear_range(pts.iter().map(|p| p.1), 0.05);
    }
    if panel.series.iter().all(|s| s.segments.is_empty()) && panel.bands.is_empty() {
        panel.note.get_or_insert_with(|| "no data".into());
    }
}

fn burn_in_line(data: &RunData, panel: &mut Panel, legend: &mut Vec<LegendItem>) {
    if let Some(b) = data.info.burn_in.filter(|b| *b > 0) {
        panel.vlines.push(VLine {
            x: b as f64,
            caption: format!("burn-in ({b} samples)"),
            shade_left: true,
        });
        legend.push(LegendItem {
            label: "burn-in (excluded)".into(),
            swatch: Swatch::Area(GREY),
        });
    }
}

/// `error.svg`: error per sample of every track, with the CRLB and the
/// burn-in; Monte Carlo runs show mean curves with 5th-95th percentile bands.
pub fn error_figure(data: &RunData) -> Figure {
    let mut panel = Panel::new(480, "sample k", "position error (m)");
    let mut legend = Vec::new();
    let crlb_style = Style::line(GREY, 2).dashed();
    let mut title = format!("Error per sample — {}", data.title());
    if let Some(mc) = data.monte_carlo.as_ref().filter(|m| !m.sample.is_empty()) {
        let names = mc_names(data);
        for c in &mc.curves {
            if let Some(b) = &c.error {
                let st = curve_style(&c.name, &names);
                add_band(
                    &mut panel,
                    &mut legend,
                    &c.name,
                    &curve_label(&c.name),
                    &mc.sample,
                    b,
                    st,
                );
            }
        }
        if let Some(b) = &mc.crlb {
            panel.series.push(Series {
                name: "crlb".into(),
                segments: segments(&mc.sample, &b.mean, false),
                style: crlb_style,
            });
            legend.push(LegendItem {
                label: "CRLB √tr(J⁻¹) (mean)".into(),
                swatch: Swatch::Line(crlb_style),
            });
        }
        legend.push(LegendItem {
            label: "5th–95th percentile".into(),
            swatch: Swatch::Area(PALETTE[0]),
        });
        title = format!(
            "Error per sample, {} trials — {}",
            mc.trials.map_or("Monte Carlo".into(), |t| t.to_string()),
            data.title()
        );
    } else {
        let xs = sample_xs(data);
        let names = names(data);
        for t in &data.track.tracks {
            let st = track_style(t, &names);
            panel.series.push(Series {
                name: t.name.clone(),
                segments: segments(&xs, &t.error, false),
                style: st,
            });
            legend.push(LegendItem {
                label: t.label(),
                swatch: Swatch::Line(st),
            });
        }
        if data.track.crlb.iter().any(Option::is_some) {
            panel.series.push(Series {
                name: "crlb".into(),
                segments: segments(&xs, &data.track.crlb, false),
                style: crlb_style,
            });
            legend.push(LegendItem {
                label: "CRLB √tr(J⁻¹)".into(),
                swatch: Swatch::Line(crlb_style),
            });
        }
    }
    burn_in_line(data, &mut panel, &mut legend);
    let log = wants_log(panel.points().into_iter().map(|p| p.1));
    if log {
        panel.y_label = "position error (m, log scale)".into();
    }
    finish_series_panel(&mut panel, log, true);
    if panel.note.is_some() && data.track.truth.iter().all(Option::is_none) {
        panel.note = Some("no truth: errors are not defined".into());
    }
    Figure {
        name: "error".into(),
        title,
        width: WIDTH,
        panels: vec![panel],
        legend,
    }
}

/// `ctte.svg`: running CTTE (seed 000) and, when present, running dynamic
/// regret (seed 001) for every track; Monte Carlo runs show mean and band.
pub fn ctte_figure(data: &RunData) -> Figure {
    let mut ctte = Panel::new(440, "sample k", "cumulative tracking error CTTE (m)");
    let mut regret = Panel::new(360, "sample k", "dynamic regret");
    let mut legend = Vec::new();
    let mut title = format!("Running CTTE — {}", data.title());
    if let Some(mc) = data.monte_carlo.as_ref().filter(|m| !m.sample.is_empty()) {
        let names = mc_names(data);
        for c in &mc.curves {
            let st = curve_style(&c.name, &names);
            if let Some(b) = &c.ctte {
                add_band(
                    &mut ctte,
                    &mut legend,
                    &c.name,
                    &curve_label(&c.name),
                    &mc.sample,
                    b,
                    st,
                );
            }
            if let Some(b) = &c.regret {
                add_band(
                    &mut regret,
                    &mut legend,
                    &c.name,
                    &curve_label(&c.name),
                    &mc.sample,
                    b,
                    st,
                );
            }
        }
        legend.push(LegendItem {
            label: "5th–95th percentile".into(),
            swatch: Swatch::Area(PALETTE[0]),
        });
        title = format!(
            "Running CTTE, {} trials — {}",
            mc.trials.map_or("Monte Carlo".into(), |t| t.to_string()),
            data.title()
        );
    } else {
        let xs = sample_xs(data);
        let names = names(data);
        for t in &data.track.tracks {
            let st = track_style(t, &names);
            ctte.series.push(Series {
                name: t.name.clone(),
                segments: segments(&xs, &t.ctte, false),
                style: st,
            });
            if let Some(r) = &t.regret {
                regret.series.push(Series {
                    name: t.name.clone(),
                    segments: segments(&xs, r, false),
                    style: st,
                });
            }
            legend.push(LegendItem {
                label: t.label(),
                swatch: Swatch::Line(st),
            });
        }
    }
    dedup_legend(&mut legend);
    finish_series_panel(&mut ctte, false, true);
    let mut panels = vec![ctte];
    if !regret.series.is_empty() {
        title = title.replacen("Running CTTE", "Running CTTE and regret", 1);
        finish_series_panel(&mut regret, false, false);
        panels.push(regret);
    }
    Figure {
        name: "ctte".into(),
        title,
        width: WIDTH,
        panels,
        legend,
    }
}

/// Node colours for the consensus plot.
const NODE_COLORS: [Rgb; 8] = [
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
fn decimate(v: Vec<(f64, f64)>, max: usize) -> Vec<(f64, f64)> {
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
/// as seed 002 Fig. 2a; and the disagreement `max_v ||theta_v - theta_bar||`.
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
    let mut per_node: Vec<Vec<(f64, [f64; 2])>> = vec![Vec::new(); n_nodes];
    for p in pts {
        per_node[p.node].push((xpos(p), p.pos));
    }
    for v in &mut per_node {
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
    }
    // theta_bar and disagreement at each x where every node reported.
    let mut by_x: std::collections::BTreeMap<u64, Vec<[f64; 2]>> = Default::default();
    for p in pts {
        by_x.entry(xpos(p).to_bits()).or_default().push(p.pos);
    }
    let mut bar: Vec<(f64, [f64; 2], f64)> = by_x
        .into_iter()
        .filter(|(_, v)| v.len() == n_nodes && n_nodes > 0)
        .map(|(x, v)| {
            let m = [
                v.iter().map(|p| p[0]).sum::<f64>() / v.len() as f64,
                v.iter().map(|p| p[1]).sum::<f64>() / v.len() as f64,
            ];
            let d = v
                .iter()
                .map(|p| (p[0] - m[0]).hypot(p[1] - m[1]))
                .fold(0.0, f64::max);
            (f64::from_bits(x), m, d)
        })
        .collect();
    bar.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Truth: per sample; with iterations, a step over the sample's iterations.
    let truth_at = |s: usize| -> Option<[f64; 2]> {
        data.track
            .sample
            .iter()
            .position(|k| (*k - s as f64).abs() < 0.5)
            .and_then(|i| data.track.truth[i])
    };
    let mut truth_pts: Vec<(f64, [f64; 2])> = Vec::new();
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
    const MAX_PTS: usize = 4000;
    let mut legend = Vec::new();
    let mut panels = Vec::new();
    for (axis, label) in [(0usize, "x (m)"), (1, "y (m)")] {
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
        panels.push(p);
    }
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
    panels.push(dis);
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

fn counter(m: &serde_json::Map<String, serde_json::Value>, k: &str) -> Option<u64> {
    m.get(k).and_then(serde_json::Value::as_u64)
}

/// Sequential light-to-dark blue for `t` in `[0, 1]`.
fn heat(t: f64) -> Rgb {
    let t = t.clamp(0.0, 1.0);
    let lerp = |a: f64, b: f64| (a + (b - a) * t).round() as u8;
    Rgb(lerp(222.0, 8.0), lerp(235.0, 69.0), lerp(247.0, 148.0))
}

/// `network.svg`: the graph to scale, each node coloured by its prox solves
/// and labelled with its counters (prox solves, messages out/in, declines).
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
    let prox: Vec<Option<u64>> = (0..rx.len())
        .map(|i| {
            counters
                .iter()
                .find(|c| counter(c, "node") == Some(i as u64))
                .and_then(|c| counter(c, "prox_solves"))
        })
        .collect();
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
    let closest = rx
        .iter()
        .enumerate()
        .flat_map(|(i, a)| {
            rx[i + 1..]
                .iter()
                .map(move |b| (a[0] - b[0]).hypot(a[1] - b[1]))
        })
        .fold(f64::INFINITY, f64::min);
    let compact = rx.len() > 10 || closest < 0.15 * span;
    for (i, p) in rx.iter().enumerate() {
        let c = counters
            .iter()
            .find(|c| counter(c, "node") == Some(i as u64));
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
            let g = |k| counter(c, k).map_or("-".into(), |v| v.to_string());
            if compact {
                lines[0] = format!("R{i} · {}", g("prox_solves"));
            } else {
                lines.push(format!("prox {}", g("prox_solves")));
                lines.push(format!("msg {}↑ {}↓", g("messages_out"), g("messages_in")));
                lines.push(format!("declines {}", g("declines")));
            }
        }
        panel.labels.push(Label {
            at: (p[0], p[1]),
            offset: (15, -8),
            lines,
            size: 15,
        });
    }
    legend.push(LegendItem {
        label: if hi > lo {
            format!("node: prox solves {lo:.0} (light) – {hi:.0} (dark)")
        } else {
            "node (receiver)".into()
        },
        swatch: Swatch::Line(Style::markers(heat(0.6), Marker::Circle, 6)),
    });
    if compact && !counters.is_empty() {
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

/// The five figures of a run, in report order: tracks, error, consensus,
/// ctte, network.
pub fn run_figures(data: &RunData) -> Vec<Figure> {
    vec![
        tracks_figure(data),
        error_figure(data),
        consensus_figure(data),
        ctte_figure(data),
        network_figure(data),
    ]
}

/// Overlay of runs `a` (solid) and `b` (dashed) for a comparison report:
/// `compare-error` (error per sample) and `compare-ctte` (running CTTE) of
/// every track of both runs; Monte Carlo runs contribute their mean curves.
pub fn comparison_figures(a: &RunData, b: &RunData, label_a: &str, label_b: &str) -> Vec<Figure> {
    let mut all: Vec<String> = Vec::new();
    for d in [a, b] {
        for n in names(d).into_iter().chain(mc_names(d)) {
            if !all.iter().any(|x| x == n) {
                all.push(n.to_string());
            }
        }
    }
    let all_ref: Vec<&str> = all.iter().map(String::as_str).collect();
    let mut figs = Vec::new();
    for (fname, ylabel, what) in [
        ("compare-error", "position error (m)", "Error per sample"),
        (
            "compare-ctte",
            "cumulative tracking error CTTE (m)",
            "Running CTTE",
        ),
    ] {
        let is_err = fname == "compare-error";
        let mut panel = Panel::new(480, "sample k", ylabel);
        let mut legend = Vec::new();
        for (d, tag, dashed) in [(a, label_a, false), (b, label_b, true)] {
            let mut curves: Vec<(String, Vec<f64>, Vec<Option<f64>>)> = Vec::new();
            match d.monte_carlo.as_ref().filter(|m| !m.sample.is_empty()) {
                Some(mc) => {
                    for c in &mc.curves {
                        let band = if is_err { &c.error } else { &c.ctte };
                        if let Some(bc) = band {
                            curves.push((c.name.clone(), mc.sample.clone(), bc.mean.clone()));
                        }
                    }
                }
                None => {
                    for t in &d.track.tracks {
                        let ys = if is_err { &t.error } else { &t.ctte };
                        curves.push((t.name.clone(), d.track.sample.clone(), ys.clone()));
                    }
                }
            }
            for (name, xs, ys) in curves {
                let mut st = Style::line(track_color(&name, &all_ref), 2);
                st.dashed = dashed;
                panel.series.push(Series {
                    name: format!("{tag}: {name}"),
                    segments: segments(&xs, &ys, false),
                    style: st,
                });
                legend.push(LegendItem {
                    label: format!("{tag}: {}", curve_label(&name)),
                    swatch: Swatch::Line(st),
                });
            }
        }
        let log = is_err && wants_log(panel.points().into_iter().map(|p| p.1));
        if log {
            panel.y_label =
                format!("{ylabel} (log scale)").replace("(m) (log scale)", "(m, log scale)");
        }
        if is_err {
            burn_in_line(a, &mut panel, &mut legend);
        }
        finish_series_panel(&mut panel, log, true);
        figs.push(Figure {
            name: fname.into(),
            title: format!("{what}: {label_a} (solid) vs {label_b} (dashed)"),
            width: WIDTH,
            panels: vec![panel],
            legend,
        });
    }
    figs
}
