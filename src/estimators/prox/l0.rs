//! A robust local prox: GTRS with `l0`-norm outlier separation (`local_solver = "gtrs_l0"`).
//!
//! Shi 2024 (Shi et al., "An l0-norm Optimization-based Algorithm for Robust and
//! Efficient MIMO Localization") models outliers as a sparse vector `o` added to the
//! measurements, `||o||_0 <= kappa` (eq. 6), and alternates a location update with
//! hard thresholding of `o` (eq. 7a-7b, 19-20). Here the same idea is applied to one
//! node's prox step of Mourya 2017 eq. (13): with `f_v(theta~) = 1/2 ||B_v theta~ - g_v||^2`
//! (Mourya 2017 eq. 9-10), step `gamma > 0` and input `u`, [`prox_gtrs_l0`] solves
//!
//! `min_{theta~ in K_v, ||o||_0 <= kappa_v}  J(theta~, o) = 1/2 ||B_v theta~ - g_v - o||^2
//!                                                   + 1/(2 gamma) ||theta~ - u||^2`
//!
//! where `K_v` is the upper nappe of the cone (Mourya 2017 eq. 12), the feasible set of
//! [`prox_gtrs`]. `o` lives on the rows of `B_v`: one row per bistatic range, two per
//! DOA, one per one-way range, so a corrupted DOA takes two of the `kappa` slots.
//!
//! # Reduction to row deletion
//!
//! For a fixed support `S` of `o` the optimal `o_i = (B_v theta~ - g_v)_i` on `S`
//! zeroes those rows. So `min_o J(theta~, o)` over `supp(o) = S` is the prox objective
//! of the local problem with the rows `S` deleted, `B_{v,-S}`, and
//!
//! `min J = min_{|S| = kappa} min_{theta~ in K_v} 1/2 ||B_{v,-S} theta~ - g_{v,-S}||^2
//!          + 1/(2 gamma) ||theta~ - u||^2`
//!
//! (supports smaller than `kappa` are dominated: deleting a row never increases the
//! minimum). Each inner problem is an exact GTRS prox ([`prox_gtrs`], global on the
//! cone). Two solvers build on this:
//!
//! * [`prox_gtrs_l0_enumerate`]: every support of size `kappa`, `C(n, kappa)` GTRS
//!   solves; the **exact global** minimiser.
//! * [`prox_gtrs_l0_alternate`]: Shi 2024 eq. (7) from `o = 0`. The location step
//!   (7a) is the GTRS prox with `g` replaced by `g + o`, taken jointly with the
//!   nonzero values of `o` on its current support `S` (= the GTRS prox with the rows
//!   `S` deleted, see above); the outlier step (7b) is the hard thresholding of eq.
//!   (19)-(20): `S` becomes the `kappa` rows of largest `|residual|` at the new point
//!   (ties to the lower row index), `o_S` = the residual there. Both steps minimise `J`
//!   over a block, so the objective trace is non-increasing. The location step
//!   depends only on `S`, so the iteration stops when a support repeats (a fixed point
//!   or a cycle) or after [`MAX_ALTERNATIONS`] location steps, and returns the best
//!   iterate. Alternation can stop at a worse support than the optimum (a row dragged
//!   by the outlier can have the largest residual): on random 3-6 row nodes with one
//!   gross outlier it did so in about 3.5% of cases, mostly with `kappa = 2` (see the
//!   test `alternation_can_stop_at_a_worse_support_so_small_nodes_are_enumerated`), so
//!   it is only a fallback.
//!
//! # What `gtrs_l0` uses
//!
//! `kappa` is first clamped by [`effective_kappa`] to `rows - 1` (at least one row is
//! kept: deleting every row would discard the node's data; a node with 0 or 1 rows
//! therefore runs plain GTRS). If `kappa` is then 0 the answer is [`prox_gtrs`]
//! itself, bit for bit. Otherwise [`prox_gtrs_l0`] enumerates when
//! `C(rows, kappa) <= `[`MAX_ENUMERATED_SUPPORTS`] (= `C(12, 2)` = 66: every node of
//! up to 12 rows with `kappa <= 2`, and `kappa = 1` up to 66 rows), which is exact,
//! and falls back to alternation for larger instances. Cost: about `C(rows, kappa)`
//! GTRS solves; on the paper's 4-row nodes with `kappa = 1`, about 1.0 us against
//! 0.18 us for one [`prox_gtrs`] (`benches/prox.rs`, `gtrs_l0_prox_kappa1`).
//!
//! Inputs are checked row by row (a non-finite row is an error even though deleting
//! it would hide it) and the result is never NaN: every failure is a [`ProxError`].

use crate::estimators::local::LocalProblem;
use crate::estimators::prox::gtrs::{ProxError, prox_gtrs};
use crate::estimators::robust::hard_threshold;
use crate::model::geometry::{LMat, Lifted};

/// Default outlier budget `kappa` per node (`algorithm.kappa`).
pub const DEFAULT_KAPPA: usize = 1;

/// [`prox_gtrs_l0`] enumerates all supports when there are at most this many
/// (`C(12, 2)`), else it alternates.
pub const MAX_ENUMERATED_SUPPORTS: usize = 66;

/// At most this many location steps (GTRS solves) of [`prox_gtrs_l0_alternate`]
/// after the first one (from `o = 0`).
pub const MAX_ALTERNATIONS: usize = 32;

/// How a [`L0Prox`] was computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum L0Method {
    /// `kappa` clamped to 0: plain [`prox_gtrs`].
    Plain,
    /// All `C(n, kappa)` supports (exact).
    Enumerate,
    /// Shi 2024 eq. (7) alternation (a local solution).
    Alternate,
}

/// The result of a robust prox, with diagnostics.
#[derive(Debug, Clone, PartialEq)]
pub struct L0Prox<const L: usize = 3> {
    /// The minimiser `theta~` (on the upper nappe).
    pub theta: Lifted<L>,
    /// The outlier rows `S` (sorted row indices; `o_i = residual_i` there, 0 elsewhere).
    pub support: Vec<usize>,
    /// `J(theta~, o)` at the answer.
    pub objective: f64,
    /// The `kappa` actually used (after [`effective_kappa`]).
    pub kappa: usize,
    /// How it was computed.
    pub method: L0Method,
    /// Objectives seen: after each location step (alternation), of every support in
    /// lexicographic order (enumeration), or the single one (plain).
    pub trace: Vec<f64>,
}

/// The outlier budget actually used on a node with `rows` rows: `min(kappa, rows - 1)`
/// (0 for an empty node), so at least one row always stays in the cost.
pub fn effective_kappa(rows: usize, kappa: usize) -> usize {
    kappa.min(rows.saturating_sub(1))
}

/// `C(n, k)`, saturating at `usize::MAX`.
pub fn binomial(n: usize, k: usize) -> usize {
    if k > n {
        return 0;
    }
    let k = k.min(n - k);
    let mut c: u128 = 1;
    for i in 0..k {
        // Exact: c * (n - i) is divisible by (i + 1) at every step.
        c = c * (n - i) as u128 / (i + 1) as u128;
        if c > usize::MAX as u128 {
            return usize::MAX;
        }
    }
    c as usize
}

/// The `gtrs_l0` prox (module docs): the exact minimiser of `J` over supports of size
/// [`effective_kappa`]`(rows, kappa)` by enumeration when there are at most
/// [`MAX_ENUMERATED_SUPPORTS`] of them, else the Shi 2024 eq. (7) alternation.
///
/// Errors: [`ProxError::BadGamma`], [`ProxError::NonFinite`] (any row, `g`, `u` or the
/// anchor), [`ProxError::Degenerate`] (as [`prox_gtrs`], or an overflowing objective).
pub fn prox_gtrs_l0<const D: usize, const L: usize>(
    p: &LocalProblem<D, L>,
    u: &Lifted<L>,
    gamma: f64,
    kappa: usize,
) -> Result<Lifted<L>, ProxError> {
    let n = p.rows.len();
    let k = effective_kappa(n, kappa);
    if k == 0 {
        validate(p, u, gamma)?;
        return prox_gtrs(p, u, gamma);
    }
    if binomial(n, k) <= MAX_ENUMERATED_SUPPORTS {
        validate(p, u, gamma)?;
        return enumerate_theta(p, u, gamma, k);
    }
    Ok(prox_gtrs_l0_alternate(p, u, gamma, kappa, MAX_ALTERNATIONS)?.theta)
}

/// One dimension's scratch of [`enumerate_theta`].
type Scratch<const D: usize, const L: usize> = (LocalProblem<D, L>, Vec<usize>);

thread_local! {
    /// Per-thread scratch of [`enumerate_theta`], one slot per dimension (2-D,
    /// 3-D): the problem with rows deleted and the support, reused so that the
    /// engine's prox calls do not allocate.
    static SCRATCH: std::cell::RefCell<[Option<Box<dyn std::any::Any>>; 2]> =
        const { std::cell::RefCell::new([None, None]) };
}

/// [`prox_gtrs_l0_enumerate`]'s minimiser only (same supports, same order, same tie
/// rule, so bit-identical), without the trace, the support or allocations: the hot
/// path of the gossip engines. `k >= 1`; the input must be validated.
fn enumerate_theta<const D: usize, const L: usize>(
    p: &LocalProblem<D, L>,
    u: &Lifted<L>,
    gamma: f64,
    k: usize,
) -> Result<Lifted<L>, ProxError> {
    SCRATCH.with(|cell| {
        let mut guard = cell.borrow_mut();
        let slot = &mut guard[usize::from(D == 3)];
        let fresh = || -> Box<dyn std::any::Any> {
            Box::new((LocalProblem::<D, L>::empty(p.anchor), Vec::<usize>::new()))
        };
        if !slot.as_ref().is_some_and(|b| b.is::<Scratch<D, L>>()) {
            *slot = Some(fresh());
        }
        let Some((scratch, idx)) = slot
            .as_mut()
            .and_then(|b| b.downcast_mut::<Scratch<D, L>>())
        else {
            return Err(ProxError::Degenerate("gtrs_l0 scratch".into()));
        };
        let best = enumerate_supports(p, u, gamma, k, scratch, idx, |_, _, _| {})?;
        // Empty support and trace: no allocation.
        let r = finish(
            best.map(|(theta, j)| (theta, Vec::new(), j)),
            k,
            L0Method::Enumerate,
            Vec::new(),
        )?;
        Ok(r.theta)
    })
}

/// The exact `gtrs_l0` prox by enumeration of every support of size
/// `k = `[`effective_kappa`]`(rows, kappa)`: one [`prox_gtrs`] per support with those
/// rows deleted (module docs, "Reduction to row deletion"). Ties go to the first
/// support in lexicographic order. Cost `C(rows, k)` GTRS solves, whatever its size.
///
/// Errors: as [`prox_gtrs_l0`].
pub fn prox_gtrs_l0_enumerate<const D: usize, const L: usize>(
    p: &LocalProblem<D, L>,
    u: &Lifted<L>,
    gamma: f64,
    kappa: usize,
) -> Result<L0Prox<L>, ProxError> {
    validate(p, u, gamma)?;
    let n = p.rows.len();
    let k = effective_kappa(n, kappa);
    if k == 0 {
        return plain(p, u, gamma);
    }
    let mut scratch = LocalProblem::empty(p.anchor);
    let mut idx = Vec::new();
    let mut trace = Vec::new();
    let mut support = Vec::new();
    let best = enumerate_supports(p, u, gamma, k, &mut scratch, &mut idx, |s, j, better| {
        trace.push(j);
        if better {
            support = s.to_vec();
        }
    })?;
    finish(
        best.map(|(theta, j)| (theta, support, j)),
        k,
        L0Method::Enumerate,
        trace,
    )
}

/// The enumeration of [`prox_gtrs_l0_enumerate`]: one [`prox_gtrs`] per support of
/// size `k >= 1` in lexicographic order (`idx` is the support buffer), ties to the
/// first. `visit(support, J, better)` sees every support; returns the best point and
/// its `J`.
fn enumerate_supports<const D: usize, const L: usize>(
    p: &LocalProblem<D, L>,
    u: &Lifted<L>,
    gamma: f64,
    k: usize,
    scratch: &mut LocalProblem<D, L>,
    idx: &mut Vec<usize>,
    mut visit: impl FnMut(&[usize], f64, bool),
) -> Result<Option<(Lifted<L>, f64)>, ProxError> {
    let n = p.rows.len();
    idx.clear();
    idx.extend(0..k);
    let mut best: Option<(Lifted<L>, f64)> = None;
    loop {
        let (theta, j) = solve_without(p, idx, u, gamma, scratch)?;
        let better = best.is_none_or(|b| j < b.1);
        visit(idx, j, better);
        if better {
            best = Some((theta, j));
        }
        if !next_combination(idx, n) {
            return Ok(best);
        }
    }
}

/// The Shi 2024 eq. (7) alternation for the `gtrs_l0` prox (module docs), from
/// `o = 0`: location step = [`prox_gtrs`] with `g` replaced by `g + o` jointly with
/// `o` on its support (the rows of the support deleted), outlier step = hard
/// thresholding eq. (19)-(20) keeping the `k = `[`effective_kappa`]`(rows, kappa)`
/// largest `|residual|` (ties to the lower row index). Stops when a support repeats
/// or after `max_iter` location steps beyond the first, and returns the best
/// iterate; `trace` holds the objective after every location step and is
/// non-increasing up to rounding.
///
/// Errors: as [`prox_gtrs_l0`].
pub fn prox_gtrs_l0_alternate<const D: usize, const L: usize>(
    p: &LocalProblem<D, L>,
    u: &Lifted<L>,
    gamma: f64,
    kappa: usize,
    max_iter: usize,
) -> Result<L0Prox<L>, ProxError> {
    validate(p, u, gamma)?;
    let n = p.rows.len();
    let k = effective_kappa(n, kappa);
    if k == 0 {
        return plain(p, u, gamma);
    }
    let mut scratch = LocalProblem::empty(p.anchor);
    // o = 0: the plain GTRS prox.
    let mut support: Vec<usize> = Vec::new();
    let (mut theta, j0) = solve_without(p, &support, u, gamma, &mut scratch)?;
    let mut trace = vec![j0];
    let mut best: Option<(Lifted<L>, Vec<usize>, f64)> = Some((theta, support.clone(), j0));
    let mut visited: Vec<Vec<usize>> = vec![support.clone()];
    let mut order = Vec::with_capacity(n);
    for _ in 0..max_iter {
        support = hard_threshold(&p.residuals(&theta), k, &mut order).to_vec();
        if visited.contains(&support) {
            break;
        }
        let (th, j) = solve_without(p, &support, u, gamma, &mut scratch)?;
        theta = th;
        trace.push(j);
        if best.as_ref().is_none_or(|b| j < b.2) {
            best = Some((theta, support.clone(), j));
        }
        visited.push(support.clone());
    }
    finish(best, k, L0Method::Alternate, trace)
}

/// The `l0` prox objective at `theta~` with the best `kappa`-sparse `o`:
/// `1/2` (sum of all squared residuals minus the `kappa` largest) `+ ||theta~ - u||^2 /
/// (2 gamma)`. Non-finite values come out as `+inf`, never NaN.
pub fn l0_objective<const D: usize, const L: usize>(
    p: &LocalProblem<D, L>,
    theta: &Lifted<L>,
    u: &Lifted<L>,
    gamma: f64,
    kappa: usize,
) -> f64 {
    let mut sq: Vec<f64> = p.residuals(theta).iter().map(|e| e * e).collect();
    sq.sort_by(|a, b| b.total_cmp(a));
    let kept: f64 = sq.iter().skip(kappa).sum();
    nan_to_inf(0.5 * kept + (theta - u).norm_squared() / (2.0 * gamma))
}

/// Advance `idx` (strictly increasing, values `< n`) to the next combination in
/// lexicographic order; false after the last.
fn next_combination(idx: &mut [usize], n: usize) -> bool {
    let k = idx.len();
    let mut i = k;
    while i > 0 {
        i -= 1;
        if idx[i] < n - k + i {
            idx[i] += 1;
            for j in i + 1..k {
                idx[j] = idx[j - 1] + 1;
            }
            return true;
        }
    }
    false
}

/// Rebuild `scratch` as `p` without the rows in `drop` (sorted), the same way as
/// [`LocalProblem::from_rows`], and solve its GTRS prox. Returns the point and the
/// objective `J` (the kept rows only).
fn solve_without<const D: usize, const L: usize>(
    p: &LocalProblem<D, L>,
    drop: &[usize],
    u: &Lifted<L>,
    gamma: f64,
    scratch: &mut LocalProblem<D, L>,
) -> Result<(Lifted<L>, f64), ProxError> {
    scratch.anchor = p.anchor;
    scratch.rows.clear();
    scratch.g.clear();
    scratch.kinds.clear();
    let mut d = drop.iter().peekable();
    for i in 0..p.rows.len() {
        if d.peek() == Some(&&i) {
            d.next();
            continue;
        }
        scratch.rows.push(p.rows[i]);
        scratch.g.push(p.g[i]);
        if let Some(&k) = p.kinds.get(i) {
            scratch.kinds.push(k);
        }
    }
    scratch.h = LMat::<L>::zeros();
    scratch.c = Lifted::<L>::zeros();
    scratch.g_sq = 0.0;
    for (row, &gi) in scratch.rows.iter().zip(&scratch.g) {
        let b = Lifted::<L>::from_column_slice(row);
        scratch.h += b * b.transpose();
        scratch.c += b * gi;
        scratch.g_sq += gi * gi;
    }
    let theta = prox_gtrs(scratch, u, gamma)?;
    let j = nan_to_inf(scratch.prox_objective(&theta, u, gamma));
    Ok((theta, j))
}

fn plain<const D: usize, const L: usize>(
    p: &LocalProblem<D, L>,
    u: &Lifted<L>,
    gamma: f64,
) -> Result<L0Prox<L>, ProxError> {
    let theta = prox_gtrs(p, u, gamma)?;
    let j = nan_to_inf(p.prox_objective(&theta, u, gamma));
    finish(Some((theta, Vec::new(), j)), 0, L0Method::Plain, vec![j])
}

fn finish<const L: usize>(
    best: Option<(Lifted<L>, Vec<usize>, f64)>,
    kappa: usize,
    method: L0Method,
    trace: Vec<f64>,
) -> Result<L0Prox<L>, ProxError> {
    match best {
        Some((theta, support, objective)) if objective.is_finite() => Ok(L0Prox {
            theta,
            support,
            objective,
            kappa,
            method,
            trace,
        }),
        _ => Err(ProxError::Degenerate(
            "gtrs_l0: the prox objective overflowed on every outlier support".into(),
        )),
    }
}

#[inline]
fn nan_to_inf(x: f64) -> f64 {
    if x.is_nan() { f64::INFINITY } else { x }
}

/// The checks of every prox ([`crate::estimators::prox::gtrs::validate`]: `gamma`, `u`, `H`, `c`,
/// the anchor), then every row and `g` entry on its own: a deleted row must
/// not hide a NaN.
fn validate<const D: usize, const L: usize>(
    p: &LocalProblem<D, L>,
    u: &Lifted<L>,
    gamma: f64,
) -> Result<(), ProxError> {
    crate::estimators::prox::gtrs::validate(p, u, gamma)?;
    if !p.rows.iter().flatten().chain(&p.g).all(|x| x.is_finite()) {
        return Err(ProxError::NonFinite(
            "local problem rows B_v or g_v (H = B^T B or c = B^T g)",
        ));
    }
    if p.g.len() != p.rows.len() {
        return Err(ProxError::Degenerate(format!(
            "{} rows but {} entries of g",
            p.rows.len(),
            p.g.len()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimators::local::RowKind;
    use crate::estimators::prox::gtrs::tests::{
        Case, brute_force, case, eval_error, paper_problem,
    };
    use crate::model::geometry::Vec2;
    use crate::model::geometry::Vec3;
    use crate::model::measure::NodeMeasurements;
    use proptest::prelude::*;

    /// `p` without the rows whose bit is set in `mask`, built from scratch.
    fn drop_rows(p: &LocalProblem, mask: u32) -> LocalProblem {
        let keep: Vec<usize> = (0..p.rows.len()).filter(|i| mask & (1 << i) == 0).collect();
        LocalProblem::from_rows(
            p.anchor,
            keep.iter().map(|&i| p.rows[i]).collect(),
            keep.iter().map(|&i| p.g[i]).collect(),
            keep.iter().map(|&i| p.kinds[i]).collect(),
        )
    }

    /// Brute force over supports: every subset of at most `k` rows (bit masks, an
    /// enumeration independent of `next_combination`), each solved by `solve`; the
    /// best value, its point and its mask.
    fn best_over_supports(
        p: &LocalProblem,
        k: usize,
        solve: &mut dyn FnMut(&LocalProblem) -> Vec3,
        u: &Vec3,
        gamma: f64,
    ) -> (f64, Vec3, u32) {
        let n = p.rows.len();
        let mut best = (f64::INFINITY, Vec3::zeros(), 0);
        for mask in 0u32..(1 << n) {
            if mask.count_ones() as usize > k {
                continue;
            }
            let q = drop_rows(p, mask);
            let th = solve(&q);
            let f = q.prox_objective(&th, u, gamma);
            if f < best.0 {
                best = (f, th, mask);
            }
        }
        best
    }

    /// `c` with `g[row]` shifted by `off (1 + |g[row]|)` (an outlier; none if no rows).
    fn with_outlier(c: &Case, row: usize, off: f64) -> Case {
        let mut g = c.p.g.clone();
        if !g.is_empty() {
            let j = row % g.len();
            g[j] += off * (1.0 + g[j].abs());
        }
        let p = LocalProblem::from_rows(c.p.anchor, c.p.rows.clone(), g, c.p.kinds.clone());
        Case { p, ..c.clone() }
    }

    /// Objective tolerance between two points: relative 1e-9 plus rounding.
    fn tol(c: &Case, a: &Vec3, b: &Vec3, f: f64) -> f64 {
        1e-9 * f.abs() + eval_error(&c.p, a, &c.u, c.gamma) + eval_error(&c.p, b, &c.u, c.gamma)
    }

    prop_compose! {
        /// A random node (see `prox::tests::case`) with an optional outlier row and a
        /// budget `kappa` in 1..=2.
        fn l0_case()(
            c in case(),
            row in 0usize..8,
            off in prop_oneof![Just(0.0), -2.0f64..2.0, (-2.0f64..2.0).prop_map(|e| 10f64.powf(e))],
            kappa in 1usize..=2,
        ) -> (Case, usize) {
            (with_outlier(&c, row, off), kappa)
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

        /// The default `gtrs_l0` equals the best `prox_gtrs` over every way of deleting
        /// at most `kappa` rows, and its support is the `kappa` largest residuals.
        #[test]
        fn gtrs_l0_equals_the_best_gtrs_prox_over_every_outlier_support((c, kappa) in l0_case()) {
            let th = prox_gtrs_l0(&c.p, &c.u, c.gamma, kappa).map_err(|e| TestCaseError::fail(e.to_string()))?;
            let k = effective_kappa(c.p.rows.len(), kappa);
            let r = prox_gtrs_l0_enumerate(&c.p, &c.u, c.gamma, kappa).map_err(|e| TestCaseError::fail(e.to_string()))?;
            prop_assert!(th.iter().zip(r.theta.iter()).all(|(a, b)| a.to_bits() == b.to_bits()));
            prop_assert_eq!(r.kappa, k);
            prop_assert_eq!(r.support.len(), k);
            let sc = c.scale + c.p.anchor.norm() + th.norm();
            prop_assert!(c.p.cone_violation(&th).abs() <= 1e-9 * sc && th[2] >= 0.0, "infeasible {th:?}");
            let mut solve = |q: &LocalProblem| prox_gtrs(q, &c.u, c.gamma).unwrap();
            let (fb, bth, _) = best_over_supports(&c.p, k, &mut solve, &c.u, c.gamma);
            let f = l0_objective(&c.p, &th, &c.u, c.gamma, k);
            prop_assert!(f <= fb + tol(&c, &th, &bth, fb), "gtrs_l0 {f:e} worse than brute force {fb:e}");
            prop_assert!(fb <= f + tol(&c, &th, &bth, fb), "brute force {fb:e} better than gtrs_l0 {f:e}?");
            // The reported objective is J at the support, which at the optimum is the
            // l0 objective (the support holds the kappa largest residuals).
            prop_assert!((r.objective - f).abs() <= tol(&c, &th, &th, f), "J {:e} vs l0 objective {f:e}", r.objective);
        }

        /// Alternation (Shi 2024 eq. 7) never increases the objective, returns its best
        /// iterate, and is never better than the exact enumeration.
        #[test]
        fn the_alternation_objective_never_increases_and_never_beats_enumeration((c, kappa) in l0_case()) {
            let a = prox_gtrs_l0_alternate(&c.p, &c.u, c.gamma, kappa, MAX_ALTERNATIONS).map_err(|e| TestCaseError::fail(e.to_string()))?;
            let e = prox_gtrs_l0_enumerate(&c.p, &c.u, c.gamma, kappa).map_err(|e| TestCaseError::fail(e.to_string()))?;
            let t = tol(&c, &a.theta, &e.theta, a.objective);
            for w in a.trace.windows(2) {
                prop_assert!(w[1] <= w[0] + t, "objective went up: {:?}", a.trace);
            }
            prop_assert!(a.trace.len() <= MAX_ALTERNATIONS + 1);
            let min = a.trace.iter().cloned().fold(f64::INFINITY, f64::min);
            prop_assert!(a.objective.to_bits() == min.to_bits(), "not the best iterate: {:?}", a);
            prop_assert!(e.objective <= a.objective + t, "alternation {:e} beat enumeration {:e}", a.objective, e.objective);
            let sc = c.scale + c.p.anchor.norm() + a.theta.norm();
            prop_assert!(c.p.cone_violation(&a.theta).abs() <= 1e-9 * sc);
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 150, ..ProptestConfig::default() })]

        /// Against the dense brute-force cone search of the GTRS tests, run on every
        /// support of size kappa: `gtrs_l0` is at least as good as the best of them.
        #[test]
        fn gtrs_l0_is_no_worse_than_a_dense_cone_search_over_every_support((c, kappa) in l0_case()) {
            let th = prox_gtrs_l0(&c.p, &c.u, c.gamma, kappa).map_err(|e| TestCaseError::fail(e.to_string()))?;
            let k = effective_kappa(c.p.rows.len(), kappa);
            let f = l0_objective(&c.p, &th, &c.u, c.gamma, k);
            let n = c.p.rows.len();
            let mut best = (f64::INFINITY, Vec3::zeros());
            for mask in 0u32..(1 << n) {
                if mask.count_ones() as usize != k {
                    continue;
                }
                let q = drop_rows(&c.p, mask);
                let (bth, _) = brute_force(&q, &c.u, c.gamma, 61);
                let fb = q.prox_objective(&bth, &c.u, c.gamma);
                if fb < best.0 {
                    best = (fb, bth);
                }
            }
            let (fb, bth) = best;
            prop_assert!(f <= fb + tol(&c, &th, &bth, fb), "gtrs_l0 {f:e} worse than the cone search {fb:e}: {th:?} vs {bth:?}");
        }
    }

    /// One node of the paper geometry (2 transmitters + DOA = 4 rows) with extra
    /// transmitters, noise-free except `corrupt`: `(transmitter, metres added)`.
    fn corrupted_node(
        r: Vec2,
        txs: &[Vec2],
        target: Vec2,
        corrupt: &[(usize, f64)],
    ) -> LocalProblem {
        let meas = NodeMeasurements {
            elevation: None,
            bistatic: txs
                .iter()
                .enumerate()
                .map(|(m, t)| {
                    let extra: f64 = corrupt.iter().filter(|c| c.0 == m).map(|c| c.1).sum();
                    (m, (target - t).norm() + (target - r).norm() + extra)
                })
                .collect(),
            doa: Some((target.y - r.y).atan2(target.x - r.x)),
            range: None,
        };
        LocalProblem::build(r, txs, 1.0, &meas)
    }

    #[test]
    fn gtrs_l0_recovers_the_clean_row_prox_when_one_bistatic_row_is_grossly_corrupted() {
        let geometry = crate::model::measure::Geometry::mourya2017();
        let txs = &geometry.transmitters;
        let target = Vec2::new(520.0, 480.0);
        for v in 0..6 {
            let r = paper_problem(v).anchor;
            let p = corrupted_node(r, txs, target, &[(1, 1500.0)]);
            assert_eq!(p.kinds[1], RowKind::Bistatic(1));
            let clean = drop_rows(&p, 1 << 1);
            for u in [
                Vec3::new(target.x, target.y, (target - r).norm()),
                Vec3::new(500.0, 500.0, 1000.0),
                Vec3::new(620.0, 380.0, 0.0),
            ] {
                let gamma = 2e-8;
                let want = prox_gtrs(&clean, &u, gamma).unwrap();
                let got = prox_gtrs_l0_enumerate(&p, &u, gamma, 1).unwrap();
                assert_eq!(got.support, vec![1], "node {v}, u {u:?}");
                approx::assert_relative_eq!(got.theta, want, max_relative = 1e-12);
                let th = prox_gtrs_l0(&p, &u, gamma, 1).unwrap();
                approx::assert_relative_eq!(th, want, max_relative = 1e-12);
                // Without separation the outlier drags the prox away.
                let plain = prox_gtrs(&p, &u, gamma).unwrap();
                assert!(
                    (plain - want).norm() > 10.0,
                    "node {v}: {plain:?} vs {want:?}"
                );
            }
            // u = the truth: both terms vanish on the clean rows, so the answer is the
            // truth itself.
            let truth = Vec3::new(target.x, target.y, (target - r).norm());
            let th = prox_gtrs_l0(&p, &truth, 2e-8, 1).unwrap();
            approx::assert_relative_eq!(th, truth, max_relative = 1e-9);
        }
    }

    #[test]
    fn two_corrupted_rows_of_six_are_both_separated_with_kappa_two() {
        let txs = [
            Vec2::new(0.0, 0.0),
            Vec2::new(2000.0, 2000.0),
            Vec2::new(2000.0, -500.0),
            Vec2::new(-800.0, 2200.0),
        ];
        let target = Vec2::new(520.0, 480.0);
        let r = Vec2::new(1500.0, -1000.0);
        let p = corrupted_node(r, &txs, target, &[(0, 900.0), (3, -700.0)]);
        let u = Vec3::new(450.0, 530.0, 1500.0);
        let want = prox_gtrs(&drop_rows(&p, 0b1001), &u, 2e-8).unwrap();
        let got = prox_gtrs_l0_enumerate(&p, &u, 2e-8, 2).unwrap();
        assert_eq!(got.support, vec![0, 3]);
        approx::assert_relative_eq!(got.theta, want, max_relative = 1e-12);
    }

    #[test]
    fn kappa_zero_and_nodes_with_at_most_one_row_run_plain_gtrs_bit_for_bit() {
        let u = Vec3::new(400.0, 700.0, 900.0);
        let full = paper_problem(2);
        let one = drop_rows(&full, 0b1110);
        let empty = LocalProblem::empty(full.anchor);
        for (p, kappa) in [(&full, 0), (&one, 1), (&one, 5), (&empty, 1)] {
            let want = prox_gtrs(p, &u, 2e-8).unwrap();
            let got = prox_gtrs_l0(p, &u, 2e-8, kappa).unwrap();
            assert!(
                got.iter()
                    .zip(want.iter())
                    .all(|(a, b)| a.to_bits() == b.to_bits()),
                "rows {} kappa {kappa}",
                p.rows.len()
            );
            for r in [
                prox_gtrs_l0_enumerate(p, &u, 2e-8, kappa).unwrap(),
                prox_gtrs_l0_alternate(p, &u, 2e-8, kappa, 4).unwrap(),
            ] {
                assert_eq!(r.method, L0Method::Plain);
                assert_eq!(r.kappa, 0);
                assert!(r.support.is_empty());
            }
        }
    }

    #[test]
    fn kappa_above_the_row_count_is_clamped_to_keep_one_row() {
        assert_eq!(effective_kappa(0, 3), 0);
        assert_eq!(effective_kappa(1, 1), 0);
        assert_eq!(effective_kappa(4, 1), 1);
        assert_eq!(effective_kappa(4, 9), 3);
        let p = paper_problem(0);
        let u = Vec3::new(400.0, 700.0, 900.0);
        let r = prox_gtrs_l0_enumerate(&p, &u, 2e-8, 9).unwrap();
        assert_eq!(r.kappa, 3);
        assert_eq!(r.support.len(), 3);
        assert_eq!(r.trace.len(), 4);
    }

    #[test]
    fn alternation_can_stop_at_a_worse_support_so_small_nodes_are_enumerated() {
        // Found by random search (about 3.5% of random 3-6 row nodes with one gross
        // outlier, mostly kappa = 2): from o = 0 hard thresholding picks rows {2, 3},
        // a fixed point, while {1, 3} is better.
        let p = LocalProblem::from_rows(
            Vec2::new(264.0702598162702, -1212.7260362392121),
            vec![
                [3403.554080549573, 3560.036341297403, -4973.844129286457],
                [-1870.8215168405736, -468.0874217203914, -4800.159550604281],
                [-1382.967081107568, 3753.530079178271, -4827.141899826911],
                [-85.80611893223795, 3823.6136293421187, -6869.8292091409685],
                [1294.9874408202459, 3728.1329940668757, -4007.690554454594],
            ],
            vec![
                -3538842.9236630714,
                -4756979.702718303,
                -6742132.360837279,
                -12801447.016499909,
                -4300640.150244228,
            ],
            vec![RowKind::Bistatic(0); 5],
        );
        let u = Vec3::new(717.0990770059361, -524.9967814998436, 782.4412948109594);
        let a = prox_gtrs_l0_alternate(&p, &u, 2e-8, 2, MAX_ALTERNATIONS).unwrap();
        let e = prox_gtrs_l0_enumerate(&p, &u, 2e-8, 2).unwrap();
        assert_eq!(a.support, vec![2, 3]);
        assert_eq!(e.support, vec![1, 3]);
        assert!(e.objective < 0.99 * a.objective, "{e:?} vs {a:?}");
        let th = prox_gtrs_l0(&p, &u, 2e-8, 2).unwrap();
        assert!(
            th.iter()
                .zip(e.theta.iter())
                .all(|(x, y)| x.to_bits() == y.to_bits())
        );
    }

    #[test]
    fn combinations_visit_every_support_once_in_lexicographic_order() {
        for n in 1..9usize {
            for k in 1..=n {
                let mut idx: Vec<usize> = (0..k).collect();
                let mut seen = vec![idx.clone()];
                while next_combination(&mut idx, n) {
                    assert!(idx.windows(2).all(|w| w[0] < w[1]) && idx[k - 1] < n);
                    assert!(seen.last().is_some_and(|l| *l < idx));
                    seen.push(idx.clone());
                }
                assert_eq!(seen.len(), binomial(n, k), "n {n} k {k}");
            }
        }
        assert_eq!(binomial(12, 2), MAX_ENUMERATED_SUPPORTS);
        assert_eq!(binomial(3, 5), 0);
        assert_eq!(binomial(200, 100), usize::MAX);
    }

    #[test]
    fn large_nodes_fall_back_to_the_alternation() {
        // 12 transmitters + DOA = 14 rows; C(14, 2) = 91 > 66 supports.
        let txs: Vec<Vec2> = (0..12)
            .map(|m| {
                let a = 0.5 * m as f64;
                Vec2::new(2000.0 * a.cos(), 2000.0 * a.sin())
            })
            .collect();
        let target = Vec2::new(300.0, -200.0);
        let r = Vec2::new(-900.0, 400.0);
        let p = corrupted_node(r, &txs, target, &[(4, 1200.0), (9, 800.0)]);
        assert_eq!(p.rows.len(), 14);
        let u = Vec3::new(250.0, -150.0, 1300.0);
        let th = prox_gtrs_l0(&p, &u, 2e-8, 2).unwrap();
        let a = prox_gtrs_l0_alternate(&p, &u, 2e-8, 2, MAX_ALTERNATIONS).unwrap();
        assert_eq!(a.method, L0Method::Alternate);
        assert!(
            th.iter()
                .zip(a.theta.iter())
                .all(|(x, y)| x.to_bits() == y.to_bits())
        );
        // Here alternation finds both outliers (it is exact on this instance).
        let e = prox_gtrs_l0_enumerate(&p, &u, 2e-8, 2).unwrap();
        assert_eq!(e.support, vec![4, 9]);
        assert_eq!(a.support, vec![4, 9]);
        // With kappa = 1 the 14 supports are enumerated.
        let th1 = prox_gtrs_l0(&p, &u, 2e-8, 1).unwrap();
        let e1 = prox_gtrs_l0_enumerate(&p, &u, 2e-8, 1).unwrap();
        assert!(
            th1.iter()
                .zip(e1.theta.iter())
                .all(|(x, y)| x.to_bits() == y.to_bits())
        );
    }

    #[test]
    fn a_non_finite_row_is_an_error_even_when_it_would_be_separated() {
        let good = paper_problem(1);
        let u = Vec3::new(1.0, 2.0, 3.0);
        for bad in [f64::NAN, f64::INFINITY] {
            let mut g = good.g.clone();
            g[0] = bad;
            let p = LocalProblem::from_rows(good.anchor, good.rows.clone(), g, good.kinds.clone());
            let mut rows = good.rows.clone();
            rows[2][1] = bad;
            let q = LocalProblem::from_rows(good.anchor, rows, good.g.clone(), good.kinds.clone());
            for p in [&p, &q] {
                for kappa in [1, 2] {
                    assert!(matches!(
                        prox_gtrs_l0(p, &u, 2e-8, kappa),
                        Err(ProxError::NonFinite(_))
                    ));
                    assert!(matches!(
                        prox_gtrs_l0_alternate(p, &u, 2e-8, kappa, 8),
                        Err(ProxError::NonFinite(_))
                    ));
                }
            }
            assert!(matches!(
                prox_gtrs_l0(&good, &Vec3::new(bad, 0.0, 0.0), 2e-8, 1),
                Err(ProxError::NonFinite(_))
            ));
        }
        assert!(matches!(
            prox_gtrs_l0(&good, &u, -1.0, 1),
            Err(ProxError::BadGamma(_))
        ));
    }

    #[test]
    fn overflowing_data_is_an_error_not_nan() {
        let p = LocalProblem::from_rows(
            Vec2::zeros(),
            vec![[1e200, 1e200, 1e200], [1e200, -1e200, 1e200]],
            vec![1e200, 1e200],
            vec![RowKind::Range, RowKind::Range],
        );
        match prox_gtrs_l0(&p, &Vec3::new(1.0, 2.0, 3.0), 1.0, 1) {
            Ok(th) => assert!(th.iter().all(|x| x.is_finite()), "{th:?}"),
            Err(e) => assert!(matches!(
                e,
                ProxError::Degenerate(_) | ProxError::NonFinite(_)
            )),
        }
    }
}
