//! Drawing a [`Figure`] with plotters (SVG string or PNG file).

use super::Disc;
use super::Figure;
use super::Marker;
use super::Panel;
use super::PlotError;
use super::Rgb;
use super::Style;
use plotters::coord::Shift;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;
use std::sync::OnceLock;

mod legend;
use legend::draw_legend;

/// Height of the title strip (px).
pub(crate) const TITLE_H: u32 = 46;
/// Width of the legend column (px).
pub(crate) const LEGEND_W: u32 = 270;
const Y_LABEL_AREA: u32 = 84;
const X_LABEL_AREA: u32 = 52;
const M_TOP: u32 = 14;
const M_RIGHT: u32 = 22;
const M_LEFT: u32 = 10;
const M_BOTTOM: u32 = 6;

/// Font family: the bundled DejaVu Sans lays text out; browsers use it when
/// installed, else their sans-serif.
const FONT: &str = "DejaVu Sans, Arial, sans-serif";
/// DejaVu Sans (Bitstream Vera licence, see assets/fonts/LICENSE-DejaVu.txt):
/// text metrics for every backend and glyphs for PNG, without system fonts.
static FONT_BYTES: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// Plot-area size (px) of a panel `height` high in a figure `width` wide.
pub(crate) fn plot_area(width: u32, height: u32) -> (f64, f64) {
    (
        width.saturating_sub(LEGEND_W + Y_LABEL_AREA + M_LEFT + M_RIGHT) as f64,
        height.saturating_sub(X_LABEL_AREA + M_TOP + M_BOTTOM) as f64,
    )
}

fn ensure_font() -> Result<(), PlotError> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(PlotError::Render {
            figure: "font".into(),
            reason: "the bundled DejaVu Sans font could not be parsed".into(),
        })
    }
}

fn rgb(c: Rgb) -> RGBColor {
    RGBColor(c.0, c.1, c.2)
}

fn err<E: std::fmt::Display>(fig: &Figure) -> impl Fn(E) -> PlotError + '_ {
    move |e| PlotError::Render {
        figure: fig.name.clone(),
        reason: e.to_string(),
    }
}

/// Draw `fig` as an SVG document.
pub fn render_svg(fig: &Figure) -> Result<String, PlotError> {
    ensure_font()?;
    let mut buf = String::new();
    {
        let root = SVGBackend::with_string(&mut buf, (fig.width, fig.height())).into_drawing_area();
        draw_figure(&root, fig, Joins::Path).map_err(err(fig))?;
        root.present().map_err(err(fig))?;
    }
    Ok(buf)
}

/// Draw `fig` into the PNG file `path`.
pub fn render_png(fig: &Figure, path: &Path) -> Result<(), PlotError> {
    ensure_font()?;
    let root = BitMapBackend::new(path, (fig.width, fig.height())).into_drawing_area();
    draw_figure(&root, fig, Joins::Segments).map_err(err(fig))?;
    root.present().map_err(|e| PlotError::Write {
        path: path.to_path_buf(),
        source: std::io::Error::other(e.to_string()),
    })
}

type DResult<DB> = Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// How thick polylines are drawn. The bitmap backend joins the segments of
/// a wide path with unbounded miters, so a sharp turn (a noisy track
/// doubling back) draws a long spike across the figure; there every segment
/// is drawn on its own. SVG viewers bound miters themselves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Joins {
    Path,
    Segments,
}

fn draw_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    fig: &Figure,
    joins: Joins,
) -> DResult<DB> {
    root.fill(&WHITE)?;
    let (title, body) = root.split_vertically(TITLE_H);
    // Shrink long titles to fit (DejaVu Sans averages ~0.6 em per glyph).
    let chars = fig.title.chars().count().max(1) as f64;
    let size = (25.0f64)
        .min((fig.width as f64 - 40.0) / (0.6 * 0.8 * chars))
        .max(12.0);
    title.draw_text(
        &fig.title,
        &(FONT, size).into_font().color(&RGBColor(25, 25, 25)),
        ((M_LEFT + 8) as i32, 13),
    )?;
    let (plots, legend) = body.split_horizontally(fig.width.saturating_sub(LEGEND_W));
    let mut rest = plots;
    for p in &fig.panels {
        let (area, r) = rest.split_vertically(p.height);
        draw_panel(&area, p, joins)?;
        rest = r;
    }
    draw_legend(&legend, &fig.legend)?;
    Ok(())
}

/// Compact tick labels: no trailing zeros, exponents for extremes.
pub(crate) fn tick(v: f64) -> String {
    let a = v.abs();
    if a < 1e-12 {
        return "0".into();
    }
    if !(1e-3..1e6).contains(&a) {
        return format!("{v:.1e}");
    }
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

/// Ticks of a log axis over `(lo, hi)`: 1, 2 and 5 times every power of
/// ten when it spans up to three decades, the powers of ten alone beyond
/// (every other one beyond twelve), so a short log axis has more than its
/// one or two powers of ten labelled.
pub(crate) fn log_ticks((lo, hi): (f64, f64)) -> Vec<f64> {
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return Vec::new();
    }
    let (k0, k1) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let decades = hi.log10() - lo.log10();
    let mults: &[f64] = if decades <= 3.0 {
        &[1.0, 2.0, 5.0]
    } else {
        &[1.0]
    };
    let step = if decades > 12.0 { 2 } else { 1 };
    (k0..=k1)
        .filter(|k| (k - k0) % step == 0)
        .flat_map(|k| mults.iter().map(move |m| m * 10f64.powi(k)))
        .filter(|v| *v >= lo * (1.0 - 1e-12) && *v <= hi * (1.0 + 1e-12))
        .collect()
}

fn chart_builder<'a, 'b, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
) -> ChartBuilder<'a, 'b, DB> {
    let mut cb = ChartBuilder::on(area);
    cb.margin_top(M_TOP)
        .margin_bottom(M_BOTTOM)
        .margin_left(M_LEFT)
        .margin_right(M_RIGHT)
        .x_label_area_size(X_LABEL_AREA)
        .y_label_area_size(Y_LABEL_AREA);
    cb
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &Panel,
    joins: Joins,
) -> DResult<DB> {
    let mut cb = chart_builder(area);
    let xr = p.x_range.0..p.x_range.1;
    if p.log_y {
        let y = (p.y_range.0..p.y_range.1)
            .log_scale()
            .with_key_points(log_ticks(p.y_range));
        let mut chart = cb.build_cartesian_2d(xr, y)?;
        contents(&mut chart, p, joins)
    } else {
        let mut chart = cb.build_cartesian_2d(xr, p.y_range.0..p.y_range.1)?;
        contents(&mut chart, p, joins)
    }
}

fn shape(s: &Style) -> ShapeStyle {
    rgb(s.color).mix(s.opacity).stroke_width(s.width.max(1))
}

/// Polygon approximation of a disc, clipped to the rectangle (convex clip,
/// Sutherland-Hodgman).
fn disc_polygon(d: &Disc, x: (f64, f64), y: (f64, f64)) -> Vec<(f64, f64)> {
    let n = 72;
    let mut poly: Vec<(f64, f64)> = (0..n)
        .map(|i| {
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            (
                d.center.0 + d.radius * a.cos(),
                d.center.1 + d.radius * a.sin(),
            )
        })
        .collect();
    type Edge = (
        fn(&(f64, f64), f64) -> bool,
        fn(&(f64, f64), &(f64, f64), f64) -> (f64, f64),
    );
    let lerp_x = |a: &(f64, f64), b: &(f64, f64), c: f64| {
        let t = (c - a.0) / (b.0 - a.0);
        (c, a.1 + t * (b.1 - a.1))
    };
    let lerp_y = |a: &(f64, f64), b: &(f64, f64), c: f64| {
        let t = (c - a.1) / (b.1 - a.1);
        (a.0 + t * (b.0 - a.0), c)
    };
    let edges: [(Edge, f64); 4] = [
        ((|p, c| p.0 >= c, lerp_x), x.0),
        ((|p, c| p.0 <= c, lerp_x), x.1),
        ((|p, c| p.1 >= c, lerp_y), y.0),
        ((|p, c| p.1 <= c, lerp_y), y.1),
    ];
    for ((inside, cut), c) in edges {
        if poly.is_empty() {
            break;
        }
        let mut out = Vec::with_capacity(poly.len() + 4);
        for i in 0..poly.len() {
            let a = poly[i];
            let b = poly[(i + 1) % poly.len()];
            match (inside(&a, c), inside(&b, c)) {
                (true, true) => out.push(b),
                (true, false) => out.push(cut(&a, &b, c)),
                (false, true) => {
                    out.push(cut(&a, &b, c));
                    out.push(b);
                }
                (false, false) => {}
            }
        }
        poly = out;
    }
    poly
}

/// Everything inside a panel's axes, bottom layer first.
fn contents<DB, Y>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, Y>>,
    p: &Panel,
    joins: Joins,
) -> DResult<DB>
where
    DB: DrawingBackend,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    draw_shading(chart, p)?;
    draw_mesh(chart, p)?;
    draw_areas(chart, p)?;
    draw_vlines(chart, p)?;
    draw_lines(chart, p, joins)?;
    draw_texts(chart, p)
}

/// The shaded spans with their captions, and the shading left of a
/// vertical line that asks for it.
fn draw_shading<DB, Y>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, Y>>,
    p: &Panel,
) -> DResult<DB>
where
    DB: DrawingBackend,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let (y0, y1) = p.y_range;
    for s in &p.spans {
        let (a, b) = (s.x0.max(p.x_range.0), s.x1.min(p.x_range.1));
        if b > a {
            chart.draw_series(std::iter::once(Rectangle::new(
                [(a, y0), (b, y1)],
                rgb(s.color).mix(0.14).filled(),
            )))?;
        }
        if (p.x_range.0..=p.x_range.1).contains(&s.x0) {
            chart.draw_series(std::iter::once(
                EmptyElement::at((s.x0, y1))
                    + Text::new(
                        s.caption.clone(),
                        (4, 22),
                        (FONT, 14).into_font().color(&rgb(s.color)),
                    ),
            ))?;
        }
    }
    for v in &p.vlines {
        if v.shade_left && v.x > p.x_range.0 {
            chart.draw_series(std::iter::once(Rectangle::new(
                [(p.x_range.0, y0), (v.x.min(p.x_range.1), y1)],
                RGBColor(120, 120, 120).mix(0.10).filled(),
            )))?;
        }
    }
    Ok(())
}

/// The grid, the axes and their labels.
fn draw_mesh<DB, Y>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, Y>>,
    p: &Panel,
) -> DResult<DB>
where
    DB: DrawingBackend,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let fmt = |v: &f64| tick(*v);
    let fmt_x = |v: &f64| {
        if p.log10_x {
            tick(10f64.powf(*v))
        } else {
            tick(*v)
        }
    };
    chart
        .configure_mesh()
        .x_desc(p.x_label.as_str())
        .y_desc(p.y_label.as_str())
        .label_style((FONT, 17).into_font().color(&RGBColor(55, 55, 55)))
        .axis_desc_style((FONT, 19).into_font().color(&RGBColor(25, 25, 25)))
        .bold_line_style(RGBColor(215, 215, 215).stroke_width(1))
        .light_line_style(TRANSPARENT)
        .axis_style(RGBColor(80, 80, 80).stroke_width(1))
        .x_labels(10)
        .y_labels(8)
        .x_label_formatter(&fmt_x)
        .y_label_formatter(&fmt)
        .draw()?;
    Ok(())
}

/// The bands and the discs.
fn draw_areas<DB, Y>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, Y>>,
    p: &Panel,
) -> DResult<DB>
where
    DB: DrawingBackend,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    for b in &p.bands {
        for seg in &b.segments {
            let mut poly: Vec<(f64, f64)> = seg.iter().map(|q| (q.0, q.2)).collect();
            poly.extend(seg.iter().rev().map(|q| (q.0, q.1)));
            chart.draw_series(std::iter::once(Polygon::new(
                poly,
                rgb(b.color).mix(0.18).filled(),
            )))?;
        }
    }
    for d in &p.discs {
        let poly = disc_polygon(d, p.x_range, p.y_range);
        if poly.len() < 3 {
            continue;
        }
        chart.draw_series(std::iter::once(Polygon::new(
            poly.clone(),
            rgb(d.color).mix(0.07).filled(),
        )))?;
        let mut ring = poly;
        ring.push(ring[0]);
        chart.draw_series(std::iter::once(PathElement::new(
            ring,
            rgb(d.color).mix(0.75).stroke_width(1),
        )))?;
    }
    Ok(())
}

/// The dashed vertical lines with their captions.
fn draw_vlines<DB, Y>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, Y>>,
    p: &Panel,
) -> DResult<DB>
where
    DB: DrawingBackend,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let (y0, y1) = p.y_range;
    for v in &p.vlines {
        chart.draw_series(DashedLineSeries::new(
            vec![(v.x, y0), (v.x, y1)],
            6,
            4,
            RGBColor(90, 90, 90).stroke_width(1),
        ))?;
        chart.draw_series(std::iter::once(
            EmptyElement::at((v.x, y1))
                + Text::new(
                    v.caption.clone(),
                    (5, 5),
                    (FONT, 16).into_font().color(&RGBColor(70, 70, 70)),
                ),
        ))?;
    }
    Ok(())
}

/// Every series: its lines clipped to the plot area, its markers.
fn draw_lines<DB, Y>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, Y>>,
    p: &Panel,
    joins: Joins,
) -> DResult<DB>
where
    DB: DrawingBackend,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    for s in &p.series {
        let st = shape(&s.style);
        for seg in &s.segments {
            // Lines are clipped to the plot area here: a backend draws a
            // line to a point outside the ranges across the margins, title
            // and legend (the bitmap backend does).
            if s.style.width > 0 && seg.len() > 1 {
                for piece in clip_polyline(seg, p.x_range, p.y_range, p.log_y) {
                    if s.style.dashed {
                        chart.draw_series(DashedLineSeries::new(piece, 9, 5, st))?;
                    } else if joins == Joins::Segments && s.style.width > 1 {
                        chart.draw_series(
                            piece
                                .windows(2)
                                .map(|w| PathElement::new(vec![w[0], w[1]], st)),
                        )?;
                    } else {
                        chart.draw_series(LineSeries::new(piece, st))?;
                    }
                }
            }
            if let Some(m) = s.style.marker {
                let inside: Vec<(f64, f64)> =
                    seg.iter().copied().filter(|q| p.contains(*q)).collect();
                draw_markers(chart, &inside, m, &s.style)?;
            } else if s.style.width > 0 && seg.len() == 1 && p.contains(seg[0]) {
                // A line of one point (a one-sample track, or a point
                // between two gaps) would draw nothing: draw it as a dot of
                // the line's colour.
                let dot = Style {
                    marker_size: s.style.width + 2,
                    ..s.style
                };
                draw_markers(chart, seg, Marker::Circle, &dot)?;
            }
        }
    }
    Ok(())
}

/// The labels, the caption and the note.
fn draw_texts<DB, Y>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, Y>>,
    p: &Panel,
) -> DResult<DB>
where
    DB: DrawingBackend,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    for l in &p.labels {
        let font = (FONT, l.size).into_font().color(&RGBColor(30, 30, 30));
        let lh = (l.size as f64 * 1.25).round() as i32;
        chart.draw_series(l.lines.iter().enumerate().map(|(i, line)| {
            EmptyElement::at(l.at)
                + Text::new(
                    line.clone(),
                    (l.offset.0, l.offset.1 + i as i32 * lh),
                    font.clone(),
                )
        }))?;
    }
    if let Some(c) = &p.caption {
        let area = chart.plotting_area().strip_coord_spec();
        area.draw_text(
            c,
            &(FONT, 17).into_font().color(&RGBColor(80, 80, 80)),
            (10, 8),
        )?;
    }
    if let Some(note) = &p.note {
        let area = chart.plotting_area();
        let (w, h) = area.dim_in_pixel();
        let style = (FONT, 22)
            .into_font()
            .color(&RGBColor(120, 120, 120))
            .pos(Pos::new(HPos::Center, VPos::Center));
        area.strip_coord_spec()
            .draw_text(note, &style, (w as i32 / 2, h as i32 / 2))?;
    }
    Ok(())
}

/// Clip a polyline to the rectangle `x` x `y` (Liang-Barsky on every
/// segment, in the drawn coordinates: `log10 y` on a log axis, where the
/// drawn segments are straight), as the pieces that lie inside.
pub(crate) fn clip_polyline(
    pts: &[(f64, f64)],
    x: (f64, f64),
    y: (f64, f64),
    log_y: bool,
) -> Vec<Vec<(f64, f64)>> {
    let fy = |v: f64| {
        if log_y {
            v.max(f64::MIN_POSITIVE).log10()
        } else {
            v
        }
    };
    let gy = |v: f64| if log_y { 10f64.powf(v) } else { v };
    let (ylo, yhi) = (fy(y.0), fy(y.1));
    let mut out: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut cur: Vec<(f64, f64)> = Vec::new();
    for w in pts.windows(2) {
        let (a, b) = ((w[0].0, fy(w[0].1)), (w[1].0, fy(w[1].1)));
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        let mut keep = a.0.is_finite() && a.1.is_finite() && b.0.is_finite() && b.1.is_finite();
        for (pk, qk) in [
            (-dx, a.0 - x.0),
            (dx, x.1 - a.0),
            (-dy, a.1 - ylo),
            (dy, yhi - a.1),
        ] {
            if !keep {
                break;
            }
            if pk == 0.0 {
                keep = qk >= 0.0;
            } else {
                let r = qk / pk;
                if pk < 0.0 {
                    t0 = t0.max(r);
                } else {
                    t1 = t1.min(r);
                }
                keep = t0 <= t1;
            }
        }
        if !keep {
            if cur.len() > 1 {
                out.push(std::mem::take(&mut cur));
            }
            cur.clear();
            continue;
        }
        // Vertices inside are kept exactly; only cuts are computed.
        let p0 = if t0 > 0.0 {
            (a.0 + t0 * dx, gy(a.1 + t0 * dy))
        } else {
            w[0]
        };
        let p1 = if t1 < 1.0 {
            (a.0 + t1 * dx, gy(a.1 + t1 * dy))
        } else {
            w[1]
        };
        if t0 > 0.0 || cur.is_empty() {
            if cur.len() > 1 {
                out.push(std::mem::take(&mut cur));
            }
            cur = vec![p0];
        }
        cur.push(p1);
        if t1 < 1.0 {
            out.push(std::mem::take(&mut cur));
        }
    }
    if cur.len() > 1 {
        out.push(cur);
    }
    out
}

fn draw_markers<DB, Y>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<RangedCoordf64, Y>>,
    seg: &[(f64, f64)],
    m: Marker,
    s: &Style,
) -> DResult<DB>
where
    DB: DrawingBackend,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let fill = rgb(s.color).mix(s.opacity).filled();
    let size = s.marker_size.max(1);
    let outline = RGBColor(40, 40, 40).mix(0.8).stroke_width(1);
    match m {
        Marker::Circle => {
            chart.draw_series(seg.iter().map(|p| Circle::new(*p, size, fill)))?;
            if size >= 5 {
                chart.draw_series(seg.iter().map(|p| Circle::new(*p, size, outline)))?;
            }
        }
        Marker::Triangle => {
            chart.draw_series(seg.iter().map(|p| TriangleMarker::new(*p, size, fill)))?;
        }
        Marker::Square => {
            let h = size as i32;
            chart.draw_series(
                seg.iter()
                    .map(|p| EmptyElement::at(*p) + Rectangle::new([(-h, -h), (h, h)], fill)),
            )?;
        }
        Marker::Cross => {
            chart.draw_series(
                seg.iter()
                    .map(|p| Cross::new(*p, size, rgb(s.color).stroke_width(2))),
            )?;
        }
    }
    Ok(())
}

/// The plot-area size plotters really lays out for a panel `height` high in a
/// figure `width` wide (checks [`plot_area`]).
#[cfg(test)]
pub(crate) fn measured_plot_area(width: u32, height: u32) -> (u32, u32) {
    let mut buf = String::new();
    let root = SVGBackend::with_string(&mut buf, (width, height + TITLE_H)).into_drawing_area();
    let (_, body) = root.split_vertically(TITLE_H);
    let (plots, _) = body.split_horizontally(width - LEGEND_W);
    let (area, _) = plots.split_vertically(height);
    let chart = chart_builder(&area)
        .build_cartesian_2d(0.0..1.0, 0.0..1.0)
        .expect("build chart");
    chart.plotting_area().dim_in_pixel()
}

#[cfg(test)]
pub(crate) fn disc_polygon_for_test(d: &Disc, x: (f64, f64), y: (f64, f64)) -> Vec<(f64, f64)> {
    disc_polygon(d, x, y)
}
