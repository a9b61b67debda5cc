//! Plots of a results directory, drawn with `plotters`.
//!
//! Every run writes five SVG figures next to its outputs (seven on the
//! acoustic channel; PNG on request):
//!
//! * `tracks.svg`: the true track, the distributed estimate `theta_bar`
//!   (Mourya 2017 eq. (11) averaged over nodes), the centralised ML reference and
//!   every baseline, with transmitters, receivers and network edges to scale
//!   (cf. Mourya 2017 Fig. 2b); where `track.csv` has `bound_NAME` columns, the
//!   certified error discs around `theta_bar` at every n-th sample.
//! * `error.svg`: error per sample of every track, the CRLB curve and the
//!   burn-in; Monte Carlo runs draw mean curves with 5th-95th percentile bands.
//! * `consensus.svg`: every node's position estimate against the sample (or,
//!   with `iterations.csv`, against the iteration), as Mourya 2017 Fig. 2a, and
//!   the consensus disagreement `max_v ||theta_v - theta_bar||`.
//! * `ctte.svg`: running CTTE (Pun-So 2022) and, when present, dynamic regret
//!   (Pun-So 2020) of every track; Monte Carlo runs draw mean and band.
//! * `network.svg`: the graph with per-node counters (prox solves, messages,
//!   declines).
//! * On the acoustic channel, `messages.svg`: a message-sequence diagram of
//!   the first frames (lost ones marked with their reason), and
//!   `channel.svg`: each link's delivery ratio against its length.
//!
//! The pipeline is: [`load_run`] reads a directory into [`RunData`]; the
//! builders in [`figures`] turn it into [`Figure`]s, a backend-free
//! description (series, bands, discs, ranges); [`render_svg`]/[`render_png`]
//! draw a `Figure`. Unit tests check the `Figure`s.

pub mod data;
pub mod figures;
mod render;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod three_d_tests;

pub use data::{RunData, load_run};
pub use figures::{comparison_figures, run_figures};
pub use render::{render_png, render_svg};

use crate::model::error::InputError;
use std::path::{Path, PathBuf};

/// A plotting or report failure.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The results directory is not a run, or a file in it is bad (exit 2).
    #[error(transparent)]
    Input(#[from] InputError),
    /// plotters failed to draw a figure.
    #[error("cannot draw {figure}: {reason}")]
    Render {
        /// Figure name.
        figure: String,
        /// plotters' message.
        reason: String,
    },
    /// Ctrl-C/SIGTERM ([`crate::engine::interrupt`]) stopped the drawing
    /// between two figures; `sonarnet report DIR` draws them later.
    #[error(
        "interrupted: {written} of {total} figures drawn (`sonarnet report {}` draws them all)",
        dir.display()
    )]
    Interrupted {
        /// Figures written.
        written: usize,
        /// Figures to write.
        total: usize,
        /// The results directory.
        dir: PathBuf,
    },
    /// A file could not be written.
    #[error("cannot write {}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}

/// An sRGB colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Rgb(pub u8, pub u8, pub u8);

/// Marker shapes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marker {
    /// Filled circle.
    Circle,
    /// Filled triangle.
    Triangle,
    /// Filled square with a dark outline.
    Square,
    /// A cross.
    Cross,
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Style {
    /// Colour.
    pub color: Rgb,
    /// Line width (px); 0 draws no line.
    pub width: u32,
    /// Dashed line.
    pub dashed: bool,
    /// Opacity in `[0, 1]`.
    pub opacity: f64,
    /// Marker at every point.
    pub marker: Option<Marker>,
    /// Marker radius (px).
    pub marker_size: u32,
}

impl Style {
    /// A solid line.
    pub fn line(color: Rgb, width: u32) -> Style {
        Style {
            color,
            width,
            dashed: false,
            opacity: 1.0,
            marker: None,
            marker_size: 0,
        }
    }

    /// Markers only.
    pub fn markers(color: Rgb, marker: Marker, size: u32) -> Style {
        Style {
            color,
            width: 0,
            dashed: false,
            opacity: 1.0,
            marker: Some(marker),
            marker_size: size,
        }
    }

    /// This style, dashed.
    pub fn dashed(mut self) -> Style {
        self.dashed = true;
        self
    }

    /// This style with opacity `a`.
    pub fn alpha(mut self, a: f64) -> Style {
        self.opacity = a;
        self
    }
}

/// A polyline (broken at missing values) and/or markers.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// What the series shows (a track name, `truth`, `crlb`, `node 3`, ...).
    pub name: String,
    /// Contiguous pieces, in data coordinates.
    pub segments: Vec<Vec<(f64, f64)>>,
    /// Style.
    pub style: Style,
}

/// A filled band between two curves (5th-95th percentiles).
#[derive(Debug, Clone, PartialEq)]
pub struct Band {
    /// The track it belongs to.
    pub name: String,
    /// Contiguous pieces of `(x, lo, hi)`.
    pub segments: Vec<Vec<(f64, f64, f64)>>,
    /// Fill colour (drawn translucent).
    pub color: Rgb,
}

/// A disc in data units (a certified error bound).
#[derive(Debug, Clone, PartialEq)]
pub struct Disc {
    /// Which bound.
    pub name: String,
    /// Centre.
    pub center: (f64, f64),
    /// Radius (data units).
    pub radius: f64,
    /// Colour.
    pub color: Rgb,
}

/// A text label anchored at a data point, offset in pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct Label {
    /// Anchor.
    pub at: (f64, f64),
    /// Pixel offset of the text's top-left corner.
    pub offset: (i32, i32),
    /// Text lines.
    pub lines: Vec<String>,
    /// Font size (px).
    pub size: u32,
}

/// A vertical marker line with a caption (e.g. the burn-in).
#[derive(Debug, Clone, PartialEq)]
pub struct VLine {
    /// Position on the x axis.
    pub x: f64,
    /// Caption at the top.
    pub caption: String,
    /// Shade the region left of `x` from the x-axis start.
    pub shade_left: bool,
}

/// A shaded stretch of the x axis with a caption (a fault).
#[derive(Debug, Clone, PartialEq)]
pub struct Span {
    /// Start.
    pub x0: f64,
    /// End.
    pub x1: f64,
    /// Caption at the top, at the start.
    pub caption: String,
    /// Fill colour (drawn translucent).
    pub color: Rgb,
}

/// One chart of a figure.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// Height in pixels.
    pub height: u32,
    /// x-axis description, with unit.
    pub x_label: String,
    /// y-axis description, with unit.
    pub y_label: String,
    /// x range drawn.
    pub x_range: (f64, f64),
    /// y range drawn.
    pub y_range: (f64, f64),
    /// Logarithmic y axis.
    pub log_y: bool,
    /// The x data are `log10` of the values (a logarithmic x axis): tick
    /// labels show `10^x`.
    pub log10_x: bool,
    /// Equal scale on both axes (ranges already adjusted by the builder).
    pub equal_aspect: bool,
    /// Bands, drawn first.
    pub bands: Vec<Band>,
    /// Discs, clipped to the ranges.
    pub discs: Vec<Disc>,
    /// Vertical lines.
    pub vlines: Vec<VLine>,
    /// Shaded stretches, drawn under everything.
    pub spans: Vec<Span>,
    /// Series, in drawing order.
    pub series: Vec<Series>,
    /// Labels.
    pub labels: Vec<Label>,
    /// A message drawn in the middle (e.g. "no samples").
    pub note: Option<String>,
    /// A caption drawn in the top-left corner of the plot area.
    pub caption: Option<String>,
}

impl Panel {
    /// An empty panel with the given axes.
    pub fn new(height: u32, x_label: &str, y_label: &str) -> Panel {
        Panel {
            height,
            x_label: x_label.into(),
            y_label: y_label.into(),
            x_range: (0.0, 1.0),
            y_range: (0.0, 1.0),
            log_y: false,
            log10_x: false,
            equal_aspect: false,
            bands: Vec::new(),
            discs: Vec::new(),
            vlines: Vec::new(),
            spans: Vec::new(),
            series: Vec::new(),
            labels: Vec::new(),
            note: None,
            caption: None,
        }
    }

    /// Every data point the panel draws (series points, band ends, disc
    /// centres, label anchors, vertical lines at `y_range.0`).
    pub fn points(&self) -> Vec<(f64, f64)> {
        let mut v: Vec<(f64, f64)> = self
            .series
            .iter()
            .flat_map(|s| s.segments.iter().flatten().copied())
            .collect();
        for b in &self.bands {
            for &(x, lo, hi) in b.segments.iter().flatten() {
                v.push((x, lo));
                v.push((x, hi));
            }
        }
        v.extend(self.discs.iter().map(|d| d.center));
        v.extend(self.labels.iter().map(|l| l.at));
        v.extend(self.vlines.iter().map(|l| (l.x, self.y_range.0)));
        v
    }

    /// Whether `(x, y)` lies in the drawn ranges (with a relative tolerance).
    pub fn contains(&self, (x, y): (f64, f64)) -> bool {
        let tol = |r: (f64, f64)| 1e-9 * (r.1 - r.0).abs().max(1.0);
        x >= self.x_range.0 - tol(self.x_range)
            && x <= self.x_range.1 + tol(self.x_range)
            && y >= self.y_range.0 - tol(self.y_range)
            && y <= self.y_range.1 + tol(self.y_range)
    }
}

/// What a legend entry shows.
#[derive(Debug, Clone, PartialEq)]
pub enum Swatch {
    /// A line (and marker) in this style.
    Line(Style),
    /// A filled area.
    Area(Rgb),
    /// A disc outline.
    Disc(Rgb),
}

/// One legend entry.
#[derive(Debug, Clone, PartialEq)]
pub struct LegendItem {
    /// Text.
    pub label: String,
    /// Swatch.
    pub swatch: Swatch,
}

/// A figure: a title, panels stacked vertically and a legend on the right.
#[derive(Debug, Clone, PartialEq)]
pub struct Figure {
    /// File stem (`tracks` -> `tracks.svg`).
    pub name: String,
    /// Title.
    pub title: String,
    /// Width in pixels.
    pub width: u32,
    /// Panels, top to bottom.
    pub panels: Vec<Panel>,
    /// Legend entries.
    pub legend: Vec<LegendItem>,
}

impl Figure {
    /// Total height in pixels.
    pub fn height(&self) -> u32 {
        render::TITLE_H + self.panels.iter().map(|p| p.height).sum::<u32>()
    }

    /// Names of every series, band and disc drawn.
    pub fn drawn_names(&self) -> Vec<&str> {
        let mut v = Vec::new();
        for p in &self.panels {
            v.extend(p.series.iter().map(|s| s.name.as_str()));
            v.extend(p.bands.iter().map(|s| s.name.as_str()));
            v.extend(p.discs.iter().map(|s| s.name.as_str()));
        }
        v
    }
}

/// Image formats to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Formats {
    /// Write `NAME.svg`.
    pub svg: bool,
    /// Write `NAME.png`.
    pub png: bool,
}

/// Render `figures` into `dir` as `NAME.svg` (and `NAME.png`). Returns the
/// SVG text of each figure, in order, for inlining.
pub fn write_figures(
    figures: &[Figure],
    dir: &Path,
    formats: Formats,
) -> Result<Vec<String>, PlotError> {
    let mut out = Vec::with_capacity(figures.len());
    for f in figures {
        // A run stopped by Ctrl-C/SIGTERM, or one that comes while drawing,
        // ends the drawing: the data files are already written.
        if crate::engine::interrupt::requested() {
            return Err(PlotError::Interrupted {
                written: out.len(),
                total: figures.len(),
                dir: dir.to_path_buf(),
            });
        }
        let svg = render_svg(f)?;
        if formats.svg {
            let path = dir.join(format!("{}.svg", f.name));
            std::fs::write(&path, &svg).map_err(|e| PlotError::Write { path, source: e })?;
        }
        if formats.png {
            render_png(f, &dir.join(format!("{}.png", f.name)))?;
        }
        out.push(svg);
    }
    Ok(out)
}

/// Read the results directory `dir` and write its SVG plots into it
/// (`tracks.svg`, `error.svg`, `consensus.svg`, `ctte.svg`, `network.svg`,
/// and on the acoustic channel `messages.svg` and `channel.svg`).
/// `sonarnet run` calls this after writing its outputs.
pub fn write_run_plots(dir: &Path) -> Result<Vec<PathBuf>, PlotError> {
    write_run_plots_as(dir, false)
}

/// [`write_run_plots`], with a PNG beside every SVG when `png` is set
/// (`sonarnet run --png`). Returns the SVG paths.
pub fn write_run_plots_as(dir: &Path, png: bool) -> Result<Vec<PathBuf>, PlotError> {
    let data = load_run(dir)?;
    let figs = run_figures(&data);
    write_figures(&figs, dir, Formats { svg: true, png })?;
    Ok(figs
        .iter()
        .map(|f| dir.join(format!("{}.svg", f.name)))
        .collect())
}
