//! Fuzzing harnesses: each takes arbitrary bytes and drives one decoder or
//! parser of untrusted input the way the program does, so that a panic, a
//! hang or an unbounded allocation shows up as a crash. The fuzz targets of
//! `fuzz/` (cargo-fuzz, libFuzzer) call these, and the test suite runs every
//! input kept in `fuzz/corpus/` and `fuzz/regressions/` through them as
//! ordinary tests, so a crash found once stays fixed.
//!
//! The harnesses assert nothing about the results beyond the absence of a
//! panic; a bad input must come back as an error value.

use crate::protocol::codec::{NodeDecoder, NodeInput, ReportDecoder, decode_peer};
use crate::protocol::{Input, NodeCore, Output};
use crate::transport::wire::Frame;
use std::path::Path;

/// The size of one frame in a harness's input: `kind`, `from`, `sample`,
/// `aux` (4 bytes each, little endian), `seq` (8) and five `f64` (40).
pub const FRAME_BYTES: usize = 64;

/// The frames of `data`, [`FRAME_BYTES`] each (a short tail is dropped).
pub fn frames_of(data: &[u8]) -> Vec<Frame> {
    let u32_at = |c: &[u8], i: usize| u32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
    let u64_at = |c: &[u8], i: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&c[i..i + 8]);
        u64::from_le_bytes(b)
    };
    data.chunks_exact(FRAME_BYTES)
        .map(|c| Frame {
            kind: u32_at(c, 0),
            from: u32_at(c, 4),
            sample: u32_at(c, 8),
            aux: u32_at(c, 12),
            seq: u64_at(c, 16),
            data: std::array::from_fn(|k| f64::from_bits(u64_at(c, 24 + 8 * k))),
        })
        .collect()
}

/// The bytes of `frames` in the layout [`frames_of`] reads (to build
/// corpora from real frames).
pub fn bytes_of(frames: &[Frame]) -> Vec<u8> {
    let mut out = Vec::with_capacity(frames.len() * FRAME_BYTES);
    for f in frames {
        out.extend_from_slice(&f.kind.to_le_bytes());
        out.extend_from_slice(&f.from.to_le_bytes());
        out.extend_from_slice(&f.sample.to_le_bytes());
        out.extend_from_slice(&f.aux.to_le_bytes());
        out.extend_from_slice(&f.seq.to_le_bytes());
        for v in f.data {
            out.extend_from_slice(&v.to_bits().to_le_bytes());
        }
    }
    out
}

/// A node of the shipped spiral (node 3, four neighbours) in `dim`
/// dimensions, as a run would start it.
fn spiral_node(dim: usize) -> Option<NodeCore> {
    let text = crate::scenario::shipped::text(if dim == 3 {
        "mourya2017-spiral-3d"
    } else {
        "mourya2017-spiral"
    })?;
    let cfg = crate::protocol::RunConfig::default();
    let plan = match crate::scenario::AnyScenario::all_from_toml_str(text, Path::new("fuzz.toml"))
        .ok()?
        .into_iter()
        .next()?
    {
        crate::scenario::AnyScenario::Plane(sc) => crate::protocol::RunPlan::new(&sc, cfg).ok()?,
        crate::scenario::AnyScenario::Space(sc) => crate::protocol::RunPlan::new(&sc, cfg).ok()?,
    };
    plan.nodes.get(3).cloned().map(NodeCore::new)
}

/// The shipped 2-D spiral's run plan and realization, made once, for the
/// coordinator's side of [`node_frames`].
fn spiral_run() -> Option<&'static (
    crate::protocol::RunPlan,
    crate::model::synth::Realization<2>,
)> {
    static RUN: std::sync::OnceLock<
        Option<(
            crate::protocol::RunPlan,
            crate::model::synth::Realization<2>,
        )>,
    > = std::sync::OnceLock::new();
    RUN.get_or_init(|| {
        let sc = spirals().0.as_ref()?;
        let plan = crate::protocol::RunPlan::new(sc, crate::protocol::RunConfig::default()).ok()?;
        Some((plan, sc.realize()))
    })
    .as_ref()
}

/// Both sides of the wire: the frames of `data` through the node's
/// decoder, in 2-D and in 3-D, and every decoded input into a running node
/// of that dimension (what a node process does with what reaches its
/// inbox); the coordinator's report decoder and the peer decoder on the
/// same frames, and every report and answer it decodes into the running
/// coordinator of the 2-D spiral (what the coordinator does with what
/// reaches its inbox).
pub fn node_frames(data: &[u8]) {
    let frames = frames_of(data);
    if let Some((plan, real)) = spiral_run() {
        use crate::protocol::codec::CoordinatorInput;
        use crate::protocol::coordinator::{Coordinator, Event};
        let mut coord = Coordinator::new(plan, real.feed());
        let mut actions = Vec::new();
        coord.handle(std::time::Duration::ZERO, [Event::Start], &mut actions);
        let mut reports = ReportDecoder::new(2);
        for (k, f) in frames.iter().enumerate() {
            let event = match reports.feed(f) {
                Ok(Some(CoordinatorInput::Report(r))) => Event::Report(r),
                Ok(Some(CoordinatorInput::Pong { node, seq })) => Event::Pong { node, seq },
                _ => continue,
            };
            actions.clear();
            let now = std::time::Duration::from_millis(k as u64 + 1);
            coord.handle(now, [event], &mut actions);
        }
    }
    for dim in [2, 3] {
        let mut node = spiral_node(dim);
        let mut dec = NodeDecoder::new(dim);
        let mut reports = ReportDecoder::new(dim);
        let mut out: Vec<Output> = Vec::new();
        for f in &frames {
            let _ = decode_peer(f, dim);
            let _ = reports.feed(f);
            let input = match dec.feed(f) {
                Ok(Some(NodeInput::Control(crate::protocol::codec::Control::Command(c)))) => {
                    Input::Command(c)
                }
                Ok(Some(NodeInput::Peer(m))) => Input::Peer(m),
                _ => continue,
            };
            if let Some(n) = node.as_mut() {
                n.handle(input, &mut out);
                out.clear();
            }
        }
    }
}

/// A scenario file's text, read as either dimension and validated (the
/// files it names are looked for beside `fuzz.toml`, where there are none).
pub fn scenario_text(data: &[u8]) {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = crate::scenario::AnyScenario::all_from_toml_str(text, Path::new("fuzz.toml"));
    }
}

/// Command-line values, one per line: every line as a `--set` override, a
/// `--grid` axis, a `--seeds` range, a `--fault` and a `--nemesis` value,
/// each applied to the shipped spiral where it applies.
pub fn command_line_values(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Some(base) = crate::scenario::shipped::text("mourya2017-spiral") else {
        return;
    };
    let Ok(sc) = crate::scenario::Scenario::from_toml_str(base, Path::new("fuzz.toml")) else {
        return;
    };
    for line in text.lines().take(16) {
        if let Ok(o) = crate::scenario::Override::parse(line) {
            let mut t: toml::Table = toml::from_str(base).unwrap_or_default();
            let _ = o.apply(&mut t);
        }
        let _ = crate::pipeline::sweep::Axis::parse(line);
        let _ = crate::pipeline::sweep::parse_seeds(line);
        let _ = sc.clone().with_fault_flag(line);
        let _ = sc.clone().with_nemesis(line, 10.0);
    }
}

/// The files of a results directory that `sonarnet report` and `replay`
/// read: the bytes as `run.json` and `summary.json`, and as `track.csv`,
/// `nodes.csv` and `messages.csv`.
pub fn results_files(data: &[u8]) {
    let p = Path::new("fuzz");
    if let Ok(v) = serde_json::from_slice::<serde_json::Value>(data) {
        let _ = crate::plot::data::parse_run_json(p, &v);
        let _ = crate::plot::data::parse_summary(p, &v);
        let _ = serde_json::from_value::<crate::pipeline::RunJson>(v);
    }
    let mut rdr = csv::ReaderBuilder::new().flexible(true).from_reader(data);
    let Ok(header) = rdr.headers().map(|h| h.iter().map(str::to_owned).collect()) else {
        return;
    };
    let rows = rdr
        .records()
        .take(10_000)
        .map_while(Result::ok)
        .map(|r| r.iter().map(str::to_owned).collect())
        .collect();
    let csv = crate::plot::data::Csv { header, rows };
    let _ = crate::plot::data::parse_track_csv(p, &csv);
    let _ = crate::plot::data::parse_node_points(p, &csv, false);
    let _ = crate::plot::data::parse_node_points(p, &csv, true);
    let _ = crate::plot::data::parse_messages(p, &csv);
}

/// The shipped spirals, read once: 2-D and 3-D.
fn spirals() -> &'static (
    Option<crate::scenario::Scenario<2>>,
    Option<crate::scenario::Scenario<3>>,
) {
    static SPIRALS: std::sync::OnceLock<(
        Option<crate::scenario::Scenario<2>>,
        Option<crate::scenario::Scenario<3>>,
    )> = std::sync::OnceLock::new();
    SPIRALS.get_or_init(|| {
        let read = |name: &str| {
            crate::scenario::shipped::text(name).and_then(|t| {
                crate::scenario::AnyScenario::all_from_toml_str(t, Path::new("fuzz.toml"))
                    .ok()?
                    .into_iter()
                    .next()
            })
        };
        let plane = match read("mourya2017-spiral") {
            Some(crate::scenario::AnyScenario::Plane(sc)) => Some(sc),
            _ => None,
        };
        let space = match read("mourya2017-spiral-3d") {
            Some(crate::scenario::AnyScenario::Space(sc)) => Some(sc),
            _ => None,
        };
        (plane, space)
    })
}

/// The files a user hands sonarnet besides the scenario, and the one a
/// restarted node reads: the bytes as a measurement trace, a truth file and
/// an async schedule of the shipped spiral (2-D and 3-D), and as a node's
/// checkpoint file (2-D and 3-D).
pub fn user_files(data: &[u8]) {
    let p = Path::new("fuzz.csv");
    let (plane, space) = spirals();
    if let Some(sc) = plane {
        let _ = crate::scenario::trace_from(data, p, &sc.geometry);
        let _ = crate::scenario::truth_from::<2, _>(data, p);
        let _ = crate::scenario::schedule_from(data, p, &sc.graph);
    }
    if let Some(sc) = space {
        let _ = crate::scenario::trace_from(data, p, &sc.geometry);
        let _ = crate::scenario::truth_from::<3, _>(data, p);
    }
    for dim in [2, 3] {
        let _ = crate::engine::checkpoint::Checkpoint::parse(data, p, 3, dim);
    }
}

/// The harness of the fuzz target `name`, for the corpus tests.
pub fn harness(name: &str) -> Option<fn(&[u8])> {
    Some(match name {
        "node_frames" => node_frames,
        "scenario_text" => scenario_text,
        "command_line_values" => command_line_values,
        "results_files" => results_files,
        "user_files" => user_files,
        _ => return None,
    })
}

/// The fuzz targets, by name.
pub const TARGETS: [&str; 5] = [
    "node_frames",
    "scenario_text",
    "command_line_values",
    "results_files",
    "user_files",
];
