//! `run.json` and `summary.json`, read into the plots' types; an error names the file
//! and the key.

use crate::model::error::InputError;
use crate::pipeline::Band;
use crate::pipeline::McSummary;
use crate::pipeline::RunJson;
use crate::plot::data::BandCurve;
use crate::plot::data::ML;
use crate::plot::data::MonteCarlo;
use crate::plot::data::Pos;
use crate::plot::data::RunInfo;
use crate::plot::data::THETA_BAR;
use crate::plot::data::TrackCurves;
use serde_json::Value;
use std::path::Path;

pub(super) fn str_at(v: &Value, path: &[&str]) -> Option<String> {
    let mut cur = v;
    for k in path {
        cur = cur.get(k)?;
    }
    match cur {
        Value::String(s) => Some(s.clone()),
        Value::Null => None,
        other => Some(other.to_string()),
    }
}

/// The points of `run.json` key `key`, `[x, y]` or `[x, y, z]` (`z` = 0 for
/// the former), and their dimension (`None` when there are none).
pub(super) fn points(
    p: &Path,
    v: Option<&Value>,
    key: &str,
) -> Result<(Vec<Pos>, Option<usize>), InputError> {
    let Some(v) = v else {
        return Ok((Vec::new(), None));
    };
    let arr = v
        .as_array()
        .ok_or_else(|| InputError::at(p, key, "expected an array of [x, y] or [x, y, z] points"))?;
    let mut dim = None;
    let pts = arr
        .iter()
        .enumerate()
        .map(|(i, q)| {
            let bad = || {
                InputError::at(
                    p,
                    format!("{key}[{i}]"),
                    "expected a point [x, y] or [x, y, z] of finite numbers, \
                     all of one dimension",
                )
            };
            let a = q
                .as_array()
                .filter(|a| (2..=3).contains(&a.len()) && dim.is_none_or(|d| d == a.len()))
                .ok_or_else(bad)?;
            dim = Some(a.len());
            let mut out = [0.0; 3];
            for (o, c) in out.iter_mut().zip(a) {
                *o = c.as_f64().filter(|x| x.is_finite()).ok_or_else(bad)?;
            }
            Ok(out)
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok((pts, dim))
}

/// Parse `run.json` ([`RunJson`], the type the run was written with).
pub fn parse_run_json(p: &Path, v: &Value) -> Result<RunInfo, InputError> {
    if !v.is_object() {
        return Err(InputError::file(p, "expected a JSON object"));
    }
    let r: RunJson =
        serde_json::from_value(v.clone()).map_err(|e| InputError::file(p, e.to_string()))?;
    let sc = &r.scenario;
    let geometry = sc.get("geometry");
    let (transmitters, tx_dim) = points(
        p,
        geometry.and_then(|g| g.get("transmitters")),
        "scenario.geometry.transmitters",
    )?;
    let (receivers, rx_dim) = points(
        p,
        geometry.and_then(|g| g.get("receivers")),
        "scenario.geometry.receivers",
    )?;
    let dim = match (tx_dim, rx_dim) {
        (Some(a), Some(b)) if a != b => {
            return Err(InputError::at(
                p,
                "scenario.geometry",
                format!("the transmitters are {a}-D but the receivers {b}-D"),
            ));
        }
        (a, b) => a.or(b).unwrap_or(2),
    };
    let edges = r.edges.clone().unwrap_or_default();
    if let Some(i) = edges
        .iter()
        .position(|&(a, b)| a >= receivers.len() || b >= receivers.len())
    {
        return Err(InputError::at(
            p,
            format!("edges[{i}]"),
            format!(
                "expected a pair of receiver indices below {}",
                receivers.len()
            ),
        ));
    }
    let burn_in = sc
        .get("algorithm")
        .and_then(|a| a.get("burn_in"))
        .and_then(Value::as_u64)
        .map(|b| b as usize);
    Ok(RunInfo {
        name: str_at(sc, &["name"]).unwrap_or_else(|| {
            p.parent()
                .and_then(|d| d.file_name())
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_else(|| "run".into())
        }),
        description: str_at(sc, &["description"]),
        dim,
        transmitters,
        receivers,
        edges,
        burn_in,
        run: r,
    })
}

/// One band of `summary.json`, checked to have one entry per sample.
pub(super) fn band(p: &Path, b: &Band, key: &str, n: usize) -> Result<BandCurve, InputError> {
    for (k, a) in [("mean", &b.mean), ("p5", &b.p5), ("p95", &b.p95)] {
        if a.len() != n {
            return Err(InputError::at(
                p,
                format!("{key}.{k}"),
                format!("has {} entries but `sample` has {n}", a.len()),
            ));
        }
    }
    Ok(BandCurve {
        mean: b.mean.clone(),
        p5: b.p5.clone(),
        p95: b.p95.clone(),
    })
}

/// Parse `summary.json` ([`McSummary`], the type the run was written with;
/// format in [`MonteCarlo`]).
pub fn parse_summary(p: &Path, v: &Value) -> Result<MonteCarlo, InputError> {
    if !v.is_object() {
        return Err(InputError::file(p, "expected a JSON object"));
    }
    let m: McSummary =
        serde_json::from_value(v.clone()).map_err(|e| InputError::file(p, e.to_string()))?;
    let n = m.sample.len();
    let mut curves = Vec::new();
    for (name, tc) in &m.curves {
        let key = format!("curves.{name}");
        let one = |b: &Option<Band>, k: &str| {
            b.as_ref()
                .map(|b| band(p, b, &format!("{key}.{k}"), n))
                .transpose()
        };
        curves.push(TrackCurves {
            name: name.clone(),
            error: one(&tc.error, "error")?,
            ctte: one(&tc.ctte, "ctte")?,
            regret: one(&tc.regret, "regret")?,
        });
    }
    let rank = |n: &str| match n {
        THETA_BAR => 0,
        ML => 1,
        _ => 2,
    };
    curves.sort_by(|a, b| rank(&a.name).cmp(&rank(&b.name)).then(a.name.cmp(&b.name)));
    let crlb = m.crlb.as_ref().map(|b| band(p, b, "crlb", n)).transpose()?;
    Ok(MonteCarlo {
        trials: m.trials,
        sample: m.sample.iter().map(|&k| k as f64).collect(),
        curves,
        crlb,
        trial_columns: Vec::new(),
        trial_rows: Vec::new(),
    })
}
