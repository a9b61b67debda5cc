//! Measurement noise models. Every model is seeded through the caller's RNG.

use rand::RngExt;
use rand_distr::{Distribution, StandardNormal};
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

/// A noise model for one measurement kind (`[measurements.range_noise]`, ...).
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
}

impl NoiseModel {
    /// A constant-sigma Gaussian.
    pub fn gaussian(sigma: f64) -> Self {
        NoiseModel::Gaussian {
            sigma,
            schedule: SigmaSchedule::Constant,
        }
    }

    /// The nominal standard deviation at 0-based sample `k`, used to weight
    /// centralised estimators and the CRLB.
    pub fn sigma_at(&self, k: usize) -> f64 {
        match self {
            NoiseModel::Gaussian { sigma, schedule } => sigma * schedule.factor(k),
        }
    }

    /// Check the parameters; `Err` names the offending key and reason.
    pub fn validate(&self) -> Result<(), String> {
        match self {
            NoiseModel::Gaussian { sigma, .. } => {
                if !(sigma.is_finite() && *sigma >= 0.0) {
                    return Err(format!("sigma must be finite and >= 0, got {sigma}"));
                }
            }
        }
        Ok(())
    }

    /// Draw one noise value for 0-based sample `k`.
    pub fn sample<R: RngExt + ?Sized>(&self, k: usize, rng: &mut R) -> f64 {
        match self {
            NoiseModel::Gaussian { .. } => {
                let z: f64 = StandardNormal.sample(rng);
                self.sigma_at(k) * z
            }
        }
    }
}
