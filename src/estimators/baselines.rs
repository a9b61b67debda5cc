//! Centralised baselines scored side by side with the distributed track.
//!
//! A scenario's `[[baselines]]` list (or `sonarnet run --baselines a,b`)
//! names estimators that the coordinator runs on **all** receivers'
//! measurements of every sample (a fusion centre), next to the distributed
//! Douglas-Rachford estimate `theta_bar`:
//!
//! | `kind` | estimator | source |
//! |---|---|---|
//! | `ogd` | online gradient descent, one step of `f_t` per sample | seed 000 eq. (3), seed 001 eq. (2) |
//! | `onm` | online Newton method (damped when the Hessian is not PD) | seed 000 Sec. V |
//! | `ml` | per-sample ML (Levenberg-Marquardt, warm start) | [`crate::estimators::central`] |
//! | `ls` | nonlinear least squares of the bistatic ranges | seed 004 eq. (3) |
//! | `l0os` | l0-norm outlier separation | seed 004 Algorithm 1 |
//! | `lq_irls` | `l_q` loss by IRLS, `1 < q < 2` | seed 004 eq. (4) |
//! | `lad` | `l_1` loss by IRLS | seed 004 eq. (4), `q = 1` |
//! | `pocs` | projection onto the farthest disc/ellipse | seed 003 eq. (18) |
//! | `lls` | closed-form linear least squares ([`online::ols_position`], the OLS initialisation) | seed 000 eq. (15)-(17), seed 003 Sec. 4 |
//! | `distributed` | the in-process DR engine with another local solver / mode | seed 002 eq. (11) |
//!
//! Every estimator is the library's one implementation ([`crate::estimators::online`],
//! [`crate::estimators::robust`], [`crate::estimators::bounds`], [`crate::estimators::central`],
//! [`crate::engine`]); this module only adapts them to a track. A step that
//! fails (degenerate geometry, an empty set) leaves the sample's estimate
//! empty (online trackers keep their previous estimate) and is counted in
//! [`BaselineTrack::failures`]; nothing produces a NaN.

use crate::estimators::bounds::{self, Region};
use crate::estimators::gossip::Mode;
use crate::estimators::online::{self, NewtonDamping, StepSize, Tracker};
use crate::estimators::prox::LocalSolver;
use crate::estimators::robust;
use crate::model::geometry::Vec2;
use crate::model::measure::{Geometry, SampleMeasurements};
use crate::model::synth::Realization;
use serde::{Deserialize, Serialize};
use std::time::Instant;

fn default_ogd_step() -> StepSize {
    StepSize::Constant { eta: 0.1 }
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
    /// Online gradient descent (seed 000 eq. (3)).
    Ogd {
        /// Track name (default `ogd`).
        #[serde(default)]
        name: Option<String>,
        /// Step rule: `{ rule = "constant", eta = 0.1 }` (default) or
        /// `{ rule = "inv_sqrt", eta0 = 1 }` (seed 001).
        #[serde(default = "default_ogd_step")]
        step: StepSize,
        /// `exact` (true first position, default) or `ols` (seed 000 eq. (15)-(17)).
        #[serde(default)]
        init: online::Init,
    },
    /// Online Newton method (seed 000 Sec. V).
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
    /// Nonlinear least squares on the bistatic ranges (seed 004 eq. (3)).
    Ls {
        /// Track name (default `ls`).
        #[serde(default)]
        name: Option<String>,
    },
    /// l0-norm outlier separation (seed 004 Algorithm 1).
    L0os {
        /// Track name (default `l0os`).
        #[serde(default)]
        name: Option<String>,
        /// Outlier fraction `p`: `kappa = round(p m n)` (seed 004 Sec. IV-A).
        #[serde(default)]
        p: Option<f64>,
        /// Or the sparsity `kappa` directly.
        #[serde(default)]
        kappa: Option<usize>,
    },
    /// `l_q` IRLS (seed 004 eq. (4)).
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
    /// POCS onto the farthest disc or ellipse (seed 003 eq. (18)), started
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
    /// ranges by seed 000 eq. (15)-(17), else the lifted bistatic system.
    Lls {
        /// Track name (default `lls`).
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

/// The file name of a local solver (`gtrs`, `relaxed`, ...).
pub fn solver_name(s: LocalSolver) -> String {
    serde_json::to_value(s)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_else(|| format!("{s:?}").to_lowercase())
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
            | BaselineCfg::Distributed { name, .. } => name.clone(),
        };
        given.unwrap_or_else(|| match self {
            BaselineCfg::Ml { .. } => "ml_baseline".into(),
            BaselineCfg::Distributed { local_solver, .. } => format!(
                "dr_{}",
                local_solver.map_or("same".to_string(), solver_name)
            ),
            other => other.kind().into(),
        })
    }

    /// True for the stateful online trackers (their regret is also reported
    /// in seed 001's prediction form, `regret_pred`).
    pub fn is_online(&self) -> bool {
        matches!(self, BaselineCfg::Ogd { .. } | BaselineCfg::Onm { .. })
    }

    /// Check the parameters against the scenario geometry (`what` says which
    /// measurements exist). Returns the reason of the first problem.
    pub fn validate(&self, geometry: &Geometry, has_bistatic: bool) -> Result<(), String> {
        let name = self.name();
        if name.is_empty()
            || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            || name.starts_with(|c: char| c.is_ascii_digit())
        {
            return Err(format!(
                "name {name:?} must be ASCII letters, digits or '_', not starting with a digit"
            ));
        }
        if RESERVED.contains(&name.as_str()) || name.starts_with("bound_") {
            return Err(format!(
                "name {name:?} is reserved for another track.csv column"
            ));
        }
        match self {
            // The trackers' own constructors validate their parameters.
            BaselineCfg::Ogd { step, .. } => online::OgdTracker::new(Vec2::zeros(), *step)
                .map(|_| ())
                .map_err(|e| format!("step: {e}")),
            BaselineCfg::Onm {
                damping: Some(d), ..
            } => online::OnmTracker::new(Vec2::zeros(), *d)
                .map(|_| ())
                .map_err(|e| format!("damping: {e}")),
            BaselineCfg::Ls { .. }
            | BaselineCfg::Lad { .. }
            | BaselineCfg::L0os { .. }
            | BaselineCfg::LqIrls { .. }
                if !has_bistatic =>
            {
                Err(format!(
                    "{} uses bistatic ranges only, and this scenario has none",
                    self.kind()
                ))
            }
            BaselineCfg::L0os { p, kappa, .. } => {
                let n_links = geometry.transmitters.len() * geometry.receivers.len();
                let k = match (p, kappa) {
                    (Some(_), Some(_)) => return Err("give `p` or `kappa`, not both".into()),
                    (None, None) => return Err("give the outlier fraction `p` or `kappa`".into()),
                    (Some(p), None) => {
                        robust::kappa_from_fraction(*p, n_links).map_err(|e| e.to_string())?
                    }
                    (None, Some(k)) => *k,
                };
                if k >= n_links {
                    return Err(format!(
                        "kappa = {k} must be below the number of links ({n_links})"
                    ));
                }
                Ok(())
            }
            BaselineCfg::LqIrls { q, .. } => {
                if *q > 1.0 && *q < 2.0 {
                    Ok(())
                } else {
                    Err(format!("q must be in (1, 2), got {q}"))
                }
            }
            BaselineCfg::Pocs { max_iter, tol, .. } => {
                if *max_iter == 0 {
                    return Err("max_iter must be at least 1".into());
                }
                if tol.is_finite() && *tol >= 0.0 {
                    Ok(())
                } else {
                    Err(format!("tol must be finite and >= 0, got {tol}"))
                }
            }
            BaselineCfg::Distributed {
                iterations_per_sample: Some(0),
                ..
            } => Err("iterations_per_sample must be at least 1".into()),
            _ => Ok(()),
        }
    }
}

/// The estimate of one baseline at every sample, and what it cost.
#[derive(Debug, Clone, PartialEq)]
pub struct BaselineTrack {
    /// Track name.
    pub name: String,
    /// The kind (`ogd`, `l0os`, ...).
    pub kind: &'static str,
    /// Estimate per sample (`None` where the estimator failed).
    pub est: Vec<Option<Vec2>>,
    /// For online trackers: the estimate *before* each sample (seed 001's
    /// `x_t` in `f_t(x_t)`, eq. (2)), i.e. the previous estimate or `x_0`.
    pub before: Option<Vec<Vec2>>,
    /// Samples whose step failed, and the first reason.
    pub failures: usize,
    /// The first failure's message.
    pub first_failure: Option<String>,
    /// Wall time of all steps (seconds); `step_seconds / samples` is the
    /// per-step CPU time of the tracker (single-threaded).
    pub step_seconds: f64,
    /// POCS only: samples whose iteration ended feasible.
    pub feasible: Option<usize>,
}

impl BaselineTrack {
    /// Count a failed step; the first reason is kept.
    fn fail(&mut self, why: String) {
        self.failures += 1;
        if self.first_failure.is_none() {
            self.first_failure = Some(why);
        }
    }
}

/// One-way and bistatic range sets of a sample as discs and ellipses,
/// enlarged by `rho` (seed 003 Remark 4): the feasible set of the bounds and
/// of POCS. DOAs are not used.
pub fn regions_of(geometry: &Geometry, sample: &SampleMeasurements, rho: f64) -> Vec<Region> {
    let mut out = Vec::new();
    for (n, node) in sample.nodes.iter().enumerate() {
        let Some(&r) = geometry.receivers.get(n) else {
            continue;
        };
        if let Some(range) = node.range {
            out.push(Region::from_range(r, range, rho));
        }
        for &(m, rho_m) in &node.bistatic {
            if let Some(&t) = geometry.transmitters.get(m) {
                out.push(Region::from_bistatic(t, r, rho_m, rho));
            }
        }
    }
    out
}

fn centroid(geometry: &Geometry) -> Vec2 {
    let all: Vec<&Vec2> = geometry
        .receivers
        .iter()
        .chain(&geometry.transmitters)
        .collect();
    all.iter().fold(Vec2::zeros(), |s, p| s + **p) / all.len().max(1) as f64
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
pub type EngineRun<'a> = &'a dyn Fn(DistributedRun, usize) -> (Vec<Option<Vec2>>, Option<String>);

/// Run one baseline over the first `samples` samples of a realization.
/// `ml` is the centralised ML reference track of those samples and the
/// seconds it took (the `ml` baseline reuses it instead of solving again);
/// `engine` runs the DR engine for the `distributed` kind.
pub fn run_baseline(
    cfg: &BaselineCfg,
    geometry: &Geometry,
    real: &Realization,
    samples: usize,
    ml: (&[Vec2], f64),
    engine: EngineRun<'_>,
) -> BaselineTrack {
    let meas = &real.measurements[..samples];
    let mut track = BaselineTrack {
        name: cfg.name(),
        kind: cfg.kind(),
        est: Vec::with_capacity(samples),
        before: None,
        failures: 0,
        first_failure: None,
        step_seconds: 0.0,
        feasible: None,
    };
    if samples == 0 {
        return track;
    }
    match cfg {
        BaselineCfg::Ogd { init, step, .. } => {
            online_track(&mut track, geometry, real, meas, *init, |x0| {
                online::OgdTracker::new(x0, *step)
                    .map(|t| Box::new(t) as Box<dyn Tracker>)
                    .map_err(|e| e.to_string())
            })
        }
        BaselineCfg::Onm { init, damping, .. } => {
            online_track(&mut track, geometry, real, meas, *init, |x0| {
                online::OnmTracker::new(x0, damping.unwrap_or_default())
                    .map(|t| Box::new(t) as Box<dyn Tracker>)
                    .map_err(|e| e.to_string())
            })
        }
        BaselineCfg::Ml { .. } => {
            track.step_seconds = ml.1;
            track.est = ml.0.iter().take(samples).map(|x| Some(*x)).collect();
        }
        BaselineCfg::Ls { .. } => robust_track(&mut track, meas, |links| {
            robust::ls(geometry, links, &Default::default())
        }),
        BaselineCfg::Lad { .. } => robust_track(&mut track, meas, |links| {
            robust::lad(geometry, links, &Default::default())
        }),
        BaselineCfg::LqIrls { q, .. } => robust_track(&mut track, meas, |links| {
            let cfg = robust::IrlsConfig {
                q: *q,
                ..Default::default()
            };
            robust::lq_irls(geometry, links, &cfg)
        }),
        BaselineCfg::L0os { p, kappa, .. } => {
            let n_links = geometry.transmitters.len() * geometry.receivers.len();
            robust_track(&mut track, meas, |links| {
                let k = match (p, kappa) {
                    (_, Some(k)) => Ok(*k),
                    // kappa scales with the links actually present.
                    (Some(p), None) => robust::kappa_from_fraction(*p, links.len().min(n_links)),
                    (None, None) => Ok(0),
                };
                k.and_then(|k| robust::l0os(geometry, links, &robust::L0osConfig::new(k)))
            })
        }
        BaselineCfg::Pocs { max_iter, tol, .. } => {
            let mut x = centroid(geometry);
            let mut feasible = 0;
            for (k, s) in meas.iter().enumerate() {
                let regions = regions_of(geometry, s, 0.0);
                let start = Instant::now();
                let r = bounds::pocs(&regions, x, *max_iter, *tol);
                track.step_seconds += start.elapsed().as_secs_f64();
                match r {
                    Ok(p) => {
                        feasible += usize::from(p.feasible);
                        x = p.x;
                        track.est.push(Some(p.x));
                    }
                    Err(e) => {
                        track.fail(format!("sample {k}: {e}"));
                        track.est.push(None);
                    }
                }
            }
            track.feasible = Some(feasible);
        }
        BaselineCfg::Lls { .. } => {
            for (k, s) in meas.iter().enumerate() {
                let start = Instant::now();
                let r = online::ols_position(geometry, s).map_err(|e| e.to_string());
                track.step_seconds += start.elapsed().as_secs_f64();
                match r {
                    Ok(x) => track.est.push(Some(x)),
                    Err(e) => {
                        track.fail(format!("sample {k}: {e}"));
                        track.est.push(None);
                    }
                }
            }
        }
        BaselineCfg::Distributed {
            local_solver,
            mode,
            iterations_per_sample,
            ..
        } => {
            let changes = DistributedRun {
                local_solver: *local_solver,
                mode: *mode,
                iterations_per_sample: *iterations_per_sample,
            };
            let start = Instant::now();
            let (est, failure) = engine(changes, samples);
            track.step_seconds = start.elapsed().as_secs_f64();
            if let Some(e) = failure {
                track.fail(e);
            }
            track.est = est;
        }
    }
    track
}

/// An online tracker of seeds 000/001 along the samples: `x_0` from `init`
/// (the exact start needs the truth), one step per sample, the estimate
/// before each step kept for the dynamic regret. `make` builds the tracker.
fn online_track(
    track: &mut BaselineTrack,
    geometry: &Geometry,
    real: &Realization,
    meas: &[SampleMeasurements],
    init: online::Init,
    make: impl FnOnce(Vec2) -> Result<Box<dyn Tracker>, String>,
) {
    let samples = meas.len();
    let start = Instant::now();
    let truth0 = real.truth.as_ref().and_then(|t| t.first().copied());
    let x0 = match (init, truth0) {
        (online::Init::Exact, None) => Err(
            "init = \"exact\" needs the true first position (no truth): use init = \"ols\""
                .to_string(),
        ),
        (_, t0) => init
            .initial_estimate(geometry, &meas[0], t0.unwrap_or_else(Vec2::zeros))
            .map_err(|e| format!("initialisation: {e}")),
    };
    let mut tracker = match x0.and_then(make) {
        Ok(t) => t,
        Err(e) => {
            track.fail(e);
            track.failures = samples;
            track.est = vec![None; samples];
            return;
        }
    };
    let mut before = Vec::with_capacity(samples);
    for (k, s) in meas.iter().enumerate() {
        before.push(tracker.estimate());
        match tracker.step(geometry, s, k + 1) {
            Ok(x) => track.est.push(Some(x)),
            Err(e) => {
                track.fail(format!("sample {k}: {e}"));
                track.est.push(Some(tracker.estimate()));
            }
        }
    }
    track.before = Some(before);
    track.step_seconds = start.elapsed().as_secs_f64();
}

/// A per-sample robust estimator of seed 004 on each sample's bistatic
/// links; `solve` is the estimator (timed alone).
fn robust_track(
    track: &mut BaselineTrack,
    meas: &[SampleMeasurements],
    solve: impl Fn(&[robust::BistaticLink]) -> Result<robust::Estimate, robust::RobustError>,
) {
    for (k, s) in meas.iter().enumerate() {
        let links = robust::links_from_sample(s);
        let start = Instant::now();
        let r = solve(&links);
        track.step_seconds += start.elapsed().as_secs_f64();
        match r {
            Ok(e) => track.est.push(Some(e.position)),
            Err(e) => {
                track.fail(format!("sample {k}: {e}"));
                track.est.push(None);
            }
        }
    }
}
