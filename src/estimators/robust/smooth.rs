//! The smooth robust losses: lq-IRLS, LAD and plain LS (Shi 2024 Sec. IV), one
//! majorise-minimise solver.

use super::Init;
use super::IrlsConfig;
use super::LsConfig;
use super::check_tol;
use crate::estimators::robust::BistaticLink;
use crate::estimators::robust::Estimate;
use crate::estimators::robust::RobustError;
use crate::estimators::robust::problem::Problem;
use crate::model::geometry::{Point, Vec2};
use crate::model::linalg::{MatD, sym_eigen};
use crate::model::measure::Geometry;

/// The loss `phi(r)` of the smooth estimators.
#[derive(Debug, Clone, Copy)]
pub(super) enum Loss {
    /// `r^2`.
    Square,
    /// `sqrt(r^2 + eps^2)`.
    Abs { eps2: f64 },
    /// `(r^2 + eps^2)^{q/2}`.
    Power { q: f64, eps2: f64 },
    /// `(r^2 + eps^2)^{3/4}` (`q = 1.5`, the default, without `powf`).
    Power15 { eps2: f64 },
}

impl Loss {
    /// `(phi(r), w(r))` with the IRLS weight `w = phi'(r) / (q r)`, i.e.
    /// `(r^2 + eps^2)^{q/2 - 1}` (1 for the square).
    #[inline]
    pub(super) fn eval(self, r: f64) -> (f64, f64) {
        match self {
            Loss::Square => (r * r, 1.0),
            Loss::Abs { eps2 } => {
                let u = (r * r + eps2).sqrt();
                (u, 1.0 / u)
            }
            Loss::Power { q, eps2 } => {
                let u = r * r + eps2;
                let phi = u.powf(0.5 * q);
                (phi, phi / u)
            }
            Loss::Power15 { eps2 } => {
                let u = r * r + eps2;
                let s = u.sqrt();
                let phi = s * s.sqrt();
                (phi, phi / u)
            }
        }
    }

    /// `(phi'(r), phi''(r))`, the exact derivatives used by the Newton
    /// candidate of [`smooth_solve`].
    #[inline]
    pub(super) fn derivs(self, r: f64) -> (f64, f64) {
        match self {
            Loss::Square => (2.0 * r, 2.0),
            Loss::Abs { eps2 } => {
                let u = r * r + eps2;
                let s = u.sqrt();
                (r / s, eps2 / (u * s))
            }
            Loss::Power { q, eps2 } => power_derivs(q, r, r * r + eps2),
            Loss::Power15 { eps2 } => power_derivs(1.5, r, r * r + eps2),
        }
    }
}

/// Derivatives of `u^{q/2}`, `u = r^2 + eps^2`, in `r`:
/// `phi' = q r u^{q/2 - 1}`, `phi'' = q u^{q/2 - 2} (u + (q - 2) r^2)`.
#[inline]
fn power_derivs(q: f64, r: f64, u: f64) -> (f64, f64) {
    let w = u.powf(0.5 * q - 1.0);
    (q * r * w, q * w / u * (u + (q - 2.0) * r * r))
}

/// Halvings tried on the exact Newton step before it is given up.
pub(super) const NEWTON_HALVINGS: usize = 8;

/// The saddle-free Newton step `-|H|^{-1} grad` of `sum_l phi(r_l(e))` at
/// `e` (`|H|` has the eigenvalues of the exact Hessian `H` made positive),
/// or `None` where `H` vanishes or is not finite. With
/// `J_l = -(u_t + u_r)` (unit vectors from the sensors to `e`),
/// `grad = sum_l phi'(r_l) J_l` and
/// `H = sum_l phi''(r_l) J_l J_l^T - phi'(r_l) ((I - u_t u_t^T)/d_t + (I - u_r u_r^T)/d_r)`.
fn newton_step<const D: usize>(
    pb: &Problem<D>,
    loss: Loss,
    e: &Point<D>,
    cur: &Dists,
) -> Option<Point<D>> {
    let floor = pb.dist_floor;
    // Upper triangle of H, and the gradient.
    let mut h = MatD::<D>::zeros();
    let mut g = Point::<D>::zeros();
    for l in 0..pb.len() {
        let (dt, dr) = (cur.t[l], cur.r[l]);
        let (d1, d2) = loss.derivs(pb.s[l] - dt - dr);
        let mut j = Point::<D>::zeros();
        for (p, d) in [(pb.t[l], dt), (pb.r[l], dr)] {
            if d > floor {
                let u = (e - p) / d;
                j -= u;
                // -phi' (I - u u^T) / d: the curvature of the range itself.
                let c = -d1 / d;
                for a in 0..D {
                    h[(a, a)] += c * (1.0 - u[a] * u[a]);
                    for b in a + 1..D {
                        h[(a, b)] -= c * u[a] * u[b];
                    }
                }
            }
        }
        for a in 0..D {
            for b in a..D {
                h[(a, b)] += d2 * j[a] * j[b];
            }
        }
        for a in 0..D {
            g[a] += d1 * j[a];
        }
    }
    if !(h.iter().all(|v| v.is_finite()) && g.iter().all(|v| v.is_finite())) {
        return None;
    }
    if D == 2 {
        let to_d = |v: Vec2| Point::<D>::from_fn(|i, _| v[i]);
        return newton_step_2d(h[(0, 0)], h[(0, 1)], h[(1, 1)], g[0], g[1]).map(to_d);
    }
    // The saddle-free step from the eigendecomposition of the symmetric H.
    for a in 0..D {
        for b in 0..a {
            h[(a, b)] = h[(b, a)];
        }
    }
    let (l, v) = sym_eigen(&h)?;
    let floor = 1e-12 * l.amax();
    if floor.is_nan() || floor <= 0.0 {
        return None;
    }
    let mut step = Point::<D>::zeros();
    for k in 0..D {
        let vk = v.column(k);
        step -= vk * (g.dot(&vk) / l[k].abs().max(floor));
    }
    step.iter().all(|c| c.is_finite()).then_some(step)
}

/// [`newton_step`] in 2-D from `H = [[h00, h01], [h01, h11]]` and `g`, with
/// the eigendecomposition in closed form.
fn newton_step_2d(h00: f64, h01: f64, h11: f64, g0: f64, g1: f64) -> Option<Vec2> {
    // Eigen-decomposition of the symmetric 2x2 H; each eigen-direction is
    // scaled by 1/|lambda| (the saddle-free Newton step), so a direction of
    // negative curvature is followed downhill instead of uphill.
    let half_tr = 0.5 * (h00 + h11);
    let disc = (0.25 * (h00 - h11) * (h00 - h11) + h01 * h01).sqrt();
    let (l1, l2) = (half_tr + disc, half_tr - disc);
    let v1 = if h01.abs() > 1e-300 || (h00 - h11).abs() > 1e-300 {
        let (a, b) = if h00 >= h11 {
            (l1 - h11, h01)
        } else {
            (h01, l1 - h00)
        };
        let n = (a * a + b * b).sqrt();
        if n > 0.0 {
            Vec2::new(a / n, b / n)
        } else {
            Vec2::new(1.0, 0.0)
        }
    } else {
        Vec2::new(1.0, 0.0)
    };
    let v2 = Vec2::new(-v1.y, v1.x);
    let g = Vec2::new(g0, g1);
    let floor = 1e-12 * l1.abs().max(l2.abs());
    if floor.is_nan() || floor <= 0.0 {
        return None;
    }
    let step = -v1 * (g.dot(&v1) / l1.abs().max(floor)) - v2 * (g.dot(&v2) / l2.abs().max(floor));
    step.iter().all(|c| c.is_finite()).then_some(step)
}

/// Step doublings tried after an accepted IRLS step.
pub(super) const MAX_DOUBLINGS: usize = 40;

/// Sensor distances `||e - t_l||`, `||e - r_l||` at one point.
pub(super) struct Dists {
    pub(super) t: Vec<f64>,
    pub(super) r: Vec<f64>,
}

impl Dists {
    pub(super) fn new(n: usize) -> Dists {
        Dists {
            t: vec![0.0; n],
            r: vec![0.0; n],
        }
    }

    /// Fill the distances at `e` and return the objective `sum_l phi(r_l(e))`.
    pub(super) fn eval<const D: usize>(
        &mut self,
        pb: &Problem<D>,
        loss: Loss,
        e: &Point<D>,
    ) -> f64 {
        let mut f = 0.0;
        for l in 0..pb.len() {
            self.t[l] = (e - pb.t[l]).norm();
            self.r[l] = (e - pb.r[l]).norm();
            f += loss.eval(pb.s[l] - self.t[l] - self.r[l]).0;
        }
        f
    }
}

/// Damped Gauss-Newton on `sum_l phi(r_l(e))` with IRLS weights: at `e^k`
/// solve `(J^T W J + lambda tr/2 I) delta = -J^T W r` (`W = diag w(r_l(e^k))`,
/// `J_l = -(e - t_l)/||e - t_l|| - (e - r_l)/||e - r_l||`) and accept the step
/// only if the objective decreases, else raise `lambda`. For `phi` concave in
/// `r^2` the weighted square is a majoriser of the objective whose gradient
/// matches at `e^k`, so this is IRLS with one damped step per reweighting;
/// for the IRLS losses an accepted step is then doubled (up to
/// [`MAX_DOUBLINGS`] times) while the objective keeps decreasing, which cuts
/// the iteration count of `lad` several-fold. Where one residual is held
/// within `eps` of zero the objective is a curved valley of width ~`eps`
/// along which both of those steps shrink to ~`eps` (a `lad` instance took
/// 1625 iterations), so the exact saddle-free Newton step of
/// `newton_step` is tried as well and taken where it is lower still.
pub(super) fn smooth_solve<const D: usize>(
    pb: &Problem<D>,
    loss: Loss,
    init: Init,
    max_iter: usize,
    tol: f64,
    name: &'static str,
) -> Result<Estimate<D>, RobustError> {
    check_tol("tol", tol)?;
    let n = pb.len();
    let mut e = pb.init(init)?;
    // Distances at the current point, at the best candidate, and scratch.
    let mut cur = Dists::new(n);
    let mut cand = Dists::new(n);
    let mut scratch = Dists::new(n);
    let mut f = cur.eval(pb, loss, &e);
    if !f.is_finite() {
        return Err(RobustError::NonFinite {
            estimator: name,
            iter: 0,
        });
    }
    let mut trace = Vec::with_capacity(max_iter.min(64) + 1);
    trace.push(f);
    let mut lambda = 1e-6;
    let needed_small = if matches!(loss, Loss::Square) { 1 } else { 3 };
    let mut small_steps = 0;
    let mut converged = false;
    let mut iterations = 0;
    for k in 0..max_iter {
        iterations = k + 1;
        let (h, g) = weighted_normal_equations(pb, loss, &e, &cur);
        // The mean eigenvalue of H.
        let mut tr = h[(0, 0)];
        for i in 1..D {
            tr += h[(i, i)];
        }
        let scale = tr / D as f64;
        if !(scale.is_finite() && g.iter().all(|v| v.is_finite())) {
            return Err(RobustError::NonFinite {
                estimator: name,
                iter: k,
            });
        }
        if scale <= 0.0 {
            converged = true;
            break;
        }
        let damped = Damped { h, g, scale };
        let accepted = damped.step(pb, loss, (&e, f), &mut lambda, [&mut cand, &mut scratch]);
        let Some((mut e_new, mut f_new, mut step)) = accepted else {
            // No decrease possible at this precision: a stationary point.
            converged = true;
            break;
        };
        if !matches!(loss, Loss::Square) {
            // The IRLS majoriser overestimates the curvature (|r| >> eps gives
            // weights far above phi''), so the step is often too short:
            // extend it by doubling while the objective keeps decreasing.
            for _ in 0..MAX_DOUBLINGS {
                let trial = step + step;
                let e_try = e + trial;
                let f_try = scratch.eval(pb, loss, &e_try);
                if f_try < f_new {
                    std::mem::swap(&mut cand, &mut scratch);
                    (e_new, f_new, step) = (e_try, f_try, trial);
                } else {
                    break;
                }
            }
        }
        if !matches!(loss, Loss::Square) {
            // Along a curved valley of the smoothed l_1 objective (one
            // residual held within eps of zero) the IRLS steps shrink to
            // nothing; the exact Newton step follows the valley. Taken only
            // where it beats the IRLS candidate, so the trace stays
            // strictly decreasing.
            if let Some(mut nstep) = newton_step(pb, loss, &e, &cur) {
                for _ in 0..NEWTON_HALVINGS {
                    let e_try = e + nstep;
                    let f_try = scratch.eval(pb, loss, &e_try);
                    if f_try < f_new {
                        std::mem::swap(&mut cand, &mut scratch);
                        (e_new, f_new, step) = (e_try, f_try, nstep);
                        break;
                    }
                    nstep *= 0.5;
                }
            }
        }
        std::mem::swap(&mut cur, &mut cand);
        lambda = (lambda / 4.0).max(1e-12);
        let rel = step.norm() / e.norm().max(pb.step_floor());
        e = e_new;
        f = f_new;
        trace.push(f);
        // IRLS zig-zags in flat valleys, so one short step proves nothing:
        // the IRLS losses need `needed_small` short steps in a row.
        small_steps = if rel < tol { small_steps + 1 } else { 0 };
        if small_steps >= needed_small {
            converged = true;
            break;
        }
    }
    Ok(Estimate {
        position: e,
        iterations,
        converged,
        objective: f,
        trace,
        outliers: Vec::new(),
    })
}

/// The IRLS normal equations at `e` (distances `cur`): the upper triangle of
/// `H` and `g`, the sums over the links of `w J J^T` and `w J r` with `J` the
/// gradient of the link's range and `w` the loss's weight of its residual.
fn weighted_normal_equations<const D: usize>(
    pb: &Problem<D>,
    loss: Loss,
    e: &Point<D>,
    cur: &Dists,
) -> (MatD<D>, Point<D>) {
    let floor = pb.dist_floor;
    let mut h = MatD::<D>::zeros();
    let mut g = Point::<D>::zeros();
    for l in 0..pb.len() {
        let (dt, dr) = (cur.t[l], cur.r[l]);
        let mut j = Point::<D>::zeros();
        if dt > floor {
            j -= (e - pb.t[l]) / dt;
        }
        if dr > floor {
            j -= (e - pb.r[l]) / dr;
        }
        let r = pb.s[l] - dt - dr;
        let w = loss.eval(r).1;
        for a in 0..D {
            for b in a..D {
                h[(a, b)] += w * j[a] * j[b];
            }
        }
        for a in 0..D {
            g[a] += w * j[a] * r;
        }
    }
    (h, g)
}

/// The Levenberg-Marquardt step of one IRLS iteration: the normal equations
/// `h` (upper triangle) and `g`, damped by `lambda` times `scale`.
struct Damped<const D: usize> {
    h: MatD<D>,
    g: Point<D>,
    scale: f64,
}

impl<const D: usize> Damped<D> {
    /// The step `-(H + d I)^{-1} g`, `None` unless `H + d I` is positive
    /// definite (in closed form in 2-D, by Cholesky otherwise).
    fn solve(&self, d: f64) -> Option<Point<D>> {
        if D == 2 {
            let (h00, h01, h11) = (self.h[(0, 0)], self.h[(0, 1)], self.h[(1, 1)]);
            let (g0, g1) = (self.g[0], self.g[1]);
            let (a00, a11) = (h00 + d, h11 + d);
            let det = a00 * a11 - h01 * h01;
            if det > 0.0 {
                let step = [-(a11 * g0 - h01 * g1) / det, -(a00 * g1 - h01 * g0) / det];
                return Some(Point::<D>::from_fn(|i, _| step[i]));
            }
            return None;
        }
        let a = MatD::<D>::from_fn(|i, j| {
            let v = self.h[(i.min(j), i.max(j))];
            if i == j { v + d } else { v }
        });
        a.cholesky().map(|c| -c.solve(&self.g))
    }

    /// The first damped step from `e` (objective `f`) that lowers the
    /// objective, raising `lambda` eightfold after each one that does not
    /// (at most 60 tries, `lambda` up to 1e16): the new point, its objective
    /// and the step, with its distances in `dists[0]` (`dists[1]` is
    /// scratch). `None`: no decrease at this precision.
    fn step(
        &self,
        pb: &Problem<D>,
        loss: Loss,
        (e, f): (&Point<D>, f64),
        lambda: &mut f64,
        dists: [&mut Dists; 2],
    ) -> Option<(Point<D>, f64, Point<D>)> {
        let [cand, scratch] = dists;
        for _ in 0..60 {
            let d = *lambda * self.scale;
            if let Some(step) = self.solve(d) {
                let e_try = e + step;
                let f_try = scratch.eval(pb, loss, &e_try);
                if f_try < f {
                    std::mem::swap(cand, scratch);
                    return Some((e_try, f_try, step));
                }
            }
            *lambda *= 8.0;
            if *lambda > 1e16 {
                break;
            }
        }
        None
    }
}

pub(super) fn check_eps(eps: f64) -> Result<(), RobustError> {
    if eps.is_finite() && eps > 0.0 {
        Ok(())
    } else {
        Err(RobustError::InvalidConfig {
            key: "epsilon",
            reason: format!("must be finite and > 0, got {eps}"),
        })
    }
}

/// `l_q` estimator, Shi 2024 eq. (4) with `1 < q < 2` (the `l_q`-IRLS
/// competitor of Sec. IV, `q = 1.5`): minimise
/// `sum_l (r_l^2 + eps^2)^{q/2}`, `r_l = s_l - ||e - t_l|| - ||e - r_l||`,
/// by IRLS (see the module docs). `q` must lie in `(1, 2)`.
pub fn lq_irls<const D: usize>(
    geom: &Geometry<D>,
    links: &[BistaticLink],
    cfg: &IrlsConfig,
) -> Result<Estimate<D>, RobustError> {
    if !(cfg.q > 1.0 && cfg.q < 2.0) {
        return Err(RobustError::InvalidConfig {
            key: "q",
            reason: format!("must be in (1, 2), got {}", cfg.q),
        });
    }
    check_eps(cfg.epsilon)?;
    let pb = Problem::new(geom, links)?;
    let eps2 = cfg.epsilon * cfg.epsilon;
    let loss = if (cfg.q - 1.5).abs() < 1e-15 {
        Loss::Power15 { eps2 }
    } else {
        Loss::Power { q: cfg.q, eps2 }
    };
    smooth_solve(&pb, loss, cfg.init, cfg.max_iter, cfg.tol, "lq_irls")
}

/// Least absolute deviations (Shi 2024 eq. (4), `q = 1`), smoothed as
/// `sum_l sqrt(r_l^2 + eps^2)` and solved by IRLS. `cfg.q` is ignored.
pub fn lad<const D: usize>(
    geom: &Geometry<D>,
    links: &[BistaticLink],
    cfg: &IrlsConfig,
) -> Result<Estimate<D>, RobustError> {
    check_eps(cfg.epsilon)?;
    let pb = Problem::new(geom, links)?;
    let loss = Loss::Abs {
        eps2: cfg.epsilon * cfg.epsilon,
    };
    smooth_solve(&pb, loss, cfg.init, cfg.max_iter, cfg.tol, "lad")
}

/// Nonlinear least squares of the bistatic ranges, Shi 2024 eq. (3), by
/// Levenberg-damped Gauss-Newton from `cfg.init`. A local minimiser.
pub fn ls<const D: usize>(
    geom: &Geometry<D>,
    links: &[BistaticLink],
    cfg: &LsConfig,
) -> Result<Estimate<D>, RobustError> {
    let pb = Problem::new(geom, links)?;
    smooth_solve(&pb, Loss::Square, cfg.init, cfg.max_iter, cfg.tol, "ls")
}
