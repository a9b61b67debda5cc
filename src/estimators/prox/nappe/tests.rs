//! The n-dimensional nappe solver against a brute force that shares nothing
//! with it (a dense grid of directions on the sphere, refined by a pattern
//! search), against the closed-form projection, and at `M = 3` against the
//! independent 2-D solver of [`crate::estimators::prox::gtrs`].

use super::*;
use crate::estimators::prox::gtrs::min_quadratic_on_upper_nappe;
use crate::model::geometry::{Mat3, Vec3};
use nalgebra::{Matrix4, Vector3, Vector4};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

/// `1/2 y^T A y - b^T y`.
fn q4(a: &Matrix4<f64>, b: &Vector4<f64>, y: &Vector4<f64>) -> f64 {
    0.5 * y.dot(&(a * y)) - b.dot(y)
}

/// The best value of `q` on the nappe along direction `e` (unit, in R^3):
/// `-1/2 max(b^T w, 0)^2 / (w^T A w)`, `w = [e, 1]`.
fn along(a: &Matrix4<f64>, b: &Vector4<f64>, e: &Vector3<f64>) -> f64 {
    let w = Vector4::new(e.x, e.y, e.z, 1.0);
    let bw = b.dot(&w).max(0.0);
    -0.5 * bw * bw / w.dot(&(a * w))
}

fn unit(theta: f64, phi: f64) -> Vector3<f64> {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    Vector3::new(st * cp, st * sp, ct)
}

/// Brute force: `n` directions of a Fibonacci sphere, the best ten refined
/// by a pattern search in the two angles (step halved to 1e-12). Returns
/// the best value of `q` found (0 at the apex).
fn brute_force(a: &Matrix4<f64>, b: &Vector4<f64>, n: usize) -> f64 {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut grid: Vec<(f64, f64, f64)> = (0..n)
        .map(|k| {
            let z = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
            let (theta, phi) = (z.acos(), golden * k as f64);
            (along(a, b, &unit(theta, phi)), theta, phi)
        })
        .collect();
    grid.sort_by(|x, y| x.0.total_cmp(&y.0));
    let mut best = 0.0f64;
    for &(f0, t0, p0) in grid.iter().take(10) {
        let (mut f, mut t, mut p) = (f0, t0, p0);
        let mut step = 0.05;
        while step > 1e-12 {
            let mut moved = false;
            for (dt, dp) in [(step, 0.0), (-step, 0.0), (0.0, step), (0.0, -step)] {
                let g = along(a, b, &unit(t + dt, p + dp));
                if g < f {
                    (f, t, p) = (g, t + dt, p + dp);
                    moved = true;
                }
            }
            if !moved {
                step *= 0.5;
            }
        }
        best = best.min(f);
    }
    best
}

/// A random instance: `A = H + I/gamma` with `H = B^T B` of `rows` random
/// rows at scale `scale`, and a random `b`.
fn instance() -> impl Strategy<Value = (Matrix4<f64>, Vector4<f64>)> {
    (
        prop::collection::vec(prop::array::uniform4(-1.0f64..1.0), 0..7),
        prop::array::uniform4(-1.0f64..1.0),
        -3.0f64..3.0,
        -4.0f64..2.0,
    )
        .prop_map(|(rows, b, log_scale, log_inv_gamma)| {
            let s = 10f64.powf(log_scale);
            let mut a = Matrix4::identity() * 10f64.powf(log_inv_gamma);
            for r in rows {
                let r = Vector4::from(r) * s;
                a += r * r.transpose();
            }
            (a, Vector4::from(b) * s)
        })
}

/// The solver's answer is on the nappe, and no worse than the brute force.
fn check(a: &Matrix4<f64>, b: &Vector4<f64>) -> Result<(), TestCaseError> {
    let y = min_quadratic_on_upper_nappe_n(a, b).map_err(|e| TestCaseError::fail(e.to_string()))?;
    let scale = y.norm().max(b.norm() / a.norm());
    let pos = y.fixed_rows::<3>(0).norm();
    prop_assert!(y[3] >= 0.0, "d < 0: {y:?}");
    prop_assert!((pos - y[3]).abs() <= 1e-12 * scale, "off the cone: {y:?}");
    let f = q4(a, b, &y);
    let fb = brute_force(a, b, 4000);
    // What rounding can hide in evaluating F = (b^T w)^2 / (w^T A w) near
    // y's direction (the brute force's many evaluations find its upward
    // noise): relative errors of b^T w and w^T A w, against their terms.
    let w = if y[3] > 0.0 {
        y / y[3]
    } else {
        Vector4::new(0.0, 0.0, 0.0, 1.0)
    };
    let (wa, ba) = (w.abs(), b.abs());
    let bw_rel = ba.dot(&wa) / b.dot(&w).abs().max(f64::MIN_POSITIVE);
    let aw_rel = wa.dot(&(a.abs() * wa)) / w.dot(&(a * w)).abs();
    let round = 32.0 * f64::EPSILON * (2.0 * bw_rel + aw_rel) * fb.abs()
        + 1e-12 * (y.dot(&(a * y)).abs() + b.dot(&y).abs());
    prop_assert!(
        f <= fb + 1e-9 * fb.abs() + round,
        "solver {f:e} worse than brute force {fb:e}: {y:?}"
    );
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, .. ProptestConfig::default() })]

    #[test]
    fn the_3d_nappe_minimiser_is_no_worse_than_a_dense_search_of_directions(
        (a, b) in instance(),
    ) {
        check(&a, &b)?;
    }

    /// `b` orthogonal to one simultaneous eigenvector of `(A, S)`: a zero
    /// `beta_i`, the hard case of the secular equation.
    #[test]
    fn the_3d_nappe_minimiser_handles_the_hard_case(
        (a, b) in instance(),
        i in 0usize..4,
    ) {
        let mut s = Matrix4::identity();
        s[(3, 3)] = -1.0;
        let l_inv = a.cholesky().unwrap().l().try_inverse().unwrap();
        let eig = (l_inv * s * l_inv.transpose()).symmetric_eigen();
        let v = l_inv.transpose() * eig.eigenvectors;
        // beta = V^T b; zero its i-th entry and map back: b = V^{-T} beta.
        let mut beta = v.transpose() * b;
        beta[i] = 0.0;
        let b = v.transpose().try_inverse().unwrap() * beta;
        prop_assume!(b.norm() > 0.0);
        check(&a, &b)?;
    }

    /// A position block with a small eigenvalue and `b` nearly along the
    /// range axis: `F` has two nearly equal local maxima near `+-v_min`,
    /// and only one is global.
    #[test]
    fn the_3d_nappe_minimiser_picks_the_global_of_two_local_maxima(
        axes in prop::array::uniform3(-1.0f64..1.0),
        angle in 0.0f64..std::f64::consts::PI,
        spread in prop::array::uniform2(0.5f64..3.0),
        tilt in prop::array::uniform3(-1.0f64..1.0),
        bp in prop::array::uniform3(-1.0f64..1.0),
        log_eps in -6.0f64..-1.0,
    ) {
        let axis = Vector3::from(axes);
        prop_assume!(axis.norm() > 0.1);
        let r = nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle);
        let diag = Vector3::new(1.0, 10f64.powf(spread[0]), 10f64.powf(spread[1]));
        let app = r.matrix() * nalgebra::Matrix3::from_diagonal(&diag) * r.matrix().transpose();
        let eps = 10f64.powf(log_eps);
        let mut a = Matrix4::zeros();
        a.fixed_view_mut::<3, 3>(0, 0).copy_from(&app);
        for i in 0..3 {
            a[(i, 3)] = eps * tilt[i];
            a[(3, i)] = eps * tilt[i];
        }
        a[(3, 3)] = 2.0;
        let b = Vector4::new(eps * bp[0], eps * bp[1], eps * bp[2], 1.0);
        check(&a, &b)?;
    }

    /// With `A = c I` the problem is the projection of `b / c` onto the
    /// nappe, whose closed form is `((|p| + s) / 2)_+ [p / |p|, 1]` for
    /// `b / c = [p, s]`.
    #[test]
    fn with_a_multiple_of_the_identity_the_3d_answer_is_the_projection_onto_the_nappe(
        b in prop::array::uniform4(-1.0f64..1.0),
        log_c in -4.0f64..4.0,
        log_b in -3.0f64..3.0,
    ) {
        let c = 10f64.powf(log_c);
        let b = Vector4::from(b) * 10f64.powf(log_b);
        let y = min_quadratic_on_upper_nappe_n(&(Matrix4::identity() * c), &b).unwrap();
        let x = b / c;
        let p = x.fixed_rows::<3>(0).into_owned();
        let rho = (0.5 * (p.norm() + x[3])).max(0.0);
        let want = if p.norm() > 0.0 {
            let e = p / p.norm();
            Vector4::new(rho * e.x, rho * e.y, rho * e.z, rho)
        } else {
            Vector4::zeros()
        };
        prop_assert!((y - want).norm() <= 1e-10 * x.norm(), "{y:?} vs {want:?}");
    }

    /// At `M = 3` (a 2-D position) the n-dimensional solver and the 2-D
    /// angle solver reach the same value: two methods that share nothing
    /// but the problem.
    #[test]
    fn in_2d_the_secular_solver_agrees_with_the_angle_solver(
        rows in prop::collection::vec(prop::array::uniform3(-1.0f64..1.0), 0..6),
        b in prop::array::uniform3(-1.0f64..1.0),
        log_scale in -3.0f64..3.0,
        log_inv_gamma in -4.0f64..2.0,
    ) {
        let s = 10f64.powf(log_scale);
        let mut a = Mat3::identity() * 10f64.powf(log_inv_gamma);
        for r in rows {
            let r = Vec3::from(r) * s;
            a += r * r.transpose();
        }
        let b = Vec3::from(b) * s;
        let q = |y: &Vec3| 0.5 * y.dot(&(a * y)) - b.dot(y);
        let y_n = min_quadratic_on_upper_nappe_n(&a, &b).unwrap();
        let y_2 = min_quadratic_on_upper_nappe(&a, &b).unwrap();
        let (fn_, f2) = (q(&y_n), q(&y_2));
        let round = 1e-12 * (y_n.dot(&(a * y_n)).abs() + y_2.dot(&(a * y_2)).abs() + b.norm() * (y_n.norm() + y_2.norm()));
        prop_assert!((fn_ - f2).abs() <= 1e-9 * f2.abs() + round, "n-dim {fn_:e} vs 2-D {f2:e}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, .. ProptestConfig::default() })]

    /// Every sign change of `phi` between its poles (found by a dense scan,
    /// log-spaced towards each pole) holds a polished root of the secular
    /// polynomial.
    #[test]
    fn every_sign_change_of_the_secular_function_holds_a_found_root(
        pos in prop::array::uniform3(-2.0f64..2.0),
        neg in -2.0f64..2.0,
        beta in prop::array::uniform4(-1.0f64..1.0),
    ) {
        let d = Vector4::new(
            10f64.powf(pos[0]),
            10f64.powf(pos[1]),
            10f64.powf(pos[2]),
            -(10f64.powf(neg)),
        );
        let beta = Vector4::from(beta);
        let phi = |l: f64| (0..4).map(|i| d[i] * beta[i] * beta[i] / (1.0 + l * d[i]).powi(2)).sum::<f64>();
        let (found, nr) = secular_roots(&d, &beta);
        let roots: Vec<f64> = found[..nr].iter().map(|&l| polish(&d, &beta, l)).collect();
        let mut poles: Vec<f64> = d.iter().map(|x| -1.0 / x).collect();
        poles.sort_by(f64::total_cmp);
        let far = 1e4 * poles.iter().fold(1.0f64, |m, p| m.max(p.abs()));
        let mut edges = vec![-far];
        edges.extend(&poles);
        edges.push(far);
        for w in edges.windows(2) {
            let (lo, hi) = (w[0], w[1]);
            let n = 4000;
            let grid: Vec<f64> = (1..n)
                .map(|k| {
                    // Dense near both ends: a tanh-like map of a uniform grid.
                    let t = k as f64 / n as f64;
                    let s = 0.5 - 0.5 * (std::f64::consts::PI * t).cos();
                    lo + (hi - lo) * s
                })
                .collect();
            for g in grid.windows(2) {
                let (fa, fb) = (phi(g[0]), phi(g[1]));
                if fa.is_finite() && fb.is_finite() && fa * fb < 0.0 {
                    let hit = roots.iter().any(|&r| r >= g[0] - 1e-9 * g[0].abs() && r <= g[1] + 1e-9 * g[1].abs());
                    prop_assert!(hit, "a root of phi in [{}, {}] was missed: {:?}", g[0], g[1], roots);
                }
            }
        }
    }
}

#[test]
fn the_apex_is_the_answer_when_minus_b_is_in_the_cone() {
    let a = Matrix4::new(
        3.0, 0.2, -0.1, 0.4, 0.2, 2.0, 0.3, -0.2, -0.1, 0.3, 1.5, 0.1, 0.4, -0.2, 0.1, 2.5,
    );
    // -b = [e, 1.5] with |e| = 1 is inside the (self-dual) cone.
    let b = -Vector4::new(0.6, 0.0, 0.8, 1.5);
    let y = min_quadratic_on_upper_nappe_n(&a, &b).unwrap();
    assert_eq!(y, Vector4::zeros());
}

#[test]
fn bad_input_is_an_error_not_a_nan() {
    let b = Vector4::new(1.0, 0.0, 0.0, 1.0);
    let mut a = Matrix4::identity();
    a[(2, 2)] = f64::NAN;
    assert!(matches!(
        min_quadratic_on_upper_nappe_n(&a, &b),
        Err(ProxError::NonFinite(_))
    ));
    let a = -Matrix4::<f64>::identity();
    assert!(matches!(
        min_quadratic_on_upper_nappe_n(&a, &b),
        Err(ProxError::Degenerate(_))
    ));
    // Indefinite with a positive diagonal.
    let mut a = Matrix4::identity();
    a[(0, 1)] = 3.0;
    a[(1, 0)] = 3.0;
    assert!(matches!(
        min_quadratic_on_upper_nappe_n(&a, &b),
        Err(ProxError::Degenerate(_))
    ));
}
