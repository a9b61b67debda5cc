//! Centralised robust localisation of one sample from its bistatic ranges.
//!
//! Every estimator sees the bistatic ranges `s_{i,j} = ||e - t_i|| + ||e - r_j|| + noise`
//! of one sample (Shi 2024 eq. (1)-(2)) as a list of [`BistaticLink`]s and
//! returns a position [`Estimate`]. DOA and one-way ranges are ignored: the
//! robust formulations of Shi 2024 are written for bistatic ranges only.
//!
//! * [`l0os`]: Shi 2024 Algorithm 1, alternating the MM closed-form location
//!   update (eq. 14) and hard thresholding of the outlier vector (eq. 19-20);
//! * [`lq_irls`]: `sum_l (r_l^2 + eps^2)^{q/2}`, `1 < q < 2` (Shi 2024 eq. (4));
//! * [`lad`]: the same with `q = 1` (least absolute deviations);
//! * [`ls`]: plain nonlinear least squares, Shi 2024 eq. (3).
//!
//! The three smooth estimators share one damped Gauss-Newton (Levenberg)
//! loop whose normal matrix is reweighted at every iteration with the IRLS
//! weights `w_l = (r_l^2 + eps^2)^{q/2 - 1}` (`w_l = 1` for `ls`), plus, for
//! the robust losses, an exact (saddle-free) Newton candidate that follows
//! the narrow valleys of the smoothed objective; a step is only accepted if
//! it lowers the objective, so every trace is strictly decreasing. All estimators are deterministic, allocate O(links) memory,
//! and return a typed error instead of a non-finite position.

mod config;
mod l0os;
mod problem;
mod smooth;
pub use config::{Init, IrlsConfig, L0osConfig, LsConfig, kappa_from_fraction};
use l0os::check_tol;
pub use l0os::l0os;
pub(crate) use problem::hard_threshold;
#[cfg(test)]
use smooth::Loss;
pub use smooth::{lad, lq_irls, ls};

use serde::{Deserialize, Serialize};

use crate::model::geometry::{Point, Vec2};
use crate::model::measure::{Geometry, SampleMeasurements};

/// One bistatic range `s_{i,j}` through transmitter `tx` and receiver `rx`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BistaticLink {
    /// Transmitter index `i` into [`Geometry::transmitters`].
    pub tx: usize,
    /// Receiver index `j` into [`Geometry::receivers`].
    pub rx: usize,
    /// Measured bistatic range (metres).
    pub rho: f64,
}

/// Collect the bistatic ranges of every receiver of one sample (DOA and
/// one-way ranges are dropped), in receiver-major order.
pub fn links_from_sample(sample: &SampleMeasurements) -> Vec<BistaticLink> {
    sample
        .nodes
        .iter()
        .enumerate()
        .flat_map(|(rx, node)| {
            node.bistatic
                .iter()
                .map(move |&(tx, rho)| BistaticLink { tx, rx, rho })
        })
        .collect()
}

/// Errors of the robust estimators.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RobustError {
    /// No bistatic range was given.
    #[error("no bistatic ranges to localise from")]
    NoLinks,
    /// A link names a transmitter that does not exist.
    #[error("link {index}: transmitter {tx} does not exist ({n_tx} transmitters)")]
    TransmitterOutOfRange {
        /// Position of the link in the input.
        index: usize,
        /// Offending transmitter index.
        tx: usize,
        /// Number of transmitters.
        n_tx: usize,
    },
    /// A link names a receiver that does not exist.
    #[error("link {index}: receiver {rx} does not exist ({n_rx} receivers)")]
    ReceiverOutOfRange {
        /// Position of the link in the input.
        index: usize,
        /// Offending receiver index.
        rx: usize,
        /// Number of receivers.
        n_rx: usize,
    },
    /// A bistatic range is NaN or infinite.
    #[error("link {index}: bistatic range must be finite, got {rho}")]
    NonFiniteRange {
        /// Position of the link in the input.
        index: usize,
        /// The value.
        rho: f64,
    },
    /// A sensor used by some link has a non-finite coordinate.
    #[error("{kind} {index} has a non-finite position")]
    NonFiniteSensor {
        /// `"transmitter"` or `"receiver"`.
        kind: &'static str,
        /// Its index.
        index: usize,
    },
    /// The given initial point is not finite.
    #[error("init: initial point must be finite, got [{0}, {1}]")]
    NonFiniteInit(f64, f64),
    /// A configuration value is out of range.
    #[error("{key}: {reason}")]
    InvalidConfig {
        /// The configuration key.
        key: &'static str,
        /// Why it was rejected.
        reason: String,
    },
    /// `kappa` leaves no inlier.
    #[error("kappa: {kappa} outliers must be fewer than the {n_links} links")]
    KappaTooLarge {
        /// Requested number of outliers.
        kappa: usize,
        /// Number of links.
        n_links: usize,
    },
    /// The iteration produced a non-finite value (overflow on absurd input).
    #[error("{estimator}: iterate became non-finite at iteration {iter}")]
    NonFinite {
        /// Which estimator.
        estimator: &'static str,
        /// Iteration index.
        iter: usize,
    },
}

/// A position estimate and its diagnostics.
#[derive(Debug, Clone, PartialEq)]
pub struct Estimate<const D: usize = 2> {
    /// The estimated target position `e`.
    pub position: Point<D>,
    /// Iterations performed.
    pub iterations: usize,
    /// True if the stopping rule fired before the iteration cap.
    pub converged: bool,
    /// Final objective: `f(e, o)` of Shi 2024 eq. (6a) for `l0os`,
    /// `sum (r^2 + eps^2)^{q/2}` for `lq_irls`/`lad`, `sum r^2` for `ls`.
    pub objective: f64,
    /// The objective at `e^0` and after every iteration.
    pub trace: Vec<f64>,
    /// `l0os` only: indices (into the input links, ascending) of the `kappa`
    /// nonzero entries of the outlier vector `o`.
    pub outliers: Vec<usize>,
}

/// The sensor layout of Shi 2024 Sec. IV-A (`m = n = 8`); the target there is
/// `[400, 200]`.
pub fn shi2024_geometry() -> Geometry {
    let v = |x: f64, y: f64| Vec2::new(x, y);
    Geometry {
        drift: Vec::new(),
        transmitters: vec![
            v(-350.0, -200.0),
            v(-350.0, 200.0),
            v(-200.0, -350.0),
            v(-200.0, 350.0),
            v(200.0, -350.0),
            v(200.0, 350.0),
            v(350.0, 200.0),
            v(350.0, -200.0),
        ],
        receivers: vec![
            v(-500.0, 500.0),
            v(500.0, -500.0),
            v(550.0, 0.0),
            v(0.0, 550.0),
            v(500.0, 500.0),
            v(0.0, -600.0),
            v(-600.0, 0.0),
            v(0.0, 0.0),
        ],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::measure::{NodeMeasurements, bistatic_range};
    use crate::model::noise::{NlosLinks, NoiseModel, SigmaSchedule};
    use crate::model::rng::{SonarRng, Stream, stream_rng};
    use proptest::prelude::*;
    use rand::RngExt;

    fn all_links(
        g: &Geometry,
        e: &Vec2,
        mut noise: impl FnMut(usize, usize) -> f64,
    ) -> Vec<BistaticLink> {
        let mut v = Vec::new();
        for (tx, t) in g.transmitters.iter().enumerate() {
            for (rx, r) in g.receivers.iter().enumerate() {
                let rho = bistatic_range(e, t, r) + noise(tx, rx);
                v.push(BistaticLink { tx, rx, rho });
            }
        }
        v
    }

    fn residuals(g: &Geometry, links: &[BistaticLink], e: &Vec2) -> Vec<f64> {
        links
            .iter()
            .map(|l| l.rho - bistatic_range(e, &g.transmitters[l.tx], &g.receivers[l.rx]))
            .collect()
    }

    fn ls_objective(g: &Geometry, links: &[BistaticLink], e: &Vec2) -> f64 {
        residuals(g, links, e).iter().map(|r| r * r).sum()
    }

    fn lq_objective(g: &Geometry, links: &[BistaticLink], e: &Vec2, q: f64, eps: f64) -> f64 {
        residuals(g, links, e)
            .iter()
            .map(|r| (r * r + eps * eps).powf(q / 2.0))
            .sum()
    }

    fn gauss(rng: &mut SonarRng) -> f64 {
        rand_distr::Distribution::<f64>::sample(&rand_distr::StandardNormal, rng)
    }

    fn random_geometry(rng: &mut SonarRng, m: usize, n: usize) -> Geometry {
        let mut p = || {
            Vec2::new(
                rng.random_range(-500.0..500.0),
                rng.random_range(-500.0..500.0),
            )
        };
        Geometry {
            drift: Vec::new(),
            transmitters: (0..m).map(|_| p()).collect(),
            receivers: (0..n).map(|_| p()).collect(),
        }
    }

    /// Dense grid search for the minimum of `f`: 4 m grid over [-800, 800]^2,
    /// then a 0.02 m grid over +-6 m around the coarse minimiser, re-centred
    /// while the minimum lies on the window's edge.
    fn grid_min(f: impl Fn(&Vec2) -> f64) -> (Vec2, f64, Vec2) {
        let mut best = (Vec2::zeros(), f64::INFINITY);
        let scan = |best: &mut (Vec2, f64), c: Vec2, half: f64, h: f64| {
            let k = (half / h).round() as i64;
            for i in -k..=k {
                for j in -k..=k {
                    let p = c + Vec2::new(i as f64 * h, j as f64 * h);
                    let v = f(&p);
                    if v < best.1 {
                        *best = (p, v);
                    }
                }
            }
        };
        scan(&mut best, Vec2::zeros(), 800.0, 4.0);
        let c = best.0;
        // Refine at 2 cm around the coarse minimum, and follow the minimum while
        // it sits on the edge of the window (a narrow valley can lead out of the
        // first window).
        let mut centre = c;
        for _ in 0..200 {
            scan(&mut best, centre, 6.0, 0.02);
            if (best.0 - centre).amax() < 6.0 - 0.01 {
                break;
            }
            centre = best.0;
        }
        (best.0, best.1, c)
    }

    fn strictly_decreasing(trace: &[f64]) -> bool {
        trace.windows(2).all(|w| w[1] < w[0])
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Shi 2024 Sec. III: f(e^{k+1}, o^{k+1}) <= f(e^k, o^k), also with
        /// negative outliers (the gamma < 0 safeguard) and kappa != #outliers.
        #[test]
        fn l0os_objective_is_monotone_non_increasing_on_random_instances(
            seed in any::<u64>(), m in 2usize..=6, n in 2usize..=6,
            kappa_frac in 0.0f64..0.6, out_frac in 0.0f64..0.5,
        ) {
            let mut rng = stream_rng(seed, Stream::Aux, 0);
            let g = random_geometry(&mut rng, m, n);
            let target = Vec2::new(rng.random_range(-400.0..400.0), rng.random_range(-400.0..400.0));
            let mut links = all_links(&g, &target, |_, _| 5.0 * gauss(&mut rng));
            for l in links.iter_mut() {
                if rng.random::<f64>() < out_frac {
                    l.rho += rng.random_range(-3000.0..5000.0);
                }
            }
            let kappa = ((kappa_frac * (m * n) as f64) as usize).min(m * n - 1);
            let cfg = L0osConfig { kappa, max_iter: 300, tol: 0.0, init: Init::Linear };
            let est = l0os(&g, &links, &cfg).unwrap();
            prop_assert_eq!(est.trace.len(), 301);
            let slack = 1e-12 * est.trace[0];
            for (k, w) in est.trace.windows(2).enumerate() {
                prop_assert!(w[1] <= w[0] + slack, "iteration {}: {} > {}", k, w[1], w[0]);
            }
            prop_assert!(est.position.x.is_finite() && est.position.y.is_finite());
            prop_assert_eq!(est.outliers.len(), kappa);
            // The reported objective is f(e, o) of eq. (6a) at the returned point.
            let mut r2: Vec<f64> = residuals(&g, &links, &est.position).iter().map(|r| r * r).collect();
            r2.sort_by(f64::total_cmp);
            let trimmed: f64 = r2[..m * n - kappa].iter().sum();
            prop_assert!((trimmed - est.objective).abs() <= 1e-9 * (1.0 + trimmed));
        }

    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// ls lands on the dense-grid global minimum of eq. (3) and is a local min.
        #[test]
        fn ls_matches_dense_grid_search_minimum_on_small_instances(
            seed in any::<u64>(), m in 3usize..=4, n in 3usize..=4,
        ) {
            let mut rng = stream_rng(seed, Stream::Aux, 1);
            let g = random_geometry(&mut rng, m, n);
            let target = Vec2::new(rng.random_range(-300.0..300.0), rng.random_range(-300.0..300.0));
            let links = all_links(&g, &target, |_, _| 2.0 * gauss(&mut rng));
            let est = ls(&g, &links, &LsConfig::default()).unwrap();
            prop_assert!(est.converged);
            prop_assert!(strictly_decreasing(&est.trace));
            let (gp, gv, _) = grid_min(|p| ls_objective(&g, &links, p));
            let f = ls_objective(&g, &links, &est.position);
            prop_assert!(f <= gv + 1e-9 * (1.0 + gv), "ls {} > grid {}", f, gv);
            prop_assert!((est.position - gp).norm() < 0.05, "ls {:?} grid {:?}", est.position, gp);
            // Local min: no better point on a small ring.
            for k in 0..16 {
                let a = k as f64 * std::f64::consts::PI / 8.0;
                let p = est.position + 1e-3 * Vec2::new(a.cos(), a.sin());
                prop_assert!(ls_objective(&g, &links, &p) >= f - 1e-9 * (1.0 + f));
            }
        }

    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// lq_irls (q = 1.5, 1.3) and lad: strictly decreasing traces and a
        /// local minimum from the default (non-robust) start; for q = 1.5,
        /// started from the coarse-grid minimiser, the dense-grid global minimum.
        #[test]
        fn irls_objectives_decrease_and_match_dense_grid_search(
            seed in any::<u64>(), m in 3usize..=4, n in 3usize..=4,
        ) {
            let mut rng = stream_rng(seed, Stream::Aux, 2);
            let g = random_geometry(&mut rng, m, n);
            let target = Vec2::new(rng.random_range(-300.0..300.0), rng.random_range(-300.0..300.0));
            let mut links = all_links(&g, &target, |_, _| 2.0 * gauss(&mut rng));
            links[0].rho += 300.0;
            for q in [1.5, 1.3, 1.0] {
                let cfg = IrlsConfig { q: if q > 1.0 { q } else { 1.5 }, ..IrlsConfig::default() };
                let solve = |cfg: &IrlsConfig| if q > 1.0 { lq_irls(&g, &links, cfg) } else { lad(&g, &links, cfg) };
                let f_of = |p: &Vec2| lq_objective(&g, &links, p, q, cfg.epsilon);
                let est = solve(&cfg).unwrap();
                prop_assert!(est.converged, "q {}: {} iterations", q, est.iterations);
                prop_assert!(strictly_decreasing(&est.trace));
                let f = f_of(&est.position);
                prop_assert!((f - est.objective).abs() <= 1e-9 * f);
                for k in 0..16 {
                    let a = k as f64 * std::f64::consts::PI / 8.0;
                    let p = est.position + 1e-3 * Vec2::new(a.cos(), a.sin());
                    // 1e-8: IRLS stops within ~1e-9 relative of the minimum
                    // value in the flat valleys of q near 1 (mm in position).
                    prop_assert!(f_of(&p) >= f - 1e-8 * f, "q {}: not a local min", q);
                }
                if q < 1.5 {
                    // Closer to l1 the objective has kinked local minima a
                    // coarse grid point may sit next to: local checks only.
                    continue;
                }
                let (gp, gv, coarse) = grid_min(f_of);
                let from_grid = solve(&IrlsConfig { init: Init::Point([coarse.x, coarse.y]), ..cfg }).unwrap();
                let fg = f_of(&from_grid.position);
                prop_assert!(fg <= gv + 1e-9 * gv, "q {}: {} > grid {} at {:?}", q, fg, gv, gp);
            }
        }
    }

    #[test]
    fn l0os_with_exactly_kappa_gross_outliers_matches_the_oracle_that_knows_them() {
        let g = shi2024_geometry();
        let target = Vec2::new(400.0, 200.0);
        let mut rng = stream_rng(4, Stream::Aux, 3);
        for trial in 0..32 {
            let bad_tx = trial % 8;
            let mut links = all_links(&g, &target, |_, _| gauss(&mut rng));
            let mut truth = Vec::new();
            for (i, l) in links.iter_mut().enumerate() {
                if l.tx == bad_tx {
                    l.rho += rng.random_range(200.0..5000.0);
                    truth.push(i);
                }
            }
            let clean: Vec<BistaticLink> =
                links.iter().filter(|l| l.tx != bad_tx).copied().collect();
            let oracle = ls(&g, &clean, &LsConfig::default()).unwrap().position;
            let cfg = L0osConfig {
                tol: 1e-10,
                ..L0osConfig::new(8)
            };
            let est = l0os(&g, &links, &cfg).unwrap();
            assert_eq!(est.outliers, truth, "trial {trial}");
            assert!(
                (est.position - oracle).norm() < 1e-3,
                "trial {trial}: {:?} vs oracle {oracle:?}",
                est.position
            );
            // With the paper's stopping rule it is still within the noise:
            // sigma = 1 m on 56 clean links puts the oracle ~0.3 m from the truth.
            let est = l0os(&g, &links, &L0osConfig::new(8)).unwrap();
            assert!(
                (est.position - oracle).norm() < 0.5,
                "trial {trial}: {:?}",
                est.position
            );
            assert!(
                (est.position - target).norm() < 2.0,
                "trial {trial}: {:?}",
                est.position
            );
        }
    }

    #[test]
    fn the_q_1_5_fast_path_equals_the_generic_power_loss() {
        for r in [-1e4, -3.0, -1e-3, 0.0, 2e-4, 0.7, 55.0, 1e6] {
            let (a, wa) = Loss::Power15 { eps2: 1e-6 }.eval(r);
            let (b, wb) = Loss::Power { q: 1.5, eps2: 1e-6 }.eval(r);
            approx::assert_relative_eq!(a, b, max_relative = 1e-14);
            approx::assert_relative_eq!(wa, wb, max_relative = 1e-14);
        }
    }

    #[test]
    fn hard_threshold_keeps_the_kappa_largest_magnitudes_with_index_tie_break() {
        let beta = [1.0, -5.0, 3.0, 5.0, -3.0, 0.5];
        let mut order = Vec::new();
        let keep = |s: &[usize]| (0..beta.len()).map(|i| s.contains(&i)).collect::<Vec<_>>();
        let s = hard_threshold(&beta, 3, &mut order).to_vec();
        assert_eq!(keep(&s), [false, true, true, true, false, false]);
        assert!(hard_threshold(&beta, 0, &mut order).is_empty());
        let s = hard_threshold(&beta, 6, &mut order).to_vec();
        assert!(keep(&s).iter().all(|&k| k));
    }

    #[test]
    fn hard_thresholding_keeps_the_kappa_largest_magnitudes_with_ties_to_the_lower_row() {
        let beta = [0.5, -3.0, 2.0, 3.0, f64::NAN, -0.1];
        let mut order = Vec::new();
        // NaN counts as the largest: it is deleted first.
        assert_eq!(hard_threshold(&beta, 1, &mut order), [4]);
        assert_eq!(hard_threshold(&beta, 2, &mut order), [1, 4]);
        assert_eq!(hard_threshold(&beta, 3, &mut order), [1, 3, 4]);
        assert_eq!(hard_threshold(&beta[..4], 2, &mut order), [1, 3]);
        assert_eq!(hard_threshold(&beta, 0, &mut order), [0usize; 0]);
    }

    #[test]
    fn invalid_inputs_are_typed_errors() {
        let g = shi2024_geometry();
        let e = Vec2::new(400.0, 200.0);
        let links = all_links(&g, &e, |_, _| 0.0);
        let lc = LsConfig::default();
        let ic = IrlsConfig::default();
        assert_eq!(ls(&g, &[], &lc), Err(RobustError::NoLinks));
        let mut bad = links.clone();
        bad[3].tx = 8;
        assert!(matches!(
            ls(&g, &bad, &lc),
            Err(RobustError::TransmitterOutOfRange {
                index: 3,
                tx: 8,
                n_tx: 8
            })
        ));
        let mut bad = links.clone();
        bad[5].rx = 9;
        assert!(matches!(
            lad(&g, &bad, &ic),
            Err(RobustError::ReceiverOutOfRange { index: 5, .. })
        ));
        let mut bad = links.clone();
        bad[1].rho = f64::NAN;
        assert!(matches!(
            l0os(&g, &bad, &L0osConfig::new(2)),
            Err(RobustError::NonFiniteRange { index: 1, .. })
        ));
        let mut gb = g.clone();
        gb.receivers[0].x = f64::INFINITY;
        assert!(matches!(
            ls(&gb, &links, &lc),
            Err(RobustError::NonFiniteSensor {
                kind: "receiver",
                index: 0
            })
        ));
        assert!(matches!(
            l0os(&g, &links, &L0osConfig::new(64)),
            Err(RobustError::KappaTooLarge {
                kappa: 64,
                n_links: 64
            })
        ));
        for q in [1.0, 2.0, f64::NAN, 0.5] {
            let cfg = IrlsConfig {
                q,
                ..IrlsConfig::default()
            };
            assert!(
                matches!(
                    lq_irls(&g, &links, &cfg),
                    Err(RobustError::InvalidConfig { key: "q", .. })
                ),
                "q = {q}"
            );
        }
        for eps in [0.0, -1.0, f64::NAN] {
            let cfg = IrlsConfig {
                epsilon: eps,
                ..IrlsConfig::default()
            };
            assert!(matches!(
                lad(&g, &links, &cfg),
                Err(RobustError::InvalidConfig { key: "epsilon", .. })
            ));
        }
        let cfg = LsConfig {
            init: Init::Point([f64::NAN, 0.0]),
            ..LsConfig::default()
        };
        assert!(matches!(
            ls(&g, &links, &cfg),
            Err(RobustError::NonFiniteInit(..))
        ));
        let cfg = L0osConfig {
            tol: -1.0,
            ..L0osConfig::new(1)
        };
        assert!(matches!(
            l0os(&g, &links, &cfg),
            Err(RobustError::InvalidConfig { key: "tol", .. })
        ));
        assert!(kappa_from_fraction(1.5, 64).is_err());
        assert!(kappa_from_fraction(f64::NAN, 64).is_err());
        assert_eq!(kappa_from_fraction(0.15, 64), Ok(10));
        assert_eq!(kappa_from_fraction(0.10, 64), Ok(6));
    }

    fn all_estimators(
        g: &Geometry,
        links: &[BistaticLink],
        init: Init,
    ) -> Vec<Result<Estimate, RobustError>> {
        let ic = IrlsConfig {
            init,
            ..IrlsConfig::default()
        };
        vec![
            l0os(
                g,
                links,
                &L0osConfig {
                    init,
                    ..L0osConfig::new(1)
                },
            ),
            lq_irls(g, links, &ic),
            lad(g, links, &ic),
            ls(
                g,
                links,
                &LsConfig {
                    init,
                    ..LsConfig::default()
                },
            ),
        ]
    }

    #[test]
    fn degenerate_inputs_give_finite_estimates_or_errors_never_nan() {
        let g = shi2024_geometry();
        // Target exactly on receiver 8 at the origin, started there: zero distances.
        let at_sensor = all_links(&g, &Vec2::zeros(), |_, _| 0.0);
        let coincident = Geometry {
            drift: Vec::new(),
            transmitters: vec![Vec2::new(1.0, 1.0); 3],
            receivers: vec![Vec2::new(1.0, 1.0); 3],
        };
        let co_links = all_links(&coincident, &Vec2::new(50.0, 0.0), |_, _| 0.0);
        let mut huge = all_links(&g, &Vec2::new(400.0, 200.0), |_, _| 0.0);
        huge[0].rho = 1e300;
        let mut negative = all_links(&g, &Vec2::new(400.0, 200.0), |_, _| 0.0);
        for l in negative.iter_mut().take(20) {
            l.rho = -l.rho;
        }
        let cases: Vec<(&Geometry, &[BistaticLink], Init)> = vec![
            (&g, &at_sensor, Init::Point([0.0, 0.0])),
            (&g, &at_sensor, Init::Linear),
            (&coincident, &co_links, Init::Linear),
            (&coincident, &co_links, Init::Point([1.0, 1.0])),
            (&g, &huge, Init::Linear),
            (&g, &negative, Init::Linear),
        ];
        for (i, (g, links, init)) in cases.into_iter().enumerate() {
            let mut ests = all_estimators(g, links, init);
            ests.push(l0os(
                g,
                links,
                &L0osConfig {
                    init,
                    ..L0osConfig::new(0)
                },
            ));
            for est in ests.into_iter().flatten() {
                assert!(
                    est.position.x.is_finite() && est.position.y.is_finite(),
                    "case {i}: {est:?}"
                );
                assert!(est.objective.is_finite(), "case {i}: {est:?}");
            }
        }
        // Zero noise, target on a sensor, started elsewhere: still found.
        for res in all_estimators(&g, &at_sensor, Init::Point([30.0, -20.0])) {
            let est = res.unwrap();
            assert!(est.position.norm() < 0.5, "{est:?}");
        }
    }

    #[test]
    fn estimates_are_bitwise_reproducible() {
        let g = shi2024_geometry();
        let mut rng = stream_rng(9, Stream::Aux, 0);
        let links = all_links(&g, &Vec2::new(400.0, 200.0), |_, n| {
            10.0 * gauss(&mut rng) + if n == 2 { 900.0 } else { 0.0 }
        });
        let a = all_estimators(&g, &links, Init::Linear);
        let b = all_estimators(&g, &links, Init::Linear);
        assert_eq!(a, b);
    }

    #[test]
    fn links_from_sample_takes_bistatic_ranges_in_receiver_order_and_drops_doa() {
        let s = SampleMeasurements {
            nodes: vec![
                NodeMeasurements {
                    elevation: None,
                    bistatic: vec![(1, 10.0), (0, 11.0)],
                    doa: Some(0.3),
                    range: None,
                },
                NodeMeasurements::default(),
                NodeMeasurements {
                    elevation: None,
                    bistatic: vec![(2, 12.0)],
                    doa: None,
                    range: Some(4.0),
                },
            ],
        };
        let l = links_from_sample(&s);
        assert_eq!(l.len(), 3);
        assert_eq!((l[0].tx, l[0].rx), (1, 0));
        assert_eq!((l[1].tx, l[1].rx), (0, 0));
        assert_eq!((l[2].tx, l[2].rx), (2, 2));
        approx::assert_relative_eq!(l[2].rho, 12.0);
    }

    /// RMSEs of (l0os, lq_irls, lad, ls) over `trials` trials of Shi 2024
    /// Sec. IV-C: Gaussian variance 100 m^2 on all 64 links, exponential NLOS
    /// bias with standard deviation `nlos_std` on all links of one random
    /// transmitter or receiver, `p = 15%`.
    fn shi2024_exponential_rmse(nlos_std: f64, trials: usize, seed: u64) -> [f64; 4] {
        let g = shi2024_geometry();
        let target = Vec2::new(400.0, 200.0);
        let noise = NoiseModel::NlosExponential {
            sigma: 10.0,
            nlos_mean: nlos_std,
            schedule: SigmaSchedule::Constant,
        };
        noise.validate().unwrap();
        let kappa = kappa_from_fraction(0.15, 64).unwrap();
        let mut sq = [0.0; 4];
        for trial in 0..trials {
            let mut lr = stream_rng(seed, Stream::Links, trial as u64);
            let mask = NlosLinks::OneRandomTransmitterOrReceiver {}
                .draw(8, 8, &mut lr)
                .unwrap();
            let mut nr = stream_rng(seed, Stream::Measurement, trial as u64);
            let links = all_links(&g, &target, |m, n| {
                noise.sample(0, mask.is_nlos(m, n), &mut nr)
            });
            let ests = [
                l0os(&g, &links, &L0osConfig::new(kappa)).unwrap(),
                lq_irls(&g, &links, &IrlsConfig::default()).unwrap(),
                lad(&g, &links, &IrlsConfig::default()).unwrap(),
                ls(&g, &links, &LsConfig::default()).unwrap(),
            ];
            for (s, e) in sq.iter_mut().zip(&ests) {
                *s += (e.position - target).norm_squared();
            }
        }
        sq.map(|s| (s / trials as f64).sqrt())
    }

    #[test]
    fn l0os_beats_lq_lad_and_ls_under_seed_004_exponential_nlos() {
        for std in [1e2, 1e3, 1e4, 1e5] {
            let [l0, lq, l1, l2] = shi2024_exponential_rmse(std, 200, 2024);
            println!(
                "nlos std {std:>8.0e}: RMSE l0os {l0:8.3}  lq_irls {lq:8.3}  lad {l1:8.3}  ls {l2:10.3}"
            );
            assert!(
                l0 < lq && l0 < l1 && l0 < l2,
                "std {std}: {l0} {lq} {l1} {l2}"
            );
        }
    }
}

#[cfg(test)]
mod three_d_tests;
