//! Position estimator of Gholami 2015 Sec. 4: POCS (eq. (15)-(18)). Its other
//! estimator, the closed-form linear least squares (Pun-So 2022 eq. (15)-(17)), is
//! [`crate::estimators::online::ols_toa`] (one-way ranges) and [`crate::estimators::online::ols_position`]
//! (also bistatic ranges): one implementation for the bounds, the trackers and the
//! `lls` baseline.

use super::BoundError;
use super::region::Region;
use crate::model::geometry::Point;

/// Result of [`pocs`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PocsResult<const D: usize = 2> {
    /// Last iterate.
    pub x: Point<D>,
    /// Number of projections performed.
    pub iterations: usize,
    /// True when every region is within `tol` of `x` (Euclidean distance).
    pub feasible: bool,
}

/// POCS with the farthest-set rule of Gholami 2015 eq. (17)-(18): while the largest
/// distance `f(x) = max_i dist(x, B_i)` (eq. (15)) exceeds `tol`, replace `x` by its
/// exact projection onto the farthest region. Returns after `max_iter`
/// projections with `feasible = false` if the regions are not reached (e.g. an
/// empty intersection).
///
/// Errors: [`BoundError::NonFinite`] for non-finite input or `tol`,
/// [`BoundError::NoRegions`] for an empty slice. A region that is itself
/// empty makes the set empty: the result is `x0` with `feasible = false`.
pub fn pocs<const D: usize>(
    regions: &[Region<D>],
    x0: Point<D>,
    max_iter: usize,
    tol: f64,
) -> Result<PocsResult<D>, BoundError> {
    if regions.is_empty() {
        return Err(BoundError::NoRegions);
    }
    if !(x0.iter().all(|v| v.is_finite()) && tol.is_finite())
        || regions.iter().any(|r| !r.is_finite())
    {
        return Err(BoundError::NonFinite);
    }
    if regions.iter().any(Region::is_empty) {
        return Ok(PocsResult {
            x: x0,
            iterations: 0,
            feasible: false,
        });
    }
    let mut x = x0;
    let mut iterations = 0;
    loop {
        // Farthest region and its projection.
        let mut far: Option<(f64, Point<D>)> = None;
        for r in regions {
            // Nonempty regions always project.
            let Some(p) = r.project(&x) else { continue };
            let d = (x - p).norm();
            if far.is_none_or(|(fd, _)| d > fd) {
                far = Some((d, p));
            }
        }
        let Some((dist, p)) = far else {
            return Ok(PocsResult {
                x,
                iterations,
                feasible: false,
            });
        };
        if dist <= tol {
            return Ok(PocsResult {
                x,
                iterations,
                feasible: true,
            });
        }
        if iterations >= max_iter {
            return Ok(PocsResult {
                x,
                iterations,
                feasible: false,
            });
        }
        x = p;
        iterations += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::geometry::Vec2;

    #[test]
    fn pocs_reaches_a_point_of_a_nonempty_intersection() {
        let regions = [
            Region::disc(Vec2::new(0.0, 0.0), 5.0),
            Region::disc(Vec2::new(6.0, 0.0), 3.0),
            Region::ellipse(Vec2::new(2.0, -4.0), Vec2::new(4.0, 4.0), 10.0),
        ];
        let r = pocs(&regions, Vec2::new(-20.0, 30.0), 10_000, 1e-9).unwrap();
        assert!(r.feasible);
        for reg in &regions {
            assert!(reg.distance(&r.x).unwrap() <= 1e-9);
        }
    }

    #[test]
    fn pocs_reports_infeasible_for_disjoint_regions() {
        let regions = [
            Region::disc(Vec2::new(0.0, 0.0), 1.0),
            Region::disc(Vec2::new(5.0, 0.0), 1.0),
        ];
        let r = pocs(&regions, Vec2::new(0.0, 0.0), 50, 1e-9).unwrap();
        assert!(!r.feasible);
        assert_eq!(r.iterations, 50);
        assert!(matches!(
            pocs(&[], Vec2::zeros(), 5, 1e-9),
            Err(BoundError::NoRegions)
        ));
    }
}
