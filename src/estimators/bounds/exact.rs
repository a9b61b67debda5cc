//! `upp_exact` (beyond Gholami 2015): the exact worst-case error
//! `max_{x in B} ||x - x_hat||` over the 2-D feasible set `B`, the
//! intersection of discs (one-way ranges, Gholami 2015 eq. (12)) and filled
//! ellipses (bistatic ranges), with the same `rho` enlargement as the other
//! bounds. The relaxations of Gholami 2015 (eq. (26), (43)-(44), (48)-(49),
//! (52)-(54)) are made for n-dimensional sets; in the plane the maximum itself
//! is a finite enumeration.
//!
//! # Why the enumeration is complete
//!
//! `B` is compact and convex (an intersection of convex pieces) and
//! `f(x) = ||x - x_hat||^2` is continuous, so the maximum is attained, and,
//! `f` being convex, at a point `x*` of the boundary of `B`. The boundary is
//! made of arcs of the pieces' boundary curves (circles and ellipses). Either
//! * `x*` lies on two or more curves: it is a **vertex**, a common point of
//!   two curves (a crossing, or a tangency); or
//! * `x*` lies on exactly one curve `C`: a neighbourhood of `x*` in `C` lies
//!   in `B` (the other pieces contain `x*` in their interior), so `x*` is a
//!   local maximum of `f` along `C`, hence a **stationary point** of `f`
//!   restricted to `C` (`(x - x_hat) . x'(phi) = 0`).
//!
//! Both kinds are computed for every curve and every pair of curves:
//! * a curve is `x(phi) = c + A cos(phi) + B sin(phi)` (a disc: `A = r e1`,
//!   `B = r e2`; an ellipse: `A = a u`, `B = b u_perp`);
//! * a vertex of curves `i` and `j` solves `Q_j(x_i(phi)) = 0`, where `Q_j`
//!   is `j`'s implicit quadratic ([`Region::quadratics`]); with
//!   `t = tan(phi / 2)` this is a quartic in `t` (times `(1 + t^2)^2`);
//! * a stationary point on curve `i` solves
//!   `(c - x_hat + A cos + B sin) . (-A sin + B cos) = 0`, also a quartic in `t`.
//!
//! The quartics' real roots (and the real parts of complex pairs, which a
//! near-double root of a tangency becomes under round-off) come from the
//! prox's Ferrari solver (`quartic_seeds` of `prox::gtrs`), and each is polished by a
//! guarded Newton iteration on the trigonometric equation itself. The
//! parametrisation is turned (`phi = phi0 + 2 atan t`, `phi0` among five
//! angles) so that the quartic's leading coefficient, the value at
//! `phi0 + pi`, is as large as it can be; the points at `phi = 0, pi/2, pi,
//! 3pi/2` of every curve are candidates too (any point of a curve that lies in
//! `B` may be: it can only be at most the maximum).
//!
//! Every candidate inside every piece (violation at most `tol`, below) is
//! kept, and the bound is the largest distance plus the allowance. Two
//! prunings keep it to microseconds, and neither drops a point of `B`: `B`
//! lies in the relaxed box (Gholami 2015 eq. (53)), so a piece that holds the
//! whole box (its four corners, by convexity) has no boundary point in `B`
//! and contributes no curve, and a root more than `1e-4 L` outside the box
//! is dropped before it is polished; the rest are polished and judged from
//! the farthest, and the first inside every piece is the answer.
//!
//! # Degenerate cases
//! * **Tangent curves**: the tangency is a double root; its seed is the real
//!   part of a complex pair, polished as far as Newton goes. The tangency
//!   point is also where the inner curve's arc ends, and the arc's own
//!   stationary points and endpoints are candidates.
//! * **A piece that contains every other one** (or `B` is one piece): no
//!   vertex lies in `B`, and the maximum is a stationary point of a curve
//!   that lies in `B`. A circle centred on `x_hat` makes its stationary
//!   quartic vanish (every point is stationary): its fixed points at `0, pi/2,
//!   pi, 3pi/2` stand for it.
//! * **Identical curves** (two equal measurements): their quartic vanishes
//!   identically and is skipped; the vertices with the other curves remain.
//! * **Segments** (an ellipse with `sum = ||f1 - f2||`): the curve runs along
//!   the segment and back; the stationary points include the segment's ends.
//! * **Empty set**: decided first, as for every bound ([`Intersection::new`]).
//!   If that solve (tolerance `1e-7` of the frame) found a point but no
//!   candidate lies in `B` to `tol`, the candidates are judged again at the
//!   solve's own tolerance; if none is in `B` even then, the outcome is empty.
//!
//! # Tolerance and allowance
//! Lengths are in the frame of [`Intersection`] (centre of the relaxed box,
//! unit half-width); `L = max_k (||c_k - x_hat|| + a_k)` bounds every distance
//! in the problem. A candidate counts as inside a piece when its violation
//! ([`Region::violation`], 1-Lipschitz) is at most `tol = 1e-9 L`, and the
//! bound is the largest candidate distance plus the round-off allowance
//! [`ALLOWANCE`]` * L`: Newton leaves a vertex at a violation of about
//! `1e-15 L` of its second curve, which moves it along the first curve by
//! that over the sine of the crossing angle, so the allowance covers crossing
//! angles down to about `1e-6` rad.

use super::BoundOutcome;
use super::FEAS_TOL;
use super::Intersection;
use super::region::{EllipseGeom, Quadratic, Region};
use crate::estimators::prox::gtrs::quartic_seeds;
use crate::model::geometry::Vec2;

/// The round-off allowance added to the largest candidate distance, relative
/// to the problem's length scale `L` (module docs).
pub const ALLOWANCE: f64 = 1e-9;

/// The tolerance on a candidate's violation of a piece, relative to `L`.
const TOL: f64 = 1e-9;

/// Below this ratio of the leading coefficient to the largest one a quartic is
/// taken as identically zero (identical curves; a circle centred on `x_hat`).
const DEGENERATE: f64 = 1e-13;

/// Newton steps when polishing a root.
const POLISH_STEPS: usize = 24;

/// A region's boundary `x(phi) = c + A cos(phi) + B sin(phi)`.
#[derive(Debug, Clone, Copy)]
struct Curve {
    c: Vec2,
    a: Vec2,
    b: Vec2,
}

impl Curve {
    /// `None` when the region is empty.
    fn of(r: &Region) -> Option<Curve> {
        match r {
            Region::Disc { center, radius } => (*radius >= 0.0).then(|| Curve {
                c: *center,
                a: Vec2::new(*radius, 0.0),
                b: Vec2::new(0.0, *radius),
            }),
            Region::Ellipse { f1, f2, sum } => {
                let g = EllipseGeom::new(f1, f2, *sum)?;
                Some(Curve {
                    c: g.c,
                    a: g.u * g.a,
                    b: Vec2::new(-g.u.y, g.u.x) * g.b,
                })
            }
        }
    }

    fn at(&self, phi: f64) -> Vec2 {
        let (s, c) = phi.sin_cos();
        self.c + self.a * c + self.b * s
    }

    fn tangent(&self, phi: f64) -> Vec2 {
        let (s, c) = phi.sin_cos();
        self.b * c - self.a * s
    }

    /// The same curve with its parameter started at `phi0`.
    fn turned(&self, phi0: f64) -> Curve {
        let (s, c) = phi0.sin_cos();
        Curve {
            c: self.c,
            a: self.a * c + self.b * s,
            b: self.b * c - self.a * s,
        }
    }

    /// The farthest this curve gets from `p` is at most this.
    fn reach(&self, p: &Vec2) -> f64 {
        (self.c - p).norm() + self.a.norm().max(self.b.norm())
    }
}

/// Gradient of [`Region::violation`] at `x` (zero where it is not defined).
fn violation_gradient(r: &Region, x: &Vec2) -> Vec2 {
    let unit = |d: Vec2| {
        let n = d.norm();
        if n > 0.0 { d / n } else { Vec2::zeros() }
    };
    match r {
        Region::Disc { center, .. } => unit(x - center),
        Region::Ellipse { f1, f2, .. } => 0.5 * (unit(x - f1) + unit(x - f2)),
    }
}

/// `Q(x(phi)) (1 + t^2)^2` as a quartic in `t = tan(phi / 2)` (coefficients
/// from the constant term up): with `X(t) = (c + A) + 2B t + (c - A) t^2`,
/// it is `X^T P X + 2 q^T X (1 + t^2) + r (1 + t^2)^2`.
fn crossing_quartic(k: &Curve, q: &Quadratic) -> [f64; 5] {
    let x0 = k.c + k.a;
    let x1 = 2.0 * k.b;
    let x2 = k.c - k.a;
    let pp = |u: &Vec2, v: &Vec2| u.dot(&(q.p * v));
    let lin = |u: &Vec2| 2.0 * q.q.dot(u);
    [
        pp(&x0, &x0) + lin(&x0) + q.r,
        2.0 * pp(&x0, &x1) + lin(&x1),
        2.0 * pp(&x0, &x2) + pp(&x1, &x1) + lin(&x2) + lin(&x0) + 2.0 * q.r,
        2.0 * pp(&x1, &x2) + lin(&x1),
        pp(&x2, &x2) + lin(&x2) + q.r,
    ]
}

/// `(x(phi) - p) . x'(phi) (1 + t^2)^2` as a quartic in `t = tan(phi / 2)`,
/// with `D = c - p`: `(DB + AB) + (2(BB - AA) - 2DA) t - 6AB t^2
/// - (2DA + 2(BB - AA)) t^3 + (AB - DB) t^4`.
fn stationary_quartic(k: &Curve, p: &Vec2) -> [f64; 5] {
    let d = k.c - p;
    let (da, db, ab) = (d.dot(&k.a), d.dot(&k.b), k.a.dot(&k.b));
    let w = k.b.norm_squared() - k.a.norm_squared();
    [
        db + ab,
        2.0 * w - 2.0 * da,
        -6.0 * ab,
        -2.0 * da - 2.0 * w,
        ab - db,
    ]
}

/// The parameters `phi` of the (approximate) roots of the trigonometric
/// equation whose quartic in `tan((phi - phi0) / 2)` is
/// `quartic(curve turned by phi0)`: the real roots and the real parts of
/// complex pairs, not yet polished.
fn raw_roots(curve: &Curve, quartic: impl Fn(&Curve) -> [f64; 5], out: &mut Vec<f64>) {
    const TURNS: [f64; 5] = [0.0, 0.61, 1.37, 2.23, 2.87];
    let mut best: Option<(f64, f64, [f64; 5])> = None;
    for phi0 in TURNS {
        let e = quartic(&curve.turned(phi0));
        let big = e.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if !(big.is_finite() && big > 0.0) {
            continue;
        }
        let lead = e[4].abs() / big;
        if best.is_none_or(|b| lead > b.1) {
            best = Some((phi0, lead, e));
        }
        if lead > 1e-3 {
            break;
        }
    }
    let Some((phi0, lead, e)) = best else {
        return;
    };
    if lead < DEGENERATE {
        return;
    }
    let (seeds, n) = quartic_seeds(&e);
    out.extend(
        seeds[..n]
            .iter()
            .map(|s| phi0 + 2.0 * s.re.atan())
            .filter(|phi| phi.is_finite()),
    );
}

/// Guarded Newton on `h`: a step is kept only if it lowers `|h|`, so the
/// result is never worse than the seed.
fn polish(mut phi: f64, h: impl Fn(f64) -> (f64, f64)) -> f64 {
    let (mut v, mut d) = h(phi);
    for _ in 0..POLISH_STEPS {
        let step = v / d;
        if !step.is_finite() || v == 0.0 {
            break;
        }
        let next = phi - step;
        let (vn, dn) = h(next);
        // A NaN value is no improvement either.
        if vn.is_nan() || vn.abs() >= v.abs() {
            break;
        }
        (phi, v, d) = (next, vn, dn);
    }
    phi
}

/// What a candidate solves on its curve.
#[derive(Debug, Clone, Copy)]
enum Kind {
    /// One of the four fixed points.
    Fixed,
    /// A stationary point of the distance to `p`.
    Stationary,
    /// A crossing with the boundary of region `j`.
    Crossing(usize),
}

/// A candidate point: curve `i` at `phi`.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    i: usize,
    phi: f64,
    kind: Kind,
}

/// Every candidate point of the maximum of `||x - p||` over the intersection
/// of `regions` (module docs): the vertices of every pair of curves, the
/// stationary points of the distance on every curve, and four fixed points
/// of every curve, unpolished.
fn candidates(curves: &[Option<Curve>], regions: &[Region], p: &Vec2) -> Vec<Candidate> {
    let quads: Vec<Option<Quadratic>> = regions
        .iter()
        .map(|r| r.quadratics().and_then(|q| q.first().copied()))
        .collect();
    let mut out = Vec::new();
    let mut phis = Vec::new();
    for (i, ci) in curves.iter().enumerate() {
        let Some(ci) = ci else { continue };
        for k in 0..4 {
            let phi = k as f64 * std::f64::consts::FRAC_PI_2;
            out.push(Candidate {
                i,
                phi,
                kind: Kind::Fixed,
            });
        }
        phis.clear();
        raw_roots(ci, |k| stationary_quartic(k, p), &mut phis);
        out.extend(phis.iter().map(|&phi| Candidate {
            i,
            phi,
            kind: Kind::Stationary,
        }));
        for (j, qj) in quads.iter().enumerate() {
            let Some(qj) = qj.filter(|_| j != i && curves[j].is_some()) else {
                continue;
            };
            phis.clear();
            raw_roots(ci, |k| crossing_quartic(k, &qj), &mut phis);
            out.extend(phis.iter().map(|&phi| Candidate {
                i,
                phi,
                kind: Kind::Crossing(j),
            }));
        }
    }
    out
}

/// Polish candidate `c` by Newton steps on its own equation; its point.
fn polished(c: &Candidate, curves: &[Option<Curve>], regions: &[Region], p: &Vec2) -> Vec2 {
    let Some(k) = curves[c.i] else {
        return Vec2::repeat(f64::NAN);
    };
    let phi = match c.kind {
        Kind::Fixed => c.phi,
        // f = (x - p) . x', f' = |x'|^2 + (x - p) . x'' with x'' = -(x - c).
        Kind::Stationary => polish(c.phi, |phi| {
            let (x, dx) = (k.at(phi), k.tangent(phi));
            (
                (x - p).dot(&dx),
                dx.norm_squared() - (x - p).dot(&(x - k.c)),
            )
        }),
        Kind::Crossing(j) => polish(c.phi, |phi| {
            let x = k.at(phi);
            let r = &regions[j];
            (
                r.violation(&x),
                violation_gradient(r, &x).dot(&k.tangent(phi)),
            )
        }),
    };
    k.at(phi)
}

/// The largest `||x - p||` over the candidates inside every region to
/// `tol`: candidates outside the box `(lo, hi)` (which contains the set) by
/// more than `margin` are dropped unpolished, the others are polished and
/// taken from the farthest, and the first one inside every region is the
/// answer.
fn largest_inside(
    cands: &[Candidate],
    curves: &[Option<Curve>],
    regions: &[Region],
    p: &Vec2,
    (lo, hi): (Vec2, Vec2),
    margin: f64,
    tol: f64,
) -> Option<f64> {
    let near = |x: &Vec2| {
        x.x >= lo.x - margin && x.x <= hi.x + margin && x.y >= lo.y - margin && x.y <= hi.y + margin
    };
    let mut pts: Vec<(f64, Vec2)> = cands
        .iter()
        .filter(|c| curves[c.i].is_some_and(|k| near(&k.at(c.phi))))
        .map(|c| polished(c, curves, regions, p))
        .filter(|x| near(x))
        .map(|x| ((x - p).norm(), x))
        .collect();
    pts.sort_by(|a, b| b.0.total_cmp(&a.0));
    pts.into_iter()
        .find(|(_, x)| regions.iter().all(|r| r.violation(x) <= tol))
        .map(|(d, _)| d)
}

impl Intersection {
    /// `upp_exact` (module [`exact`](self)): `max_{x in B} ||x - x_hat||`
    /// plus the round-off allowance; never below the true maximum, and never
    /// above it by more than `ALLOWANCE * L` (plus `tol`'s share near a
    /// vertex).
    pub(super) fn upp_exact_plane(&self, x_hat: &Vec2) -> Result<BoundOutcome, super::BoundError> {
        super::check_point(x_hat)?;
        let p = self.to_local(x_hat);
        let curves: Vec<Option<Curve>> = self.local.iter().map(Curve::of).collect();
        let scale_l = curves
            .iter()
            .flatten()
            .map(|c| c.reach(&p))
            .fold(0.0f64, f64::max)
            .max(f64::MIN_POSITIVE);
        let bx = (
            self.to_local(&self.relaxed.lo),
            self.to_local(&self.relaxed.hi),
        );
        // Unpolished roots are within ~1e-8 L of their point (a near-double
        // root within ~sqrt(eps)): the margin keeps every one that may be in B.
        let margin = 1e-4 * scale_l;
        // B lies in the box; a region that holds the whole box (its four
        // corners, by convexity) has no boundary point in it, so neither its
        // vertices nor its stationary points can be in B.
        let (lo, hi) = bx;
        let corners = [lo, hi, Vec2::new(lo.x, hi.y), Vec2::new(hi.x, lo.y)];
        let active: Vec<Option<Curve>> = curves
            .iter()
            .zip(&self.local)
            .map(|(c, r)| c.filter(|_| corners.iter().any(|x| r.violation(x) > -margin)))
            .collect();
        let cands = candidates(&active, &self.local, &p);
        let inside = |tol| largest_inside(&cands, &active, &self.local, &p, bx, margin, tol);
        let best = inside(TOL * scale_l).or_else(|| inside(FEAS_TOL.max(TOL * scale_l)));
        Ok(match best {
            Some(d) => BoundOutcome::Bound((d + ALLOWANCE * scale_l) * self.scale),
            None => BoundOutcome::Empty,
        })
    }
}
