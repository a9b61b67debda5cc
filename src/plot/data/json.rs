//! `run.json` and `summary.json`, read into the plots' types; an error names the file
//! and the key.

use super::*;

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

pub(super) fn points(p: &Path, v: Option<&Value>, key: &str) -> Result<Vec<[f64; 2]>, InputError> {
    let Some(v) = v else {
        return Ok(Vec::new());
    };
    let arr = v
        .as_array()
        .ok_or_else(|| InputError::at(p, key, "expected an array of [x, y] points"))?;
    arr.iter()
        .enumerate()
        .map(|(i, q)| {
            let a = q.as_array().filter(|a| a.len() == 2);
            match a.map(|a| (a[0].as_f64(), a[1].as_f64())) {
                Some((Some(x), Some(y))) if x.is_finite() && y.is_finite() => Ok([x, y]),
                _ => Err(InputError::at(
                    p,
                    format!("{key}[{i}]"),
                    "expected a point [x, y] of finite numbers",
                )),
            }
        })
        .collect()
}

/// Parse `run.json`.
pub fn parse_run_json(p: &Path, v: &Value) -> Result<RunInfo, InputError> {
    if !v.is_object() {
        return Err(InputError::file(p, "expected a JSON object"));
    }
    let sc = v.get("scenario").cloned().unwrap_or(Value::Null);
    let geometry = sc.get("geometry");
    let transmitters = points(
        p,
        geometry.and_then(|g| g.get("transmitters")),
        "scenario.geometry.transmitters",
    )?;
    let receivers = points(
        p,
        geometry.and_then(|g| g.get("receivers")),
        "scenario.geometry.receivers",
    )?;
    let edges = match v.get("edges") {
        None | Some(Value::Null) => Vec::new(),
        Some(e) => {
            let arr = e
                .as_array()
                .ok_or_else(|| InputError::at(p, "edges", "expected an array of [a, b] pairs"))?;
            arr.iter()
                .enumerate()
                .map(|(i, q)| {
                    let a = q.as_array().filter(|a| a.len() == 2);
                    match a.map(|a| (a[0].as_u64(), a[1].as_u64())) {
                        Some((Some(a), Some(b)))
                            if (a as usize) < receivers.len() && (b as usize) < receivers.len() =>
                        {
                            Ok((a as usize, b as usize))
                        }
                        _ => Err(InputError::at(
                            p,
                            format!("edges[{i}]"),
                            format!(
                                "expected a pair of receiver indices below {}",
                                receivers.len()
                            ),
                        )),
                    }
                })
                .collect::<Result<_, _>>()?
        }
    };
    Ok(RunInfo {
        name: str_at(&sc, &["name"]).unwrap_or_else(|| {
            p.parent()
                .and_then(|d| d.file_name())
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_else(|| "run".into())
        }),
        description: str_at(&sc, &["description"]),
        scenario_file: str_at(v, &["scenario_file"]),
        seed: v.get("seed").and_then(Value::as_u64),
        engine: str_at(v, &["engine"]),
        mode: str_at(v, &["mode"]),
        clock: str_at(v, &["clock"]),
        local_solver: str_at(v, &["local_solver"]),
        poll_us: v.get("poll_us").and_then(Value::as_u64),
        status: str_at(v, &["status"]),
        error: str_at(v, &["error"]),
        crate_version: str_at(v, &["crate_version"]),
        command_line: v
            .get("command_line")
            .and_then(Value::as_array)
            .map(|a| {
                a.iter()
                    .map(|s| s.as_str().map_or_else(|| s.to_string(), str::to_owned))
                    .collect()
            })
            .unwrap_or_default(),
        transmitters,
        receivers,
        edges,
        burn_in: sc
            .get("algorithm")
            .and_then(|a| a.get("burn_in"))
            .and_then(Value::as_u64)
            .map(|b| b as usize),
        scenario: sc,
    })
}

pub(super) fn band(p: &Path, v: &Value, key: &str, n: usize) -> Result<BandCurve, InputError> {
    let arr = |k: &str| -> Result<Vec<Option<f64>>, InputError> {
        let loc = format!("{key}.{k}");
        let a = v
            .get(k)
            .and_then(Value::as_array)
            .ok_or_else(|| InputError::at(p, &loc, "missing or not an array"))?;
        if a.len() != n {
            return Err(InputError::at(
                p,
                &loc,
                format!("has {} entries but `sample` has {n}", a.len()),
            ));
        }
        a.iter()
            .enumerate()
            .map(|(i, x)| match x {
                Value::Null => Ok(None),
                x => match x.as_f64() {
                    Some(f) if f.is_finite() => Ok(Some(f)),
                    _ => Err(InputError::at(
                        p,
                        format!("{loc}[{i}]"),
                        "expected a finite number or null",
                    )),
                },
            })
            .collect()
    };
    Ok(BandCurve {
        mean: arr("mean")?,
        p5: arr("p5")?,
        p95: arr("p95")?,
    })
}

/// Parse `summary.json` (format in [`MonteCarlo`]).
pub fn parse_summary(p: &Path, v: &Value) -> Result<MonteCarlo, InputError> {
    if !v.is_object() {
        return Err(InputError::file(p, "expected a JSON object"));
    }
    let sample: Vec<f64> = match v.get("sample") {
        None => Vec::new(),
        Some(s) => s
            .as_array()
            .ok_or_else(|| InputError::at(p, "sample", "expected an array of sample indices"))?
            .iter()
            .enumerate()
            .map(|(i, x)| {
                x.as_f64()
                    .filter(|f| f.is_finite())
                    .ok_or_else(|| InputError::at(p, format!("sample[{i}]"), "expected a number"))
            })
            .collect::<Result<_, _>>()?,
    };
    let n = sample.len();
    let mut curves = Vec::new();
    if let Some(c) = v.get("curves") {
        let obj = c
            .as_object()
            .ok_or_else(|| InputError::at(p, "curves", "expected an object keyed by track"))?;
        for (name, tc) in obj {
            let key = format!("curves.{name}");
            let one = |k: &str| {
                tc.get(k)
                    .filter(|x| !x.is_null())
                    .map(|x| band(p, x, &format!("{key}.{k}"), n))
                    .transpose()
            };
            curves.push(TrackCurves {
                name: name.clone(),
                error: one("error")?,
                ctte: one("ctte")?,
                regret: one("regret")?,
            });
        }
    }
    let rank = |n: &str| match n {
        THETA_BAR => 0,
        ML => 1,
        _ => 2,
    };
    curves.sort_by(|a, b| rank(&a.name).cmp(&rank(&b.name)).then(a.name.cmp(&b.name)));
    let crlb = v
        .get("crlb")
        .filter(|x| !x.is_null())
        .map(|x| band(p, x, "crlb", n))
        .transpose()?;
    Ok(MonteCarlo {
        trials: v.get("trials").and_then(Value::as_u64),
        sample,
        curves,
        crlb,
        trial_columns: Vec::new(),
        trial_rows: Vec::new(),
    })
}
