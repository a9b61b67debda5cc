//! Initial estimates: exact or OLS (seed 000 eq. (15)-(17)), and the closed-form linear
//! LS of one-way and bistatic ranges.

use super::*;

/// How a tracker's `x_0` is chosen (seed 000 Sec. V).
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
    pub fn initial_estimate(
        self,
        geometry: &Geometry,
        first: &SampleMeasurements,
        x_true_first: Vec2,
    ) -> Result<Vec2, TrackError> {
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
/// * With at least 3 one-way ranges whose anchors are not collinear: seed 000
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
pub fn ols_position(geometry: &Geometry, sample: &SampleMeasurements) -> Result<Vec2, TrackError> {
    if sample.nodes.len() > geometry.receivers.len() {
        return Err(TrackError::TooManyNodes {
            nodes: sample.nodes.len(),
            receivers: geometry.receivers.len(),
        });
    }
    let mut anchors: Vec<(Vec2, f64)> = Vec::new();
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

/// Closed-form linear least squares on differenced squared one-way ranges, seed 000
/// eq. (15)-(17): subtracting `||x - a_i||^2 = r_i^2` from the next equation gives
/// `(a_{i+1} - a_i)^T x = (||a_{i+1}||^2 - ||a_i||^2 + r_i^2 - r_{i+1}^2) / 2`,
/// `i = 1..m-1`, solved as `x = (A^T A)^{-1} A^T b` over the `(anchor, range)` pairs in
/// the given order. The one implementation of this estimator: [`ols_position`] (and
/// so the trackers' OLS initialisation and the `lls` baseline) and the seed 003
/// bound tests use it.
///
/// Errors (as text, for [`TrackError::OlsDegenerate`]): fewer than 3 pairs,
/// non-finite input, or collinear anchors (`A^T A` singular to `1e-10` relative).
pub fn ols_toa(anchors: &[(Vec2, f64)]) -> Result<Vec2, String> {
    if anchors.len() < 3 {
        return Err(format!("{} one-way ranges (need >= 3)", anchors.len()));
    }
    if anchors
        .iter()
        .any(|(a, r)| !(a.x.is_finite() && a.y.is_finite() && r.is_finite()))
    {
        return Err("non-finite anchor or one-way range".into());
    }
    let mut ata = Mat2::zeros();
    let mut atb = Vec2::zeros();
    for w in anchors.windows(2) {
        let (a0, r0) = w[0];
        let (a1, r1) = w[1];
        let row = a1 - a0;
        let b = 0.5 * (a1.norm_squared() - a0.norm_squared() + r0 * r0 - r1 * r1);
        ata += row * row.transpose();
        atb += row * b;
    }
    let det = ata.determinant();
    let tr = ata.trace();
    if det.is_nan() || det <= OLS_RANK_REL * tr * tr {
        return Err("one-way anchors are collinear (A^T A singular)".into());
    }
    let x = Vec2::new(
        (ata[(1, 1)] * atb.x - ata[(0, 1)] * atb.y) / det,
        (ata[(0, 0)] * atb.y - ata[(1, 0)] * atb.x) / det,
    );
    if x.x.is_finite() && x.y.is_finite() {
        Ok(x)
    } else {
        Err("non-finite OLS solution".into())
    }
}

pub(super) fn ols_bistatic(
    geometry: &Geometry,
    bistatic: &[(usize, usize, f64)],
    lift_tx: bool,
) -> Result<Vec2, String> {
    // Column index of each lifted focus.
    let key = |b: &(usize, usize, f64)| if lift_tx { b.0 } else { b.1 };
    let mut lifted: Vec<usize> = bistatic.iter().map(key).collect();
    lifted.sort_unstable();
    lifted.dedup();
    let cols = 2 + lifted.len();
    let rows = bistatic.len();
    let label = if lift_tx { "transmitter" } else { "receiver" };
    if rows < cols {
        return Err(format!(
            "{label}-lifted bistatic system has {rows} equations for {cols} unknowns"
        ));
    }
    let mut a = nalgebra::DMatrix::<f64>::zeros(rows, cols);
    let mut b = nalgebra::DVector::<f64>::zeros(rows);
    for (i, bi) in bistatic.iter().enumerate() {
        let (m, n, rho) = *bi;
        let (lift, other) = if lift_tx {
            (geometry.transmitters[m], geometry.receivers[n])
        } else {
            (geometry.receivers[n], geometry.transmitters[m])
        };
        let j = lifted.partition_point(|&k| k < key(bi));
        let row = 2.0 * (lift - other);
        a[(i, 0)] = row.x;
        a[(i, 1)] = row.y;
        a[(i, 2 + j)] = 2.0 * rho;
        b[i] = rho * rho + lift.norm_squared() - other.norm_squared();
    }
    let svd = a.svd(true, true);
    let smax = svd.singular_values.max();
    let smin = svd.singular_values.min();
    if smin.is_nan() || smin <= OLS_RANK_REL * smax {
        return Err(format!("{label}-lifted bistatic system is rank deficient"));
    }
    let z = svd
        .solve(&b, 0.0)
        .map_err(|e| format!("{label}-lifted solve failed: {e}"))?;
    let x = Vec2::new(z[0], z[1]);
    if x.x.is_finite() && x.y.is_finite() {
        Ok(x)
    } else {
        Err(format!("{label}-lifted solution is non-finite"))
    }
}
