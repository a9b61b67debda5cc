//! The least-squares estimates `x_hat_t` (Pun-So 2022 Sec. V-A), dynamic regret (Pun-So 2020
//! Sec. II) and CTTE (Pun-So 2022 Sec. II) accumulators.

use super::loss_grad;
use crate::estimators::online::TrackError;
use crate::estimators::online::commit;
use crate::estimators::online::loss;
use crate::model::geometry::Point;
use crate::model::measure::Geometry;
use crate::model::measure::SampleMeasurements;
use serde::Deserialize;
use serde::Serialize;

/// Options of the gradient-descent computation of `x_hat_t` (Pun-So 2022 Sec. V-A).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct XHatOptions {
    /// GD step; `None` means `1 / m_eff` with `m_eff` = [`LossEval::weight`](crate::estimators::online::LossEval::weight)
    /// (`= 1/m` of Pun-So 2022 for TOA; bistatic terms count 4 because their
    /// curvature `2 ||u_t + u_r||^2` can reach 8).
    pub step: Option<f64>,
    /// Stop when `||grad f_t|| <` this (Pun-So 2022: `1e-8`).
    pub grad_tol: f64,
    /// Stop after this many GD iterations (Pun-So 2022: 5000).
    pub max_iter: usize,
}

impl Default for XHatOptions {
    fn default() -> Self {
        XHatOptions {
            step: None,
            grad_tol: 1e-8,
            max_iter: 5000,
        }
    }
}

/// A least-squares estimate `x_hat_t`, the last GD iterate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct XHat<const D: usize = 2> {
    /// The estimate.
    pub x: Point<D>,
    /// `f_t(x_hat_t)`.
    pub value: f64,
    /// `||grad f_t(x_hat_t)||`.
    pub grad_norm: f64,
    /// GD iterations performed.
    pub iterations: usize,
    /// Whether the gradient tolerance was met.
    pub converged: bool,
}

/// `x_hat_t ~ argmin f_t` by gradient descent from `start` (Pun-So 2022 Sec. V-A
/// uses the true position `x_t^*`), constant step, until the gradient norm is
/// below `grad_tol` or `max_iter` iterations; the last iterate is returned.
pub fn x_hat<const D: usize>(
    geometry: &Geometry<D>,
    sample: &SampleMeasurements,
    start: Point<D>,
    opts: &XHatOptions,
) -> Result<XHat<D>, TrackError> {
    let mut x = start;
    let mut ev = loss_grad(geometry, sample, &x)?;
    let step = match opts.step {
        Some(s) => s,
        None if ev.weight > 0.0 => 1.0 / ev.weight,
        None => 1.0,
    };
    if !(step.is_finite() && step > 0.0) {
        return Err(TrackError::BadParameter {
            name: "x_hat step",
            reason: format!("must be finite and > 0, got {step}"),
        });
    }
    if !(opts.grad_tol.is_finite() && opts.grad_tol >= 0.0) {
        return Err(TrackError::BadParameter {
            name: "grad_tol",
            reason: format!("must be finite and >= 0, got {}", opts.grad_tol),
        });
    }
    let mut iterations = 0;
    while ev.grad.norm() >= opts.grad_tol && iterations < opts.max_iter {
        x = commit(x - step * ev.grad, "x_hat gradient descent")?;
        ev = loss_grad(geometry, sample, &x)?;
        iterations += 1;
    }
    let grad_norm = ev.grad.norm();
    Ok(XHat {
        x,
        value: ev.value,
        grad_norm,
        iterations,
        converged: grad_norm < opts.grad_tol,
    })
}

/// One dynamic-regret term `f_t(x) - f_t(x_hat_t)` (Pun-So 2020 Sec. II).
/// Pun-So 2020 evaluates `f_t` at the estimate made *before* sample `t`
/// (`x_{t-1}` in this module's indexing). Can be slightly negative when
/// `x_hat_t` is only a local or approximate minimiser.
pub fn regret_term<const D: usize>(
    geometry: &Geometry<D>,
    sample: &SampleMeasurements,
    x: &Point<D>,
    x_hat: &XHat<D>,
) -> Result<f64, TrackError> {
    Ok(loss(geometry, sample, x)? - x_hat.value)
}

/// Running dynamic regret `sum_t f_t(x_t) - f_t(x_hat_t)` (Pun-So 2020 Sec. II).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DynamicRegret {
    /// The running sum.
    pub sum: f64,
    /// Number of terms added.
    pub count: usize,
}

impl DynamicRegret {
    /// Add one term (see [`regret_term`]); returns the running sum.
    pub fn push(&mut self, term: f64) -> f64 {
        self.sum += term;
        self.count += 1;
        self.sum
    }
}

/// Running cumulative target tracking error `CTTE = sum_t ||x_t - x_t^*||`
/// (Pun-So 2022 Sec. II).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Ctte {
    /// The running sum.
    pub sum: f64,
    /// Number of terms added.
    pub count: usize,
}

impl Ctte {
    /// Add `||x - x_true||`; returns the running CTTE.
    pub fn push<const D: usize>(&mut self, x: &Point<D>, x_true: &Point<D>) -> f64 {
        self.sum += (x - x_true).norm();
        self.count += 1;
        self.sum
    }

    /// `CTTE / count` (0 before the first term).
    pub fn mean(&self) -> f64 {
        if self.count == 0 {
            0.0
        } else {
            self.sum / self.count as f64
        }
    }
}
