//! Figures of a Monte Carlo run whose trials are one snapshot each (the
//! static-target experiments of Gholami 2015 Sec. 6 and Shi 2024 Sec. IV):
//! a time axis has one point there, so these show what those papers plot
//! instead: the CDF of the error across trials (Gholami 2015 Figs. 8-9), the
//! CDF of each bound's relative tightness, and the estimates scattered around
//! the truth.

use super::finish_series_panel;
use crate::plot::Figure;
use crate::plot::LegendItem;
use crate::plot::Marker;
use crate::plot::Panel;
use crate::plot::Series;
use crate::plot::Style;
use crate::plot::Swatch;
use crate::plot::data::{RunData, THETA_BAR};
use crate::plot::figures::BLACK;
use crate::plot::figures::BOUND_COLORS;
use crate::plot::figures::PALETTE;
use crate::plot::figures::WIDTH;
use crate::plot::figures::curve_label;
use crate::plot::figures::curve_style;
use crate::plot::figures::fit_map;
use crate::plot::figures::linear_range;
use crate::plot::figures::mc_names;
use crate::plot::figures::track_color;

/// Whether `data` is a Monte Carlo run of one-snapshot trials.
pub fn is_snapshot(data: &RunData) -> bool {
    data.monte_carlo
        .as_ref()
        .is_some_and(|m| m.sample.len() <= 1 && !m.trial_rows.is_empty())
}

/// The finite values of `trials.csv` column `name`.
fn column(data: &RunData, name: &str) -> Vec<f64> {
    let Some(mc) = &data.monte_carlo else {
        return Vec::new();
    };
    let Some(j) = mc.trial_columns.iter().position(|c| c == name) else {
        return Vec::new();
    };
    mc.trial_rows
        .iter()
        .filter_map(|r| r.get(j).copied().flatten())
        .filter(|v| v.is_finite())
        .collect()
}

/// The empirical CDF of `v` as a staircase: `(x, fraction of values <= x)`.
pub fn cdf_points(mut v: Vec<f64>) -> Vec<(f64, f64)> {
    v.sort_by(f64::total_cmp);
    let n = v.len() as f64;
    let mut pts = Vec::with_capacity(2 * v.len());
    for (i, x) in v.iter().enumerate() {
        pts.push((*x, i as f64 / n));
        pts.push((*x, (i + 1) as f64 / n));
    }
    pts
}

fn trials_title(data: &RunData) -> String {
    let n = data
        .monte_carlo
        .as_ref()
        .and_then(|m| m.trials)
        .map_or("Monte Carlo".into(), |t| format!("{t} trials"));
    format!("{n} — {}", data.title())
}

/// `error-cdf.svg` of a snapshot run (in place of `error.svg`): the CDF of each track's error across the
/// trials, with the mean CRLB as a dashed vertical line.
pub fn error_cdf_figure(data: &RunData) -> Figure {
    let names = mc_names(data);
    let mut panel = Panel::new(480, "position error (m)", "fraction of trials (CDF)");
    let mut legend = Vec::new();
    for name in &names {
        let v = column(data, &format!("{name}.rmse"));
        if v.is_empty() {
            continue;
        }
        let st = curve_style(name, &names);
        panel.series.push(Series {
            name: name.to_string(),
            segments: vec![cdf_points(v)],
            style: st,
        });
        legend.push(LegendItem {
            label: curve_label(name),
            swatch: Swatch::Line(st),
        });
    }
    let crlb = column(data, "crlb_rms");
    if !crlb.is_empty() {
        let mean = crlb.iter().sum::<f64>() / crlb.len() as f64;
        let st = Style::line(super::GREY, 2).dashed();
        panel.series.push(Series {
            name: "crlb".into(),
            segments: vec![vec![(mean, 0.0), (mean, 1.0)]],
            style: st,
        });
        legend.push(LegendItem {
            label: "CRLB √tr(J⁻¹), mean over trials".into(),
            swatch: Swatch::Line(st),
        });
    }
    finish_series_panel(&mut panel, false, true);
    panel.y_range = (0.0, 1.0);
    Figure {
        name: "error-cdf".into(),
        title: format!("CDF of the position error, {}", trials_title(data)),
        width: WIDTH,
        panels: vec![panel],
        legend,
    }
}

/// `tightness.svg`: for every track that carries bounds, the CDF across
/// trials of each bound's relative tightness `(bound - error) / error`
/// (Gholami 2015 Sec. 6: tau <= 1 means the bound is below twice the error).
pub fn tightness_cdf_figure(data: &RunData) -> Option<Figure> {
    let mc = data.monte_carlo.as_ref()?;
    let suffix = ".rel_tightness_median";
    let mut by_track: Vec<(String, Vec<String>)> = Vec::new();
    for c in &mc.trial_columns {
        let Some(stem) = c.strip_suffix(suffix) else {
            continue;
        };
        let Some((track, bound)) = stem.split_once(".bounds.") else {
            continue;
        };
        match by_track.iter_mut().find(|(t, _)| t == track) {
            Some((_, b)) => b.push(bound.to_string()),
            None => by_track.push((track.to_string(), vec![bound.to_string()])),
        }
    }
    if by_track.is_empty() {
        return None;
    }
    let mut bounds: Vec<String> = by_track.iter().flat_map(|(_, b)| b.clone()).collect();
    bounds.sort();
    bounds.dedup();
    let color = |b: &str| {
        let i = bounds.iter().position(|x| x == b).unwrap_or(0);
        if i < BOUND_COLORS.len() {
            BOUND_COLORS[i]
        } else {
            PALETTE[(i + 2) % PALETTE.len()]
        }
    };
    // A few near-degenerate trials have tau in the hundreds: the axis ends
    // at the largest 98th percentile, and the CDFs are cut there.
    let cap = by_track
        .iter()
        .flat_map(|(t, bs)| bs.iter().map(move |b| (t, b)))
        .filter_map(|(t, b)| {
            crate::model::metrics::quantile(&column(data, &format!("{t}.bounds.{b}{suffix}")), 0.98)
        })
        .fold(f64::NEG_INFINITY, f64::max);
    let mut legend = Vec::new();
    let mut panels = Vec::new();
    for (track, bs) in &by_track {
        let mut panel = Panel::new(
            300,
            &format!(
                "relative tightness τ = (bound − error) / error of the bounds on {}",
                curve_label(track)
            ),
            "fraction of trials (CDF)",
        );
        let mut cut = false;
        for b in bs {
            let v = column(data, &format!("{track}.bounds.{b}{suffix}"));
            if v.is_empty() {
                continue;
            }
            let mut pts = cdf_points(v);
            if cap.is_finite() && pts.iter().any(|p| p.0 > cap) {
                let below = pts
                    .iter()
                    .filter(|p| p.0 <= cap)
                    .map(|p| p.1)
                    .fold(0.0, f64::max);
                pts.retain(|p| p.0 <= cap);
                pts.push((cap, below));
                cut = true;
            }
            let st = Style::line(color(b), 2);
            panel.series.push(Series {
                name: format!("{track}.{b}"),
                segments: vec![pts],
                style: st,
            });
            legend.push(LegendItem {
                label: b.clone(),
                swatch: Swatch::Line(st),
            });
        }
        finish_series_panel(&mut panel, false, false);
        panel.y_range = (0.0, 1.0);
        if cut {
            panel.x_label = format!("{} (cut at its 98th percentile)", panel.x_label);
        }
        panels.push(panel);
    }
    super::dedup_legend(&mut legend);
    Some(Figure {
        name: "tightness".into(),
        title: format!(
            "CDF of the bounds' relative tightness, {}",
            trials_title(data)
        ),
        width: WIDTH,
        panels,
        legend,
    })
}

/// `scatter.svg`: every trial's estimate minus the truth (m), per track, at
/// equal scale, the truth at the origin.
pub fn scatter_figure(data: &RunData) -> Option<Figure> {
    let names = mc_names(data);
    let mut panel = Panel::new(520, "estimate − truth, x (m)", "estimate − truth, y (m)");
    let mut legend = Vec::new();
    // theta_bar last, drawn on top.
    let order: Vec<&str> = names
        .iter()
        .copied()
        .filter(|n| *n != THETA_BAR)
        .chain(names.iter().copied().filter(|n| *n == THETA_BAR))
        .collect();
    for name in order {
        let xs = column(data, &format!("{name}.error_x"));
        let ys = column(data, &format!("{name}.error_y"));
        if xs.is_empty() || xs.len() != ys.len() {
            continue;
        }
        let st = Style::markers(track_color(name, &names), Marker::Circle, 2).alpha(0.6);
        panel.series.push(Series {
            name: name.to_string(),
            segments: vec![xs.into_iter().zip(ys).collect()],
            style: st,
        });
        legend.push(LegendItem {
            label: curve_label(name),
            swatch: Swatch::Line(st),
        });
    }
    if panel.series.is_empty() {
        return None;
    }
    let truth = Style::markers(BLACK, Marker::Cross, 6);
    panel.series.push(Series {
        name: "truth".into(),
        segments: vec![vec![(0.0, 0.0)]],
        style: truth,
    });
    legend.push(LegendItem {
        label: "truth".into(),
        swatch: Swatch::Line(truth),
    });
    let pts = panel.points();
    let widen = |(lo, hi): (f64, f64)| {
        if hi > lo {
            (lo, hi)
        } else {
            (lo - 1.0, hi + 1.0)
        }
    };
    let x = widen(linear_range(pts.iter().map(|p| p.0), 0.05));
    let y = widen(linear_range(pts.iter().map(|p| p.1), 0.05));
    fit_map(&mut panel, x, y, 360, 640);
    Some(Figure {
        name: "scatter".into(),
        title: format!("Estimates around the truth, {}", trials_title(data)),
        width: WIDTH,
        panels: vec![panel],
        legend,
    })
}
