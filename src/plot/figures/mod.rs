//! Figure builders: [`RunData`] in, backend-free [`Figure`]s out.

mod channel;
mod consensus;
mod depth;
mod network;
mod series;
mod snapshot;
mod sweep;
mod tracks;
pub use channel::{SEQUENCE_FRAMES, channel_figure, messages_figure};
pub use consensus::consensus_figure;
pub use depth::depth_figure;
pub use network::{MAX_LABELLED_NODES, network_figure};
pub use series::{MAX_BANDS, ctte_figure, error_figure};
use series::{burn_in_line, fault_spans, finish_series_panel};
pub use snapshot::{
    cdf_points, error_cdf_figure, is_snapshot, scatter_figure, tightness_cdf_figure,
};
pub use sweep::{SweepCurve, sweep_figure};
pub use tracks::tracks_figure;

use super::data::{Pos, RunData, THETA_BAR, Track, TrackKind};
use super::render::plot_area;
use super::{Figure, Label, LegendItem, Marker, Panel, Rgb, Series, Style, Swatch};

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

fn point_segments(pos: &[Option<crate::plot::data::Pos>]) -> Vec<Vec<(f64, f64)>> {
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
    let paths = data.drift_paths();
    data.info
        .transmitters
        .iter()
        .chain(&data.info.receivers)
        .chain(paths.iter().flat_map(|(_, p)| p))
        .map(|p| (p[0], p[1]))
        .collect()
}

/// The colour of a drifting receiver's path.
const DRIFT_COLOR: Rgb = Rgb(150, 90, 40);

/// The path of every drifting receiver (`receivers.csv`) on a map panel,
/// in the coordinates `xy` picks (plan view or x-z section), with its
/// legend entry; the receivers' markers stay at their sample-0 positions.
fn draw_drift(
    data: &RunData,
    xy: fn(&Pos) -> (f64, f64),
    panel: &mut Panel,
    legend: &mut Vec<LegendItem>,
) {
    let paths = data.drift_paths();
    if paths.is_empty() {
        return;
    }
    let st = Style::line(DRIFT_COLOR, 2);
    panel.series.push(Series {
        name: "receiver drift".into(),
        segments: paths
            .iter()
            .map(|(_, p)| p.iter().map(xy).collect())
            .collect(),
        style: st,
    });
    legend.push(LegendItem {
        label: "receiver drift (from its marker)".into(),
        swatch: Swatch::Line(st),
    });
}

/// Add transmitters, receivers and edges to a map panel.
fn draw_geometry(data: &RunData, panel: &mut Panel, legend: &mut Vec<LegendItem>, labels: bool) {
    draw_drift(data, |p| (p[0], p[1]), panel, legend);
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

/// The figures of a run, in report order: tracks (the plan view of a 3-D
/// run, followed by its depth figure), error, consensus, ctte, network, and
/// on the acoustic channel messages and channel.
pub fn run_figures(data: &RunData) -> Vec<Figure> {
    if is_snapshot(data) {
        // One snapshot per trial: distributions across the trials, not
        // curves over a one-point time axis.
        let mut figs = vec![tracks_figure(data)];
        figs.extend(depth_figure(data));
        figs.push(error_cdf_figure(data));
        figs.extend(tightness_cdf_figure(data));
        figs.extend(scatter_figure(data));
        figs.push(network_figure(data));
        return figs;
    }
    let mut figs = vec![tracks_figure(data)];
    figs.extend(depth_figure(data));
    figs.extend([
        error_figure(data),
        consensus_figure(data),
        ctte_figure(data),
        network_figure(data),
    ]);
    figs.extend(messages_figure(data));
    figs.extend(channel_figure(data));
    figs
}

/// Overlay of runs `a` (solid) and `b` (dashed) for a comparison report:
/// `c` mixed 45 % towards black: run B's shade of a track colour.
pub fn darker(c: Rgb) -> Rgb {
    let f = |v: u8| (f64::from(v) * 0.55).round() as u8;
    Rgb(f(c.0), f(c.1), f(c.2))
}

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
                // Run B: dashed and in a darker shade of the track's colour,
                // so the two runs differ by more than the dash.
                let c = track_color(&name, &all_ref);
                let c = if dashed { darker(c) } else { c };
                let mut st = Style::line(c, 2);
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
