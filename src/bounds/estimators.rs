//! Position estimators of seed 003 Sec. 4: POCS (eq. (15)-(18)) and the
//! closed-form linear least squares (seed 000 eq. (15)-(17)).

use super::BoundError;
use super::region::Region;
use crate::geometry::Vec2;
use nalgebra::{DMatrix, DVector};

/// Result of [`pocs`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PocsResult {
    /// Last iterate.
    pub x: Vec2,
    /// Number of projections performed.
    pub iterations: usize,
    /// True when every region is within `tol` of `x` (Euclidean distance).
    pub feasible: bool,
}

/// POCS with the farthest-set rule of seed 003 eq. (17)-(18): while the largest
/// distance `f(x) = max_i dist(x, B_i)` (eq. (15)) exceeds `tol`, replace `x` by its
/// exact projection onto the farthest region. Returns after `max_iter`
/// projections with `feasible = false` if the regions are not reached (e.g. an
/// empty intersection).
///
/// Errors: [`BoundError::NonFinite`] for non-finite input or `tol`,
/// [`BoundError::NoRegions`] for an empty slice. A region that is itself
/// empty makes the set empty: the result is `x0` with `feasible = false`.
pub fn pocs(
    regions: &[Region],
    x0: Vec2,
    max_iter: usize,
    tol: f64,
) -> Result<PocsResult, BoundError> {
    if regions.is_empty() {
        return Err(BoundError::NoRegions);
    }
    if !(x0.x.is_finite() && x0.y.is_finite() && tol.is_finite())
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
        let mut far: Option<(f64, Vec2)> = None;
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

/// Why a least-squares estimate could not be formed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LlsError {
    /// Slices of different lengths.
    #[error("{0} anchors but {1} ranges")]
    LengthMismatch(usize, usize),
    /// Not enough measurements for the unknowns.
    #[error("need at least {needed} measurements, got {got}")]
    TooFew {
        /// Minimum number of measurements.
        needed: usize,
        /// Number given.
        got: usize,
    },
    /// NaN or infinite input.
    #[error("non-finite input")]
    NonFinite,
    /// The linear system is rank deficient (e.g. collinear anchors).
    #[error("rank-deficient geometry: {0}")]
    Degenerate(&'static str),
    /// A transmitter index in a bistatic link is out of range.
    #[error("transmitter index {0} out of range")]
    BadIndex(usize),
}

/// Closed-form linear least squares on differenced squared one-way ranges, seed
/// 000 eq. (15)-(17): subtracting `||x - a_i||^2 = r_i^2` from the next equation
/// gives `(a_{i+1} - a_i)^T x = (||a_{i+1}||^2 - ||a_i||^2 + r_i^2 - r_{i+1}^2) / 2`,
/// `i = 1..m-1`, solved as `x = (A^T A)^{-1} A^T b`. Needs `m >= 3`
/// non-collinear anchors.
pub fn lls(anchors: &[Vec2], ranges: &[f64]) -> Result<Vec2, LlsError> {
    if anchors.len() != ranges.len() {
        return Err(LlsError::LengthMismatch(anchors.len(), ranges.len()));
    }
    if anchors.len() < 3 {
        return Err(LlsError::TooFew {
            needed: 3,
            got: anchors.len(),
        });
    }
    if anchors
        .iter()
        .any(|a| !(a.x.is_finite() && a.y.is_finite()))
        || ranges.iter().any(|r| !r.is_finite())
    {
        return Err(LlsError::NonFinite);
    }
    // Work relative to the first anchor for conditioning: x = a_1 + y.
    let o = anchors[0];
    let mut ata = nalgebra::Matrix2::<f64>::zeros();
    let mut atb = Vec2::zeros();
    for i in 0..anchors.len() - 1 {
        let (ai, aj) = (anchors[i] - o, anchors[i + 1] - o);
        let row = aj - ai;
        let rhs = 0.5
            * (aj.norm_squared() - ai.norm_squared() + ranges[i] * ranges[i]
                - ranges[i + 1] * ranges[i + 1]);
        ata += row * row.transpose();
        atb += row * rhs;
    }
    solve_normal(&ata, &atb).map(|y| o + y)
}

fn solve_normal(ata: &nalgebra::Matrix2<f64>, atb: &Vec2) -> Result<Vec2, LlsError> {
    let det = ata.determinant();
    let scale = ata.norm_squared();
    if det.abs().partial_cmp(&(1e-12 * scale)) != Some(std::cmp::Ordering::Greater) {
        return Err(LlsError::Degenerate("anchors (nearly) collinear"));
    }
    let y = ata
        .try_inverse()
        .ok_or(LlsError::Degenerate("singular normal matrix"))?
        * atb;
    if !(y.x.is_finite() && y.y.is_finite()) {
        return Err(LlsError::Degenerate("non-finite solution"));
    }
    Ok(y)
}

/// One bistatic link for [`lls_bistatic`]: transmitter index, receiver position,
/// measured range sum `||x - t|| + ||x - r||`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BistaticLink {
    /// Index into the transmitter slice.
    pub tx: usize,
    /// Receiver position `r`.
    pub rx: Vec2,
    /// Measured `||x - t|| + ||x - r||`.
    pub sum: f64,
}

/// Closed-form linear least squares for bistatic ranges (the same
/// squaring-and-linearising idea as seed 000 eq. (15)-(17); not in the seeds).
/// With `d_m = ||x - t_m||` as an extra unknown per transmitter, squaring
/// `||x - r|| = rho - d_m` gives the linear equation
/// `2 (t_m - r)^T x + 2 rho d_m = rho^2 + ||t_m||^2 - ||r||^2`
/// (written relative to a reference point); the `2 + M` unknowns `(x, d_1..d_M)`
/// are fitted by least squares (SVD), ignoring `d_m = ||x - t_m||`.
/// Needs at least `3 + M` links with enough receiver spread per transmitter.
pub fn lls_bistatic(transmitters: &[Vec2], links: &[BistaticLink]) -> Result<Vec2, LlsError> {
    let m = transmitters.len();
    let nu = 2 + m;
    if links.len() < nu + 1 {
        return Err(LlsError::TooFew {
            needed: nu + 1,
            got: links.len(),
        });
    }
    let finite = |v: &Vec2| v.x.is_finite() && v.y.is_finite();
    if !transmitters.iter().all(finite) || !links.iter().all(|l| finite(&l.rx) && l.sum.is_finite())
    {
        return Err(LlsError::NonFinite);
    }
    if let Some(l) = links.iter().find(|l| l.tx >= m) {
        return Err(LlsError::BadIndex(l.tx));
    }
    // Reference point and scale for conditioning.
    let o = links.iter().fold(Vec2::zeros(), |s, l| s + l.rx) / links.len() as f64;
    let scale = links
        .iter()
        .map(|l| l.sum)
        .fold(0.0f64, f64::max)
        .max(f64::MIN_POSITIVE);
    let mut a = DMatrix::<f64>::zeros(links.len(), nu);
    let mut b = DVector::<f64>::zeros(links.len());
    for (k, l) in links.iter().enumerate() {
        let t = (transmitters[l.tx] - o) / scale;
        let r = (l.rx - o) / scale;
        let rho = l.sum / scale;
        let g = 2.0 * (t - r);
        a[(k, 0)] = g.x;
        a[(k, 1)] = g.y;
        a[(k, 2 + l.tx)] = 2.0 * rho;
        b[k] = rho * rho + t.norm_squared() - r.norm_squared();
    }
    let svd = a.svd(true, true);
    let smax = svd.singular_values.max();
    let smin = svd.singular_values.min();
    if smin.partial_cmp(&(1e-10 * smax)) != Some(std::cmp::Ordering::Greater) {
        return Err(LlsError::Degenerate(
            "bistatic geometry does not determine (x, d)",
        ));
    }
    let sol = svd
        .solve(&b, 1e-14 * smax)
        .map_err(|_| LlsError::Degenerate("bistatic least squares failed"))?;
    let x = o + Vec2::new(sol[0], sol[1]) * scale;
    if !finite(&x) {
        return Err(LlsError::Degenerate("non-finite solution"));
    }
    Ok(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SonarRng;
    use rand::{RngExt, SeedableRng};

    #[test]
    fn lls_recovers_the_position_from_exact_ranges() {
        let mut rng = SonarRng::seed_from_u64(3);
        for _ in 0..100 {
            let anchors: Vec<Vec2> = (0..5)
                .map(|_| {
                    Vec2::new(
                        rng.random_range(-100.0..100.0),
                        rng.random_range(-100.0..100.0),
                    )
                })
                .collect();
            let x = Vec2::new(rng.random_range(-50.0..50.0), rng.random_range(-50.0..50.0));
            let ranges: Vec<f64> = anchors.iter().map(|a| (x - a).norm()).collect();
            let xh = lls(&anchors, &ranges).unwrap();
            assert!((xh - x).norm() < 1e-8, "{xh:?} vs {x:?}");
        }
    }

    #[test]
    fn lls_matches_the_normal_equations_of_seed_000_eq_15_to_17() {
        // Noisy ranges: compare with a direct dense evaluation of eq. (15)-(17)
        // in absolute coordinates.
        let anchors = [
            Vec2::new(0.5, 0.5),
            Vec2::new(0.0, 0.5),
            Vec2::new(0.5, 0.0),
            Vec2::new(1.0, 1.2),
        ];
        let ranges = [0.31, 0.52, 0.47, 0.9];
        let m = anchors.len();
        let mut a = DMatrix::<f64>::zeros(m - 1, 2);
        let mut b = DVector::<f64>::zeros(m - 1);
        for i in 0..m - 1 {
            let row = anchors[i + 1] - anchors[i];
            a[(i, 0)] = row.x;
            a[(i, 1)] = row.y;
            b[i] = 0.5
                * (anchors[i + 1].norm_squared() - anchors[i].norm_squared()
                    + ranges[i] * ranges[i]
                    - ranges[i + 1] * ranges[i + 1]);
        }
        let direct = (a.transpose() * &a).try_inverse().unwrap() * a.transpose() * b;
        let xh = lls(&anchors, &ranges).unwrap();
        assert!((xh - Vec2::new(direct[0], direct[1])).norm() < 1e-12);
    }

    #[test]
    fn lls_rejects_collinear_anchors_and_bad_input() {
        let anchors = [
            Vec2::new(0.0, 0.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(2.0, 0.0),
        ];
        assert!(matches!(
            lls(&anchors, &[1.0, 1.0, 1.0]),
            Err(LlsError::Degenerate(_))
        ));
        assert!(matches!(
            lls(&anchors[..2], &[1.0, 1.0]),
            Err(LlsError::TooFew { .. })
        ));
        assert!(matches!(
            lls(&anchors, &[1.0, f64::NAN, 1.0]),
            Err(LlsError::NonFinite)
        ));
        assert!(matches!(
            lls(&anchors, &[1.0]),
            Err(LlsError::LengthMismatch(3, 1))
        ));
    }

    #[test]
    fn bistatic_lls_recovers_the_position_from_exact_sums() {
        let mut rng = SonarRng::seed_from_u64(4);
        for _ in 0..100 {
            let txs: Vec<Vec2> = (0..2)
                .map(|_| {
                    Vec2::new(
                        rng.random_range(-100.0..100.0),
                        rng.random_range(-100.0..100.0),
                    )
                })
                .collect();
            let rxs: Vec<Vec2> = (0..4)
                .map(|_| {
                    Vec2::new(
                        rng.random_range(-100.0..100.0),
                        rng.random_range(-100.0..100.0),
                    )
                })
                .collect();
            let x = Vec2::new(rng.random_range(-50.0..50.0), rng.random_range(-50.0..50.0));
            let mut links = Vec::new();
            for (ti, t) in txs.iter().enumerate() {
                for r in &rxs {
                    links.push(BistaticLink {
                        tx: ti,
                        rx: *r,
                        sum: (x - t).norm() + (x - r).norm(),
                    });
                }
            }
            let xh = lls_bistatic(&txs, &links).unwrap();
            assert!((xh - x).norm() < 1e-6, "{xh:?} vs {x:?}");
        }
    }

    #[test]
    fn bistatic_lls_rejects_underdetermined_input() {
        let txs = [Vec2::new(0.0, 0.0)];
        let link = BistaticLink {
            tx: 0,
            rx: Vec2::new(1.0, 0.0),
            sum: 3.0,
        };
        assert!(matches!(
            lls_bistatic(&txs, &[link; 3]),
            Err(LlsError::TooFew { .. })
        ));
        // Four links from the same receiver: rank deficient.
        assert!(matches!(
            lls_bistatic(&txs, &[link; 4]),
            Err(LlsError::Degenerate(_))
        ));
        let bad = BistaticLink { tx: 1, ..link };
        assert!(matches!(
            lls_bistatic(&txs, &[link, link, link, bad]),
            Err(LlsError::BadIndex(1))
        ));
    }

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
