//! Scoring of a run: every track (the distributed `theta_bar`, the ML
//! reference, each baseline) against the truth, with CTTE, dynamic regret and
//! certified error bounds. One implementation, called by the one run
//! pipeline ([`crate::pipeline::run`]) of single runs and of every Monte Carlo
//! trial ([`crate::pipeline::montecarlo`]).
//!
//! * **Error, RMSE, CTTE** ([`crate::model::metrics`]): `e_k = ||x_k - x_k*||`,
//!   `CTTE = sum_k e_k` (Pun-So 2022 Sec. II).
//! * **Dynamic regret** (Pun-So 2020 Sec. II): `sum_k f_k(x_k) - f_k(x_hat_k)`
//!   with the range loss `f_k` of [`crate::estimators::online::loss`] and `x_hat_k` found
//!   by gradient descent from the true position, step `1/m`, until
//!   `||grad|| < 1e-8` or 5000 iterations (Pun-So 2022 Sec. V,
//!   [`crate::estimators::online::x_hat`]). `x_k` is the track's estimate at sample `k`.
//!   For the online trackers `regret_pred` is Pun-So 2020's own indexing
//!   (eq. (2): `f_t` is evaluated at the estimate made *before* sample `t`).
//! * **Curve shape**: `ctte_rate_mid`, `ctte_rate_3q`, `ctte_rate` are
//!   `CTTE(t)/t` at `t = T/2, 3T/4, T` (a decreasing sequence is sublinear
//!   growth); `regret_slope_first_tenth` / `_last_tenth` are the mean regret
//!   increments per sample over the first and the last tenth of the run.
//! * **Bounds** (Gholami 2015): per sample, the discs and ellipses (in 3-D balls
//!   and spheroids) of all ranges
//!   enlarged by `rho` (Remark 4) and the chosen bounds at each track's
//!   estimate. `coverage` is the fraction of samples whose set is nonempty
//!   and whose bound is at least the true error; `invalid_fraction` the
//!   fraction nonempty but below it; `empty_fraction` the fraction whose set
//!   is empty. Tightness `v - e` and relative tightness `(v - e)/e` are over
//!   the nonempty samples.

use crate::estimators::baselines::BaselineTrack;
use crate::estimators::bounds::{BoundOutcome, Intersection};
use crate::estimators::online::{self, XHatOptions};
use crate::estimators::track::regions_of;
use crate::model::geometry::Point;
use crate::model::measure::{Geometry, SampleMeasurements, Sigmas};
use crate::model::metrics;
use crate::scenario::{BoundKind, Realization, Scenario};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::time::Instant;

/// Metrics of one certified bound on one track.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoundMetrics {
    /// Fraction of samples with a nonempty set and `error <= bound`.
    pub coverage: f64,
    /// Fraction of samples with a nonempty set and `error > bound`.
    pub invalid_fraction: f64,
    /// Fraction of samples whose feasible set was empty.
    pub empty_fraction: f64,
    /// Mean of `v - e` over the nonempty samples (metres).
    pub mean_tightness: Option<f64>,
    /// Median of `(v - e) / e` over the nonempty samples with `e > 0`.
    pub rel_tightness_median: Option<f64>,
    /// 80th percentile of `(v - e) / e`.
    pub rel_tightness_p80: Option<f64>,
    /// Mean bound value over the nonempty samples (metres).
    pub mean_bound: Option<f64>,
    /// Mean solve time per instance (seconds).
    pub seconds_per_instance: f64,
}

/// Metrics of one track. Error metrics are `None` without truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(default)]
pub struct TrackMetrics {
    /// RMSE over all samples with an estimate.
    pub rmse: Option<f64>,
    /// RMSE after the burn-in.
    pub rmse_after_burn_in: Option<f64>,
    /// Median error.
    pub median_error: Option<f64>,
    /// Error at the last sample.
    pub final_error: Option<f64>,
    /// `sum_k e_k`.
    pub ctte: Option<f64>,
    /// CTTE after `T/2` samples.
    pub ctte_mid: Option<f64>,
    /// `CTTE(T/2) / (T/2)`.
    pub ctte_rate_mid: Option<f64>,
    /// `CTTE(3T/4) / (3T/4)`.
    pub ctte_rate_3q: Option<f64>,
    /// `CTTE(T) / T`.
    pub ctte_rate: Option<f64>,
    /// Dynamic regret `sum_k f_k(x_k) - f_k(x_hat_k)`.
    pub regret: Option<f64>,
    /// Mean regret increment per sample over the first tenth.
    pub regret_slope_first_tenth: Option<f64>,
    /// Mean regret increment per sample over the last tenth.
    pub regret_slope_last_tenth: Option<f64>,
    /// Online trackers: Pun-So 2020's regret, `f_t` at the estimate before sample `t`.
    pub regret_pred: Option<f64>,
    /// `regret_pred` increments over the first tenth.
    pub regret_pred_slope_first_tenth: Option<f64>,
    /// `regret_pred` increments over the last tenth.
    pub regret_pred_slope_last_tenth: Option<f64>,
    /// Samples where the estimator failed (no estimate, or kept the previous one).
    pub failures: usize,
    /// The first failure.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub first_failure: Option<String>,
    /// Mean time per sample of the estimator (seconds).
    pub step_seconds: Option<f64>,
    /// POCS: fraction of samples that ended feasible.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub feasible_fraction: Option<f64>,
    /// Certified bounds on this track.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub bounds: BTreeMap<String, BoundMetrics>,
}

/// One scored track with its per-sample series.
#[derive(Debug, Clone, PartialEq)]
pub struct ScoredTrack<const D: usize = 2> {
    /// `theta_bar`, `ml` or a baseline name.
    pub name: String,
    /// Estimate per sample.
    pub est: Vec<Option<Point<D>>>,
    /// Error per sample (with truth).
    pub error: Option<Vec<Option<f64>>>,
    /// Running CTTE per sample (with truth).
    pub ctte: Option<Vec<f64>>,
    /// Running dynamic regret per sample.
    pub regret: Option<Vec<f64>>,
    /// Running `regret_pred` (online trackers).
    pub regret_pred: Option<Vec<f64>>,
    /// Bound radii per bound name and sample (`None`: empty set or no estimate).
    pub bounds: Vec<(String, Vec<Option<f64>>)>,
    /// The metrics.
    pub metrics: TrackMetrics,
}

/// A scored run: `tracks[0]` is `theta_bar`, `tracks[1]` the ML reference,
/// then the baselines in scenario order.
#[derive(Debug, Clone, PartialEq)]
pub struct Scored<const D: usize = 2> {
    /// Every track.
    pub tracks: Vec<ScoredTrack<D>>,
    /// CRLB per sample (with truth).
    pub crlb: Vec<Option<f64>>,
    /// `x_hat_k` solves that did not reach the gradient tolerance.
    pub x_hat_not_converged: usize,
}

impl<const D: usize> Scored<D> {
    /// The track called `name`.
    pub fn track(&self, name: &str) -> Option<&ScoredTrack<D>> {
        self.tracks.iter().find(|t| t.name == name)
    }
}

/// Flatten a track's metrics into `prefix.key` entries (numbers only).
pub fn flatten_into(out: &mut BTreeMap<String, f64>, prefix: &str, m: &TrackMetrics) {
    if let Ok(serde_json::Value::Object(o)) = serde_json::to_value(m) {
        flatten_value(out, prefix, &serde_json::Value::Object(o));
    }
}

fn flatten_value(out: &mut BTreeMap<String, f64>, prefix: &str, v: &serde_json::Value) {
    match v {
        serde_json::Value::Number(n) => {
            if let Some(x) = n.as_f64() {
                out.insert(prefix.to_string(), x);
            }
        }
        serde_json::Value::Object(o) => {
            for (k, v) in o {
                flatten_value(out, &format!("{prefix}.{k}"), v);
            }
        }
        _ => {}
    }
}

fn at(curve: &[f64], n: usize) -> Option<f64> {
    n.checked_sub(1).and_then(|i| curve.get(i)).copied()
}

fn slopes(curve: &[f64]) -> (Option<f64>, Option<f64>) {
    let t = curve.len();
    let tenth = t / 10;
    if tenth == 0 {
        return (None, None);
    }
    let first = at(curve, tenth).map(|v| v / tenth as f64);
    let last = match (at(curve, t), at(curve, t - tenth)) {
        (Some(a), Some(b)) => Some((a - b) / tenth as f64),
        _ => None,
    };
    (first, last)
}

/// Score everything for the first `done` samples of a run: `theta_bar`, the
/// centralised ML reference track `ml` ([`crate::estimators::central::ml_track`]) and the
/// baselines.
pub fn score<const D: usize>(
    sc: &Scenario<D>,
    real: &Realization<D>,
    theta_bar: &[Point<D>],
    ml: Vec<Point<D>>,
    baselines: Vec<BaselineTrack<D>>,
    done: usize,
) -> Scored<D> {
    let geometry = &sc.geometry;
    let meas = &real.measurements[..done];
    let truth = real.truth.as_ref().map(|t| &t[..done]);
    let burn_in = sc.algorithm.burn_in.min(done.saturating_sub(1));

    let crlb: Vec<Option<f64>> = match truth {
        Some(t) => (0..done)
            .map(|k| crlb_of(&geometry.at(k), &meas[k], &real.sigmas[k], &t[k]))
            .collect(),
        None => vec![None; done],
    };
    // x_hat per sample (regret), shared by every track.
    let (x_hats, x_hat_not_converged) = match truth {
        Some(t) if sc.scoring.regret => {
            let (xh, nc) = x_hats(geometry, meas, t);
            (Some(xh), nc)
        }
        _ => (None, 0),
    };
    let regret_curve =
        |est: &[Option<Point<D>>]| regret_curve(geometry, meas, x_hats.as_deref()?, est);
    // The certified-bound feasible sets, one per sample.
    let bound_cfg = sc.bounds.as_ref();
    let sets: Vec<Option<Intersection<D>>> = match bound_cfg {
        Some(b) => (0..done)
            .map(|k| {
                feasible_set(
                    &geometry.at(k),
                    &meas[k],
                    b.rho + b.rho_sigmas * real.sigmas[k].range,
                )
            })
            .collect(),
        None => Vec::new(),
    };

    let mut raw: Vec<(String, Vec<Option<Point<D>>>, Option<BaselineTrack<D>>)> = vec![
        (
            "theta_bar".into(),
            theta_bar.iter().map(|x| Some(*x)).collect(),
            None,
        ),
        ("ml".into(), ml.into_iter().map(Some).collect(), None),
    ];
    for b in baselines {
        raw.push((b.name.clone(), b.run.est.clone(), Some(b)));
    }

    let mut tracks = Vec::with_capacity(raw.len());
    for (name, est, base) in raw {
        let error: Option<Vec<Option<f64>>> = truth.map(|t| {
            est.iter()
                .zip(t)
                .map(|(e, x)| e.map(|e| (e - x).norm()))
                .collect()
        });
        let mut m = TrackMetrics::default();
        let ctte_curve = error
            .as_ref()
            .and_then(|err| error_metrics(err, burn_in, &mut m));
        let regret = regret_curve(&est);
        if let Some(r) = &regret {
            m.regret = r.last().copied();
            (m.regret_slope_first_tenth, m.regret_slope_last_tenth) = slopes(r);
        }
        let regret_pred = base
            .as_ref()
            .and_then(|b| b.run.before.as_ref())
            .and_then(|before| {
                let v: Vec<Option<Point<D>>> = before.iter().map(|x| Some(*x)).collect();
                regret_curve(&v)
            });
        if let Some(r) = &regret_pred {
            m.regret_pred = r.last().copied();
            (
                m.regret_pred_slope_first_tenth,
                m.regret_pred_slope_last_tenth,
            ) = slopes(r);
        }
        if let Some(b) = &base {
            m.failures = b.run.failures;
            m.first_failure = b.run.first_failure.clone();
            m.step_seconds = (done > 0).then(|| b.run.step_seconds / done as f64);
            m.feasible_fraction = b.run.feasible.map(|f| f as f64 / done.max(1) as f64);
        }
        // Bounds on this track.
        let mut series = Vec::new();
        for &kind in bound_cfg.map_or(&[][..], |bc| bc.kinds_for(&name)) {
            let (radii, secs) = bound_series(kind, &sets, &est);
            if let Some(err) = &error {
                m.bounds
                    .insert(kind.as_str().to_string(), bound_metrics(&radii, err, secs));
            }
            series.push((kind.as_str().to_string(), radii));
        }
        tracks.push(ScoredTrack {
            name,
            est,
            error,
            ctte: ctte_curve,
            regret,
            regret_pred,
            bounds: series,
            metrics: m,
        });
    }
    Scored {
        tracks,
        crlb,
        x_hat_not_converged,
    }
}

/// The CRLB of one sample's measurements at the true position `truth`.
fn crlb_of<const D: usize>(
    geometry: &Geometry<D>,
    meas: &SampleMeasurements,
    sigmas: &Sigmas,
    truth: &Point<D>,
) -> Option<f64> {
    let obs = crate::estimators::central::observations(geometry, meas);
    crate::estimators::central::crlb(&obs, sigmas, truth)
}

/// The certified-bound feasible set of one sample: the intersection of its
/// measurement regions widened by `rho` (`None` without regions, or when
/// they do not intersect).
fn feasible_set<const D: usize>(
    geometry: &Geometry<D>,
    meas: &SampleMeasurements,
    rho: f64,
) -> Option<Intersection<D>> {
    let regions = regions_of(geometry, meas, rho);
    if regions.is_empty() {
        return None;
    }
    Intersection::new(&regions).ok().flatten()
}

/// The best fixed point `x_hat` of every sample with regret terms (the
/// comparator of Pun-So 2022's regret), and how many of them did not
/// converge.
fn x_hats<const D: usize>(
    geometry: &Geometry<D>,
    meas: &[SampleMeasurements],
    truth: &[Point<D>],
) -> (Vec<Option<online::XHat<D>>>, usize) {
    let mut not_converged = 0;
    let xh = meas
        .iter()
        .zip(truth)
        .enumerate()
        .map(|(k, (m, t))| {
            if online::term_count(m) == 0 {
                return None;
            }
            let xh = online::x_hat(&geometry.at(k), m, *t, &XHatOptions::default()).ok();
            if let Some(x) = &xh {
                not_converged += usize::from(!x.converged);
            }
            xh
        })
        .collect();
    (xh, not_converged)
}

/// The running regret of track `est` against the `x_hat` of every sample
/// (`None` if a sample with regret terms has no estimate or a term fails).
fn regret_curve<const D: usize>(
    geometry: &Geometry<D>,
    meas: &[SampleMeasurements],
    x_hats: &[Option<online::XHat<D>>],
    est: &[Option<Point<D>>],
) -> Option<Vec<f64>> {
    let mut terms = Vec::with_capacity(meas.len());
    for k in 0..meas.len() {
        let term = match (&x_hats[k], est[k]) {
            (Some(h), Some(x)) => online::regret_term(&geometry.at(k), &meas[k], &x, h).ok()?,
            (None, _) => 0.0,
            (Some(_), None) => return None,
        };
        terms.push(term);
    }
    Some(metrics::running_sum(&terms))
}

/// The error metrics of a track into `m` (rmse, median, final error, and the
/// CTTE figures when every sample has an estimate); the CTTE curve then.
fn error_metrics(err: &[Option<f64>], burn_in: usize, m: &mut TrackMetrics) -> Option<Vec<f64>> {
    let present: Vec<f64> = err.iter().flatten().copied().collect();
    let after: Vec<f64> = err
        .get(burn_in..)
        .unwrap_or(&[])
        .iter()
        .flatten()
        .copied()
        .collect();
    m.rmse = metrics::rms(&present);
    m.rmse_after_burn_in = metrics::rms(&after);
    m.median_error = metrics::median(&present);
    m.final_error = err.last().copied().flatten();
    let c = metrics::running_sum(&err.iter().map(|e| e.unwrap_or(0.0)).collect::<Vec<_>>());
    if present.len() != err.len() {
        return None;
    }
    m.ctte = c.last().copied();
    let t = c.len();
    m.ctte_mid = at(&c, t / 2);
    m.ctte_rate_mid = m.ctte_mid.map(|v| v / (t / 2) as f64);
    m.ctte_rate_3q = at(&c, 3 * t / 4).map(|v| v / (3 * t / 4) as f64);
    m.ctte_rate = m.ctte.map(|v| v / t as f64);
    Some(c)
}

/// Bound `kind`'s radius around every estimate of a track (`None` where
/// the sample has no feasible set or no estimate, or the bound fails), and
/// the mean seconds per instance.
fn bound_series<const D: usize>(
    kind: BoundKind,
    sets: &[Option<Intersection<D>>],
    est: &[Option<Point<D>>],
) -> (Vec<Option<f64>>, f64) {
    let mut radii = Vec::with_capacity(est.len());
    let start = Instant::now();
    let mut instances = 0usize;
    for (set, x) in sets.iter().zip(est) {
        let r = match (set, x) {
            (Some(set), Some(x)) => {
                instances += 1;
                let out = match kind {
                    BoundKind::UppRbbox => set.upp_rbbox(x),
                    BoundKind::UppBbox => set.upp_bbox(x),
                    BoundKind::UppMinball => set.upp_minball(x),
                    BoundKind::UppMaxdis => set.upp_maxdis(x),
                    BoundKind::UppExact => set.upp_exact(x),
                };
                match out {
                    Ok(BoundOutcome::Bound(v)) if v.is_finite() => Some(v),
                    _ => None,
                }
            }
            _ => None,
        };
        radii.push(r);
    }
    (
        radii,
        start.elapsed().as_secs_f64() / instances.max(1) as f64,
    )
}

/// Coverage and tightness of one bound series against the errors.
pub fn bound_metrics(radii: &[Option<f64>], errors: &[Option<f64>], secs: f64) -> BoundMetrics {
    let n = radii.len().max(1) as f64;
    let (mut covered, mut invalid, mut empty) = (0usize, 0usize, 0usize);
    let mut tight = Vec::new();
    let mut rel = Vec::new();
    let mut vals = Vec::new();
    for (r, e) in radii.iter().zip(errors) {
        match (r, e) {
            (Some(v), Some(e)) => {
                // Solver tolerance: bounds are exact to ~1e-8 relative.
                if *e <= v * (1.0 + 1e-7) + 1e-9 {
                    covered += 1;
                } else {
                    invalid += 1;
                }
                tight.push(v - e);
                vals.push(*v);
                if *e > 0.0 {
                    rel.push((v - e) / e);
                }
            }
            (None, _) => empty += 1,
            (Some(_), None) => {}
        }
    }
    let mean = |v: &[f64]| (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64);
    BoundMetrics {
        coverage: covered as f64 / n,
        invalid_fraction: invalid as f64 / n,
        empty_fraction: empty as f64 / n,
        mean_tightness: mean(&tight),
        rel_tightness_median: metrics::median(&rel),
        rel_tightness_p80: metrics::quantile(&rel, 0.8),
        mean_bound: mean(&vals),
        seconds_per_instance: secs,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn bound_metrics_count_covered_invalid_and_empty_samples() {
        let radii = [Some(2.0), Some(1.0), None, Some(4.0)];
        let errors = [Some(1.0), Some(1.5), Some(1.0), Some(2.0)];
        let m = bound_metrics(&radii, &errors, 0.0);
        assert_relative_eq!(m.coverage, 0.5);
        assert_relative_eq!(m.invalid_fraction, 0.25);
        assert_relative_eq!(m.empty_fraction, 0.25);
        assert_relative_eq!(m.mean_tightness.unwrap(), (1.0 - 0.5 + 2.0) / 3.0);
        // (v - e)/e = 1, -1/3, 1.
        assert_relative_eq!(m.rel_tightness_median.unwrap(), 1.0);
    }

    #[test]
    fn regret_slopes_are_mean_increments_of_the_first_and_last_tenth() {
        // Regret 1, 2, ..., 20 after a first tenth growing by 3 per sample.
        let mut c = Vec::new();
        let mut s = 0.0;
        for k in 0..20 {
            s += if k < 2 { 3.0 } else { 1.0 };
            c.push(s);
        }
        let (first, last) = slopes(&c);
        assert_relative_eq!(first.unwrap(), 3.0);
        assert_relative_eq!(last.unwrap(), 1.0);
        assert_eq!(slopes(&[1.0; 9]), (None, None));
    }
}
