//! The local prox a node takes, as chosen by `algorithm.local_solver`: one
//! dispatcher over the relaxed prox and the GTRS prox of Mourya 2017
//! ([`crate::estimators::prox::gtrs`]) and the robust `gtrs_l0` prox of Shi 2024
//! ([`crate::estimators::prox::l0`]). It sits above both, so neither imports the other's
//! caller.

pub mod gtrs;
pub mod l0;
pub mod nappe;

use crate::estimators::local::LocalProblem;
use crate::estimators::prox::gtrs::{ProxError, prox_gtrs, prox_relaxed};
use crate::estimators::prox::l0::prox_gtrs_l0;
use crate::model::geometry::Lifted;

crate::named_enum! {
    /// Which local prox the Douglas-Rachford engine uses
    /// (`algorithm.local_solver`, `--local-solver`).
    pub enum LocalSolver {
        /// Exact prox on the cone surface (Mourya 2017 eq. 13).
        Gtrs = "gtrs",
        /// Unconstrained prox, a 3x3 SPD solve (Mourya 2017 eq. 11 without eq. 12).
        Relaxed = "relaxed",
        /// gtrs with up to algorithm.kappa outlier rows per node separated (Shi 2024 eq. 7).
        GtrsL0 = "gtrs_l0",
    }
}

impl LocalSolver {
    /// The local prox this solver names, with its parameter: `kappa` is the
    /// outlier budget of [`LocalSolver::GtrsL0`] (`algorithm.kappa`) and
    /// is dropped by the other two.
    pub fn with_kappa(self, kappa: usize) -> LocalProx {
        match self {
            LocalSolver::Gtrs => LocalProx::Gtrs,
            LocalSolver::Relaxed => LocalProx::Relaxed,
            LocalSolver::GtrsL0 => LocalProx::GtrsL0 { kappa },
        }
    }
}

/// A local prox with its parameters: what a node runs at each step
/// ([`LocalSolver`] is its name in files, outputs and on the command line).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LocalProx {
    /// [`prox_gtrs`]: exact prox on the cone surface (Mourya 2017 eq. 13).
    Gtrs,
    /// [`prox_relaxed`]: unconstrained prox (Mourya 2017 eq. 11 without
    /// eq. 12).
    Relaxed,
    /// [`prox_gtrs_l0`]: eq. 13 with `l0` outlier separation of up to
    /// `kappa` rows (Shi 2024 eq. 7, 19-20).
    GtrsL0 {
        /// Rows that may be separated as outliers (capped at run time by
        /// [`crate::estimators::prox::l0::effective_kappa`]).
        kappa: usize,
    },
}

impl LocalProx {
    /// Its name.
    pub fn solver(self) -> LocalSolver {
        match self {
            LocalProx::Gtrs => LocalSolver::Gtrs,
            LocalProx::Relaxed => LocalSolver::Relaxed,
            LocalProx::GtrsL0 { .. } => LocalSolver::GtrsL0,
        }
    }
}

/// The local prox step `prox_{gamma f_v}(u)` of `solver` on `p`, in 2-D or 3-D.
pub fn prox<const D: usize, const L: usize>(
    solver: LocalProx,
    p: &LocalProblem<D, L>,
    u: &Lifted<L>,
    gamma: f64,
) -> Result<Lifted<L>, ProxError> {
    match solver {
        LocalProx::Gtrs => prox_gtrs(p, u, gamma),
        LocalProx::Relaxed => prox_relaxed(p, u, gamma),
        LocalProx::GtrsL0 { kappa } => prox_gtrs_l0(p, u, gamma, kappa),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimators::local::RowKind;
    use crate::estimators::prox::gtrs::tests::paper_problem;
    use crate::model::geometry::{Vec2, Vec3};

    #[test]
    fn only_gtrs_l0_carries_kappa_and_every_prox_knows_its_name() {
        assert_eq!(LocalSolver::Gtrs.with_kappa(3), LocalProx::Gtrs);
        assert_eq!(LocalSolver::Relaxed.with_kappa(3), LocalProx::Relaxed);
        assert_eq!(
            LocalSolver::GtrsL0.with_kappa(3),
            LocalProx::GtrsL0 { kappa: 3 }
        );
        for s in [LocalSolver::Gtrs, LocalSolver::Relaxed, LocalSolver::GtrsL0] {
            assert_eq!(s.with_kappa(2).solver(), s);
        }
        // With no row to separate, the l0 prox is the plain GTRS prox.
        let p = paper_problem(0);
        let u = Vec3::new(1.0, 2.0, 3.0);
        let plain = prox(LocalProx::Gtrs, &p, &u, 1.0).unwrap();
        let none = prox(LocalProx::GtrsL0 { kappa: 0 }, &p, &u, 1.0).unwrap();
        approx::assert_relative_eq!(plain, none, max_relative = 1e-9);
    }

    #[test]
    fn bad_gamma_is_an_error_for_every_solver() {
        let p = paper_problem(0);
        let u = Vec3::new(1.0, 2.0, 3.0);
        for g in [0.0, -1e-8, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            for s in [LocalSolver::Gtrs, LocalSolver::Relaxed, LocalSolver::GtrsL0] {
                assert!(
                    matches!(
                        prox(s.with_kappa(1), &p, &u, g),
                        Err(ProxError::BadGamma(_))
                    ),
                    "{s:?} gamma {g}"
                );
            }
        }
    }

    #[test]
    fn non_finite_inputs_are_errors_never_nan() {
        let good = paper_problem(1);
        let u = Vec3::new(1.0, 2.0, 3.0);
        let mut cases: Vec<(LocalProblem, Vec3)> = Vec::new();
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            cases.push((good.clone(), Vec3::new(1.0, bad, 3.0)));
            let mut rows = good.rows.clone();
            rows[0][2] = bad;
            cases.push((
                LocalProblem::from_rows(good.anchor, rows, good.g.clone(), good.kinds.clone()),
                u,
            ));
            let mut g = good.g.clone();
            g[2] = bad;
            cases.push((
                LocalProblem::from_rows(good.anchor, good.rows.clone(), g, good.kinds.clone()),
                u,
            ));
            // A zero row with a non-finite g still poisons c (0 * inf = NaN).
            cases.push((
                LocalProblem::from_rows(
                    good.anchor,
                    vec![[0.0, 0.0, 0.0]],
                    vec![bad],
                    vec![RowKind::Range],
                ),
                u,
            ));
            cases.push((LocalProblem::empty(Vec2::new(bad, 0.0)), u));
        }
        for (k, (p, u)) in cases.iter().enumerate() {
            for s in [LocalSolver::Gtrs, LocalSolver::Relaxed, LocalSolver::GtrsL0] {
                assert!(
                    matches!(
                        prox(s.with_kappa(1), p, u, 2e-8),
                        Err(ProxError::NonFinite(_))
                    ),
                    "case {k} {s:?}"
                );
            }
        }
    }

    #[test]
    fn overflowing_data_is_an_error_not_nan() {
        let p = LocalProblem::from_rows(
            Vec2::zeros(),
            vec![[1e200, 1e200, 1e200]],
            vec![1e200],
            vec![RowKind::Range],
        );
        for s in [LocalSolver::Gtrs, LocalSolver::Relaxed, LocalSolver::GtrsL0] {
            assert!(
                prox(s.with_kappa(1), &p, &Vec3::new(1.0, 2.0, 3.0), 1.0).is_err(),
                "{s:?}"
            );
        }
    }

    #[test]
    fn huge_gamma_gives_a_finite_answer_or_an_error_never_nan() {
        // Rank-1 H: A = H + I/gamma is barely positive definite for huge gamma.
        let p = LocalProblem::from_rows(
            Vec2::new(1.0, 2.0),
            vec![[2.0, -1.0, 0.5]],
            vec![3.0],
            vec![RowKind::Range],
        );
        for gamma in [1e10, 1e100, 1e300, f64::MAX] {
            for s in [LocalSolver::Gtrs, LocalSolver::Relaxed, LocalSolver::GtrsL0] {
                if let Ok(th) = prox(s.with_kappa(1), &p, &Vec3::new(1.0, 2.0, 3.0), gamma) {
                    assert!(th.iter().all(|x| x.is_finite()), "{s:?} {gamma}: {th:?}");
                }
            }
        }
        // Tiny gamma: the prox is (almost) the projection of u, found exactly.
        let th = prox_gtrs(&p, &Vec3::new(4.0, 6.0, 5.0), 1e-300).unwrap();
        approx::assert_relative_eq!(th, Vec3::new(4.0, 6.0, 5.0), max_relative = 1e-12);
    }
}

#[cfg(test)]
mod three_d_tests;
