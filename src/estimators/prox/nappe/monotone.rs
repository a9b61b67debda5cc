//! The fast path of the nappe solver: the minimiser over the whole cone
//! `y^T S y = 0`, `S = diag(1, ..., 1, -1)`, from the one root of the secular
//! function on its monotone interval, taken when it lies on the upper nappe.
//!
//! # Why it is the global minimiser
//!
//! If `(A + lambda S) y* = b`, `A + lambda S` is positive semidefinite and
//! `y*^T S y* = 0`, then `y*` minimises `q(y) = 1/2 y^T A y - b^T y` over the
//! whole cone: for every `y` on it, `q(y) = q(y) + lambda/2 y^T S y` is the
//! Lagrangian, a convex quadratic whose minimiser is `y*`, so `q(y) >= q(y*)`
//! (the sufficient half of Moré 1993, Thm. 3.2). The upper nappe is part of
//! the cone, so a `y*` with `y*[M-1] >= 0` is also the minimiser over the
//! nappe: the answer of Mourya 2017 eq. (13), certified by the Cholesky factor
//! of `A + lambda S` that exists only when the matrix is positive definite.
//!
//! # How the multiplier is found
//!
//! On the open interval `I` of `lambda` where `A + lambda S` is positive
//! definite (it holds `0`, since `A` is), `y(lambda) = (A + lambda S)^{-1} b`
//! and `psi(lambda) = y^T S y` is strictly decreasing:
//! `psi' = -2 (S y)^T (A + lambda S)^{-1} (S y) < 0` for `y != 0`. In the
//! coordinates of [`super`] it is the secular function `sum_i d_i beta_i^2 /
//! (1 + lambda d_i)^2`, whose poles at the ends of `I` send it from `+inf` to
//! `-inf`: one root, except in the hard case (a pole with `beta_i = 0`).
//! Halley's method on `psi` from `lambda = 0` (with `y' = -z`,
//! `z = (A + lambda S)^{-1} S y`: `psi' = -2 (S y)^T z`, `psi'' = 6 z^T S z`)
//! is kept inside a bracket: a point with `psi > 0` bounds the root from
//! below, one with `psi < 0` or where the factorisation fails (outside `I`)
//! from above; a Halley step out of the bracket falls back to Newton's, and
//! that to the midpoint. When the step is small against the inverse's norm
//! bound `tau = trace((A + lambda S)^{-1})` (`|step| tau <= 1e-8`) it is taken
//! to first order, `y - step z`, without a new factorisation: the matrix is
//! positive definite there (`|step| < 1/tau <= lambda_min`) and the point
//! exact to `(step tau)^2 ||y||`.
//!
//! When the root is on the lower nappe, when there is none in `I` (the hard
//! case), or when the factor at the root is too ill-conditioned to trust the
//! direction of `y`, this path gives up and the caller enumerates every KKT
//! point. On the tracking problems it succeeds after two factorisations
//! (`L D L^T` and four triangular solves of the lifted size each).

// The triangular kernels index rows and columns of the same arrays.
#![allow(clippy::needless_range_loop)]

use super::{Mat, Vector};

/// Newton or bisection steps before the fast path gives up.
const MAX_STEPS: usize = 60;

/// `|psi| / ||y||^2` at which the root is taken (the direction of `y` is then
/// exact to about this much).
const ROOT_TOL: f64 = 1e-15;

/// `|step| ||(A + lambda S)^{-1}||` bound under which the last step is taken
/// to first order: `y - step z` is then exact to `1e-16 ||y||`.
const FINISH_TOL: f64 = 1e-8;

/// The smallest pivot of the factorisation (an entry of `D` in `L D L^T`),
/// relative to the largest, for which the direction of `y` is trusted: below
/// it the enumeration, whose Newton ascent refines the direction, is used (on
/// random problems the two then agree in value to 1e-13 relative).
const MIN_PIVOT_RATIO: f64 = 1e-2;

/// The factorisation `L D L^T` of `A + lambda S` (`L` unit lower triangular,
/// row-major; `D` kept as its reciprocals): a Cholesky factorisation without
/// square roots, positive definite exactly when every entry of `D` is positive.
struct Factor<const M: usize> {
    l: [[f64; M]; M],
    inv_d: [f64; M],
    /// Smallest entry of `D` over the largest.
    pivot_ratio: f64,
}

impl<const M: usize> Factor<M> {
    /// `None` where `A + lambda S` is not (numerically) positive definite.
    fn new(a: &Mat<M>, lambda: f64) -> Option<Self> {
        let mut l = [[0.0; M]; M];
        let mut d = [0.0; M];
        let mut inv_d = [0.0; M];
        // w[i][k] = L[i][k] d[k], the products the updates need.
        let mut w = [[0.0; M]; M];
        for j in 0..M {
            let shift = if j + 1 == M { -lambda } else { lambda };
            let mut dj = a[(j, j)] + shift;
            for k in 0..j {
                dj -= w[j][k] * l[j][k];
            }
            // Not positive, or NaN.
            if dj.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                return None;
            }
            d[j] = dj;
            inv_d[j] = 1.0 / dj;
            for i in j + 1..M {
                let mut s = a[(i, j)];
                for k in 0..j {
                    s -= w[i][k] * l[j][k];
                }
                w[i][j] = s;
                l[i][j] = s * inv_d[j];
            }
        }
        let (lo, hi) = d.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &x| {
            (lo.min(x), hi.max(x))
        });
        Some(Factor {
            l,
            inv_d,
            pivot_ratio: lo / hi,
        })
    }

    /// `L^{-1} r`.
    fn forward(&self, r: &Vector<M>) -> [f64; M] {
        let mut x = [0.0; M];
        for i in 0..M {
            let mut s = r[i];
            for k in 0..i {
                s -= self.l[i][k] * x[k];
            }
            x[i] = s;
        }
        x
    }

    /// `(A + lambda S)^{-1} r`.
    fn solve(&self, r: &Vector<M>) -> Vector<M> {
        let mut x = self.forward(r);
        for i in 0..M {
            x[i] *= self.inv_d[i];
        }
        for i in (0..M).rev() {
            let mut s = x[i];
            for k in i + 1..M {
                s -= self.l[k][i] * x[k];
            }
            x[i] = s;
        }
        Vector::<M>::from_fn(|i, _| x[i])
    }

    /// `trace((A + lambda S)^{-1}) = sum_j ||row j of L^{-1}||^2 / D_j`, a bound
    /// on the largest eigenvalue of the inverse.
    fn inverse_trace(&self) -> f64 {
        let mut x = [[0.0; M]; M];
        let mut trace = 0.0;
        for i in 0..M {
            x[i][i] = 1.0;
            let mut row = 1.0;
            for j in 0..i {
                let mut s = 0.0;
                for k in j..i {
                    s -= self.l[i][k] * x[k][j];
                }
                x[i][j] = s;
                row += s * s;
            }
            trace += row * self.inv_d[i];
        }
        trace
    }
}

/// `S y`.
fn s_times<const M: usize>(y: &Vector<M>) -> Vector<M> {
    let mut sy = *y;
    sy[M - 1] = -sy[M - 1];
    sy
}

/// The minimiser of `1/2 y^T A y - b^T y` over the cone `y^T S y = 0` when it
/// is certified (see the module docs) and lies on the upper nappe
/// (`y[M-1] >= 0`); `None` when the caller must enumerate. `a` is symmetric
/// positive definite with its largest diagonal entry 1 (the caller's scaling).
pub(super) fn upper_nappe_minimiser<const M: usize>(
    a: &Mat<M>,
    b: &Vector<M>,
) -> Option<Vector<M>> {
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    let mut lambda = 0.0f64;
    for _ in 0..MAX_STEPS {
        let Some(factor) = Factor::new(a, lambda) else {
            // Outside I, which holds 0: the root is on the side of 0.
            if lambda > 0.0 {
                hi = lambda;
            } else {
                lo = lambda;
            }
            lambda = midpoint(lo, hi)?;
            continue;
        };
        let y = factor.solve(b);
        let sy = s_times(&y);
        let psi = y.dot(&sy);
        let size = y.norm_squared();
        if !(size > 0.0 && psi.is_finite()) {
            return None;
        }
        let trusted = factor.pivot_ratio >= MIN_PIVOT_RATIO;
        if psi.abs() <= ROOT_TOL * size {
            return (trusted && y[M - 1] > 0.0).then_some(y);
        }
        if psi > 0.0 {
            lo = lambda;
        } else {
            hi = lambda;
        }
        // y' = -z, psi' = -2 (S y)^T z, psi'' = 6 z^T S z.
        let z = factor.solve(&sy);
        let dpsi = -2.0 * sy.dot(&z);
        let d2psi = 6.0 * z.dot(&s_times(&z));
        let halley_den = 2.0 * dpsi * dpsi - psi * d2psi;
        let halley = -2.0 * psi * dpsi / halley_den;
        let newton = -psi / dpsi;
        let inside = |step: f64| {
            let next = lambda + step;
            step.is_finite() && next > lo && next < hi
        };
        let step = if halley_den > 0.0 && inside(halley) {
            halley
        } else if inside(newton) {
            newton
        } else {
            lambda = midpoint(lo, hi)?;
            continue;
        };
        // ||(A + lambda S)^{-1}|| <= tau: for |step| tau < 1 the matrix stays
        // positive definite at lambda + step, and y(lambda + step) = y - step z
        // up to (step tau)^2 ||y||.
        if (step * factor.inverse_trace()).abs() <= FINISH_TOL {
            let y = y - z * step;
            return (trusted && y[M - 1] > 0.0).then_some(y);
        }
        lambda += step;
    }
    None
}

/// The midpoint of a finite bracket; `None` for an unbounded one (no step to
/// take: `psi` has the same sign on a whole side, so give up).
fn midpoint(lo: f64, hi: f64) -> Option<f64> {
    (lo.is_finite() && hi.is_finite()).then_some(0.5 * (lo + hi))
}

#[cfg(test)]
mod tests {
    use super::super::enumerate_kkt_points;
    use super::*;
    use nalgebra::{Matrix4, Vector4};
    use proptest::prelude::*;

    /// `1/2 y^T A y - b^T y`.
    fn q(a: &Matrix4<f64>, b: &Vector4<f64>, y: &Vector4<f64>) -> f64 {
        0.5 * y.dot(&(a * y)) - b.dot(y)
    }

    /// A random positive definite `A` (largest diagonal 1) and `b`.
    fn instance() -> impl Strategy<Value = (Matrix4<f64>, Vector4<f64>)> {
        (
            prop::array::uniform16(-1.0f64..1.0),
            0.01f64..2.0,
            prop::array::uniform4(-3.0f64..3.0),
        )
            .prop_map(|(g, shift, b)| {
                let g = Matrix4::from_row_slice(&g);
                let a = g * g.transpose() + Matrix4::identity() * shift;
                let alpha = (0..4).map(|i| a[(i, i)]).fold(0.0, f64::max);
                (a / alpha, Vector4::from_row_slice(&b))
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]

        #[test]
        fn the_fast_path_answer_is_a_certified_kkt_point_on_the_upper_nappe(
            (a, b) in instance()
        ) {
            if let Some(y) = upper_nappe_minimiser(&a, &b) {
                let scale = y.norm();
                prop_assert!(y[3] > 0.0);
                let cone = y.xyz().norm() - y[3];
                prop_assert!(cone.abs() <= 1e-6 * scale, "off the cone by {cone}");
                // The enumeration of every KKT point finds nothing better.
                let full = enumerate_kkt_points(&a, &b).expect("solvable");
                let (fq, eq) = (q(&a, &b, &y), q(&a, &b, &full));
                prop_assert!(fq <= eq + 1e-12 * (1.0 + eq.abs()), "{fq} > {eq}");
            }
        }
    }

    #[test]
    fn on_random_problems_the_fast_path_is_mostly_taken_and_never_worse_than_the_enumeration() {
        use rand::SeedableRng;
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        let mut taken = 0;
        for _ in 0..2000 {
            let g = Matrix4::from_fn(|_, _| rng.random_range(-1.0..1.0));
            let a = g * g.transpose() + Matrix4::identity() * rng.random_range(0.05..2.0);
            let alpha = (0..4).map(|i| a[(i, i)]).fold(0.0, f64::max);
            let a = a / alpha;
            let b = Vector4::from_fn(|_, _| rng.random_range(-3.0..3.0));
            let full = enumerate_kkt_points(&a, &b).expect("solvable");
            if let Some(y) = upper_nappe_minimiser(&a, &b) {
                taken += 1;
                let (fq, eq) = (q(&a, &b, &y), q(&a, &b, &full));
                assert!(fq <= eq + 1e-12 * (1.0 + eq.abs()), "{fq} > {eq}");
                approx::assert_relative_eq!(y, full, epsilon = 1e-9, max_relative = 1e-7);
            }
        }
        // About half of random problems have their cone minimiser on the
        // upper nappe (b's sign is symmetric).
        assert!(taken > 800, "the fast path was taken {taken} times of 2000");
    }

    #[test]
    fn a_minimiser_on_the_lower_nappe_is_left_to_the_enumeration() {
        // b points down the axis of the lower nappe: the cone minimiser there
        // has y[3] < 0.
        let a = Matrix4::identity();
        let b = Vector4::new(0.3, 0.0, 0.0, -2.0);
        assert!(upper_nappe_minimiser(&a, &b).is_none());
    }

    #[test]
    fn with_the_identity_the_fast_path_projects_onto_the_nappe() {
        // For A = I the minimiser is the projection of b onto the nappe:
        // b = (p, t) with ||p|| > |t| projects to ((||p|| + t)/2) (p/||p||, 1).
        let a = Matrix4::identity();
        let b = Vector4::new(3.0, 4.0, 0.0, 1.0);
        let y = upper_nappe_minimiser(&a, &b).expect("the root is on the upper nappe");
        let expect = Vector4::new(0.6 * 3.0, 0.8 * 3.0, 0.0, 3.0);
        approx::assert_relative_eq!(y, expect, max_relative = 1e-13);
    }
}
