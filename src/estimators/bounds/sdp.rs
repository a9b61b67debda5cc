//! The SDP positioning estimate Gholami 2015 compares its bounds on (Sec. 4
//! and Figs. 9, 12, 13; the paper refers to Biswas, Lian, Wang and Ye 2006
//! for it), for one target and one-way ranges, in any dimension.
//!
//! With anchors `a_i` and ranges `d_i`, `||x - a_i||^2 = d_i^2` reads
//! `y - 2 a_i^T x + ||a_i||^2 = d_i^2` in the lifted variables `(x, y)`,
//! `y = ||x||^2`. Biswas et al. relax `y = ||x||^2` to the semidefinite
//! constraint `[[I, x], [x^T, y]] >= 0` and minimise the sum of absolute
//! residuals:
//!
//! `min sum_i |y - 2 a_i^T x + ||a_i||^2 - d_i^2|  s.t.  [[I, x], [x^T, y]] >= 0`.
//!
//! For one unknown position the matrix constraint is, by its Schur
//! complement, `y >= ||x||^2`: the rotated second-order cone
//! `||(y - 1, 2 x)|| <= y + 1`. The SDP is therefore solved exactly as a
//! second-order cone program (clarabel), in a frame centred on the anchors'
//! centroid and scaled by their spread; the relaxation commutes with that
//! change of frame (a translation maps the set `y >= ||x||^2` onto itself
//! and each residual onto itself, a scaling multiplies every residual by
//! the same factor), so the estimate is the one of the original data.

use super::BoundError;
use super::solve::{Conic, Solved, build, run};
use clarabel::algebra::CscMatrix;
use clarabel::solver::SupportedConeT::{NonnegativeConeT, SecondOrderConeT};

/// The SDP estimate and its relaxation's values, in the caller's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SdpEstimate<const N: usize> {
    /// The position estimate `x`.
    pub x: [f64; N],
    /// The lifted `y` (`>= ||x||^2`; equal where the relaxation is tight).
    pub y: f64,
    /// The optimal value: the sum of absolute residuals, in squared metres.
    pub value: f64,
}

/// [`SdpEstimate`] of the `(anchor, range)` pairs (Biswas et al. 2006, as
/// Gholami 2015 uses it). Needs at least `N + 1` pairs.
///
/// Errors: [`BoundError::NoRegions`] for fewer than `N + 1` pairs,
/// [`BoundError::NonFinite`] for a non-finite anchor or range,
/// [`BoundError::Solver`] if the conic solver fails.
pub fn sdp_toa<const N: usize>(anchors: &[([f64; N], f64)]) -> Result<SdpEstimate<N>, BoundError> {
    let m = anchors.len();
    if m < N + 1 {
        return Err(BoundError::NoRegions);
    }
    if anchors
        .iter()
        .any(|(a, d)| !(d.is_finite() && a.iter().all(|v| v.is_finite())))
    {
        return Err(BoundError::NonFinite);
    }
    // The frame: centroid and spread of the anchors (ranges for a single
    // anchor position).
    let mut centre = [0.0; N];
    for (a, _) in anchors {
        for k in 0..N {
            centre[k] += a[k] / m as f64;
        }
    }
    let spread = anchors
        .iter()
        .map(|(a, d)| dist(a, &centre).max(d.abs()))
        .fold(0.0, f64::max);
    let s = if spread > 0.0 { spread } else { 1.0 };
    let local: Vec<([f64; N], f64)> = anchors
        .iter()
        .map(|(a, d)| (std::array::from_fn(|k| (a[k] - centre[k]) / s), d / s))
        .collect();

    // Variables v = [x (N), y, t (m)]; minimise sum t.
    let (iy, it) = (N, N + 1);
    let mut c = Conic::new(N + 1 + m);
    for (i, (a, d)) in local.iter().enumerate() {
        // r_i = y - 2 a^T x + ||a||^2 - d^2; t_i - r_i >= 0 and t_i + r_i >= 0,
        // each as s = b - A v >= 0.
        let ci = a.iter().map(|v| v * v).sum::<f64>() - d * d;
        let mut minus: Vec<(usize, f64)> = vec![(it + i, -1.0), (iy, 1.0)];
        let mut plus: Vec<(usize, f64)> = vec![(it + i, -1.0), (iy, -1.0)];
        for (k, ak) in a.iter().enumerate() {
            minus.push((k, -2.0 * ak));
            plus.push((k, 2.0 * ak));
        }
        c.row(&minus, -ci);
        c.row(&plus, ci);
    }
    c.cones.push(NonnegativeConeT(2 * m));
    // (y + 1, y - 1, 2 x) in the second-order cone: y >= ||x||^2.
    c.row(&[(iy, -1.0)], 1.0);
    c.row(&[(iy, -1.0)], -1.0);
    for k in 0..N {
        c.row(&[(k, -2.0)], 0.0);
    }
    c.cones.push(SecondOrderConeT(N + 2));
    let mut q = vec![0.0; c.ncols];
    q[it..].iter_mut().for_each(|v| *v = 1.0);
    let p = CscMatrix::zeros((c.ncols, c.ncols));
    let mut solver = build(&p, &q, &c, "SDP estimate")?;
    match run(&mut solver, "SDP estimate")? {
        Solved::Optimal { primal, x } => {
            let pos: [f64; N] = std::array::from_fn(|k| centre[k] + s * x[k]);
            // y in the caller's frame: ||x||^2 = ||c + s x'||^2 with y' for ||x'||^2.
            let xl = &x[..N];
            let cx: f64 = (0..N).map(|k| centre[k] * xl[k]).sum();
            let cc: f64 = centre.iter().map(|v| v * v).sum();
            let y = s * s * x[iy] + 2.0 * s * cx + cc;
            Ok(SdpEstimate {
                x: pos,
                y,
                value: s * s * primal,
            })
        }
        Solved::Infeasible => Err(BoundError::Solver {
            problem: "SDP estimate",
            status: "reported infeasible (cannot happen: every point is feasible)".into(),
        }),
    }
}

fn dist<const N: usize>(a: &[f64; N], b: &[f64; N]) -> f64 {
    (0..N).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// `sum_i | ||x - a_i||^2 - d_i^2 |`: the unrelaxed objective.
    fn l1<const N: usize>(anchors: &[([f64; N], f64)], x: &[f64; N]) -> f64 {
        anchors
            .iter()
            .map(|(a, d)| (dist(a, x).powi(2) - d * d).abs())
            .sum()
    }

    #[test]
    fn exact_ranges_give_the_true_position_in_2d_and_3d() {
        let truth2 = [3.0, 7.5];
        let a2 = [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0], [0.0, 10.0]];
        let an2: Vec<([f64; 2], f64)> = a2.iter().map(|a| (*a, dist(a, &truth2))).collect();
        let e = sdp_toa(&an2).unwrap();
        approx::assert_abs_diff_eq!(e.x[0], truth2[0], epsilon = 1e-5);
        approx::assert_abs_diff_eq!(e.x[1], truth2[1], epsilon = 1e-5);
        let truth3 = [3.0, 7.5, 2.0];
        let a3 = [
            [0.0, 0.0, 0.0],
            [10.0, 0.0, 0.0],
            [0.0, 10.0, 0.0],
            [0.0, 0.0, 10.0],
            [10.0, 10.0, 10.0],
        ];
        let an3: Vec<([f64; 3], f64)> = a3.iter().map(|a| (*a, dist(a, &truth3))).collect();
        let e = sdp_toa(&an3).unwrap();
        for (x, t) in e.x.iter().zip(truth3) {
            approx::assert_abs_diff_eq!(*x, t, epsilon = 1e-5);
        }
        approx::assert_abs_diff_eq!(e.value, 0.0, epsilon = 1e-5);
    }

    #[test]
    fn too_few_or_non_finite_anchors_are_errors() {
        let a = [([0.0, 0.0], 1.0), ([1.0, 0.0], 1.0)];
        assert_eq!(sdp_toa(&a), Err(BoundError::NoRegions));
        let a = [([0.0, 0.0], 1.0), ([1.0, 0.0], f64::NAN), ([0.0, 1.0], 1.0)];
        assert_eq!(sdp_toa(&a), Err(BoundError::NonFinite));
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 64, .. ProptestConfig::default() })]

        /// The relaxation's value is a lower bound of the unrelaxed
        /// objective (a dense grid of positions, shared nothing with the
        /// solver), its `y` is at least `||x||^2`, and the value at its own
        /// lifted point is the reported one.
        #[test]
        fn the_relaxation_bounds_the_unrelaxed_problem_from_below(
            anchors in prop::collection::vec(prop::array::uniform2(0.0f64..10.0), 3..9),
            truth in prop::array::uniform2(0.0f64..10.0),
            noise in prop::collection::vec(0.0f64..2.0, 9),
            offset in prop::array::uniform2(-1e4f64..1e4),
        ) {
            let an: Vec<([f64; 2], f64)> = anchors
                .iter()
                .zip(&noise)
                .map(|(a, e)| ([a[0] + offset[0], a[1] + offset[1]], dist(a, &truth) + e))
                .collect();
            let est = sdp_toa(&an).unwrap();
            let xx: f64 = est.x.iter().map(|v| v * v).sum();
            let scale = xx.max(1.0);
            prop_assert!(est.y >= xx - 1e-6 * scale, "y {} < ||x||^2 {}", est.y, xx);
            let lifted: f64 = an
                .iter()
                .map(|(a, d)| {
                    let aa: f64 = a.iter().map(|v| v * v).sum();
                    let ax: f64 = (0..2).map(|k| a[k] * est.x[k]).sum();
                    (est.y - 2.0 * ax + aa - d * d).abs()
                })
                .sum();
            prop_assert!((lifted - est.value).abs() <= 1e-5 * (1.0 + est.value + scale * 1e-6), "{lifted} vs {}", est.value);
            let mut grid_min = f64::INFINITY;
            for i in 0..=200 {
                for j in 0..=200 {
                    let x = [offset[0] - 2.0 + 0.07 * i as f64, offset[1] - 2.0 + 0.07 * j as f64];
                    grid_min = grid_min.min(l1(&an, &x));
                }
            }
            prop_assert!(est.value <= grid_min * (1.0 + 1e-6) + 1e-6, "relaxation {} above a grid point's {}", est.value, grid_min);
        }
    }
}
