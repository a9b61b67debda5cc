//! `error.svg` and `ctte.svg`: the error and CTTE of every track against the sample,
//! with Monte Carlo bands.

use crate::plot::Band;
use crate::plot::Figure;
use crate::plot::LegendItem;
use crate::plot::Panel;
use crate::plot::Rgb;
use crate::plot::Series;
use crate::plot::Style;
use crate::plot::Swatch;
use crate::plot::VLine;
use crate::plot::data::BandCurve;
use crate::plot::data::RunData;
use crate::plot::figures::GREY;
use crate::plot::figures::WIDTH;
use crate::plot::figures::curve_label;
use crate::plot::figures::curve_style;
use crate::plot::figures::dedup_legend;
use crate::plot::figures::linear_range;
use crate::plot::figures::log_range;
use crate::plot::figures::mc_names;
use crate::plot::figures::names;
use crate::plot::figures::sample_xs;
use crate::plot::figures::segments;
use crate::plot::figures::track_style;
use crate::plot::figures::wants_log;
use crate::plot::figures::zero_based_range;

/// Percentile bands drawn per panel.
pub const MAX_BANDS: usize = 3;

pub(super) fn add_band(
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
    // At most MAX_BANDS bands per panel, the first curves' (theta_bar and
    // ml come first): more overlapping fills turn to mud. Each has its own
    // swatch in the track's colour.
    if !segs.is_empty() && panel.bands.len() < MAX_BANDS {
        panel.bands.push(Band {
            name: name.to_string(),
            segments: segs,
            color: style.color,
        });
        legend.push(LegendItem {
            label: format!("{label} 5th–95th percentile"),
            swatch: Swatch::Area(style.color),
        });
    } else if !segs.is_empty() {
        let note = format!("5th–95th percentile bands of the first {MAX_BANDS} tracks only");
        panel.caption = Some(note);
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
pub(super) fn finish_series_panel(panel: &mut Panel, log: bool, zero_based: bool) {
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

/// The colour of the fault shading.
pub(super) const FAULT_COLOR: Rgb = Rgb(214, 39, 40);

/// Shade every fault of `metrics.json` on `panel`, from `range(fault)`:
/// lasting faults as a span, instantaneous ones (crash, restart) as a thin
/// one, each captioned with its kind and nodes.
pub(super) fn fault_spans(
    data: &RunData,
    panel: &mut Panel,
    legend: &mut Vec<LegendItem>,
    range: impl Fn(&crate::pipeline::FaultOutcome) -> (f64, f64),
) {
    let Some(m) = &data.metrics else { return };
    for f in &m.faults {
        let (x0, x1) = range(f);
        let nodes: Vec<String> = f.nodes.iter().map(u32::to_string).collect();
        let what = if f.kind == "partition" {
            f.detail.clone()
        } else {
            nodes.join(",")
        };
        panel.spans.push(super::super::Span {
            x0,
            x1: if x1 > x0 { x1 } else { x0 + 0.3 },
            caption: format!("{} {what}", f.kind),
            color: FAULT_COLOR,
        });
    }
    if !m.faults.is_empty() {
        legend.push(LegendItem {
            label: "fault (faults.csv)".into(),
            swatch: Swatch::Area(FAULT_COLOR),
        });
    }
}

pub(super) fn burn_in_line(data: &RunData, panel: &mut Panel, legend: &mut Vec<LegendItem>) {
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
    fault_spans(data, &mut panel, &mut legend, |f| {
        (f.sample as f64, f.until_sample.max(f.sample) as f64)
    });
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

/// `ctte.svg`: running CTTE (Pun-So 2022) and, when present, running dynamic
/// regret (Pun-So 2020) for every track; Monte Carlo runs show mean and band.
pub fn ctte_figure(data: &RunData) -> Figure {
    let mut ctte = Panel::new(440, "sample k", "cumulative tracking error CTTE (m)");
    let mut regret = Panel::new(
        360,
        "sample k",
        "dynamic regret (m², running Σ f_t(x_t) − f_t(x̂_t))",
    );
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
