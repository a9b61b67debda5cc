//! The online trackers and their closed-form helpers in 3-D: the loss's
//! gradient and Hessian against finite differences, the linear least squares
//! against exact data, ONM and OGD converging on a static target, and the
//! any-dimension Newton rule against the 2-D closed form.

use super::*;
use crate::model::measure::{Geometry, SampleMeasurements};
use crate::model::rng::{Stream, stream_rng};
use approx::assert_relative_eq;
use proptest::prelude::*;
use rand::RngExt;

fn p3(x: f64, y: f64, z: f64) -> Point<3> {
    Point::<3>::new(x, y, z)
}

/// Two transmitters near the surface, five receivers at several depths.
fn ocean() -> Geometry<3> {
    Geometry {
        drift: Vec::new(),
        transmitters: vec![p3(0.0, 0.0, 5.0), p3(2000.0, 1800.0, 10.0)],
        receivers: vec![
            p3(-1000.0, -1000.0, 100.0),
            p3(1500.0, -1000.0, 400.0),
            p3(-1000.0, 1000.0, 50.0),
            p3(1500.0, 1000.0, 800.0),
            p3(300.0, 2500.0, 250.0),
        ],
    }
}

fn exact(g: &Geometry<3>, x: &Point<3>, range: bool) -> SampleMeasurements {
    SampleMeasurements::noise_free(g, x, false, range)
}

#[test]
fn the_3d_loss_gradient_and_hessian_match_finite_differences() {
    let g = ocean();
    let s = exact(&g, &p3(500.0, 420.0, 300.0), true);
    // Away from the truth, so every residual is nonzero.
    let x = p3(620.0, 300.0, 180.0);
    let ev = loss_grad_hess(&g, &s, &x).expect("finite");
    let h = 1e-3;
    for k in 0..3 {
        let mut xp = x;
        let mut xm = x;
        xp[k] += h;
        xm[k] -= h;
        let (fp, fm) = (
            loss(&g, &s, &xp).expect("finite"),
            loss(&g, &s, &xm).expect("finite"),
        );
        assert_relative_eq!((fp - fm) / (2.0 * h), ev.grad[k], max_relative = 1e-6);
        let (gp, gm) = (
            loss_grad(&g, &s, &xp).expect("finite").grad,
            loss_grad(&g, &s, &xm).expect("finite").grad,
        );
        for i in 0..3 {
            assert_relative_eq!(
                (gp[i] - gm[i]) / (2.0 * h),
                ev.hess[(i, k)],
                max_relative = 1e-5,
                epsilon = 1e-6
            );
        }
    }
}

#[test]
fn the_3d_linear_least_squares_recover_the_position_from_exact_ranges() {
    let mut rng = stream_rng(3, Stream::Aux, 0);
    for _ in 0..100 {
        let mut draw = |s: f64| {
            p3(
                rng.random_range(-s..s),
                rng.random_range(-s..s),
                rng.random_range(-s..s),
            )
        };
        let x = draw(50.0);
        let anchors: Vec<(Point<3>, f64)> = (0..6)
            .map(|_| {
                let a = draw(100.0);
                (a, (x - a).norm())
            })
            .collect();
        let xh = ols_toa(&anchors).expect("regular");
        assert!((xh - x).norm() < 1e-8, "{xh:?} vs {x:?}");
    }
    // Four coplanar anchors do not fix a 3-D position; three are too few.
    let plane: Vec<(Point<3>, f64)> = [
        p3(0.0, 0.0, 1.0),
        p3(1.0, 0.0, 1.0),
        p3(0.0, 1.0, 1.0),
        p3(1.0, 1.0, 1.0),
    ]
    .into_iter()
    .map(|a| (a, 1.0))
    .collect();
    assert!(ols_toa(&plane).unwrap_err().contains("coplanar"));
    assert!(ols_toa(&plane[..3]).unwrap_err().contains("need >= 4"));
    // Bistatic ranges alone, through the lifted system.
    let g = ocean();
    let x = p3(512.0, 433.0, 310.0);
    let xh = ols_position(&g, &exact(&g, &x, false)).expect("regular");
    assert!((xh - x).norm() < 1e-6, "{xh:?} vs {x:?}");
    // One-way ranges win when there are enough of them.
    let xh = ols_position(&g, &exact(&g, &x, true)).expect("regular");
    assert!((xh - x).norm() < 1e-6, "{xh:?} vs {x:?}");
}

#[test]
fn onm_and_ogd_in_3d_converge_on_a_static_target_from_exact_data() {
    let g = ocean();
    let x = p3(512.0, 433.0, 310.0);
    let s = exact(&g, &x, true);
    let start = x + p3(40.0, -30.0, 25.0);
    let mut onm = OnmTracker::new(start, NewtonDamping::default()).expect("valid");
    let mut ogd = OgdTracker::new(start, StepSize::Lipschitz { scale: 1.0 }).expect("valid");
    let e0 = (start - x).norm();
    for t in 1..=30 {
        onm.step(&g, &s, t).expect("step");
        ogd.step(&g, &s, t).expect("step");
    }
    assert!((onm.estimate() - x).norm() < 1e-6, "{:?}", onm.estimate());
    assert!(
        (ogd.estimate() - x).norm() < 0.2 * e0,
        "{:?}",
        ogd.estimate()
    );
}

fn sym2() -> impl Strategy<Value = (Mat2, Vec2)> {
    (
        prop::array::uniform3(-10.0f64..10.0),
        prop::array::uniform2(-10.0f64..10.0),
    )
        .prop_map(|(h, g)| (Mat2::new(h[0], h[1], h[1], h[2]), Vec2::new(g[0], g[1])))
}

proptest! {
    #[test]
    fn the_any_dimension_newton_rule_agrees_with_the_2d_closed_form((h, g) in sym2()) {
        for damping in [
            NewtonDamping::default(),
            NewtonDamping::Plain { rel_floor: 1e-6, abs_floor: 1e-9 },
            NewtonDamping::GradientFallback { rel_floor: 1e-6, abs_floor: 1e-9, eta: 0.5 },
        ] {
            let closed = newton_displacement_2d(&h, &g, &damping);
            let eigen = newton_displacement_eigen::<2>(&h, &g, &damping);
            match (closed, eigen) {
                (Ok((a, da)), Ok((b, db))) => {
                    prop_assert_eq!(da, db);
                    prop_assert!((a - b).norm() <= 1e-9 * (1.0 + a.norm()), "{a:?} vs {b:?}");
                }
                (Err(_), Err(_)) => {}
                (a, b) => prop_assert!(false, "closed form {a:?}, eigen {b:?}"),
            }
        }
        let closed = sym_norm(&h);
        let eigen = crate::model::linalg::sym_eigen(&h).map(|(l, _)| l.amax()).unwrap_or(f64::NAN);
        prop_assert!((closed - eigen).abs() <= 1e-12 * (1.0 + closed));
    }
}
