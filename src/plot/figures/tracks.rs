//! `tracks.svg`: the true track, every estimated track and the geometry on one map,
//! with the bound discs.

use crate::plot::Disc;
use crate::plot::Figure;
use crate::plot::LegendItem;
use crate::plot::Marker;
use crate::plot::Panel;
use crate::plot::Series;
use crate::plot::Style;
use crate::plot::Swatch;
use crate::plot::data::RunData;
use crate::plot::data::THETA_BAR;
use crate::plot::data::Track;
use crate::plot::data::TrackKind;
use crate::plot::figures::BLACK;
use crate::plot::figures::BOUND_COLORS;
use crate::plot::figures::WIDTH;
use crate::plot::figures::dedup_legend;
use crate::plot::figures::draw_geometry;
use crate::plot::figures::fit_map;
use crate::plot::figures::geometry_points;
use crate::plot::figures::linear_range;
use crate::plot::figures::names;
use crate::plot::figures::point_segments;
use crate::plot::figures::track_style;

/// `tracks.svg`: the true track, every estimated track, the geometry to
/// scale (cf. Mourya 2017 Fig. 2b) and the bound discs at every n-th sample.
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
    let n = tt.sample.len();
    bound_discs(data, &mut tracks, &mut legend);
    truth_line(&tt.truth, &mut tracks, &mut legend);
    // Reference first (under), then baselines, then theta_bar on top.
    let mut order: Vec<&Track> = tt.tracks.iter().collect();
    order.sort_by_key(|t| match t.kind {
        TrackKind::Reference => 0,
        TrackKind::Baseline => 1,
        TrackKind::Distributed => 2,
    });
    // The axes keep to the scene: the sensors and the true track, with a
    // margin of one scene size. Estimates beyond it (a diverging baseline)
    // are clipped at the edge and named, instead of shrinking everything
    // else to a dot.
    let mut scene: Vec<(f64, f64)> = geometry_points(data);
    scene.extend(tt.truth.iter().flatten().map(|p| (p[0], p[1])));
    let (sx, sy) = (
        linear_range(scene.iter().map(|p| p.0), 0.0),
        linear_range(scene.iter().map(|p| p.1), 0.0),
    );
    let size = (sx.1 - sx.0).max(sy.1 - sy.0);
    let on_map = |p: &(f64, f64)| {
        p.0 >= sx.0 - size && p.0 <= sx.1 + size && p.1 >= sy.0 - size && p.1 <= sy.1 + size
    };
    let mut clipped: Vec<String> = Vec::new();
    let mut in_scene: Vec<(f64, f64)> = tracks.points().into_iter().filter(|p| on_map(p)).collect();
    for t in order {
        let st = track_style(t, &names);
        let segments = point_segments(&t.pos);
        let off = segments.iter().flatten().filter(|p| !on_map(p)).count();
        in_scene.extend(segments.iter().flatten().filter(|p| on_map(p)).copied());
        tracks.series.push(Series {
            name: t.name.clone(),
            segments,
            style: st,
        });
        let mut label = t.label();
        if off > 0 {
            clipped.push(format!("{} ({off} samples)", t.name));
            label.push_str(&format!(" ({off} samples off the map)"));
        }
        legend.push(LegendItem {
            label,
            swatch: Swatch::Line(st),
        });
    }
    let track_pts = in_scene;
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
    if !clipped.is_empty() {
        panels[0].caption = Some(format!("clipped at the scene: {}", clipped.join(", ")));
    }
    dedup_legend(&mut legend);
    Figure {
        name: "tracks".into(),
        title: if data.dim() == 3 {
            format!("Tracks in plan view (x, y) — {}", data.title())
        } else {
            format!("Tracks — {}", data.title())
        },
        width: WIDTH,
        panels,
        legend,
    }
}

/// Bound discs around `theta_bar` at every n-th sample (a dozen in all).
fn bound_discs(data: &RunData, tracks: &mut Panel, legend: &mut Vec<LegendItem>) {
    let tt = &data.track;
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
}

/// The true track, a line with a dot at every sample.
fn truth_line(
    truth: &[Option<crate::plot::data::Pos>],
    tracks: &mut Panel,
    legend: &mut Vec<LegendItem>,
) {
    let truth = point_segments(truth);
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
}
