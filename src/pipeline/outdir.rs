//! Results directories never mix runs: a run into an existing directory
//! first removes the previous run's files, and refuses (exit 2) a directory
//! that holds files sonarnet did not write.

use std::path::{Path, PathBuf};

/// Why a results directory cannot be used; an I/O failure keeps its cause.
#[derive(Debug, thiserror::Error)]
pub enum OutDirError {
    /// A file of that name is in the way.
    #[error("{} exists and is not a directory", .0.display())]
    NotADirectory(PathBuf),
    /// Listing, creating, writing in or removing from the directory failed.
    #[error("cannot {what} {}", path.display())]
    Io {
        /// What was being done (`list`, `create`, `write in`, `remove`).
        what: &'static str,
        /// The path.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The directory holds files sonarnet does not write.
    #[error(
        "{} holds files sonarnet did not write ({}): choose another --out, or move them",
        dir.display(),
        shown(names)
    )]
    Foreign {
        /// The directory.
        dir: PathBuf,
        /// The foreign entries' names, sorted.
        names: Vec<String>,
    },
}

impl OutDirError {
    /// The [`OutDirError::Io`] of doing `what` to `path`.
    pub(crate) fn io(what: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.to_path_buf();
        move |source| OutDirError::Io { what, path, source }
    }
}

/// The first five names and how many more.
fn shown(names: &[String]) -> String {
    let first: Vec<&str> = names.iter().take(5).map(String::as_str).collect();
    let more = if names.len() > 5 {
        format!(" and {} more", names.len() - 5)
    } else {
        String::new()
    };
    format!("{}{more}", first.join(", "))
}

/// Files a run, a Monte Carlo run, a sweep or `sonarnet report` writes.
const FILES: &[&str] = &[
    "run.json",
    "metrics.json",
    "summary.json",
    "bench.json",
    "scenario.toml",
    "report.html",
    "track.csv",
    "nodes.csv",
    "schedule.csv",
    "iterations.csv",
    "messages.csv",
    "faults.csv",
    "measurements.csv",
    "truth.csv",
    "receivers.csv",
    "trials.csv",
    "sweep.csv",
    "sweep-summary.csv",
    ".sonarnet-write-check",
];

/// Plot names (`NAME.svg`, `NAME.png`).
const PLOTS: &[&str] = &[
    "tracks",
    "depth",
    "error",
    "ctte",
    "consensus",
    "network",
    "messages",
    "channel",
    "sweep",
    "error-cdf",
    "tightness",
    "scatter",
];

/// Directories a run writes (checkpoint files, a sweep's runs).
const DIRS: &[&str] = &["checkpoints", "runs"];

/// Whether `name` (a directory entry) is a file sonarnet writes into a
/// results directory.
pub fn is_sonarnet_output(name: &str, is_dir: bool) -> bool {
    if is_dir {
        return DIRS.contains(&name);
    }
    if FILES.contains(&name) {
        return true;
    }
    if name.starts_with("compare-") && name.ends_with(".html") {
        return true;
    }
    match name.rsplit_once('.') {
        Some((stem, "svg" | "png")) => PLOTS.contains(&stem) || stem.starts_with("compare-"),
        _ => false,
    }
}

/// The command line's check of a results directory before any work:
/// [`clear_previous_run`], then [`super::check_out_dir`] (writable). The
/// library's [`crate::scenario::Scenario::run_and_write`] only checks that it
/// can write, so a program may keep its own files next to a run's.
pub fn prepare_out_dir(dir: &Path) -> Result<(), OutDirError> {
    if dir.exists() && !dir.is_dir() {
        return Err(OutDirError::NotADirectory(dir.to_path_buf()));
    }
    clear_previous_run(dir)?;
    super::check_out_dir(dir)
}

/// Make `dir` ready for a new run: create it if needed; if it holds a
/// previous run's files, remove them (and nothing else). Refuses, naming
/// them, when it holds anything sonarnet does not write. Returns the
/// entries removed.
pub fn clear_previous_run(dir: &Path) -> Result<Vec<PathBuf>, OutDirError> {
    if !dir.exists() {
        return Ok(Vec::new());
    }
    let entries = std::fs::read_dir(dir)
        .map_err(OutDirError::io("list", dir))?
        .collect::<Result<Vec<_>, _>>()
        .map_err(OutDirError::io("list", dir))?;
    let mut ours = Vec::new();
    let mut foreign = Vec::new();
    for e in entries {
        let name = e.file_name().to_string_lossy().into_owned();
        let is_dir = e.file_type().map(|t| t.is_dir()).unwrap_or(false);
        if is_sonarnet_output(&name, is_dir) {
            ours.push((e.path(), is_dir));
        } else {
            foreign.push(name);
        }
    }
    if !foreign.is_empty() {
        foreign.sort();
        return Err(OutDirError::Foreign {
            dir: dir.to_path_buf(),
            names: foreign,
        });
    }
    for (p, is_dir) in &ours {
        let r = if *is_dir {
            std::fs::remove_dir_all(p)
        } else {
            std::fs::remove_file(p)
        };
        r.map_err(OutDirError::io("remove the previous run's", p))?;
    }
    Ok(ours.into_iter().map(|(p, _)| p).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("sonarnet-outdir-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_previous_runs_files_are_removed_and_nothing_else_is_touched() {
        let d = tmp("ours");
        for f in [
            "run.json",
            "track.csv",
            "tracks.svg",
            "tracks.png",
            "compare-b.html",
        ] {
            std::fs::write(d.join(f), "x").unwrap();
        }
        std::fs::create_dir_all(d.join("checkpoints")).unwrap();
        std::fs::write(d.join("checkpoints/node-0.json"), "{}").unwrap();
        let removed = clear_previous_run(&d).unwrap();
        assert_eq!(removed.len(), 6);
        assert_eq!(std::fs::read_dir(&d).unwrap().count(), 0);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn a_directory_with_foreign_files_is_refused_and_left_as_it_was() {
        let d = tmp("foreign");
        std::fs::write(d.join("run.json"), "x").unwrap();
        std::fs::write(d.join("notes.txt"), "mine").unwrap();
        std::fs::write(d.join("data.csv"), "mine").unwrap();
        let e = clear_previous_run(&d).unwrap_err();
        assert!(e.to_string().contains("(data.csv, notes.txt)"), "{e}");
        assert!(d.join("run.json").exists() && d.join("notes.txt").exists());
        std::fs::remove_dir_all(&d).unwrap();
    }
}
