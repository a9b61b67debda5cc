//! The time-varying least-squares loss of one sample (Pun-So 2022 eq. (3); bistatic terms
//! as Pun-So 2020), with its gradient and Hessian.

use crate::estimators::online::COINCIDENT_REL;
use crate::estimators::online::TrackError;
use crate::model::geometry::Point;
use crate::model::linalg::MatD;
use crate::model::measure::Geometry;
use crate::model::measure::SampleMeasurements;

/// Value, gradient and (optionally) Hessian of `f_t` at one point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LossEval<const D: usize = 2> {
    /// `f_t(x)`.
    pub value: f64,
    /// `grad f_t(x)`.
    pub grad: Point<D>,
    /// `hess f_t(x)` (zero when only the gradient was requested).
    pub hess: MatD<D>,
    /// Number of squared residuals in `f_t` (the `m` of Pun-So 2022 for TOA).
    pub terms: usize,
    /// Sum of the per-term gradient-Lipschitz weights: 1 per one-way range,
    /// 4 per bistatic range (`||u_t + u_r||^2 <= 4`). Equals `terms` for TOA.
    pub weight: f64,
}

/// Distance to `p` and the unit vector `(x - p)/||x - p||` (zero on the focus).
#[inline(always)]
pub(super) fn dist_unit<const D: usize>(x: &Point<D>, p: &Point<D>) -> (f64, Point<D>, bool) {
    let diff = x - p;
    let d = diff.norm();
    if d <= COINCIDENT_REL * (1.0 + p.amax()) {
        (d, Point::<D>::zeros(), false)
    } else {
        (d, diff / d, true)
    }
}

/// Curvature of `||x - p||`: `(I - u u^T) / d`, added with weight `w`.
#[inline(always)]
pub(super) fn add_proj<const D: usize>(h: &mut MatD<D>, u: &Point<D>, d: f64, w: f64) {
    let s = w / d;
    for i in 0..D {
        h[(i, i)] += s * (1.0 - u[i] * u[i]);
    }
    for i in 0..D {
        for j in i + 1..D {
            let off = -s * u[i] * u[j];
            h[(i, j)] += off;
            h[(j, i)] += off;
        }
    }
}

#[inline(always)]
pub(super) fn add_outer<const D: usize>(h: &mut MatD<D>, u: &Point<D>, w: f64) {
    for i in 0..D {
        h[(i, i)] += w * u[i] * u[i];
    }
    for i in 0..D {
        for j in i + 1..D {
            let off = w * u[i] * u[j];
            h[(i, j)] += off;
            h[(j, i)] += off;
        }
    }
}

#[inline(always)]
pub(super) fn accumulate<const GRAD: bool, const HESS: bool, const D: usize>(
    geometry: &Geometry<D>,
    sample: &SampleMeasurements,
    x: &Point<D>,
) -> Result<LossEval<D>, TrackError> {
    if !x.iter().all(|v| v.is_finite()) {
        return Err(TrackError::NonFinite("position x"));
    }
    if sample.nodes.len() > geometry.receivers.len() {
        return Err(TrackError::TooManyNodes {
            nodes: sample.nodes.len(),
            receivers: geometry.receivers.len(),
        });
    }
    let mut value = 0.0;
    let mut grad = Point::<D>::zeros();
    let mut hess = MatD::<D>::zeros();
    let mut terms = 0usize;
    let mut weight = 0.0;
    for (n, node) in sample.nodes.iter().enumerate() {
        if node.range.is_none() && node.bistatic.is_empty() {
            continue;
        }
        let rn = &geometry.receivers[n];
        let (dr, ur, ok_r) = dist_unit(x, rn);
        if let Some(r) = node.range {
            if !r.is_finite() {
                return Err(TrackError::NonFinite("one-way range"));
            }
            let e = dr - r;
            value += e * e;
            terms += 1;
            weight += 1.0;
            if GRAD {
                grad += (2.0 * e) * ur;
            }
            if HESS && ok_r {
                add_outer(&mut hess, &ur, 2.0);
                add_proj(&mut hess, &ur, dr, 2.0 * e);
            }
        }
        for &(m, rho) in &node.bistatic {
            let Some(tm) = geometry.transmitters.get(m) else {
                return Err(TrackError::UnknownTransmitter {
                    node: n,
                    m,
                    count: geometry.transmitters.len(),
                });
            };
            if !rho.is_finite() {
                return Err(TrackError::NonFinite("bistatic range"));
            }
            let (dt, ut, ok_t) = dist_unit(x, tm);
            let e = dt + dr - rho;
            value += e * e;
            terms += 1;
            weight += 4.0;
            let s = ut + ur;
            if GRAD {
                grad += (2.0 * e) * s;
            }
            if HESS {
                add_outer(&mut hess, &s, 2.0);
                if ok_t {
                    add_proj(&mut hess, &ut, dt, 2.0 * e);
                }
                if ok_r {
                    add_proj(&mut hess, &ur, dr, 2.0 * e);
                }
            }
        }
    }
    let finite = value.is_finite()
        && grad.iter().all(|v| v.is_finite())
        && hess.iter().all(|v| v.is_finite());
    if !finite {
        return Err(TrackError::NonFiniteResult(
            "loss evaluation (check geometry)",
        ));
    }
    Ok(LossEval {
        value,
        grad,
        hess,
        terms,
        weight,
    })
}

/// `f_t(x)`: Pun-So 2022 eq. (2) over the one-way ranges plus the bistatic
/// least-squares terms (see the module docs). Errors on non-finite input.
pub fn loss<const D: usize>(
    geometry: &Geometry<D>,
    sample: &SampleMeasurements,
    x: &Point<D>,
) -> Result<f64, TrackError> {
    accumulate::<false, false, D>(geometry, sample, x).map(|e| e.value)
}

/// `f_t(x)` and `grad f_t(x) = sum 2 e_i u_i` (Pun-So 2022 eq. (3)); for a
/// bistatic term `u_i = u_t + u_r`, the sum of the unit vectors from both foci.
#[inline]
pub fn loss_grad<const D: usize>(
    geometry: &Geometry<D>,
    sample: &SampleMeasurements,
    x: &Point<D>,
) -> Result<LossEval<D>, TrackError> {
    accumulate::<true, false, D>(geometry, sample, x)
}

/// `f_t`, its gradient and Hessian. One-way term (Pun-So 2020, proof of Thm. 1):
/// `2 u u^T + 2 e (I - u u^T)/d`; bistatic term:
/// `2 s s^T + 2 e [(I - u_t u_t^T)/d_t + (I - u_r u_r^T)/d_r]`, `s = u_t + u_r`.
pub fn loss_grad_hess<const D: usize>(
    geometry: &Geometry<D>,
    sample: &SampleMeasurements,
    x: &Point<D>,
) -> Result<LossEval<D>, TrackError> {
    accumulate::<true, true, D>(geometry, sample, x)
}

/// Number of squared residuals in `f_t` (one per one-way and per bistatic range).
pub fn term_count(sample: &SampleMeasurements) -> usize {
    sample
        .nodes
        .iter()
        .map(|n| n.bistatic.len() + usize::from(n.range.is_some()))
        .sum()
}
