//! L0-norm outlier separation (Shi 2024 Sec. III, eq. (7), (19)-(20)).

use super::L0osConfig;
use crate::estimators::robust::BistaticLink;
use crate::estimators::robust::Estimate;
use crate::estimators::robust::RobustError;
use crate::estimators::robust::problem::Problem;
use crate::estimators::robust::problem::hard_threshold;
use crate::model::geometry::Point;
use crate::model::measure::Geometry;

/// Shi 2024 Algorithm 1 (`l0`-norm outlier separation, `l0-OS`): minimise
/// `f(e, o) = sum_{i,j} (s_{ij} - ||e - t_i|| - ||e - r_j|| - o_{ij})^2`
/// s.t. `||o||_0 <= kappa` (eq. 6) by alternating
///
/// * the MM location update eq. (14): with `gamma = s - o^k`,
///   `a = ||e^k - r_j|| / ||e^k - t_i||`, `b = 1/a`,
///   `p = gamma (e^k - t_i)/||e^k - t_i||`, `q = gamma (e^k - r_j)/||e^k - r_j||`,
///   `e^{k+1} = sum[(1+a) t_i + (1+b) r_j + p + q] / sum(2 + a + b)`;
/// * the outlier update eq. (19)-(20): `o^{k+1} = H_kappa(beta)`, keeping the
///   `kappa` largest-magnitude residuals `beta = s - ||e^{k+1} - t|| - ||e^{k+1} - r||`;
///
/// from `o^0 = 0`, until the relative change of `e` is below `tol`.
///
/// One safeguard beyond the paper: eq. (11) majorises `-2 gamma ||e - t||` by
/// a linear function only when `gamma >= 0`. For a link with `gamma < 0`
/// (a negative measured range, impossible for physical data) the term is
/// convex and is majorised instead by `|gamma| (||e - t||^2 / ||e^k - t|| + ||e^k - t||)`,
/// which adds `|gamma| / ||e^k - t||` to the weights of `t` in eq. (14) and
/// drops `p`. With every `gamma >= 0` the update is exactly eq. (14); in all
/// cases the objective trace is non-increasing (Shi 2024 Sec. III).
pub fn l0os<const D: usize>(
    geom: &Geometry<D>,
    links: &[BistaticLink],
    cfg: &L0osConfig,
) -> Result<Estimate<D>, RobustError> {
    let pb = Problem::new(geom, links)?;
    let n = pb.len();
    if cfg.kappa >= n {
        return Err(RobustError::KappaTooLarge {
            kappa: cfg.kappa,
            n_links: n,
        });
    }
    check_tol("tol", cfg.tol)?;
    let mut e = pb.init(cfg.init)?;
    let mut o = vec![0.0; n];
    let mut beta = vec![0.0; n];
    let mut keep = vec![false; n];
    let mut order = Vec::with_capacity(n);
    // Distances ||e - t_l||, ||e - r_l|| at the current e, shared by the
    // residuals beta (eq. 19) and the next location update (eq. 14).
    let mut dist_t = vec![0.0; n];
    let mut dist_r = vec![0.0; n];
    let mut f0 = 0.0;
    for l in 0..n {
        dist_t[l] = (e - pb.t[l]).norm();
        dist_r[l] = (e - pb.r[l]).norm();
        f0 += (pb.s[l] - dist_t[l] - dist_r[l]).powi(2);
    }
    let mut trace = Vec::with_capacity(cfg.max_iter.min(64) + 1);
    trace.push(f0);
    let floor = pb.dist_floor;
    let mut converged = false;
    let mut iterations = 0;
    for k in 0..cfg.max_iter {
        iterations = k + 1;
        // Location update, eq. (14).
        let mut num = Point::<D>::zeros();
        let mut den = 0.0;
        for l in 0..n {
            let (t, r) = (pb.t[l], pb.r[l]);
            let (dt, dr) = (dist_t[l].max(floor), dist_r[l].max(floor));
            let (it, ir) = (1.0 / dt, 1.0 / dr);
            let gamma = pb.s[l] - o[l];
            let (mut wt, mut wr) = (1.0 + dr * it, 1.0 + dt * ir);
            if gamma >= 0.0 {
                // p + q of eq. (11), e^k - t = e - t.
                num += (gamma * it) * (e - t) + (gamma * ir) * (e - r);
            } else {
                wt -= gamma * it;
                wr -= gamma * ir;
            }
            num += wt * t + wr * r;
            den += wt + wr;
        }
        let e_new = num / den;
        if !e_new.iter().all(|v| v.is_finite()) {
            return Err(RobustError::NonFinite {
                estimator: "l0os",
                iter: k,
            });
        }
        // Outlier update, eq. (19)-(20).
        for l in 0..n {
            dist_t[l] = (e_new - pb.t[l]).norm();
            dist_r[l] = (e_new - pb.r[l]).norm();
            beta[l] = pb.s[l] - dist_t[l] - dist_r[l];
        }
        keep.fill(false);
        for &i in hard_threshold(&beta, cfg.kappa, &mut order) {
            keep[i] = true;
        }
        let mut f = 0.0;
        for l in 0..n {
            if keep[l] {
                o[l] = beta[l];
            } else {
                o[l] = 0.0;
                f += beta[l] * beta[l];
            }
        }
        if !f.is_finite() {
            return Err(RobustError::NonFinite {
                estimator: "l0os",
                iter: k,
            });
        }
        trace.push(f);
        let rel = (e_new - e).norm() / e.norm().max(pb.step_floor());
        e = e_new;
        if rel < cfg.tol {
            converged = true;
            break;
        }
    }
    let objective = *trace.last().unwrap_or(&0.0);
    let outliers = (0..n).filter(|&l| keep[l]).collect();
    Ok(Estimate {
        position: e,
        iterations,
        converged,
        objective,
        trace,
        outliers,
    })
}

pub(super) fn check_tol(key: &'static str, tol: f64) -> Result<(), RobustError> {
    if tol.is_finite() && tol >= 0.0 {
        Ok(())
    } else {
        Err(RobustError::InvalidConfig {
            key,
            reason: format!("must be finite and >= 0, got {tol}"),
        })
    }
}
