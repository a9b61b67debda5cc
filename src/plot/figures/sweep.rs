//! `sweep.svg`: a metric against the first grid key of a sweep, one line per
//! combination of the other keys, with error bars of one standard deviation
//! over the seeds.

use crate::plot::Figure;
use crate::plot::LegendItem;
use crate::plot::Marker;
use crate::plot::Panel;
use crate::plot::Series;
use crate::plot::Style;
use crate::plot::Swatch;
use crate::plot::figures::PALETTE;
use crate::plot::figures::WIDTH;
use crate::plot::figures::linear_range;
use crate::plot::figures::wants_log;

/// One line of the sweep plot.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepCurve {
    /// The other keys' values (`gamma=1e-7, mode=sync`), or the metric.
    pub label: String,
    /// `(x, mean, std)` per grid value of the first key.
    pub points: Vec<(f64, f64, Option<f64>)>,
}

/// The sweep figure. `x_key` is the first grid key; `categories` its values
/// when they are not numbers (then `x` is the value's index); `metric` the
/// plotted metric. The x axis is logarithmic when the values are positive
/// and span more than 30x, and so is the y axis for the means.
pub fn sweep_figure(
    x_key: &str,
    categories: Option<&[String]>,
    metric: &str,
    curves: &[SweepCurve],
) -> Figure {
    let xs = || curves.iter().flat_map(|c| c.points.iter().map(|p| p.0));
    let log_x = categories.is_none() && xs().all(|x| x > 0.0) && wants_log(xs());
    let log_y = curves
        .iter()
        .flat_map(|c| c.points.iter())
        .all(|p| p.1 > 0.0)
        && wants_log(curves.iter().flat_map(|c| c.points.iter().map(|p| p.1)));
    let tx = |x: f64| if log_x { x.log10() } else { x };
    let x_label = match categories {
        Some(c) => format!(
            "{x_key} ({})",
            c.iter()
                .enumerate()
                .map(|(i, v)| format!("{i} = {v}"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
        None if log_x => format!("{x_key} (log scale)"),
        None => x_key.to_string(),
    };
    let mut panel = Panel::new(520, &x_label, metric);
    panel.log10_x = log_x;
    let mut legend = Vec::new();
    let x_span = {
        let (lo, hi) = linear_range(xs().map(tx), 0.0);
        (hi - lo).max(1e-9)
    };
    for (i, c) in curves.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        let marker = [
            Marker::Circle,
            Marker::Square,
            Marker::Triangle,
            Marker::Cross,
        ][(i / PALETTE.len()) % 4];
        let mut line = Style::line(color, 2);
        line.marker = Some(marker);
        line.marker_size = 4;
        panel.series.push(Series {
            name: c.label.clone(),
            segments: vec![c.points.iter().map(|p| (tx(p.0), p.1)).collect()],
            style: line,
        });
        // Error bars: mean +- std, with caps 1 % of the x span wide.
        let cap = 0.01 * x_span;
        let mut bars = Vec::new();
        for &(x, m, s) in &c.points {
            let Some(s) = s.filter(|s| *s > 0.0) else {
                continue;
            };
            let (x, lo, hi) = (tx(x), m - s, m + s);
            let lo = if log_y { lo.max(m / 1e3) } else { lo };
            bars.push(vec![(x, lo), (x, hi)]);
            bars.push(vec![(x - cap, lo), (x + cap, lo)]);
            bars.push(vec![(x - cap, hi), (x + cap, hi)]);
        }
        if !bars.is_empty() {
            panel.series.push(Series {
                name: format!("{} ± std", c.label),
                segments: bars,
                style: Style::line(color, 1),
            });
        }
        legend.push(LegendItem {
            label: c.label.clone(),
            swatch: Swatch::Line(line),
        });
    }
    if curves.iter().all(|c| c.points.is_empty()) {
        panel.note = Some(format!("no completed run has {metric}"));
    }
    super::series::finish_series_panel(&mut panel, log_y, false);
    // Pad the x range so the end markers and caps are not cut.
    let pad = 0.04 * (panel.x_range.1 - panel.x_range.0);
    panel.x_range = (panel.x_range.0 - pad, panel.x_range.1 + pad);
    Figure {
        name: "sweep".into(),
        title: format!("{metric} against {x_key} (mean ± one std over the seeds)"),
        width: WIDTH,
        panels: vec![panel],
        legend,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve(label: &str, pts: &[(f64, f64, Option<f64>)]) -> SweepCurve {
        SweepCurve {
            label: label.into(),
            points: pts.to_vec(),
        }
    }

    #[test]
    fn a_wide_positive_grid_gets_log_axes_and_every_point_is_in_range() {
        let c = [
            curve(
                "a",
                &[
                    (1e-9, 200.0, Some(10.0)),
                    (1e-7, 2.5, Some(0.1)),
                    (1e2, 90.0, None),
                ],
            ),
            curve(
                "b",
                &[
                    (1e-9, 150.0, None),
                    (1e-7, 3.0, Some(0.5)),
                    (1e2, 60.0, Some(5.0)),
                ],
            ),
        ];
        let f = sweep_figure("algorithm.gamma", None, "rmse_after_burn_in", &c);
        let p = &f.panels[0];
        assert!(p.log10_x && p.log_y);
        for q in p.points() {
            assert!(
                p.contains(q),
                "{q:?} outside {:?} {:?}",
                p.x_range,
                p.y_range
            );
        }
        assert_eq!(f.legend.len(), 2);
        // The error bar of the first point: 190..210 at x = -9.
        let bars = &p.series[1].segments[0];
        assert_eq!(bars, &vec![(-9.0, 190.0), (-9.0, 210.0)]);
    }

    #[test]
    fn a_narrow_or_categorical_grid_stays_linear() {
        let c = [curve("m", &[(0.0, 1.0, None), (1.0, 2.0, None)])];
        let f = sweep_figure(
            "algorithm.mode",
            Some(&["sync".into(), "async".into()]),
            "rmse",
            &c,
        );
        let p = &f.panels[0];
        assert!(!p.log10_x && !p.log_y);
        assert!(p.x_label.contains("0 = sync, 1 = async"), "{}", p.x_label);
    }
}
