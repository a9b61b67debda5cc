//! Every local prox in 3-D (`theta~ = [x, y, z, d]`) against brute forces that
//! share nothing with them: the exact GTRS prox against a dense search of
//! directions on the sphere that only evaluates the prox objective, `gtrs_l0`
//! against that search on every outlier support, the relaxed prox against its
//! normal equations written from the rows.

use super::*;
use crate::estimators::local::RowKind;
use crate::estimators::prox::gtrs::{prox_gtrs, prox_relaxed};
use crate::estimators::prox::l0::{
    effective_kappa, prox_gtrs_l0, prox_gtrs_l0_alternate, prox_gtrs_l0_enumerate,
};
use crate::model::geometry::{Lifted, Point};
use crate::model::measure::{self, NodeMeasurements};
use nalgebra::{Vector3, Vector4};
use proptest::prelude::*;
use proptest::test_runner::TestCaseError;

type P3 = LocalProblem<3, 4>;

fn unit(theta: f64, phi: f64) -> Vector3<f64> {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    Vector3::new(st * cp, st * sp, ct)
}

/// The point at distance `rho` from the receiver along `e`, on the nappe.
fn on_ray(p: &P3, e: &Vector3<f64>, rho: f64) -> Vector4<f64> {
    let x = p.anchor + e * rho;
    Vector4::new(x.x, x.y, x.z, rho)
}

/// The best prox objective on the ray along `e` (`rho >= 0`). The objective
/// restricted to the ray is a quadratic in `rho`: fitted from three of its
/// values, twice (the second fit around the first minimiser), then
/// evaluated at the minimiser found and at the apex.
fn along(p: &P3, u: &Vector4<f64>, gamma: f64, e: &Vector3<f64>) -> (f64, Vector4<f64>) {
    let f = |rho: f64| p.prox_objective(&on_ray(p, e, rho), u, gamma);
    let apex = (f(0.0), on_ray(p, e, 0.0));
    let mut centre = 0.0;
    let mut s = 1.0 + (u.fixed_rows::<3>(0) - p.anchor).norm();
    let mut best = apex;
    for _ in 0..2 {
        let (f0, f1, f2) = (f(centre), f(centre + s), f(centre + 2.0 * s));
        let a2 = (f2 - 2.0 * f1 + f0) / (2.0 * s * s);
        if a2.is_nan() || a2 <= 0.0 {
            break;
        }
        let a1 = (f1 - f0) / s - a2 * s;
        let rho = (centre - a1 / (2.0 * a2)).max(0.0);
        let v = f(rho);
        if v < best.0 {
            best = (v, on_ray(p, e, rho));
        }
        centre = (rho - s.min(rho) * 1e-3).max(0.0);
        s = (rho * 1e-3).max(1e-9);
    }
    best
}

/// Brute force of the 3-D GTRS prox: `n` directions of a Fibonacci sphere,
/// the best eight refined by a pattern search in the two angles (step halved
/// to 1e-11).
fn brute_force(p: &P3, u: &Vector4<f64>, gamma: f64, n: usize) -> (f64, Vector4<f64>) {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut grid: Vec<(f64, f64, f64)> = (0..n)
        .map(|k| {
            let z = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
            let (t, ph) = (z.acos(), golden * k as f64);
            (along(p, u, gamma, &unit(t, ph)).0, t, ph)
        })
        .collect();
    grid.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut best = along(p, u, gamma, &unit(grid[0].1, grid[0].2));
    for &(f0, t0, p0) in grid.iter().take(8) {
        let (mut f, mut t, mut ph) = (f0, t0, p0);
        let mut step = 0.02;
        while step > 1e-11 {
            let mut moved = false;
            for (dt, dp) in [(step, 0.0), (-step, 0.0), (0.0, step), (0.0, -step)] {
                let g = along(p, u, gamma, &unit(t + dt, ph + dp));
                if g.0 < f {
                    (f, t, ph) = (g.0, t + dt, ph + dp);
                    moved = true;
                    if g.0 < best.0 {
                        best = g;
                    }
                }
            }
            if !moved {
                step *= 0.5;
            }
        }
    }
    best
}

/// What rounding can hide in one evaluation of the prox objective at `th`:
/// every residual's error against its terms, and the proximal term's.
fn eval_error(p: &P3, th: &Vector4<f64>, u: &Vector4<f64>, gamma: f64) -> f64 {
    let mut s = 0.0;
    for (row, g) in p.rows.iter().zip(&p.g) {
        let terms: f64 = (0..4).map(|i| (row[i] * th[i]).abs()).sum::<f64>() + g.abs();
        let e: f64 = (0..4).map(|i| row[i] * th[i]).sum::<f64>() - g;
        s += (e.abs() + 8.0 * f64::EPSILON * terms) * terms;
    }
    s += (th - u).norm() * (th.norm() + u.norm()) / gamma;
    16.0 * f64::EPSILON * s
}

/// A random 3-D receiver with its own measurements of a target: `m`
/// transmitters, DOA (azimuth and elevation) and one-way range on or off,
/// noise added to every measurement, at coordinate scale `scale`.
#[derive(Debug, Clone)]
struct Case {
    p: P3,
    u: Vector4<f64>,
    gamma: f64,
}

fn case() -> impl Strategy<Value = Case> {
    (
        prop::sample::select(vec![3.0, 3000.0]),
        prop::collection::vec(prop::array::uniform3(-1.0f64..1.0), 1..4),
        (
            prop::array::uniform3(-1.0f64..1.0),
            prop::array::uniform3(-1.0f64..1.0),
        ),
        (
            any::<bool>(),
            any::<bool>(),
            prop::array::uniform6(-1.0f64..1.0),
        ),
        (-2.0f64..1.0, prop::array::uniform4(-1.0f64..1.0), 0u8..3),
    )
        .prop_map(
            |(scale, tx, (r, x), (doa, range, noise), (log_g, du, u_mode))| {
                let pt = |a: [f64; 3]| Point::<3>::from(a) * scale;
                let (anchor, target) = (pt(r), pt(x));
                let txs: Vec<Point<3>> = tx.into_iter().map(pt).collect();
                let sig = 0.05 * scale;
                let meas = NodeMeasurements {
                    bistatic: txs
                        .iter()
                        .enumerate()
                        .map(|(m, t)| {
                            let n = noise[m % 3] * sig;
                            (m, measure::bistatic_range(&target, t, &anchor) + n)
                        })
                        .collect(),
                    doa: doa.then(|| measure::doa(&target, &anchor) + 0.05 * noise[3]),
                    elevation: doa.then(|| measure::elevation(&target, &anchor) + 0.05 * noise[4]),
                    range: range.then(|| measure::one_way_range(&target, &anchor) + noise[5] * sig),
                };
                let p = P3::build(anchor, &txs, 1.0, &meas);
                // gamma relative to the scale of H (the paper's 1/gamma ~ 5 H).
                let h = p.h.norm().max(1.0);
                let gamma = 10f64.powf(log_g) / h;
                let truth = Vector4::new(target.x, target.y, target.z, (target - anchor).norm());
                let u = match u_mode {
                    // Near the lifted truth.
                    0 => truth + Vector4::from(du) * (0.2 * scale),
                    // Anywhere.
                    1 => Vector4::from(du) * (2.0 * scale),
                    // Below the apex (-u in the cone's direction).
                    _ => {
                        Vector4::new(anchor.x, anchor.y, anchor.z, 0.0)
                            + Vector4::new(du[0], du[1], du[2], -2.0) * scale
                    }
                };
                Case { p, u, gamma }
            },
        )
}

fn no_worse_than_brute_force(
    p: &P3,
    th: &Vector4<f64>,
    u: &Vector4<f64>,
    gamma: f64,
) -> Result<(), TestCaseError> {
    let scale = 1.0 + p.anchor.norm() + th.norm();
    let viol = p.cone_violation(th);
    prop_assert!(
        viol.abs() <= 1e-10 * scale,
        "off the cone by {viol}: {th:?}"
    );
    prop_assert!(th[3] >= 0.0, "d < 0: {th:?}");
    let f = p.prox_objective(th, u, gamma);
    let (fb, bth) = brute_force(p, u, gamma, 2000);
    let tol = 1e-9 * fb.abs() + eval_error(p, th, u, gamma) + eval_error(p, &bth, u, gamma);
    prop_assert!(
        f <= fb + tol,
        "prox {f:e} worse than brute force {fb:e} (tol {tol:e}): {th:?} vs {bth:?}"
    );
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, .. ProptestConfig::default() })]

    #[test]
    fn the_3d_gtrs_prox_is_no_worse_than_a_dense_search_of_the_prox_objective(c in case()) {
        let th = prox_gtrs(&c.p, &c.u, c.gamma).map_err(|e| TestCaseError::fail(e.to_string()))?;
        no_worse_than_brute_force(&c.p, &th, &c.u, c.gamma)?;
        // The dispatcher runs the same solver.
        let via = prox(LocalProx::Gtrs, &c.p, &c.u, c.gamma).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert_eq!(via, th);
    }

    #[test]
    fn the_3d_relaxed_prox_solves_its_normal_equations_written_from_the_rows(c in case()) {
        let th = prox_relaxed(&c.p, &c.u, c.gamma).map_err(|e| TestCaseError::fail(e.to_string()))?;
        // Gradient B^T (B th - g) + (th - u) / gamma, row by row.
        let mut grad = (th - c.u) / c.gamma;
        let mut mag = (th.abs() + c.u.abs()) / c.gamma;
        for (row, g) in c.p.rows.iter().zip(&c.p.g) {
            let b = Vector4::from(*row);
            let e = b.dot(&th) - g;
            let terms = b.abs().dot(&th.abs()) + g.abs();
            grad += b * e;
            mag += b.abs() * (e.abs() + terms);
        }
        for i in 0..4 {
            prop_assert!(grad[i].abs() <= 1e-9 * mag[i], "gradient {grad:?} against {mag:?}");
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, .. ProptestConfig::default() })]

    #[test]
    fn the_3d_gtrs_l0_prox_is_no_worse_than_a_brute_force_of_every_outlier_support(
        c in case(),
        kappa in 1usize..3,
        outlier in -40.0f64..40.0,
    ) {
        // One gross outlier on the first row.
        let mut g = c.p.g.clone();
        g[0] += outlier * (1.0 + g[0].abs());
        let p = P3::from_rows(c.p.anchor, c.p.rows.clone(), g, c.p.kinds.clone());
        let n = p.rows.len();
        let k = effective_kappa(n, kappa);
        let r = prox_gtrs_l0_enumerate(&p, &c.u, c.gamma, kappa)
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert_eq!(r.kappa, k);
        let hot = prox_gtrs_l0(&p, &c.u, c.gamma, kappa).map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert_eq!(hot, r.theta);
        // Brute force: every support of size k, its rows deleted, searched densely.
        let mut best = f64::INFINITY;
        let mut tol = 0.0f64;
        let mut idx: Vec<usize> = (0..k).collect();
        loop {
            let keep: Vec<usize> = (0..n).filter(|i| !idx.contains(i)).collect();
            let q = P3::from_rows(
                p.anchor,
                keep.iter().map(|&i| p.rows[i]).collect(),
                keep.iter().map(|&i| p.g[i]).collect(),
                keep.iter().map(|&i| p.kinds[i]).collect(),
            );
            let (fb, bth) = brute_force(&q, &c.u, c.gamma, 800);
            if fb < best {
                best = fb;
                tol = 1e-9 * fb.abs() + 2.0 * eval_error(&q, &bth, &c.u, c.gamma);
            }
            // Next combination in lexicographic order.
            let Some(i) = (0..k).rev().find(|&i| idx[i] < n - k + i) else { break };
            idx[i] += 1;
            for j in i + 1..k {
                idx[j] = idx[j - 1] + 1;
            }
        }
        if k == 0 {
            let (fb, bth) = brute_force(&p, &c.u, c.gamma, 800);
            best = fb;
            tol = 1e-9 * fb.abs() + 2.0 * eval_error(&p, &bth, &c.u, c.gamma);
        }
        prop_assert!(r.objective <= best + tol, "l0 prox {:e} worse than brute force {best:e}", r.objective);
        // The alternation never beats the exact enumeration, and its trace does not rise.
        let alt = prox_gtrs_l0_alternate(&p, &c.u, c.gamma, kappa, 32)
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        prop_assert!(alt.objective >= r.objective - 1e-9 * r.objective.abs());
        for w in alt.trace.windows(2) {
            prop_assert!(w[1] <= w[0] + 1e-9 * w[0].abs(), "trace rose: {:?}", alt.trace);
        }
    }
}

#[test]
fn noise_free_3d_rows_vanish_at_the_lifted_truth() {
    let anchor = Point::<3>::new(-1000.0, 400.0, 120.0);
    let txs = [
        Point::<3>::new(0.0, 0.0, 5.0),
        Point::<3>::new(2000.0, 1500.0, 10.0),
    ];
    let target = Point::<3>::new(520.0, 480.0, 310.0);
    let meas = NodeMeasurements {
        bistatic: txs
            .iter()
            .enumerate()
            .map(|(m, t)| (m, measure::bistatic_range(&target, t, &anchor)))
            .collect(),
        doa: Some(measure::doa(&target, &anchor)),
        elevation: Some(measure::elevation(&target, &anchor)),
        range: Some(measure::one_way_range(&target, &anchor)),
    };
    let p = P3::build(anchor, &txs, 2.0, &meas);
    assert_eq!(
        p.kinds,
        [
            RowKind::Bistatic(0),
            RowKind::Bistatic(1),
            RowKind::Doa(0),
            RowKind::Doa(1),
            RowKind::Range
        ]
    );
    let truth: Lifted<4> = crate::model::geometry::lift(&target, (target - anchor).norm());
    for (i, e) in p.residuals(&truth).iter().enumerate() {
        let terms: f64 =
            (0..4).map(|k| (p.rows[i][k] * truth[k]).abs()).sum::<f64>() + p.g[i].abs();
        assert!(
            e.abs() <= 1e-14 * terms,
            "row {i}: residual {e} against {terms}"
        );
    }
    // The two DOA rows are orthogonal to the measured direction and to each other.
    let dir = measure::direction::<3>(meas.doa.unwrap_or(0.0), meas.elevation.unwrap_or(0.0));
    let (a, b) = (
        Vector3::new(p.rows[2][0], p.rows[2][1], p.rows[2][2]),
        Vector3::new(p.rows[3][0], p.rows[3][1], p.rows[3][2]),
    );
    approx::assert_abs_diff_eq!(a.dot(&dir), 0.0, epsilon = 1e-15);
    approx::assert_abs_diff_eq!(b.dot(&dir), 0.0, epsilon = 1e-15);
    approx::assert_abs_diff_eq!(a.dot(&b), 0.0, epsilon = 1e-15);
    approx::assert_relative_eq!(a.norm(), 2.0, max_relative = 1e-15);
    approx::assert_relative_eq!(b.norm(), 2.0, max_relative = 1e-15);
    // Noise-free rows through the exact prox: the lifted truth is a fixed point.
    let th = prox_gtrs(&p, &truth, 1e-3).expect("prox");
    approx::assert_relative_eq!(th, truth, max_relative = 1e-9);
}

#[test]
fn a_3d_doa_without_an_elevation_gives_no_doa_rows() {
    let meas = NodeMeasurements {
        doa: Some(0.3),
        ..NodeMeasurements::default()
    };
    let p = P3::build(Point::<3>::zeros(), &[], 1.0, &meas);
    assert!(p.rows.is_empty());
}

#[test]
fn in_3d_each_doa_row_is_weighted_by_its_own_angle_noise() {
    let anchor = Point::<3>::new(0.0, 0.0, 50.0);
    let txs = [Point::<3>::new(100.0, -300.0, 0.0)];
    let target = Point::<3>::new(400.0, 300.0, 200.0);
    let meas = NodeMeasurements::clone(
        &crate::model::measure::SampleMeasurements::noise_free(
            &crate::model::measure::Geometry::<3> {
                drift: Vec::new(),
                transmitters: txs.to_vec(),
                receivers: vec![anchor],
            },
            &target,
            true,
            true,
        )
        .nodes[0],
    );
    let sig = crate::model::measure::Sigmas {
        range: 4.0,
        doa: 0.02,
        elevation: 0.05,
    };
    let plain = P3::build(anchor, &txs, 1.5, &meas);
    let w = P3::build_weighted(anchor, &txs, 1.5, &meas, Some(&sig));
    let d = (target - anchor).norm();
    let el = measure::elevation(&target, &anchor);
    for (i, kind) in plain.kinds.iter().enumerate() {
        let div = match kind {
            RowKind::Bistatic(m) => 2.0 * meas.bistatic[*m].1 * sig.range,
            RowKind::Doa(0) => 1.5 * d * el.cos() * sig.doa,
            RowKind::Doa(_) => 1.5 * d * sig.elevation,
            RowKind::Range => sig.range,
        };
        for k in 0..4 {
            approx::assert_relative_eq!(
                w.rows[i][k],
                plain.rows[i][k] / div,
                max_relative = 1e-9,
                epsilon = 1e-300
            );
        }
    }
}
