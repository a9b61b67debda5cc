//! The scenario file as written ([`ScenarioFile`] and its tables), parsed by
//! serde with `deny_unknown_fields` at every level. Every key is documented in
//! the scenario reference (`docs/src/scenarios.md`); [`super::Scenario::from_parsed`] checks the values.

use crate::estimators::gossip::Mode;
use crate::estimators::prox::LocalSolver;
use crate::model::motion::Motion;
use crate::model::synth::MeasurementsCfg;
use crate::scenario::expect::ExpectCfg;
use serde::Deserialize;
use serde::Serialize;

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
    /// The network between the nodes (`[channel]`; ideal by default).
    #[serde(default, skip_serializing_if = "is_ideal")]
    pub channel: crate::model::channel::ChannelCfg,
    /// Faults as a schedule (`[[faults]]`, [`crate::model::fault`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub faults: Vec<crate::model::fault::FaultSpec>,
    /// Random faults drawn from the run seed (`[nemesis]`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub nemesis: Option<crate::model::fault::NemesisCfg>,
    /// Thresholds the scenario tests assert.
    #[serde(default)]
    pub expect: ExpectCfg,
    /// Centralised baselines scored next to the distributed track (`[[baselines]]`).
    #[serde(default)]
    pub baselines: Vec<crate::estimators::baselines::BaselineCfg>,
    /// Certified error bounds attached to the tracks (`[bounds]`, Gholami 2015).
    #[serde(default)]
    pub bounds: Option<BoundsCfg>,
    /// What the scoring computes (`[scoring]`).
    #[serde(default)]
    pub scoring: ScoringCfg,
    /// Repeat the run over seeds `seed..seed+trials` (`[monte_carlo]`).
    #[serde(default)]
    pub monte_carlo: Option<MonteCarloCfg>,
    /// Which host runs which node over zenoh (`[deploy] hosts = { a = [0, 1],
    /// b = [2, 3] }`, the scenario reference (`docs/src/scenarios.md`)); only `--transport zenoh` reads it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub deploy: Option<crate::scenario::deploy::Placement>,
    /// Named variants of this scenario (`[[variants]]`): each is a table of
    /// overrides deep-merged into the file (see the scenario reference (`docs/src/scenarios.md`)).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub variants: Vec<VariantCfg>,
}

fn is_ideal(c: &crate::model::channel::ChannelCfg) -> bool {
    *c == crate::model::channel::ChannelCfg::Ideal {}
}

/// `algorithm.clock`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ClockCfg {
    /// The coordinator sequences the iterations.
    Logical,
    /// Free-running nodes on Poisson clocks.
    Realtime,
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

/// A certified bound of Gholami 2015.
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
    /// The exact worst-case error in 2-D (beyond the paper,
    /// [`crate::estimators::bounds::exact`]).
    UppExact,
}

impl BoundKind {
    /// The name used in files (`upp_maxdis`, ...).
    pub fn as_str(self) -> &'static str {
        match self {
            BoundKind::UppRbbox => "upp_rbbox",
            BoundKind::UppBbox => "upp_bbox",
            BoundKind::UppMinball => "upp_minball",
            BoundKind::UppMaxdis => "upp_maxdis",
            BoundKind::UppExact => "upp_exact",
        }
    }
}

/// `[bounds]`: which certified bounds to attach, to which tracks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundsCfg {
    /// The bounds to compute at every sample.
    pub names: Vec<BoundKind>,
    /// Enlargement `rho` (metres) of every measured range (Gholami 2015 Remark 4):
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
    /// Transmitter positions `t_m` (metres), `[x, y]` or `[x, y, z]`.
    #[serde(default, with = "crate::model::xy::list")]
    pub transmitters: Vec<crate::model::xy::Pt>,
    /// Receiver positions `r_n`; may be omitted when `network.generator` is
    /// `random_geometric` with `count` (receivers are then drawn). Their
    /// dimension is the scenario's: 2-D if they are `[x, y]`, 3-D if they
    /// are `[x, y, z]`.
    #[serde(default, with = "crate::model::xy::list")]
    pub receivers: Vec<crate::model::xy::Pt>,
    /// Receivers that move (`[[geometry.drift]]`): a velocity, or waypoints
    /// and a speed, per receiver ([`crate::model::drift`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub drift: Vec<crate::model::drift::DriftCfg>,
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
    Ring {},
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
        min: Option<crate::model::xy::Pt>,
        /// Upper corner of the layout box.
        #[serde(default)]
        max: Option<crate::model::xy::Pt>,
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
    /// separation, Shi 2024 eq. 7).
    #[serde(default = "default_solver")]
    pub local_solver: LocalSolver,
    /// `gtrs_l0` only: how many rows of each node's cost may be outliers. Must be
    /// below the number of rows of every node that has measurements.
    #[serde(default = "default_kappa")]
    pub kappa: usize,
    /// How each node scales its prox: `none` (Mourya 2017 eq. 11, default) or
    /// `inverse_probability` (eq. 5, step `gamma / p_v`).
    #[serde(default)]
    pub prox_scaling: crate::estimators::gossip::ProxScaling,
    /// Where the nodes start: `init_u` (default) or `first_fix`, each node's
    /// own least-squares fix of the first sample.
    #[serde(default)]
    pub init: InitMode,
    /// `none` (Mourya 2017 eq. 9, default) or `noise`: each row of the local
    /// cost divided by its noise standard deviation.
    #[serde(default)]
    pub row_weights: RowWeights,
    /// Initial `u`: one `[x, y, d]` for every node, or one per node
    /// (`[[x, y, d], ...]`, one entry per receiver). Ignored with `first_fix`.
    #[serde(default)]
    pub init_u: InitU,
    /// Replay this async schedule (CSV `iteration,v,w`) instead of drawing one.
    #[serde(default)]
    pub schedule: Option<String>,
    /// The clock this scenario runs on unless `--clock` says otherwise:
    /// `logical` (the default, or `realtime` on the acoustic channel) or
    /// `realtime` (async, with a `[realtime]` table).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clock: Option<ClockCfg>,
    /// Samples excluded from the `*_after_burn_in` metrics.
    #[serde(default)]
    pub burn_in: usize,
}

/// `algorithm.init`: where every node's `u` starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InitMode {
    /// From `algorithm.init_u` (default).
    #[default]
    InitU,
    /// From the node's own fix of its first sample, as a deployed node would
    /// start: the relaxed least-squares solution of its rows of Mourya 2017
    /// eq. (9) where it has at least 3 rows, else the transmitters' centroid
    /// ([`crate::estimators::local::LocalProblem::first_fix`]).
    FirstFix,
}

/// `algorithm.row_weights`: how the rows of each node's cost are weighted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RowWeights {
    /// Unweighted, Mourya 2017 eq. (9) (default).
    #[default]
    None,
    /// Each row divided by its first-order noise standard deviation
    /// ([`crate::estimators::local::LocalProblem::build_weighted`]).
    Noise,
}

/// `algorithm.init_u`: one initial `u` for every node, or one per node.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(untagged)]
pub enum InitU {
    /// `[x, y, d]` (3-D: `[x, y, z, d]`) for every node.
    One(Vec<f64>),
    /// `[[x, y, d], ...]`, one per node in node order.
    PerNode(Vec<Vec<f64>>),
}

impl Default for InitU {
    /// Zeros in the scenario's dimension (an empty list reads as zeros).
    fn default() -> Self {
        InitU::One(Vec::new())
    }
}

/// One entry of `init_u`: a number (of the one `[x, y, d]`) or a node's
/// `[x, y, d]`.
enum InitItem {
    Num(f64),
    Triple(Vec<f64>),
}

impl<'de> Deserialize<'de> for InitItem {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = InitItem;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a number or an [x, y, d] array")
            }
            fn visit_f64<E>(self, v: f64) -> Result<InitItem, E> {
                Ok(InitItem::Num(v))
            }
            fn visit_i64<E>(self, v: i64) -> Result<InitItem, E> {
                Ok(InitItem::Num(v as f64))
            }
            fn visit_u64<E>(self, v: u64) -> Result<InitItem, E> {
                Ok(InitItem::Num(v as f64))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut a: A,
            ) -> Result<InitItem, A::Error> {
                let mut v = Vec::new();
                while let Some(x) = a.next_element::<f64>()? {
                    v.push(x);
                }
                Ok(InitItem::Triple(v))
            }
        }
        d.deserialize_any(V)
    }
}

impl<'de> Deserialize<'de> for InitU {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        use serde::de::Error;
        const EXPECTED: &str = "[x, y, d] for every node, or [[x, y, d], ...] with one per node \
                                (in 3-D [x, y, z, d])";
        let items = Vec::<InitItem>::deserialize(d)?;
        let nums: Option<Vec<f64>> = items
            .iter()
            .map(|i| match i {
                InitItem::Num(x) => Some(*x),
                InitItem::Triple(_) => None,
            })
            .collect();
        if let Some(n) = nums {
            return match n.len() {
                3 | 4 => Ok(InitU::One(n)),
                len => Err(D::Error::custom(format!(
                    "{len} numbers: expected {EXPECTED}"
                ))),
            };
        }
        items
            .into_iter()
            .enumerate()
            .map(|(k, i)| match i {
                InitItem::Triple(t) if matches!(t.len(), 3 | 4) => Ok(t),
                InitItem::Triple(t) => Err(D::Error::custom(format!(
                    "entry {k} has {} numbers: expected {EXPECTED}",
                    t.len()
                ))),
                InitItem::Num(_) => Err(D::Error::custom(format!(
                    "entry {k} is a number among [x, y, d] arrays: expected {EXPECTED}"
                ))),
            })
            .collect::<Result<Vec<_>, _>>()
            .map(InitU::PerNode)
    }
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
