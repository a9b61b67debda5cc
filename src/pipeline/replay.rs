//! `sonarnet replay DIR`: compare two results directories file by file,
//! leaving out what measures the machine rather than the run (wall times,
//! rates, memory, the command line, paths and provenance).

use std::collections::BTreeSet;
use std::path::Path;

/// Where two results directories first differ.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Difference {
    /// The file (relative to the directory).
    pub file: String,
    /// `row N` of a CSV (1 = the first data row; 0 = the header), the JSON
    /// key path, or `missing in ...`.
    pub at: String,
    /// The two values, as written.
    pub values: (String, String),
}

impl std::fmt::Display for Difference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: {}: {} vs {}",
            self.file, self.at, self.values.0, self.values.1
        )
    }
}

/// A key or CSV column that measures the machine, not the run.
pub fn is_timing(key: &str) -> bool {
    key.contains("seconds")
        || key.ends_with("_per_s")
        || key.ends_with("per_second")
        || key == "realtime_factor"
        || key == "realtime"
        || key.contains("rss")
        || key == "command_line"
}

/// Files compared: every CSV and the metrics. `run.json` records where,
/// when and how (paths, times, host), and `scenario.toml` names the
/// directory's own files, so neither is compared.
fn compared(name: &str) -> bool {
    name.ends_with(".csv") || name == "metrics.json" || name == "summary.json"
}

/// Why two results directories could not be compared.
#[derive(Debug, thiserror::Error)]
pub enum CompareError {
    /// A directory could not be listed or a file read.
    #[error("cannot read {}", path.display())]
    Read {
        /// The directory or file.
        path: std::path::PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A JSON file did not parse.
    #[error("{file} is not JSON")]
    Json {
        /// The file's name.
        file: String,
        /// The parser's error.
        #[source]
        source: serde_json::Error,
    },
}

/// Compare the results in `a` (the original) with `b` (the replay): `None`
/// if every compared file is equal, else the first difference (files in
/// name order, rows in file order).
pub fn compare_results(a: &Path, b: &Path) -> Result<Option<Difference>, CompareError> {
    let read_error = |path: std::path::PathBuf| move |source| CompareError::Read { path, source };
    let names = |d: &Path| -> Result<BTreeSet<String>, CompareError> {
        Ok(std::fs::read_dir(d)
            .map_err(read_error(d.to_path_buf()))?
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| compared(n))
            .collect())
    };
    let (na, nb) = (names(a)?, names(b)?);
    for n in na.union(&nb) {
        let diff = |at: &str| Difference {
            file: n.clone(),
            at: at.into(),
            values: (String::new(), String::new()),
        };
        if !na.contains(n) {
            return Ok(Some(diff(&format!("missing in {}", a.display()))));
        }
        if !nb.contains(n) {
            return Ok(Some(diff(&format!("missing in {}", b.display()))));
        }
        let read = |d: &Path| std::fs::read_to_string(d.join(n)).map_err(read_error(d.join(n)));
        let (ta, tb) = (read(a)?, read(b)?);
        let d = if n.ends_with(".json") {
            json_difference(&ta, &tb).map_err(|source| CompareError::Json {
                file: n.clone(),
                source,
            })?
        } else {
            csv_difference(&ta, &tb)
        };
        if let Some((at, values)) = d {
            return Ok(Some(Difference {
                file: n.clone(),
                at,
                values,
            }));
        }
    }
    Ok(None)
}

type Found = Option<(String, (String, String))>;

/// A CSV line without the cells of the [`is_timing`] columns of `header`.
pub fn without_timing(header: &str, line: &str) -> String {
    line.split(',')
        .zip(header.split(','))
        .filter(|(_, h)| !is_timing(h))
        .map(|(c, _)| c)
        .collect::<Vec<_>>()
        .join(",")
}

fn csv_difference(a: &str, b: &str) -> Found {
    let (mut la, mut lb) = (a.lines(), b.lines());
    let (ha, hb) = (la.next().unwrap_or(""), lb.next().unwrap_or(""));
    if ha != hb {
        return Some(("row 0 (header)".into(), (ha.into(), hb.into())));
    }
    let pick = |l: &str| without_timing(ha, l);
    let mut row = 0usize;
    loop {
        row += 1;
        match (la.next(), lb.next()) {
            (None, None) => return None,
            (x, y) => {
                let (x, y) = (x.map(pick), y.map(pick));
                if x != y {
                    let show = |v: Option<String>| v.unwrap_or_else(|| "(no row)".into());
                    return Some((format!("row {row}"), (show(x), show(y))));
                }
            }
        }
    }
}

fn json_difference(a: &str, b: &str) -> Result<Found, serde_json::Error> {
    let parse = |t: &str| serde_json::from_str::<serde_json::Value>(t);
    let (va, vb) = (parse(a)?, parse(b)?);
    let (mut sa, mut sb) = (Vec::new(), Vec::new());
    scalars(&va, "", &mut sa);
    scalars(&vb, "", &mut sb);
    let (ka, kb): (Vec<_>, Vec<_>) = (sa.iter().collect(), sb.iter().collect());
    for i in 0..ka.len().max(kb.len()) {
        match (ka.get(i), kb.get(i)) {
            (Some(x), Some(y)) if x == y => {}
            (x, y) => {
                let at = x.or(y).map(|p| p.0.clone()).unwrap_or_default();
                let v = |p: Option<&&(String, String)>| {
                    p.map_or("(none)".to_string(), |p| format!("{} = {}", p.0, p.1))
                };
                return Ok(Some((at, (v(x), v(y)))));
            }
        }
    }
    Ok(None)
}

/// Every scalar of a JSON value with its key path (`.a.b[2]`), leaving out
/// the keys [`is_timing`] names.
pub fn scalars(v: &serde_json::Value, path: &str, out: &mut Vec<(String, String)>) {
    use serde_json::Value;
    match v {
        Value::Object(m) => {
            for (k, x) in m {
                if !is_timing(k) {
                    scalars(x, &format!("{path}.{k}"), out);
                }
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                scalars(x, &format!("{path}[{i}]"), out);
            }
        }
        other => out.push((path.to_string(), other.to_string())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str, files: &[(&str, &str)]) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("sonarnet-cmp-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        for (f, t) in files {
            std::fs::write(d.join(f), t).unwrap();
        }
        d
    }

    #[test]
    fn equal_results_differing_only_in_timings_compare_equal() {
        let a = dir(
            "eq-a",
            &[
                ("track.csv", "sample,x,wall_seconds\n0,1.5,0.1\n"),
                ("metrics.json", r#"{"rmse": 1.0, "wall_seconds": 3.0}"#),
                ("run.json", r#"{"host": "a"}"#),
            ],
        );
        let b = dir(
            "eq-b",
            &[
                ("track.csv", "sample,x,wall_seconds\n0,1.5,0.7\n"),
                ("metrics.json", r#"{"rmse": 1.0, "wall_seconds": 9.0}"#),
                ("run.json", r#"{"host": "b"}"#),
            ],
        );
        assert_eq!(compare_results(&a, &b).unwrap(), None);
    }

    #[test]
    fn the_first_differing_file_and_row_are_named() {
        let a = dir(
            "ne-a",
            &[
                ("nodes.csv", "k,x\n0,1.0\n1,2.0\n2,3.0\n"),
                ("track.csv", "k,x\n0,1\n"),
                ("metrics.json", r#"{"a": {"rmse": 1.0}}"#),
            ],
        );
        let b = dir(
            "ne-b",
            &[
                ("nodes.csv", "k,x\n0,1.0\n1,2.0000000000000004\n2,3.0\n"),
                ("track.csv", "k,x\n0,2\n"),
                ("metrics.json", r#"{"a": {"rmse": 2.0}}"#),
            ],
        );
        let d = compare_results(&a, &b).unwrap().unwrap();
        assert_eq!(d.file, "metrics.json");
        assert_eq!(d.at, ".a.rmse");
        std::fs::write(b.join("metrics.json"), r#"{"a": {"rmse": 1.0}}"#).unwrap();
        let d = compare_results(&a, &b).unwrap().unwrap();
        assert_eq!((d.file.as_str(), d.at.as_str()), ("nodes.csv", "row 2"));
        std::fs::remove_file(b.join("nodes.csv")).unwrap();
        let d = compare_results(&a, &b).unwrap().unwrap();
        assert!(d.at.starts_with("missing in"), "{d}");
    }
}
