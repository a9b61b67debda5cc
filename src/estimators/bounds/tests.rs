//! Unit and property tests of the bounds against closed forms and brute force.

use super::*;
use crate::model::geometry::Vec2;
use crate::model::rng::SonarRng;
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};

/// Relative tolerance of a bound against a brute-force value.
const REL: f64 = 1e-6;

fn val(o: BoundOutcome) -> f64 {
    match o {
        BoundOutcome::Bound(v) => v,
        BoundOutcome::Empty => panic!("unexpected Empty"),
    }
}

fn all_bounds(regions: &[Region], x_hat: &Vec2) -> [BoundOutcome; 4] {
    [
        upp_rbbox(regions, x_hat).unwrap(),
        upp_bbox(regions, x_hat).unwrap(),
        upp_minball(regions, x_hat).unwrap(),
        upp_maxdis(regions, x_hat).unwrap(),
    ]
}

fn in_set(regions: &[Region], x: &Vec2, tol: f64) -> bool {
    regions.iter().all(|r| r.contains(x, tol))
}

/// Brute-force `max ||x - x_hat||` over a grid on `bx`, filtered to the set,
/// plus the grid points themselves.
fn grid_max(regions: &[Region], bx: &AxisBox, x_hat: &Vec2, n: usize) -> (f64, Vec<Vec2>) {
    let mut best = 0.0f64;
    let mut pts = vec![];
    for i in 0..=n {
        for j in 0..=n {
            let x = Vec2::new(
                bx.lo.x + (bx.hi.x - bx.lo.x) * i as f64 / n as f64,
                bx.lo.y + (bx.hi.y - bx.lo.y) * j as f64 / n as f64,
            );
            if in_set(regions, &x, 0.0) {
                best = best.max((x - x_hat).norm());
                pts.push(x);
            }
        }
    }
    (best, pts)
}

#[test]
fn single_disc_bounds_match_closed_forms() {
    let c = Vec2::new(3.0, -2.0);
    let r = 4.0;
    let regions = [Region::disc(c, r)];
    let x_hat = Vec2::new(5.0, 1.0);
    let d = (x_hat - c).norm();
    let [rb, bb, mb, md] = all_bounds(&regions, &x_hat).map(val);
    // One quadratic constraint: the SDP relaxation is exact (S-lemma).
    assert!((md - (d + r)).abs() < REL * (d + r), "maxdis {md}");
    // The S-lemma ball of one disc is the disc.
    assert!((mb - (d + r)).abs() < REL * (d + r), "minball {mb}");
    let corner = Vec2::new((x_hat.x - (c.x - r)).abs(), (x_hat.y - (c.y - r)).abs()).norm();
    assert!((rb - corner).abs() < 1e-12);
    assert!((bb - corner).abs() < REL * corner);
}

#[test]
fn single_ellipse_maxdis_is_exact_against_brute_force() {
    let f1 = Vec2::new(-3.0, 1.0);
    let f2 = Vec2::new(4.0, 2.0);
    let sum = 11.0;
    let reg = Region::ellipse(f1, f2, sum);
    let x_hat = Vec2::new(1.0, 6.0);
    // Farthest boundary point by dense parametric sampling.
    let g = region::EllipseGeom::new(&f1, &f2, sum).unwrap();
    let v = Vec2::new(-g.u.y, g.u.x);
    let brute = (0..200_000)
        .map(|k| {
            let th = k as f64 / 200_000.0 * std::f64::consts::TAU;
            (g.c + g.u * (g.a * th.cos()) + v * (g.b * th.sin()) - x_hat).norm()
        })
        .fold(0.0, f64::max);
    let md = val(upp_maxdis(&[reg], &x_hat).unwrap());
    assert!(md >= brute * (1.0 - REL), "{md} < {brute}");
    assert!(md <= brute * (1.0 + 1e-6), "{md} not tight vs {brute}");
    // Exact bounding box = the ellipse's own box.
    let i = Intersection::new(&[reg]).unwrap().unwrap();
    let bb = i.bounding_box().unwrap().unwrap();
    let (lo, hi) = reg.aabb().unwrap();
    assert!(
        (bb.lo - lo).norm() < 1e-6 && (bb.hi - hi).norm() < 1e-6,
        "{bb:?} vs {lo:?} {hi:?}"
    );
}

#[test]
fn lens_of_two_discs_has_the_analytic_box_and_ball() {
    // Discs at (+-3, 0), radius 5: lens with corners (0, +-4), x-extent +-2.
    let regions = [
        Region::disc(Vec2::new(-3.0, 0.0), 5.0),
        Region::disc(Vec2::new(3.0, 0.0), 5.0),
    ];
    let i = Intersection::new(&regions).unwrap().unwrap();
    let bb = i.bounding_box().unwrap().unwrap();
    assert!((bb.lo - Vec2::new(-2.0, -4.0)).norm() < 1e-6, "{bb:?}");
    assert!((bb.hi - Vec2::new(2.0, 4.0)).norm() < 1e-6, "{bb:?}");
    let rb = i.relaxed_box();
    assert!(
        (rb.lo - Vec2::new(-2.0, -5.0)).norm() < 1e-12
            && (rb.hi - Vec2::new(2.0, 5.0)).norm() < 1e-12
    );
    // N = 2 <= n: eq. (43) is the exact minimum ball: centre 0, radius 4.
    let ball = i.min_ball().unwrap().unwrap();
    assert!(
        ball.center.norm() < 1e-6 && (ball.radius - 4.0).abs() < 1e-6,
        "{ball:?}"
    );
    assert!((ball.diameter() - 8.0).abs() < 2e-6);
}

#[test]
fn minball_qp_of_eq_43_equals_the_general_s_lemma_sdp_on_discs() {
    let mut rng = SonarRng::seed_from_u64(21);
    let mut checked = 0;
    while checked < 20 {
        let inst = random_instance(&mut rng, 2 + checked % 5, 0);
        let Some(i) = Intersection::new(&inst.regions).unwrap() else {
            continue;
        };
        let qp = i.min_ball().unwrap().unwrap();
        let sdp = i.min_ball_via_sdp().unwrap().unwrap();
        let s = qp.radius.max(1.0);
        assert!(
            (qp.radius - sdp.radius).abs() < 1e-5 * s,
            "{qp:?} vs {sdp:?}"
        );
        assert!(
            (qp.center - sdp.center).norm() < 1e-4 * s,
            "{qp:?} vs {sdp:?}"
        );
        checked += 1;
    }
}

#[test]
fn multipliers_summing_to_one_on_discs_give_the_ball_of_eq_42_43() {
    let mut rng = SonarRng::seed_from_u64(5);
    let inst = random_instance(&mut rng, 4, 0);
    let discs: Vec<(Vec2, f64)> = inst
        .regions
        .iter()
        .map(|r| match r {
            Region::Disc { center, radius } => (*center, *radius),
            Region::Ellipse { .. } => unreachable!("discs only"),
        })
        .collect();
    let quads: Vec<_> = inst
        .regions
        .iter()
        .flat_map(|r| r.quadratics().unwrap())
        .collect();
    let lam = [0.1, 0.4, 0.3, 0.2];
    let (c1, g1) = solve::ball_from_simplex(&discs, &lam);
    let (c2, g2) = solve::ball_from_multipliers(&quads, &lam).unwrap();
    assert!(
        (c1 - c2).norm() < 1e-12 * c1.norm().max(1.0),
        "{c1} vs {c2}"
    );
    assert!((g1 - g2).abs() < 1e-9 * g1.abs().max(1.0), "{g1} vs {g2}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, failure_persistence: None, ..ProptestConfig::default() })]

    /// Gholami 2015 eq. (35): any multipliers `lambda >= 0` certify a ball,
    /// after scaling; it holds every point of the set, here the true
    /// position and the set's points on a grid over its bounding box.
    #[test]
    fn any_nonnegative_multipliers_certify_a_ball_that_holds_the_set(
        seed in any::<u64>(), n_discs in 1usize..5, n_ell in 0usize..4,
        lam in proptest::collection::vec(0.0f64..2.0, 11),
    ) {
        prop_assume!(n_discs + n_ell >= 2);
        let mut rng = SonarRng::seed_from_u64(seed);
        let inst = random_instance(&mut rng, n_discs, n_ell);
        let quads: Vec<_> = inst.regions.iter().filter_map(|r| r.quadratics()).flatten().collect();
        let lam = &lam[..quads.len().min(lam.len())];
        prop_assume!(lam.len() == quads.len());
        if let Some((c, gamma)) = solve::ball_from_multipliers(&quads, lam) {
            let mut points = vec![inst.x_true];
            if let Some(i) = Intersection::new(&inst.regions).unwrap()
                && let Some(bx) = i.bounding_box().unwrap()
            {
                points.extend(grid_max(&inst.regions, &bx, &inst.x_true, 30).1);
            }
            for x in points {
                let d2 = (x - c).norm_squared();
                prop_assert!(d2 <= gamma * (1.0 + 1e-12) + 1e-9, "{} outside the ball ({} > {})", x, d2, gamma);
            }
        }
    }
}

#[test]
fn empty_intersections_are_empty_for_every_bound() {
    let x = Vec2::new(0.3, 0.1);
    let cases: Vec<Vec<Region>> = vec![
        // Disjoint boxes.
        vec![
            Region::disc(Vec2::new(0.0, 0.0), 1.0),
            Region::disc(Vec2::new(5.0, 0.0), 1.0),
        ],
        // Overlapping boxes, disjoint discs (diagonal gap 0.12).
        vec![
            Region::disc(Vec2::new(0.0, 0.0), 1.0),
            Region::disc(Vec2::new(1.5, 1.5), 1.0),
        ],
        // Empty region.
        vec![Region::disc(Vec2::new(0.0, 0.0), -0.5)],
        vec![Region::ellipse(
            Vec2::new(0.0, 0.0),
            Vec2::new(3.0, 0.0),
            2.9,
        )],
        // Three pairwise-intersecting discs with no common point.
        vec![
            Region::disc(Vec2::new(0.0, 0.0), 1.0),
            Region::disc(Vec2::new(1.9, 0.0), 1.0),
            Region::disc(Vec2::new(0.95, 1.65), 1.0),
        ],
        // Ellipse and disc that miss each other but whose boxes overlap.
        vec![
            Region::ellipse(Vec2::new(0.0, 0.0), Vec2::new(4.0, 4.0), 6.0),
            Region::disc(Vec2::new(4.0, -0.5), 1.5),
        ],
    ];
    for (k, regions) in cases.iter().enumerate() {
        for (name, b) in ["rbbox", "bbox", "minball", "maxdis"]
            .iter()
            .zip(all_bounds(regions, &x))
        {
            assert_eq!(b, BoundOutcome::Empty, "case {k}: {name}");
        }
    }
}

#[test]
fn bad_input_gives_typed_errors() {
    let d = Region::disc(Vec2::new(0.0, 0.0), 1.0);
    assert_eq!(upp_bbox(&[], &Vec2::zeros()), Err(BoundError::NoRegions));
    assert_eq!(
        upp_maxdis(&[d], &Vec2::new(f64::NAN, 0.0)),
        Err(BoundError::NonFinite)
    );
    assert_eq!(
        upp_rbbox(
            &[Region::disc(Vec2::new(0.0, f64::INFINITY), 1.0)],
            &Vec2::zeros()
        ),
        Err(BoundError::NonFinite)
    );
}

#[test]
fn bounds_scale_with_the_geometry() {
    let base = [
        Region::disc(Vec2::new(0.0, 0.0), 5.0),
        Region::disc(Vec2::new(6.0, 1.0), 4.0),
        Region::ellipse(Vec2::new(-1.0, 5.0), Vec2::new(5.0, -3.0), 11.0),
    ];
    let x = Vec2::new(2.5, 0.5);
    let k = 1000.0;
    let scaled: Vec<Region> = base
        .iter()
        .map(|r| r.to_frame(&Vec2::new(-7.0e3, 2.0e3), 1.0 / k))
        .collect();
    let xs = (x - Vec2::new(-7.0e3, 2.0e3)) * k;
    let a = all_bounds(&base, &x).map(val);
    let b = all_bounds(&scaled, &xs).map(val);
    for (u, v) in a.iter().zip(&b) {
        assert!((u * k - v).abs() < 1e-6 * v, "{u} * {k} vs {v}");
    }
}

#[test]
fn tangent_discs_give_a_bound_or_empty_never_an_error() {
    let regions = [
        Region::disc(Vec2::new(0.0, 0.0), 1.0),
        Region::disc(Vec2::new(2.0, 0.0), 1.0),
    ];
    let x_hat = Vec2::new(1.0, 0.5);
    for b in all_bounds(&regions, &x_hat) {
        if let BoundOutcome::Bound(v) = b {
            assert!(v >= 0.5 * (1.0 - REL), "{v}");
        }
    }
}

#[test]
fn degenerate_ellipses_segment_and_coincident_foci_are_bounded_correctly() {
    // Segment [(-4, 0), (4, 0)] cut by a disc: the set is [-1, 3] x {0}.
    let seg = [
        Region::ellipse(Vec2::new(-4.0, 0.0), Vec2::new(4.0, 0.0), 8.0),
        Region::disc(Vec2::new(1.0, 0.0), 2.0),
    ];
    let x_hat = Vec2::new(0.0, 1.0);
    let exact = Vec2::new(3.0, -1.0).norm();
    for (k, b) in all_bounds(&seg, &x_hat).into_iter().enumerate() {
        let v = val(b);
        assert!(v >= exact * (1.0 - REL), "bound {k}: {v} < {exact}");
    }
    // Coincident foci: the ellipse is the disc of radius sum / 2.
    let disc_like = [Region::ellipse(
        Vec2::new(2.0, 2.0),
        Vec2::new(2.0, 2.0),
        6.0,
    )];
    let x_hat = Vec2::new(0.0, 0.0);
    let exact = Vec2::new(2.0, 2.0).norm() + 3.0;
    let md = val(upp_maxdis(&disc_like, &x_hat).unwrap());
    assert!((md - exact).abs() < REL * exact, "{md} vs {exact}");
    let p = disc_like[0].project(&Vec2::new(10.0, 2.0)).unwrap();
    assert!((p - Vec2::new(5.0, 2.0)).norm() < 1e-12);
}

/// A random instance whose true position is feasible by construction.
pub(super) struct Instance {
    pub(super) regions: Vec<Region>,
    pub(super) x_true: Vec2,
    anchors: Vec<Vec2>,
    ranges: Vec<f64>,
}

/// Positive range errors: exponential (mean 1) plus, with prob. 0.2, a uniform
/// NLOS bias in (0, 10), as in Gholami 2015 Sec. 6.
pub(super) fn positive_error(rng: &mut SonarRng) -> f64 {
    let u: f64 = rng.random_range(1e-12..1.0);
    let mut e = -u.ln();
    if rng.random_range(0.0..1.0) < 0.2 {
        e += rng.random_range(0.0..10.0);
    }
    e
}

pub(super) fn random_instance(rng: &mut SonarRng, n_discs: usize, n_ell: usize) -> Instance {
    let x_true = Vec2::new(rng.random_range(-40.0..40.0), rng.random_range(-40.0..40.0));
    let pt = |rng: &mut SonarRng| {
        Vec2::new(
            rng.random_range(-100.0..100.0),
            rng.random_range(-100.0..100.0),
        )
    };
    let mut regions = vec![];
    let mut anchors = vec![];
    let mut ranges = vec![];
    for _ in 0..n_discs {
        let a = pt(rng);
        let d = (x_true - a).norm() + positive_error(rng);
        anchors.push(a);
        ranges.push(d);
        regions.push(Region::from_range(a, d, 0.0));
    }
    for _ in 0..n_ell {
        let (t, r) = (pt(rng), pt(rng));
        let s = (x_true - t).norm() + (x_true - r).norm() + positive_error(rng);
        regions.push(Region::from_bistatic(t, r, s, 0.0));
    }
    Instance {
        regions,
        x_true,
        anchors,
        ranges,
    }
}

/// Estimates to bound: POCS (feasible), LLS (often infeasible), a perturbed truth.
pub(super) fn estimates(inst: &Instance, rng: &mut SonarRng) -> Vec<Vec2> {
    let mut v = vec![];
    let p = pocs(
        &inst.regions,
        Vec2::new(rng.random_range(-100.0..100.0), 0.0),
        5000,
        1e-9,
    )
    .unwrap();
    v.push(p.x);
    let anchors: Vec<(Vec2, f64)> = inst
        .anchors
        .iter()
        .copied()
        .zip(inst.ranges.iter().copied())
        .collect();
    if let Ok(x) = crate::estimators::online::ols_toa(&anchors) {
        v.push(x);
    }
    v.push(inst.x_true + Vec2::new(rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0)));
    v
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn every_bound_covers_the_true_error_and_a_dense_sample_of_the_set(
        seed in any::<u64>(), n_discs in 1usize..6, n_ell in 0usize..4,
    ) {
        prop_assume!(n_discs + n_ell >= 1);
        let mut rng = SonarRng::seed_from_u64(seed);
        let inst = random_instance(&mut rng, n_discs, n_ell);
        let i = Intersection::new(&inst.regions).unwrap();
        let i = i.expect("the true position is feasible, so the set is nonempty");
        let bbox = i.bounding_box().unwrap().unwrap();
        let rbox = i.relaxed_box();
        let scale = rbox.diagonal().max(1e-9);
        // The exact box lies in the relaxed box and contains the truth.
        prop_assert!(bbox.lo.x >= rbox.lo.x - 1e-7 * scale && bbox.hi.y <= rbox.hi.y + 1e-7 * scale);
        prop_assert!(bbox.contains(&inst.x_true, 1e-7 * scale));
        for x_hat in estimates(&inst, &mut rng) {
            let e = (inst.x_true - x_hat).norm();
            let rb = val(i.upp_rbbox(&x_hat).unwrap());
            let bb = val(i.upp_bbox(&x_hat).unwrap());
            let mb = val(i.upp_minball(&x_hat).unwrap());
            let md = val(i.upp_maxdis(&x_hat).unwrap());
            let tol = REL * (e + scale);
            for (name, b) in [("rbbox", rb), ("bbox", bb), ("minball", mb), ("maxdis", md)] {
                prop_assert!(b + tol >= e, "{} = {} < true error {}", name, b, e);
            }
            // Theorems: exact box inside relaxed box; the SDP dual contains the
            // S-lemma ball certificate, so sqrt(v_sdp) <= R + ||x_hat - c||.
            prop_assert!(bb <= rb + tol, "bbox {} > rbbox {}", bb, rb);
            prop_assert!(md <= mb + tol, "maxdis {} > minball {}", md, mb);
            // Dense sample of the set (grid on the exact box, filtered).
            let (smax, pts) = grid_max(&inst.regions, &bbox, &x_hat, 48);
            for (name, b) in [("rbbox", rb), ("bbox", bb), ("minball", mb), ("maxdis", md)] {
                prop_assert!(b + tol >= smax, "{} = {} < sampled max {}", name, b, smax);
            }
            let ball = i.min_ball().unwrap().unwrap();
            for p in &pts {
                prop_assert!((p - ball.center).norm() <= ball.radius + REL * scale);
            }
        }
    }

    #[test]
    fn pocs_output_is_in_the_set_when_it_reports_feasible(
        seed in any::<u64>(), n_discs in 1usize..7, n_ell in 0usize..4,
    ) {
        prop_assume!(n_discs + n_ell >= 1);
        let mut rng = SonarRng::seed_from_u64(seed);
        let inst = random_instance(&mut rng, n_discs, n_ell);
        let x0 = Vec2::new(rng.random_range(-200.0..200.0), rng.random_range(-200.0..200.0));
        let tol = 1e-8;
        let r = pocs(&inst.regions, x0, 20_000, tol).unwrap();
        if r.feasible {
            for reg in &inst.regions {
                // Checked with the sum-of-distances form, independent of projection.
                prop_assert!(reg.violation(&r.x) <= tol, "{:?}: {}", reg, reg.violation(&r.x));
            }
        }
    }

    #[test]
    fn random_empty_instances_are_empty_for_every_bound(
        seed in any::<u64>(), n_extra in 0usize..4, gap in 0.05f64..5.0,
    ) {
        // Two discs separated by `gap`, plus random discs/ellipses through the
        // first disc's centre: the set is empty.
        let mut rng = SonarRng::seed_from_u64(seed);
        let c = Vec2::new(rng.random_range(-50.0..50.0), rng.random_range(-50.0..50.0));
        let dir = {
            let th: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            Vec2::new(th.cos(), th.sin())
        };
        let r1 = rng.random_range(1.0..30.0);
        let r2 = rng.random_range(1.0..30.0);
        let mut regions = vec![Region::disc(c, r1), Region::disc(c + dir * (r1 + r2 + gap), r2)];
        for k in 0..n_extra {
            let a = Vec2::new(rng.random_range(-100.0..100.0), rng.random_range(-100.0..100.0));
            if k % 2 == 0 {
                regions.push(Region::disc(a, (a - c).norm() + rng.random_range(0.0..20.0)));
            } else {
                let b = Vec2::new(rng.random_range(-100.0..100.0), rng.random_range(-100.0..100.0));
                regions.push(Region::ellipse(a, b, (a - c).norm() + (b - c).norm() + rng.random_range(0.0..20.0)));
            }
        }
        let x_hat = c;
        for (name, b) in ["rbbox", "bbox", "minball", "maxdis"].iter().zip(all_bounds(&regions, &x_hat)) {
            prop_assert_eq!(b, BoundOutcome::Empty, "{}", name);
        }
    }
}

/// Empirical orderings between the bounds that are not theorems, and tightness
/// against the brute-force `v_max1` (printed; run with
/// `cargo test --lib bounds::tests::report -- --ignored --nocapture`).
#[test]
#[ignore]
fn report_empirical_orderings() {
    let mut rng = SonarRng::seed_from_u64(2024);
    for (nd, ne) in [(4, 0), (8, 0), (4, 2), (0, 4), (2, 6)] {
        let (mut n, mut md_bb, mut mb_bb, mut md_rb, mut mb_rb) = (0, 0, 0, 0, 0);
        let mut ratios = [0.0f64; 4];
        for _ in 0..200 {
            let inst = random_instance(&mut rng, nd, ne);
            let Some(i) = Intersection::new(&inst.regions).unwrap() else {
                continue;
            };
            let x_hat = pocs(&inst.regions, Vec2::zeros(), 5000, 1e-9).unwrap().x;
            let rb = val(i.upp_rbbox(&x_hat).unwrap());
            let bb = val(i.upp_bbox(&x_hat).unwrap());
            let mb = val(i.upp_minball(&x_hat).unwrap());
            let md = val(i.upp_maxdis(&x_hat).unwrap());
            let bbox = i.bounding_box().unwrap().unwrap();
            let vmax1 = grid_max(&inst.regions, &bbox, &x_hat, 200).0.max(1e-9);
            n += 1;
            md_bb += usize::from(md <= bb);
            mb_bb += usize::from(mb <= bb);
            md_rb += usize::from(md <= rb);
            mb_rb += usize::from(mb <= rb);
            for (r, b) in ratios.iter_mut().zip([rb, bb, mb, md]) {
                *r += b / vmax1;
            }
        }
        let m = n as f64;
        eprintln!(
            "discs {nd} ellipses {ne}: n={n} maxdis<=bbox {md_bb} minball<=bbox {mb_bb} maxdis<=rbbox {md_rb} minball<=rbbox {mb_rb}; mean bound/v_max1 rbbox {:.2} bbox {:.2} minball {:.2} maxdis {:.2}",
            ratios[0] / m,
            ratios[1] / m,
            ratios[2] / m,
            ratios[3] / m
        );
    }
    let tangent = [
        Region::disc(Vec2::new(0.0, 0.0), 1.0),
        Region::disc(Vec2::new(2.0, 0.0), 1.0),
    ];
    eprintln!(
        "tangent discs: {:?}",
        all_bounds(&tangent, &Vec2::new(1.0, 0.5))
    );
}
