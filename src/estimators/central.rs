//! Centralised references: the per-sample maximum-likelihood estimate and the
//! Cramér-Rao lower bound, computed from all receivers' measurements, in 2-D
//! or 3-D.
//!
//! Measurement model (Mourya 2017 Sec. III-A, Pun-So 2022 eq. 1): bistatic ranges
//! `||x - t_m|| + ||x - r_n||`, DOAs `atan2(y - r_ny, x - r_nx)` (the azimuth
//! in 3-D, with the elevation `atan2(z - r_nz, ||(x - r_n)_xy||)`) and one-way
//! ranges `||x - r_n||`, with independent Gaussian errors of standard
//! deviations `sigma_range`, `sigma_doa` (and `sigma_elevation`). The ML
//! estimate minimises the weighted squared residuals `sum (z - h(x))^2 /
//! sigma^2` (angle residuals wrapped to `(-pi, pi]`) by Levenberg-Marquardt;
//! the CRLB is `sqrt(trace(J^{-1}))` with the Fisher information
//! `J = sum grad h grad h^T / sigma^2` (Kay 1993 eq. 3.31 for independent
//! Gaussian errors).

use crate::model::geometry::Point;
use crate::model::linalg::lu_solve;
use crate::model::measure::{self, Geometry, SampleMeasurements, Sigmas};
use nalgebra::SMatrix;

/// One scalar measurement with its model, for the centralised estimators.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Obs<const D: usize = 2> {
    /// Bistatic range via transmitter `t` to receiver `r`.
    Bistatic {
        /// Transmitter.
        t: Point<D>,
        /// Receiver.
        r: Point<D>,
        /// Measured value.
        z: f64,
    },
    /// DOA (the azimuth in 3-D) at receiver `r`.
    Doa {
        /// Receiver.
        r: Point<D>,
        /// Measured angle.
        z: f64,
    },
    /// The DOA's elevation at receiver `r` (3-D only).
    Elevation {
        /// Receiver.
        r: Point<D>,
        /// Measured angle.
        z: f64,
    },
    /// One-way range to receiver `r`.
    Range {
        /// Receiver.
        r: Point<D>,
        /// Measured value.
        z: f64,
    },
}

const MIN_DIST: f64 = 1e-9;

impl<const D: usize> Obs<D> {
    /// Residual `z - h(x)` (wrapped for angles) and the gradient of `h` at `x`.
    pub fn residual_and_gradient(&self, x: &Point<D>) -> (f64, Point<D>) {
        let unit = |d: Point<D>| {
            let n = d.norm();
            if n > MIN_DIST {
                d / n
            } else {
                Point::<D>::zeros()
            }
        };
        match *self {
            Obs::Bistatic { t, r, z } => (
                z - measure::bistatic_range(x, &t, &r),
                unit(x - t) + unit(x - r),
            ),
            Obs::Range { r, z } => (z - measure::one_way_range(x, &r), unit(x - r)),
            Obs::Doa { r, z } => {
                let d = x - r;
                // The horizontal distance squared (all of it in 2-D).
                let q = (d[0] * d[0] + d[1] * d[1]).max(MIN_DIST);
                let g = Point::<D>::from_fn(|i, _| match i {
                    0 => -d[1] / q,
                    1 => d[0] / q,
                    _ => 0.0,
                });
                (measure::wrap_angle(z - measure::doa(x, &r)), g)
            }
            Obs::Elevation { r, z } => {
                let d = x - r;
                let h = d[0].hypot(d[1]);
                let q = d.norm_squared().max(MIN_DIST);
                let hz = if D > 2 { d[D - 1] } else { 0.0 };
                let g = Point::<D>::from_fn(|i, _| match i {
                    0 | 1 if h > MIN_DIST => -hz * d[i] / (q * h),
                    0 | 1 => 0.0,
                    _ => h / q,
                });
                (measure::wrap_angle(z - measure::elevation(x, &r)), g)
            }
        }
    }

    /// Standard deviation of this observation.
    pub fn sigma(&self, s: &Sigmas) -> f64 {
        match self {
            Obs::Doa { .. } => s.doa,
            Obs::Elevation { .. } => s.elevation,
            _ => s.range,
        }
    }
}

/// Flatten one sample's measurements into observations.
pub fn observations<const D: usize>(
    geometry: &Geometry<D>,
    sample: &SampleMeasurements,
) -> Vec<Obs<D>> {
    let mut out = Vec::new();
    for (n, nm) in sample.nodes.iter().enumerate() {
        let r = geometry.receivers[n];
        for &(m, z) in &nm.bistatic {
            out.push(Obs::Bistatic {
                t: geometry.transmitters[m],
                r,
                z,
            });
        }
        if let Some(z) = nm.doa {
            out.push(Obs::Doa { r, z });
        }
        if let Some(z) = nm.elevation.filter(|_| D == 3) {
            out.push(Obs::Elevation { r, z });
        }
        if let Some(z) = nm.range {
            out.push(Obs::Range { r, z });
        }
    }
    out
}

fn weight(sigma: f64) -> f64 {
    1.0 / sigma.max(1e-12).powi(2)
}

/// The weighted least-squares cost `sum ((z - h(x)) / sigma)^2`.
pub fn ml_cost<const D: usize>(obs: &[Obs<D>], sigmas: &Sigmas, x: &Point<D>) -> f64 {
    obs.iter()
        .map(|o| {
            let (e, _) = o.residual_and_gradient(x);
            e * e * weight(o.sigma(sigmas))
        })
        .sum()
}

/// Levenberg-Marquardt on the weighted ML cost from `x0`. Always returns a
/// finite point (the best iterate found).
pub fn ml_estimate<const D: usize>(obs: &[Obs<D>], sigmas: &Sigmas, x0: Point<D>) -> Point<D> {
    if obs.is_empty() || !x0.iter().all(|v| v.is_finite()) {
        return x0;
    }
    let mut x = x0;
    let mut cost = ml_cost(obs, sigmas, &x);
    let mut lambda = 1e-3;
    for _ in 0..100 {
        let mut jtj = SMatrix::<f64, D, D>::zeros();
        let mut jte = Point::<D>::zeros();
        for o in obs {
            let (e, g) = o.residual_and_gradient(&x);
            let w = weight(o.sigma(sigmas));
            jtj += g * g.transpose() * w;
            jte += g * (e * w);
        }
        let mut improved = false;
        for _ in 0..20 {
            let a = jtj
                + SMatrix::<f64, D, D>::from_diagonal(&jtj.diagonal()) * lambda
                + SMatrix::<f64, D, D>::identity() * 1e-12;
            let Some(step) = lu_solve(&a, &jte) else {
                lambda *= 10.0;
                continue;
            };
            let cand = x + step;
            let c = ml_cost(obs, sigmas, &cand);
            if c.is_finite() && c <= cost {
                let rel = (cost - c) / cost.max(1e-300);
                x = cand;
                cost = c;
                lambda = (lambda / 10.0).max(1e-12);
                improved = rel > 1e-14 && step.norm() > 1e-12 * (1.0 + x.norm());
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    x
}

/// A starting point for the first sample: the best point of a coarse grid
/// (41 points a side in 2-D, 21 in 3-D) over the box spanned by all
/// transmitters and receivers (enlarged by half its size), refined by
/// [`ml_estimate`].
pub fn ml_initial<const D: usize>(
    geometry: &Geometry<D>,
    obs: &[Obs<D>],
    sigmas: &Sigmas,
) -> Point<D> {
    let pts: Vec<&Point<D>> = geometry
        .transmitters
        .iter()
        .chain(&geometry.receivers)
        .collect();
    let (mut lo, mut hi) = (
        Point::<D>::repeat(f64::INFINITY),
        Point::<D>::repeat(f64::NEG_INFINITY),
    );
    for p in &pts {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    let span = (hi - lo).map(|v| v.max(1.0));
    let (lo, hi) = (lo - span * 0.5, hi + span * 0.5);
    let g: usize = if D == 2 { 40 } else { 20 };
    let mut best = (f64::INFINITY, (lo + hi) / 2.0);
    // Grid points in lexicographic order of their indices (x outermost).
    let count = (g + 1).pow(D as u32);
    for flat in 0..count {
        let x = Point::<D>::from_fn(|i, _| {
            let k = flat / (g + 1).pow((D - 1 - i) as u32) % (g + 1);
            lo[i] + (hi[i] - lo[i]) * k as f64 / g as f64
        });
        let c = ml_cost(obs, sigmas, &x);
        if c < best.0 {
            best = (c, x);
        }
    }
    ml_estimate(obs, sigmas, best.1)
}

/// The likelihood's error ellipsoid whose long axis over short axis exceeds
/// this (a Fisher-information condition number above its square) is
/// searched along the long axis for a lower basin ([`ml_refine`]).
pub const ELONGATED_AXES: f64 = 5.0;

/// The starts along the long axis, in standard deviations along it.
const AXIS_STARTS: [f64; 8] = [-6.0, -4.5, -3.0, -1.5, 1.5, 3.0, 4.5, 6.0];

/// The Fisher information `J = sum grad h grad h^T / sigma^2` at `x`.
fn fisher<const D: usize>(obs: &[Obs<D>], sigmas: &Sigmas, x: &Point<D>) -> SMatrix<f64, D, D> {
    let mut j = SMatrix::<f64, D, D>::zeros();
    for o in obs {
        let (_, g) = o.residual_and_gradient(x);
        j += g * g.transpose() * weight(o.sigma(sigmas));
    }
    j
}

/// A local minimum `x` of the ML cost, checked for a lower basin along the
/// direction the measurements determine worst. Where the error ellipsoid
/// at `x` (the Fisher information's, `J^{-1/2}`) is elongated, its long
/// axis ratio above [`ELONGATED_AXES`] (in 3-D, the depth seen by
/// receivers spread far wider than deep), the cost along that axis can have
/// a second basin a few standard deviations away, where a descent from the
/// previous sample's estimate stays. Levenberg-Marquardt is started at
/// `x + m s v` for `m` = ±1.5, ±3, ±4.5, ±6 (`v` the long axis, `s` its
/// standard deviation `1 / sqrt(lambda_min(J))`), and the lowest cost is
/// kept; another start replaces `x` only if it is lower by more than a
/// relative 1e-9 (a start that falls back into `x`'s basin changes nothing).
/// Elsewhere `x` is returned as it is.
pub fn ml_refine<const D: usize>(obs: &[Obs<D>], sigmas: &Sigmas, x: Point<D>) -> Point<D> {
    let Some((vals, vecs)) = crate::model::linalg::sym_eigen(&fisher(obs, sigmas, &x)) else {
        return x;
    };
    let (low, high) = (vals[0], vals[D - 1]);
    if !(low > 0.0 && low.is_finite() && high.is_finite())
        || high <= low * ELONGATED_AXES * ELONGATED_AXES
    {
        return x;
    }
    let axis = vecs.column(0).into_owned() / low.sqrt();
    let mut best = (ml_cost(obs, sigmas, &x), x);
    let bar = best.0 - 1e-9 * (1.0 + best.0);
    for m in AXIS_STARTS {
        let y = ml_estimate(obs, sigmas, x + axis * m);
        let c = ml_cost(obs, sigmas, &y);
        if c < bar && c < best.0 {
            best = (c, y);
        }
    }
    best.1
}

/// The ML track: sample 0 from [`ml_initial`], then each sample started
/// from the previous estimate; each sample's minimum is checked for a lower
/// basin along its worst-determined direction ([`ml_refine`]).
pub fn ml_track<const D: usize>(
    geometry: &Geometry<D>,
    samples: &[SampleMeasurements],
    sigmas: &[Sigmas],
) -> Vec<Point<D>> {
    let mut out: Vec<Point<D>> = Vec::with_capacity(samples.len());
    for (k, s) in samples.iter().enumerate() {
        let geometry = geometry.at(k);
        let obs = observations(&geometry, s);
        let x = match out.last() {
            None => ml_initial(&geometry, &obs, &sigmas[k]),
            Some(prev) => {
                let warm = ml_estimate(&obs, &sigmas[k], *prev);
                // Guard against a local minimum: compare with a cold start.
                if ml_cost(&obs, &sigmas[k], &warm) > 4.0 * obs.len() as f64 + 100.0 {
                    let cold = ml_initial(&geometry, &obs, &sigmas[k]);
                    if ml_cost(&obs, &sigmas[k], &cold) < ml_cost(&obs, &sigmas[k], &warm) {
                        cold
                    } else {
                        warm
                    }
                } else {
                    warm
                }
            }
        };
        out.push(ml_refine(&obs, &sigmas[k], x));
    }
    out
}

/// The CRLB at `x`: `sqrt(trace(J^{-1}))` with the Fisher information
/// `J = sum grad h grad h^T / sigma^2` of the observation set (the
/// measurements' structure, evaluated at the true position; in 3-D the
/// azimuth and the elevation contribute one term each). `None` when `J` is
/// singular.
pub fn crlb<const D: usize>(obs: &[Obs<D>], sigmas: &Sigmas, x: &Point<D>) -> Option<f64> {
    let inv = fisher(obs, sigmas, x).try_inverse()?;
    let tr = inv.trace();
    (tr.is_finite() && tr >= 0.0).then(|| tr.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::geometry::Vec2;
    use approx::assert_relative_eq;

    /// The first four receivers of the Mourya 2017 network.
    fn geom() -> Geometry {
        let mut g = Geometry::mourya2017();
        g.receivers.truncate(4);
        g
    }

    fn exact(g: &Geometry, x: &Vec2) -> SampleMeasurements {
        SampleMeasurements::noise_free(g, x, true, false)
    }

    #[test]
    fn ml_recovers_the_target_from_noise_free_measurements() {
        let g = geom();
        let x = Vec2::new(512.0, 433.0);
        let s = Sigmas {
            elevation: 0.0,
            range: 5.0,
            doa: 0.5,
        };
        let track = ml_track(&g, &[exact(&g, &x)], &[s]);
        assert_relative_eq!(track[0], x, epsilon = 1e-6);
    }

    #[test]
    fn crlb_of_one_way_ranges_matches_the_closed_form() {
        // Two orthogonal one-way ranges: J = diag(1, 1) / sigma^2, CRLB = sigma * sqrt(2).
        let obs = [
            Obs::Range {
                r: Vec2::new(10.0, 0.0),
                z: 0.0,
            },
            Obs::Range {
                r: Vec2::new(0.0, 10.0),
                z: 0.0,
            },
        ];
        let s = Sigmas {
            elevation: 0.0,
            range: 2.0,
            doa: 1.0,
        };
        assert_relative_eq!(
            crlb(&obs, &s, &Vec2::zeros()).unwrap(),
            2.0 * 2f64.sqrt(),
            epsilon = 1e-12
        );
    }

    #[test]
    fn crlb_is_none_for_a_single_range() {
        let obs = [Obs::Range {
            r: Vec2::new(10.0, 0.0),
            z: 0.0,
        }];
        let s = Sigmas {
            elevation: 0.0,
            range: 2.0,
            doa: 1.0,
        };
        assert!(crlb(&obs, &s, &Vec2::zeros()).is_none());
    }

    #[test]
    fn gradients_match_finite_differences() {
        let x = Vec2::new(3.0, -2.0);
        let obs = [
            Obs::Bistatic {
                t: Vec2::new(0.0, 0.0),
                r: Vec2::new(7.0, 1.0),
                z: 3.0,
            },
            Obs::Doa {
                r: Vec2::new(-1.0, 4.0),
                z: 0.3,
            },
            Obs::Range {
                r: Vec2::new(1.0, 1.0),
                z: 2.0,
            },
        ];
        for o in obs {
            let (e0, g) = o.residual_and_gradient(&x);
            let h = 1e-6;
            for k in 0..2 {
                let mut xp = x;
                xp[k] += h;
                let (e1, _) = o.residual_and_gradient(&xp);
                // residual = z - h(x) so d(residual) = -grad h
                assert_relative_eq!(-(e1 - e0) / h, g[k], epsilon = 1e-5);
            }
        }
    }

    fn ocean() -> Geometry<3> {
        let p = |x: f64, y: f64, z: f64| Point::<3>::new(x, y, z);
        Geometry {
            drift: Vec::new(),
            transmitters: vec![p(0.0, 0.0, 10.0), p(2000.0, 2000.0, 5.0)],
            receivers: vec![
                p(-1000.0, -1000.0, 100.0),
                p(1500.0, -1000.0, 300.0),
                p(-1000.0, 1000.0, 50.0),
                p(1500.0, 1000.0, 500.0),
            ],
        }
    }

    #[test]
    fn ml_recovers_a_3d_target_from_noise_free_ranges_azimuths_and_elevations() {
        let g = ocean();
        let x = Point::<3>::new(512.0, 433.0, 250.0);
        let s = Sigmas {
            elevation: 0.02,
            range: 5.0,
            doa: 0.05,
        };
        let meas = SampleMeasurements::noise_free(&g, &x, true, false);
        assert!(meas.nodes.iter().all(|n| n.elevation.is_some()));
        let obs = observations(&g, &meas);
        // Two bistatic ranges, an azimuth and an elevation per receiver.
        assert_eq!(obs.len(), 4 * 4);
        let track = ml_track(&g, &[meas], &[s]);
        assert_relative_eq!(track[0], x, epsilon = 1e-6);
    }

    #[test]
    fn the_3d_crlb_of_three_orthogonal_ranges_is_the_closed_form() {
        // J = I / sigma^2: CRLB = sigma * sqrt(3).
        let obs = [
            Point::<3>::new(10.0, 0.0, 0.0),
            Point::<3>::new(0.0, 10.0, 0.0),
            Point::<3>::new(0.0, 0.0, 10.0),
        ]
        .map(|r| Obs::Range { r, z: 0.0 });
        let s = Sigmas {
            elevation: 1.0,
            range: 2.0,
            doa: 1.0,
        };
        let c = crlb(&obs, &s, &Point::<3>::zeros()).expect("regular");
        assert_relative_eq!(c, 2.0 * 3f64.sqrt(), epsilon = 1e-12);
        // Two ranges leave the third axis unobserved.
        assert!(crlb(&obs[..2], &s, &Point::<3>::zeros()).is_none());
    }

    #[test]
    fn the_3d_crlb_of_one_receivers_range_and_angles_is_the_closed_form() {
        // A range and both angles at distance d: the information is
        // 1/s_r^2 along the ray, 1/(d s_el)^2 in elevation and
        // 1/(d cos(el) s_az)^2 in azimuth, so trace J^-1 is their sum.
        let r = Point::<3>::new(1.0, -2.0, 3.0);
        let x = Point::<3>::new(41.0, 28.0, 23.0);
        let d = (x - r).norm();
        let el = measure::elevation(&x, &r);
        let s = Sigmas {
            elevation: 0.03,
            range: 0.5,
            doa: 0.02,
        };
        let obs = [
            Obs::Range { r, z: 0.0 },
            Obs::Doa { r, z: 0.0 },
            Obs::Elevation { r, z: 0.0 },
        ];
        let want =
            (s.range.powi(2) + (d * s.elevation).powi(2) + (d * el.cos() * s.doa).powi(2)).sqrt();
        assert_relative_eq!(
            crlb(&obs, &s, &x).expect("regular"),
            want,
            max_relative = 1e-12
        );
    }

    #[test]
    fn the_3d_gradients_match_finite_differences() {
        let x = Point::<3>::new(3.0, -2.0, 1.5);
        let p = |a: f64, b: f64, c: f64| Point::<3>::new(a, b, c);
        let obs = [
            Obs::Bistatic {
                t: p(0.0, 0.0, 4.0),
                r: p(7.0, 1.0, -1.0),
                z: 3.0,
            },
            Obs::Doa {
                r: p(-1.0, 4.0, 2.0),
                z: 0.3,
            },
            Obs::Elevation {
                r: p(-1.0, 4.0, 2.0),
                z: 0.1,
            },
            Obs::Range {
                r: p(1.0, 1.0, 1.0),
                z: 2.0,
            },
        ];
        for o in obs {
            let (e0, g) = o.residual_and_gradient(&x);
            let h = 1e-6;
            for k in 0..3 {
                let mut xp = x;
                xp[k] += h;
                let (e1, _) = o.residual_and_gradient(&xp);
                assert_relative_eq!(-(e1 - e0) / h, g[k], epsilon = 1e-5);
            }
        }
    }
}
