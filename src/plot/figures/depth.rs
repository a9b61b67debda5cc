//! `depth.svg` (3-D runs): the depth of the true and estimated tracks
//! against the sample, and the vertical section `x`-`z` of the scene
//! (`tracks.svg` is then the plan view).

use crate::plot::Figure;
use crate::plot::Label;
use crate::plot::LegendItem;
use crate::plot::Marker;
use crate::plot::Panel;
use crate::plot::Rgb;
use crate::plot::Series;
use crate::plot::Style;
use crate::plot::Swatch;
use crate::plot::data::Pos;
use crate::plot::data::RunData;
use crate::plot::data::Track;
use crate::plot::data::TrackKind;
use crate::plot::figures::BLACK;
use crate::plot::figures::TX_COLOR;
use crate::plot::figures::WIDTH;
use crate::plot::figures::dedup_legend;
use crate::plot::figures::draw_drift;
use crate::plot::figures::linear_range;
use crate::plot::figures::names;
use crate::plot::figures::segments;
use crate::plot::figures::track_style;

/// `depth.svg`, for a 3-D run only (`None` in 2-D): `z` of the truth and of
/// every track against the sample, and the `x`-`z` section with the
/// transmitters, the receivers and the tracks. Both axes keep to the scene
/// (the sensors and the true track, with a margin of one scene size): an
/// estimate beyond it is clipped at the edge, as in `tracks.svg`.
pub fn depth_figure(data: &RunData) -> Option<Figure> {
    if data.dim() != 3 {
        return None;
    }
    let tt = &data.track;
    let names = names(data);
    let mut legend = Vec::new();
    let mut order: Vec<&Track> = tt.tracks.iter().collect();
    order.sort_by_key(|t| match t.kind {
        TrackKind::Reference => 0,
        TrackKind::Baseline => 1,
        TrackKind::Distributed => 2,
    });
    let truth_style = Style {
        marker: Some(Marker::Circle),
        marker_size: 2,
        ..Style::line(BLACK, 2)
    };
    // The scene: sensors (and where drifting receivers go) and truth.
    let paths = data.drift_paths();
    let sensors: Vec<Pos> = data
        .info
        .transmitters
        .iter()
        .chain(&data.info.receivers)
        .chain(paths.iter().flat_map(|(_, p)| p))
        .copied()
        .collect();
    let scene: Vec<Pos> = sensors
        .iter()
        .copied()
        .chain(tt.truth.iter().flatten().copied())
        .collect();
    let widen = |r: (f64, f64)| {
        let s = (r.1 - r.0).max(1.0);
        (r.0 - s, r.1 + s)
    };
    let (zr, xr) = (
        linear_range(scene.iter().map(|p| p[2]), 0.0),
        linear_range(scene.iter().map(|p| p[0]), 0.0),
    );
    let (zlim, xlim) = (widen(zr), widen(xr));
    let inside = |v: f64, r: (f64, f64)| v >= r.0 && v <= r.1;

    // Depth against the sample.
    let mut zt = Panel::new(380, "sample k", "z (m, up; the surface is 0)");
    let z_of = |pos: &[Option<Pos>]| pos.iter().map(|p| p.map(|p| p[2])).collect::<Vec<_>>();
    let truth_z = z_of(&tt.truth);
    if truth_z.iter().any(Option::is_some) {
        zt.series.push(Series {
            name: "truth".into(),
            segments: segments(&tt.sample, &truth_z, false),
            style: truth_style,
        });
        legend.push(LegendItem {
            label: "true track".into(),
            swatch: Swatch::Line(truth_style),
        });
    }
    for t in &order {
        let st = track_style(t, &names);
        zt.series.push(Series {
            name: t.name.clone(),
            segments: segments(&tt.sample, &z_of(&t.pos), false),
            style: st,
        });
        legend.push(LegendItem {
            label: t.label(),
            swatch: Swatch::Line(st),
        });
    }
    let shown: Vec<f64> = zt
        .points()
        .into_iter()
        .map(|p| p.1)
        .filter(|z| inside(*z, zlim))
        .chain(scene.iter().map(|p| p[2]))
        .collect();
    zt.x_range = linear_range(tt.sample.iter().copied(), 0.0);
    zt.y_range = linear_range(shown.into_iter(), 0.06);
    zt.caption = Some("depth against the sample".into());

    // The x-z section.
    let mut sec = Panel::new(420, "x (m)", "z (m, up)");
    let sensor_series = |pts: &[Pos], name: &str, st: Style, tag: &str, sec: &mut Panel| {
        if pts.is_empty() {
            return;
        }
        sec.series.push(Series {
            name: name.into(),
            segments: vec![pts.iter().map(|p| (p[0], p[2])).collect()],
            style: st,
        });
        for (i, p) in pts.iter().enumerate() {
            sec.labels.push(Label {
                at: (p[0], p[2]),
                offset: (9, 4),
                lines: vec![format!("{tag}{i}")],
                size: 14,
            });
        }
    };
    let tx_st = Style::markers(TX_COLOR, Marker::Triangle, 8);
    let rx_st = Style::markers(Rgb(40, 40, 40), Marker::Square, 6);
    sensor_series(
        &data.info.transmitters,
        "transmitters",
        tx_st,
        "T",
        &mut sec,
    );
    draw_drift(data, |p| (p[0], p[2]), &mut sec, &mut legend);
    sensor_series(&data.info.receivers, "receivers", rx_st, "R", &mut sec);
    if !data.info.transmitters.is_empty() {
        legend.push(LegendItem {
            label: "transmitter".into(),
            swatch: Swatch::Line(tx_st),
        });
    }
    if !data.info.receivers.is_empty() {
        legend.push(LegendItem {
            label: "receiver (node)".into(),
            swatch: Swatch::Line(rx_st),
        });
    }
    let xz = |pos: &[Option<Pos>]| -> Vec<Vec<(f64, f64)>> {
        let xs: Vec<f64> = pos.iter().map(|p| p.map_or(0.0, |p| p[0])).collect();
        let zs: Vec<Option<f64>> = pos.iter().map(|p| p.map(|p| p[2])).collect();
        // Each point's own x, broken where a position is missing.
        segments(&xs, &zs, false)
    };
    if tt.truth.iter().any(Option::is_some) {
        sec.series.push(Series {
            name: "truth".into(),
            segments: xz(&tt.truth),
            style: truth_style,
        });
    }
    for t in &order {
        sec.series.push(Series {
            name: t.name.clone(),
            segments: xz(&t.pos),
            style: track_style(t, &names),
        });
    }
    let pts: Vec<(f64, f64)> = sec
        .points()
        .into_iter()
        .filter(|p| inside(p.0, xlim) && inside(p.1, zlim))
        .collect();
    sec.x_range = linear_range(pts.iter().map(|p| p.0), 0.06);
    sec.y_range = linear_range(pts.iter().map(|p| p.1), 0.08);
    let (w, h) = (sec.x_range.1 - sec.x_range.0, sec.y_range.1 - sec.y_range.0);
    let (pw, ph) = crate::plot::render::plot_area(WIDTH, sec.height);
    // Metres per pixel across over metres per pixel up.
    let exaggeration = (w / pw) / (h / ph);
    sec.caption = Some(if exaggeration > 1.5 {
        format!("x-z section, vertical scale {exaggeration:.0}x the horizontal")
    } else {
        "x-z section".into()
    });
    if tt.sample.is_empty() {
        zt.note = Some("no samples in track.csv".into());
    }
    dedup_legend(&mut legend);
    Some(Figure {
        name: "depth".into(),
        title: format!("Depth — {}", data.title()),
        width: WIDTH,
        panels: vec![zt, sec],
        legend,
    })
}
