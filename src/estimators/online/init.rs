//! Initial estimates: exact or OLS (Pun-So 2022 eq. (15)-(17)), and the closed-form linear
//! LS of one-way and bistatic ranges.

use crate::estimators::online::TrackError;
use crate::estimators::online::check_x0;
use crate::model::geometry::{Point, Vec2};
use crate::model::linalg::{MatD, determinant, lu_solve};
use crate::model::measure::Geometry;
use crate::model::measure::SampleMeasurements;
use serde::Deserialize;
use serde::Serialize;

/// How a tracker's `x_0` is chosen (Pun-So 2022 Sec. V).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Init {
    /// Exact initialisation: `x_0 = x_1^*`, the true first position.
    #[default]
    Exact,
    /// OLS initialisation from the first sample, [`ols_position`].
    Ols,
}

impl Init {
    /// `x_0` from the first sample and the true first position `x_true_first`.
    pub fn initial_estimate<const D: usize>(
        self,
        geometry: &Geometry<D>,
        first: &SampleMeasurements,
        x_true_first: Point<D>,
    ) -> Result<Point<D>, TrackError> {
        match self {
            Init::Exact => {
                check_x0(&x_true_first)?;
                Ok(x_true_first)
            }
            Init::Ols => ols_position(geometry, first),
        }
    }
}

/// Relative rank threshold of the OLS normal equations.
pub(super) const OLS_RANK_REL: f64 = 1e-10;

/// OLS position estimate from one sample.
///
/// * With at least `D + 1` one-way ranges whose anchors are not collinear (not
///   coplanar in 3-D): Pun-So 2022
///   eq. (15)-(17), `x_0 = (A^T A)^{-1} A^T b` with rows
///   `a_{i+1} - a_i` and `b_i = (||a_{i+1}||^2 - ||a_i||^2 + r_i^2 - r_{i+1}^2)/2`
///   over the anchors in node order (eq. (17) as printed has an index typo;
///   this is the form derived just below it and in eq. (20)). Bistatic ranges
///   are then not used.
/// * Otherwise, from the bistatic ranges alone (not in the papers): squaring
///   `||x - r_n|| = rho - ||x - t_m||` gives the linear equation
///   `2 (t_m - r_n)^T x + 2 rho D_m = rho^2 + ||t_m||^2 - ||r_n||^2` in `x` and
///   the lifted transmitter distance `D_m = ||x - t_m||`; by symmetry one can
///   instead lift the receiver distance `d_n`. The lifting with fewer unknowns
///   is tried first, then the other; the linear least-squares solution's `x`
///   is returned (the lifted distances are discarded).
///
/// Errors ([`TrackError::OlsDegenerate`]) when neither system has full column rank.
pub fn ols_position<const D: usize>(
    geometry: &Geometry<D>,
    sample: &SampleMeasurements,
) -> Result<Point<D>, TrackError> {
    if sample.nodes.len() > geometry.receivers.len() {
        return Err(TrackError::TooManyNodes {
            nodes: sample.nodes.len(),
            receivers: geometry.receivers.len(),
        });
    }
    let mut anchors: Vec<(Point<D>, f64)> = Vec::new();
    let mut bistatic: Vec<(usize, usize, f64)> = Vec::new();
    for (n, node) in sample.nodes.iter().enumerate() {
        if let Some(r) = node.range {
            if !r.is_finite() {
                return Err(TrackError::NonFinite("one-way range"));
            }
            anchors.push((geometry.receivers[n], r));
        }
        for &(m, rho) in &node.bistatic {
            if m >= geometry.transmitters.len() {
                return Err(TrackError::UnknownTransmitter {
                    node: n,
                    m,
                    count: geometry.transmitters.len(),
                });
            }
            if !rho.is_finite() {
                return Err(TrackError::NonFinite("bistatic range"));
            }
            bistatic.push((m, n, rho));
        }
    }
    let mut why = match ols_toa(&anchors) {
        Ok(x) => return Ok(x),
        Err(e) => e,
    };
    if bistatic.is_empty() {
        return Err(TrackError::OlsDegenerate(format!(
            "{why}; no bistatic ranges"
        )));
    }
    let n_tx = {
        let mut v: Vec<usize> = bistatic.iter().map(|b| b.0).collect();
        v.sort_unstable();
        v.dedup();
        v.len()
    };
    let n_rx = {
        let mut v: Vec<usize> = bistatic.iter().map(|b| b.1).collect();
        v.sort_unstable();
        v.dedup();
        v.len()
    };
    let order = if n_tx <= n_rx {
        [true, false]
    } else {
        [false, true]
    };
    for lift_tx in order {
        match ols_bistatic(geometry, &bistatic, lift_tx) {
            Ok(x) => return Ok(x),
            Err(e) => {
                why.push_str("; ");
                why.push_str(&e);
            }
        }
    }
    Err(TrackError::OlsDegenerate(why))
}

/// Closed-form linear least squares on differenced squared one-way ranges, Pun-So 2022
/// eq. (15)-(17): subtracting `||x - a_i||^2 = r_i^2` from the next equation gives
/// `(a_{i+1} - a_i)^T x = (||a_{i+1}||^2 - ||a_i||^2 + r_i^2 - r_{i+1}^2) / 2`,
/// `i = 1..m-1`, solved as `x = (A^T A)^{-1} A^T b` over the `(anchor, range)` pairs in
/// the given order. The one implementation of this estimator: [`ols_position`] (and
/// so the trackers' OLS initialisation and the `lls` baseline) and the Gholami 2015
/// bound tests use it.
///
/// In 3-D the same rows have three columns and `D + 1 = 4` pairs are needed.
///
/// Errors (as text, for [`TrackError::OlsDegenerate`]): fewer than `D + 1`
/// pairs, non-finite input, or collinear (coplanar) anchors (`det(A^T A) <=
/// 1e-10 tr(A^T A)^D`).
pub fn ols_toa<const D: usize>(anchors: &[(Point<D>, f64)]) -> Result<Point<D>, String> {
    if anchors.len() < D + 1 {
        return Err(format!(
            "{} one-way ranges (need >= {})",
            anchors.len(),
            D + 1
        ));
    }
    if anchors
        .iter()
        .any(|(a, r)| !(a.iter().all(|v| v.is_finite()) && r.is_finite()))
    {
        return Err("non-finite anchor or one-way range".into());
    }
    let mut ata = MatD::<D>::zeros();
    let mut atb = Point::<D>::zeros();
    for w in anchors.windows(2) {
        let (a0, r0) = w[0];
        let (a1, r1) = w[1];
        let row = a1 - a0;
        let b = 0.5 * (a1.norm_squared() - a0.norm_squared() + r0 * r0 - r1 * r1);
        ata += row * row.transpose();
        atb += row * b;
    }
    let degenerate = if D == 2 {
        "one-way anchors are collinear (A^T A singular)"
    } else {
        "one-way anchors are coplanar (A^T A singular)"
    };
    let det = determinant(&ata).ok_or("unsupported dimension")?;
    let tr = ata.trace();
    if det.is_nan() || det <= OLS_RANK_REL * (0..D).fold(1.0, |p, _| p * tr) {
        return Err(degenerate.into());
    }
    let x = if D == 2 {
        Point::<D>::from_fn(|i, _| {
            if i == 0 {
                (ata[(1, 1)] * atb[0] - ata[(0, 1)] * atb[1]) / det
            } else {
                (ata[(0, 0)] * atb[1] - ata[(1, 0)] * atb[0]) / det
            }
        })
    } else {
        lu_solve(&ata, &atb).ok_or(degenerate)?
    };
    if x.iter().all(|v| v.is_finite()) {
        Ok(x)
    } else {
        Err("non-finite OLS solution".into())
    }
}

/// One row of the lifted bistatic system: a bistatic range `rho` from the
/// focus `lift` (whose distance to the target is lifted into an unknown of
/// its own, one per `key`) and the focus `other`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiftedRow<const D: usize = 2> {
    /// Which lifted distance this row's `lift` focus has (`0..n_keys`).
    pub key: usize,
    /// The focus whose distance `d_key = ||x - lift||` is an unknown.
    pub lift: Point<D>,
    /// The other focus.
    pub other: Point<D>,
    /// The bistatic range `||x - lift|| + ||x - other||`.
    pub rho: f64,
}

/// Closed-form linear least squares of bistatic ranges, the one implementation
/// for the trackers' OLS start and the `lls` baseline ([`ols_position`]) and
/// the robust estimators' linear start (Shi 2024, [`crate::estimators::robust`]).
///
/// Squaring `||x - lift|| = rho - ||x - other||` gives, for every row, the
/// equation of Mourya 2017 eq. (9) linear in `x` and the lifted `d_key`:
/// `[2 (other - lift)^T, -2 rho] [x; d_key] = ||other||^2 - rho^2 - ||lift||^2`,
/// written in coordinates centred on `centre` for conditioning. Each `d_key`
/// is eliminated in closed form (the Schur complement of its column), which
/// leaves a 2x2 system in `x`. `None` when that system is singular
/// (`det <= 1e-10 tr^2`) or the solution is not finite.
pub fn lifted_bistatic_ls<const D: usize>(
    rows: impl IntoIterator<Item = LiftedRow<D>>,
    n_keys: usize,
    centre: Point<D>,
) -> Option<Point<D>> {
    /// Per key: `S_aa` (upper triangle), `s_ac`, `S_cc`, `s_ag`, `s_cg`.
    #[derive(Clone)]
    struct Key<const D: usize> {
        aa: MatD<D>,
        ac: Point<D>,
        cc: f64,
        ag: Point<D>,
        cg: f64,
    }
    let zero = Key::<D> {
        aa: MatD::<D>::zeros(),
        ac: Point::<D>::zeros(),
        cc: 0.0,
        ag: Point::<D>::zeros(),
        cg: 0.0,
    };
    let mut acc = vec![zero; n_keys];
    for row in rows {
        let (t, r) = (row.other - centre, row.lift - centre);
        let a = 2.0 * (t - r);
        let c = -2.0 * row.rho;
        let g = t.norm_squared() - row.rho * row.rho - r.norm_squared();
        let k = acc.get_mut(row.key)?;
        for i in 0..D {
            for j in i..D {
                k.aa[(i, j)] += a[i] * a[j];
            }
            k.ac[i] += a[i] * c;
            k.ag[i] += a[i] * g;
        }
        k.cc += c * c;
        k.cg += c * g;
    }
    // The Schur complement of every lifted column: M x = b (upper triangle of M).
    let mut m = MatD::<D>::zeros();
    let mut b = Point::<D>::zeros();
    for k in &acc {
        for i in 0..D {
            for j in i..D {
                m[(i, j)] += k.aa[(i, j)];
            }
            b[i] += k.ag[i];
        }
        if k.cc > 0.0 {
            for i in 0..D {
                for j in i..D {
                    m[(i, j)] -= k.ac[i] * k.ac[j] / k.cc;
                }
                b[i] -= k.ac[i] * k.cg / k.cc;
            }
        }
    }
    if D == 2 {
        let (m00, m01, m11, b0, b1) = (m[(0, 0)], m[(0, 1)], m[(1, 1)], b[0], b[1]);
        let det = m00 * m11 - m01 * m01;
        let tr = m00 + m11;
        if !(det.is_finite() && tr > 0.0 && det > OLS_RANK_REL * tr * tr) {
            return None;
        }
        let e = Vec2::new((m11 * b0 - m01 * b1) / det, (m00 * b1 - m01 * b0) / det);
        let e = Point::<D>::from_fn(|i, _| e[i]) + centre;
        return e.iter().all(|v| v.is_finite()).then_some(e);
    }
    for i in 0..D {
        for j in 0..i {
            m[(i, j)] = m[(j, i)];
        }
    }
    let det = determinant(&m)?;
    let tr = m.trace();
    if !(det.is_finite() && tr > 0.0 && det > OLS_RANK_REL * tr * tr * tr) {
        return None;
    }
    let e = lu_solve(&m, &b)? + centre;
    e.iter().all(|v| v.is_finite()).then_some(e)
}

/// [`lifted_bistatic_ls`] of `(m, n, rho)` triples, lifting the transmitter
/// distances (`lift_tx`) or the receiver distances, centred on the foci's mean.
pub(super) fn ols_bistatic<const D: usize>(
    geometry: &Geometry<D>,
    bistatic: &[(usize, usize, f64)],
    lift_tx: bool,
) -> Result<Point<D>, String> {
    let key = |b: &(usize, usize, f64)| if lift_tx { b.0 } else { b.1 };
    let mut lifted: Vec<usize> = bistatic.iter().map(key).collect();
    lifted.sort_unstable();
    lifted.dedup();
    let cols = D + lifted.len();
    let rows = bistatic.len();
    let label = if lift_tx { "transmitter" } else { "receiver" };
    if rows < cols {
        return Err(format!(
            "{label}-lifted bistatic system has {rows} equations for {cols} unknowns"
        ));
    }
    let row = |&(m, n, rho): &(usize, usize, f64)| {
        let (t, r) = (geometry.transmitters[m], geometry.receivers[n]);
        if lift_tx {
            LiftedRow {
                key: m,
                lift: t,
                other: r,
                rho,
            }
        } else {
            LiftedRow {
                key: n,
                lift: r,
                other: t,
                rho,
            }
        }
    };
    let sum: Point<D> = bistatic
        .iter()
        .map(|b| geometry.transmitters[b.0])
        .sum::<Point<D>>()
        + bistatic
            .iter()
            .map(|b| geometry.receivers[b.1])
            .sum::<Point<D>>();
    let centre = sum / (2.0 * rows as f64);
    let n_keys = if lift_tx {
        geometry.transmitters.len()
    } else {
        geometry.receivers.len()
    };
    lifted_bistatic_ls(bistatic.iter().map(row), n_keys, centre)
        .ok_or_else(|| format!("{label}-lifted bistatic system is rank deficient"))
}
