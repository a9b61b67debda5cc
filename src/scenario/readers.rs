//! The trace, truth and schedule files a scenario names (CSV), read into
//! validated measurements, positions and schedules; an error names the file
//! and the line. Every count a file gives is bounded before it is
//! allocated: a trace holds at most [`MAX_SAMPLES`] samples, and its
//! samples x receivers measurement slots fit in [`MAX_RECORD_BYTES`]; a
//! truth file holds at most [`MAX_SAMPLES`] rows and a schedule at most
//! [`MAX_SCHEDULE_STEPS`].

use crate::model::error::InputError;
use crate::model::geometry::Point;
use crate::model::graph::Graph;
use crate::model::measure::Geometry;
use crate::model::measure::NodeMeasurements;
use crate::model::measure::SampleMeasurements;
use crate::scenario::limits::{MAX_RECORD_BYTES, MAX_SAMPLES};
use serde::Deserialize;
use std::collections::BTreeSet;
use std::io::Read;
use std::path::Path;

const TRACE_HEADER: &[&str] = &["sample", "receiver", "transmitter", "kind", "value"];
const SCHEDULE_HEADER: &[&str] = &["iteration", "v", "w"];

/// The most steps an async schedule file may hold (16 bytes each).
pub const MAX_SCHEDULE_STEPS: usize = 100_000_000;

#[derive(Debug, Deserialize)]
struct TraceRow {
    sample: usize,
    receiver: usize,
    transmitter: Option<usize>,
    kind: String,
    value: f64,
}

fn open(path: &Path) -> Result<std::fs::File, InputError> {
    std::fs::File::open(path).map_err(|e| InputError::file(path, format!("cannot open: {e}")))
}

/// A CSV reader over `r` (the contents of `path`) whose header is `header`.
fn csv_reader<R: Read>(r: R, path: &Path, header: &[&str]) -> Result<csv::Reader<R>, InputError> {
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(r);
    let h = rdr
        .headers()
        .map_err(|e| InputError::at(path, "line 1", format!("cannot read header: {e}")))?;
    let got: Vec<&str> = h.iter().collect();
    // sonarnet's own outputs append a `seed` column; accept and ignore it.
    let with_seed = got.len() == header.len() + 1
        && got[..header.len()] == *header
        && got[header.len()] == "seed";
    if got != header && !with_seed {
        return Err(InputError::at(
            path,
            "line 1",
            format!(
                "header must be `{}` (optionally followed by `,seed`), got `{}`",
                header.join(","),
                got.join(",")
            ),
        ));
    }
    Ok(rdr)
}

fn trim_record(rec: &csv::StringRecord, n: usize) -> csv::StringRecord {
    let mut r: csv::StringRecord = rec.iter().take(n).collect();
    r.set_position(rec.position().cloned());
    r
}

/// What is wrong with a row that did not deserialize: the column by its
/// name and the reason (the line is named by the caller).
fn bad_row(header: &[&str], e: &csv::Error) -> String {
    match e.kind() {
        csv::ErrorKind::Deserialize { err, .. } => {
            let column = err
                .field()
                .and_then(|i| header.get(usize::try_from(i).ok()?))
                .map_or(String::new(), |name| format!("column `{name}`: "));
            format!("bad row: {column}{}", err.kind())
        }
        _ => format!("bad row: {e}"),
    }
}

/// A row the CSV reader could not read, at its line, with the reason.
fn unreadable(path: &Path, e: &csv::Error) -> InputError {
    let line = e
        .position()
        .map_or("line ?".into(), |p| format!("line {}", p.line()));
    let why = match e.kind() {
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => format!("{len} fields where the header has {expected_len}"),
        csv::ErrorKind::Utf8 { err, .. } => format!("not UTF-8 text ({err})"),
        csv::ErrorKind::Io(err) => format!("cannot read: {err}"),
        _ => e.to_string(),
    };
    InputError::at(path, line, why)
}

fn row_line(rec: &csv::StringRecord) -> String {
    rec.position()
        .map_or("line ?".into(), |p| format!("line {}", p.line()))
}

/// Read a measurement trace (`sample,receiver,transmitter,kind,value`);
/// `kind` is `bistatic_range`, `doa` (the azimuth, radians), `range`, or in
/// a 3-D scenario `elevation` (radians above the horizontal).
pub fn read_trace<const D: usize>(
    path: &Path,
    geometry: &Geometry<D>,
) -> Result<Vec<SampleMeasurements>, InputError> {
    trace_from(open(path)?, path, geometry)
}

/// [`read_trace`] of the contents `r` of the file `path`.
pub fn trace_from<const D: usize, R: Read>(
    r: R,
    path: &Path,
    geometry: &Geometry<D>,
) -> Result<Vec<SampleMeasurements>, InputError> {
    let mut rdr = csv_reader(r, path, TRACE_HEADER)?;
    let n = geometry.receivers.len();
    let m = geometry.transmitters.len();
    let slot = std::mem::size_of::<NodeMeasurements>().max(1) as u64;
    let max_samples = (MAX_RECORD_BYTES / slot / n.max(1) as u64).min(MAX_SAMPLES as u64);
    let mut out: Vec<SampleMeasurements> = Vec::new();
    let mut seen = BTreeSet::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| unreadable(path, &e))?;
        let line = row_line(&rec);
        let row: TraceRow = trim_record(&rec, 5)
            .deserialize(None)
            .map_err(|e| InputError::at(path, &line, bad_row(TRACE_HEADER, &e)))?;
        if !row.value.is_finite() {
            return Err(InputError::at(
                path,
                &line,
                format!("value must be finite, got {}", row.value),
            ));
        }
        if row.receiver >= n {
            return Err(InputError::at(
                path,
                &line,
                format!(
                    "receiver {} does not exist (scenario has {n})",
                    row.receiver
                ),
            ));
        }
        if row.sample as u64 >= max_samples {
            return Err(InputError::at(
                path,
                &line,
                format!(
                    "sample {}: a trace of {n} receivers holds at most {max_samples} samples",
                    row.sample
                ),
            ));
        }
        if out.len() <= row.sample {
            out.resize(
                row.sample + 1,
                SampleMeasurements {
                    nodes: vec![NodeMeasurements::default(); n],
                },
            );
        }
        let node = &mut out[row.sample].nodes[row.receiver];
        let key = (row.sample, row.receiver, row.kind.clone(), row.transmitter);
        if !seen.insert(key) {
            return Err(InputError::at(path, &line, "duplicate measurement"));
        }
        match row.kind.as_str() {
            "bistatic_range" => {
                let Some(t) = row.transmitter else {
                    return Err(InputError::at(
                        path,
                        &line,
                        "bistatic_range needs a transmitter",
                    ));
                };
                if t >= m {
                    return Err(InputError::at(
                        path,
                        &line,
                        format!("transmitter {t} does not exist (scenario has {m})"),
                    ));
                }
                node.bistatic.push((t, row.value));
            }
            "doa" | "range" | "elevation" => {
                if row.kind == "elevation" && D != 3 {
                    return Err(InputError::at(
                        path,
                        &line,
                        "an elevation is measured only in a 3-D scenario ([x, y, z] positions)",
                    ));
                }
                if row.transmitter.is_some() {
                    return Err(InputError::at(
                        path,
                        &line,
                        format!("transmitter must be empty for kind {}", row.kind),
                    ));
                }
                match row.kind.as_str() {
                    "doa" => node.doa = Some(row.value),
                    "elevation" => node.elevation = Some(row.value),
                    _ => node.range = Some(row.value),
                }
            }
            other => {
                return Err(InputError::at(
                    path,
                    &line,
                    format!(
                        "unknown kind `{other}` (expected bistatic_range, doa, range{})",
                        if D == 3 {
                            " or elevation"
                        } else {
                            " (or elevation in 3-D)"
                        }
                    ),
                ));
            }
        }
    }
    if out.is_empty() {
        return Err(InputError::file(path, "the trace has no measurements"));
    }
    for s in &mut out {
        for node in &mut s.nodes {
            node.bistatic.sort_by_key(|&(t, _)| t);
        }
    }
    Ok(out)
}

/// Read a truth file: `sample,x,y` in 2-D, `sample,x,y,z` in 3-D
/// (samples 0..S-1 in order).
pub fn read_truth<const D: usize>(path: &Path) -> Result<Vec<Point<D>>, InputError> {
    truth_from(open(path)?, path)
}

/// [`read_truth`] of the contents `r` of the file `path`.
pub fn truth_from<const D: usize, R: Read>(r: R, path: &Path) -> Result<Vec<Point<D>>, InputError> {
    let header: &[&str] = if D == 3 {
        &["sample", "x", "y", "z"]
    } else {
        &["sample", "x", "y"]
    };
    let mut rdr = csv_reader(r, path, header)?;
    let mut out = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| unreadable(path, &e))?;
        let line = row_line(&rec);
        let row = trim_record(&rec, D + 1);
        let bad = |e: &csv::Error| InputError::at(path, &line, bad_row(header, e));
        let (k, c): (usize, Vec<f64>) = if D == 3 {
            let (k, x, y, z): (usize, f64, f64, f64) =
                row.deserialize(None).map_err(|e| bad(&e))?;
            (k, vec![x, y, z])
        } else {
            let (k, x, y): (usize, f64, f64) = row.deserialize(None).map_err(|e| bad(&e))?;
            (k, vec![x, y])
        };
        if k != out.len() {
            return Err(InputError::at(
                path,
                &line,
                format!("expected sample {}, got {k}", out.len()),
            ));
        }
        if k >= MAX_SAMPLES {
            return Err(InputError::at(
                path,
                &line,
                format!("a truth file holds at most {MAX_SAMPLES} samples"),
            ));
        }
        if !c.iter().all(|v| v.is_finite()) {
            return Err(InputError::at(
                path,
                &line,
                format!("{} must be finite", header[1..].join(", ")),
            ));
        }
        out.push(Point::<D>::from_fn(|i, _| c[i]));
    }
    Ok(out)
}

/// Read an async schedule (`iteration,v,w`, iterations 0.. in order, every
/// `(v, w)` an edge of `graph`).
pub fn read_schedule(path: &Path, graph: &Graph) -> Result<Vec<(usize, usize)>, InputError> {
    schedule_from(open(path)?, path, graph)
}

/// [`read_schedule`] of the contents `r` of the file `path`.
pub fn schedule_from<R: Read>(
    r: R,
    path: &Path,
    graph: &Graph,
) -> Result<Vec<(usize, usize)>, InputError> {
    let mut rdr = csv_reader(r, path, SCHEDULE_HEADER)?;
    let mut out = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| unreadable(path, &e))?;
        let line = row_line(&rec);
        let (it, v, w): (usize, usize, usize) = trim_record(&rec, 3)
            .deserialize(None)
            .map_err(|e| InputError::at(path, &line, bad_row(SCHEDULE_HEADER, &e)))?;
        if it != out.len() {
            return Err(InputError::at(
                path,
                &line,
                format!("expected iteration {}, got {it}", out.len()),
            ));
        }
        if it >= MAX_SCHEDULE_STEPS {
            return Err(InputError::at(
                path,
                &line,
                format!("a schedule holds at most {MAX_SCHEDULE_STEPS} steps"),
            ));
        }
        if v >= graph.len() || w >= graph.len() {
            return Err(InputError::at(
                path,
                &line,
                format!(
                    "node {} does not exist (network has {})",
                    v.max(w),
                    graph.len()
                ),
            ));
        }
        if !graph.has_edge(v, w) {
            return Err(InputError::at(
                path,
                &line,
                format!("({v}, {w}) is not an edge of the network"),
            ));
        }
        out.push((v, w));
    }
    Ok(out)
}
