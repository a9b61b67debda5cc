//! The CSV files of a results directory (`track.csv`, `nodes.csv`, `iterations.csv`,
//! `trials.csv`), read with the line of every error.

use crate::model::error::InputError;
use crate::plot::data::BoundSeries;
use crate::plot::data::ML;
use crate::plot::data::NodePoint;
use crate::plot::data::Pos;
use crate::plot::data::THETA_BAR;
use crate::plot::data::Track;
use crate::plot::data::TrackKind;
use crate::plot::data::TrackTable;
use std::path::Path;

/// A CSV file as strings.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Csv {
    /// Header.
    pub header: Vec<String>,
    /// Rows.
    pub rows: Vec<Vec<String>>,
}

impl Csv {
    pub(super) fn col(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h == name)
    }

    /// Parse the cell of data row `i` (0-based), column `j`: empty is `None`,
    /// anything else must be a finite number.
    pub(super) fn cell(
        &self,
        p: &Path,
        i: usize,
        j: usize,
        s: &str,
    ) -> Result<Option<f64>, InputError> {
        let s = s.trim();
        if s.is_empty() {
            return Ok(None);
        }
        match s.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(Some(v)),
            _ => Err(InputError::at(
                p,
                format!("line {}, column {}", i + 2, self.header[j]),
                format!("expected a finite number, found `{s}`"),
            )),
        }
    }

    /// Column `j` as numbers.
    pub(super) fn numbers(&self, p: &Path, j: usize) -> Result<Vec<Option<f64>>, InputError> {
        self.rows
            .iter()
            .enumerate()
            .map(|(i, r)| self.cell(p, i, j, r.get(j).map_or("", String::as_str)))
            .collect()
    }

    /// Named column as numbers, or `None` if there is no such column.
    pub(super) fn numbers_of(
        &self,
        p: &Path,
        name: &str,
    ) -> Result<Option<Vec<Option<f64>>>, InputError> {
        self.col(name).map(|j| self.numbers(p, j)).transpose()
    }
}

/// Read a CSV file with a header row.
pub fn read_csv(p: &Path) -> Result<Csv, InputError> {
    let mut rdr = csv::Reader::from_path(p).map_err(|e| InputError::file(p, e.to_string()))?;
    let header = rdr
        .headers()
        .map_err(|e| InputError::file(p, format!("cannot read the header: {e}")))?
        .iter()
        .map(|s| s.trim().to_string())
        .collect::<Vec<_>>();
    let mut rows = Vec::new();
    for (i, r) in rdr.records().enumerate() {
        let r = r.map_err(|e| InputError::at(p, format!("line {}", i + 2), e.to_string()))?;
        rows.push(r.iter().map(str::to_owned).collect());
    }
    Ok(Csv { header, rows })
}

/// Positions from coordinate columns; without a `z` column, `z` is 0.
pub(super) fn xyz(
    x: &[Option<f64>],
    y: &[Option<f64>],
    z: Option<&[Option<f64>]>,
) -> Vec<Option<Pos>> {
    x.iter()
        .zip(y)
        .enumerate()
        .map(|(i, (a, b))| match (a, b, z.map(|z| z[i])) {
            (Some(a), Some(b), None) => Some([*a, *b, 0.0]),
            (Some(a), Some(b), Some(Some(c))) => Some([*a, *b, c]),
            _ => None,
        })
        .collect()
}

pub(super) fn running_sum(e: &[Option<f64>]) -> Vec<Option<f64>> {
    let mut s = 0.0;
    e.iter()
        .map(|v| {
            v.map(|v| {
                s += v;
                s
            })
        })
        .collect()
}

pub(super) fn distances(
    pos: &[Option<Pos>],
    truth: &[Option<Pos>],
    dim: usize,
) -> Vec<Option<f64>> {
    pos.iter()
        .zip(truth)
        .map(|(p, t)| match (p, t) {
            (Some(p), Some(t)) => Some(super::distance(p, t, dim)),
            _ => None,
        })
        .collect()
}

/// Split a parsed `track.csv` into tracks (the generic column convention:
/// `est_*` and the plain `error,ctte,regret` are `theta_bar`; `ml_*` is the
/// ML reference; any other `NAME_x,NAME_y` pair is a baseline with optional
/// `NAME_error,NAME_ctte,NAME_regret`; `bound_NAME` is a bound radius). A
/// 3-D run's file has `true_z`/`est_z` and a `_z` beside every `_y`.
pub fn parse_track_csv(p: &Path, csv: &Csv) -> Result<TrackTable, InputError> {
    let j = csv.col("sample").ok_or_else(|| {
        InputError::at(p, "line 1", "no `sample` column: this is not a track.csv")
    })?;
    let sample = csv
        .numbers(p, j)?
        .into_iter()
        .enumerate()
        .map(|(i, v)| {
            v.ok_or_else(|| InputError::at(p, format!("line {}", i + 2), "empty `sample`"))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let n = sample.len();
    let none = || vec![None; n];
    let get = |name: &str| -> Result<Vec<Option<f64>>, InputError> {
        Ok(csv.numbers_of(p, name)?.unwrap_or_else(none))
    };
    let dim = if csv.col("true_z").is_some() || csv.col("est_z").is_some() {
        3
    } else {
        2
    };
    let coords = |prefix: &str| -> Result<Vec<Option<Pos>>, InputError> {
        let z = if dim == 3 {
            Some(get(&format!("{prefix}_z"))?)
        } else {
            None
        };
        Ok(xyz(
            &get(&format!("{prefix}_x"))?,
            &get(&format!("{prefix}_y"))?,
            z.as_deref(),
        ))
    };
    let truth = coords("true")?;
    let mut names: Vec<(String, TrackKind)> = Vec::new();
    if csv.col("est_x").is_some() && csv.col("est_y").is_some() {
        names.push(("est".into(), TrackKind::Distributed));
    }
    if csv.col("ml_x").is_some() && csv.col("ml_y").is_some() {
        names.push(("ml".into(), TrackKind::Reference));
    }
    for h in &csv.header {
        if let Some(base) = h.strip_suffix("_x")
            && !matches!(base, "true" | "est" | "ml")
            && csv.col(&format!("{base}_y")).is_some()
        {
            names.push((base.to_string(), TrackKind::Baseline));
        }
    }
    let mut tracks = Vec::new();
    for (prefix, kind) in &names {
        let pos = coords(prefix)?;
        let (err_col, ctte_col, regret_col) = if *kind == TrackKind::Distributed {
            (
                "error".to_string(),
                "ctte".to_string(),
                "regret".to_string(),
            )
        } else {
            (
                format!("{prefix}_error"),
                format!("{prefix}_ctte"),
                format!("{prefix}_regret"),
            )
        };
        let error = match csv.numbers_of(p, &err_col)? {
            Some(e) => e,
            None => distances(&pos, &truth, dim),
        };
        let ctte = match csv.numbers_of(p, &ctte_col)? {
            Some(c) => c,
            None => running_sum(&error),
        };
        let regret = csv.numbers_of(p, &regret_col)?;
        let name = match kind {
            TrackKind::Distributed => THETA_BAR.to_string(),
            TrackKind::Reference => ML.to_string(),
            TrackKind::Baseline => prefix.clone(),
        };
        tracks.push(Track {
            name,
            kind: *kind,
            pos,
            error,
            ctte,
            regret,
        });
    }
    let claimed = |h: &str| {
        names.iter().any(|(b, k)| {
            *k == TrackKind::Baseline
                && ["_x", "_y", "_z", "_error", "_ctte", "_regret"]
                    .iter()
                    .any(|s| h == format!("{b}{s}"))
        })
    };
    let mut bounds = Vec::new();
    for (jj, h) in csv.header.iter().enumerate() {
        if let Some(name) = h.strip_prefix("bound_")
            && !claimed(h)
        {
            // Bound radii: an empty cell is an empty set; a non-finite radius
            // (an unbounded region) is not drawn either.
            let radius = csv
                .rows
                .iter()
                .map(|r| {
                    r.get(jj)
                        .and_then(|s| s.trim().parse::<f64>().ok())
                        .filter(|v| v.is_finite() && *v >= 0.0)
                })
                .collect();
            bounds.push(BoundSeries {
                name: name.to_string(),
                radius,
            });
        }
    }
    Ok(TrackTable {
        sample,
        truth,
        dim,
        tracks,
        crlb: get("crlb")?,
        bounds,
    })
}

/// Parse `nodes.csv` (`sample,node,x,y,...`) or, with `iterations`,
/// `iterations.csv` (`iteration,sample,node,x,y,...`); a `z` column (3-D
/// runs) is read when present.
pub fn parse_node_points(
    p: &Path,
    csv: &Csv,
    iterations: bool,
) -> Result<Vec<NodePoint>, InputError> {
    let mut need = vec!["sample", "node", "x", "y"];
    if iterations {
        need.push("iteration");
    }
    let mut cols = Vec::new();
    for n in &need {
        cols.push(csv.col(n).ok_or_else(|| {
            InputError::at(
                p,
                "line 1",
                format!("no `{n}` column (expected {})", need.join(",")),
            )
        })?);
    }
    let z_col = csv.col("z");
    if let Some(j) = z_col {
        cols.push(j);
        need.push("z");
    }
    let mut out = Vec::with_capacity(csv.rows.len());
    for (i, r) in csv.rows.iter().enumerate() {
        let mut v = [0.0; 6];
        for (k, &j) in cols.iter().enumerate() {
            v[k] = csv
                .cell(p, i, j, r.get(j).map_or("", String::as_str))?
                .ok_or_else(|| {
                    InputError::at(
                        p,
                        format!("line {}, column {}", i + 2, need[k]),
                        "empty cell",
                    )
                })?;
        }
        let index = |x: f64, what: &str| -> Result<u64, InputError> {
            if x >= 0.0 && x.fract().abs() < 1e-9 {
                Ok(x as u64)
            } else {
                Err(InputError::at(
                    p,
                    format!("line {}, column {what}", i + 2),
                    format!("expected a non-negative integer, found {x}"),
                ))
            }
        };
        out.push(NodePoint {
            sample: index(v[0], "sample")? as usize,
            node: index(v[1], "node")? as usize,
            pos: [
                v[2],
                v[3],
                if z_col.is_some() {
                    v[need.len() - 1]
                } else {
                    0.0
                },
            ],
            iteration: if iterations {
                Some(index(v[4], "iteration")?)
            } else {
                None
            },
        });
    }
    Ok(out)
}

/// One row of `messages.csv` (the acoustic channel): a frame between two
/// nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct MessageRow {
    /// Start of its transmission (emulated s).
    pub t_send: f64,
    /// End of its arrival (emulated s), `None` when it was lost.
    pub t_recv: Option<f64>,
    /// Sender.
    pub from: usize,
    /// Addressee.
    pub to: usize,
    /// Kind (`request`, `accept`, `decline`, `reflect`, `average`).
    pub kind: String,
    /// Bits on the channel.
    pub bits: u64,
    /// Why it was lost (`None`: delivered).
    pub reason: Option<String>,
}

/// Parse `messages.csv` (`t_send,t_recv,from,to,kind,bits,fate,reason,seed`);
/// the frames still `in_flight` when the run ended are left out.
pub fn parse_messages(p: &Path, csv: &Csv) -> Result<Vec<MessageRow>, InputError> {
    let need = [
        "t_send", "t_recv", "from", "to", "kind", "bits", "fate", "reason",
    ];
    let mut cols = [0usize; 8];
    for (k, n) in need.iter().enumerate() {
        cols[k] = csv.col(n).ok_or_else(|| {
            InputError::at(
                p,
                "line 1",
                format!("no `{n}` column (expected {})", need.join(",")),
            )
        })?;
    }
    let mut out = Vec::with_capacity(csv.rows.len());
    for (i, r) in csv.rows.iter().enumerate() {
        let text = |k: usize| r.get(cols[k]).map_or("", |s| s.trim());
        let num = |k: usize| csv.cell(p, i, cols[k], text(k));
        let bad = |k: usize, why: &str| {
            InputError::at(
                p,
                format!("line {}, column {}", i + 2, need[k]),
                why.to_string(),
            )
        };
        let index = |k: usize| -> Result<u64, InputError> {
            match num(k)? {
                Some(x) if x >= 0.0 && x.fract().abs() < 1e-9 && x < 9e15 => Ok(x as u64),
                _ => Err(bad(k, "expected a non-negative integer")),
            }
        };
        let t_send = num(0)?.ok_or_else(|| bad(0, "empty cell"))?;
        let fate = text(6);
        let reason = match fate {
            "delivered" => None,
            "lost" => Some(text(7).to_string()),
            // Never judged: the run ended first. Not drawn.
            "in_flight" => continue,
            _ => return Err(bad(6, "expected `delivered`, `lost` or `in_flight`")),
        };
        out.push(MessageRow {
            t_send,
            t_recv: num(1)?,
            from: index(2)? as usize,
            to: index(3)? as usize,
            kind: text(4).to_string(),
            bits: index(5)?,
            reason,
        });
    }
    Ok(out)
}
