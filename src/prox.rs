//! Proximal operators of the local cost (seed 002 eq. 11 and eq. 13).
//!
//! PLACEHOLDER: the real GTRS solver is being written; see issue 2 §3.

use crate::geometry::Vec3;
use crate::local::LocalProblem;
use serde::{Deserialize, Serialize};

/// Which local prox the Douglas-Rachford engine uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LocalSolver {
    /// Exact prox on the cone surface `||theta~[0:2] - r_v|| = theta~[2]` (eq. 13).
    Gtrs,
    /// Unconstrained prox, a 3x3 SPD solve (eq. 11 without eq. 12).
    Relaxed,
}

/// Why a prox could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ProxError {
    /// `gamma` must be finite and positive.
    #[error("gamma must be finite and > 0, got {0}")]
    BadGamma(f64),
    /// An input (measurement row, `u`) was NaN or infinite.
    #[error("non-finite input: {0}")]
    NonFinite(&'static str),
    /// The problem is numerically degenerate.
    #[error("degenerate local problem: {0}")]
    Degenerate(String),
}

/// `argmin_theta f_v(theta) + 1/(2 gamma) ||theta - u||^2` (no constraint).
pub fn prox_relaxed(p: &LocalProblem, u: &Vec3, gamma: f64) -> Result<Vec3, ProxError> {
    if !(gamma.is_finite() && gamma > 0.0) {
        return Err(ProxError::BadGamma(gamma));
    }
    let a = p.h + crate::geometry::Mat3::identity() / gamma;
    let b = p.c + u / gamma;
    a.cholesky()
        .map(|ch| ch.solve(&b))
        .ok_or_else(|| ProxError::Degenerate("H + I/gamma not positive definite".into()))
}

/// Exact GTRS prox (eq. 13). PLACEHOLDER implementation.
pub fn prox_gtrs(p: &LocalProblem, u: &Vec3, gamma: f64) -> Result<Vec3, ProxError> {
    prox_relaxed(p, u, gamma)
}

/// Dispatch on [`LocalSolver`].
pub fn prox(
    solver: LocalSolver,
    p: &LocalProblem,
    u: &Vec3,
    gamma: f64,
) -> Result<Vec3, ProxError> {
    match solver {
        LocalSolver::Gtrs => prox_gtrs(p, u, gamma),
        LocalSolver::Relaxed => prox_relaxed(p, u, gamma),
    }
}
