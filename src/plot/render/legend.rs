//! The legend column of a figure: one row per item, its swatch (line,
//! marker, area or disc) and its label word-wrapped.

use super::{DResult, FONT, LEGEND_W, M_TOP, rgb, shape};
use crate::plot::{LegendItem, Marker, Swatch};
use plotters::coord::Shift;
use plotters::prelude::*;

/// Word-wrap `s` to lines of at most `n` characters.
fn wrap(s: &str, n: usize) -> Vec<String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    for w in s.split_whitespace() {
        if !cur.is_empty() && cur.chars().count() + 1 + w.chars().count() > n {
            out.push(std::mem::take(&mut cur));
        }
        if !cur.is_empty() {
            cur.push(' ');
        }
        cur.push_str(w);
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

/// The legend of a figure, in the column `area` at its right.
pub(super) fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    items: &[LegendItem],
) -> DResult<DB> {
    if items.is_empty() {
        return Ok(());
    }
    let font = (FONT, 17).into_font().color(&RGBColor(30, 30, 30));
    let (x0, sw, tx) = (6, 40, 56);
    let mut y = M_TOP as i32 + 14;
    let top = y - 12;
    let mut rows = Vec::new();
    for it in items {
        let lines = wrap(&it.label, 24);
        let h = 9 + 18 * lines.len().max(1) as i32;
        rows.push((it, lines, y));
        y += h;
    }
    let bottom = y - 2;
    area.draw(&Rectangle::new(
        [(x0 - 4, top), (LEGEND_W as i32 - 12, bottom)],
        RGBColor(190, 190, 190).stroke_width(1),
    ))?;
    for (it, lines, y) in rows {
        let cy = y + 7;
        match &it.swatch {
            Swatch::Line(s) => {
                let st = shape(s);
                if s.width > 0 {
                    if s.dashed {
                        area.draw(&PathElement::new(vec![(x0 + 2, cy), (x0 + 16, cy)], st))?;
                        area.draw(&PathElement::new(
                            vec![(x0 + 24, cy), (x0 + sw - 2, cy)],
                            st,
                        ))?;
                    } else {
                        area.draw(&PathElement::new(vec![(x0 + 2, cy), (x0 + sw - 2, cy)], st))?;
                    }
                }
                if let Some(m) = s.marker {
                    let c = (x0 + sw / 2, cy);
                    let size = s.marker_size.clamp(2, 8);
                    let fill = rgb(s.color).mix(s.opacity).filled();
                    match m {
                        Marker::Circle => {
                            area.draw(&Circle::new(c, size, fill))?;
                            if size >= 5 {
                                area.draw(&Circle::new(
                                    c,
                                    size,
                                    RGBColor(40, 40, 40).mix(0.8).stroke_width(1),
                                ))?;
                            }
                        }
                        Marker::Triangle => area.draw(&TriangleMarker::new(c, size, fill))?,
                        Marker::Square => {
                            let h = size as i32;
                            area.draw(&Rectangle::new(
                                [(c.0 - h, c.1 - h), (c.0 + h, c.1 + h)],
                                fill,
                            ))?
                        }
                        Marker::Cross => {
                            area.draw(&Cross::new(c, size, rgb(s.color).stroke_width(2)))?
                        }
                    }
                }
            }
            Swatch::Area(c) => area.draw(&Rectangle::new(
                [(x0 + 2, cy - 7), (x0 + sw - 2, cy + 7)],
                rgb(*c).mix(0.22).filled(),
            ))?,
            Swatch::Disc(c) => {
                area.draw(&Circle::new(
                    (x0 + sw / 2, cy),
                    8,
                    rgb(*c).mix(0.1).filled(),
                ))?;
                area.draw(&Circle::new(
                    (x0 + sw / 2, cy),
                    8,
                    rgb(*c).mix(0.75).stroke_width(1),
                ))?;
            }
        }
        for (i, l) in lines.iter().enumerate() {
            area.draw_text(l, &font, (tx, y + i as i32 * 18))?;
        }
    }
    Ok(())
}
