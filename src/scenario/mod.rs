//! Scenario files: TOML parsed into validated types.
//!
//! The raw file format ([`ScenarioFile`]) is documented key by key in
//! `scenarios/README.md`. [`Scenario::load`] parses it with
//! `deny_unknown_fields`, checks every value, loads the trace, truth and
//! schedule files it names (paths relative to the scenario file), and returns
//! one [`InputError`] that names the file, the key or line, and the reason.

pub mod expect;

pub use crate::estimators::gossip::Mode;
pub use crate::model::synth::{MeasurementsCfg, Realization};
pub use crate::scenario::expect::ExpectCfg;

use crate::estimators::prox::LocalSolver;
use crate::model::error::InputError;
use crate::model::geometry::{Vec2, Vec3, v2};
use crate::model::graph::Graph;
use crate::model::measure::{Geometry, NodeMeasurements, SampleMeasurements, Sigmas};
use crate::model::motion::Motion;
use crate::model::rng::{SonarRng, Stream, stream_rng};
use rand::RngExt;
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// The raw scenario file (`deny_unknown_fields` at every level).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioFile {
    /// Short identifier.
    pub name: String,
    /// Free text.
    #[serde(default)]
    pub description: String,
    /// The run seed (overridden by `--seed`).
    #[serde(default)]
    pub seed: u64,
    /// Transmitter and receiver positions.
    pub geometry: GeometryCfg,
    /// The gossip graph over the receivers.
    pub network: NetworkCfg,
    /// Target motion (required unless a trace is given).
    #[serde(default)]
    pub target: Option<TargetCfg>,
    /// What is measured and how noisy, or a recorded trace.
    pub measurements: MeasurementsCfg,
    /// Douglas-Rachford parameters.
    pub algorithm: AlgorithmCfg,
    /// Free-running emulator parameters (multi-process engine, `--clock realtime`).
    #[serde(default)]
    pub realtime: Option<RealtimeCfg>,
    /// Thresholds the scenario tests assert.
    #[serde(default)]
    pub expect: ExpectCfg,
    /// Centralised baselines scored next to the distributed track (`[[baselines]]`).
    #[serde(default)]
    pub baselines: Vec<crate::estimators::baselines::BaselineCfg>,
    /// Certified error bounds attached to the tracks (`[bounds]`, seed 003).
    #[serde(default)]
    pub bounds: Option<BoundsCfg>,
    /// What the scoring computes (`[scoring]`).
    #[serde(default)]
    pub scoring: ScoringCfg,
    /// Repeat the run over seeds `seed..seed+trials` (`[monte_carlo]`).
    #[serde(default)]
    pub monte_carlo: Option<MonteCarloCfg>,
    /// Named variants of this scenario (`[[variants]]`): each is a table of
    /// overrides deep-merged into the file (see `scenarios/README.md`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub variants: Vec<VariantCfg>,
}

/// One `[[variants]]` entry: a `name` and any scenario keys to override.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VariantCfg {
    /// Variant name (used in the results directory name and `--variant`).
    pub name: String,
    /// The overriding keys, merged table by table into the base file
    /// (arrays and values replace).
    #[serde(flatten)]
    pub overrides: toml::Table,
}

/// A certified bound of seed 003.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BoundKind {
    /// Upp-RBBox, eq. (53)-(54).
    UppRbbox,
    /// Upp-BBox, eq. (48)-(49).
    UppBbox,
    /// Upp-MinBall, eq. (43)-(44).
    UppMinball,
    /// Upp-MaxDis, eq. (26).
    UppMaxdis,
}

impl BoundKind {
    /// The name used in files (`upp_maxdis`, ...).
    pub fn as_str(self) -> &'static str {
        match self {
            BoundKind::UppRbbox => "upp_rbbox",
            BoundKind::UppBbox => "upp_bbox",
            BoundKind::UppMinball => "upp_minball",
            BoundKind::UppMaxdis => "upp_maxdis",
        }
    }
}

/// `[bounds]`: which certified bounds to attach, to which tracks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundsCfg {
    /// The bounds to compute at every sample.
    pub names: Vec<BoundKind>,
    /// Enlargement `rho` (metres) of every measured range (seed 003 Remark 4):
    /// the sets are `||x - a|| <= d + rho` and `||x - t|| + ||x - r|| <= rho_mn + rho`.
    #[serde(default)]
    pub rho: f64,
    /// Further enlargement in units of the nominal range sigma of the sample.
    #[serde(default)]
    pub rho_sigmas: f64,
    /// Tracks that carry the bounds (`theta_bar`, `ml`, baseline names);
    /// default: `theta_bar` and every baseline.
    #[serde(default)]
    pub tracks: Option<Vec<String>>,
    /// Tracks with their own list of bounds, replacing `names` for them (they
    /// carry these bounds whether or not `tracks` lists them), e.g.
    /// `per_track = { lls = ["upp_maxdis"] }`.
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub per_track: std::collections::BTreeMap<String, Vec<BoundKind>>,
}

impl BoundsCfg {
    /// Whether the track `name` carries the `names` bounds (`tracks`, or by default
    /// every track but `ml`). See [`BoundsCfg::kinds_for`] for what it carries.
    pub fn applies_to(&self, name: &str) -> bool {
        match &self.tracks {
            Some(t) => t.iter().any(|x| x == name),
            None => name != "ml",
        }
    }

    /// The bounds the track `name` carries: its `per_track` list, else `names` if
    /// [`BoundsCfg::applies_to`] it, else none.
    pub fn kinds_for(&self, name: &str) -> &[BoundKind] {
        if let Some(k) = self.per_track.get(name) {
            return k;
        }
        if self.applies_to(name) {
            &self.names
        } else {
            &[]
        }
    }

    /// Every bound some track carries, in first-mention order (`names`, then the
    /// `per_track` lists).
    pub fn all_kinds(&self) -> Vec<BoundKind> {
        let mut v: Vec<BoundKind> = Vec::new();
        for k in self.names.iter().chain(self.per_track.values().flatten()) {
            if !v.contains(k) {
                v.push(*k);
            }
        }
        v
    }
}

/// `[scoring]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScoringCfg {
    /// Compute the dynamic regret of every track (needs `x_hat_t` per sample;
    /// default true).
    #[serde(default = "default_true")]
    pub regret: bool,
}

impl Default for ScoringCfg {
    fn default() -> Self {
        ScoringCfg { regret: true }
    }
}

/// `[monte_carlo]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MonteCarloCfg {
    /// Number of trials (seeds `seed .. seed + trials`).
    pub trials: usize,
}

/// `[geometry]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct GeometryCfg {
    /// Transmitter positions `t_m` (metres).
    #[serde(default)]
    pub transmitters: Vec<[f64; 2]>,
    /// Receiver positions `r_n`; may be omitted when `network.generator` is
    /// `random_geometric` with `count` (receivers are then drawn).
    #[serde(default)]
    pub receivers: Vec<[f64; 2]>,
}

/// `[network]`: exactly one of `edges` and `generator`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct NetworkCfg {
    /// Explicit 0-based edges.
    #[serde(default)]
    pub edges: Option<Vec<[usize; 2]>>,
    /// A graph generator.
    #[serde(default)]
    pub generator: Option<GeneratorCfg>,
}

/// Graph generators.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum GeneratorCfg {
    /// `0-1-...-(N-1)-0`.
    Ring,
    /// A `rows x cols` lattice over the receivers in row-major order.
    Grid {
        /// Rows.
        rows: usize,
        /// Columns.
        cols: usize,
    },
    /// Receivers closer than `radius` are joined. With `count`, `min`, `max`
    /// the `count` receivers are drawn uniformly in the box `[min, max]` from
    /// `seed` (redrawn until the graph is connected, at most 1000 times).
    RandomGeometric {
        /// Connection radius (metres).
        radius: f64,
        /// Seed of the receiver layout.
        #[serde(default)]
        seed: u64,
        /// Number of receivers to draw (only when `geometry.receivers` is empty).
        #[serde(default)]
        count: Option<usize>,
        /// Lower corner of the layout box.
        #[serde(default)]
        min: Option<[f64; 2]>,
        /// Upper corner of the layout box.
        #[serde(default)]
        max: Option<[f64; 2]>,
    },
}

/// `[target]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetCfg {
    /// Number of samples `k = 0..samples`.
    pub samples: usize,
    /// The motion model.
    pub motion: Motion,
}

fn default_true() -> bool {
    true
}

fn default_ips() -> usize {
    50
}

/// `[algorithm]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AlgorithmCfg {
    /// `sync` or `async`.
    pub mode: Mode,
    /// Prox step `gamma > 0`.
    pub gamma: f64,
    /// Douglas-Rachford iterations between two samples.
    #[serde(default = "default_ips")]
    pub iterations_per_sample: usize,
    /// `gtrs` (exact, eq. 13), `relaxed` or `gtrs_l0` (eq. 13 with `l0` outlier
    /// separation, seed 004 eq. 7).
    #[serde(default = "default_solver")]
    pub local_solver: LocalSolver,
    /// `gtrs_l0` only: how many rows of each node's cost may be outliers. Must be
    /// below the number of rows of every node that has measurements.
    #[serde(default = "default_kappa")]
    pub kappa: usize,
    /// Initial `u` of every node.
    #[serde(default)]
    pub init_u: [f64; 3],
    /// Replay this async schedule (CSV `iteration,v,w`) instead of drawing one.
    #[serde(default)]
    pub schedule: Option<String>,
    /// Samples excluded from the `*_after_burn_in` metrics.
    #[serde(default)]
    pub burn_in: usize,
}

fn default_solver() -> LocalSolver {
    LocalSolver::Gtrs
}

fn default_kappa() -> usize {
    crate::estimators::prox::l0::DEFAULT_KAPPA
}

/// `[realtime]`: the free-running emulator's clocks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RealtimeCfg {
    /// Time between two samples (milliseconds).
    pub sample_period_ms: f64,
    /// Poisson wake-up rate of every node (per second).
    pub wake_rate_hz: f64,
}

/// Where the measurements come from.
#[derive(Debug, Clone, PartialEq)]
pub enum DataSource {
    /// Synthesized from a motion model at run time (depends on the seed).
    Synthetic {
        /// The target motion.
        motion: Motion,
    },
    /// Read from a trace file.
    Trace {
        /// The trace file.
        path: PathBuf,
        /// Per-sample measurements.
        measurements: Vec<SampleMeasurements>,
        /// The true track, if a truth file was given.
        truth: Option<Vec<Vec2>>,
    },
}

/// Validated algorithm parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct Algorithm {
    /// Gossip mode.
    pub mode: Mode,
    /// Prox step.
    pub gamma: f64,
    /// Iterations between samples.
    pub iterations_per_sample: usize,
    /// Local prox.
    pub local_solver: LocalSolver,
    /// Outlier budget per node of `gtrs_l0`.
    pub kappa: usize,
    /// Initial `u`.
    pub init_u: Vec3,
    /// A replayed async schedule, `(v, w)` per iteration, and its file.
    pub schedule: Option<(PathBuf, Vec<(usize, usize)>)>,
    /// Burn-in samples.
    pub burn_in: usize,
}

/// A validated scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// The scenario file.
    pub path: PathBuf,
    /// The raw file as parsed (recorded in `run.json`).
    pub file: ScenarioFile,
    /// Scenario name.
    pub name: String,
    /// Run seed.
    pub seed: u64,
    /// Positions.
    pub geometry: Geometry,
    /// Gossip graph over the receivers.
    pub graph: Graph,
    /// Number of samples.
    pub samples: usize,
    /// Measurement source.
    pub source: DataSource,
    /// What to synthesize and the nominal noise.
    pub measurements: MeasurementsCfg,
    /// DR parameters.
    pub algorithm: Algorithm,
    /// Realtime clocks, if given.
    pub realtime: Option<RealtimeCfg>,
    /// Test thresholds.
    pub expect: ExpectCfg,
    /// Record every node's `theta` after every iteration (`iterations.csv`);
    /// a run option (`--trace-iterations`), not part of the file.
    pub trace_iterations: bool,
    /// Baselines (validated, unique names).
    pub baselines: Vec<crate::estimators::baselines::BaselineCfg>,
    /// Certified bounds.
    pub bounds: Option<BoundsCfg>,
    /// Scoring options.
    pub scoring: ScoringCfg,
    /// Monte Carlo trials (`None`: a single run).
    pub trials: Option<usize>,
    /// The variant's name, for a file with `[[variants]]`.
    pub variant: Option<String>,
}

/// Check the baselines (parameters, unique names) and the `[bounds]` table
/// against them: `Err((key, reason))`. The one check for the file and for
/// `--baselines`, which replaces the list (so `bounds.tracks` must still name
/// existing tracks).
fn check_tracks(
    baselines: &[crate::estimators::baselines::BaselineCfg],
    bounds: Option<&BoundsCfg>,
    geometry: &Geometry,
) -> Result<(), (String, String)> {
    let mut names = BTreeSet::new();
    for (i, b) in baselines.iter().enumerate() {
        b.validate(geometry, !geometry.transmitters.is_empty())
            .map_err(|e| (format!("baselines[{i}] ({})", b.kind()), e))?;
        if !names.insert(b.name()) {
            return Err((
                format!("baselines[{i}].name"),
                format!(
                    "duplicate track name {:?}: give each baseline its own `name`",
                    b.name()
                ),
            ));
        }
    }
    let Some(b) = bounds else {
        return Ok(());
    };
    if b.names.is_empty() {
        return Err(("bounds.names".into(), "list at least one bound".into()));
    }
    for (k, v) in [("bounds.rho", b.rho), ("bounds.rho_sigmas", b.rho_sigmas)] {
        if !(v.is_finite() && v >= 0.0) {
            return Err((k.into(), format!("must be finite and >= 0, got {v}")));
        }
    }
    let keys = b
        .tracks
        .iter()
        .flatten()
        .enumerate()
        .map(|(i, t)| (format!("bounds.tracks[{i}]"), t))
        .chain(
            b.per_track
                .keys()
                .map(|t| (format!("bounds.per_track.{t}"), t)),
        );
    for (key, t) in keys {
        if t != "theta_bar" && t != "ml" && !names.contains(t) {
            return Err((
                key,
                format!(
                    "no track {t:?}: use theta_bar, ml or a baseline name ({})",
                    names.iter().cloned().collect::<Vec<_>>().join(", ")
                ),
            ));
        }
    }
    if let Some((t, _)) = b.per_track.iter().find(|(_, v)| v.is_empty()) {
        return Err((
            format!("bounds.per_track.{t}"),
            "list at least one bound".into(),
        ));
    }
    Ok(())
}

/// Deep-merge `over` into `base`: tables merge key by key, anything else
/// (values, arrays, arrays of tables) replaces. A table that names a
/// different `model` or `kind` (a noise model, a generator, a motion)
/// replaces the base table whole, so a variant can switch models.
pub fn merge_tables(base: &mut toml::Table, over: &toml::Table) {
    let switches = |b: &toml::Table, o: &toml::Table| {
        ["model", "kind", "rule"]
            .iter()
            .any(|tag| o.get(*tag).is_some_and(|v| b.get(*tag) != Some(v)))
    };
    for (k, v) in over {
        match (base.get_mut(k), v) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) if !switches(b, o) => {
                merge_tables(b, o)
            }
            _ => {
                base.insert(k.clone(), v.clone());
            }
        }
    }
}

fn check_point(path: &Path, key: &str, p: &[f64; 2]) -> Result<Vec2, InputError> {
    if p.iter().all(|x| x.is_finite()) {
        Ok(v2(*p))
    } else {
        Err(InputError::at(
            path,
            key,
            format!("coordinates must be finite, got {p:?}"),
        ))
    }
}

impl Scenario {
    /// Read, parse and validate a scenario file without `[[variants]]`
    /// (a file with variants is an error here: use [`Scenario::load_all`]).
    pub fn load(path: &Path) -> Result<Scenario, InputError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| InputError::file(path, format!("cannot read scenario: {e}")))?;
        Self::from_toml_str(&text, path)
    }

    /// Read, parse and validate a scenario file: one scenario, or one per
    /// `[[variants]]` entry, in file order.
    pub fn load_all(path: &Path) -> Result<Vec<Scenario>, InputError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| InputError::file(path, format!("cannot read scenario: {e}")))?;
        Self::all_from_toml_str(&text, path)
    }

    /// Parse and validate scenario text without variants; `path` names it in
    /// errors and anchors relative file names.
    pub fn from_toml_str(text: &str, path: &Path) -> Result<Scenario, InputError> {
        let file: ScenarioFile = toml::from_str(text).map_err(|e| toml_error(path, text, &e))?;
        if !file.variants.is_empty() {
            let names: Vec<&str> = file.variants.iter().map(|v| v.name.as_str()).collect();
            return Err(InputError::at(
                path,
                "variants",
                format!(
                    "the file has {} variants ({}); load them all, or pick one with --variant",
                    names.len(),
                    names.join(", ")
                ),
            ));
        }
        Self::from_parsed(file, path)
    }

    /// Parse and validate scenario text with any `[[variants]]`: each variant
    /// is the base file with the variant's tables deep-merged over it.
    pub fn all_from_toml_str(text: &str, path: &Path) -> Result<Vec<Scenario>, InputError> {
        let file: ScenarioFile = toml::from_str(text).map_err(|e| toml_error(path, text, &e))?;
        if file.variants.is_empty() {
            return Ok(vec![Self::from_parsed(file, path)?]);
        }
        let mut base: toml::Table = toml::from_str(text).map_err(|e| toml_error(path, text, &e))?;
        base.remove("variants");
        let mut seen = BTreeSet::new();
        let mut out = Vec::with_capacity(file.variants.len());
        for (i, v) in file.variants.iter().enumerate() {
            let key = format!("variants[{i}]");
            let vname = v.name.trim();
            if vname.is_empty()
                || !vname
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
            {
                return Err(InputError::at(
                    path,
                    format!("{key}.name"),
                    format!(
                        "{:?} must be non-empty ASCII letters, digits, '-', '_' or '.'",
                        v.name
                    ),
                ));
            }
            if !seen.insert(vname.to_string()) {
                return Err(InputError::at(
                    path,
                    format!("{key}.name"),
                    format!("duplicate variant name {vname:?}"),
                ));
            }
            let mut t = base.clone();
            merge_tables(&mut t, &v.overrides);
            let f: ScenarioFile =
                toml::Value::Table(t)
                    .try_into()
                    .map_err(|e: toml::de::Error| {
                        InputError::at(
                            path,
                            format!("{key} ({vname})"),
                            e.message().trim().to_string(),
                        )
                    })?;
            let sc = Self::from_parsed(f, path).map_err(|mut e| {
                e.location = Some(match e.location.take() {
                    Some(l) => format!("{key} ({vname}): {l}"),
                    None => format!("{key} ({vname})"),
                });
                e
            })?;
            out.push(Scenario {
                variant: Some(vname.to_string()),
                ..sc
            });
        }
        Ok(out)
    }

    /// Validate a parsed scenario file.
    pub fn from_parsed(file: ScenarioFile, path: &Path) -> Result<Scenario, InputError> {
        let base = path.parent().unwrap_or(Path::new("."));
        if file.name.trim().is_empty() {
            return Err(InputError::at(path, "name", "must not be empty"));
        }
        // Geometry.
        let transmitters = file
            .geometry
            .transmitters
            .iter()
            .enumerate()
            .map(|(i, p)| check_point(path, &format!("geometry.transmitters[{i}]"), p))
            .collect::<Result<Vec<_>, _>>()?;
        let mut receivers = file
            .geometry
            .receivers
            .iter()
            .enumerate()
            .map(|(i, p)| check_point(path, &format!("geometry.receivers[{i}]"), p))
            .collect::<Result<Vec<_>, _>>()?;

        // Network.
        let graph = match (&file.network.edges, &file.network.generator) {
            (Some(_), Some(_)) => {
                return Err(InputError::at(
                    path,
                    "network",
                    "give either `edges` or `generator`, not both",
                ));
            }
            (None, None) => {
                return Err(InputError::at(
                    path,
                    "network",
                    "give `edges` or `generator`",
                ));
            }
            (Some(edges), None) => {
                let e: Vec<(usize, usize)> = edges.iter().map(|e| (e[0], e[1])).collect();
                Graph::new(receivers.len(), &e).map_err(|err| {
                    let key = match &err {
                        crate::model::graph::GraphError::OutOfRange { index, .. }
                        | crate::model::graph::GraphError::SelfLoop { index, .. }
                        | crate::model::graph::GraphError::Duplicate { index, .. } => {
                            format!("network.edges[{index}]")
                        }
                        _ => "network.edges".to_string(),
                    };
                    InputError::at(path, key, err.to_string())
                })?
            }
            (None, Some(generator)) => build_generated(path, generator, &mut receivers)?,
        };
        if receivers.is_empty() {
            return Err(InputError::at(path, "geometry.receivers", "no receivers"));
        }
        let geometry = Geometry {
            transmitters,
            receivers,
        };

        // Measurements config.
        let m = &file.measurements;
        if !(m.omega.is_finite() && m.omega > 0.0) {
            return Err(InputError::at(
                path,
                "measurements.omega",
                format!("must be finite and > 0, got {}", m.omega),
            ));
        }
        if let Some(n) = &m.range_noise {
            n.validate()
                .map_err(|e| InputError::at(path, "measurements.range_noise", e))?;
        }
        if let Some(n) = &m.doa_noise {
            n.validate()
                .map_err(|e| InputError::at(path, "measurements.doa_noise", e))?;
        }
        m.nlos_links
            .validate()
            .map_err(|e| InputError::at(path, "measurements.nlos_links", e))?;
        m.nlos_links
            .draw(
                geometry.transmitters.len(),
                geometry.receivers.len(),
                &mut stream_rng(0, Stream::Links, 0),
            )
            .map_err(|e| InputError::at(path, "measurements.nlos_links", e.to_string()))?;

        // Data source.
        let (source, samples) = match &m.trace {
            Some(trace) => {
                let tpath = base.join(trace);
                let meas = read_trace(&tpath, &geometry)?;
                let truth = match &m.truth {
                    Some(t) => {
                        let p = base.join(t);
                        let tr = read_truth(&p)?;
                        if tr.len() != meas.len() {
                            return Err(InputError::file(
                                &p,
                                format!(
                                    "has {} samples but the trace {} has {}",
                                    tr.len(),
                                    tpath.display(),
                                    meas.len()
                                ),
                            ));
                        }
                        Some(tr)
                    }
                    None => None,
                };
                let samples = meas.len();
                if let Some(t) = &file.target
                    && t.samples > samples
                {
                    return Err(InputError::at(
                        path,
                        "target.samples",
                        format!("asks for {} samples but the trace has {samples}", t.samples),
                    ));
                }
                let samples = file.target.as_ref().map_or(samples, |t| t.samples);
                (
                    DataSource::Trace {
                        path: tpath,
                        measurements: meas,
                        truth,
                    },
                    samples,
                )
            }
            None => {
                if m.truth.is_some() {
                    return Err(InputError::at(
                        path,
                        "measurements.truth",
                        "a truth file only goes with a trace (measurements.trace)",
                    ));
                }
                let Some(t) = &file.target else {
                    return Err(InputError::at(
                        path,
                        "target",
                        "missing: give [target] (samples, motion) or measurements.trace",
                    ));
                };
                t.motion
                    .validate()
                    .map_err(|e| InputError::at(path, "target.motion", e))?;
                if !m.bistatic && !m.doa && !m.range {
                    return Err(InputError::at(
                        path,
                        "measurements",
                        "nothing to measure: enable bistatic, doa or range",
                    ));
                }
                if m.bistatic && geometry.transmitters.is_empty() {
                    return Err(InputError::at(
                        path,
                        "measurements.bistatic",
                        "bistatic ranges need at least one transmitter in geometry.transmitters \
                         (set bistatic = false for a pure TOA/DOA network)",
                    ));
                }
                if (m.bistatic || m.range) && m.range_noise.is_none() {
                    return Err(InputError::at(
                        path,
                        "measurements.range_noise",
                        "missing: ranges are synthesized, so give their noise model",
                    ));
                }
                if m.doa && m.doa_noise.is_none() {
                    return Err(InputError::at(
                        path,
                        "measurements.doa_noise",
                        "missing: DOAs are synthesized, so give their noise model",
                    ));
                }
                (
                    DataSource::Synthetic {
                        motion: t.motion.clone(),
                    },
                    t.samples,
                )
            }
        };
        if samples == 0 {
            return Err(InputError::at(path, "target.samples", "must be at least 1"));
        }

        // Algorithm.
        let a = &file.algorithm;
        if !(a.gamma.is_finite() && a.gamma > 0.0) {
            return Err(InputError::at(
                path,
                "algorithm.gamma",
                format!("must be finite and > 0, got {}", a.gamma),
            ));
        }
        if a.iterations_per_sample == 0 {
            return Err(InputError::at(
                path,
                "algorithm.iterations_per_sample",
                "must be at least 1",
            ));
        }
        if !a.init_u.iter().all(|x| x.is_finite()) {
            return Err(InputError::at(path, "algorithm.init_u", "must be finite"));
        }
        if a.burn_in >= samples {
            return Err(InputError::at(
                path,
                "algorithm.burn_in",
                format!(
                    "must be below the number of samples ({samples}), got {}",
                    a.burn_in
                ),
            ));
        }
        let schedule = match &a.schedule {
            Some(s) => {
                let p = base.join(s);
                Some((p.clone(), read_schedule(&p, &graph)?))
            }
            None => None,
        };
        if let Some(rt) = &file.realtime {
            if !(rt.sample_period_ms.is_finite() && rt.sample_period_ms > 0.0) {
                return Err(InputError::at(
                    path,
                    "realtime.sample_period_ms",
                    "must be finite and > 0",
                ));
            }
            if !(rt.wake_rate_hz.is_finite() && rt.wake_rate_hz > 0.0) {
                return Err(InputError::at(
                    path,
                    "realtime.wake_rate_hz",
                    "must be finite and > 0",
                ));
            }
        }
        // Baselines, bounds, Monte Carlo.
        check_tracks(&file.baselines, file.bounds.as_ref(), &geometry)
            .map_err(|(key, reason)| InputError::at(path, key, reason))?;
        crate::scenario::expect::validate_syntax(&file.expect)
            .map_err(|e| InputError::at(path, "expect.holds", e))?;
        if let Some(mc) = &file.monte_carlo
            && mc.trials == 0
        {
            return Err(InputError::at(
                path,
                "monte_carlo.trials",
                "must be at least 1",
            ));
        }
        let algorithm = Algorithm {
            mode: a.mode,
            gamma: a.gamma,
            iterations_per_sample: a.iterations_per_sample,
            local_solver: a.local_solver,
            kappa: a.kappa,
            init_u: Vec3::new(a.init_u[0], a.init_u[1], a.init_u[2]),
            schedule,
            burn_in: a.burn_in,
        };
        let sc = Scenario {
            path: path.to_path_buf(),
            name: file.name.clone(),
            seed: file.seed,
            geometry,
            graph,
            samples,
            source,
            measurements: file.measurements.clone(),
            algorithm,
            realtime: file.realtime.clone(),
            expect: file.expect.clone(),
            trace_iterations: false,
            baselines: file.baselines.clone(),
            bounds: file.bounds.clone(),
            scoring: file.scoring.clone(),
            trials: file.monte_carlo.as_ref().map(|m| m.trials),
            variant: None,
            file,
        };
        sc.check_schedule_length()?;
        sc.check_kappa()?;
        Ok(sc)
    }

    /// The nominal number of rows of node `id`'s local cost (seed 002 eq. 9): one per
    /// bistatic range, two per DOA, one per one-way range. Synthetic data: what the
    /// measurements config synthesizes; a trace: the most the node has at any sample.
    pub fn nominal_rows(&self, id: usize) -> usize {
        let rows = |m: &NodeMeasurements| {
            m.bistatic.len() + 2 * usize::from(m.doa.is_some()) + usize::from(m.range.is_some())
        };
        match &self.source {
            DataSource::Trace { measurements, .. } => measurements
                .iter()
                .filter_map(|s| s.nodes.get(id).map(rows))
                .max()
                .unwrap_or(0),
            DataSource::Synthetic { .. } => {
                let m = &self.measurements;
                let n_tx = if m.bistatic {
                    self.geometry.transmitters.len()
                } else {
                    0
                };
                n_tx + 2 * usize::from(m.doa) + usize::from(m.range)
            }
        }
    }

    /// With `gtrs_l0`, `algorithm.kappa` must be below the nominal row count
    /// ([`Scenario::nominal_rows`]) of every node that has any row (a node without
    /// measurements runs the plain prox anyway). Samples with fewer rows are clamped at
    /// run time ([`crate::estimators::prox::l0::effective_kappa`]).
    pub fn check_kappa(&self) -> Result<(), InputError> {
        if self.algorithm.local_solver != LocalSolver::GtrsL0 {
            return Ok(());
        }
        let kappa = self.algorithm.kappa;
        for id in 0..self.geometry.receivers.len() {
            let rows = self.nominal_rows(id);
            if rows > 0 && kappa >= rows {
                return Err(InputError::at(
                    &self.path,
                    "algorithm.kappa",
                    format!(
                        "must be below the number of rows of every node's local cost with \
                         local_solver = \"gtrs_l0\" (node {id} has {rows}), got {kappa}"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Total DR iterations of a run.
    pub fn total_iterations(&self) -> usize {
        self.samples * self.algorithm.iterations_per_sample
    }

    fn check_schedule_length(&self) -> Result<(), InputError> {
        if let (Mode::Async, Some((p, s))) = (self.algorithm.mode, &self.algorithm.schedule) {
            let need = self.total_iterations();
            if s.len() < need {
                return Err(InputError::file(
                    p,
                    format!(
                        "has {} iterations but the run needs {need} ({} samples x {} iterations)",
                        s.len(),
                        self.samples,
                        self.algorithm.iterations_per_sample
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Replace the baselines (`--baselines`); names must be unique.
    pub fn with_baselines(
        mut self,
        baselines: Vec<crate::estimators::baselines::BaselineCfg>,
    ) -> Result<Self, InputError> {
        check_tracks(&baselines, self.bounds.as_ref(), &self.geometry)
            .map_err(|(key, reason)| cli_error("--baselines", format!("{key}: {reason}")))?;
        self.baselines = baselines;
        Ok(self)
    }

    /// Run `n` Monte Carlo trials (`--trials`; `None` or 1 is a single run).
    pub fn with_trials(mut self, n: Option<usize>) -> Result<Self, InputError> {
        if n == Some(0) {
            return Err(cli_error("--trials", "must be at least 1"));
        }
        if n.is_some() {
            self.trials = n;
        }
        Ok(self)
    }

    /// Override the run seed.
    pub fn with_seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Record every node's `theta` after every iteration into `iterations.csv`.
    pub fn with_trace_iterations(mut self, on: bool) -> Self {
        self.trace_iterations = on;
        self
    }

    /// Override the gossip mode.
    pub fn with_mode(mut self, mode: Mode) -> Result<Self, InputError> {
        self.algorithm.mode = mode;
        self.check_schedule_length()?;
        Ok(self)
    }

    /// Override the local solver (see [`Scenario::check_kappa`] for `gtrs_l0`).
    pub fn with_local_solver(mut self, s: LocalSolver) -> Self {
        self.algorithm.local_solver = s;
        self
    }

    /// Override the `gtrs_l0` outlier budget `algorithm.kappa` (checked by
    /// [`Scenario::check_kappa`]).
    pub fn with_kappa(mut self, kappa: usize) -> Self {
        self.algorithm.kappa = kappa;
        self
    }

    /// Override the iterations per sample (must be >= 1).
    pub fn with_iterations_per_sample(mut self, n: usize) -> Result<Self, InputError> {
        if n == 0 {
            return Err(cli_error("--iterations-per-sample", "must be at least 1"));
        }
        self.algorithm.iterations_per_sample = n;
        self.check_schedule_length()?;
        Ok(self)
    }

    /// Override the number of samples (at most the trace length for traces).
    pub fn with_samples(mut self, n: usize) -> Result<Self, InputError> {
        if n == 0 {
            return Err(cli_error("--samples", "must be at least 1"));
        }
        if let DataSource::Trace { measurements, .. } = &self.source
            && n > measurements.len()
        {
            return Err(cli_error(
                "--samples",
                format!(
                    "the trace has only {} samples, asked for {n}",
                    measurements.len()
                ),
            ));
        }
        if self.algorithm.burn_in >= n {
            return Err(cli_error(
                "--samples",
                format!("must exceed algorithm.burn_in = {}", self.algorithm.burn_in),
            ));
        }
        self.samples = n;
        self.check_schedule_length()?;
        Ok(self)
    }

    /// Nominal noise sigmas at sample `k`.
    pub fn sigmas_at(&self, k: usize) -> Sigmas {
        let m = &self.measurements;
        Sigmas {
            range: m.range_noise.as_ref().map_or(1.0, |n| n.sigma_at(k)),
            doa: m.doa_noise.as_ref().map_or(0.1, |n| n.sigma_at(k)),
        }
    }

    /// The truth and measurements of a run with this scenario's seed
    /// (`self.seed`, the one run seed): synthesized for synthetic scenarios,
    /// read from the trace otherwise.
    pub fn realize(&self) -> Realization {
        let seed = self.seed;
        let sigmas = (0..self.samples).map(|k| self.sigmas_at(k)).collect();
        match &self.source {
            DataSource::Trace {
                measurements,
                truth,
                ..
            } => Realization {
                truth: truth.as_ref().map(|t| t[..self.samples].to_vec()),
                measurements: measurements[..self.samples].to_vec(),
                sigmas,
                nlos: crate::model::noise::NlosMask::all_los(
                    self.geometry.transmitters.len(),
                    self.geometry.receivers.len(),
                ),
            },
            DataSource::Synthetic { motion } => {
                let truth = motion.track(self.samples, &mut stream_rng(seed, Stream::Motion, 0));
                let (n_tx, n_rx) = (
                    self.geometry.transmitters.len(),
                    self.geometry.receivers.len(),
                );
                // Validated at load time, so a draw error cannot happen here;
                // fall back to all-LOS rather than panic.
                let nlos = self
                    .measurements
                    .nlos_links
                    .draw(n_tx, n_rx, &mut stream_rng(seed, Stream::Links, 0))
                    .unwrap_or_else(|_| crate::model::noise::NlosMask::all_los(n_tx, n_rx));
                let measurements = crate::model::synth::synthesize(
                    &self.geometry,
                    &truth,
                    &self.measurements,
                    &nlos,
                    seed,
                );
                Realization {
                    truth: Some(truth),
                    measurements,
                    sigmas,
                    nlos,
                }
            }
        }
    }
}

fn cli_error(flag: &str, reason: impl Into<String>) -> InputError {
    InputError::at(Path::new("<command line>"), flag, reason)
}

fn toml_error(path: &Path, text: &str, e: &toml::de::Error) -> InputError {
    let location = e.span().map(|span| {
        let line = text[..span.start.min(text.len())].matches('\n').count() + 1;
        format!("line {line}")
    });
    InputError {
        file: path.to_path_buf(),
        location,
        reason: e.message().to_string(),
    }
}

fn build_generated(
    path: &Path,
    generator: &GeneratorCfg,
    receivers: &mut Vec<Vec2>,
) -> Result<Graph, InputError> {
    let key = "network.generator";
    let wrap = |e: crate::model::graph::GraphError| InputError::at(path, key, e.to_string());
    match generator {
        GeneratorCfg::Ring => {
            Graph::new(receivers.len(), &Graph::ring_edges(receivers.len())).map_err(wrap)
        }
        GeneratorCfg::Grid { rows, cols } => {
            if rows * cols != receivers.len() {
                return Err(InputError::at(
                    path,
                    key,
                    format!(
                        "grid {rows} x {cols} = {} nodes but there are {} receivers",
                        rows * cols,
                        receivers.len()
                    ),
                ));
            }
            Graph::new(receivers.len(), &Graph::grid_edges(*rows, *cols)).map_err(wrap)
        }
        GeneratorCfg::RandomGeometric {
            radius,
            seed,
            count,
            min,
            max,
        } => {
            if !(radius.is_finite() && *radius > 0.0) {
                return Err(InputError::at(
                    path,
                    "network.generator.radius",
                    "must be finite and > 0",
                ));
            }
            match (count, min, max) {
                (None, None, None) => {
                    if receivers.is_empty() {
                        return Err(InputError::at(
                            path,
                            key,
                            "no geometry.receivers: give count, min and max to draw them",
                        ));
                    }
                    Graph::new(receivers.len(), &Graph::geometric_edges(receivers, *radius))
                        .map_err(|e| {
                            InputError::at(path, key, format!("{e} (radius {radius} is too small)"))
                        })
                }
                (Some(count), Some(lo), Some(hi)) => {
                    if !receivers.is_empty() {
                        return Err(InputError::at(
                            path,
                            key,
                            "count/min/max draw the receivers, so geometry.receivers must be empty",
                        ));
                    }
                    let lo = check_point(path, "network.generator.min", lo)?;
                    let hi = check_point(path, "network.generator.max", hi)?;
                    if lo.x >= hi.x || lo.y >= hi.y {
                        return Err(InputError::at(
                            path,
                            key,
                            "min must be below max in x and y",
                        ));
                    }
                    let mut last_err = None;
                    for attempt in 0..1000u64 {
                        let mut rng: SonarRng = stream_rng(*seed, Stream::Graph, attempt);
                        let pts: Vec<Vec2> = (0..*count)
                            .map(|_| {
                                Vec2::new(
                                    rng.random_range(lo.x..hi.x),
                                    rng.random_range(lo.y..hi.y),
                                )
                            })
                            .collect();
                        match Graph::new(*count, &Graph::geometric_edges(&pts, *radius)) {
                            Ok(g) => {
                                *receivers = pts;
                                return Ok(g);
                            }
                            Err(e) => last_err = Some(e),
                        }
                    }
                    Err(InputError::at(
                        path,
                        key,
                        format!(
                            "no connected layout in 1000 draws (last: {}); increase radius",
                            last_err.map(|e| e.to_string()).unwrap_or_default()
                        ),
                    ))
                }
                _ => Err(InputError::at(
                    path,
                    key,
                    "give all of count, min and max (to draw receivers) or none of them",
                )),
            }
        }
    }
}

#[derive(Debug, Deserialize)]
struct TraceRow {
    sample: usize,
    receiver: usize,
    transmitter: Option<usize>,
    kind: String,
    value: f64,
}

fn csv_reader(path: &Path, header: &[&str]) -> Result<csv::Reader<std::fs::File>, InputError> {
    let f = std::fs::File::open(path)
        .map_err(|e| InputError::file(path, format!("cannot open: {e}")))?;
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .from_reader(f);
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

fn row_line(rec: &csv::StringRecord) -> String {
    rec.position()
        .map_or("line ?".into(), |p| format!("line {}", p.line()))
}

/// Read a measurement trace (`sample,receiver,transmitter,kind,value`).
pub fn read_trace(path: &Path, geometry: &Geometry) -> Result<Vec<SampleMeasurements>, InputError> {
    let mut rdr = csv_reader(
        path,
        &["sample", "receiver", "transmitter", "kind", "value"],
    )?;
    let n = geometry.receivers.len();
    let m = geometry.transmitters.len();
    let mut out: Vec<SampleMeasurements> = Vec::new();
    let mut seen = BTreeSet::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| {
            let loc = e
                .position()
                .map_or("line ?".into(), |p| format!("line {}", p.line()));
            InputError::at(path, loc, e.to_string())
        })?;
        let line = row_line(&rec);
        let row: TraceRow = trim_record(&rec, 5)
            .deserialize(None)
            .map_err(|e| InputError::at(path, &line, format!("bad row: {e}")))?;
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
            "doa" | "range" => {
                if row.transmitter.is_some() {
                    return Err(InputError::at(
                        path,
                        &line,
                        format!("transmitter must be empty for kind {}", row.kind),
                    ));
                }
                if row.kind == "doa" {
                    node.doa = Some(row.value);
                } else {
                    node.range = Some(row.value);
                }
            }
            other => {
                return Err(InputError::at(
                    path,
                    &line,
                    format!("unknown kind `{other}` (expected bistatic_range, doa or range)"),
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

/// Read a truth file (`sample,x,y`, samples 0..S-1 in order).
pub fn read_truth(path: &Path) -> Result<Vec<Vec2>, InputError> {
    let mut rdr = csv_reader(path, &["sample", "x", "y"])?;
    let mut out = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| InputError::file(path, e.to_string()))?;
        let line = row_line(&rec);
        let (k, x, y): (usize, f64, f64) = trim_record(&rec, 3)
            .deserialize(None)
            .map_err(|e| InputError::at(path, &line, format!("bad row: {e}")))?;
        if k != out.len() {
            return Err(InputError::at(
                path,
                &line,
                format!("expected sample {}, got {k}", out.len()),
            ));
        }
        if !(x.is_finite() && y.is_finite()) {
            return Err(InputError::at(path, &line, "x and y must be finite"));
        }
        out.push(Vec2::new(x, y));
    }
    Ok(out)
}

/// Read an async schedule (`iteration,v,w`, iterations 0.. in order, every
/// `(v, w)` an edge of `graph`).
pub fn read_schedule(path: &Path, graph: &Graph) -> Result<Vec<(usize, usize)>, InputError> {
    let mut rdr = csv_reader(path, &["iteration", "v", "w"])?;
    let mut out = Vec::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| InputError::file(path, e.to_string()))?;
        let line = row_line(&rec);
        let (it, v, w): (usize, usize, usize) = trim_record(&rec, 3)
            .deserialize(None)
            .map_err(|e| InputError::at(path, &line, format!("bad row: {e}")))?;
        if it != out.len() {
            return Err(InputError::at(
                path,
                &line,
                format!("expected iteration {}, got {it}", out.len()),
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
