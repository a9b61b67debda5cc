//! The estimators' configurations (`[[baselines]]` parameters), each checked where it
//! enters.

use crate::estimators::robust::RobustError;
use serde::Deserialize;
use serde::Serialize;

/// Starting point `e^0` of an estimator.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Init {
    /// Closed-form linear least squares on the lifted rows of Mourya 2017 eq. (9)
    /// (unknowns `e` and one `d_j = ||e - r_j||` per receiver, the `d_j`
    /// eliminated by a Schur complement); falls back to [`Init::Centroid`]
    /// when that 2x2 system is singular. Not robust to outliers.
    #[default]
    Linear,
    /// Centroid of the sensors used by the links.
    Centroid,
    /// A given point `[x, y]`.
    Point([f64; 2]),
}

pub(super) fn default_l0os_max_iter() -> usize {
    500
}
pub(super) fn default_l0os_tol() -> f64 {
    1e-4
}

/// Parameters of [`l0os`](crate::estimators::robust::l0os) (Shi 2024 Algorithm 1).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct L0osConfig {
    /// Sparsity `kappa` of the outlier vector (eq. 6b); see [`kappa_from_fraction`].
    pub kappa: usize,
    /// Iteration cap (default 500).
    #[serde(default = "default_l0os_max_iter")]
    pub max_iter: usize,
    /// Stop when `||e^k - e^{k-1}|| / ||e^{k-1}|| < tol` (default `1e-4`, Shi 2024
    /// Sec. IV-A); the denominator is floored at `1e-3` times the sensor spread.
    #[serde(default = "default_l0os_tol")]
    pub tol: f64,
    /// Starting point `e^0` (the paper does not say which; default [`Init::Linear`]).
    #[serde(default)]
    pub init: Init,
}

impl L0osConfig {
    /// Defaults with the given `kappa`.
    pub fn new(kappa: usize) -> Self {
        L0osConfig {
            kappa,
            max_iter: default_l0os_max_iter(),
            tol: default_l0os_tol(),
            init: Init::default(),
        }
    }
}

/// `kappa = round(p m n)` of Shi 2024 Sec. IV-A for an outlier fraction
/// `p` in `[0, 1]` and `n_links = m n` links.
pub fn kappa_from_fraction(p: f64, n_links: usize) -> Result<usize, RobustError> {
    if !(p.is_finite() && (0.0..=1.0).contains(&p)) {
        return Err(RobustError::InvalidConfig {
            key: "p",
            reason: format!("outlier fraction must be in [0, 1], got {p}"),
        });
    }
    Ok((p * n_links as f64).round() as usize)
}

pub(super) fn default_q() -> f64 {
    1.5
}
pub(super) fn default_epsilon() -> f64 {
    1e-3
}
pub(super) fn default_irls_max_iter() -> usize {
    1000
}
pub(super) fn default_smooth_tol() -> f64 {
    1e-7
}

/// Parameters of [`lq_irls`](crate::estimators::robust::lq_irls) and [`lad`](crate::estimators::robust::lad).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IrlsConfig {
    /// Exponent `q` (default 1.5 as Shi 2024 Sec. IV-A; [`lad`](crate::estimators::robust::lad) forces 1).
    #[serde(default = "default_q")]
    pub q: f64,
    /// Smoothing `eps > 0` (metres) of `(r^2 + eps^2)^{q/2}` (default `1e-3`).
    #[serde(default = "default_epsilon")]
    pub epsilon: f64,
    /// Iteration cap (default 1000; on random 3-4 x 3-4 instances with a
    /// gross outlier `lad` needs at most ~50 and `q = 1.5` ~20).
    #[serde(default = "default_irls_max_iter")]
    pub max_iter: usize,
    /// Stop when the accepted step is below `tol` times `max(||e||, 1e-3 spread)`
    /// (default `1e-7`).
    #[serde(default = "default_smooth_tol")]
    pub tol: f64,
    /// Starting point (default [`Init::Linear`]).
    #[serde(default)]
    pub init: Init,
}

impl Default for IrlsConfig {
    fn default() -> Self {
        IrlsConfig {
            q: default_q(),
            epsilon: default_epsilon(),
            max_iter: default_irls_max_iter(),
            tol: default_smooth_tol(),
            init: Init::default(),
        }
    }
}

pub(super) fn default_ls_max_iter() -> usize {
    100
}

/// Parameters of [`ls`](crate::estimators::robust::ls).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LsConfig {
    /// Iteration cap (default 100).
    #[serde(default = "default_ls_max_iter")]
    pub max_iter: usize,
    /// Relative step tolerance as in [`IrlsConfig::tol`] (default `1e-7`).
    #[serde(default = "default_smooth_tol")]
    pub tol: f64,
    /// Starting point (default [`Init::Linear`]).
    #[serde(default)]
    pub init: Init,
}

impl Default for LsConfig {
    fn default() -> Self {
        LsConfig {
            max_iter: default_ls_max_iter(),
            tol: default_smooth_tol(),
            init: Init::default(),
        }
    }
}
