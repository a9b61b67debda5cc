//! Feasible-set pieces: discs (one-way ranges) and ellipses (bistatic ranges),
//! their exact Euclidean projections, axis-aligned bounding boxes and
//! standard-form quadratics; in 3-D balls and prolate spheroids.
//!
//! A spheroid is an ellipse turned about its focal axis, so every question
//! about it is the ellipse's question in the plane through the axis and the
//! point asked about: its projection is the ellipse's projection in the
//! coordinates (along the axis, distance from the axis).

use crate::model::geometry::Point;
use crate::model::linalg::MatD;

/// One convex piece of the feasible set of Gholami 2015 eq. (12)-(13), extended to
/// bistatic ranges. A position `x` that produced a range with a nonnegative error
/// lies in the piece (Gholami 2015 Sec. 4; Remark 4 for the enlargement `rho`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Region<const D: usize = 2> {
    /// One-way range: `||x - center|| <= radius` (a disc, Gholami 2015 eq. (12);
    /// a ball in 3-D). A negative radius is an empty set.
    Disc {
        /// Anchor (receiver) position.
        center: Point<D>,
        /// Enlarged measured range `d^_i + rho_i` (Gholami 2015 eq. (20)).
        radius: f64,
    },
    /// Bistatic range: `||x - f1|| + ||x - f2|| <= sum`, a filled ellipse (a
    /// prolate spheroid in 3-D) with foci `f1` (transmitter) and `f2`
    /// (receiver). `sum < ||f1 - f2||` is empty and `sum == ||f1 - f2||` is
    /// the segment `[f1, f2]`.
    Ellipse {
        /// Transmitter position.
        f1: Point<D>,
        /// Receiver position.
        f2: Point<D>,
        /// Enlarged measured bistatic range.
        sum: f64,
    },
}

/// A quadratic constraint in the standard form `x^T P x + 2 q^T x + r <= 0`
/// used by the QCQP (1) and its SDP relaxation (2) of Gholami 2015.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Quadratic<const D: usize = 2> {
    /// Symmetric matrix `P` (here always positive semidefinite).
    pub p: MatD<D>,
    /// Linear part `q` (the constraint has `2 q^T x`).
    pub q: Point<D>,
    /// Constant `r`.
    pub r: f64,
}

impl<const D: usize> Quadratic<D> {
    /// `x^T P x + 2 q^T x + r`.
    pub fn eval(&self, x: &Point<D>) -> f64 {
        x.dot(&(self.p * x)) + 2.0 * self.q.dot(x) + self.r
    }
}

/// Below this ratio `b / a` of semi-axes an ellipse is handled as its segment
/// (projection only; the error is at most `b`).
const SEGMENT_RATIO: f64 = 1e-12;

/// Centre, unit major axis and semi-axes of a nonempty ellipse.
#[derive(Debug, Clone, Copy)]
pub(crate) struct EllipseGeom<const D: usize = 2> {
    pub c: Point<D>,
    pub u: Point<D>,
    pub a: f64,
    pub b: f64,
}

impl<const D: usize> EllipseGeom<D> {
    /// `None` when `sum < ||f1 - f2||` (empty).
    pub(crate) fn new(f1: &Point<D>, f2: &Point<D>, sum: f64) -> Option<Self> {
        let d = f2 - f1;
        let dist = d.norm();
        if sum < dist {
            return None;
        }
        let u = if dist > 0.0 {
            d / dist
        } else {
            Point::<D>::from_fn(|i, _| if i == 0 { 1.0 } else { 0.0 })
        };
        let a = 0.5 * sum;
        let e = 0.5 * dist;
        // (a - e)(a + e) is the accurate form of a^2 - e^2.
        let b = ((a - e) * (a + e)).max(0.0).sqrt();
        Some(Self {
            c: 0.5 * (f1 + f2),
            u,
            a,
            b,
        })
    }

    /// The unit normal of the major axis in 2-D (`u` turned a quarter).
    fn perp(&self) -> Point<D> {
        Point::<D>::from_fn(|i, _| match i {
            0 => -self.u[1],
            1 => self.u[0],
            _ => 0.0,
        })
    }

    fn is_segment(&self) -> bool {
        self.b <= SEGMENT_RATIO * self.a
    }
}

impl<const D: usize> Region<D> {
    /// Disc `||x - center|| <= radius`.
    pub fn disc(center: Point<D>, radius: f64) -> Self {
        Region::Disc { center, radius }
    }

    /// Ellipse `||x - f1|| + ||x - f2|| <= sum`.
    pub fn ellipse(f1: Point<D>, f2: Point<D>, sum: f64) -> Self {
        Region::Ellipse { f1, f2, sum }
    }

    /// Disc from a one-way range measured at `anchor`, enlarged by `rho >= 0`
    /// (Gholami 2015 Remark 4, eq. (19)-(21): `d~ = d^ + rho` bounds the true range
    /// when the error is at least `-rho`).
    pub fn from_range(anchor: Point<D>, measured: f64, rho: f64) -> Self {
        Region::Disc {
            center: anchor,
            radius: measured + rho,
        }
    }

    /// Ellipse from a bistatic range `||x - tx|| + ||x - rx||` measured with an
    /// error of at least `-rho` (Gholami 2015 Remark 4 applied to the range sum).
    pub fn from_bistatic(tx: Point<D>, rx: Point<D>, measured: f64, rho: f64) -> Self {
        Region::Ellipse {
            f1: tx,
            f2: rx,
            sum: measured + rho,
        }
    }

    /// True when every number in the region is finite.
    pub fn is_finite(&self) -> bool {
        match self {
            Region::Disc { center, radius } => {
                center.iter().all(|v| v.is_finite()) && radius.is_finite()
            }
            Region::Ellipse { f1, f2, sum } => {
                f1.iter().chain(f2.iter()).all(|v| v.is_finite()) && sum.is_finite()
            }
        }
    }

    /// True when the region itself is empty (negative radius, or
    /// `sum < ||f1 - f2||`).
    pub fn is_empty(&self) -> bool {
        match self {
            Region::Disc { radius, .. } => *radius < 0.0,
            Region::Ellipse { f1, f2, sum } => *sum < (f2 - f1).norm(),
        }
    }

    /// Signed violation: `||x - c|| - radius` for a disc,
    /// `(||x - f1|| + ||x - f2|| - sum) / 2` for an ellipse. It is `<= 0`
    /// exactly on the region and never exceeds the distance to the region
    /// (both terms are 1-Lipschitz).
    pub fn violation(&self, x: &Point<D>) -> f64 {
        match self {
            Region::Disc { center, radius } => (x - center).norm() - radius,
            Region::Ellipse { f1, f2, sum } => 0.5 * ((x - f1).norm() + (x - f2).norm() - sum),
        }
    }

    /// `violation(x) <= tol`.
    pub fn contains(&self, x: &Point<D>, tol: f64) -> bool {
        self.violation(x) <= tol
    }

    /// Euclidean projection `P_B(x)` of Gholami 2015 eq. (17)-(18); `None` when the
    /// region is empty. For an ellipse outside point the exact nearest boundary
    /// point is found from the 1-D secular equation (safeguarded Newton).
    pub fn project(&self, x: &Point<D>) -> Option<Point<D>> {
        match self {
            Region::Disc { center, radius } => {
                if *radius < 0.0 {
                    return None;
                }
                let d = x - center;
                let n = d.norm();
                if n <= *radius {
                    Some(*x)
                } else {
                    Some(center + d * (radius / n))
                }
            }
            Region::Ellipse { f1, f2, sum } => {
                let g = EllipseGeom::new(f1, f2, *sum)?;
                Some(project_ellipse(&g, f1, f2, x))
            }
        }
    }

    /// Euclidean distance to the region (`None` when empty).
    pub fn distance(&self, x: &Point<D>) -> Option<f64> {
        self.project(x).map(|p| (x - p).norm())
    }

    /// Axis-aligned bounding box `(lo, hi)` of the region (`None` when empty):
    /// for a disc the l-infinity ball of Gholami 2015 Sec. 5.2.3, for an ellipse
    /// with semi-axes `a` (along unit `u`) and `b` the half-widths
    /// `sqrt(a^2 u_x^2 + b^2 u_y^2)` and `sqrt(a^2 u_y^2 + b^2 u_x^2)`; for a
    /// spheroid `sqrt(a^2 u_i^2 + b^2 (1 - u_i^2))` along axis `i`.
    pub fn aabb(&self) -> Option<(Point<D>, Point<D>)> {
        match self {
            Region::Disc { center, radius } => {
                if *radius < 0.0 {
                    return None;
                }
                let h = Point::<D>::repeat(*radius);
                Some((center - h, center + h))
            }
            Region::Ellipse { f1, f2, sum } => {
                let g = EllipseGeom::new(f1, f2, *sum)?;
                let (a2, b2) = (g.a * g.a, g.b * g.b);
                let u = g.u;
                let h = Point::<D>::from_fn(|i, _| {
                    if D == 2 {
                        let (ui, uj) = (u[i], u[1 - i]);
                        (a2 * ui * ui + b2 * uj * uj).sqrt()
                    } else {
                        (a2 * u[i] * u[i] + b2 * (1.0 - u[i] * u[i]).max(0.0)).sqrt()
                    }
                });
                Some((g.c - h, g.c + h))
            }
        }
    }

    /// Standard-form quadratics whose intersection is the region (`None` when
    /// empty). A disc gives `||x||^2 - 2 c^T x + ||c||^2 - R^2 <= 0` (Gholami 2015
    /// eq. (25)). An ellipse with centre `c`, unit major axis `u`, `u_perp`,
    /// semi-axes `a = sum/2`, `b = sqrt(a^2 - ||f1 - f2||^2/4)` is
    /// `((x-c).u)^2 / a^2 + ((x-c).u_perp)^2 / b^2 <= 1`; multiplied by `b^2`:
    /// `P = (b^2/a^2) u u^T + u_perp u_perp^T`, `q = -P c`, `r = c^T P c - b^2`
    /// (in 3-D `u_perp u_perp^T` is `I - u u^T`, a spheroid).
    /// Each ellipse also yields the redundant circumscribed disc
    /// `||x - c|| <= a`, which keeps thin ellipses well conditioned and makes
    /// the segment case (`b = 0`, line `((x-c).u_perp)^2 <= 0` plus that disc)
    /// exact.
    pub fn quadratics(&self) -> Option<Vec<Quadratic<D>>> {
        let disc = |c: &Point<D>, r: f64| Quadratic {
            p: MatD::<D>::identity(),
            q: -c,
            r: c.norm_squared() - r * r,
        };
        match self {
            Region::Disc { center, radius } => {
                if *radius < 0.0 {
                    return None;
                }
                Some(vec![disc(center, *radius)])
            }
            Region::Ellipse { f1, f2, sum } => {
                let g = EllipseGeom::new(f1, f2, *sum)?;
                let ratio = if g.a > 0.0 { (g.b / g.a).powi(2) } else { 1.0 };
                let uu = g.u * g.u.transpose();
                let normal = if D == 2 {
                    let v = g.perp();
                    v * v.transpose()
                } else {
                    MatD::<D>::identity() - uu
                };
                let p = uu * ratio + normal;
                let pc = p * g.c;
                let ell = Quadratic {
                    p,
                    q: -pc,
                    r: g.c.dot(&pc) - g.b * g.b,
                };
                Some(vec![ell, disc(&g.c, g.a)])
            }
        }
    }

    /// A length scale of the region (radius or semi-major axis; 0 when empty).
    pub(crate) fn size(&self) -> f64 {
        match self {
            Region::Disc { radius, .. } => radius.max(0.0),
            Region::Ellipse { sum, .. } => (0.5 * sum).max(0.0),
        }
    }

    /// The region in the frame `y = (x - c0) / l`.
    pub(crate) fn to_frame(self, c0: &Point<D>, l: f64) -> Self {
        match self {
            Region::Disc { center, radius } => Region::Disc {
                center: (center - c0) / l,
                radius: radius / l,
            },
            Region::Ellipse { f1, f2, sum } => Region::Ellipse {
                f1: (f1 - c0) / l,
                f2: (f2 - c0) / l,
                sum: sum / l,
            },
        }
    }
}

/// Projection onto the segment `[p0, p1]`.
fn project_segment<const D: usize>(p0: &Point<D>, p1: &Point<D>, x: &Point<D>) -> Point<D> {
    let d = p1 - p0;
    let dd = d.norm_squared();
    if dd <= 0.0 {
        return *p0;
    }
    let t = ((x - p0).dot(&d) / dd).clamp(0.0, 1.0);
    p0 + d * t
}

/// Exact projection onto a filled ellipse or spheroid (nonempty). In 3-D the
/// point's plane through the axis holds its nearest point: the ellipse's
/// projection there, with `v` the unit direction from the axis to the point
/// (any normal of the axis when the point is on it, where the vertex or the
/// point itself is the answer).
fn project_ellipse<const D: usize>(
    g: &EllipseGeom<D>,
    f1: &Point<D>,
    f2: &Point<D>,
    x: &Point<D>,
) -> Point<D> {
    if g.is_segment() {
        return project_segment(f1, f2, x);
    }
    let d = x - g.c;
    let v = if D == 2 {
        g.perp()
    } else {
        let w = d - g.u * d.dot(&g.u);
        let n = w.norm();
        if n > 0.0 { w / n } else { Point::<D>::zeros() }
    };
    let (y0, y1) = (d.dot(&g.u), d.dot(&v));
    let (e0, e1) = (g.a, g.b);
    let (z0, z1) = (y0 / e0, y1 / e1);
    if z0 * z0 + z1 * z1 <= 1.0 {
        return *x;
    }
    let (p0, p1) = project_ellipse_quadrant(e0, e1, y0.abs(), y1.abs());
    g.c + g.u * p0.copysign(y0) + v * p1.copysign(y1)
}

/// Nearest point of the ellipse `(x0/e0)^2 + (x1/e1)^2 = 1` (`e0 >= e1 > 0`) to the
/// outside point `(y0, y1)`, `y0, y1 >= 0` (D. Eberly, "Distance from a point to an
/// ellipse"). With `s = mu / e1^2` the KKT point is `x0 = r0 y0 / (s + r0)`,
/// `x1 = y1 / (s + 1)`, `r0 = (e0/e1)^2`, and `s` is the unique root on
/// `s > -1` of the decreasing convex `G(s) = (r0 z0/(s+r0))^2 + (z1/(s+1))^2 - 1`.
fn project_ellipse_quadrant(e0: f64, e1: f64, y0: f64, y1: f64) -> (f64, f64) {
    if y1 <= 0.0 {
        // On the major axis and outside: the vertex is nearest.
        return (e0, 0.0);
    }
    if y0 <= 0.0 {
        return (0.0, e1);
    }
    let (z0, z1) = (y0 / e0, y1 / e1);
    let r0 = (e0 / e1) * (e0 / e1);
    let n0 = r0 * z0;
    let big_g = |s: f64| {
        let (a, b) = (n0 / (s + r0), z1 / (s + 1.0));
        (
            a * a + b * b - 1.0,
            -2.0 * (a * a / (s + r0) + b * b / (s + 1.0)),
        )
    };
    // Bracket: G(z1 - 1) >= 0 and G(hypot(n0, z1) - 1) <= 0 (Eberly).
    let mut lo = z1 - 1.0;
    let mut hi = n0.hypot(z1) - 1.0;
    let mut s = lo;
    for _ in 0..200 {
        let (gv, dg) = big_g(s);
        if gv >= 0.0 {
            lo = s;
        } else {
            hi = s;
        }
        if gv.abs() <= 0.0 || hi - lo <= 4.0 * f64::EPSILON * s.abs().max(1.0) {
            break;
        }
        // Newton from the left never overshoots a convex decreasing function;
        // bisect whenever rounding pushes it out of the bracket.
        let mut next = s - gv / dg;
        if !(next > lo && next < hi) {
            next = 0.5 * (lo + hi);
        }
        if (next - s).abs() <= 2.0 * f64::EPSILON * s.abs().max(1.0) {
            s = next;
            break;
        }
        s = next;
    }
    (r0 * y0 / (s + r0), y1 / (s + 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::geometry::Vec2;
    use crate::model::rng::SonarRng;
    use rand::{RngExt, SeedableRng};

    fn brute_nearest_on_ellipse(g: &EllipseGeom, x: &Vec2) -> f64 {
        let v = g.perp();
        let pt = |th: f64| g.c + g.u * (g.a * th.cos()) + v * (g.b * th.sin());
        let n = 20_000;
        let mut best = (f64::INFINITY, 0.0);
        for k in 0..n {
            let th = k as f64 / n as f64 * std::f64::consts::TAU;
            let d = (pt(th) - x).norm();
            if d < best.0 {
                best = (d, th);
            }
        }
        // Golden-section refinement around the best sample.
        let h = std::f64::consts::TAU / n as f64;
        let (mut a, mut b) = (best.1 - h, best.1 + h);
        let phi = 0.5 * (5f64.sqrt() - 1.0);
        for _ in 0..100 {
            let c = b - phi * (b - a);
            let d = a + phi * (b - a);
            if (pt(c) - x).norm() < (pt(d) - x).norm() {
                b = d;
            } else {
                a = c;
            }
        }
        (pt(0.5 * (a + b)) - x).norm().min(best.0)
    }

    #[test]
    fn ellipse_projection_matches_brute_force_on_random_points() {
        let mut rng = SonarRng::seed_from_u64(11);
        for _ in 0..300 {
            let f1 = Vec2::new(rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0));
            let f2 = Vec2::new(rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0));
            let dist = (f2 - f1).norm();
            // Include very thin ellipses.
            let sum = dist * (1.0 + 10f64.powf(rng.random_range(-6.0..0.5)));
            let reg = Region::ellipse(f1, f2, sum);
            let g = EllipseGeom::new(&f1, &f2, sum).unwrap();
            let x = Vec2::new(rng.random_range(-12.0..12.0), rng.random_range(-12.0..12.0));
            let p = reg.project(&x).unwrap();
            let dp = (p - x).norm();
            if reg.violation(&x) <= 0.0 {
                assert!(dp <= 0.0, "inside point must be fixed");
                continue;
            }
            // On the boundary (sum-of-distances form).
            assert!(
                reg.violation(&p).abs() <= 1e-9 * sum,
                "{:?}",
                reg.violation(&p)
            );
            // No boundary point is nearer than p (brute force).
            let db = brute_nearest_on_ellipse(&g, &x);
            assert!(
                dp <= db + 1e-9 * (1.0 + db),
                "projection {dp} vs brute force {db}"
            );
            assert!(
                dp >= db - 1e-7 * (1.0 + db),
                "projection {dp} vs brute force {db}"
            );
        }
    }

    #[test]
    fn ellipse_projection_handles_axis_points_and_segments() {
        let reg = Region::ellipse(Vec2::new(-3.0, 0.0), Vec2::new(3.0, 0.0), 10.0);
        // a = 5, b = 4.
        let p = reg.project(&Vec2::new(9.0, 0.0)).unwrap();
        assert!((p - Vec2::new(5.0, 0.0)).norm() < 1e-12);
        let p = reg.project(&Vec2::new(0.0, -7.0)).unwrap();
        assert!((p - Vec2::new(0.0, -4.0)).norm() < 1e-12);
        let seg = Region::ellipse(Vec2::new(0.0, 0.0), Vec2::new(2.0, 0.0), 2.0);
        let p = seg.project(&Vec2::new(1.5, 3.0)).unwrap();
        assert!((p - Vec2::new(1.5, 0.0)).norm() < 1e-12);
        let p = seg.project(&Vec2::new(-1.0, -1.0)).unwrap();
        assert!(p.norm() < 1e-12);
        assert!(
            Region::ellipse(Vec2::zeros(), Vec2::new(2.0, 0.0), 1.9)
                .project(&p)
                .is_none()
        );
    }

    #[test]
    fn ellipse_quadratic_agrees_with_sum_of_distances_form() {
        let mut rng = SonarRng::seed_from_u64(5);
        for _ in 0..200 {
            let f1 = Vec2::new(rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0));
            let f2 = Vec2::new(rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0));
            let sum = (f2 - f1).norm() * rng.random_range(1.01..3.0) + 0.1;
            let reg = Region::ellipse(f1, f2, sum);
            let quads = reg.quadratics().unwrap();
            let g = EllipseGeom::new(&f1, &f2, sum).unwrap();
            for _ in 0..50 {
                let x = Vec2::new(rng.random_range(-15.0..15.0), rng.random_range(-15.0..15.0));
                let inside_sum = reg.violation(&x) <= 0.0;
                let inside_quad = quads.iter().all(|q| q.eval(&x) <= 0.0);
                let margin = reg.violation(&x).abs();
                if margin > 1e-9 {
                    assert_eq!(inside_sum, inside_quad, "x = {x:?}");
                }
            }
            // Boundary points of the sum form are zeros of the ellipse quadratic.
            let v = g.perp();
            for k in 0..16 {
                let th = k as f64 * 0.4;
                let x = g.c + g.u * (g.a * th.cos()) + v * (g.b * th.sin());
                assert!(reg.violation(&x).abs() < 1e-9 * sum);
                assert!(quads[0].eval(&x).abs() < 1e-9 * sum * sum);
            }
        }
    }

    #[test]
    fn region_aabb_contains_boundary_and_touches_it() {
        let mut rng = SonarRng::seed_from_u64(9);
        for _ in 0..100 {
            let f1 = Vec2::new(rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0));
            let f2 = Vec2::new(rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0));
            let sum = (f2 - f1).norm() * rng.random_range(1.0..2.0) + 0.01;
            let reg = Region::ellipse(f1, f2, sum);
            let (lo, hi) = reg.aabb().unwrap();
            let g = EllipseGeom::new(&f1, &f2, sum).unwrap();
            let v = g.perp();
            let (mut mlo, mut mhi) = (Vec2::repeat(f64::INFINITY), Vec2::repeat(f64::NEG_INFINITY));
            for k in 0..20_000 {
                let th = k as f64 / 20_000.0 * std::f64::consts::TAU;
                let x = g.c + g.u * (g.a * th.cos()) + v * (g.b * th.sin());
                mlo = mlo.inf(&x);
                mhi = mhi.sup(&x);
            }
            let tol = 1e-9 * sum;
            assert!(lo.x <= mlo.x + tol && lo.y <= mlo.y + tol);
            assert!(hi.x >= mhi.x - tol && hi.y >= mhi.y - tol);
            // Sampling at 2e4 points is within 1e-6 of the extremes.
            assert!((lo - mlo).norm() < 1e-6 * sum && (hi - mhi).norm() < 1e-6 * sum);
        }
    }
}
