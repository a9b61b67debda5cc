//! Measurement noise models and NLOS link sets. Every draw is seeded through
//! the caller's RNG.
//!
//! Models (`[measurements.range_noise] model = "..."`):
//!
//! | `model` | error | source |
//! |---|---|---|
//! | `gaussian` | `N(0, sigma^2)` | seed 002 Sec. III-C |
//! | `laplacian` | Laplace, standard deviation `sigma` (scale `b = sigma / sqrt 2`) | seed 004 Sec. IV-D |
//! | `gmm` | `(1 - c2) N(0, sigma1^2) + c2 N(0, variance_ratio sigma1^2)` | seed 004 eq. (22) |
//! | `nlos_exponential` | `N(0, sigma^2)`, plus `Exp(mean nlos_mean)` on NLOS links | seed 004 Sec. IV-C |
//! | `nlos_bernoulli_uniform` | `Exp(mean los_mean) + b U(0, r)`, `b ~ Bernoulli(p)` | seed 003 Sec. 6 |
//! | `exponential` | `Exp(mean mean)` (positive LOS error) | seed 003 Sec. 6 |
//!
//! Which links are NLOS for `nlos_exponential` is a separate per-trial draw,
//! [`NlosLinks::draw`] (seed 004 Sec. IV-C: all links of one random
//! transmitter or receiver). `nlos_bernoulli_uniform` draws its own NLOS flag
//! per measurement and ignores the link mask.

use rand::RngExt;
use rand_distr::{Distribution, Exp1, StandardNormal};
use serde::{Deserialize, Serialize};

/// How a noise standard deviation varies with the sample index `t` (1-based),
/// as in seed 000 / 001 Sec. V.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SigmaSchedule {
    /// `sigma_t = c`.
    #[default]
    Constant,
    /// `sigma_t = c / sqrt(t)`.
    InvSqrtT,
    /// `sigma_t = c / sqrt(2 t)`.
    InvSqrt2T,
}

impl SigmaSchedule {
    /// The factor multiplying `c` at 0-based sample index `k` (`t = k + 1`).
    pub fn factor(self, k: usize) -> f64 {
        let t = (k + 1) as f64;
        match self {
            SigmaSchedule::Constant => 1.0,
            SigmaSchedule::InvSqrtT => 1.0 / t.sqrt(),
            SigmaSchedule::InvSqrt2T => 1.0 / (2.0 * t).sqrt(),
        }
    }
}

fn default_los_mean() -> f64 {
    1.0
}

/// A noise model for one measurement kind (`[measurements.range_noise]`, ...).
///
/// The `schedule` of the zero-mean models scales the whole distribution
/// (for `nlos_exponential` only its Gaussian part); the positive-error models
/// (`exponential`, `nlos_bernoulli_uniform`) have no schedule.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case", deny_unknown_fields)]
pub enum NoiseModel {
    /// Zero-mean Gaussian with standard deviation `sigma` (scaled by `schedule`).
    Gaussian {
        /// Standard deviation at `t = 1` (or always, for a constant schedule).
        sigma: f64,
        /// How sigma varies with the sample index.
        #[serde(default)]
        schedule: SigmaSchedule,
    },
    /// Zero-mean Laplacian parametrised by its STANDARD DEVIATION `sigma`
    /// (density `exp(-|x|/b) / (2b)` with scale `b = sigma / sqrt(2)`), the
    /// outlier law of seed 004 Sec. IV-D.
    Laplacian {
        /// Standard deviation at `t = 1` (the scale is `sigma / sqrt 2`).
        sigma: f64,
        /// How sigma varies with the sample index.
        #[serde(default)]
        schedule: SigmaSchedule,
    },
    /// Two-component zero-mean Gaussian mixture, seed 004 eq. (22):
    /// `phi(y) = c1 N(y; 0, sigma1^2) + c2 N(y; 0, sigma2^2)`, `c1 = 1 - c2`,
    /// `sigma2^2 = variance_ratio * sigma1^2` (the paper uses `c2 = 0.1`,
    /// `variance_ratio = 100`).
    Gmm {
        /// Weight `c2` in `[0, 1]` of the wide component.
        c2: f64,
        /// Standard deviation `sigma1` of the dense component at `t = 1`.
        sigma1: f64,
        /// `sigma2^2 / sigma1^2 >= 1`.
        variance_ratio: f64,
        /// How `sigma1` (and with it `sigma2`) varies with the sample index.
        #[serde(default)]
        schedule: SigmaSchedule,
    },
    /// Zero-mean Gaussian noise on every link plus, on NLOS links only, a
    /// positive exponential bias with mean `nlos_mean` (an exponential's
    /// standard deviation equals its mean), seed 004 Sec. IV-C.
    NlosExponential {
        /// Standard deviation of the Gaussian part at `t = 1`.
        sigma: f64,
        /// Mean (= standard deviation) of the NLOS bias, metres.
        nlos_mean: f64,
        /// How `sigma` varies with the sample index (the bias is not scaled).
        #[serde(default)]
        schedule: SigmaSchedule,
    },
    /// Seed 003 Sec. 6: `eps = eps_E + b eps_U` with `eps_E ~ Exp(mean los_mean)`,
    /// `b ~ Bernoulli(p)` drawn per measurement, `eps_U ~ U(0, r)`. The paper
    /// uses `los_mean = 1`, `r = 10` m, `p = 0.2`.
    NlosBernoulliUniform {
        /// Mean of the exponential LOS error (default 1).
        #[serde(default = "default_los_mean")]
        los_mean: f64,
        /// Probability `p_NLOS` in `[0, 1]` that a measurement is NLOS.
        p: f64,
        /// Upper end `r` of the uniform NLOS error.
        r: f64,
    },
    /// Positive exponential LOS error with mean `mean` (seed 003 Sec. 6 LOS part).
    Exponential {
        /// Mean (= standard deviation).
        mean: f64,
    },
}

/// One noise draw and whether it was an NLOS draw (ground truth for
/// diagnostics of outlier detectors).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseDraw {
    /// The error to add to the noise-free measurement.
    pub value: f64,
    /// True if this draw carries an NLOS component.
    pub nlos: bool,
}

fn check_nonneg(key: &str, v: f64) -> Result<(), String> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(format!("{key} must be finite and >= 0, got {v}"))
    }
}

fn check_unit(key: &str, v: f64) -> Result<(), String> {
    if v.is_finite() && (0.0..=1.0).contains(&v) {
        Ok(())
    } else {
        Err(format!("{key} must be in [0, 1], got {v}"))
    }
}

impl NoiseModel {
    /// A constant-sigma Gaussian.
    pub fn gaussian(sigma: f64) -> Self {
        NoiseModel::Gaussian {
            sigma,
            schedule: SigmaSchedule::Constant,
        }
    }

    /// The nominal (inlier) standard deviation at 0-based sample `k`, used to
    /// weight centralised estimators and the CRLB: `sigma` for `gaussian`,
    /// `laplacian` and `nlos_exponential` (its Gaussian part), `sigma1` for
    /// `gmm` (its dense component), the exponential LOS standard deviation
    /// (= its mean) for `exponential` and `nlos_bernoulli_uniform`. The full
    /// moments, outliers included, are in [`NoiseModel::moments`].
    pub fn sigma_at(&self, k: usize) -> f64 {
        match self {
            NoiseModel::Gaussian { sigma, schedule }
            | NoiseModel::Laplacian { sigma, schedule }
            | NoiseModel::NlosExponential {
                sigma, schedule, ..
            } => sigma * schedule.factor(k),
            NoiseModel::Gmm {
                sigma1, schedule, ..
            } => sigma1 * schedule.factor(k),
            NoiseModel::NlosBernoulliUniform { los_mean, .. } => *los_mean,
            NoiseModel::Exponential { mean } => *mean,
        }
    }

    /// Closed-form `(mean, variance)` of the error at sample `k` on a link
    /// with the given NLOS status (`is_nlos` matters only for
    /// `nlos_exponential`; `nlos_bernoulli_uniform` returns the moments of its
    /// Bernoulli mixture: mean `l + p r / 2`, variance
    /// `l^2 + p r^2 / 3 - p^2 r^2 / 4`).
    pub fn moments(&self, k: usize, is_nlos: bool) -> (f64, f64) {
        match self {
            NoiseModel::Gaussian { .. } | NoiseModel::Laplacian { .. } => {
                let s = self.sigma_at(k);
                (0.0, s * s)
            }
            NoiseModel::Gmm {
                c2, variance_ratio, ..
            } => {
                let s1 = self.sigma_at(k);
                (0.0, s1 * s1 * ((1.0 - c2) + c2 * variance_ratio))
            }
            NoiseModel::NlosExponential { nlos_mean, .. } => {
                let s = self.sigma_at(k);
                if is_nlos {
                    (*nlos_mean, s * s + nlos_mean * nlos_mean)
                } else {
                    (0.0, s * s)
                }
            }
            NoiseModel::NlosBernoulliUniform { los_mean, p, r } => (
                los_mean + p * r / 2.0,
                los_mean * los_mean + p * r * r / 3.0 - p * p * r * r / 4.0,
            ),
            NoiseModel::Exponential { mean } => (*mean, mean * mean),
        }
    }

    /// Check the parameters; `Err` names the offending key and reason.
    pub fn validate(&self) -> Result<(), String> {
        match self {
            NoiseModel::Gaussian { sigma, .. } | NoiseModel::Laplacian { sigma, .. } => {
                check_nonneg("sigma", *sigma)
            }
            NoiseModel::Gmm {
                c2,
                sigma1,
                variance_ratio,
                ..
            } => {
                check_unit("c2", *c2)?;
                check_nonneg("sigma1", *sigma1)?;
                if !(variance_ratio.is_finite() && *variance_ratio >= 1.0) {
                    return Err(format!(
                        "variance_ratio (sigma2^2 / sigma1^2) must be finite and >= 1 \
                         (component 2 is the wide one), got {variance_ratio}"
                    ));
                }
                Ok(())
            }
            NoiseModel::NlosExponential {
                sigma, nlos_mean, ..
            } => {
                check_nonneg("sigma", *sigma)?;
                check_nonneg("nlos_mean", *nlos_mean)
            }
            NoiseModel::NlosBernoulliUniform { los_mean, p, r } => {
                check_nonneg("los_mean", *los_mean)?;
                check_unit("p", *p)?;
                check_nonneg("r", *r)
            }
            NoiseModel::Exponential { mean } => check_nonneg("mean", *mean),
        }
    }

    /// Draw one error for 0-based sample `k` on a link whose NLOS status is
    /// `is_nlos` (from [`NlosMask`]; pass `false` when there is no mask).
    /// Equivalent to `self.draw(k, is_nlos, rng).value`.
    pub fn sample<R: RngExt + ?Sized>(&self, k: usize, is_nlos: bool, rng: &mut R) -> f64 {
        self.draw(k, is_nlos, rng).value
    }

    /// Draw one error and report whether it has an NLOS component: for
    /// `nlos_exponential` that is `is_nlos`, for `nlos_bernoulli_uniform` the
    /// model's own Bernoulli draw (the argument is ignored), otherwise `false`.
    /// Parameters are assumed valid ([`NoiseModel::validate`]).
    pub fn draw<R: RngExt + ?Sized>(&self, k: usize, is_nlos: bool, rng: &mut R) -> NoiseDraw {
        let los = |value| NoiseDraw { value, nlos: false };
        match self {
            NoiseModel::Gaussian { .. } => {
                let z: f64 = StandardNormal.sample(rng);
                los(self.sigma_at(k) * z)
            }
            NoiseModel::Laplacian { .. } => {
                let e: f64 = Exp1.sample(rng);
                let b = self.sigma_at(k) / std::f64::consts::SQRT_2;
                los(if rng.random::<bool>() { b * e } else { -b * e })
            }
            NoiseModel::Gmm {
                c2, variance_ratio, ..
            } => {
                let wide = rng.random::<f64>() < *c2;
                let z: f64 = StandardNormal.sample(rng);
                let s1 = self.sigma_at(k);
                los(if wide {
                    s1 * variance_ratio.sqrt() * z
                } else {
                    s1 * z
                })
            }
            NoiseModel::NlosExponential { nlos_mean, .. } => {
                let z: f64 = StandardNormal.sample(rng);
                let mut value = self.sigma_at(k) * z;
                if is_nlos {
                    let e: f64 = Exp1.sample(rng);
                    value += nlos_mean * e;
                }
                NoiseDraw {
                    value,
                    nlos: is_nlos,
                }
            }
            NoiseModel::NlosBernoulliUniform { los_mean, p, r } => {
                let e: f64 = Exp1.sample(rng);
                let nlos = rng.random::<f64>() < *p;
                let mut value = los_mean * e;
                if nlos {
                    value += r * rng.random::<f64>();
                }
                NoiseDraw { value, nlos }
            }
            NoiseModel::Exponential { mean } => {
                let e: f64 = Exp1.sample(rng);
                los(mean * e)
            }
        }
    }
}

/// Which links are NLOS in a trial (`[measurements.nlos_links]`). A link is a
/// bistatic path `(transmitter m, receiver n)` or a one-way path to receiver
/// `n` (TOA).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum NlosLinks {
    /// Every link is LOS.
    None {},
    /// A fixed set of links.
    List {
        /// Bistatic links `[m, n]`.
        #[serde(default)]
        links: Vec<[usize; 2]>,
        /// One-way links, by receiver index.
        #[serde(default)]
        one_way: Vec<usize>,
    },
    /// Seed 004 Sec. IV-C: one node, drawn uniformly among the transmitters and
    /// receivers, is NLOS; all its links are (for a transmitter `m`: every
    /// `(m, n)`; for a receiver `n`: every `(m, n)` and the one-way link `n`).
    OneRandomTransmitterOrReceiver {},
    /// `round(fraction * M N)` distinct bistatic links and
    /// `round(fraction * N)` distinct one-way links, drawn uniformly.
    RandomFraction {
        /// Fraction in `[0, 1]`.
        fraction: f64,
    },
}

impl Default for NlosLinks {
    /// `None {}`: every link LOS.
    fn default() -> Self {
        NlosLinks::None {}
    }
}

/// Errors of [`NlosLinks::draw`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum NlosError {
    /// A listed link names a transmitter or receiver that does not exist.
    #[error(
        "nlos_links.links: link [{m}, {n}] out of range ({n_tx} transmitters, {n_rx} receivers)"
    )]
    LinkOutOfRange {
        /// Transmitter index.
        m: usize,
        /// Receiver index.
        n: usize,
        /// Number of transmitters.
        n_tx: usize,
        /// Number of receivers.
        n_rx: usize,
    },
    /// A listed one-way link names a receiver that does not exist.
    #[error("nlos_links.one_way: receiver {n} out of range ({n_rx} receivers)")]
    OneWayOutOfRange {
        /// Receiver index.
        n: usize,
        /// Number of receivers.
        n_rx: usize,
    },
    /// There is no transmitter or receiver to choose from.
    #[error("nlos_links: one_random_transmitter_or_receiver needs at least one node")]
    NoNodes,
    /// `fraction` outside `[0, 1]` or not finite.
    #[error("nlos_links.fraction must be in [0, 1], got {0}")]
    BadFraction(f64),
}

/// The NLOS status of every link of one trial.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NlosMask {
    /// Number of transmitters `M`.
    pub n_tx: usize,
    /// Number of receivers `N`.
    pub n_rx: usize,
    /// Bistatic links, index `m * N + n`.
    pub bistatic: Vec<bool>,
    /// One-way links, index `n`.
    pub one_way: Vec<bool>,
}

impl NlosMask {
    /// A mask with every link LOS.
    pub fn all_los(n_tx: usize, n_rx: usize) -> NlosMask {
        NlosMask {
            n_tx,
            n_rx,
            bistatic: vec![false; n_tx * n_rx],
            one_way: vec![false; n_rx],
        }
    }

    /// Whether the bistatic link `(m, n)` is NLOS (`false` when out of range).
    pub fn is_nlos(&self, m: usize, n: usize) -> bool {
        m < self.n_tx && n < self.n_rx && self.bistatic[m * self.n_rx + n]
    }

    /// Whether the one-way link to receiver `n` is NLOS (`false` when out of range).
    pub fn is_one_way_nlos(&self, n: usize) -> bool {
        self.one_way.get(n).copied().unwrap_or(false)
    }

    /// Number of NLOS bistatic links.
    pub fn bistatic_count(&self) -> usize {
        self.bistatic.iter().filter(|&&b| b).count()
    }
}

/// Set `count` distinct entries of `mask` to true, uniformly (partial Fisher-Yates).
fn mark_random<R: RngExt + ?Sized>(mask: &mut [bool], count: usize, rng: &mut R) {
    let mut idx: Vec<usize> = (0..mask.len()).collect();
    for i in 0..count.min(idx.len()) {
        let j = rng.random_range(i..idx.len());
        idx.swap(i, j);
        mask[idx[i]] = true;
    }
}

impl NlosLinks {
    /// Check the parameters that do not depend on the network size.
    pub fn validate(&self) -> Result<(), String> {
        match self {
            NlosLinks::RandomFraction { fraction } => check_unit("fraction", *fraction),
            _ => Ok(()),
        }
    }

    /// Draw the NLOS mask of one trial for `n_tx` transmitters and `n_rx`
    /// receivers. `List` and `None` consume no randomness.
    pub fn draw<R: RngExt + ?Sized>(
        &self,
        n_tx: usize,
        n_rx: usize,
        rng: &mut R,
    ) -> Result<NlosMask, NlosError> {
        let mut mask = NlosMask::all_los(n_tx, n_rx);
        match self {
            NlosLinks::None {} => {}
            NlosLinks::List { links, one_way } => {
                for &[m, n] in links {
                    if m >= n_tx || n >= n_rx {
                        return Err(NlosError::LinkOutOfRange { m, n, n_tx, n_rx });
                    }
                    mask.bistatic[m * n_rx + n] = true;
                }
                for &n in one_way {
                    if n >= n_rx {
                        return Err(NlosError::OneWayOutOfRange { n, n_rx });
                    }
                    mask.one_way[n] = true;
                }
            }
            NlosLinks::OneRandomTransmitterOrReceiver {} => {
                if n_tx + n_rx == 0 {
                    return Err(NlosError::NoNodes);
                }
                let pick = rng.random_range(0..n_tx + n_rx);
                if pick < n_tx {
                    mask.bistatic[pick * n_rx..(pick + 1) * n_rx].fill(true);
                } else {
                    let n = pick - n_tx;
                    for m in 0..n_tx {
                        mask.bistatic[m * n_rx + n] = true;
                    }
                    mask.one_way[n] = true;
                }
            }
            NlosLinks::RandomFraction { fraction } => {
                if !(fraction.is_finite() && (0.0..=1.0).contains(fraction)) {
                    return Err(NlosError::BadFraction(*fraction));
                }
                let nb = (fraction * (n_tx * n_rx) as f64).round() as usize;
                mark_random(&mut mask.bistatic, nb, rng);
                let no = (fraction * n_rx as f64).round() as usize;
                mark_random(&mut mask.one_way, no, rng);
            }
        }
        Ok(mask)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Stream, stream_rng};

    const N: usize = 200_000;

    /// Sample mean, variance and the standard errors of both (the variance's
    /// from the sample fourth central moment).
    fn stats(xs: &[f64]) -> (f64, f64, f64, f64) {
        let n = xs.len() as f64;
        let mean = xs.iter().sum::<f64>() / n;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
        let m4 = xs.iter().map(|x| (x - mean).powi(4)).sum::<f64>() / n;
        (mean, var, (var / n).sqrt(), ((m4 - var * var) / n).sqrt())
    }

    fn draws(model: &NoiseModel, is_nlos: bool, seed: u64) -> Vec<f64> {
        let mut rng = stream_rng(seed, Stream::Aux, 0);
        (0..N).map(|_| model.sample(0, is_nlos, &mut rng)).collect()
    }

    /// Mean and variance within 5 standard errors of the closed form.
    fn assert_moments(model: &NoiseModel, is_nlos: bool, seed: u64) -> Vec<f64> {
        model.validate().unwrap();
        let xs = draws(model, is_nlos, seed);
        let (mean, var, se_mean, se_var) = stats(&xs);
        let (m0, v0) = model.moments(0, is_nlos);
        assert!(
            (mean - m0).abs() < 5.0 * se_mean,
            "{model:?} nlos={is_nlos}: mean {mean} vs {m0} (se {se_mean})"
        );
        assert!(
            (var - v0).abs() < 5.0 * se_var,
            "{model:?} nlos={is_nlos}: var {var} vs {v0} (se {se_var})"
        );
        xs
    }

    #[test]
    fn gaussian_sample_moments_match_closed_form() {
        assert_moments(&NoiseModel::gaussian(3.0), false, 1);
    }

    #[test]
    fn laplacian_sample_moments_and_mean_absolute_value_match_closed_form() {
        let sigma = 2.5;
        let m = NoiseModel::Laplacian {
            sigma,
            schedule: SigmaSchedule::Constant,
        };
        let xs = assert_moments(&m, false, 2);
        // E|x| = b = sigma / sqrt 2 for a Laplacian (sigma sqrt(2/pi) for a
        // Gaussian): tells the shape apart, not only the variance.
        let mad = xs.iter().map(|x| x.abs()).sum::<f64>() / N as f64;
        let b = sigma / std::f64::consts::SQRT_2;
        let se = (sigma * sigma - b * b).sqrt() / (N as f64).sqrt();
        assert!((mad - b).abs() < 5.0 * se, "E|x| {mad} vs b {b}");
    }

    #[test]
    fn gmm_sample_moments_match_seed_004_eq_22() {
        let m = NoiseModel::Gmm {
            c2: 0.1,
            sigma1: 1.5,
            variance_ratio: 100.0,
            schedule: SigmaSchedule::Constant,
        };
        let xs = assert_moments(&m, false, 3);
        // Fraction beyond 5 sigma1 is ~ c2 P(|z| > 0.5) (wide) + c1 P(|z| > 5).
        let frac = xs.iter().filter(|x| x.abs() > 5.0 * 1.5).count() as f64 / N as f64;
        let expect = 0.1 * 0.617_075 + 0.9 * 5.733e-7;
        assert!(
            (frac - expect).abs() < 5.0 * (expect / N as f64).sqrt(),
            "{frac} vs {expect}"
        );
    }

    #[test]
    fn nlos_exponential_is_gaussian_on_los_links_and_biased_on_nlos_links() {
        let m = NoiseModel::NlosExponential {
            sigma: 10.0,
            nlos_mean: 100.0,
            schedule: SigmaSchedule::Constant,
        };
        assert_moments(&m, false, 4);
        let xs = assert_moments(&m, true, 5);
        // The NLOS part is positive: P(x < 0) = P(z sigma < -E) is small.
        let neg = xs.iter().filter(|&&x| x < 0.0).count() as f64 / N as f64;
        assert!(neg < 0.06, "{neg}");
    }

    #[test]
    fn nlos_bernoulli_uniform_matches_seed_003_mixture_moments_and_nlos_rate() {
        let m = NoiseModel::NlosBernoulliUniform {
            los_mean: 1.0,
            p: 0.2,
            r: 10.0,
        };
        assert_moments(&m, false, 6);
        let mut rng = stream_rng(7, Stream::Aux, 0);
        let mut nlos = 0usize;
        for _ in 0..N {
            let d = m.draw(0, false, &mut rng);
            assert!(d.value >= 0.0);
            nlos += usize::from(d.nlos);
        }
        let rate = nlos as f64 / N as f64;
        assert!(
            (rate - 0.2).abs() < 5.0 * (0.2 * 0.8 / N as f64).sqrt(),
            "{rate}"
        );
    }

    #[test]
    fn exponential_sample_moments_match_closed_form_and_are_positive() {
        let m = NoiseModel::Exponential { mean: 4.0 };
        let xs = assert_moments(&m, false, 8);
        assert!(xs.iter().all(|&x| x >= 0.0));
    }

    #[test]
    fn schedule_scales_the_zero_mean_models() {
        let m = NoiseModel::Laplacian {
            sigma: 2.0,
            schedule: SigmaSchedule::InvSqrtT,
        };
        approx::assert_relative_eq!(m.moments(3, false).1, 4.0 / 4.0, max_relative = 1e-12);
    }

    #[test]
    fn validation_rejects_negative_nan_and_out_of_range_parameters() {
        let c = SigmaSchedule::Constant;
        let bad = [
            (NoiseModel::gaussian(-1.0), "sigma"),
            (NoiseModel::gaussian(f64::NAN), "sigma"),
            (
                NoiseModel::Laplacian {
                    sigma: f64::NAN,
                    schedule: c,
                },
                "sigma",
            ),
            (
                NoiseModel::Gmm {
                    c2: 1.5,
                    sigma1: 1.0,
                    variance_ratio: 100.0,
                    schedule: c,
                },
                "c2",
            ),
            (
                NoiseModel::Gmm {
                    c2: -0.1,
                    sigma1: 1.0,
                    variance_ratio: 100.0,
                    schedule: c,
                },
                "c2",
            ),
            (
                NoiseModel::Gmm {
                    c2: 0.1,
                    sigma1: -1.0,
                    variance_ratio: 100.0,
                    schedule: c,
                },
                "sigma1",
            ),
            (
                NoiseModel::Gmm {
                    c2: 0.1,
                    sigma1: 1.0,
                    variance_ratio: 0.5,
                    schedule: c,
                },
                "variance_ratio",
            ),
            (
                NoiseModel::Gmm {
                    c2: 0.1,
                    sigma1: 1.0,
                    variance_ratio: f64::NAN,
                    schedule: c,
                },
                "variance_ratio",
            ),
            (
                NoiseModel::NlosExponential {
                    sigma: 1.0,
                    nlos_mean: -3.0,
                    schedule: c,
                },
                "nlos_mean",
            ),
            (
                NoiseModel::NlosExponential {
                    sigma: f64::INFINITY,
                    nlos_mean: 3.0,
                    schedule: c,
                },
                "sigma",
            ),
            (
                NoiseModel::NlosBernoulliUniform {
                    los_mean: 1.0,
                    p: 1.01,
                    r: 10.0,
                },
                "p",
            ),
            (
                NoiseModel::NlosBernoulliUniform {
                    los_mean: 1.0,
                    p: -0.01,
                    r: 10.0,
                },
                "p",
            ),
            (
                NoiseModel::NlosBernoulliUniform {
                    los_mean: 1.0,
                    p: f64::NAN,
                    r: 10.0,
                },
                "p",
            ),
            (
                NoiseModel::NlosBernoulliUniform {
                    los_mean: -1.0,
                    p: 0.2,
                    r: 10.0,
                },
                "los_mean",
            ),
            (
                NoiseModel::NlosBernoulliUniform {
                    los_mean: 1.0,
                    p: 0.2,
                    r: -10.0,
                },
                "r",
            ),
            (NoiseModel::Exponential { mean: f64::NAN }, "mean"),
            (NoiseModel::Exponential { mean: -2.0 }, "mean"),
        ];
        for (m, key) in bad {
            let err = m.validate().expect_err(&format!("{m:?} accepted"));
            assert!(err.starts_with(key), "{m:?}: {err}");
        }
        let good = [
            NoiseModel::gaussian(0.0),
            NoiseModel::NlosBernoulliUniform {
                los_mean: 1.0,
                p: 0.0,
                r: 10.0,
            },
            NoiseModel::NlosBernoulliUniform {
                los_mean: 1.0,
                p: 1.0,
                r: 10.0,
            },
            NoiseModel::Gmm {
                c2: 0.0,
                sigma1: 1.0,
                variance_ratio: 1.0,
                schedule: c,
            },
        ];
        for m in good {
            m.validate().unwrap();
        }
        assert!(
            NlosLinks::RandomFraction { fraction: 1.2 }
                .validate()
                .is_err()
        );
        assert!(
            NlosLinks::RandomFraction { fraction: f64::NAN }
                .validate()
                .is_err()
        );
    }

    #[test]
    fn toml_config_parses_with_defaults_and_rejects_unknown_keys() {
        let m: NoiseModel =
            toml::from_str("model = \"nlos_bernoulli_uniform\"\np = 0.2\nr = 10.0").unwrap();
        assert_eq!(
            m,
            NoiseModel::NlosBernoulliUniform {
                los_mean: 1.0,
                p: 0.2,
                r: 10.0
            }
        );
        let g: NoiseModel =
            toml::from_str("model = \"gmm\"\nc2 = 0.1\nsigma1 = 1.0\nvariance_ratio = 100.0")
                .unwrap();
        assert!(matches!(g, NoiseModel::Gmm { .. }));
        assert!(
            toml::from_str::<NoiseModel>("model = \"exponential\"\nmean = 1.0\nsigma = 2.0")
                .is_err()
        );
        let l: NlosLinks = toml::from_str("kind = \"list\"\nlinks = [[0, 1], [2, 3]]").unwrap();
        assert_eq!(
            l,
            NlosLinks::List {
                links: vec![[0, 1], [2, 3]],
                one_way: vec![]
            }
        );
        let o: NlosLinks = toml::from_str("kind = \"one_random_transmitter_or_receiver\"").unwrap();
        assert_eq!(o, NlosLinks::OneRandomTransmitterOrReceiver {});
        assert!(toml::from_str::<NlosLinks>("kind = \"none\"\nfraction = 0.1").is_err());
    }

    #[test]
    fn one_random_node_makes_exactly_its_links_nlos_and_picks_every_node_equally() {
        let (n_tx, n_rx) = (3, 5);
        let mut rng = stream_rng(11, Stream::Links, 0);
        let mut hits = vec![0usize; n_tx + n_rx];
        let trials = 16_000;
        for _ in 0..trials {
            let mask = NlosLinks::OneRandomTransmitterOrReceiver {}
                .draw(n_tx, n_rx, &mut rng)
                .unwrap();
            let tx: Vec<usize> = (0..n_tx)
                .filter(|&m| (0..n_rx).all(|n| mask.is_nlos(m, n)))
                .collect();
            let rx: Vec<usize> = (0..n_rx)
                .filter(|&n| (0..n_tx).all(|m| mask.is_nlos(m, n)))
                .collect();
            if tx.len() == 1 {
                assert_eq!(mask.bistatic_count(), n_rx);
                assert!(mask.one_way.iter().all(|&b| !b));
                hits[tx[0]] += 1;
            } else {
                assert_eq!(rx.len(), 1);
                assert_eq!(mask.bistatic_count(), n_tx);
                assert!(mask.is_one_way_nlos(rx[0]));
                hits[n_tx + rx[0]] += 1;
            }
        }
        let p = 1.0 / (n_tx + n_rx) as f64;
        let se = (p * (1.0 - p) / trials as f64).sqrt();
        for h in hits {
            assert!((h as f64 / trials as f64 - p).abs() < 5.0 * se, "{h}");
        }
    }

    #[test]
    fn random_fraction_marks_the_rounded_number_of_distinct_links() {
        let mut rng = stream_rng(12, Stream::Links, 0);
        let mask = NlosLinks::RandomFraction { fraction: 0.15 }
            .draw(8, 8, &mut rng)
            .unwrap();
        assert_eq!(mask.bistatic_count(), 10);
        assert_eq!(mask.one_way.iter().filter(|&&b| b).count(), 1);
        assert_eq!(
            NlosLinks::RandomFraction { fraction: 1.0 }
                .draw(2, 3, &mut rng)
                .unwrap()
                .bistatic_count(),
            6
        );
        assert!(
            NlosLinks::RandomFraction { fraction: -0.1 }
                .draw(2, 3, &mut rng)
                .is_err()
        );
    }

    #[test]
    fn listed_links_are_nlos_and_out_of_range_links_are_errors() {
        let mut rng = stream_rng(13, Stream::Links, 0);
        let l = NlosLinks::List {
            links: vec![[1, 2]],
            one_way: vec![0],
        };
        let mask = l.draw(2, 3, &mut rng).unwrap();
        assert!(mask.is_nlos(1, 2) && mask.is_one_way_nlos(0));
        assert_eq!(mask.bistatic_count(), 1);
        assert!(!mask.is_nlos(5, 5));
        let err = NlosLinks::List {
            links: vec![[2, 0]],
            one_way: vec![],
        }
        .draw(2, 3, &mut rng);
        assert!(matches!(err, Err(NlosError::LinkOutOfRange { m: 2, .. })));
        let err = NlosLinks::List {
            links: vec![],
            one_way: vec![3],
        }
        .draw(2, 3, &mut rng);
        assert!(matches!(err, Err(NlosError::OneWayOutOfRange { n: 3, .. })));
        assert_eq!(
            NlosLinks::OneRandomTransmitterOrReceiver {}.draw(0, 0, &mut rng),
            Err(NlosError::NoNodes)
        );
    }

    #[test]
    fn same_seed_gives_the_same_draws() {
        let m = NoiseModel::NlosBernoulliUniform {
            los_mean: 1.0,
            p: 0.3,
            r: 5.0,
        };
        let a: Vec<f64> = {
            let mut r = stream_rng(3, Stream::Measurement, 1);
            (0..16).map(|_| m.sample(0, false, &mut r)).collect()
        };
        let b: Vec<f64> = {
            let mut r = stream_rng(3, Stream::Measurement, 1);
            (0..16).map(|_| m.sample(0, false, &mut r)).collect()
        };
        assert_eq!(a, b);
    }
}
