//! The scenario file as written ([`ScenarioFile`] and its tables), parsed by
//! serde with `deny_unknown_fields` at every level. Every key is documented in
//! `scenarios/README.md`; [`super::Scenario::from_parsed`] checks the values.

use super::*;

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
