//! `upp_exact` in 3-D for intersections of balls (one-way ranges): the exact
//! worst-case error `max_{x in B} ||x - x_hat||` by closed-form candidates.
//!
//! # Why the candidates are complete
//!
//! `B` is compact and convex and `f(x) = ||x - x_hat||^2` is convex, so the
//! maximum is attained at a boundary point `x*`. Let `A` be the spheres
//! through `x*`; near `x*`, `B` is cut out by them alone, so `x*` is a local
//! maximum of `f` on their common surface, hence a stationary point there:
//! * one sphere `S_i`: `x* - x_hat` is normal to it, so `x*` is on the line
//!   through `c_i` and `x_hat`: `c_i +- R_i (c_i - x_hat) / ||c_i - x_hat||`;
//! * two spheres meet in a circle (centre `m`, radius `rho`, axis `n`): the
//!   stationary points are `m +- rho w`, `w` the unit part of `x_hat - m`
//!   across `n`;
//! * three or more: `x*` is a common point of three spheres, one of the two
//!   points of the line where their radical planes meet, on `S_i`.
//!
//! Where a surface is all stationary (`x_hat` at a sphere's centre, or on a
//! circle's axis) every point of it is equally far, and the part of it in
//! `B` is the whole of it or is bounded by circles (and those by vertices):
//! fixed points of the surface (six on a sphere, four on a circle) and the
//! candidates of the boundary stand for it.
//!
//! Every candidate within `TOL L` of every ball is kept; the bound is the
//! largest distance plus [`ALLOWANCE`]` L`, `L` the problem's length scale,
//! as in 2-D ([`super::exact`]). With a spheroid (a bistatic range) the
//! pairwise curves are quartic space curves with no closed-form stationary
//! points, and the value comes from the certified search over directions of
//! [`super::exact_3d_search`] instead.

use super::exact::ALLOWANCE;
use super::region::Region;
use super::{BoundError, BoundOutcome, FEAS_TOL, Intersection};
use crate::model::geometry::Point;

type P3 = Point<3>;

/// The tolerance on a candidate's violation of a ball, relative to `L`.
const TOL: f64 = 1e-9;

/// Two unit vectors across unit `n`, and `n`.
fn across(n: &P3) -> (P3, P3) {
    let seed = if n.x.abs() < 0.9 {
        P3::new(1.0, 0.0, 0.0)
    } else {
        P3::new(0.0, 1.0, 0.0)
    };
    let a = (seed - n * n.dot(&seed)).normalize();
    (a, n.cross(&a))
}

/// Every candidate point of the module docs.
fn candidates(balls: &[(P3, f64)], p: &P3, scale_l: f64) -> Vec<P3> {
    let tiny = 1e-12 * scale_l;
    let mut out = Vec::new();
    for &(c, r) in balls {
        let d = c - p;
        if d.norm() > tiny {
            let u = d.normalize();
            out.extend([c + u * r, c - u * r]);
        } else {
            for k in 0..3 {
                let e = P3::from_fn(|i, _| if i == k { r } else { 0.0 });
                out.extend([c + e, c - e]);
            }
        }
    }
    for (i, &(ci, ri)) in balls.iter().enumerate() {
        for &(cj, rj) in &balls[i + 1..] {
            let d = cj - ci;
            let l = d.norm();
            if l <= tiny {
                continue;
            }
            let n = d / l;
            // Distance from c_i to the circle's plane, and the circle's radius.
            let a = (l * l + ri * ri - rj * rj) / (2.0 * l);
            let rho2 = (ri - a) * (ri + a);
            if rho2 < -(TOL * scale_l).powi(2) {
                continue;
            }
            let rho = rho2.max(0.0).sqrt();
            let m = ci + n * a;
            let w = (p - m) - n * n.dot(&(p - m));
            if w.norm() > tiny {
                let u = w.normalize();
                out.extend([m + u * rho, m - u * rho]);
            } else {
                let (e1, e2) = across(&n);
                out.extend([m + e1 * rho, m - e1 * rho, m + e2 * rho, m - e2 * rho]);
            }
        }
    }
    for (i, &(ci, ri)) in balls.iter().enumerate() {
        for (j, &(cj, rj)) in balls.iter().enumerate().skip(i + 1) {
            for &(ck, rk) in &balls[j + 1..] {
                out.extend(three_spheres((ci, ri), (cj, rj), (ck, rk), scale_l));
            }
        }
    }
    out
}

/// The common points of three spheres: the radical planes
/// `2 (c_j - c_i) . x = R_i^2 - R_j^2 + ||c_j||^2 - ||c_i||^2` (and `k`) meet
/// in a line `x0 + s v`, met by `S_i` at up to two points. None when the
/// centres are collinear (then the spheres meet in a circle of two of them).
fn three_spheres(
    (ci, ri): (P3, f64),
    (cj, rj): (P3, f64),
    (ck, rk): (P3, f64),
    scale_l: f64,
) -> Vec<P3> {
    // Centred on c_i for conditioning.
    let (a, b) = (cj - ci, ck - ci);
    let v = a.cross(&b);
    let vv = v.norm_squared();
    if vv <= (1e-12 * scale_l * scale_l).powi(2) {
        return Vec::new();
    }
    // a . y = ha, b . y = hb with y = x - c_i.
    let ha = 0.5 * (ri * ri - rj * rj + a.norm_squared());
    let hb = 0.5 * (ri * ri - rk * rk + b.norm_squared());
    // The point of the line in the plane of a and b.
    let y0 = (b.cross(&v) * ha + v.cross(&a) * hb) / vv;
    let vn = v / vv.sqrt();
    // ||y0 + s vn||^2 = R_i^2, y0 . vn = 0.
    let s2 = ri * ri - y0.norm_squared();
    if s2 < -(TOL * scale_l).powi(2) {
        return Vec::new();
    }
    let s = s2.max(0.0).sqrt();
    vec![ci + y0 + vn * s, ci + y0 - vn * s]
}

impl Intersection<3> {
    /// The pieces in the local frame, less the spheroids that hold the whole
    /// relaxed box (its eight corners, by convexity): `B` lies in that box, so
    /// they do not cut it, and a set whose spheroids all hold it is
    /// handled in closed form. All pieces when none would be left.
    fn pieces_that_cut(&self) -> Vec<Region<3>> {
        let (lo, hi) = (
            self.to_local(&self.relaxed.lo),
            self.to_local(&self.relaxed.hi),
        );
        let corners: Vec<P3> = (0..8)
            .map(|k| P3::from_fn(|i, _| if k >> i & 1 == 1 { hi[i] } else { lo[i] }))
            .collect();
        let cuts = |r: &Region<3>| {
            matches!(r, Region::Disc { .. }) || corners.iter().any(|c| r.violation(c) > 0.0)
        };
        let pieces: Vec<Region<3>> = self.local.iter().filter(|r| cuts(r)).cloned().collect();
        if pieces.is_empty() {
            self.local.clone()
        } else {
            pieces
        }
    }

    /// `upp_exact` for balls (see the module docs of `exact_3d`):
    /// `max_{x in B} ||x - x_hat||` plus the round-off allowance; never
    /// below the true maximum. With a spheroid, the certified search of
    /// `exact_3d_search`.
    pub(super) fn upp_exact_space(&self, x_hat: &P3) -> Result<BoundOutcome, BoundError> {
        super::check_point(x_hat)?;
        let p = self.to_local(x_hat);
        let pieces = self.pieces_that_cut();
        let mut balls = Vec::with_capacity(pieces.len());
        for r in &pieces {
            match *r {
                Region::Disc { center, radius } => balls.push((center, radius)),
                Region::Ellipse { .. } => return self.upp_exact_search(&pieces, x_hat),
            }
        }
        let scale_l = balls
            .iter()
            .map(|(c, r)| (c - p).norm() + r)
            .fold(0.0f64, f64::max)
            .max(f64::MIN_POSITIVE);
        let mut cands: Vec<(f64, P3)> = candidates(&balls, &p, scale_l)
            .into_iter()
            .filter(|x| x.iter().all(|v| v.is_finite()))
            .map(|x| ((x - p).norm(), x))
            .collect();
        cands.sort_by(|a, b| b.0.total_cmp(&a.0));
        let inside = |tol: f64| {
            cands
                .iter()
                .find(|(_, x)| self.local.iter().all(|r| r.violation(x) <= tol))
                .map(|(d, _)| *d)
        };
        let best = inside(TOL * scale_l).or_else(|| inside(FEAS_TOL.max(TOL * scale_l)));
        Ok(match best {
            Some(d) => BoundOutcome::Bound((d + ALLOWANCE * scale_l) * self.scale),
            None => BoundOutcome::Empty,
        })
    }
}
