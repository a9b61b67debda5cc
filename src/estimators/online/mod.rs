//! Centralised online trackers for one-way (TOA) and bistatic ranges.
//!
//! Implements the time-varying least-squares formulation of Pun & So,
//! "Local strong convexity of source localization and error bound for target
//! tracking under TOA measurements" (Pun-So 2022) and "Dynamic regret bound for
//! moving target tracking based on online TOA measurements" (Pun-So 2020):
//!
//! * the per-sample loss `f_t` (Pun-So 2022 eq. (2), Pun-So 2020 eq. (1)), extended
//!   to bistatic ranges, with analytic gradient and Hessian ([`loss`],
//!   [`loss_grad`], [`loss_grad_hess`]);
//! * online gradient descent ([`OgdTracker`], Pun-So 2022 eq. (3)) with constant
//!   or `eta0 / sqrt(t)` steps (Pun-So 2020 Sec. V);
//! * the online Newton method ([`OnmTracker`], Pun-So 2022 Sec. V) with a
//!   documented modification when the Hessian is not positive definite;
//! * exact and OLS initialisation ([`Init`], [`ols_position`], Pun-So 2022
//!   eq. (15)-(17));
//! * least-squares estimates `x_hat_t` by gradient descent ([`x_hat`], Pun-So 2022
//!   Sec. V-A), dynamic regret (Pun-So 2020 Sec. II) and CTTE (Pun-So 2022 Sec. II)
//!   accumulators;
//! * the target trajectories of Pun-So 2022 eq. (19) and Pun-So 2020 Sec. V
//!   ([`walk_trajectory`] of a [`Walk`](crate::model::motion::Walk)).
//!
//! # The loss
//!
//! For one sample (time `t`) the loss sums one squared residual per range:
//!
//! ```text
//! f_t(x) = sum_{n with range r_n}     (||x - r_n|| - range_n)^2                   (one-way, Pun-So 2022 eq. 2)
//!        + sum_{(m, n) with rho_{m,n}} (||x - t_m|| + ||x - r_n|| - rho_{m,n})^2  (bistatic)
//! ```
//!
//! The anchors of Pun-So 2022 are the receivers `r_n` that report a one-way
//! `range`. Direction-of-arrival measurements (`doa`) are **ignored**: Pun-So 2022
//! and 001 are range-only, and mixing radians with metres would need a weight
//! the papers do not give.
//!
//! `f_t` is not differentiable where `x` coincides with a range focus `p`
//! (an anchor, receiver or transmitter). When `||x - p|| <= 1e-12 (1 + ||p||_inf)`
//! the unit vector `(x - p)/||x - p||` of that focus is replaced by `0` (the
//! minimum-norm element of the subdifferential of `||x - p||`) and its
//! curvature term is dropped; the residual still enters the loss value.

mod init;
mod loss;
mod regret;
mod walks;
pub use init::{Init, LiftedRow, lifted_bistatic_ls, ols_position, ols_toa};
pub use loss::{LossEval, loss, loss_grad, loss_grad_hess, term_count};
pub use regret::{Ctte, DynamicRegret, XHat, XHatOptions, regret_term, x_hat};
pub use walks::{trajectory_eq19, walk_trajectory};

use crate::model::geometry::{Point, Vec2};
use crate::model::linalg::{MatD, lu_solve, sym_eigen};
use crate::model::measure::{Geometry, SampleMeasurements};
use serde::{Deserialize, Serialize};

/// A 2x2 matrix (Hessians of `f_t` in 2-D).
pub type Mat2 = nalgebra::Matrix2<f64>;

/// Distance below which `x` counts as sitting on a focus, relative to `1 + ||p||_inf`.
const COINCIDENT_REL: f64 = 1e-12;

/// Why a tracker or helper could not produce a result.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TrackError {
    /// An input (position, measurement, parameter) was NaN or infinite.
    #[error("non-finite input: {0}")]
    NonFinite(&'static str),
    /// A bistatic measurement names a transmitter the geometry does not have.
    #[error(
        "bistatic measurement at node {node} refers to transmitter {m}, but the geometry has {count}"
    )]
    UnknownTransmitter {
        /// Receiver that reported the measurement.
        node: usize,
        /// Transmitter index in the measurement.
        m: usize,
        /// Number of transmitters in the geometry.
        count: usize,
    },
    /// The sample has measurements for more receivers than the geometry has.
    #[error("sample has {nodes} nodes but the geometry has only {receivers} receivers")]
    TooManyNodes {
        /// `sample.nodes.len()`.
        nodes: usize,
        /// `geometry.receivers.len()`.
        receivers: usize,
    },
    /// The 1-based sample index `t` was 0.
    #[error("sample index t is 1-based, got 0")]
    ZeroTime,
    /// A tuning parameter was out of range.
    #[error("bad parameter {name}: {reason}")]
    BadParameter {
        /// Parameter name.
        name: &'static str,
        /// What is wrong with it.
        reason: String,
    },
    /// The OLS initialisation has too few or degenerate measurements.
    #[error("OLS initialisation impossible: {0}")]
    OlsDegenerate(String),
    /// The computation overflowed (e.g. coordinates near `f64::MAX`).
    #[error("non-finite result in {0}")]
    NonFiniteResult(&'static str),
    /// The undamped Newton step ([`NewtonDamping::Plain`]) met a Hessian that is
    /// singular to its eigenvalue floor.
    #[error("singular Hessian (eigenvalues {0:e} and {1:e}): no Newton step")]
    SingularHessian(f64, f64),
}

/// OGD step-size rule.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "rule", rename_all = "snake_case", deny_unknown_fields)]
pub enum StepSize {
    /// `eta_t = eta` (Pun-So 2022 Sec. V: `eta = 0.1`).
    Constant {
        /// The step size.
        eta: f64,
    },
    /// `eta_t = eta0 / sqrt(t)` (Pun-So 2020 Sec. V: `eta0 = 1`).
    InvSqrt {
        /// The step size at `t = 1`.
        eta0: f64,
    },
    /// `eta_t = scale / L_t`, where `L_t = ||hess f_t(x_{t-1})||_2` is the
    /// local Lipschitz constant of `grad f_t` at the previous estimate (the
    /// default, `scale = 1`: the classical `1/L` gradient step). Unlike a
    /// constant `eta`, it is stable whatever the geometry's scale: the
    /// bistatic terms of a km-scale scene have `L ~ 8 m` per range, so seed
    /// 000's `eta = 0.1` (`eta L >> 2`) diverges there.
    Lipschitz {
        /// The multiple of `1/L_t` (in `(0, 2)` for a locally quadratic `f_t`).
        #[serde(default = "one")]
        scale: f64,
    },
}

fn one() -> f64 {
    1.0
}

/// The spectral norm of a symmetric `D x D` matrix: its largest eigenvalue in
/// absolute value (in closed form in 2-D, by [`sym_eigen`] in 3-D).
pub fn sym_norm<const D: usize>(h: &MatD<D>) -> f64 {
    if D != 2 {
        let sym = (h + h.transpose()) * 0.5;
        return sym_eigen(&sym).map_or(f64::NAN, |(l, _)| l.amax());
    }
    let (a, b, d) = (h[(0, 0)], 0.5 * (h[(0, 1)] + h[(1, 0)]), h[(1, 1)]);
    let m = 0.5 * (a + d);
    let r = (0.25 * (a - d) * (a - d) + b * b).sqrt();
    (m + r).abs().max((m - r).abs())
}

impl StepSize {
    /// `eta_t` for 1-based sample index `t`.
    pub fn at(&self, t: usize) -> f64 {
        match *self {
            StepSize::Constant { eta } => eta,
            StepSize::InvSqrt { eta0 } => eta0 / (t as f64).sqrt(),
            // Scaled by 1/L_t where the tracker steps (it knows x_{t-1}).
            StepSize::Lipschitz { scale } => scale,
        }
    }

    fn validate(&self) -> Result<(), TrackError> {
        let v = match *self {
            StepSize::Constant { eta } => eta,
            StepSize::InvSqrt { eta0 } => eta0,
            StepSize::Lipschitz { scale } => scale,
        };
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(TrackError::BadParameter {
                name: "step size",
                reason: format!("must be finite and > 0, got {v}"),
            })
        }
    }
}

/// What the online Newton method does with a Hessian that is not safely
/// positive definite. Let `lambda_1 >= lambda_2` be the eigenvalues of
/// `hess f_t(x_{t-1})` and `floor = max(rel_floor * max|lambda_i|, abs_floor)`.
/// When `lambda_2 >= floor` both variants take the plain Newton step of
/// Pun-So 2022 Sec. V, `x_t = x_{t-1} - (hess f_t)^{-1} grad f_t`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum NewtonDamping {
    /// Eigenvalue modification (Nocedal & Wright, Sec. 3.4): replace each
    /// eigenvalue by `max(|lambda_i|, floor)` and step with the modified
    /// inverse. Negative curvature is turned into positive curvature of the
    /// same magnitude (the step descends instead of climbing to a saddle or
    /// maximum), near-zero curvature is capped at `floor`, so the step is
    /// always finite and a descent direction.
    AbsEigen {
        /// Relative eigenvalue floor (default `1e-6`).
        rel_floor: f64,
        /// Absolute eigenvalue floor (default `1e-12`; the Hessian of `f_t` is dimensionless).
        abs_floor: f64,
    },
    /// The paper's undamped step with the Hessian as it is, also when it is
    /// indefinite (Pun-So 2022 Sec. V): `x_{t-1} - (hess f_t)^{-1} grad f_t`. Only a
    /// Hessian that is singular to `floor` (`min |lambda_i| < floor`) has no step:
    /// the update fails, the tracker keeps its estimate and counts a failure.
    Plain {
        /// Relative eigenvalue floor.
        rel_floor: f64,
        /// Absolute eigenvalue floor.
        abs_floor: f64,
    },
    /// Fall back to a gradient step `x_{t-1} - eta grad f_t` when `lambda_2 < floor`.
    GradientFallback {
        /// Relative eigenvalue floor.
        rel_floor: f64,
        /// Absolute eigenvalue floor.
        abs_floor: f64,
        /// Step of the fallback gradient step.
        eta: f64,
    },
}

impl Default for NewtonDamping {
    fn default() -> Self {
        NewtonDamping::AbsEigen {
            rel_floor: 1e-6,
            abs_floor: 1e-12,
        }
    }
}

impl NewtonDamping {
    fn validate(&self) -> Result<(), TrackError> {
        let (rel, abs, eta) = match *self {
            NewtonDamping::AbsEigen {
                rel_floor,
                abs_floor,
            }
            | NewtonDamping::Plain {
                rel_floor,
                abs_floor,
            } => (rel_floor, abs_floor, 1.0),
            NewtonDamping::GradientFallback {
                rel_floor,
                abs_floor,
                eta,
            } => (rel_floor, abs_floor, eta),
        };
        if !(rel.is_finite() && rel >= 0.0) {
            return Err(TrackError::BadParameter {
                name: "rel_floor",
                reason: format!("must be finite and >= 0, got {rel}"),
            });
        }
        if !(abs.is_finite() && abs > 0.0) {
            return Err(TrackError::BadParameter {
                name: "abs_floor",
                reason: format!("must be finite and > 0, got {abs}"),
            });
        }
        if !(eta.is_finite() && eta > 0.0) {
            return Err(TrackError::BadParameter {
                name: "eta",
                reason: format!("must be finite and > 0, got {eta}"),
            });
        }
        Ok(())
    }
}

/// The Newton displacement `d` (the update is `x - d`) under `damping`, and
/// whether the Hessian had to be modified; [`TrackError::SingularHessian`] for a
/// singular Hessian under [`NewtonDamping::Plain`].
fn newton_displacement<const D: usize>(
    h: &MatD<D>,
    g: &Point<D>,
    damping: &NewtonDamping,
) -> Result<(Point<D>, bool), TrackError> {
    if D != 2 {
        return newton_displacement_eigen(h, g, damping);
    }
    let h = Mat2::from_fn(|i, j| h[(i, j)]);
    let g = Vec2::new(g[0], g[1]);
    let to_d = |v: Vec2| Point::<D>::from_fn(|i, _| v[i]);
    newton_displacement_2d(&h, &g, damping).map(|(d, damped)| (to_d(d), damped))
}

/// The floors of `damping`: `(rel_floor, abs_floor)`.
fn floors(damping: &NewtonDamping) -> (f64, f64) {
    match *damping {
        NewtonDamping::AbsEigen {
            rel_floor,
            abs_floor,
        }
        | NewtonDamping::Plain {
            rel_floor,
            abs_floor,
        }
        | NewtonDamping::GradientFallback {
            rel_floor,
            abs_floor,
            ..
        } => (rel_floor, abs_floor),
    }
}

/// [`newton_displacement`] in any dimension from the symmetric
/// eigendecomposition `H = V diag(l) V^T` (the 2-D closed form below is the
/// same rule).
fn newton_displacement_eigen<const D: usize>(
    h: &MatD<D>,
    g: &Point<D>,
    damping: &NewtonDamping,
) -> Result<(Point<D>, bool), TrackError> {
    let sym = (h + h.transpose()) * 0.5;
    let (l, v) = sym_eigen(&sym).ok_or(TrackError::NonFiniteResult("Hessian eigenvalues"))?;
    let (lo, hi) = (l[0], l[D - 1]);
    let (rel, abs) = floors(damping);
    let floor = (rel * l.amax()).max(abs);
    let solve = || lu_solve(&sym, g).ok_or(TrackError::SingularHessian(hi, lo));
    if lo >= floor {
        return Ok((solve()?, false));
    }
    Ok(match *damping {
        NewtonDamping::Plain { .. } => {
            if l.iter().any(|x| x.abs() < floor) {
                return Err(TrackError::SingularHessian(hi, lo));
            }
            (solve()?, false)
        }
        NewtonDamping::AbsEigen { .. } => {
            let mut d = Point::<D>::zeros();
            for k in 0..D {
                let vk = v.column(k);
                d += vk * (vk.dot(g) / l[k].abs().max(floor));
            }
            (d, true)
        }
        NewtonDamping::GradientFallback { eta, .. } => (g * eta, true),
    })
}

/// [`newton_displacement`] for a 2x2 Hessian, in closed form.
fn newton_displacement_2d(
    h: &Mat2,
    g: &Vec2,
    damping: &NewtonDamping,
) -> Result<(Vec2, bool), TrackError> {
    let a = h[(0, 0)];
    let b = 0.5 * (h[(0, 1)] + h[(1, 0)]);
    let c = h[(1, 1)];
    let mean = 0.5 * (a + c);
    let hd = 0.5 * (a - c);
    // Entries are bounded by ~|e| / (1e-12 (1 + ||p||)) (see `COINCIDENT_REL`),
    // far from overflow in the squares, so no `hypot` is needed.
    let rad = (hd * hd + b * b).sqrt();
    let l1 = mean + rad;
    let l2 = mean - rad;
    let (rel, abs) = match *damping {
        NewtonDamping::AbsEigen {
            rel_floor,
            abs_floor,
        }
        | NewtonDamping::Plain {
            rel_floor,
            abs_floor,
        }
        | NewtonDamping::GradientFallback {
            rel_floor,
            abs_floor,
            ..
        } => (rel_floor, abs_floor),
    };
    let floor = (rel * l1.abs().max(l2.abs())).max(abs);
    if l2 >= floor {
        // Plain Newton step: explicit inverse of the SPD 2x2 matrix.
        let det = l1 * l2;
        return Ok((Vec2::new(c * g.x - b * g.y, a * g.y - b * g.x) / det, false));
    }
    Ok(match *damping {
        NewtonDamping::Plain { .. } => {
            if l1.abs().min(l2.abs()) < floor {
                return Err(TrackError::SingularHessian(l1, l2));
            }
            // Indefinite but invertible: the same explicit inverse.
            let det = l1 * l2;
            (Vec2::new(c * g.x - b * g.y, a * g.y - b * g.x) / det, false)
        }
        NewtonDamping::AbsEigen { .. } => {
            // Eigenvector of l1, computed in the cancellation-free branch.
            let v = if hd >= 0.0 {
                Vec2::new(hd + rad, b)
            } else {
                Vec2::new(b, rad - hd)
            };
            let vn = v.norm();
            let v1 = if vn > f64::MIN_POSITIVE {
                v / vn
            } else {
                Vec2::new(1.0, 0.0)
            };
            let v2 = Vec2::new(-v1.y, v1.x);
            let m1 = l1.abs().max(floor);
            let m2 = l2.abs().max(floor);
            (v1 * (v1.dot(g) / m1) + v2 * (v2.dot(g) / m2), true)
        }
        NewtonDamping::GradientFallback { eta, .. } => (g * eta, true),
    })
}

/// A centralised online tracker: one update per sample. Object safe, so a
/// coordinator can run a `Vec<Box<dyn Tracker>>` side by side.
pub trait Tracker<const D: usize = 2>: Send {
    /// Short label for logs and CSV columns (e.g. `"ogd"`, `"onm"`).
    fn name(&self) -> &str;
    /// The current estimate `x_t` (`x_0` before the first step).
    fn estimate(&self) -> Point<D>;
    /// Restart from `x0`. Errors if `x0` is not finite.
    fn reset(&mut self, x0: Point<D>) -> Result<(), TrackError>;
    /// Process sample `t` (1-based): `x_t = update(x_{t-1}, f_t)`, return `x_t`.
    /// On error the estimate is left unchanged.
    fn step(
        &mut self,
        geometry: &Geometry<D>,
        sample: &SampleMeasurements,
        t: usize,
    ) -> Result<Point<D>, TrackError>;
}

fn check_x0<const D: usize>(x0: &Point<D>) -> Result<(), TrackError> {
    if x0.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(TrackError::NonFinite("initial estimate x0"))
    }
}

fn commit<const D: usize>(x: Point<D>, what: &'static str) -> Result<Point<D>, TrackError> {
    if x.iter().all(|v| v.is_finite()) {
        Ok(x)
    } else {
        Err(TrackError::NonFiniteResult(what))
    }
}

/// Online gradient descent, Pun-So 2022 eq. (3):
/// `x_t = x_{t-1} - eta_t grad f_t(x_{t-1})`.
#[derive(Debug, Clone, PartialEq)]
pub struct OgdTracker<const D: usize = 2> {
    name: String,
    x: Point<D>,
    step: StepSize,
}

impl<const D: usize> OgdTracker<D> {
    /// A tracker starting at `x0` (named `"ogd"`).
    pub fn new(x0: Point<D>, step: StepSize) -> Result<Self, TrackError> {
        check_x0(&x0)?;
        step.validate()?;
        Ok(OgdTracker {
            name: "ogd".into(),
            x: x0,
            step,
        })
    }

    /// Rename (for running several OGD variants side by side).
    pub fn with_name(mut self, name: impl Into<String>) -> Self {
        self.name = name.into();
        self
    }
}

impl<const D: usize> Tracker<D> for OgdTracker<D> {
    fn name(&self) -> &str {
        &self.name
    }

    fn estimate(&self) -> Point<D> {
        self.x
    }

    fn reset(&mut self, x0: Point<D>) -> Result<(), TrackError> {
        check_x0(&x0)?;
        self.x = x0;
        Ok(())
    }

    fn step(
        &mut self,
        geometry: &Geometry<D>,
        sample: &SampleMeasurements,
        t: usize,
    ) -> Result<Point<D>, TrackError> {
        if t == 0 {
            return Err(TrackError::ZeroTime);
        }
        let (ev, eta) = match self.step {
            StepSize::Lipschitz { scale } => {
                let ev = loss_grad_hess(geometry, sample, &self.x)?;
                // A flat f_t (no curvature at all) takes no step.
                let l = sym_norm(&ev.hess);
                (ev, if l > 0.0 { scale / l } else { 0.0 })
            }
            rule => (loss_grad(geometry, sample, &self.x)?, rule.at(t)),
        };
        let x = commit(self.x - eta * ev.grad, "OGD update")?;
        self.x = x;
        Ok(x)
    }
}

/// Online Newton method, Pun-So 2022 Sec. V (after Lesage-Landry et al., Pun-So 2022 ref. 23):
/// `x_t = x_{t-1} - (hess f_t(x_{t-1}))^{-1} grad f_t(x_{t-1})`, with the
/// [`NewtonDamping`] modification when the Hessian is not safely positive
/// definite. Never returns a non-finite estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct OnmTracker<const D: usize = 2> {
    name: String,
    x: Point<D>,
    damping: NewtonDamping,
    damped_steps: usize,
}

impl<const D: usize> OnmTracker<D> {
    /// A tracker starting at `x0` (named `"onm"`).
    pub fn new(x0: Point<D>, damping: NewtonDamping) -> Result<Self, TrackError> {
        check_x0(&x0)?;
        damping.validate()?;
        Ok(OnmTracker {
            name: "onm".into(),
            x: x0,
            damping,
            damped_steps: 0,
        })
    }

    /// Rename (for running several ONM variants side by side).
    pub fn with_name(mut self, name: impl Into<String>) -> Self {
        self.name = name.into();
        self
    }

    /// How many steps since construction or [`Tracker::reset`] used the
    /// modified (non-Newton) update.
    pub fn damped_steps(&self) -> usize {
        self.damped_steps
    }
}

impl<const D: usize> Tracker<D> for OnmTracker<D> {
    fn name(&self) -> &str {
        &self.name
    }

    fn estimate(&self) -> Point<D> {
        self.x
    }

    fn reset(&mut self, x0: Point<D>) -> Result<(), TrackError> {
        check_x0(&x0)?;
        self.x = x0;
        self.damped_steps = 0;
        Ok(())
    }

    fn step(
        &mut self,
        geometry: &Geometry<D>,
        sample: &SampleMeasurements,
        t: usize,
    ) -> Result<Point<D>, TrackError> {
        if t == 0 {
            return Err(TrackError::ZeroTime);
        }
        let ev = loss_grad_hess(geometry, sample, &self.x)?;
        let (d, damped) = newton_displacement(&ev.hess, &ev.grad, &self.damping)?;
        let x = commit(self.x - d, "ONM update")?;
        self.x = x;
        self.damped_steps += usize::from(damped);
        Ok(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::measure::NodeMeasurements;
    use crate::model::motion::Walk;
    use crate::model::rng::{SonarRng, Stream, stream_rng};
    use approx::assert_abs_diff_eq;
    use proptest::prelude::*;
    use rand_distr::{Distribution, StandardNormal};

    /// Pun-So 2022 / 001 Sec. V anchors.
    fn paper_geometry() -> Geometry {
        Geometry {
            drift: Vec::new(),
            transmitters: vec![],
            receivers: vec![
                Vec2::new(0.5, 0.5),
                Vec2::new(0.0, 0.5),
                Vec2::new(0.5, 0.0),
            ],
        }
    }

    /// Two transmitters, four receivers: bistatic at every receiver, one-way at two.
    fn mixed_geometry() -> Geometry {
        Geometry {
            drift: Vec::new(),
            transmitters: vec![Vec2::new(-1.0, 0.3), Vec2::new(2.5, -0.7)],
            receivers: vec![
                Vec2::new(0.0, 0.0),
                Vec2::new(1.0, 2.0),
                Vec2::new(-0.5, 1.5),
                Vec2::new(2.0, 1.0),
            ],
        }
    }

    fn gauss(rng: &mut SonarRng) -> f64 {
        StandardNormal.sample(rng)
    }

    /// One-way ranges at every receiver, noise `sigma`.
    fn toa_sample(g: &Geometry, x: &Vec2, sigma: f64, rng: &mut SonarRng) -> SampleMeasurements {
        SampleMeasurements {
            nodes: g
                .receivers
                .iter()
                .map(|a| NodeMeasurements {
                    range: Some((x - a).norm() + sigma * gauss(rng)),
                    ..Default::default()
                })
                .collect(),
        }
    }

    /// Bistatic ranges from every transmitter at every receiver, one-way
    /// ranges at even receivers, and a DOA (ignored by the loss).
    fn mixed_sample(g: &Geometry, x: &Vec2, sigma: f64, rng: &mut SonarRng) -> SampleMeasurements {
        SampleMeasurements {
            nodes: g
                .receivers
                .iter()
                .enumerate()
                .map(|(n, r)| NodeMeasurements {
                    elevation: None,
                    bistatic: g
                        .transmitters
                        .iter()
                        .enumerate()
                        .map(|(m, t)| (m, (x - t).norm() + (x - r).norm() + sigma * gauss(rng)))
                        .collect(),
                    doa: Some(1.234),
                    range: (n % 2 == 0).then(|| (x - r).norm() + sigma * gauss(rng)),
                })
                .collect(),
        }
    }

    fn bistatic_only(s: &SampleMeasurements) -> SampleMeasurements {
        SampleMeasurements {
            nodes: s
                .nodes
                .iter()
                .map(|n| NodeMeasurements {
                    bistatic: n.bistatic.clone(),
                    ..Default::default()
                })
                .collect(),
        }
    }

    fn min_focus_dist(g: &Geometry, x: &Vec2) -> f64 {
        g.receivers
            .iter()
            .chain(&g.transmitters)
            .map(|p| (x - p).norm())
            .fold(f64::INFINITY, f64::min)
    }

    fn check_derivatives(g: &Geometry, s: &SampleMeasurements, x: &Vec2) {
        let ev = loss_grad_hess(g, s, x).unwrap();
        let h = 1e-6;
        for k in 0..2 {
            let mut e = Vec2::zeros();
            e[k] = h;
            let fp = loss(g, s, &(x + e)).unwrap();
            let fm = loss(g, s, &(x - e)).unwrap();
            let fd = (fp - fm) / (2.0 * h);
            assert_abs_diff_eq!(ev.grad[k], fd, epsilon = 1e-6 * (1.0 + ev.grad[k].abs()));
            let gp = loss_grad(g, s, &(x + e)).unwrap().grad;
            let gm = loss_grad(g, s, &(x - e)).unwrap().grad;
            let col = (gp - gm) / (2.0 * h);
            for j in 0..2 {
                assert_abs_diff_eq!(
                    ev.hess[(j, k)],
                    col[j],
                    epsilon = 1e-5 * (1.0 + ev.hess[(j, k)].abs())
                );
            }
        }
        // The gradient-only path agrees with the full evaluation.
        let evg = loss_grad(g, s, x).unwrap();
        assert_abs_diff_eq!(evg.value, ev.value, epsilon = 1e-12);
        assert_abs_diff_eq!((evg.grad - ev.grad).norm(), 0.0, epsilon = 1e-12);
    }

    proptest! {
        #[test]
        fn gradient_and_hessian_match_finite_differences_for_toa(
            px in -3.0..3.0f64, py in -3.0..3.0f64,
            tx in -3.0..3.0f64, ty in -3.0..3.0f64,
            sigma in 0.0..0.5f64, seed in any::<u64>(),
        ) {
            let g = paper_geometry();
            let x = Vec2::new(px, py);
            prop_assume!(min_focus_dist(&g, &x) > 0.05);
            let mut rng = stream_rng(seed, Stream::Aux, 0);
            let s = toa_sample(&g, &Vec2::new(tx, ty), sigma, &mut rng);
            check_derivatives(&g, &s, &x);
        }

        #[test]
        fn gradient_and_hessian_match_finite_differences_for_bistatic_and_toa(
            px in -3.0..3.0f64, py in -3.0..3.0f64,
            tx in -3.0..3.0f64, ty in -3.0..3.0f64,
            sigma in 0.0..0.5f64, seed in any::<u64>(),
        ) {
            let g = mixed_geometry();
            let x = Vec2::new(px, py);
            prop_assume!(min_focus_dist(&g, &x) > 0.05);
            let mut rng = stream_rng(seed, Stream::Aux, 1);
            let s = mixed_sample(&g, &Vec2::new(tx, ty), sigma, &mut rng);
            check_derivatives(&g, &s, &x);
        }

        /// Degenerate geometry: target on an anchor, start on an anchor,
        /// collinear anchors, arbitrary noise. ONM must return a finite estimate.
        #[test]
        fn onm_never_returns_nan_on_degenerate_geometry(
            anchor_idx in 0usize..3,
            start_on_anchor in any::<bool>(),
            collinear in any::<bool>(),
            ox in -1.0..1.0f64, oy in -1.0..1.0f64,
            sigma in 0.0..1.0f64, seed in any::<u64>(),
            fallback in any::<bool>(),
        ) {
            let g = if collinear {
                Geometry { drift: Vec::new(), transmitters: vec![], receivers: vec![
                    Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(2.0, 0.0)] }
            } else {
                paper_geometry()
            };
            let a = g.receivers[anchor_idx];
            // Target exactly on an anchor (or on the anchors' line when collinear).
            let target = if collinear { Vec2::new(a.x + ox, 0.0) } else { a };
            let start = if start_on_anchor { a } else { Vec2::new(a.x + ox, if collinear { 0.0 } else { a.y + oy }) };
            let damping = if fallback {
                NewtonDamping::GradientFallback { rel_floor: 1e-6, abs_floor: 1e-12, eta: 0.1 }
            } else {
                NewtonDamping::default()
            };
            let mut onm = OnmTracker::new(start, damping).unwrap();
            let mut rng = stream_rng(seed, Stream::Aux, 2);
            for t in 1..=20 {
                let s = toa_sample(&g, &target, sigma, &mut rng);
                let x = onm.step(&g, &s, t).unwrap();
                prop_assert!(x.x.is_finite() && x.y.is_finite());
            }
        }
    }

    #[test]
    fn loss_ignores_doa_and_counts_terms() {
        let g = mixed_geometry();
        let mut rng = stream_rng(1, Stream::Aux, 3);
        let x = Vec2::new(0.7, 0.4);
        let s = mixed_sample(&g, &Vec2::new(0.8, 0.2), 0.1, &mut rng);
        let mut s2 = s.clone();
        for n in &mut s2.nodes {
            n.doa = None;
        }
        assert_abs_diff_eq!(
            loss(&g, &s, &x).unwrap(),
            loss(&g, &s2, &x).unwrap(),
            epsilon = 0.0
        );
        assert_eq!(term_count(&s), 4 * 2 + 2);
        let ev = loss_grad(&g, &s, &x).unwrap();
        assert_eq!(ev.terms, 10);
        assert_abs_diff_eq!(ev.weight, 4.0 * 8.0 + 2.0, epsilon = 0.0);
    }

    #[test]
    fn loss_is_zero_at_the_truth_without_noise_and_matches_hand_computation() {
        let g = mixed_geometry();
        let mut rng = stream_rng(2, Stream::Aux, 0);
        let truth = Vec2::new(0.3, 0.9);
        let s = mixed_sample(&g, &truth, 0.0, &mut rng);
        let ev = loss_grad_hess(&g, &s, &truth).unwrap();
        assert_abs_diff_eq!(ev.value, 0.0, epsilon = 1e-24);
        assert_abs_diff_eq!(ev.grad.norm(), 0.0, epsilon = 1e-12);
        // Single one-way range: f = (||x - a|| - r)^2.
        let g1 = Geometry {
            drift: Vec::new(),
            transmitters: vec![],
            receivers: vec![Vec2::new(1.0, 1.0)],
        };
        let s1 = SampleMeasurements {
            nodes: vec![NodeMeasurements {
                range: Some(2.0),
                ..Default::default()
            }],
        };
        let x = Vec2::new(4.0, 5.0); // distance 5
        assert_abs_diff_eq!(loss(&g1, &s1, &x).unwrap(), 9.0, epsilon = 1e-12);
    }

    #[test]
    fn loss_on_a_focus_uses_the_zero_subgradient() {
        let g = paper_geometry();
        let s = SampleMeasurements {
            nodes: vec![
                NodeMeasurements {
                    range: Some(0.3),
                    ..Default::default()
                },
                NodeMeasurements::default(),
                NodeMeasurements::default(),
            ],
        };
        let ev = loss_grad_hess(&g, &s, &g.receivers[0]).unwrap();
        assert_abs_diff_eq!(ev.value, 0.09, epsilon = 1e-15);
        assert_abs_diff_eq!(ev.grad.norm(), 0.0, epsilon = 0.0);
        assert_abs_diff_eq!(ev.hess.norm(), 0.0, epsilon = 0.0);
    }

    #[test]
    fn bad_inputs_give_typed_errors_and_leave_the_estimate_unchanged() {
        let g = paper_geometry();
        let mut rng = stream_rng(3, Stream::Aux, 0);
        let good = toa_sample(&g, &Vec2::new(2.0, 1.0), 0.01, &mut rng);
        let x0 = Vec2::new(2.0, 1.0);
        let mut trackers: Vec<Box<dyn Tracker>> = vec![
            Box::new(OgdTracker::new(x0, StepSize::Constant { eta: 0.1 }).unwrap()),
            Box::new(OnmTracker::new(x0, NewtonDamping::default()).unwrap()),
        ];
        let mut nan = good.clone();
        nan.nodes[1].range = Some(f64::NAN);
        let mut inf_bi = good.clone();
        inf_bi.nodes[0].bistatic.push((0, f64::INFINITY));
        let mut bad_tx = good.clone();
        bad_tx.nodes[0].bistatic.push((0, 1.0));
        let mut too_many = good.clone();
        too_many.nodes.push(NodeMeasurements::default());
        for tr in &mut trackers {
            assert_eq!(
                tr.step(&g, &nan, 1),
                Err(TrackError::NonFinite("one-way range"))
            );
            assert!(matches!(
                tr.step(&g, &bad_tx, 1),
                Err(TrackError::UnknownTransmitter { m: 0, count: 0, .. })
            ));
            assert!(matches!(
                tr.step(&g, &inf_bi, 1),
                Err(TrackError::UnknownTransmitter { .. })
            ));
            assert!(matches!(
                tr.step(&g, &too_many, 1),
                Err(TrackError::TooManyNodes {
                    nodes: 4,
                    receivers: 3
                })
            ));
            assert_eq!(tr.step(&g, &good, 0), Err(TrackError::ZeroTime));
            assert_abs_diff_eq!((tr.estimate() - x0).norm(), 0.0, epsilon = 0.0);
            assert!(tr.reset(Vec2::new(f64::NAN, 0.0)).is_err());
            assert!(tr.step(&g, &good, 1).is_ok());
        }
        let gm = mixed_geometry();
        let mut sm = mixed_sample(&gm, &x0, 0.0, &mut rng);
        sm.nodes[1].bistatic[0].1 = f64::INFINITY;
        assert_eq!(
            loss(&gm, &sm, &x0),
            Err(TrackError::NonFinite("bistatic range"))
        );
        let mut gnan = g.clone();
        gnan.receivers[2].x = f64::NAN;
        assert!(matches!(
            loss(&gnan, &good, &x0),
            Err(TrackError::NonFiniteResult(_))
        ));
        assert!(OgdTracker::new(x0, StepSize::Constant { eta: -1.0 }).is_err());
        assert!(OgdTracker::new(x0, StepSize::InvSqrt { eta0: f64::NAN }).is_err());
        assert!(
            OnmTracker::new(
                x0,
                NewtonDamping::AbsEigen {
                    rel_floor: 0.0,
                    abs_floor: 0.0
                }
            )
            .is_err()
        );
        assert!(
            OgdTracker::new(
                Vec2::new(f64::INFINITY, 0.0),
                StepSize::Constant { eta: 0.1 }
            )
            .is_err()
        );
    }

    #[test]
    fn ogd_on_a_static_target_with_zero_noise_converges_to_it() {
        let g = paper_geometry();
        let truth = Vec2::new(2.0, 1.0);
        let mut rng = stream_rng(4, Stream::Aux, 0);
        let s = toa_sample(&g, &truth, 0.0, &mut rng);
        // lambda_min(hess) ~ 0.13 here: sum eta_t lambda_min must reach ~ 25.
        for (step, steps) in [
            (StepSize::Constant { eta: 0.1 }, 20_000),
            (StepSize::InvSqrt { eta0: 0.3 }, 200_000),
        ] {
            let mut ogd = OgdTracker::new(Vec2::new(2.3, 0.6), step).unwrap();
            let mut x = ogd.estimate();
            for t in 1..=steps {
                x = ogd.step(&g, &s, t).unwrap();
            }
            assert_abs_diff_eq!((x - truth).norm(), 0.0, epsilon = 1e-9);
        }
    }

    #[test]
    fn onm_with_zero_noise_near_the_truth_converges_quadratically() {
        for (g, truth, s) in [
            {
                let g = paper_geometry();
                let t = Vec2::new(2.0, 1.0);
                let s = toa_sample(&g, &t, 0.0, &mut stream_rng(5, Stream::Aux, 0));
                (g, t, s)
            },
            {
                let g = mixed_geometry();
                let t = Vec2::new(0.6, 0.8);
                let s = mixed_sample(&g, &t, 0.0, &mut stream_rng(5, Stream::Aux, 1));
                (g, t, bistatic_only(&s))
            },
        ] {
            let mut onm =
                OnmTracker::new(truth + Vec2::new(0.02, -0.015), NewtonDamping::default()).unwrap();
            let mut errs = vec![(onm.estimate() - truth).norm()];
            for t in 1..=6 {
                errs.push((onm.step(&g, &s, t).unwrap() - truth).norm());
            }
            // e_{k+1} <= C e_k^2 while the error is above rounding level.
            for w in errs.windows(2) {
                if w[0] > 1e-7 {
                    assert!(w[1] <= 20.0 * w[0] * w[0], "errors {errs:?}");
                }
            }
            assert!(errs[4] < 1e-12, "errors {errs:?}");
            assert_eq!(onm.damped_steps(), 0);
        }
    }

    #[test]
    fn onm_gradient_fallback_takes_a_gradient_step_when_the_hessian_is_indefinite() {
        let g = paper_geometry();
        // Ranges much larger than the distance: the curvature term 2 e/d is very negative.
        let s = SampleMeasurements {
            nodes: (0..3)
                .map(|_| NodeMeasurements {
                    range: Some(5.0),
                    ..Default::default()
                })
                .collect(),
        };
        let x0 = Vec2::new(0.4, 0.4);
        let ev = loss_grad_hess(&g, &s, &x0).unwrap();
        assert!(ev.hess.symmetric_eigenvalues().min() < 0.0);
        let mut fb = OnmTracker::new(
            x0,
            NewtonDamping::GradientFallback {
                rel_floor: 1e-6,
                abs_floor: 1e-12,
                eta: 0.05,
            },
        )
        .unwrap();
        let x = fb.step(&g, &s, 1).unwrap();
        assert_abs_diff_eq!((x - (x0 - 0.05 * ev.grad)).norm(), 0.0, epsilon = 1e-15);
        assert_eq!(fb.damped_steps(), 1);
        // AbsEigen: the modified step is a descent direction.
        let mut ae = OnmTracker::new(x0, NewtonDamping::default()).unwrap();
        let x = ae.step(&g, &s, 1).unwrap();
        assert!((x - x0).dot(&ev.grad) < 0.0);
        assert_eq!(ae.damped_steps(), 1);
    }

    #[test]
    fn newton_displacement_matches_the_inverse_hessian_on_random_spd_matrices() {
        let mut rng = stream_rng(6, Stream::Aux, 0);
        for _ in 0..1000 {
            let m = Mat2::new(
                gauss(&mut rng),
                gauss(&mut rng),
                gauss(&mut rng),
                gauss(&mut rng),
            );
            let h = m * m.transpose() + Mat2::identity() * 0.1;
            let gv = Vec2::new(gauss(&mut rng), gauss(&mut rng));
            let (d, damped) = newton_displacement(&h, &gv, &NewtonDamping::default()).unwrap();
            let want = h.try_inverse().unwrap() * gv;
            assert!(!damped);
            assert_abs_diff_eq!((d - want).norm(), 0.0, epsilon = 1e-9 * (1.0 + want.norm()));
        }
        // H = 0: finite (capped) step.
        let (d, damped) = newton_displacement(
            &Mat2::zeros(),
            &Vec2::new(1e-3, 0.0),
            &NewtonDamping::default(),
        )
        .unwrap();
        assert!(damped && d.x.is_finite() && d.y.is_finite());
        // Diagonal indefinite: eigenvalue magnitudes are used.
        let (d, _) = newton_displacement(
            &Mat2::new(2.0, 0.0, 0.0, -4.0),
            &Vec2::new(1.0, 1.0),
            &NewtonDamping::default(),
        )
        .unwrap();
        assert_abs_diff_eq!((d - Vec2::new(0.5, 0.25)).norm(), 0.0, epsilon = 1e-15);
    }

    #[test]
    fn the_plain_newton_step_inverts_an_indefinite_hessian_and_refuses_a_singular_one() {
        let plain = NewtonDamping::Plain {
            rel_floor: 1e-9,
            abs_floor: 1e-12,
        };
        // Indefinite: the unmodified inverse, d = H^-1 g (towards the saddle).
        let h = Mat2::new(2.0, 1.0, 1.0, -4.0);
        let g = Vec2::new(1.0, 1.0);
        let (d, damped) = newton_displacement(&h, &g, &plain).unwrap();
        let want = h.try_inverse().unwrap() * g;
        assert!(!damped);
        assert_abs_diff_eq!((d - want).norm(), 0.0, epsilon = 1e-15);
        // PD: the same step as the default damping.
        let spd = Mat2::new(3.0, 0.5, 0.5, 1.0);
        let a = newton_displacement(&spd, &g, &plain).unwrap();
        let b = newton_displacement(&spd, &g, &NewtonDamping::default()).unwrap();
        assert_eq!(a, b);
        // Singular (one zero eigenvalue, the other negative): an error naming it.
        let sing = Mat2::new(0.0, 0.0, 0.0, -3.0);
        assert!(matches!(
            newton_displacement(&sing, &g, &plain),
            Err(TrackError::SingularHessian(..))
        ));
        // From a TOML table, as a scenario gives it.
        let v: NewtonDamping =
            toml::from_str("kind = \"plain\"\nrel_floor = 1e-9\nabs_floor = 1e-12").unwrap();
        assert_eq!(v, plain);
    }

    /// Brute-force global minimiser of `f` on `[lo, hi]^2`: a 501^2 grid, then
    /// 201^2 grids over `+-10` spacings around the best point, each 10x finer,
    /// down to a spacing below `1e-7`. (Wide windows: the loss has valleys
    /// with curvature ratio ~ 50, so the coarse best point can be several
    /// spacings away from the minimiser along the valley.)
    fn grid_argmin(g: &Geometry, s: &SampleMeasurements, lo: f64, hi: f64) -> Vec2 {
        let mut best = (f64::INFINITY, Vec2::zeros());
        let n = 500;
        let mut h = (hi - lo) / n as f64;
        for i in 0..=n {
            for j in 0..=n {
                let x = Vec2::new(lo + i as f64 * h, lo + j as f64 * h);
                let f = loss(g, s, &x).unwrap();
                if f < best.0 {
                    best = (f, x);
                }
            }
        }
        while h > 1e-7 {
            let c = best.1;
            let (mut bi, mut bj) = (100, 100);
            let hn = h / 10.0;
            for i in 0..=200 {
                for j in 0..=200 {
                    let x = c + Vec2::new((i as f64 - 100.0) * hn, (j as f64 - 100.0) * hn);
                    let f = loss(g, s, &x).unwrap();
                    if f < best.0 {
                        best = (f, x);
                        (bi, bj) = (i, j);
                    }
                }
            }
            // The minimiser must be inside the window, else the grid search is inconclusive.
            assert!(
                (1..200).contains(&bi) && (1..200).contains(&bj),
                "window too small"
            );
            h = hn;
        }
        best.1
    }

    #[test]
    fn x_hat_by_gradient_descent_matches_a_brute_force_grid_minimiser() {
        let g = paper_geometry();
        for (k, sigma) in [1e-4, 1e-2, 5e-2].into_iter().enumerate() {
            let mut rng = stream_rng(7, Stream::Aux, k as u64);
            let truth = Vec2::new(2.0 + 0.3 * gauss(&mut rng), 1.0 + 0.3 * gauss(&mut rng));
            let s = toa_sample(&g, &truth, sigma, &mut rng);
            let xh = x_hat(&g, &s, truth, &XHatOptions::default()).unwrap();
            assert!(xh.converged, "{xh:?}");
            let xg = grid_argmin(&g, &s, -2.0, 5.0);
            assert_abs_diff_eq!((xh.x - xg).norm(), 0.0, epsilon = 1e-6);
            assert!(xh.value <= loss(&g, &s, &xg).unwrap() + 1e-12);
        }
        // Bistatic + one-way: default step 1/m_eff still converges to the grid minimiser.
        let gm = mixed_geometry();
        let truth = Vec2::new(0.6, 0.8);
        let s = mixed_sample(&gm, &truth, 0.02, &mut stream_rng(7, Stream::Aux, 9));
        let xh = x_hat(&gm, &s, truth, &XHatOptions::default()).unwrap();
        assert!(xh.converged, "{xh:?}");
        let xg = grid_argmin(&gm, &s, -1.5, 3.0);
        assert_abs_diff_eq!((xh.x - xg).norm(), 0.0, epsilon = 1e-6);
    }

    #[test]
    fn regret_and_ctte_accumulate_their_terms() {
        let g = paper_geometry();
        let truth = Vec2::new(2.0, 1.0);
        let s = toa_sample(&g, &truth, 0.01, &mut stream_rng(8, Stream::Aux, 0));
        let xh = x_hat(&g, &s, truth, &XHatOptions::default()).unwrap();
        let mut reg = DynamicRegret::default();
        let mut ctte = Ctte::default();
        let pts = [Vec2::new(2.1, 1.0), Vec2::new(1.9, 1.2), xh.x];
        let mut want_r = 0.0;
        let mut want_c = 0.0;
        for p in &pts {
            let term = regret_term(&g, &s, p, &xh).unwrap();
            assert!(term >= -1e-15);
            want_r += loss(&g, &s, p).unwrap() - xh.value;
            want_c += (p - truth).norm();
            reg.push(term);
            ctte.push(p, &truth);
        }
        assert_abs_diff_eq!(reg.sum, want_r, epsilon = 1e-15);
        assert_abs_diff_eq!(ctte.sum, want_c, epsilon = 1e-15);
        assert_abs_diff_eq!(ctte.mean(), want_c / 3.0, epsilon = 1e-15);
        assert_eq!((reg.count, ctte.count), (3, 3));
    }

    #[test]
    fn ols_recovers_the_position_from_noise_free_ranges() {
        let g = paper_geometry();
        let truth = Vec2::new(2.0, 1.0);
        let s = toa_sample(&g, &truth, 0.0, &mut stream_rng(9, Stream::Aux, 0));
        let x = Init::Ols.initial_estimate(&g, &s, Vec2::zeros()).unwrap();
        assert_abs_diff_eq!((x - truth).norm(), 0.0, epsilon = 1e-12);
        let x = Init::Exact.initial_estimate(&g, &s, truth).unwrap();
        assert_abs_diff_eq!((x - truth).norm(), 0.0, epsilon = 0.0);
        // Bistatic only, two transmitters (transmitter-lifted: 4 unknowns, 8 rows).
        let gm = mixed_geometry();
        let truth = Vec2::new(0.6, 0.8);
        let sb = bistatic_only(&mixed_sample(
            &gm,
            &truth,
            0.0,
            &mut stream_rng(9, Stream::Aux, 1),
        ));
        let x = ols_position(&gm, &sb).unwrap();
        assert_abs_diff_eq!((x - truth).norm(), 0.0, epsilon = 1e-9);
        // One transmitter, many receivers.
        let g1 = Geometry {
            drift: Vec::new(),
            transmitters: vec![gm.transmitters[0]],
            receivers: gm.receivers.clone(),
        };
        let mut s1 = sb.clone();
        for n in &mut s1.nodes {
            n.bistatic.truncate(1);
        }
        let x = ols_position(&g1, &s1).unwrap();
        assert_abs_diff_eq!((x - truth).norm(), 0.0, epsilon = 1e-9);
        // Many transmitters, one receiver: the receiver-lifted system is used.
        let g2 = Geometry {
            drift: Vec::new(),
            transmitters: gm.receivers.clone(),
            receivers: vec![gm.transmitters[1]],
        };
        let s2 = SampleMeasurements {
            nodes: vec![NodeMeasurements {
                bistatic: g2
                    .transmitters
                    .iter()
                    .enumerate()
                    .map(|(m, t)| (m, (truth - t).norm() + (truth - g2.receivers[0]).norm()))
                    .collect(),
                ..Default::default()
            }],
        };
        let x = ols_position(&g2, &s2).unwrap();
        assert_abs_diff_eq!((x - truth).norm(), 0.0, epsilon = 1e-9);
    }

    #[test]
    fn ols_toa_recovers_the_position_from_exact_ranges() {
        let mut rng = stream_rng(3, Stream::Aux, 0);
        for _ in 0..100 {
            let x = Vec2::new(rng.random_range(-50.0..50.0), rng.random_range(-50.0..50.0));
            let anchors: Vec<(Vec2, f64)> = (0..5)
                .map(|_| {
                    let a = Vec2::new(
                        rng.random_range(-100.0..100.0),
                        rng.random_range(-100.0..100.0),
                    );
                    (a, (x - a).norm())
                })
                .collect();
            let xh = ols_toa(&anchors).unwrap();
            assert!((xh - x).norm() < 1e-8, "{xh:?} vs {x:?}");
        }
    }

    #[test]
    fn ols_toa_matches_the_normal_equations_of_seed_000_eq_15_to_17() {
        // Noisy ranges: a direct dense evaluation of eq. (15)-(17).
        let anchors = [
            (Vec2::new(0.5, 0.5), 0.31),
            (Vec2::new(0.0, 0.5), 0.52),
            (Vec2::new(0.5, 0.0), 0.47),
            (Vec2::new(1.0, 1.2), 0.9),
        ];
        let m = anchors.len();
        let mut a = nalgebra::DMatrix::<f64>::zeros(m - 1, 2);
        let mut b = nalgebra::DVector::<f64>::zeros(m - 1);
        for i in 0..m - 1 {
            let ((a0, r0), (a1, r1)) = (anchors[i], anchors[i + 1]);
            let row = a1 - a0;
            a[(i, 0)] = row.x;
            a[(i, 1)] = row.y;
            b[i] = 0.5 * (a1.norm_squared() - a0.norm_squared() + r0 * r0 - r1 * r1);
        }
        let direct = (a.transpose() * &a).try_inverse().unwrap() * a.transpose() * b;
        let xh = ols_toa(&anchors).unwrap();
        assert!((xh - Vec2::new(direct[0], direct[1])).norm() < 1e-12);
    }

    #[test]
    fn ols_toa_rejects_collinear_anchors_too_few_ranges_and_non_finite_input() {
        let line = [
            (Vec2::new(0.0, 0.0), 1.0),
            (Vec2::new(1.0, 0.0), 1.0),
            (Vec2::new(2.0, 0.0), 1.0),
        ];
        assert!(ols_toa(&line).unwrap_err().contains("collinear"));
        assert!(ols_toa(&line[..2]).unwrap_err().contains("need >= 3"));
        let mut bad = line;
        bad[1] = (Vec2::new(1.0, 1.0), f64::NAN);
        assert!(ols_toa(&bad).unwrap_err().contains("non-finite"));
    }

    #[test]
    fn ols_rejects_collinear_anchors_and_too_few_ranges() {
        let g = Geometry {
            drift: Vec::new(),
            transmitters: vec![],
            receivers: vec![
                Vec2::new(0.0, 0.0),
                Vec2::new(1.0, 0.0),
                Vec2::new(3.0, 0.0),
            ],
        };
        let s = toa_sample(
            &g,
            &Vec2::new(1.0, 2.0),
            0.0,
            &mut stream_rng(10, Stream::Aux, 0),
        );
        assert!(matches!(
            ols_position(&g, &s),
            Err(TrackError::OlsDegenerate(_))
        ));
        let mut s2 = s.clone();
        s2.nodes.truncate(2);
        assert!(matches!(
            ols_position(&g, &s2),
            Err(TrackError::OlsDegenerate(_))
        ));
        let gm = mixed_geometry();
        let mut sb = bistatic_only(&mixed_sample(
            &gm,
            &Vec2::new(0.6, 0.8),
            0.0,
            &mut stream_rng(10, Stream::Aux, 1),
        ));
        sb.nodes.truncate(1); // 2 equations, 3 unknowns either way
        assert!(matches!(
            ols_position(&gm, &sb),
            Err(TrackError::OlsDegenerate(_))
        ));
    }

    #[test]
    fn trajectories_have_the_prescribed_step_lengths_and_are_seed_reproducible() {
        let start = Vec2::new(2.0, 1.0);
        let len = 1000;
        let c = 0.005;
        let tr = trajectory_eq19(start, c, len, &mut stream_rng(11, Stream::Motion, 0)).unwrap();
        let tr2 = walk_trajectory(
            Walk::SqrtDecayCircle { c },
            start,
            len,
            &mut stream_rng(11, Stream::Motion, 0),
        )
        .unwrap();
        assert_eq!(tr, tr2);
        assert_eq!(tr.len(), len);
        assert_abs_diff_eq!((tr[0] - start).norm(), 0.0, epsilon = 0.0);
        let mut mean_dir = Vec2::zeros();
        for (k, w) in tr.windows(2).enumerate() {
            // eq. (19): x_{t+1} - x_t has length c / sqrt(2 (t + 1)), t = k + 1.
            let want = c / (2.0 * (k as f64 + 2.0)).sqrt();
            assert_abs_diff_eq!((w[1] - w[0]).norm(), want, epsilon = 1e-15);
            mean_dir += (w[1] - w[0]) / want;
        }
        // Uniform directions: the mean unit step is near zero (4 sigma ~ 4/sqrt(2 * 999)).
        assert!(mean_dir.norm() / ((len - 1) as f64) < 0.09);
        let d = walk_trajectory(
            Walk::SqrtDecayDiagonal { c: 0.0025 },
            start,
            len,
            &mut stream_rng(11, Stream::Motion, 1),
        )
        .unwrap();
        let mut neg = 0;
        for (k, w) in d.windows(2).enumerate() {
            let s = w[1] - w[0];
            let a = 0.0025 / (2.0 * (k as f64 + 1.0)).sqrt();
            assert_abs_diff_eq!(s.x.abs(), a, epsilon = 1e-15);
            assert_abs_diff_eq!(s.x, s.y, epsilon = 1e-15);
            neg += usize::from(s.x < 0.0);
        }
        assert!((400..600).contains(&neg), "{neg}");
        let b = walk_trajectory(
            Walk::UniformBox { half_width: 0.0025 },
            start,
            len,
            &mut stream_rng(11, Stream::Motion, 2),
        )
        .unwrap();
        let mut var = 0.0;
        for w in b.windows(2) {
            let s = w[1] - w[0];
            assert!(s.x.abs() <= 0.0025 && s.y.abs() <= 0.0025);
            var += s.norm_squared();
        }
        // E||d||^2 = 2 h^2 / 3.
        let want = 2.0 * 0.0025f64.powi(2) / 3.0;
        assert_abs_diff_eq!(var / (len - 1) as f64, want, epsilon = 0.1 * want);
        assert!(
            walk_trajectory(
                Walk::SqrtDecayCircle { c: f64::NAN },
                start,
                3,
                &mut stream_rng(1, Stream::Motion, 0)
            )
            .is_err()
        );
        assert!(
            trajectory_eq19(start, c, 0, &mut stream_rng(1, Stream::Motion, 0))
                .unwrap()
                .is_empty()
        );
    }

    // ----- Reproductions (ignored; they print numbers) -----------------------
    //
    // cargo test --lib online::tests::reproduce -- --ignored --nocapture --test-threads 1

    type SigmaOfT = Box<dyn Fn(usize) -> f64>;

    struct CtteCurves {
        ogd: Vec<f64>,
        onm: Vec<f64>,
        onm_damped: usize,
    }

    /// Mean running CTTE over `trials` of OGD (`eta = 0.1`) and ONM on the
    /// Pun-So 2022 Sec. V setup with trajectory eq. (19) (scale `c`) and noise `sigma(t)`.
    fn pun_so_2022_ctte(
        init: Init,
        c: f64,
        sigma: &dyn Fn(usize) -> f64,
        horizon: usize,
        trials: u64,
    ) -> CtteCurves {
        let g = paper_geometry();
        let mut out = CtteCurves {
            ogd: vec![0.0; horizon],
            onm: vec![0.0; horizon],
            onm_damped: 0,
        };
        for trial in 0..trials {
            let mut motion_rng = stream_rng(trial, Stream::Motion, 0);
            let mut noise_rng = stream_rng(trial, Stream::Measurement, 0);
            let traj = trajectory_eq19(Vec2::new(2.0, 1.0), c, horizon, &mut motion_rng).unwrap();
            let samples: Vec<_> = traj
                .iter()
                .enumerate()
                .map(|(k, x)| toa_sample(&g, x, sigma(k + 1), &mut noise_rng))
                .collect();
            let x0 = init.initial_estimate(&g, &samples[0], traj[0]).unwrap();
            let mut ogd = OgdTracker::new(x0, StepSize::Constant { eta: 0.1 }).unwrap();
            let mut onm = OnmTracker::new(x0, NewtonDamping::default()).unwrap();
            let (mut c_ogd, mut c_onm) = (Ctte::default(), Ctte::default());
            for (k, (s, xt)) in samples.iter().zip(&traj).enumerate() {
                let a = ogd.step(&g, s, k + 1).unwrap();
                let b = onm.step(&g, s, k + 1).unwrap();
                out.ogd[k] += c_ogd.push(&a, xt) / trials as f64;
                out.onm[k] += c_onm.push(&b, xt) / trials as f64;
            }
            out.onm_damped += onm.damped_steps();
        }
        out
    }

    /// Local log-log growth exponent of a curve between 1-based times a < b.
    fn exponent(curve: &[f64], a: usize, b: usize) -> f64 {
        (curve[b - 1] / curve[a - 1]).ln() / (b as f64 / a as f64).ln()
    }

    fn print_curves(label: &str, cv: &CtteCurves, checkpoints: &[usize]) {
        let n = cv.ogd.len();
        println!("  {label}  (ONM modified steps: {})", cv.onm_damped);
        println!(
            "    {:>6} {:>12} {:>12} {:>10}",
            "t", "CTTE OGD", "CTTE ONM", "ONM-OGD"
        );
        for &t in checkpoints {
            println!(
                "    {:>6} {:>12.5} {:>12.5} {:>10.5}",
                t,
                cv.ogd[t - 1],
                cv.onm[t - 1],
                cv.onm[t - 1] - cv.ogd[t - 1]
            );
        }
        let tenth = n / 10;
        let first = |c: &[f64]| c[tenth - 1] / tenth as f64;
        let last = |c: &[f64]| (c[n - 1] - c[n - tenth - 1]) / tenth as f64;
        println!(
            "    mean per-step error first/last tenth: OGD {:.3e} / {:.3e}   ONM {:.3e} / {:.3e}",
            first(&cv.ogd),
            last(&cv.ogd),
            first(&cv.onm),
            last(&cv.onm)
        );
        println!(
            "    log-log exponent t={}..{}: OGD {:.3}  ONM {:.3}",
            n / 10,
            n,
            exponent(&cv.ogd, n / 10, n),
            exponent(&cv.onm, n / 10, n)
        );
    }

    #[test]
    #[ignore = "reproduction of Pun-So 2022 Sec. V-A (prints numbers)"]
    fn reproduce_pun_so_2022_sec_v_a_ctte_of_ogd_vs_onm() {
        let trials = 200;
        let cps = [10, 50, 100, 200, 300, 400, 500];
        let scenarios: [(&str, SigmaOfT); 3] = [
            ("sigma = 1e-4", Box::new(|_| 1e-4)),
            ("sigma = 1e-2", Box::new(|_| 1e-2)),
            (
                "sigma = 0.01/sqrt(t)",
                Box::new(|t| 0.01 / (t as f64).sqrt()),
            ),
        ];
        println!("Pun-So 2022 Sec. V-A: T = 500, c = 0.005, {trials} trials, OGD eta = 0.1");
        for (label, sigma) in &scenarios {
            for init in [Init::Exact, Init::Ols] {
                let cv = pun_so_2022_ctte(init, 0.005, sigma.as_ref(), 500, trials);
                print_curves(&format!("{label}, {init:?} init"), &cv, &cps);
            }
        }
        println!("Pun-So 2022 Fig. 2 / Fig. 3: T = 10000, exact init");
        let cps = [100, 1000, 2000, 5000, 10000];
        let long: [(&str, SigmaOfT); 3] = [
            ("Fig. 2 sigma = 1e-4", Box::new(|_| 1e-4)),
            (
                "Fig. 3a sigma = 0.005/sqrt(2t)",
                Box::new(|t| 0.005 / (2.0 * t as f64).sqrt()),
            ),
            (
                "Fig. 3b sigma = 0.008/sqrt(2t)",
                Box::new(|t| 0.008 / (2.0 * t as f64).sqrt()),
            ),
        ];
        for (label, sigma) in &long {
            let cv = pun_so_2022_ctte(Init::Exact, 0.005, sigma.as_ref(), 10_000, trials);
            print_curves(label, &cv, &cps);
        }
    }

    #[test]
    #[ignore = "reproduction of Pun-So 2020 Sec. V examples 1-3 (prints numbers)"]
    fn reproduce_pun_so_2020_examples_dynamic_regret_of_ogd() {
        let g = paper_geometry();
        let horizon = 10_000;
        let trials = 200u64;
        let examples = [
            (
                "Ex. 1: diagonal +-, sigma = 1e-4",
                Walk::SqrtDecayDiagonal { c: 0.0025 },
                1e-4,
            ),
            (
                "Ex. 2: diagonal +-, sigma = 1e-2",
                Walk::SqrtDecayDiagonal { c: 0.0025 },
                1e-2,
            ),
            (
                "Ex. 3a: uniform box, sigma = 1e-4",
                Walk::UniformBox { half_width: 0.0025 },
                1e-4,
            ),
            (
                "Ex. 3b: uniform box, sigma = 1e-2",
                Walk::UniformBox { half_width: 0.0025 },
                1e-2,
            ),
        ];
        println!(
            "Pun-So 2020 Sec. V: T = {horizon}, {trials} trials, OGD eta_t = 1/sqrt(t), x_0 = x_0^*"
        );
        println!(
            "  regret_pred = sum f_t(x_(t-1)) - f_t(x_hat_t) (Pun-So 2020 definition); regret_post uses x_t"
        );
        let cps = [1usize, 10, 100, 1000, 5000, 10_000];
        for (label, motion, sigma) in examples {
            let mut pred = vec![0.0; horizon];
            let mut post = vec![0.0; horizon];
            // Per-trial cumulative regret_pred at the checkpoints (for medians).
            let mut per_trial: Vec<Vec<f64>> = vec![Vec::new(); cps.len()];
            let mut not_conv = 0usize;
            let mut lost = 0usize;
            let mut final_err = 0.0;
            for trial in 0..trials {
                let mut motion_rng = stream_rng(trial, Stream::Motion, 1);
                let mut noise_rng = stream_rng(trial, Stream::Measurement, 1);
                // Positions x*_0 .. x*_T; sample t measures x*_t.
                let traj =
                    walk_trajectory(motion, Vec2::new(2.0, 1.0), horizon + 1, &mut motion_rng)
                        .unwrap();
                let mut ogd = OgdTracker::new(traj[0], StepSize::InvSqrt { eta0: 1.0 }).unwrap();
                let (mut rp, mut rq) = (DynamicRegret::default(), DynamicRegret::default());
                for t in 1..=horizon {
                    let s = toa_sample(&g, &traj[t], sigma, &mut noise_rng);
                    let xh = x_hat(&g, &s, traj[t], &XHatOptions::default()).unwrap();
                    not_conv += usize::from(!xh.converged);
                    let before = ogd.estimate();
                    let after = ogd.step(&g, &s, t).unwrap();
                    let r = rp.push(regret_term(&g, &s, &before, &xh).unwrap());
                    pred[t - 1] += r / trials as f64;
                    post[t - 1] +=
                        rq.push(regret_term(&g, &s, &after, &xh).unwrap()) / trials as f64;
                    if let Some(i) = cps.iter().position(|&c| c == t) {
                        per_trial[i].push(r);
                    }
                }
                let e = (ogd.estimate() - traj[horizon]).norm();
                final_err += e / trials as f64;
                lost += usize::from(e > 0.1);
            }
            println!(
                "  {label}: x_hat not converged in {not_conv} of {} solves; mean final error {final_err:.3e}; trials with final error > 0.1: {lost}",
                horizon as u64 * trials
            );
            println!(
                "    {:>6} {:>12} {:>12} {:>12} {:>16}",
                "t", "mean R_pred", "median R_pred", "mean R_post", "mean per-step in (prev cp, t]"
            );
            let mut prev = 0usize;
            for (i, &t) in cps.iter().enumerate() {
                let mut v = per_trial[i].clone();
                v.sort_by(f64::total_cmp);
                let med = v[v.len() / 2];
                let base = if prev == 0 { 0.0 } else { pred[prev - 1] };
                println!(
                    "    {:>6} {:>12.5e} {:>12.5e} {:>12.5e} {:>16.3e}",
                    t,
                    pred[t - 1],
                    med,
                    post[t - 1],
                    (pred[t - 1] - base) / (t - prev) as f64
                );
                prev = t;
            }
            let tenth = horizon / 10;
            println!(
                "    R_pred slope first tenth {:.3e}, last tenth {:.3e}",
                pred[tenth - 1] / tenth as f64,
                (pred[horizon - 1] - pred[horizon - tenth - 1]) / tenth as f64,
            );
        }
    }
}

#[cfg(test)]
mod three_d_tests;
