//! The robust bistatic estimators in 3-D: exact data recovered by each, the
//! least-squares point stationary against a search of 26 directions, and a
//! gross outlier found and separated by `l0os` and resisted by `lad`.

use super::*;
use crate::model::geometry::Point;
use crate::model::measure::{self, Geometry};

fn p3(x: f64, y: f64, z: f64) -> Point<3> {
    Point::<3>::new(x, y, z)
}

/// Four transmitters and four receivers spread over 1 km and 600 m of depth.
fn ocean() -> Geometry<3> {
    Geometry {
        drift: Vec::new(),
        transmitters: vec![
            p3(-500.0, -500.0, 10.0),
            p3(500.0, -500.0, 20.0),
            p3(500.0, 500.0, 15.0),
            p3(-500.0, 500.0, 5.0),
        ],
        receivers: vec![
            p3(-400.0, 0.0, 300.0),
            p3(400.0, 0.0, 600.0),
            p3(0.0, -400.0, 150.0),
            p3(0.0, 400.0, 450.0),
        ],
    }
}

fn links(g: &Geometry<3>, x: &Point<3>) -> Vec<BistaticLink> {
    let mut out = Vec::new();
    for (rx, r) in g.receivers.iter().enumerate() {
        for (tx, t) in g.transmitters.iter().enumerate() {
            out.push(BistaticLink {
                tx,
                rx,
                rho: measure::bistatic_range(x, t, r),
            });
        }
    }
    out
}

#[test]
fn every_robust_estimator_recovers_a_3d_target_from_exact_ranges() {
    let g = ocean();
    let x = p3(120.0, -80.0, 260.0);
    let l = links(&g, &x);
    let found = [
        ls(&g, &l, &LsConfig::default()).expect("ls").position,
        lad(&g, &l, &IrlsConfig::default()).expect("lad").position,
        lq_irls(&g, &l, &IrlsConfig::default())
            .expect("lq")
            .position,
        l0os(&g, &l, &L0osConfig::new(1)).expect("l0os").position,
    ];
    for (k, e) in found.iter().enumerate() {
        assert!((e - x).norm() < 1e-3, "estimator {k}: {e:?} vs {x:?}");
    }
}

#[test]
fn the_3d_least_squares_point_is_stationary_against_a_search_of_directions() {
    let g = ocean();
    let x = p3(120.0, -80.0, 260.0);
    let mut l = links(&g, &x);
    // Noise of a few metres, deterministic.
    for (i, link) in l.iter_mut().enumerate() {
        link.rho += 3.0 * ((i as f64) * 1.7).sin();
    }
    let est = ls(&g, &l, &LsConfig::default()).expect("ls");
    let f = |e: &Point<3>| -> f64 {
        l.iter()
            .map(|k| {
                let r =
                    k.rho - measure::bistatic_range(e, &g.transmitters[k.tx], &g.receivers[k.rx]);
                r * r
            })
            .sum()
    };
    let f0 = f(&est.position);
    approx::assert_relative_eq!(est.objective, f0, max_relative = 1e-9);
    for i in -1i32..=1 {
        for j in -1i32..=1 {
            for k in -1i32..=1 {
                if (i, j, k) == (0, 0, 0) {
                    continue;
                }
                let d = p3(f64::from(i), f64::from(j), f64::from(k)).normalize() * 1e-2;
                assert!(
                    f(&(est.position + d)) >= f0 - 1e-9 * f0,
                    "descent along {d:?}"
                );
            }
        }
    }
}

#[test]
fn in_3d_l0os_separates_a_gross_outlier_and_lad_resists_it() {
    let g = ocean();
    let x = p3(120.0, -80.0, 260.0);
    let mut l = links(&g, &x);
    l[5].rho += 400.0;
    // The MM update creeps near the optimum: a tight tolerance shows where it goes.
    let cfg = L0osConfig {
        tol: 1e-12,
        max_iter: 20_000,
        ..L0osConfig::new(1)
    };
    let r = l0os(&g, &l, &cfg).expect("l0os");
    assert_eq!(r.outliers, vec![5]);
    assert!(
        (r.position - x).norm() < 1e-3,
        "{:?} {} {}",
        r.position,
        r.iterations,
        r.converged
    );
    let plain = ls(&g, &l, &LsConfig::default()).expect("ls").position;
    let robust = lad(&g, &l, &IrlsConfig::default()).expect("lad").position;
    assert!(
        (robust - x).norm() < 0.2 * (plain - x).norm(),
        "lad {robust:?}, ls {plain:?}"
    );
}

#[test]
fn a_given_2d_starting_point_is_refused_in_3d() {
    let g = ocean();
    let l = links(&g, &p3(0.0, 0.0, 100.0));
    let cfg = LsConfig {
        init: Init::Point([1.0, 2.0]),
        ..LsConfig::default()
    };
    assert!(matches!(
        ls(&g, &l, &cfg),
        Err(RobustError::InvalidConfig { key: "init", .. })
    ));
}
