//! The estimators' one seam, after argmin's problem/solver split: a
//! [`TrackProblem`] (the geometry, the samples' measurements and, where known,
//! the true first position) and a [`SampleSolver`] that estimates the target
//! position one sample at a time, carrying whatever state it needs from one
//! sample to the next. [`run_track`] is the executor: it drives any solver
//! along the samples, times it, and records its failures the same way for
//! every estimator.
//!
//! The solvers of the centralised baselines ([`crate::estimators::baselines`])
//! are adapters over the library's estimators: the online trackers of
//! Pun-So 2022 and 2020 ([`OnlineSolver`]), the robust estimators of Shi 2024
//! ([`RobustSolver`]), POCS of Gholami 2015 ([`PocsSolver`]) and the closed-form
//! linear least squares ([`LlsSolver`]). Each is configured with validated
//! `with_*` builders, so a bad parameter is refused where it enters.

use crate::estimators::bounds::{self, Region};
use crate::estimators::online::{self, NewtonDamping, StepSize, Tracker};
use crate::estimators::robust;
use crate::model::error::KeyError;
use crate::model::geometry::Point;
use crate::model::measure::{Geometry, SampleMeasurements};
use std::time::Instant;

/// Why a solver has no estimate: the underlying estimator's own error,
/// kept as the source.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SolveError {
    /// `init = "exact"` without the true first position.
    #[error("init = \"exact\" needs the true first position (no truth): use init = \"ols\"")]
    NoTruth,
    /// The online tracker's `x_0` could not be computed.
    #[error("initialisation: {0}")]
    Init(#[source] online::TrackError),
    /// `solve` before a successful `start`.
    #[error("the tracker was not started")]
    NotStarted,
    /// An online tracker or the linear least squares failed.
    #[error(transparent)]
    Online(#[from] online::TrackError),
    /// A robust estimator of Shi 2024 failed.
    #[error(transparent)]
    Robust(#[from] robust::RobustError),
    /// POCS or the SDP estimate failed.
    #[error(transparent)]
    Bound(#[from] bounds::BoundError),
    /// Too few one-way ranges for the SDP estimate.
    #[error("the SDP estimate needs at least 3 one-way ranges, got {0}")]
    TooFewRanges(usize),
}

fn refuse(key: &'static str, reason: impl Into<String>) -> KeyError {
    KeyError::new(key, reason)
}

/// The estimation problem of a track: every sample's measurements in one
/// geometry (each sample solved at its own positions, [`Geometry::at`], when
/// receivers drift), and the true first position when a truth file gives it (the
/// trackers' exact initialisation, Pun-So 2022 Sec. V, needs it).
#[derive(Debug, Clone, Copy)]
pub struct TrackProblem<'a, const D: usize = 2> {
    /// Sensor positions.
    pub geometry: &'a Geometry<D>,
    /// The measurements of each sample, in order.
    pub samples: &'a [SampleMeasurements],
    /// The true position at the first sample, if known.
    pub truth0: Option<Point<D>>,
}

/// A sequential position estimator: one [`SampleSolver::solve`] per sample.
///
/// The contract [`run_track`] relies on: `start` is called once before the
/// first sample; `solve` returns a finite estimate or the reason it has none;
/// after a failed `solve` the track records [`SampleSolver::on_failure`].
pub trait SampleSolver<const D: usize = 2> {
    /// Prepare the track (e.g. choose `x_0`). An error here leaves every
    /// sample without an estimate.
    fn start(&mut self, _problem: &TrackProblem<'_, D>) -> Result<(), SolveError> {
        Ok(())
    }
    /// The estimate held before the next `solve`, for estimators that carry
    /// one (Pun-So 2020's `x_t` in `f_t(x_t)`, eq. (2)); `None` otherwise.
    fn prior(&self) -> Option<Point<D>> {
        None
    }
    /// Estimate sample `k` (0-based).
    fn solve(
        &mut self,
        geometry: &Geometry<D>,
        sample: &SampleMeasurements,
        k: usize,
    ) -> Result<Point<D>, SolveError>;
    /// What the track holds where `solve` failed: nothing by default; an
    /// online tracker keeps its previous estimate.
    fn on_failure(&self) -> Option<Point<D>> {
        None
    }
    /// Samples whose solve ended feasible, for estimators that report it (POCS).
    fn feasible(&self) -> Option<usize> {
        None
    }
}

/// What [`run_track`] records of a solver's run.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TrackRun<const D: usize = 2> {
    /// Estimate per sample (`None` where the solver has none).
    pub est: Vec<Option<Point<D>>>,
    /// [`SampleSolver::prior`] before each sample, when the solver has one.
    pub before: Option<Vec<Point<D>>>,
    /// Samples without a fresh estimate (all of them if `start` failed).
    pub failures: usize,
    /// The first failure's message.
    pub first_failure: Option<String>,
    /// Wall time of `start` and every `solve` (seconds, single-threaded).
    pub step_seconds: f64,
    /// [`SampleSolver::feasible`] at the end.
    pub feasible: Option<usize>,
}

impl<const D: usize> TrackRun<D> {
    /// Count a failure; the first reason is kept.
    pub fn fail(&mut self, why: String) {
        self.failures += 1;
        if self.first_failure.is_none() {
            self.first_failure = Some(why);
        }
    }
}

/// The scene of a track: the bounding box of the sensors (and the first
/// true position). An estimate is *exploding* when it is not finite or lies
/// more than [`Scene::EXPLODED`] scene diameters from the box's centre;
/// [`run_track`] counts it as a failure (a finite one stays the track's
/// estimate; a non-finite one is replaced as a solver failure is).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scene<const D: usize = 2> {
    /// Centre of the bounding box.
    pub center: Point<D>,
    /// Its diagonal (at least 1 m).
    pub diameter: f64,
}

impl<const D: usize> Scene<D> {
    /// How many diameters from the centre an estimate may lie.
    pub const EXPLODED: f64 = 100.0;

    /// The scene of `geometry` (and `truth0`).
    pub fn of(geometry: &Geometry<D>, truth0: Option<Point<D>>) -> Scene<D> {
        let pts = geometry
            .transmitters
            .iter()
            .chain(&geometry.receivers)
            .copied()
            .chain(truth0)
            .filter(|p| p.iter().all(|v| v.is_finite()));
        let (mut lo, mut hi) = (
            Point::<D>::repeat(f64::INFINITY),
            Point::<D>::repeat(f64::NEG_INFINITY),
        );
        for p in pts {
            lo = lo.inf(&p);
            hi = hi.sup(&p);
        }
        if !lo[0].is_finite() {
            return Scene {
                center: Point::<D>::zeros(),
                diameter: 1.0,
            };
        }
        Scene {
            center: (lo + hi) / 2.0,
            diameter: (hi - lo).norm().max(1.0),
        }
    }

    /// Whether `x` is a sane estimate (finite, within the limit).
    pub fn holds(&self, x: &Point<D>) -> bool {
        x.iter().all(|v| v.is_finite())
            && (x - self.center).norm() <= Self::EXPLODED * self.diameter
    }
}

/// Drive `solver` along every sample of `problem` (the executor of the seam).
pub fn run_track<const D: usize>(
    problem: &TrackProblem<'_, D>,
    solver: &mut dyn SampleSolver<D>,
) -> TrackRun<D> {
    let n = problem.samples.len();
    let mut run = TrackRun {
        est: Vec::with_capacity(n),
        ..TrackRun::default()
    };
    if n == 0 {
        return run;
    }
    let start = Instant::now();
    let started = solver.start(problem);
    run.step_seconds += start.elapsed().as_secs_f64();
    if let Err(e) = started {
        run.fail(e.to_string());
        run.failures = n;
        run.est = vec![None; n];
        return run;
    }
    let scene = Scene::of(problem.geometry, problem.truth0);
    let mut before = Vec::with_capacity(n);
    for (k, s) in problem.samples.iter().enumerate() {
        if let Some(x) = solver.prior() {
            before.push(x);
        }
        let start = Instant::now();
        let r = solver.solve(&problem.geometry.at(k), s, k);
        run.step_seconds += start.elapsed().as_secs_f64();
        match r {
            Ok(x) if scene.holds(&x) => run.est.push(Some(x)),
            Ok(x) if x.iter().all(|v| v.is_finite()) => {
                // Exploded: a failure, the estimate kept as made (its error
                // is the track's; plots clip it, tables print it in
                // engineering notation).
                let at: Vec<String> = x.iter().map(|v| format!("{v:.3e}")).collect();
                run.fail(format!(
                    "sample {k}: the estimate exploded to ({}), beyond {} scene diameters",
                    at.join(", "),
                    Scene::<D>::EXPLODED
                ));
                run.est.push(Some(x));
            }
            Ok(_) => {
                run.fail(format!("sample {k}: a non-finite estimate"));
                run.est.push(solver.on_failure());
            }
            Err(e) => {
                run.fail(format!("sample {k}: {e}"));
                run.est.push(solver.on_failure());
            }
        }
    }
    run.before = (before.len() == n).then_some(before);
    run.feasible = solver.feasible();
    run
}

/// Which online tracker of Pun-So 2022 an [`OnlineSolver`] runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OnlineRule {
    /// Online gradient descent (Pun-So 2022 eq. (3)) with this step rule.
    Ogd(StepSize),
    /// Online Newton method (Pun-So 2022 Sec. V) with this damping.
    Onm(NewtonDamping),
}

/// An online tracker of Pun-So 2022 and 2020 as a [`SampleSolver`]: `x_0` from its
/// [`online::Init`], then one update per sample, keeping its estimate where a
/// step fails.
pub struct OnlineSolver<const D: usize = 2> {
    rule: OnlineRule,
    init: online::Init,
    tracker: Option<Box<dyn Tracker<D>>>,
}

impl<const D: usize> OnlineSolver<D> {
    /// A tracker with the given rule, validated here (exact initialisation).
    pub fn new(rule: OnlineRule) -> Result<Self, KeyError> {
        match rule {
            OnlineRule::Ogd(step) => online::OgdTracker::<D>::new(Point::<D>::zeros(), step)
                .map(|_| ())
                .map_err(|e| refuse("step", e.to_string()))?,
            OnlineRule::Onm(d) => online::OnmTracker::<D>::new(Point::<D>::zeros(), d)
                .map(|_| ())
                .map_err(|e| refuse("damping", e.to_string()))?,
        }
        Ok(OnlineSolver {
            rule,
            init: online::Init::default(),
            tracker: None,
        })
    }

    /// How `x_0` is chosen (Pun-So 2022 Sec. V).
    pub fn with_init(mut self, init: online::Init) -> Self {
        self.init = init;
        self
    }
}

impl<const D: usize> SampleSolver<D> for OnlineSolver<D> {
    fn start(&mut self, problem: &TrackProblem<'_, D>) -> Result<(), SolveError> {
        let x0 = match (self.init, problem.truth0) {
            (online::Init::Exact, None) => {
                return Err(SolveError::NoTruth);
            }
            (init, t0) => init
                .initial_estimate(
                    problem.geometry,
                    &problem.samples[0],
                    t0.unwrap_or_else(Point::<D>::zeros),
                )
                .map_err(SolveError::Init)?,
        };
        let tracker: Box<dyn Tracker<D>> = match self.rule {
            OnlineRule::Ogd(step) => Box::new(online::OgdTracker::new(x0, step)?),
            OnlineRule::Onm(d) => Box::new(online::OnmTracker::new(x0, d)?),
        };
        self.tracker = Some(tracker);
        Ok(())
    }

    fn prior(&self) -> Option<Point<D>> {
        self.tracker.as_ref().map(|t| t.estimate())
    }

    fn solve(
        &mut self,
        geometry: &Geometry<D>,
        sample: &SampleMeasurements,
        k: usize,
    ) -> Result<Point<D>, SolveError> {
        let t = self.tracker.as_mut().ok_or(SolveError::NotStarted)?;
        Ok(t.step(geometry, sample, k + 1)?)
    }

    fn on_failure(&self) -> Option<Point<D>> {
        self.prior()
    }
}

/// Which estimator of Shi 2024 a [`RobustSolver`] runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RobustMethod {
    /// Nonlinear least squares (eq. (3)).
    Ls,
    /// Least absolute deviations by IRLS (eq. (4), `q = 1`).
    Lad,
    /// `l_q` IRLS (eq. (4)) with this exponent.
    LqIrls(f64),
    /// l0-norm outlier separation (Algorithm 1) with this sparsity.
    L0os(Sparsity),
}

/// The sparsity `kappa` of l0-OS: given, or from an outlier fraction of the
/// links each sample has (Shi 2024 Sec. IV-A).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sparsity {
    /// `kappa` itself.
    Kappa(usize),
    /// `kappa = round(p L)` over the `L` links present in a sample.
    Fraction(f64),
}

/// A robust one-sample estimator of Shi 2024 on each sample's bistatic links.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobustSolver {
    method: RobustMethod,
}

impl RobustSolver {
    /// The estimator, its parameters validated (`q` in `(1, 2)`, `p` in `[0, 1]`).
    pub fn new(method: RobustMethod) -> Result<Self, KeyError> {
        match method {
            RobustMethod::LqIrls(q) if !(q > 1.0 && q < 2.0) => {
                return Err(refuse("q", format!("must be in (1, 2), got {q}")));
            }
            RobustMethod::L0os(Sparsity::Fraction(p)) => {
                robust::kappa_from_fraction(p, 0).map_err(|e| match e {
                    robust::RobustError::InvalidConfig { key, reason } => refuse(key, reason),
                    other => refuse("p", other.to_string()),
                })?;
            }
            _ => {}
        }
        Ok(RobustSolver { method })
    }
}

impl<const D: usize> SampleSolver<D> for RobustSolver {
    fn solve(
        &mut self,
        geometry: &Geometry<D>,
        sample: &SampleMeasurements,
        _k: usize,
    ) -> Result<Point<D>, SolveError> {
        let links = robust::links_from_sample(sample);
        let r = match self.method {
            RobustMethod::Ls => robust::ls(geometry, &links, &Default::default()),
            RobustMethod::Lad => robust::lad(geometry, &links, &Default::default()),
            RobustMethod::LqIrls(q) => {
                let cfg = robust::IrlsConfig {
                    q,
                    ..Default::default()
                };
                robust::lq_irls(geometry, &links, &cfg)
            }
            RobustMethod::L0os(sparsity) => {
                let n_links = geometry.transmitters.len() * geometry.receivers.len();
                let k = match sparsity {
                    Sparsity::Kappa(k) => Ok(k),
                    Sparsity::Fraction(p) => {
                        robust::kappa_from_fraction(p, links.len().min(n_links))
                    }
                };
                k.and_then(|k| robust::l0os(geometry, &links, &robust::L0osConfig::new(k)))
            }
        };
        Ok(r.map(|e| e.position)?)
    }
}

/// One-way and bistatic range sets of a sample as discs and ellipses,
/// enlarged by `rho` (Gholami 2015 Remark 4): the feasible set of the bounds and
/// of POCS (balls and spheroids in 3-D). DOAs are not used.
pub fn regions_of<const D: usize>(
    geometry: &Geometry<D>,
    sample: &SampleMeasurements,
    rho: f64,
) -> Vec<Region<D>> {
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

/// POCS onto the farthest disc or ellipse (Gholami 2015 eq. (18)), each sample
/// started from the previous estimate (the first from the sensors' centroid).
#[derive(Debug, Clone, PartialEq)]
pub struct PocsSolver<const D: usize = 2> {
    max_iter: usize,
    tol: f64,
    x: Point<D>,
    feasible: usize,
}

impl<const D: usize> Default for PocsSolver<D> {
    fn default() -> Self {
        PocsSolver {
            max_iter: 1000,
            tol: 1e-9,
            x: Point::<D>::zeros(),
            feasible: 0,
        }
    }
}

impl<const D: usize> PocsSolver<D> {
    /// At most `max_iter >= 1` projections per sample (default 1000).
    pub fn with_max_iter(mut self, max_iter: usize) -> Result<Self, KeyError> {
        if max_iter == 0 {
            return Err(refuse("max_iter", "must be at least 1"));
        }
        self.max_iter = max_iter;
        Ok(self)
    }

    /// Feasibility tolerance in metres, finite and `>= 0` (default `1e-9`).
    pub fn with_tol(mut self, tol: f64) -> Result<Self, KeyError> {
        if !(tol.is_finite() && tol >= 0.0) {
            return Err(refuse("tol", format!("must be finite and >= 0, got {tol}")));
        }
        self.tol = tol;
        Ok(self)
    }
}

impl<const D: usize> SampleSolver<D> for PocsSolver<D> {
    fn start(&mut self, problem: &TrackProblem<'_, D>) -> Result<(), SolveError> {
        self.x = problem.geometry.centroid();
        self.feasible = 0;
        Ok(())
    }

    fn solve(
        &mut self,
        geometry: &Geometry<D>,
        sample: &SampleMeasurements,
        _k: usize,
    ) -> Result<Point<D>, SolveError> {
        let regions = regions_of(geometry, sample, 0.0);
        let p = bounds::pocs(&regions, self.x, self.max_iter, self.tol)?;
        self.feasible += usize::from(p.feasible);
        self.x = p.x;
        Ok(p.x)
    }

    fn feasible(&self) -> Option<usize> {
        Some(self.feasible)
    }
}

/// The SDP relaxation estimate ([`bounds::sdp_toa`], Biswas et al. 2006 as
/// Gholami 2015 Sec. 4 uses it) per sample, from the sample's one-way
/// ranges.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SdpSolver;

impl<const D: usize> SampleSolver<D> for SdpSolver {
    fn solve(
        &mut self,
        geometry: &Geometry<D>,
        sample: &SampleMeasurements,
        _k: usize,
    ) -> Result<Point<D>, SolveError> {
        let anchors: Vec<([f64; D], f64)> = sample
            .nodes
            .iter()
            .zip(&geometry.receivers)
            .filter_map(|(node, r)| node.range.map(|d| ((*r).into(), d)))
            .collect();
        if anchors.len() < 3 {
            return Err(SolveError::TooFewRanges(anchors.len()));
        }
        let e = bounds::sdp_toa(&anchors)?;
        Ok(Point::<D>::from(e.x))
    }
}

/// The closed-form linear least squares of [`online::ols_position`] per sample.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LlsSolver;

impl<const D: usize> SampleSolver<D> for LlsSolver {
    fn solve(
        &mut self,
        geometry: &Geometry<D>,
        sample: &SampleMeasurements,
        _k: usize,
    ) -> Result<Point<D>, SolveError> {
        Ok(online::ols_position(geometry, sample)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::geometry::Vec2;
    use approx::assert_abs_diff_eq;

    /// Mourya 2017's network and a target moving 11 m per sample, measured
    /// without noise (bistatic and one-way ranges).
    struct Fixture {
        g: Geometry,
        truth: Vec<Vec2>,
        samples: Vec<SampleMeasurements>,
    }

    impl Fixture {
        fn new() -> Self {
            let g = Geometry::mourya2017();
            let truth: Vec<Vec2> = (0..6)
                .map(|k| Vec2::new(400.0 + 10.0 * k as f64, 300.0 - 5.0 * k as f64))
                .collect();
            let samples = truth
                .iter()
                .map(|x| SampleMeasurements::noise_free(&g, x, false, true))
                .collect();
            Fixture { g, truth, samples }
        }

        /// The problem, with the true first position or without.
        fn problem(&self, with_truth: bool) -> TrackProblem<'_> {
            TrackProblem {
                geometry: &self.g,
                samples: &self.samples,
                truth0: with_truth.then_some(self.truth[0]),
            }
        }
    }

    /// A solver that fails on the samples listed, and otherwise returns the
    /// sample index as its x coordinate.
    struct Scripted {
        fail_at: Vec<usize>,
        keep: bool,
        last: Option<Vec2>,
    }

    impl SampleSolver for Scripted {
        fn solve(
            &mut self,
            _: &Geometry,
            _: &SampleMeasurements,
            k: usize,
        ) -> Result<Vec2, SolveError> {
            if self.fail_at.contains(&k) {
                return Err(SolveError::Online(online::TrackError::ZeroTime));
            }
            let x = Vec2::new(k as f64, 0.0);
            self.last = Some(x);
            Ok(x)
        }
        fn on_failure(&self) -> Option<Vec2> {
            if self.keep { self.last } else { None }
        }
    }

    #[test]
    fn the_executor_counts_failures_keeps_the_first_reason_and_records_what_the_solver_holds() {
        let f = Fixture::new();
        let problem = f.problem(false);
        for keep in [false, true] {
            let mut s = Scripted {
                fail_at: vec![2, 4],
                keep,
                last: None,
            };
            let run = run_track(&problem, &mut s);
            assert_eq!(run.failures, 2);
            assert_eq!(
                run.first_failure.as_deref(),
                Some("sample 2: sample index t is 1-based, got 0")
            );
            assert_eq!(run.est.len(), 6);
            assert_eq!(run.est[3], Some(Vec2::new(3.0, 0.0)));
            let held = keep.then(|| Vec2::new(1.0, 0.0));
            assert_eq!(run.est[2], held);
            assert_eq!(run.before, None, "a solver without a prior records none");
            assert_eq!(run.feasible, None);
        }
    }

    #[test]
    fn a_tracker_that_cannot_start_leaves_every_sample_empty_and_says_why() {
        let f = Fixture::new();
        let problem = f.problem(false);
        let mut ogd = OnlineSolver::new(OnlineRule::Ogd(StepSize::Constant { eta: 0.1 })).unwrap();
        let run = run_track(&problem, &mut ogd);
        assert_eq!(run.failures, 6);
        assert_eq!(run.est, vec![None; 6]);
        assert!(run.first_failure.unwrap().contains("use init = \"ols\""));
    }

    #[test]
    fn an_online_tracker_records_its_estimate_before_each_step_starting_from_x0() {
        let f = Fixture::new();
        let truth = &f.truth;
        let problem = f.problem(true);
        let mut onm = OnlineSolver::new(OnlineRule::Onm(NewtonDamping::default())).unwrap();
        let run = run_track(&problem, &mut onm);
        assert_eq!(run.failures, 0);
        let before = run.before.expect("an online tracker has a prior");
        assert_eq!(
            before[0], truth[0],
            "exact initialisation: x_0 is the truth"
        );
        for (b, e) in before[1..].iter().zip(&run.est) {
            assert_eq!(Some(*b), *e, "x_t before step t+1");
        }
        // Noise-free ranges: one Newton step from the previous position lands
        // close to the new one (the target moves 11 m per sample).
        for (e, x) in run.est.iter().zip(truth) {
            assert!((e.unwrap() - x).norm() < 1.0, "{e:?} vs {x:?}");
        }
    }

    #[test]
    fn noise_free_samples_are_recovered_by_every_per_sample_solver() {
        let f = Fixture::new();
        let truth = &f.truth;
        let problem = f.problem(false);
        let mut solvers: Vec<(&str, Box<dyn SampleSolver>)> = vec![
            ("lls", Box::new(LlsSolver)),
            ("ls", Box::new(RobustSolver::new(RobustMethod::Ls).unwrap())),
            (
                "lad",
                Box::new(RobustSolver::new(RobustMethod::Lad).unwrap()),
            ),
            (
                "lq",
                Box::new(RobustSolver::new(RobustMethod::LqIrls(1.5)).unwrap()),
            ),
            (
                "l0os",
                Box::new(RobustSolver::new(RobustMethod::L0os(Sparsity::Kappa(1))).unwrap()),
            ),
            (
                "pocs",
                Box::new(PocsSolver::default().with_tol(1e-9).unwrap()),
            ),
        ];
        for (name, s) in &mut solvers {
            let run = run_track(&problem, s.as_mut());
            assert_eq!(run.failures, 0, "{name}: {:?}", run.first_failure);
            for (e, x) in run.est.iter().zip(truth) {
                let e = e.unwrap();
                assert_abs_diff_eq!(e.x, x.x, epsilon = 1e-3);
                assert_abs_diff_eq!(e.y, x.y, epsilon = 1e-3);
            }
            if *name == "pocs" {
                assert_eq!(run.feasible, Some(6), "consistent sets are reached");
            }
        }
    }

    #[test]
    fn noise_free_3d_samples_are_recovered_by_every_per_sample_solver_and_the_trackers() {
        use crate::model::geometry::Point;
        let p3 = |x, y, z| Point::<3>::new(x, y, z);
        let g = Geometry {
            drift: Vec::new(),
            transmitters: vec![
                p3(-500.0, -500.0, -10.0),
                p3(500.0, -500.0, -20.0),
                p3(500.0, 500.0, -15.0),
                p3(-500.0, 500.0, -5.0),
            ],
            receivers: vec![
                p3(-400.0, 0.0, -300.0),
                p3(400.0, 0.0, -600.0),
                p3(0.0, -400.0, -150.0),
                p3(0.0, 400.0, -450.0),
            ],
        };
        let truth: Vec<Point<3>> = (0..6)
            .map(|k| {
                p3(
                    40.0 + 10.0 * k as f64,
                    -30.0 - 5.0 * k as f64,
                    -200.0 - 3.0 * k as f64,
                )
            })
            .collect();
        let samples: Vec<SampleMeasurements> = truth
            .iter()
            .map(|x| SampleMeasurements::noise_free(&g, x, false, true))
            .collect();
        let problem = TrackProblem {
            geometry: &g,
            samples: &samples,
            truth0: Some(truth[0]),
        };
        let mut solvers: Vec<(&str, Box<dyn SampleSolver<3>>)> = vec![
            ("lls", Box::new(LlsSolver)),
            ("ls", Box::new(RobustSolver::new(RobustMethod::Ls).unwrap())),
            (
                "lad",
                Box::new(RobustSolver::new(RobustMethod::Lad).unwrap()),
            ),
            ("sdp", Box::new(SdpSolver)),
            (
                "pocs",
                Box::new(PocsSolver::<3>::default().with_tol(1e-9).unwrap()),
            ),
            (
                "onm",
                Box::new(
                    OnlineSolver::<3>::new(OnlineRule::Onm(NewtonDamping::default())).unwrap(),
                ),
            ),
        ];
        for (name, s) in &mut solvers {
            let run = run_track(&problem, s.as_mut());
            assert_eq!(run.failures, 0, "{name}: {:?}", run.first_failure);
            for (k, (e, x)) in run.est.iter().zip(&truth).enumerate() {
                let e = e.unwrap();
                let tol = if *name == "onm" { 1.0 } else { 1e-2 };
                assert!((e - x).norm() < tol, "{name} sample {k}: {e:?} vs {x:?}");
            }
        }
    }

    #[test]
    fn the_builders_refuse_bad_parameters_by_name() {
        let key = |r: Result<PocsSolver, KeyError>| r.unwrap_err().key;
        assert_eq!(key(PocsSolver::default().with_max_iter(0)), "max_iter");
        assert_eq!(key(PocsSolver::default().with_tol(-1.0)), "tol");
        assert_eq!(key(PocsSolver::default().with_tol(f64::NAN)), "tol");
        for q in [1.0, 2.0, f64::NAN] {
            let e = RobustSolver::new(RobustMethod::LqIrls(q)).unwrap_err();
            assert_eq!(e.key, "q");
        }
        let e = RobustSolver::new(RobustMethod::L0os(Sparsity::Fraction(1.5))).unwrap_err();
        assert_eq!(e.key, "p");
        let e = OnlineSolver::<2>::new(OnlineRule::Ogd(StepSize::Constant { eta: -1.0 })).err();
        assert_eq!(e.map(|e| e.key), Some("step".to_string()));
        assert!(RobustSolver::new(RobustMethod::LqIrls(1.5)).is_ok());
        assert!(
            PocsSolver::<2>::default()
                .with_max_iter(1)
                .and_then(|p| p.with_tol(0.0))
                .is_ok()
        );
    }
}
