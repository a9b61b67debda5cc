//! `upp_exact` in 3-D with spheroids against a brute force that shares
//! nothing with its search: the set is star-shaped from an interior point
//! `z`, so its boundary is `z + t(e) e` over unit `e`, with `t(e)` found by
//! bisection on the pieces' own membership; the farthest boundary point from
//! `x_hat` over a dense Fibonacci grid of `e`, the best refined by a random
//! pattern search in the two angles.

use super::*;
use crate::model::geometry::Point;
use crate::model::rng::SonarRng;
use rand::{RngExt, SeedableRng};

type P3 = Point<3>;

fn p3(x: f64, y: f64, z: f64) -> P3 {
    P3::new(x, y, z)
}

fn unit(t: f64, f: f64) -> P3 {
    let (st, ct) = t.sin_cos();
    let (sf, cf) = f.sin_cos();
    p3(st * cf, st * sf, ct)
}

/// The boundary point of the set on the ray from the interior `z` along `e`.
fn exit(regions: &[Region<3>], z: &P3, e: &P3, reach: f64) -> P3 {
    let inside = |t: f64| regions.iter().all(|r| r.violation(&(z + e * t)) <= 0.0);
    let (mut lo, mut hi) = (0.0, reach);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if inside(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-15 * reach {
            break;
        }
    }
    z + e * lo
}

/// The brute force of the module docs: the largest distance from `x_hat` of
/// a boundary point found.
fn brute_exact(regions: &[Region<3>], z: &P3, x_hat: &P3, rng: &mut SonarRng) -> f64 {
    let reach = 100.0;
    let far = |t: f64, f: f64| (exit(regions, z, &unit(t, f), reach) - x_hat).norm();
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let n = 20_000;
    let mut grid: Vec<(f64, f64, f64)> = (0..n)
        .map(|k| {
            let c = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
            let (t, f) = (c.acos(), golden * k as f64);
            (far(t, f), t, f)
        })
        .collect();
    grid.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut best = 0.0f64;
    for &(d0, t0, f0) in grid.iter().take(6) {
        let (mut d, mut t, mut f) = (d0, t0, f0);
        let mut step = 0.02;
        while step > 1e-12 {
            // Many directions: where two surfaces meet nearly parallel (a
            // thin lens) the distance rises only in a narrow wedge along
            // their crease.
            let mut moved = false;
            for _ in 0..400 {
                let a = rng.random_range(0.0..std::f64::consts::TAU);
                let (tt, ff) = (t + step * a.cos(), f + step * a.sin());
                let e = far(tt, ff);
                if e > d {
                    (d, t, f) = (e, tt, ff);
                    moved = true;
                    break;
                }
            }
            if !moved {
                step *= 0.5;
            }
        }
        best = best.max(d);
    }
    best
}

/// A random set around `truth`: two to four balls and one to three
/// spheroids with positive range errors (`truth` inside every piece).
fn random_set(rng: &mut SonarRng, tight: bool) -> (Vec<Region<3>>, P3) {
    let truth = p3(
        rng.random_range(0.0..10.0),
        rng.random_range(0.0..10.0),
        rng.random_range(0.0..10.0),
    );
    let anchor = |rng: &mut SonarRng| {
        p3(
            rng.random_range(-5.0..15.0),
            rng.random_range(-5.0..15.0),
            rng.random_range(-5.0..15.0),
        )
    };
    let error = |rng: &mut SonarRng| {
        if tight {
            rng.random_range(0.01..0.1)
        } else {
            rng.random_range(0.2..2.0)
        }
    };
    let mut regions = Vec::new();
    for _ in 0..rng.random_range(0..3) {
        let a = anchor(rng);
        regions.push(Region::from_range(a, (truth - a).norm() + error(rng), 0.0));
    }
    for _ in 0..rng.random_range(1..4) {
        let (t, r) = (anchor(rng), anchor(rng));
        let rho = (truth - t).norm() + (truth - r).norm() + error(rng);
        regions.push(Region::from_bistatic(t, r, rho, 0.0));
    }
    (regions, truth)
}

#[test]
fn the_3d_exact_worst_case_with_spheroids_is_within_1e6_of_a_brute_force_of_boundary_rays_nested_sets_included()
 {
    let mut rng = SonarRng::seed_from_u64(38);
    for case in 0..20 {
        let (mut regions, truth) = random_set(&mut rng, case % 4 == 1);
        if case % 4 == 3 {
            // Nested: a small spheroid about the truth, inside (or nearly
            // inside) every other piece.
            let axis = p3(0.1, -0.05, 0.08);
            regions.push(Region::ellipse(truth + axis, truth - axis, 0.6));
        }
        let x_hat = match case % 3 {
            0 => truth,
            // Anywhere near: inside or outside the set.
            _ => {
                truth
                    + p3(
                        rng.random_range(-2.0..2.0),
                        rng.random_range(-2.0..2.0),
                        rng.random_range(-2.0..2.0),
                    )
            }
        };
        let i = Intersection::new(&regions)
            .expect("finite")
            .expect("nonempty");
        let exact = i
            .upp_exact(&x_hat)
            .expect("solves")
            .value()
            .expect("nonempty");
        let brute = brute_exact(&regions, &truth, &x_hat, &mut rng);
        assert!(
            exact >= brute * (1.0 - 1e-12),
            "case {case}: exact {exact} below a point of the set at {brute}"
        );
        assert!(
            exact <= brute * (1.0 + 1e-6),
            "case {case}: exact {exact} more than 1e-6 above the brute force {brute}"
        );
        for f in [upp_bbox, upp_minball, upp_maxdis] {
            let b = f(&regions, &x_hat)
                .expect("solves")
                .value()
                .expect("nonempty");
            assert!(
                exact <= b * (1.0 + 1e-7),
                "case {case}: exact {exact} above {b}"
            );
        }
    }
}

#[test]
fn near_tangent_spheroids_give_the_tip_of_their_thin_lens() {
    // Two spheroids whose sums are just above what it takes to meet: a thin
    // lens around the point between them.
    let (a, b, c) = (p3(0.0, 0.0, 0.0), p3(1.0, 0.0, 0.0), p3(3.0, 0.5, 0.2));
    let mid = p3(2.0, 0.1, 0.0);
    let s1 = (mid - a).norm() + (mid - b).norm() + 1e-4;
    let s2 = (mid - c).norm() + (mid - p3(5.0, -1.0, 0.4)).norm() + 1e-4;
    let regions = [
        Region::ellipse(a, b, s1),
        Region::ellipse(c, p3(5.0, -1.0, 0.4), s2),
    ];
    let i = Intersection::new(&regions)
        .expect("finite")
        .expect("nonempty");
    let x_hat = mid + p3(0.0, 0.0, 0.3);
    let exact = i
        .upp_exact(&x_hat)
        .expect("solves")
        .value()
        .expect("nonempty");
    let mut rng = SonarRng::seed_from_u64(39);
    let brute = brute_exact(&regions, &mid, &x_hat, &mut rng);
    assert!(exact >= brute * (1.0 - 1e-12), "{exact} < {brute}");
    assert!(exact <= brute * (1.0 + 1e-6), "{exact} >> {brute}");
}

#[test]
fn a_spheroid_holding_the_whole_set_leaves_the_closed_form_of_balls() {
    // A ball centred on x_hat inside a large spheroid: every point of its
    // sphere is equally far, which the search could not certify; the
    // spheroid holds the relaxed box and is dropped.
    let centre = p3(1.0, 2.0, 3.0);
    let regions = [
        Region::disc(centre, 2.0),
        Region::ellipse(p3(-5.0, 2.0, 3.0), p3(7.0, 2.0, 3.0), 20.0),
    ];
    let i = Intersection::new(&regions)
        .expect("finite")
        .expect("nonempty");
    let exact = i
        .upp_exact(&centre)
        .expect("solves")
        .value()
        .expect("nonempty");
    approx::assert_relative_eq!(exact, 2.0, max_relative = 1e-8);
}

#[test]
fn a_single_spheroid_gives_its_farthest_point_in_closed_form() {
    // From its centre, the farthest points of a prolate spheroid are the
    // ends of its major axis: distance sum / 2.
    let (f1, f2) = (p3(-3.0, 0.0, 1.0), p3(3.0, 0.0, 1.0));
    let regions = [Region::ellipse(f1, f2, 10.0)];
    let i = Intersection::new(&regions)
        .expect("finite")
        .expect("nonempty");
    let exact = i
        .upp_exact(&p3(0.0, 0.0, 1.0))
        .expect("solves")
        .value()
        .expect("nonempty");
    assert!((5.0..=5.0 * (1.0 + 1e-7)).contains(&exact), "{exact}");
    // From a point on the minor axis at distance 1 from the centre: the
    // farthest point of the ellipse x^2/25 + y^2/16 = 1 from (0, 1), by the
    // closed form of the stationary condition, is at y = -16/9, distance
    // sqrt(25 (1 - y^2/16) + (y - 1)^2).
    let y: f64 = -16.0 / 9.0;
    let expect = (25.0 * (1.0 - y * y / 16.0) + (y - 1.0) * (y - 1.0)).sqrt();
    let exact = i
        .upp_exact(&p3(0.0, 1.0, 1.0))
        .expect("solves")
        .value()
        .expect("nonempty");
    assert!(
        (expect..=expect * (1.0 + 1e-7)).contains(&exact),
        "{exact} against {expect}"
    );
}

#[test]
fn disjoint_spheroids_are_reported_empty() {
    let regions = [
        Region::ellipse(p3(0.0, 0.0, 0.0), p3(1.0, 0.0, 0.0), 2.0),
        Region::ellipse(p3(10.0, 0.0, 0.0), p3(11.0, 0.0, 0.0), 2.0),
    ];
    assert!(Intersection::new(&regions).expect("finite").is_none());
    assert!(matches!(
        upp_exact(&regions, &p3(0.0, 0.0, 0.0)),
        Ok(BoundOutcome::Empty)
    ));
}
