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
        assert!(
            (qp.radius - sdp.radius).abs() < 1e-5 * s,
            "{qp:?} vs {sdp:?}"
        );
        assert!(
            (qp.center - sdp.center).norm() < 1e-4 * s,
            "{qp:?} vs {sdp:?}"
        );
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

/// Brute force of `max_{x in B} ||x - x_hat||` over balls: Fibonacci points
/// of every sphere that lie in `B`, the best refined by a pattern search in
/// the sphere's two angles that keeps to `B`.
fn brute_exact(regions: &[Region<3>], x_hat: &Point<3>) -> f64 {
    // Points computed on a sphere are on it only to rounding.
    let inside = |x: &Point<3>| regions.iter().all(|r| r.violation(x) <= 1e-12 * 50.0);
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let mut best = 0.0f64;
    for r in regions {
        let Region::Disc { center, radius } = *r else {
            panic!("balls only")
        };
        let at = |t: f64, f: f64| {
            let (st, ct) = t.sin_cos();
            let (sf, cf) = f.sin_cos();
            center + p3(st * cf, st * sf, ct) * radius
        };
        let n = 6000;
        let mut seeds: Vec<(f64, f64, f64)> = (0..n)
            .filter_map(|k| {
                let z = 1.0 - 2.0 * (k as f64 + 0.5) / n as f64;
                let (t, f) = (z.acos(), golden * k as f64);
                let x = at(t, f);
                inside(&x).then(|| ((x - x_hat).norm(), t, f))
            })
            .collect();
        seeds.sort_by(|a, b| b.0.total_cmp(&a.0));
        for &(d0, t0, f0) in seeds.iter().take(5) {
            let (mut d, mut t, mut f) = (d0, t0, f0);
            let mut step = 0.02;
            while step > 1e-13 {
                let mut moved = false;
                for (a, b) in [(step, 0.0), (-step, 0.0), (0.0, step), (0.0, -step)] {
                    let x = at(t + a, f + b);
                    let e = (x - x_hat).norm();
                    if e > d && inside(&x) {
                        (d, t, f) = (e, t + a, f + b);
                        moved = true;
                    }
                }
                if !moved {
                    step *= 0.5;
                }
            }
            best = best.max(d);
        }
    }
    // A pattern search in the angles stalls where B's boundary crosses the
    // sphere; the circles where two spheres meet are searched on their own:
    // 20000 points each, the best refined by golden sections in its angle.
    let balls: Vec<(Point<3>, f64)> = regions
        .iter()
        .filter_map(|r| match *r {
            Region::Disc { center, radius } => Some((center, radius)),
            Region::Ellipse { .. } => None,
        })
        .collect();
    for (i, &(ci, ri)) in balls.iter().enumerate() {
        for &(cj, rj) in &balls[i + 1..] {
            let l = (cj - ci).norm();
            // cos of the angle at c_i between c_j and a common point.
            let cos = (l * l + ri * ri - rj * rj) / (2.0 * l * ri);
            if !(l > 0.0 && cos.abs() <= 1.0) {
                continue;
            }
            let n = (cj - ci) / l;
            let (u, v) = frame(&n);
            let sin = (1.0 - cos * cos).sqrt();
            let at = |a: f64| ci + (n * cos + (u * a.cos() + v * a.sin()) * sin) * ri;
            let m = 20_000;
            let step = std::f64::consts::TAU / m as f64;
            for k in 0..m {
                let a0 = step * k as f64;
                // An arc's end between two samples: bisected to rounding.
                let (a1, in0, in1) = (a0 + step, inside(&at(a0)), inside(&at(a0 + step)));
                if in0 != in1 {
                    let (mut yes, mut no) = if in0 { (a0, a1) } else { (a1, a0) };
                    for _ in 0..60 {
                        let mid = 0.5 * (yes + no);
                        if inside(&at(mid)) {
                            yes = mid;
                        } else {
                            no = mid;
                        }
                    }
                    best = best.max((at(yes) - x_hat).norm());
                }
                if !in0 {
                    continue;
                }
                let h = std::f64::consts::TAU / m as f64;
                let (mut lo, mut hi) = (a0 - h, a0 + h);
                let g = |a: f64| {
                    if inside(&at(a)) {
                        (at(a) - x_hat).norm()
                    } else {
                        0.0
                    }
                };
                best = best.max(g(a0));
                let phi = 0.5 * (5f64.sqrt() - 1.0);
                for _ in 0..80 {
                    let (c, d) = (hi - phi * (hi - lo), lo + phi * (hi - lo));
                    if g(c) > g(d) {
                        hi = d;
                    } else {
                        lo = c;
                    }
                }
                best = best.max(g(0.5 * (lo + hi)));
            }
        }
    }
    best
}

#[test]
fn the_3d_exact_worst_case_over_balls_matches_a_brute_force_and_is_below_every_relaxation() {
    let mut rng = SonarRng::seed_from_u64(26);
    for case in 0..24 {
        let (mut regions, truth) = random_set(&mut rng, false);
        if case % 4 == 3 {
            // Nested: a ball inside all the others.
            regions.push(Region::disc(truth, 0.3));
        }
        let x_hat = match case % 3 {
            0 => truth,
            1 => {
                truth
                    + p3(
                        rng.random_range(-3.0..3.0),
                        rng.random_range(-3.0..3.0),
                        rng.random_range(-3.0..3.0),
                    )
            }
            // On a centre: every point of that sphere is equally far.
            _ => match regions[0] {
                Region::Disc { center, .. } => center,
                Region::Ellipse { f1, .. } => f1,
            },
        };
        let i = Intersection::new(&regions)
            .expect("finite")
            .expect("nonempty");
        let exact = i
            .upp_exact(&x_hat)
            .expect("balls")
            .value()
            .expect("nonempty");
        let brute = brute_exact(&regions, &x_hat);
        let l = 30.0;
        assert!(
            exact >= brute,
            "case {case}: exact {exact} below brute force {brute}"
        );
        assert!(
            exact <= brute + 1e-6 * l,
            "case {case}: exact {exact} above brute force {brute}"
        );
        for f in [upp_bbox, upp_minball, upp_maxdis] {
            let b = f(&regions, &x_hat)
                .expect("solves")
                .value()
                .expect("nonempty");
            // Up to the round-off allowance (1e-9 of the length scale L <= 50 here).
            assert!(
                exact <= b + 1e-7,
                "case {case}: exact {exact} above a relaxation {b}"
            );
        }
    }
}

#[test]
fn the_3d_exact_worst_case_finds_disjoint_balls_empty() {
    assert!(
        Intersection::new(&[
            Region::disc(p3(0.0, 0.0, 0.0), 1.0),
            Region::disc(p3(3.0, 0.0, 0.0), 1.0)
        ])
        .expect("finite")
        .is_none()
    );
}
