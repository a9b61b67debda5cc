//! Certified position-error bounds and set-based estimators (Gholami, Ström,
//! Wymeersch, Rydström, "On geometric upper bounds for positioning algorithms in
//! wireless sensor networks", Gholami 2015), for one-way ranges (discs) and
//! bistatic ranges (ellipses) in 2-D.
//!
//! With range errors bounded below by `-rho` (Gholami 2015 Remark 4), the true
//! position lies in the intersection `B` of the [`Region`]s. For an estimate
//! `x_hat` every bound `u` here satisfies `u >= max_{x in B} ||x - x_hat||`,
//! so `u >= ||x_true - x_hat||`, whatever the conic solver's accuracy: each
//! value is the one its certificate gives (Upp-MinBall's multipliers,
//! Upp-BBox's and Upp-MaxDis's dual variables, evaluated exactly plus a
//! round-off allowance), not the solver's own objective value:
//!
//! | function | Gholami 2015 | formulation |
//! |---|---|---|
//! | [`upp_rbbox`] | eq. (52)-(54) | closed form: intersect per-region boxes, farthest corner from `x_hat` |
//! | [`upp_bbox`] | eq. (48)-(49) | exact bounding box of `B` from 4 SOCPs, farthest corner |
//! | [`upp_minball`] | eq. (34)-(44) | S-lemma enclosing ball `(c, R)`: QP over the simplex (discs) or a 5x5 LMI SDP (with ellipses); `R + ||x_hat - c||` |
//! | [`upp_maxdis`] | eq. (2), (25)-(26) | SDP relaxation of `max_{x in B} ||x - x_hat||^2` with a 3x3 PSD block; `sqrt(v_sdp)` |
//! | [`upp_exact`] | beyond the paper | the exact `max_{x in B} ||x - x_hat||`: in 2-D the vertices and stationary points of the boundary curves (quartics), plus a round-off allowance ([`exact`]); in 3-D over balls closed-form candidates; in 3-D with spheroids a branch and bound over directions on certified support-function values, within 1e-7 relative |
//!
//! The paper's diameter forms for feasible estimates (eq. (44) `2R`, eq. (49)
//! and (54) box diagonals) are available from [`Ball::diameter`] and
//! [`AxisBox::diagonal`]; the farthest-corner and `R + ||x_hat - c||` forms used
//! here are never larger when `x_hat` lies in the box or ball, and stay valid for
//! infeasible estimates (LLS, SDP).
//!
//! An empty intersection is reported as [`BoundOutcome::Empty`], decided by the
//! min-max-violation SOCP `min t : every region enlarged by t meets` (empty when
//! `t* > 1e-7` in units of the relaxed box half-width) or by any later solve
//! that finds its problem infeasible.
//!
//! All solves use Clarabel in a frame centred on the relaxed box with unit
//! half-width, so the numbers the solver sees are O(1).
//!
//! Orderings that are theorems (and tested): `upp_bbox <= upp_rbbox` (nested
//! boxes) and `upp_maxdis <= upp_minball` (the enclosing-ball S-lemma
//! certificate composed with the exact one-constraint S-lemma for
//! `ball(c, R) in ball(x_hat, R + ||x_hat - c||)` is dual feasible for the SDP).
//! Gholami 2015 reports Upp-MaxDis as the tightest in its 10 m cube; it is not a
//! theorem, and on random 2-D instances with anchors ~100 m away Upp-BBox is
//! the tightest (about 1.06 x the brute-force `v_max1`) while Upp-MaxDis is
//! 1.5-2.8 x: the SDP slack `min_i (d_i^2 - ||x - a_i||^2)` grows with the
//! range (see `tests::report_empirical_orderings`).

mod estimators;
pub mod exact;
mod exact_3d;
mod exact_3d_search;
mod region;
mod sdp;
mod solve;

#[cfg(test)]
mod exact_tests;
#[cfg(test)]
mod search_tests;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod three_d_tests;

pub use estimators::{PocsResult, pocs};
pub use region::{Quadratic, Region};
pub use sdp::{SdpEstimate, sdp_toa};

use crate::model::geometry::Point;

/// Result of a bound: a number, or the statement that the feasible set is empty
/// (no position is consistent with the measurements; no bound is meaningful).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BoundOutcome {
    /// An upper bound on `||x - x_hat||` over the feasible set (metres).
    Bound(f64),
    /// The intersection of the regions is empty.
    Empty,
}

impl BoundOutcome {
    /// The bound, or `None` when empty.
    pub fn value(&self) -> Option<f64> {
        match self {
            BoundOutcome::Bound(v) => Some(*v),
            BoundOutcome::Empty => None,
        }
    }
}

/// Why a bound or estimate could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BoundError {
    /// No regions: the feasible set is the whole plane (unbounded).
    #[error("no regions: the feasible set is unbounded")]
    NoRegions,
    /// A region, the estimate or a parameter was NaN or infinite.
    #[error("non-finite input")]
    NonFinite,
    /// The conic solver failed.
    #[error("{problem}: solver status {status}")]
    Solver {
        /// Which problem.
        problem: &'static str,
        /// Solver status or setup error.
        status: String,
    },
    /// The bound is not defined for these regions in this dimension.
    #[error("{0}")]
    Unsupported(&'static str),
}

/// An axis-aligned box `[lo, hi]` containing the feasible set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisBox<const D: usize = 2> {
    /// Lower corner.
    pub lo: Point<D>,
    /// Upper corner.
    pub hi: Point<D>,
}

impl<const D: usize> AxisBox<D> {
    /// Diagonal length `sqrt(sum_l (hi_l - lo_l)^2)`: the paper's bound on the
    /// maximum length of the set (Gholami 2015 eq. (49) and (54)).
    pub fn diagonal(&self) -> f64 {
        (self.hi - self.lo).norm()
    }

    /// `max_{x in box} ||x - p||`, attained at the farthest corner.
    pub fn farthest_corner(&self, p: &Point<D>) -> f64 {
        let far =
            Point::<D>::from_fn(|i, _| (p[i] - self.lo[i]).abs().max((self.hi[i] - p[i]).abs()));
        if D == 2 {
            far[0].hypot(far[1])
        } else {
            far.norm()
        }
    }

    /// True when `p` is in the box enlarged by `tol`.
    pub fn contains(&self, p: &Point<D>, tol: f64) -> bool {
        (0..D).all(|i| p[i] >= self.lo[i] - tol && p[i] <= self.hi[i] + tol)
    }
}

/// A disc `||x - center|| <= radius` containing the feasible set.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ball<const D: usize = 2> {
    /// Centre `x_c` (Gholami 2015 eq. (42) for discs).
    pub center: Point<D>,
    /// Radius `R` (Gholami 2015 eq. (44)).
    pub radius: f64,
}

impl<const D: usize> Ball<D> {
    /// `2R`, the paper's Upp-MinBall bound on the maximum length (eq. (44)).
    pub fn diameter(&self) -> f64 {
        2.0 * self.radius
    }

    /// `R + ||p - x_c||`, a bound on `||x - p||` for every `x` in the ball.
    pub fn bound(&self, p: &Point<D>) -> f64 {
        self.radius + (p - self.center).norm()
    }
}

/// Feasibility threshold on the min-max violation, in frame units.
const FEAS_TOL: f64 = 1e-7;

/// A nonempty (to solver tolerance) intersection of regions, with the
/// normalised frame used for every solve. Build it once and query several
/// bounds to pay for the emptiness check once.
#[derive(Debug, Clone)]
pub struct Intersection<const D: usize = 2> {
    regions: Vec<Region<D>>,
    /// Regions in the frame `y = (x - origin) / scale`.
    local: Vec<Region<D>>,
    origin: Point<D>,
    scale: f64,
    relaxed: AxisBox<D>,
    witness: Point<D>,
}

impl<const D: usize> Intersection<D> {
    /// Check the regions and decide emptiness. `Ok(None)` when the intersection
    /// is empty: a region is itself empty, the per-region boxes do not meet, or
    /// the min-max-violation SOCP gives `t* > 1e-7` (frame units).
    pub fn new(regions: &[Region<D>]) -> Result<Option<Self>, BoundError> {
        if regions.is_empty() {
            return Err(BoundError::NoRegions);
        }
        if regions.iter().any(|r| !r.is_finite()) {
            return Err(BoundError::NonFinite);
        }
        let Some(relaxed) = relaxed_box(regions) else {
            return Ok(None);
        };
        let origin = 0.5 * (relaxed.lo + relaxed.hi);
        let size = regions.iter().map(Region::size).fold(0.0, f64::max);
        let mut scale = (0.5 * (relaxed.hi - relaxed.lo).max()).max(1e-9 * size);
        if !scale.is_finite() || scale <= 0.0 {
            scale = 1.0;
        }
        let local: Vec<Region<D>> = regions.iter().map(|r| r.to_frame(&origin, scale)).collect();
        let (t, w) = solve::min_max_violation(&local)?;
        if t > FEAS_TOL {
            return Ok(None);
        }
        Ok(Some(Self {
            regions: regions.to_vec(),
            local,
            origin,
            scale,
            relaxed,
            witness: origin + w * scale,
        }))
    }

    /// The regions.
    pub fn regions(&self) -> &[Region<D>] {
        &self.regions
    }

    /// A point minimising the largest violation (in the set up to ~1e-7 of
    /// the relaxed box half-width).
    pub fn witness(&self) -> Point<D> {
        self.witness
    }

    fn to_local(&self, x: &Point<D>) -> Point<D> {
        (x - self.origin) / self.scale
    }

    fn to_world(&self, y: &Point<D>) -> Point<D> {
        self.origin + y * self.scale
    }

    /// Intersection of the per-region bounding boxes, Gholami 2015 eq. (53).
    pub fn relaxed_box(&self) -> AxisBox<D> {
        self.relaxed
    }

    /// Exact bounding box of the set, Gholami 2015 eq. (48a)-(48b) (`None` if the
    /// solver finds the set empty).
    pub fn bounding_box(&self) -> Result<Option<AxisBox<D>>, BoundError> {
        Ok(solve::bounding_box(&self.local)?.map(|(lo, hi)| AxisBox {
            lo: self.to_world(&lo),
            hi: self.to_world(&hi),
        }))
    }

    fn local_quadratics(&self) -> Vec<Quadratic<D>> {
        // Regions of a nonempty intersection are nonempty.
        self.local
            .iter()
            .filter_map(Region::quadratics)
            .flatten()
            .collect()
    }

    /// S-lemma enclosing ball (Gholami 2015 eq. (34)-(44)); `None` if the
    /// certificate proves the set empty. Discs only: the simplex QP (43) with
    /// `x_c` from eq. (42); with ellipses: the 5x5 LMI SDP form of eq. (37).
    pub fn min_ball(&self) -> Result<Option<Ball<D>>, BoundError> {
        let discs: Option<Vec<(Point<D>, f64)>> = self
            .local
            .iter()
            .map(|r| match r {
                Region::Disc { center, radius } => Some((*center, *radius)),
                Region::Ellipse { .. } => None,
            })
            .collect();
        let (c, r2) = match discs {
            Some(d) => solve::minball_qp(&d)?,
            None => match solve::minball_sdp(&self.local_quadratics())? {
                Some(b) => b,
                None => return Ok(None),
            },
        };
        self.ball_to_world(c, r2)
    }

    /// The general S-lemma SDP form even for discs (for cross-checking eq. (43)).
    #[cfg(test)]
    pub(crate) fn min_ball_via_sdp(&self) -> Result<Option<Ball<D>>, BoundError> {
        match solve::minball_sdp(&self.local_quadratics())? {
            Some((c, r2)) => self.ball_to_world(c, r2),
            None => Ok(None),
        }
    }

    fn ball_to_world(&self, c: Point<D>, r2: f64) -> Result<Option<Ball<D>>, BoundError> {
        if r2 < -FEAS_TOL {
            return Ok(None);
        }
        Ok(Some(Ball {
            center: self.to_world(&c),
            radius: r2.max(0.0).sqrt() * self.scale,
        }))
    }

    /// `v_sdp` of Gholami 2015 eq. (26) (in m^2): the SDP relaxation value of
    /// `max_{x in B} ||x - x_hat||^2` (`None` if the solver finds `B` empty).
    pub fn maxdis_sdp_value(&self, x_hat: &Point<D>) -> Result<Option<f64>, BoundError> {
        check_point(x_hat)?;
        let y = self.to_local(x_hat);
        Ok(
            solve::maxdis_sdp(&self.local, &self.local_quadratics(), &y)?
                .map(|v| v.max(0.0) * self.scale * self.scale),
        )
    }

    /// Upp-RBBox (eq. (52)-(54)): farthest corner of the relaxed box from `x_hat`.
    pub fn upp_rbbox(&self, x_hat: &Point<D>) -> Result<BoundOutcome, BoundError> {
        check_point(x_hat)?;
        Ok(BoundOutcome::Bound(self.relaxed.farthest_corner(x_hat)))
    }

    /// Upp-BBox (eq. (48)-(49)): farthest corner of the exact bounding box.
    pub fn upp_bbox(&self, x_hat: &Point<D>) -> Result<BoundOutcome, BoundError> {
        check_point(x_hat)?;
        Ok(match self.bounding_box()? {
            Some(b) => BoundOutcome::Bound(b.farthest_corner(x_hat)),
            None => BoundOutcome::Empty,
        })
    }

    /// Upp-MinBall (eq. (43)-(44)): `R + ||x_hat - x_c||` (`<= 2R` when `x_hat`
    /// is in the ball).
    pub fn upp_minball(&self, x_hat: &Point<D>) -> Result<BoundOutcome, BoundError> {
        check_point(x_hat)?;
        Ok(match self.min_ball()? {
            Some(b) => BoundOutcome::Bound(b.bound(x_hat)),
            None => BoundOutcome::Empty,
        })
    }

    /// Upp-MaxDis (eq. (26)): `sqrt(v_sdp)`.
    pub fn upp_maxdis(&self, x_hat: &Point<D>) -> Result<BoundOutcome, BoundError> {
        Ok(match self.maxdis_sdp_value(x_hat)? {
            Some(v) => BoundOutcome::Bound(v.sqrt()),
            None => BoundOutcome::Empty,
        })
    }

    /// `upp_exact` (beyond Gholami 2015): the exact worst-case error
    /// `max_{x in B} ||x - x_hat||` plus a round-off allowance, never below
    /// the true maximum. In 2-D from the vertices and the stationary points
    /// of the boundary curves ([`exact`]); in 3-D over balls from the
    /// farthest points of each sphere, of each circle where two meet and the
    /// points where three meet (`exact_3d`); in 3-D with spheroids by a
    /// certified search over directions, within 1e-7 relative above the
    /// maximum (`exact_3d_search`).
    pub fn upp_exact(&self, x_hat: &Point<D>) -> Result<BoundOutcome, BoundError> {
        let (set, x): (&dyn std::any::Any, &dyn std::any::Any) = (self, x_hat);
        if let (Some(set), Some(x)) = (set.downcast_ref::<Intersection<2>>(), x.downcast_ref()) {
            return set.upp_exact_plane(x);
        }
        if let (Some(set), Some(x)) = (set.downcast_ref::<Intersection<3>>(), x.downcast_ref()) {
            return set.upp_exact_space(x);
        }
        Err(BoundError::Unsupported(
            "upp_exact is implemented in 2-D and 3-D only",
        ))
    }
}

fn check_point<const D: usize>(x: &Point<D>) -> Result<(), BoundError> {
    if x.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(BoundError::NonFinite)
    }
}

/// Intersection of the per-region axis-aligned boxes (Gholami 2015 eq. (53),
/// generalised to ellipses); `None` when a region is empty or the boxes do not
/// meet.
pub fn relaxed_box<const D: usize>(regions: &[Region<D>]) -> Option<AxisBox<D>> {
    let mut lo = Point::<D>::repeat(f64::NEG_INFINITY);
    let mut hi = Point::<D>::repeat(f64::INFINITY);
    for r in regions {
        let (l, h) = r.aabb()?;
        lo = lo.sup(&l);
        hi = hi.inf(&h);
    }
    if (0..D).any(|i| lo[i] > hi[i]) || regions.is_empty() {
        return None;
    }
    Some(AxisBox { lo, hi })
}

fn with_intersection<const D: usize>(
    regions: &[Region<D>],
    x_hat: &Point<D>,
    f: impl FnOnce(&Intersection<D>, &Point<D>) -> Result<BoundOutcome, BoundError>,
) -> Result<BoundOutcome, BoundError> {
    check_point(x_hat)?;
    match Intersection::new(regions)? {
        Some(i) => f(&i, x_hat),
        None => Ok(BoundOutcome::Empty),
    }
}

/// Upp-RBBox, Gholami 2015 eq. (52)-(54): the per-region axis-aligned boxes (the
/// l-infinity balls for discs) are intersected in closed form and the bound is
/// the distance from `x_hat` to the farthest corner (at most the eq. (54)
/// diagonal when `x_hat` is in the box). Includes the emptiness check (one SOCP).
pub fn upp_rbbox<const D: usize>(
    regions: &[Region<D>],
    x_hat: &Point<D>,
) -> Result<BoundOutcome, BoundError> {
    with_intersection(regions, x_hat, |i, x| i.upp_rbbox(x))
}

/// Upp-BBox, Gholami 2015 eq. (48)-(49): exact bounding box of the intersection from
/// two SOCPs per axis; the bound is the farthest corner from `x_hat`.
pub fn upp_bbox<const D: usize>(
    regions: &[Region<D>],
    x_hat: &Point<D>,
) -> Result<BoundOutcome, BoundError> {
    with_intersection(regions, x_hat, |i, x| i.upp_bbox(x))
}

/// Upp-MinBall, Gholami 2015 eq. (43)-(44): S-lemma enclosing ball `(x_c, R)`; the
/// bound is `R + ||x_hat - x_c||` (the paper's `2R` when `x_hat` is feasible is
/// never smaller).
pub fn upp_minball<const D: usize>(
    regions: &[Region<D>],
    x_hat: &Point<D>,
) -> Result<BoundOutcome, BoundError> {
    with_intersection(regions, x_hat, |i, x| i.upp_minball(x))
}

/// `upp_exact` (beyond Gholami 2015, [`exact`]): the exact worst-case error
/// `max_{x in B} ||x - x_hat||`: in 2-D from the vertices of the set and the
/// stationary points of the distance on its boundary curves, plus a
/// documented round-off allowance; in 3-D as [`Intersection::upp_exact`]
/// says. Includes the emptiness check (one SOCP).
pub fn upp_exact<const D: usize>(
    regions: &[Region<D>],
    x_hat: &Point<D>,
) -> Result<BoundOutcome, BoundError> {
    with_intersection(regions, x_hat, |i, x| i.upp_exact(x))
}

/// Upp-MaxDis, Gholami 2015 eq. (26): `sqrt(v_sdp)` of the SDP relaxation of
/// `max_{x in B} ||x - x_hat||^2`.
pub fn upp_maxdis<const D: usize>(
    regions: &[Region<D>],
    x_hat: &Point<D>,
) -> Result<BoundOutcome, BoundError> {
    with_intersection(regions, x_hat, |i, x| i.upp_maxdis(x))
}
