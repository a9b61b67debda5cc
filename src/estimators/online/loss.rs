//! The time-varying least-squares loss of one sample (Pun-So 2022 eq. (3); bistatic terms
//! as Pun-So 2020), with its gradient and Hessian.

use crate::estimators::online::COINCIDENT_REL;
use crate::estimators::online::Mat2;
use crate::estimators::online::TrackError;
use crate::model::geometry::Vec2;
use crate::model::measure::Geometry;
use crate::model::measure::SampleMeasurements;

/// Value, gradient and (optionally) Hessian of `f_t` at one point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LossEval {
    /// `f_t(x)`.
    pub value: f64,
    /// `grad f_t(x)`.
    pub grad: Vec2,
    /// `hess f_t(x)` (zero when only the gradient was requested).
    pub hess: Mat2,
    /// Number of squared residuals in `f_t` (the `m` of Pun-So 2022 for TOA).
    pub terms: usize,
    /// Sum of the per-term gradient-Lipschitz weights: 1 per one-way range,
    /// 4 per bistatic range (`||u_t + u_r||^2 <= 4`). Equals `terms` for TOA.
    pub weight: f64,
}

/// Distance to `p` and the unit vector `(x - p)/||x - p||` (zero on the focus).
#[inline(always)]
pub(super) fn dist_unit(x: &Vec2, p: &Vec2) -> (f64, Vec2, bool) {
    let diff = x - p;
    let d = diff.norm();
    if d <= COINCIDENT_REL * (1.0 + p.x.abs().max(p.y.abs())) {
        (d, Vec2::zeros(), false)
    } else {
        (d, diff / d, true)
    }
}

/// Curvature of `||x - p||`: `(I - u u^T) / d`, added with weight `w`.
#[inline(always)]
pub(super) fn add_proj(h: &mut Mat2, u: &Vec2, d: f64, w: f64) {
    let s = w / d;
    h[(0, 0)] += s * (1.0 - u.x * u.x);
    h[(1, 1)] += s * (1.0 - u.y * u.y);
    let off = -s * u.x * u.y;
    h[(0, 1)] += off;
    h[(1, 0)] += off;
}

#[inline(always)]
pub(super) fn add_outer(h: &mut Mat2, u: &Vec2, w: f64) {
    h[(0, 0)] += w * u.x * u.x;
    h[(1, 1)] += w * u.y * u.y;
    let off = w * u.x * u.y;
    h[(0, 1)] += off;
    h[(1, 0)] += off;
}

#[inline(always)]
pub(super) fn accumulate<const GRAD: bool, const HESS: bool>(
    geometry: &Geometry,
    sample: &SampleMeasurements,
    x: &Vec2,
) -> Result<LossEval, TrackError> {
    if !(x.x.is_finite() && x.y.is_finite()) {
        return Err(TrackError::NonFinite("position x"));
    }
    if sample.nodes.len() > geometry.receivers.len() {
        return Err(TrackError::TooManyNodes {
            nodes: sample.nodes.len(),
            receivers: geometry.receivers.len(),
        });
    }
    let mut value = 0.0;
    let mut grad = Vec2::zeros();
    let mut hess = Mat2::zeros();
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
pub fn loss(geometry: &Geometry, sample: &SampleMeasurements, x: &Vec2) -> Result<f64, TrackError> {
    accumulate::<false, false>(geometry, sample, x).map(|e| e.value)
}

/// `f_t(x)` and `grad f_t(x) = sum 2 e_i u_i` (Pun-So 2022 eq. (3)); for a
/// bistatic term `u_i = u_t + u_r`, the sum of the unit vectors from both foci.
#[inline]
pub fn loss_grad(
    geometry: &Geometry,
    sample: &SampleMeasurements,
    x: &Vec2,
) -> Result<LossEval, TrackError> {
    accumulate::<true, false>(geometry, sample, x)
}

/// `f_t`, its gradient and Hessian. One-way term (Pun-So 2020, proof of Thm. 1):
/// `2 u u^T + 2 e (I - u u^T)/d`; bistatic term:
/// `2 s s^T + 2 e [(I - u_t u_t^T)/d_t + (I - u_r u_r^T)/d_r]`, `s = u_t + u_r`.
pub fn loss_grad_hess(
    geometry: &Geometry,
    sample: &SampleMeasurements,
    x: &Vec2,
) -> Result<LossEval, TrackError> {
    accumulate::<true, true>(geometry, sample, x)
}

/// Number of squared residuals in `f_t` (one per one-way and per bistatic range).
pub fn term_count(sample: &SampleMeasurements) -> usize {
    sample
        .nodes
        .iter()
        .map(|n| n.bistatic.len() + usize::from(n.range.is_some()))
        .sum()
}
