//! Balls and prolate spheroids (the 3-D regions) against brute force: the
//! exact projection against a dense search of the surface, the bounding box
//! against the surface's extreme points, the quadratic form against the
//! focal definition, and POCS reaching an intersection.

use super::region::EllipseGeom;
use super::*;
use crate::model::geometry::Point;
use crate::model::rng::SonarRng;
use rand::{RngExt, SeedableRng};

fn p3(x: f64, y: f64, z: f64) -> Point<3> {
    Point::<3>::new(x, y, z)
}

/// An orthonormal basis `(u, v, w)` with `u` the spheroid's axis.
fn frame(u: &Point<3>) -> (Point<3>, Point<3>) {
    let seed = if u.x.abs() < 0.9 {
        p3(1.0, 0.0, 0.0)
    } else {
        p3(0.0, 1.0, 0.0)
    };
    let v = (seed - u * u.dot(&seed)).normalize();
    (v, u.cross(&v))
}

/// The nearest surface point's distance by a dense grid of the two surface
/// angles, refined by a pattern search.
fn brute_distance(g: &EllipseGeom<3>, x: &Point<3>) -> f64 {
    let (v, w) = frame(&g.u);
    let at = |th: f64, ph: f64| {
        let s = g.c + g.u * (g.a * th.cos()) + (v * ph.cos() + w * ph.sin()) * (g.b * th.sin());
        (s - x).norm()
    };
    let n = 200;
    let mut best = (f64::INFINITY, 0.0, 0.0);
    for i in 0..=n {
        for j in 0..n {
            let (th, ph) = (
                std::f64::consts::PI * i as f64 / n as f64,
                std::f64::consts::TAU * j as f64 / n as f64,
            );
            let d = at(th, ph);
            if d < best.0 {
                best = (d, th, ph);
            }
        }
    }
    let (mut d, mut th, mut ph) = best;
    let mut step = 0.05;
    while step > 1e-12 {
        let mut moved = false;
        for (a, b) in [(step, 0.0), (-step, 0.0), (0.0, step), (0.0, -step)] {
            let e = at(th + a, ph + b);
            if e < d {
                (d, th, ph) = (e, th + a, ph + b);
                moved = true;
            }
        }
        if !moved {
            step *= 0.5;
        }
    }
    d
}

fn random_spheroid(rng: &mut SonarRng) -> (Point<3>, Point<3>, f64) {
    let mut pt = |s: f64| {
        p3(
            rng.random_range(-s..s),
            rng.random_range(-s..s),
            rng.random_range(-s..s),
        )
    };
    let (f1, f2) = (pt(5.0), pt(5.0));
    let dist = (f2 - f1).norm();
    let sum = dist * (1.0 + 10f64.powf(rng.random_range(-3.0..0.5)));
    (f1, f2, sum)
}

#[test]
fn the_spheroid_projection_is_the_nearest_point_of_a_dense_search_of_the_surface() {
    let mut rng = SonarRng::seed_from_u64(21);
    for _ in 0..60 {
        let (f1, f2, sum) = random_spheroid(&mut rng);
        let reg = Region::ellipse(f1, f2, sum);
        let g = EllipseGeom::new(&f1, &f2, sum).expect("nonempty");
        let x = p3(
            rng.random_range(-12.0..12.0),
            rng.random_range(-12.0..12.0),
            rng.random_range(-12.0..12.0),
        );
        let p = reg.project(&x).expect("nonempty");
        if reg.violation(&x) <= 0.0 {
            assert_eq!(p, x, "an inside point is its own projection");
            continue;
        }
        // On the surface, and no farther than the brute force's nearest point.
        assert!(
            reg.violation(&p).abs() <= 1e-9 * (1.0 + sum),
            "{}",
            reg.violation(&p)
        );
        let (dp, db) = ((p - x).norm(), brute_distance(&g, &x));
        assert!(
            dp <= db + 1e-9 * (1.0 + db),
            "projection {dp} against brute force {db}"
        );
    }
}

#[test]
fn the_spheroid_bounding_box_touches_the_surface_on_every_side() {
    let mut rng = SonarRng::seed_from_u64(22);
    for _ in 0..40 {
        let (f1, f2, sum) = random_spheroid(&mut rng);
        let reg = Region::ellipse(f1, f2, sum);
        let g = EllipseGeom::new(&f1, &f2, sum).expect("nonempty");
        let (lo, hi) = reg.aabb().expect("nonempty");
        let (v, w) = frame(&g.u);
        let (mut seen_lo, mut seen_hi) = (
            Point::<3>::repeat(f64::INFINITY),
            Point::<3>::repeat(f64::NEG_INFINITY),
        );
        let n = 300;
        for i in 0..=n {
            for j in 0..n {
                let (th, ph) = (
                    std::f64::consts::PI * i as f64 / n as f64,
                    std::f64::consts::TAU * j as f64 / n as f64,
                );
                let s =
                    g.c + g.u * (g.a * th.cos()) + (v * ph.cos() + w * ph.sin()) * (g.b * th.sin());
                seen_lo = seen_lo.inf(&s);
                seen_hi = seen_hi.sup(&s);
            }
        }
        for k in 0..3 {
            let tol = 1e-9 * (1.0 + sum);
            assert!(
                lo[k] <= seen_lo[k] + tol && seen_hi[k] <= hi[k] + tol,
                "box misses the surface"
            );
            // The grid's extremes approach the box to the grid's resolution.
            let slack = 1e-3 * sum;
            assert!(
                seen_lo[k] - lo[k] <= slack && hi[k] - seen_hi[k] <= slack,
                "box too loose"
            );
        }
    }
}

#[test]
fn a_3d_regions_quadratics_agree_with_its_focal_definition() {
    let mut rng = SonarRng::seed_from_u64(23);
    for _ in 0..40 {
        let (f1, f2, sum) = random_spheroid(&mut rng);
        let ball = Region::disc(f1, 0.5 * sum);
        for reg in [Region::ellipse(f1, f2, sum), ball] {
            let qs = reg.quadratics().expect("nonempty");
            for _ in 0..50 {
                let x = p3(
                    rng.random_range(-12.0..12.0),
                    rng.random_range(-12.0..12.0),
                    rng.random_range(-12.0..12.0),
                );
                let viol = reg.violation(&x);
                if viol.abs() < 1e-6 {
                    continue;
                }
                let inside = qs.iter().all(|q| q.eval(&x) <= 0.0);
                assert_eq!(inside, viol < 0.0, "{reg:?} at {x:?}");
            }
        }
    }
}

#[test]
fn pocs_reaches_a_point_of_an_intersection_of_balls_and_spheroids() {
    let truth = p3(1.0, 2.0, 3.0);
    let anchors = [
        p3(0.0, 0.0, 0.0),
        p3(6.0, 0.0, 1.0),
        p3(0.0, 7.0, 2.0),
        p3(2.0, 2.0, 9.0),
    ];
    let mut regions: Vec<Region<3>> = anchors
        .iter()
        .map(|a| Region::from_range(*a, (truth - a).norm(), 0.5))
        .collect();
    regions.push(Region::from_bistatic(
        anchors[0],
        anchors[3],
        (truth - anchors[0]).norm() + (truth - anchors[3]).norm(),
        0.5,
    ));
    let r = pocs(&regions, p3(-20.0, 30.0, -10.0), 10_000, 1e-9).expect("finite");
    assert!(r.feasible);
    for reg in &regions {
        assert!(reg.distance(&r.x).expect("nonempty") <= 1e-9);
    }
}

/// A random nonempty 3-D intersection: four to six balls around a true
/// point with positive range errors, and one spheroid through two of the
/// anchors when `spheroid`.
fn random_set(rng: &mut SonarRng, spheroid: bool) -> (Vec<Region<3>>, Point<3>) {
    let truth = p3(
        rng.random_range(0.0..10.0),
        rng.random_range(0.0..10.0),
        rng.random_range(0.0..10.0),
    );
    let n = rng.random_range(4..7);
    let anchors: Vec<Point<3>> = (0..n)
        .map(|_| {
            p3(
                rng.random_range(-2.0..12.0),
                rng.random_range(-2.0..12.0),
                rng.random_range(-2.0..12.0),
            )
        })
        .collect();
    let mut regions: Vec<Region<3>> = anchors
        .iter()
        .map(|a| Region::from_range(*a, (truth - a).norm() + rng.random_range(0.0..2.0), 0.0))
        .collect();
    if spheroid {
        let (t, r) = (anchors[0], anchors[1]);
        let rho = (truth - t).norm() + (truth - r).norm() + rng.random_range(0.0..2.0);
        regions.push(Region::from_bistatic(t, r, rho, 0.0));
    }
    (regions, truth)
}

/// Points of the set: random points of its relaxed box that lie in it, and
/// POCS from random starts far outside (which stops on the boundary).
fn sample_set(rng: &mut SonarRng, regions: &[Region<3>]) -> Vec<Point<3>> {
    let b = relaxed_box(regions).expect("nonempty");
    let mut out = Vec::new();
    for _ in 0..20_000 {
        let x = Point::<3>::from_fn(|i, _| rng.random_range(b.lo[i]..=b.hi[i]));
        if regions.iter().all(|r| r.violation(&x) <= 0.0) {
            out.push(x);
        }
    }
    for _ in 0..300 {
        let x0 = Point::<3>::from_fn(|i, _| rng.random_range(-40.0..50.0) + 0.0 * b.lo[i]);
        if let Ok(r) = pocs(regions, x0, 5000, 1e-12)
            && r.feasible
        {
            out.push(r.x);
        }
    }
    out
}

#[test]
fn every_3d_bound_holds_every_sampled_point_of_the_set_and_the_orderings_hold() {
    let mut rng = SonarRng::seed_from_u64(24);
    for case in 0..12 {
        let (regions, truth) = random_set(&mut rng, case % 2 == 1);
        let x_hat = truth
            + p3(
                rng.random_range(-2.0..2.0),
                rng.random_range(-2.0..2.0),
                rng.random_range(-2.0..2.0),
            );
        let pts = sample_set(&mut rng, &regions);
        assert!(!pts.is_empty());
        let far = pts.iter().map(|p| (p - x_hat).norm()).fold(0.0, f64::max);
        let v = |f: fn(&[Region<3>], &Point<3>) -> Result<BoundOutcome, BoundError>| {
            f(&regions, &x_hat)
                .expect("solves")
                .value()
                .expect("nonempty")
        };
        let (rbbox, bbox, minball, maxdis) =
            (v(upp_rbbox), v(upp_bbox), v(upp_minball), v(upp_maxdis));
        for (name, b) in [
            ("rbbox", rbbox),
            ("bbox", bbox),
            ("minball", minball),
            ("maxdis", maxdis),
        ] {
            assert!(
                b >= far * (1.0 - 1e-12),
                "case {case}: {name} {b} below a sampled distance {far}"
            );
        }
        assert!(
            bbox <= rbbox * (1.0 + 1e-9),
            "case {case}: bbox {bbox} > rbbox {rbbox}"
        );
        assert!(
            maxdis <= minball * (1.0 + 1e-6),
            "case {case}: maxdis {maxdis} > minball {minball}"
        );
        // The certified box holds every sample, inside the relaxed box.
        let i = Intersection::new(&regions)
            .expect("finite")
            .expect("nonempty");
        let bx = i.bounding_box().expect("solves").expect("nonempty");
        let rb = i.relaxed_box();
        for p in &pts {
            assert!(bx.contains(p, 1e-9), "case {case}: {p:?} outside {bx:?}");
        }
        for k in 0..3 {
            assert!(bx.lo[k] >= rb.lo[k] - 1e-6 && bx.hi[k] <= rb.hi[k] + 1e-6);
        }
    }
}

#[test]
fn the_3d_min_ball_of_balls_agrees_between_the_simplex_qp_and_the_s_lemma_sdp() {
    let mut rng = SonarRng::seed_from_u64(25);
    for _ in 0..8 {
        let (regions, _) = random_set(&mut rng, false);
        let i = Intersection::new(&regions)
            .expect("finite")
            .expect("nonempty");
        let qp = i.min_ball().expect("solves").expect("nonempty");
        let sdp = i.min_ball_via_sdp().expect("solves").expect("nonempty");
        // As in 2-D: the radius to the solvers' accuracy, the centre (on
        // which the radius depends only to second order) to 1e-4.
        let s = qp.radius.max(1.0);
        assert!((qp.radius - sdp.radius).abs() < 1e-5 * s, "{qp:?} vs {sdp:?}");
        assert!((qp.center - sdp.center).norm() < 1e-4 * s, "{qp:?} vs {sdp:?}");
    }
}

#[test]
fn disjoint_3d_balls_are_reported_empty_by_every_bound() {
    let regions = [
        Region::disc(p3(0.0, 0.0, 0.0), 1.0),
        Region::disc(p3(0.0, 0.0, 5.0), 1.0),
    ];
    let x = p3(0.0, 0.0, 2.5);
    for f in [upp_rbbox, upp_bbox, upp_minball, upp_maxdis] {
        assert_eq!(f(&regions, &x).expect("solves"), BoundOutcome::Empty);
    }
}
