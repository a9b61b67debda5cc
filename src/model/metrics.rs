//! Track metrics: one implementation, used by every engine and baseline.

use crate::model::coords::Coords;
use crate::model::geometry::{Point, Vec2};
use serde::{Deserialize, Serialize};

/// The network estimate `theta_bar = mean_i theta_i[0:D]` (node-id order) of
/// the nodes' lifted variables in `D` dimensions.
pub fn theta_bar<const D: usize>(thetas: &[Coords]) -> Point<D> {
    let mut s = Point::<D>::zeros();
    for t in thetas {
        s += t.point::<D>();
    }
    s / thetas.len().max(1) as f64
}

/// Consensus disagreement `max_i ||theta_i[0:D] - theta_bar||`.
pub fn disagreement<const D: usize>(thetas: &[Coords]) -> f64 {
    let bar = theta_bar::<D>(thetas);
    thetas
        .iter()
        .map(|t| (t.point::<D>() - bar).norm())
        .fold(0.0, f64::max)
}

/// Root mean square of `xs` (`None` when empty).
pub fn rms(xs: &[f64]) -> Option<f64> {
    (!xs.is_empty()).then(|| (xs.iter().map(|e| e * e).sum::<f64>() / xs.len() as f64).sqrt())
}

/// Median of `xs` (`None` when empty).
pub fn median(xs: &[f64]) -> Option<f64> {
    quantile(xs, 0.5)
}

/// The `q`-quantile of `xs` with linear interpolation (`None` when empty).
pub fn quantile(xs: &[f64], q: f64) -> Option<f64> {
    if xs.is_empty() {
        return None;
    }
    let mut v = xs.to_vec();
    v.sort_by(f64::total_cmp);
    let pos = q.clamp(0.0, 1.0) * (v.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    Some(v[lo] + (v[hi] - v[lo]) * (pos - lo as f64))
}

/// Accuracy of one track against the truth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TrackScore {
    /// RMSE over all samples.
    pub rmse: f64,
    /// RMSE over samples `burn_in..`.
    pub rmse_after_burn_in: f64,
    /// Median error.
    pub median_error: f64,
    /// Error at the last sample.
    pub final_error: f64,
    /// Cumulative target tracking error `sum_t ||x_t - x_t*||` (Pun-So 2022).
    pub ctte: f64,
}

/// Per-sample errors `||est_k - truth_k||`.
pub fn errors(est: &[Vec2], truth: &[Vec2]) -> Vec<f64> {
    est.iter().zip(truth).map(|(e, t)| (e - t).norm()).collect()
}

/// Running CTTE per sample (the running sum of the errors).
pub fn running_ctte(errors: &[f64]) -> Vec<f64> {
    running_sum(errors)
}

/// Running sum `s_k = sum_{j <= k} x_j` (running CTTE, running regret).
pub fn running_sum(xs: &[f64]) -> Vec<f64> {
    xs.iter()
        .scan(0.0, |s, e| {
            *s += e;
            Some(*s)
        })
        .collect()
}

/// Score a track; `None` when there are no samples after `burn_in`.
pub fn score(errors: &[f64], burn_in: usize) -> Option<TrackScore> {
    Some(TrackScore {
        rmse: rms(errors)?,
        rmse_after_burn_in: rms(errors.get(burn_in..)?)?,
        median_error: median(errors)?,
        final_error: *errors.last()?,
        ctte: errors.iter().sum(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn scores_match_hand_computed_values() {
        let e = [3.0, 4.0, 0.0, 5.0];
        let s = score(&e, 1).unwrap();
        assert_relative_eq!(s.rmse, (50.0f64 / 4.0).sqrt());
        assert_relative_eq!(s.rmse_after_burn_in, (41.0f64 / 3.0).sqrt());
        assert_relative_eq!(s.median_error, 3.5);
        assert_relative_eq!(s.final_error, 5.0);
        assert_relative_eq!(s.ctte, 12.0);
        assert_eq!(running_ctte(&e).len(), 4);
        assert_relative_eq!(running_ctte(&e)[3], 12.0);
    }

    #[test]
    fn theta_bar_and_disagreement_of_symmetric_points() {
        let c = |v: &[f64]| Coords::from_slice(v).unwrap();
        let t = [
            c(&[1.0, 0.0, 9.0]),
            c(&[-1.0, 0.0, 2.0]),
            c(&[0.0, 3.0, 0.0]),
            c(&[0.0, -3.0, 0.0]),
        ];
        assert_relative_eq!(theta_bar::<2>(&t), Vec2::zeros());
        assert_relative_eq!(disagreement::<2>(&t), 3.0);
        // In 3-D the third number is a depth, not `d`.
        let t = [c(&[1.0, 0.0, 4.0, 9.0]), c(&[-1.0, 0.0, -4.0, 2.0])];
        assert_relative_eq!(theta_bar::<3>(&t), Point::<3>::zeros());
        assert_relative_eq!(disagreement::<3>(&t), 17f64.sqrt());
    }

    #[test]
    fn quantiles_interpolate_and_empty_input_gives_none() {
        assert_relative_eq!(quantile(&[1.0, 2.0, 3.0, 4.0, 5.0], 0.95).unwrap(), 4.8);
        assert!(median(&[]).is_none());
        assert!(score(&[], 0).is_none());
    }
}
