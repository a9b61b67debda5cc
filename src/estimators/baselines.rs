//! Centralised baselines scored side by side with the distributed track.
//!
//! A scenario's `[[baselines]]` list (or `sonarnet run --baselines a,b`)
//! names estimators that the coordinator runs on **all** receivers'
//! measurements of every sample (a fusion centre), next to the distributed
//! Douglas-Rachford estimate `theta_bar`:
//!
//! | `kind` | estimator | source |
//! |---|---|---|
//! | `ogd` | online gradient descent, one step of `f_t` per sample | Pun-So 2022 eq. (3), Pun-So 2020 eq. (2) |
//! | `onm` | online Newton method (damped when the Hessian is not PD) | Pun-So 2022 Sec. V |
//! | `ml` | per-sample ML (Levenberg-Marquardt, warm start) | [`crate::estimators::central`] |
//! | `ls` | nonlinear least squares of the bistatic ranges | Shi 2024 eq. (3) |
//! | `l0os` | l0-norm outlier separation | Shi 2024 Algorithm 1 |
//! | `lq_irls` | `l_q` loss by IRLS, `1 < q < 2` | Shi 2024 eq. (4) |
//! | `lad` | `l_1` loss by IRLS | Shi 2024 eq. (4), `q = 1` |
//! | `pocs` | projection onto the farthest disc/ellipse | Gholami 2015 eq. (18) |
//! | `lls` | closed-form linear least squares ([`online::ols_position`], the OLS initialisation) | Pun-So 2022 eq. (15)-(17), Gholami 2015 Sec. 4 |
//! | `distributed` | the in-process DR engine with another local solver / mode | Mourya 2017 eq. (11) |
//!
//! Every estimator is the library's one implementation ([`crate::estimators::online`],
//! [`crate::estimators::robust`], [`crate::estimators::bounds`], [`crate::estimators::central`],
//! [`crate::engine`]). A baseline is an adapter: its configuration builds a
//! solver of the one problem/solver seam, [`crate::estimators::track`] (whose
//! `with_*` builders validate the parameters), and [`run_track`] drives it
//! along the samples; `ml` reuses the reference track and `distributed` runs
//! the engine. A step that fails (degenerate geometry, an empty set) leaves
//! the sample's estimate empty (online trackers keep their previous estimate)
//! and is counted in [`TrackRun::failures`]; nothing produces a NaN.

use crate::estimators::gossip::Mode;
use crate::estimators::online::{self, NewtonDamping, StepSize};
use crate::estimators::prox::LocalSolver;
use crate::estimators::robust;
use crate::estimators::track::{
    LlsSolver, OnlineRule, OnlineSolver, PocsSolver, RobustMethod, RobustSolver, SampleSolver,
    SdpSolver, Sparsity, TrackProblem, TrackRun, run_track,
};
use crate::model::error::KeyError;
use crate::model::geometry::Point;
use crate::model::measure::Geometry;
use crate::model::synth::Realization;
use serde::{Deserialize, Serialize};
use std::time::Instant;

fn default_ogd_step() -> StepSize {
    StepSize::Lipschitz { scale: 1.0 }
}
fn default_q() -> f64 {
    1.5
}
fn default_pocs_iter() -> usize {
    1000
}
fn default_pocs_tol() -> f64 {
    1e-9
}

/// One `[[baselines]]` entry. `name` defaults to the kind; names must be
/// unique within a scenario and are the column prefix in `track.csv`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum BaselineCfg {
    /// Online gradient descent (Pun-So 2022 eq. (3)).
    Ogd {
        /// Track name (default `ogd`).
        #[serde(default)]
        name: Option<String>,
        /// Step rule: `{ rule = "lipschitz", scale = 1 }` (default: `1/L_t`,
        /// the local Lipschitz constant of `grad f_t`, stable at any
        /// scale), `{ rule = "constant", eta = 0.1 }` (Pun-So 2022) or
        /// `{ rule = "inv_sqrt", eta0 = 1 }` (Pun-So 2020).
        #[serde(default = "default_ogd_step")]
        step: StepSize,
        /// `exact` (true first position, default) or `ols` (Pun-So 2022 eq. (15)-(17)).
        #[serde(default)]
        init: online::Init,
    },
    /// Online Newton method (Pun-So 2022 Sec. V).
    Onm {
        /// Track name (default `onm`).
        #[serde(default)]
        name: Option<String>,
        /// `exact` (default) or `ols`.
        #[serde(default)]
        init: online::Init,
        /// What to do with a Hessian that is not safely PD (default: eigenvalue
        /// modification, see [`NewtonDamping`]).
        #[serde(default)]
        damping: Option<NewtonDamping>,
    },
    /// Per-sample centralised ML estimate (the same as the `ml` reference).
    Ml {
        /// Track name (default `ml_baseline`; `ml` is the reference's name).
        #[serde(default)]
        name: Option<String>,
    },
    /// Nonlinear least squares on the bistatic ranges (Shi 2024 eq. (3)).
    Ls {
        /// Track name (default `ls`).
        #[serde(default)]
        name: Option<String>,
    },
    /// l0-norm outlier separation (Shi 2024 Algorithm 1).
    L0os {
        /// Track name (default `l0os`).
        #[serde(default)]
        name: Option<String>,
        /// Outlier fraction `p`: `kappa = round(p m n)` (Shi 2024 Sec. IV-A).
        #[serde(default)]
        p: Option<f64>,
        /// Or the sparsity `kappa` directly.
        #[serde(default)]
        kappa: Option<usize>,
    },
    /// `l_q` IRLS (Shi 2024 eq. (4)).
    LqIrls {
        /// Track name (default `lq_irls`).
        #[serde(default)]
        name: Option<String>,
        /// Exponent in `(1, 2)` (default 1.5).
        #[serde(default = "default_q")]
        q: f64,
    },
    /// Least absolute deviations by IRLS (`q = 1`).
    Lad {
        /// Track name (default `lad`).
        #[serde(default)]
        name: Option<String>,
    },
    /// POCS onto the farthest disc or ellipse (Gholami 2015 eq. (18)), started
    /// from the previous sample's estimate (the first from the sensors' centroid).
    Pocs {
        /// Track name (default `pocs`).
        #[serde(default)]
        name: Option<String>,
        /// Maximum number of projections per sample (default 1000).
        #[serde(default = "default_pocs_iter")]
        max_iter: usize,
        /// Feasibility tolerance in metres (default 1e-9).
        #[serde(default = "default_pocs_tol")]
        tol: f64,
    },
    /// Closed-form linear least squares, [`online::ols_position`]: one-way
    /// ranges by Pun-So 2022 eq. (15)-(17), else the lifted bistatic system.
    Lls {
        /// Track name (default `lls`).
        #[serde(default)]
        name: Option<String>,
    },
    /// The SDP relaxation estimate of Biswas et al. 2006, as Gholami 2015
    /// Sec. 4 compares it ([`crate::estimators::bounds::sdp_toa`]): one-way
    /// ranges only (at least three per sample).
    Sdp {
        /// Track name (default `sdp`).
        #[serde(default)]
        name: Option<String>,
    },
    /// The distributed DR engine run again in-process with other settings,
    /// e.g. `local_solver = "gtrs"` next to a `gtrs_l0` main track.
    Distributed {
        /// Track name (default `dr_<local_solver>`).
        #[serde(default)]
        name: Option<String>,
        /// Local solver (default: the scenario's).
        #[serde(default)]
        local_solver: Option<LocalSolver>,
        /// Gossip mode (default: the scenario's).
        #[serde(default)]
        mode: Option<Mode>,
        /// Iterations per sample (default: the scenario's).
        #[serde(default)]
        iterations_per_sample: Option<usize>,
    },
}

/// Kinds accepted by `--baselines` (with default parameters).
pub const KINDS: &[&str] = &[
    "ogd",
    "onm",
    "ml",
    "ls",
    "l0os",
    "lq_irls",
    "lad",
    "pocs",
    "lls",
    "sdp",
    "distributed",
];

/// Names a baseline may not take (they are other columns of `track.csv`).
const RESERVED: &[&str] = &["true", "est", "ml", "theta_bar", "bound", "sample", "seed"];

impl BaselineCfg {
    /// The baseline of `kind` with default parameters (for `--baselines`).
    pub fn default_of(kind: &str) -> Option<BaselineCfg> {
        let text = format!("kind = \"{kind}\"");
        toml::from_str(&text).ok()
    }

    /// The kind, as written in files.
    pub fn kind(&self) -> &'static str {
        match self {
            BaselineCfg::Ogd { .. } => "ogd",
            BaselineCfg::Onm { .. } => "onm",
            BaselineCfg::Ml { .. } => "ml",
            BaselineCfg::Ls { .. } => "ls",
            BaselineCfg::L0os { .. } => "l0os",
            BaselineCfg::LqIrls { .. } => "lq_irls",
            BaselineCfg::Lad { .. } => "lad",
            BaselineCfg::Pocs { .. } => "pocs",
            BaselineCfg::Lls { .. } => "lls",
            BaselineCfg::Sdp { .. } => "sdp",
            BaselineCfg::Distributed { .. } => "distributed",
        }
    }

    /// The track name (column prefix in `track.csv`, key in `metrics.json`).
    pub fn name(&self) -> String {
        let given = match self {
            BaselineCfg::Ogd { name, .. }
            | BaselineCfg::Onm { name, .. }
            | BaselineCfg::Ml { name }
            | BaselineCfg::Ls { name }
            | BaselineCfg::L0os { name, .. }
            | BaselineCfg::LqIrls { name, .. }
            | BaselineCfg::Lad { name }
            | BaselineCfg::Pocs { name, .. }
            | BaselineCfg::Lls { name }
            | BaselineCfg::Sdp { name }
            | BaselineCfg::Distributed { name, .. } => name.clone(),
        };
        given.unwrap_or_else(|| match self {
            BaselineCfg::Ml { .. } => "ml_baseline".into(),
            BaselineCfg::Distributed { local_solver, .. } => {
                format!("dr_{}", local_solver.map_or("same", LocalSolver::as_str))
            }
            other => other.kind().into(),
        })
    }

    /// Check the parameters against the scenario geometry (`has_bistatic`
    /// says whether bistatic ranges exist): the first problem's key (under
    /// the baseline's table) and reason.
    pub fn validate<const D: usize>(
        &self,
        geometry: &Geometry<D>,
        has_bistatic: bool,
    ) -> Result<(), KeyError> {
        let name = self.name();
        if name.is_empty()
            || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            || name.starts_with(|c: char| c.is_ascii_digit())
        {
            return Err(KeyError::new(
                "name",
                format!("{name:?} must be ASCII letters, digits or '_', not starting with a digit"),
            ));
        }
        if RESERVED.contains(&name.as_str()) || name.starts_with("bound_") {
            return Err(KeyError::new(
                "name",
                format!("{name:?} is reserved for another track.csv column"),
            ));
        }
        let has_links = matches!(
            self,
            BaselineCfg::Ls { .. }
                | BaselineCfg::Lad { .. }
                | BaselineCfg::L0os { .. }
                | BaselineCfg::LqIrls { .. }
        );
        if has_links && !has_bistatic {
            return Err(KeyError::new(
                "kind",
                format!(
                    "{} uses bistatic ranges only, and this scenario has none",
                    self.kind()
                ),
            ));
        }
        match self {
            BaselineCfg::L0os { p, kappa, .. } => {
                let n_links = geometry.transmitters.len() * geometry.receivers.len();
                let k = match (p, kappa) {
                    (Some(_), Some(_)) => {
                        return Err(KeyError::new("p", "give `p` or `kappa`, not both"));
                    }
                    (None, None) => {
                        return Err(KeyError::new(
                            "p",
                            "give the outlier fraction `p` or `kappa`",
                        ));
                    }
                    (Some(p), None) => robust::kappa_from_fraction(*p, n_links)
                        .map_err(|e| KeyError::new("p", e.to_string()))?,
                    (None, Some(k)) => *k,
                };
                if k >= n_links {
                    return Err(KeyError::new(
                        "kappa",
                        format!("{k} must be below the number of links ({n_links})"),
                    ));
                }
            }
            BaselineCfg::Distributed {
                iterations_per_sample: Some(0),
                ..
            } => {
                return Err(KeyError::new("iterations_per_sample", "must be at least 1"));
            }
            _ => {}
        }
        // The solvers' builders check their own parameters.
        self.plan::<D>().map(|_| ())
    }

    /// How this baseline is computed: a solver of the seam
    /// ([`crate::estimators::track`]) built from the parameters (which its
    /// builders validate), the ML reference track, or a run of the engine.
    fn plan<const D: usize>(&self) -> Result<Plan<D>, KeyError> {
        let robust =
            |m| -> Result<Plan<D>, KeyError> { Ok(Plan::Solver(Box::new(RobustSolver::new(m)?))) };
        match self {
            BaselineCfg::Ogd { step, init, .. } => Ok(Plan::Solver(Box::new(
                OnlineSolver::new(OnlineRule::Ogd(*step))?.with_init(*init),
            ))),
            BaselineCfg::Onm { damping, init, .. } => Ok(Plan::Solver(Box::new(
                OnlineSolver::new(OnlineRule::Onm(damping.unwrap_or_default()))?.with_init(*init),
            ))),
            BaselineCfg::Ml { .. } => Ok(Plan::Reference),
            BaselineCfg::Ls { .. } => robust(RobustMethod::Ls),
            BaselineCfg::Lad { .. } => robust(RobustMethod::Lad),
            BaselineCfg::LqIrls { q, .. } => robust(RobustMethod::LqIrls(*q)),
            BaselineCfg::L0os { p, kappa, .. } => robust(RobustMethod::L0os(match (p, kappa) {
                (_, Some(k)) => Sparsity::Kappa(*k),
                (Some(p), None) => Sparsity::Fraction(*p),
                (None, None) => Sparsity::Kappa(0),
            })),
            BaselineCfg::Pocs { max_iter, tol, .. } => Ok(Plan::Solver(Box::new(
                PocsSolver::default()
                    .with_max_iter(*max_iter)?
                    .with_tol(*tol)?,
            ))),
            BaselineCfg::Lls { .. } => Ok(Plan::Solver(Box::new(LlsSolver))),
            BaselineCfg::Sdp { .. } => Ok(Plan::Solver(Box::new(SdpSolver))),
            BaselineCfg::Distributed {
                local_solver,
                mode,
                iterations_per_sample,
                ..
            } => Ok(Plan::Engine(DistributedRun {
                local_solver: *local_solver,
                mode: *mode,
                iterations_per_sample: *iterations_per_sample,
            })),
        }
    }
}

/// How one baseline is computed ([`BaselineCfg::plan`]).
enum Plan<const D: usize> {
    /// A sequential solver, driven by [`run_track`].
    Solver(Box<dyn SampleSolver<D>>),
    /// The centralised ML reference track, already solved.
    Reference,
    /// The Douglas-Rachford engine with other settings.
    Engine(DistributedRun),
}

/// The estimate of one baseline at every sample, and what it cost.
#[derive(Debug, Clone, PartialEq)]
pub struct BaselineTrack<const D: usize = 2> {
    /// Track name.
    pub name: String,
    /// The kind (`ogd`, `l0os`, ...).
    pub kind: &'static str,
    /// The estimates, failures and cost as [`run_track`] records them
    /// (`est[k]` is `None` where the estimator failed; online trackers keep
    /// their previous estimate).
    pub run: TrackRun<D>,
}

/// What the `distributed` baseline changes in the scenario's own run (each
/// `None` keeps the scenario's value).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DistributedRun {
    /// Local solver.
    pub local_solver: Option<LocalSolver>,
    /// Gossip mode.
    pub mode: Option<Mode>,
    /// Iterations per sample.
    pub iterations_per_sample: Option<usize>,
}

/// The `distributed` baseline's run of the Douglas-Rachford engine with
/// these changes over the first `samples` samples: `theta_bar` per sample
/// (`None` past a failure) and the failure, if any. The run pipeline, which
/// sits above the engine, supplies it ([`crate::pipeline::evaluate`]).
pub type EngineRun<'a, const D: usize = 2> =
    &'a dyn Fn(DistributedRun, usize) -> (Vec<Option<Point<D>>>, Option<String>);

/// Run one baseline over the first `samples` samples of a realization.
/// `ml` is the centralised ML reference track of those samples and the
/// seconds it took (the `ml` baseline reuses it instead of solving again);
/// `engine` runs the DR engine for the `distributed` kind.
pub fn run_baseline<const D: usize>(
    cfg: &BaselineCfg,
    geometry: &Geometry<D>,
    real: &Realization<D>,
    samples: usize,
    ml: (&[Point<D>], f64),
    engine: EngineRun<'_, D>,
) -> BaselineTrack<D> {
    let mut run = TrackRun::default();
    if samples > 0 {
        match cfg.plan::<D>() {
            Ok(Plan::Solver(mut solver)) => {
                let problem = TrackProblem {
                    geometry,
                    samples: &real.measurements[..samples],
                    truth0: real.truth.as_ref().and_then(|t| t.first().copied()),
                };
                run = run_track(&problem, solver.as_mut());
            }
            Ok(Plan::Reference) => {
                run.step_seconds = ml.1;
                run.est = ml.0.iter().take(samples).map(|x| Some(*x)).collect();
            }
            Ok(Plan::Engine(changes)) => {
                let start = Instant::now();
                let (est, failure) = engine(changes, samples);
                run.step_seconds = start.elapsed().as_secs_f64();
                if let Some(e) = failure {
                    run.fail(e);
                }
                run.est = est;
            }
            // The scenario's validation refuses what gets here; stay total.
            Err(e) => {
                run.fail(e.to_string());
                run.failures = samples;
                run.est = vec![None; samples];
            }
        }
    }
    BaselineTrack {
        name: cfg.name(),
        kind: cfg.kind(),
        run,
    }
}
