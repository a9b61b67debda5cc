//! Centralised references: the per-sample maximum-likelihood estimate and the
//! Cramér-Rao lower bound, computed from all receivers' measurements.
//!
//! Measurement model (Mourya 2017 Sec. III-A, Pun-So 2022 eq. 1): bistatic ranges
//! `||x - t_m|| + ||x - r_n||`, DOAs `atan2(y - r_ny, x - r_nx)` and one-way
//! ranges `||x - r_n||`, with independent Gaussian errors of standard
//! deviations `sigma_range`, `sigma_doa`. The ML estimate minimises the
//! weighted squared residuals `sum (z - h(x))^2 / sigma^2` (DOA residuals
//! wrapped to `(-pi, pi]`) by Levenberg-Marquardt.

use crate::model::geometry::Vec2;
use crate::model::measure::{self, Geometry, SampleMeasurements, Sigmas};
use nalgebra::{Matrix2, Vector2};

/// One scalar measurement with its model, for the centralised estimators.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Obs {
    /// Bistatic range via transmitter `t` to receiver `r`.
    Bistatic {
        /// Transmitter.
        t: Vec2,
        /// Receiver.
        r: Vec2,
        /// Measured value.
        z: f64,
    },
    /// DOA at receiver `r`.
    Doa {
        /// Receiver.
        r: Vec2,
        /// Measured angle.
        z: f64,
    },
    /// One-way range to receiver `r`.
    Range {
        /// Receiver.
        r: Vec2,
        /// Measured value.
        z: f64,
    },
}

const MIN_DIST: f64 = 1e-9;

impl Obs {
    /// Residual `z - h(x)` (wrapped for DOA) and the gradient of `h` at `x`.
    pub fn residual_and_gradient(&self, x: &Vec2) -> (f64, Vec2) {
        let unit = |d: Vec2| {
            let n = d.norm();
            if n > MIN_DIST { d / n } else { Vec2::zeros() }
        };
        match *self {
            Obs::Bistatic { t, r, z } => (
                z - measure::bistatic_range(x, &t, &r),
                unit(x - t) + unit(x - r),
            ),
            Obs::Range { r, z } => (z - measure::one_way_range(x, &r), unit(x - r)),
            Obs::Doa { r, z } => {
                let d = x - r;
                let q = d.norm_squared().max(MIN_DIST);
                (
                    measure::wrap_angle(z - measure::doa(x, &r)),
                    Vec2::new(-d.y / q, d.x / q),
                )
            }
        }
    }

    /// Standard deviation of this observation.
    pub fn sigma(&self, s: &Sigmas) -> f64 {
        match self {
            Obs::Doa { .. } => s.doa,
            _ => s.range,
        }
    }
}

/// Flatten one sample's measurements into observations.
pub fn observations(geometry: &Geometry, sample: &SampleMeasurements) -> Vec<Obs> {
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
pub fn ml_cost(obs: &[Obs], sigmas: &Sigmas, x: &Vec2) -> f64 {
    obs.iter()
        .map(|o| {
            let (e, _) = o.residual_and_gradient(x);
            e * e * weight(o.sigma(sigmas))
        })
        .sum()
}

/// Levenberg-Marquardt on the weighted ML cost from `x0`. Always returns a
/// finite point (the best iterate found).
pub fn ml_estimate(obs: &[Obs], sigmas: &Sigmas, x0: Vec2) -> Vec2 {
    if obs.is_empty() || !x0.iter().all(|v| v.is_finite()) {
        return x0;
    }
    let mut x = x0;
    let mut cost = ml_cost(obs, sigmas, &x);
    let mut lambda = 1e-3;
    for _ in 0..100 {
        let mut jtj = Matrix2::zeros();
        let mut jte = Vector2::zeros();
        for o in obs {
            let (e, g) = o.residual_and_gradient(&x);
            let w = weight(o.sigma(sigmas));
            jtj += g * g.transpose() * w;
            jte += g * (e * w);
        }
        let mut improved = false;
        for _ in 0..20 {
            let a = jtj
                + Matrix2::from_diagonal(&jtj.diagonal()) * lambda
                + Matrix2::identity() * 1e-12;
            let Some(step) = a.lu().solve(&jte) else {
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
/// over the box spanned by all transmitters and receivers (enlarged by half
/// its size), refined by [`ml_estimate`].
pub fn ml_initial(geometry: &Geometry, obs: &[Obs], sigmas: &Sigmas) -> Vec2 {
    let pts: Vec<&Vec2> = geometry
        .transmitters
        .iter()
        .chain(&geometry.receivers)
        .collect();
    let (mut lo, mut hi) = (Vec2::repeat(f64::INFINITY), Vec2::repeat(f64::NEG_INFINITY));
    for p in &pts {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    let span = (hi - lo).map(|v| v.max(1.0));
    let (lo, hi) = (lo - span * 0.5, hi + span * 0.5);
    let g = 40;
    let mut best = (f64::INFINITY, (lo + hi) / 2.0);
    for i in 0..=g {
        for j in 0..=g {
            let x = Vec2::new(
                lo.x + (hi.x - lo.x) * i as f64 / g as f64,
                lo.y + (hi.y - lo.y) * j as f64 / g as f64,
            );
            let c = ml_cost(obs, sigmas, &x);
            if c < best.0 {
                best = (c, x);
            }
        }
    }
    ml_estimate(obs, sigmas, best.1)
}

/// The ML track: sample 0 from [`ml_initial`], then each sample started
/// from the previous estimate.
pub fn ml_track(
    geometry: &Geometry,
    samples: &[SampleMeasurements],
    sigmas: &[Sigmas],
) -> Vec<Vec2> {
    let mut out: Vec<Vec2> = Vec::with_capacity(samples.len());
    for (k, s) in samples.iter().enumerate() {
        let obs = observations(geometry, s);
        let x = match out.last() {
            None => ml_initial(geometry, &obs, &sigmas[k]),
            Some(prev) => {
                let warm = ml_estimate(&obs, &sigmas[k], *prev);
                // Guard against a local minimum: compare with a cold start.
                if ml_cost(&obs, &sigmas[k], &warm) > 4.0 * obs.len() as f64 + 100.0 {
                    let cold = ml_initial(geometry, &obs, &sigmas[k]);
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
        out.push(x);
    }
    out
}

/// The CRLB at `x`: `sqrt(trace(J^{-1}))` with the Fisher information
/// `J = sum grad h grad h^T / sigma^2` of the observation set (the
/// measurements' structure, evaluated at the true position). `None` when
/// `J` is singular.
pub fn crlb(obs: &[Obs], sigmas: &Sigmas, x: &Vec2) -> Option<f64> {
    let mut j = Matrix2::zeros();
    for o in obs {
        let (_, g) = o.residual_and_gradient(x);
        j += g * g.transpose() * weight(o.sigma(sigmas));
    }
    let inv = j.try_inverse()?;
    let tr = inv.trace();
    (tr.is_finite() && tr >= 0.0).then(|| tr.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
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
}
