//! The results directory of one run: `run.json`, the CSVs (`track.csv`,
//! `nodes.csv`, `schedule.csv`, `iterations.csv`, `messages.csv`, `faults.csv`,
//! `measurements.csv`, `truth.csv`, `receivers.csv` when receivers drift) and
//! `metrics.json`.

use super::RunJson;
use super::RunStatus;
use crate::engine::RunOutcome;
use crate::model::geometry::Point;
use crate::pipeline::FaultOutcome;
use crate::pipeline::Outcome;
use crate::pipeline::RunError;
use crate::pipeline::RunOptions;
use crate::pipeline::outdir::OutDirError;
use crate::pipeline::score;
use crate::pipeline::score::Scored;
use crate::protocol::Clock;
use crate::protocol::EngineKind;
use crate::scenario::Realization;
use crate::scenario::Scenario;
use serde::Serialize;
use std::io::Write;
use std::path::Path;

impl<const D: usize> Outcome<D> {
    /// Write the results directory `opts.out_dir` of this run of `sc`. Always
    /// writes what there is, even for a run that stopped early. A 3-D run's
    /// position columns have a `z` after `x` and `y`.
    pub fn write(&self, sc: &Scenario<D>, opts: &RunOptions) -> Result<(), RunError> {
        let Outcome {
            metrics: m,
            run,
            started,
            ..
        } = self;
        let status = m.status;
        let dir = &opts.out_dir;
        std::fs::create_dir_all(dir).map_err(|e| RunError::Output {
            path: dir.clone(),
            source: e,
        })?;
        write_run_json(dir, sc, opts, status, run, *started)?;
        write_scenario_toml(dir, sc, opts)?;
        self.tables(sc, &mut CsvDir(dir))?;
        write_json(&dir.join("metrics.json"), m)?;
        Ok(())
    }

    /// Every table of the results directory, in the order [`Outcome::write`]
    /// writes them, handed to `sink` (the CSV files, or the Python package's
    /// DataFrames): `track`, `nodes`, `faults` (with faults), `schedule`,
    /// `messages`, `iterations` (when they have rows), `measurements`,
    /// `truth` (when known) and `receivers` (when receivers drift). One
    /// producer for both, so that a DataFrame holds what the CSV holds.
    pub fn tables(&self, sc: &Scenario<D>, sink: &mut dyn TableSink) -> Result<(), RunError> {
        let Outcome {
            metrics: m,
            run,
            scored,
            real,
            ..
        } = self;
        let done = run.record.thetas.len();
        track_table(sink, sc, real, scored, done)?;
        nodes_table(sink, sc, run)?;
        if sc.has_faults() {
            faults_table(sink, sc, &m.faults)?;
        }
        run_tables(sink, sc, run)?;
        trace_table(sink, &real.measurements[..done], sc.seed)?;
        if let Some(t) = real.truth.as_ref().map(|t| &t[..done]) {
            let mut header = vec!["sample"];
            header.extend(AXES[..D].iter());
            header.push("seed");
            sink.table(
                "truth",
                &header,
                &mut t.iter().enumerate().map(|(k, p)| {
                    let mut row = vec![k.to_string()];
                    row.extend(p.iter().map(|v| num(*v)));
                    row.push(sc.seed.to_string());
                    row
                }),
            )?;
        }
        if sc.geometry.drifts() {
            receivers_table(sink, sc, done)?;
        }
        Ok(())
    }
}

/// Where the tables of a run go ([`Outcome::tables`]): each comes as its
/// name (`track`, `nodes`, ...), its header and its rows of cells, every
/// float in its shortest round-trip form.
pub trait TableSink {
    /// Take one table.
    fn table(
        &mut self,
        name: &str,
        header: &[&str],
        rows: &mut dyn Iterator<Item = Vec<String>>,
    ) -> Result<(), RunError>;
}

/// The sink of the results directory: table `NAME` is the file `NAME.csv`.
pub struct CsvDir<'a>(pub &'a Path);

impl TableSink for CsvDir<'_> {
    fn table(
        &mut self,
        name: &str,
        header: &[&str],
        rows: &mut dyn Iterator<Item = Vec<String>>,
    ) -> Result<(), RunError> {
        write_csv(&self.0.join(format!("{name}.csv")), header, rows)
    }
}

/// `receivers.csv` (a run whose receivers drift): every receiver's
/// position at every completed sample, `sample,node,x,y[,z],drifts`.
fn receivers_table<const D: usize>(
    sink: &mut dyn TableSink,
    sc: &Scenario<D>,
    done: usize,
) -> Result<(), RunError> {
    let mut header = vec!["sample", "node"];
    header.extend(AXES[..D].iter());
    header.push("drifts");
    let g = &sc.geometry;
    let n = g.receivers.len();
    sink.table(
        "receivers",
        &header,
        &mut (0..done).flat_map(|k| {
            (0..n).map(move |i| {
                let mut row = vec![k.to_string(), i.to_string()];
                row.extend(g.receiver_at(i, k).iter().map(|v| num(*v)));
                row.push(matches!(g.drift.get(i), Some(Some(_))).to_string());
                row
            })
        }),
    )
}

/// `nodes.csv`: every node's `theta` after every completed sample,
/// whether it was alive, and (with faults) whether it was paused.
fn nodes_table<const D: usize>(
    sink: &mut dyn TableSink,
    sc: &Scenario<D>,
    run: &RunOutcome,
) -> Result<(), RunError> {
    let record = &run.record;
    // With faults, a `paused` column (before `seed`); without, the file
    // is as it always was.
    let faults = sc.has_faults();
    let mut header = vec!["sample", "node"];
    header.extend(AXES[..D].iter());
    header.extend(["d", "alive"]);
    if faults {
        header.push("paused");
    }
    header.push("seed");
    sink.table(
        "nodes",
        &header,
        &mut record.thetas.iter().enumerate().flat_map(|(k, ts)| {
            let alive = record.alive.get(k);
            let paused = run.paused(k);
            ts.iter().enumerate().map(move |(i, t)| {
                let up = alive.and_then(|m| m.get(i)).copied().unwrap_or(true);
                let mut row = vec![k.to_string(), i.to_string()];
                row.extend(t.iter().map(|v| num(*v)));
                row.push(up.to_string());
                if faults {
                    let p = paused.and_then(|m| m.get(i)).copied().unwrap_or(false);
                    row.push(p.to_string());
                }
                row.push(sc.seed.to_string());
                row
            })
        }),
    )
}

/// `faults.csv`: every fault applied, its detection and recovery.
fn faults_table<const D: usize>(
    sink: &mut dyn TableSink,
    sc: &Scenario<D>,
    faults: &[FaultOutcome],
) -> Result<(), RunError> {
    let opt = |v: Option<f64>| v.map(num).unwrap_or_default();
    sink.table(
        "faults",
        &[
            "t_s",
            "sample",
            "kind",
            "nodes",
            "detail",
            "detected_s",
            "recovered_s",
            "seed",
        ],
        &mut faults.iter().map(|f| {
            vec![
                num(f.t_s),
                f.sample.to_string(),
                f.kind.clone(),
                f.nodes
                    .iter()
                    .map(u32::to_string)
                    .collect::<Vec<_>>()
                    .join(" "),
                f.detail.clone(),
                opt(f.detected_s),
                opt(f.recovered_s),
                sc.seed.to_string(),
            ]
        }),
    )
}

/// The tables a run has only when they have rows: `schedule.csv`
/// (async schedules), `messages.csv` (the acoustic channel) and
/// `iterations.csv` (`--trace-iterations`).
fn run_tables<const D: usize>(
    sink: &mut dyn TableSink,
    sc: &Scenario<D>,
    run: &RunOutcome,
) -> Result<(), RunError> {
    let record = &run.record;
    if !record.schedule.is_empty() {
        sink.table(
            "schedule",
            &["iteration", "v", "w", "seed"],
            &mut record.schedule.iter().enumerate().map(|(it, (v, w))| {
                vec![
                    it.to_string(),
                    v.to_string(),
                    w.to_string(),
                    sc.seed.to_string(),
                ]
            }),
        )?;
    }
    let messages = run.channel.as_ref().map_or(&[][..], |c| &c.messages[..]);
    if !messages.is_empty() {
        // The SINR column only under the SINR reception rule.
        let sinr = messages.iter().any(|r| r.sinr_db.is_some());
        let mut header = vec![
            "t_send", "t_recv", "from", "to", "kind", "bits", "fate", "reason",
        ];
        if sinr {
            header.push("sinr_db");
        }
        header.push("seed");
        sink.table(
            "messages",
            &header,
            &mut messages.iter().map(|r| {
                let mut row = vec![
                    num(r.t_send),
                    r.t_recv.map(num).unwrap_or_default(),
                    r.from.to_string(),
                    r.to.to_string(),
                    r.kind.to_string(),
                    r.bits.to_string(),
                    r.fate().to_string(),
                    r.lost.map(|x| x.as_str().to_string()).unwrap_or_default(),
                ];
                if sinr {
                    row.push(r.sinr_db.map(num).unwrap_or_default());
                }
                row.push(sc.seed.to_string());
                row
            }),
        )?;
    }
    if !record.iteration_trace.is_empty() {
        let mut header = vec!["iteration", "sample", "node"];
        header.extend(AXES[..D].iter());
        header.extend(["d", "seed"]);
        sink.table(
            "iterations",
            &header,
            &mut record.iteration_trace.iter().map(|(it, k, i, t)| {
                let mut row = vec![it.to_string(), k.to_string(), i.to_string()];
                row.extend(t.iter().map(|v| num(*v)));
                row.push(sc.seed.to_string());
                row
            }),
        )?;
    }
    Ok(())
}

/// Write `track.csv`: the distributed track's columns, then per baseline
/// `NAME_x,NAME_y,NAME_error,NAME_ctte,NAME_regret` (+ `NAME_regret_pred` for
/// online trackers) and bound radii (`bound_B` on `theta_bar`, `NAME_bound_B`
/// on a baseline; empty when the set was empty).
pub fn write_track_csv<const D: usize>(
    path: &Path,
    sc: &Scenario<D>,
    real: &Realization<D>,
    scored: &Scored<D>,
    done: usize,
) -> Result<(), RunError> {
    struct File<'a>(&'a Path);
    impl TableSink for File<'_> {
        fn table(
            &mut self,
            _: &str,
            header: &[&str],
            rows: &mut dyn Iterator<Item = Vec<String>>,
        ) -> Result<(), RunError> {
            write_csv(self.0, header, rows)
        }
    }
    track_table(&mut File(path), sc, real, scored, done)
}

/// The columns of `track.csv` ([`write_track_csv`]).
fn track_table<const D: usize>(
    sink: &mut dyn TableSink,
    sc: &Scenario<D>,
    real: &Realization<D>,
    scored: &Scored<D>,
    done: usize,
) -> Result<(), RunError> {
    let truth = real.truth.as_ref().map(|t| &t[..done]);
    let axes = &AXES[..D];
    let mut header: Vec<String> = vec!["sample".into()];
    header.extend(axes.iter().map(|a| format!("true_{a}")));
    header.extend(axes.iter().map(|a| format!("est_{a}")));
    header.push("error".into());
    header.extend(axes.iter().map(|a| format!("ml_{a}")));
    header.extend(["crlb".into(), "ctte".into()]);
    let tb = &scored.tracks[0];
    let ml = &scored.tracks[1];
    if tb.regret.is_some() {
        header.push("regret".into());
    }
    for (b, _) in &tb.bounds {
        header.push(format!("bound_{b}"));
    }
    for t in &scored.tracks[2..] {
        for suffix in axes.iter().chain(&["error", "ctte"]) {
            header.push(format!("{}_{suffix}", t.name));
        }
        if t.regret.is_some() {
            header.push(format!("{}_regret", t.name));
        }
        if t.regret_pred.is_some() {
            header.push(format!("{}_regret_pred", t.name));
        }
        for (b, _) in &t.bounds {
            header.push(format!("{}_bound_{b}", t.name));
        }
    }
    header.push("seed".into());
    let header_refs: Vec<&str> = header.iter().map(String::as_str).collect();
    let mut rows = (0..done).map(|k| {
        let t = truth.map(|t| t[k]);
        let e = |tr: &score::ScoredTrack<D>| tr.error.as_ref().and_then(|e| e[k]);
        let c = |tr: &score::ScoredTrack<D>| tr.ctte.as_ref().map(|c| c[k]);
        let est = tb.est[k].unwrap_or_else(Point::<D>::zeros);
        let mut row = vec![k.to_string()];
        row.extend(coords(t));
        row.extend(est.iter().map(|v| num(*v)));
        row.push(opt(e(tb)));
        row.extend(coords(ml.est[k]));
        row.push(opt(scored.crlb[k]));
        row.push(opt(c(tb)));
        if let Some(r) = &tb.regret {
            row.push(num(r[k]));
        }
        for (_, radii) in &tb.bounds {
            row.push(opt(radii[k]));
        }
        for tr in &scored.tracks[2..] {
            row.extend(coords(tr.est[k]));
            row.push(opt(e(tr)));
            row.push(opt(c(tr)));
            if let Some(r) = &tr.regret {
                row.push(num(r[k]));
            }
            if let Some(r) = &tr.regret_pred {
                row.push(num(r[k]));
            }
            for (_, radii) in &tr.bounds {
                row.push(opt(radii[k]));
            }
        }
        row.push(sc.seed.to_string());
        row
    });
    sink.table("track", &header_refs, &mut rows)
}

/// Write measurements in the trace format
/// (`sample,receiver,transmitter,kind,value,seed`), so a run can be replayed.
pub fn write_trace(
    path: &Path,
    samples: &[crate::model::measure::SampleMeasurements],
    seed: u64,
) -> Result<(), RunError> {
    write_csv(path, TRACE_HEADER, &mut trace_rows(samples, seed))
}

const TRACE_HEADER: &[&str] = &["sample", "receiver", "transmitter", "kind", "value", "seed"];

/// `measurements.csv`, the trace format ([`write_trace`]).
fn trace_table(
    sink: &mut dyn TableSink,
    samples: &[crate::model::measure::SampleMeasurements],
    seed: u64,
) -> Result<(), RunError> {
    sink.table("measurements", TRACE_HEADER, &mut trace_rows(samples, seed))
}

fn trace_rows(
    samples: &[crate::model::measure::SampleMeasurements],
    seed: u64,
) -> impl Iterator<Item = Vec<String>> + '_ {
    samples.iter().enumerate().flat_map(move |(k, s)| {
        s.nodes.iter().enumerate().flat_map(move |(n, nm)| {
            let mut rows = Vec::new();
            for &(m, v) in &nm.bistatic {
                rows.push(vec![
                    k.to_string(),
                    n.to_string(),
                    m.to_string(),
                    "bistatic_range".into(),
                    num(v),
                    seed.to_string(),
                ]);
            }
            if let Some(v) = nm.doa {
                rows.push(vec![
                    k.to_string(),
                    n.to_string(),
                    String::new(),
                    "doa".into(),
                    num(v),
                    seed.to_string(),
                ]);
            }
            if let Some(v) = nm.elevation {
                rows.push(vec![
                    k.to_string(),
                    n.to_string(),
                    String::new(),
                    "elevation".into(),
                    num(v),
                    seed.to_string(),
                ]);
            }
            if let Some(v) = nm.range {
                rows.push(vec![
                    k.to_string(),
                    n.to_string(),
                    String::new(),
                    "range".into(),
                    num(v),
                    seed.to_string(),
                ]);
            }
            rows
        })
    })
}

/// `scenario.toml`: the run's resolved scenario
/// ([`Scenario::resolved_toml`]), with the command that reproduces it.
fn write_scenario_toml<const D: usize>(
    dir: &Path,
    sc: &Scenario<D>,
    opts: &RunOptions,
) -> Result<(), RunError> {
    let path = dir.join("scenario.toml");
    let logical_async =
        opts.clock == Clock::Logical && sc.algorithm.mode == crate::scenario::Mode::Async;
    let mut how = format!(
        "sonarnet run {} --engine {} --clock {}",
        path.display(),
        opts.engine.as_str(),
        opts.clock.as_str()
    );
    if opts.poll_us > 0 {
        how.push_str(&format!(" --poll-us {}", opts.poll_us));
    }
    how.push_str(&format!("   (or: sonarnet replay {})", dir.display()));
    let text = sc
        .resolved_toml(logical_async, &how)
        .map_err(|e| RunError::Output {
            path: path.clone(),
            source: std::io::Error::new(std::io::ErrorKind::InvalidData, e),
        })?;
    std::fs::write(&path, text).map_err(io_err(&path))
}

/// The names of the position columns, `x`, `y` and, in 3-D, `z`.
const AXES: [&str; 3] = ["x", "y", "z"];

/// Shortest round-trip decimal form of a float (exact replay from CSV).
fn num(x: f64) -> String {
    format!("{x:?}")
}

/// A point's coordinates as CSV fields; empty fields for `None`.
fn coords<const D: usize>(p: Option<Point<D>>) -> impl Iterator<Item = String> {
    (0..D).map(move |i| opt(p.map(|p| p[i])))
}

fn opt(x: Option<f64>) -> String {
    x.map(num).unwrap_or_default()
}

fn io_err(path: &Path) -> impl Fn(std::io::Error) -> RunError + '_ {
    move |e| RunError::Output {
        path: path.to_path_buf(),
        source: e,
    }
}

/// Make sure the results directory `dir` can be written before any work
/// starts: create it (and its parents) and write and remove a probe file in
/// it. The error says why it cannot be used, e.g. an existing file of that
/// name, a path below a file, or a read-only place. (The command line also
/// clears a previous run's files first: [`super::outdir::prepare_out_dir`].)
pub fn check_out_dir(dir: &Path) -> Result<(), OutDirError> {
    if dir.exists() && !dir.is_dir() {
        return Err(OutDirError::NotADirectory(dir.to_path_buf()));
    }
    std::fs::create_dir_all(dir).map_err(OutDirError::io("create", dir))?;
    let probe = dir.join(".sonarnet-write-check");
    std::fs::write(&probe, b"").map_err(OutDirError::io("write in", dir))?;
    std::fs::remove_file(&probe).map_err(OutDirError::io("remove", &probe))
}

/// Write a CSV file with a header and string rows.
pub fn write_csv(
    path: &Path,
    header: &[&str],
    rows: impl Iterator<Item = Vec<String>>,
) -> Result<(), RunError> {
    let f = std::fs::File::create(path).map_err(io_err(path))?;
    let mut w = csv::Writer::from_writer(std::io::BufWriter::new(f));
    let to_io = |e: csv::Error| RunError::Output {
        path: path.to_path_buf(),
        source: std::io::Error::other(e),
    };
    w.write_record(header).map_err(to_io)?;
    for r in rows {
        w.write_record(&r).map_err(to_io)?;
    }
    w.flush().map_err(io_err(path))
}

/// Write pretty JSON.
pub fn write_json<T: Serialize>(path: &Path, v: &T) -> Result<(), RunError> {
    let mut f = std::fs::File::create(path).map_err(io_err(path))?;
    let s = serde_json::to_string_pretty(v).map_err(|e| RunError::Output {
        path: path.to_path_buf(),
        source: std::io::Error::other(e),
    })?;
    f.write_all(s.as_bytes()).map_err(io_err(path))?;
    f.write_all(b"\n").map_err(io_err(path))
}

fn write_run_json<const D: usize>(
    dir: &Path,
    sc: &Scenario<D>,
    opts: &RunOptions,
    status: RunStatus,
    run: &crate::engine::RunOutcome,
    started: std::time::SystemTime,
) -> Result<(), RunError> {
    let resolved = sc.resolved_file();
    let scenario = serde_json::to_value(&resolved).map_err(|e| RunError::Output {
        path: dir.join("run.json"),
        source: std::io::Error::other(e),
    })?;
    let v = RunJson {
        scenario_file: Some(sc.path.display().to_string()),
        scenario,
        edges: Some(sc.graph.edges().to_vec()),
        seed: Some(sc.seed),
        crate_version: Some(env!("CARGO_PKG_VERSION").into()),
        engine: Some(opts.engine.as_str().into()),
        driver: run.driver,
        mode: Some(sc.algorithm.mode.as_str().into()),
        clock: Some(opts.clock.as_str().into()),
        local_solver: Some(sc.algorithm.local_solver.as_str().into()),
        poll_us: Some(opts.poll_us),
        command_line: opts.command_line.clone(),
        status: Some(status),
        error: run
            .error
            .as_ref()
            .map(crate::protocol::EngineError::in_full),
        run_id: run.processes.as_ref().map(|p| p.run_id.clone()),
        stall_timeout_s: Some(opts.stall_timeout.as_secs_f64()),
        git_commit: super::provenance::GIT_COMMIT.map(str::to_owned),
        host: super::provenance::host_name(),
        inputs: super::provenance::input_paths(sc),
        overrides: sc.overrides.clone(),
        started_utc: Some(super::provenance::utc_iso(started)),
        transport: (opts.engine == EngineKind::Processes).then(|| match opts.net.transport {
            crate::transport::TransportChoice::Iceoryx2 => "iceoryx2".into(),
            crate::transport::TransportChoice::Zenoh(_) => "zenoh".into(),
        }),
        placement: match opts.net.transport {
            crate::transport::TransportChoice::Zenoh(_) => {
                opts.net.placement.clone().or_else(|| sc.deploy.clone())
            }
            crate::transport::TransportChoice::Iceoryx2 => None,
        },
    };
    write_json(&dir.join("run.json"), &v)
}
