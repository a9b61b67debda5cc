//! The local least-squares cost of one receiver, Mourya 2017 eq. (9)-(10),
//! in 2-D and 3-D.
//!
//! For node `v` with lifted variable `theta~ = [theta, d]` (`d = ||theta - r_v||`,
//! `theta` in `D` = 2 or 3 dimensions):
//!
//! * one row per bistatic range `rho_{m,v}` (eq. 9, any dimension):
//!   `[2 (t_m - r_v)^T, -2 rho_{m,v}]`, `g = ||t_m||^2 - rho_{m,v}^2 - ||r_v||^2`;
//! * DOA rows (eq. 10). In 2-D the paper's two rows `omega [1, 0, -cos phi]`,
//!   `omega [0, 1, -sin phi]`, `g = omega x_r`, `omega y_r`: `theta - d e(phi) = r_v`.
//!   Rotated into the basis `(e, n)` of the measured direction they are one
//!   row along `e` (`e^T (theta - r_v) = d`) and one orthogonal to it
//!   (`n^T (theta - r_v) = 0`). In 3-D the DOA is an azimuth `phi` and an
//!   elevation `psi`, with direction `e = [cos psi cos phi, cos psi sin phi, sin psi]`,
//!   and the cost keeps the two rows orthogonal to `e`, one per angle:
//!   `omega [n_phi^T, 0]`, `g = omega n_phi^T r_v` with
//!   `n_phi = [-sin phi, cos phi, 0]` (a change of azimuth moves the target
//!   along it), and `omega [n_psi^T, 0]`, `g = omega n_psi^T r_v` with
//!   `n_psi = [-sin psi cos phi, -sin psi sin phi, cos psi]`. Each vanishes
//!   on the measured ray, and each moves with its own angle alone (to first
//!   order: by `d cos psi` per radian of azimuth, `d` per radian of
//!   elevation), so each is weighted by its own noise
//!   ([`LocalProblem::build_weighted`]). The along row of 2-D is dropped in
//!   3-D: on the cone (12) it is the second-order term `d (1 - cos angle)`;
//! * one row per one-way range `r_v` (TOA, Pun-So 2022): `[0, ..., 0, 1]`, `g = r_v`.
//!
//! `f_v(theta~) = 1/2 ||B_v theta~ - g_v||^2`.

use crate::model::geometry::{LMat, Lifted, Point, check_dims, lift};
use crate::model::measure::{NodeMeasurements, Sigmas};

/// What kind of measurement produced a row of `B_v` (used by robust solvers
/// and diagnostics).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowKind {
    /// Bistatic range through transmitter `m`.
    Bistatic(usize),
    /// A DOA row: in 2-D the first (cos) or second (sin) row of eq. (10); in
    /// 3-D the azimuth (0) or elevation (1) row.
    Doa(u8),
    /// One-way range.
    Range,
}

/// The local cost `f_v(theta~) = 1/2 ||B theta~ - g||^2` of one node in `D`
/// dimensions (`L = D + 1`), with the normal-equation data `H = B^T B`,
/// `c = B^T g` precomputed for the prox.
#[derive(Debug, Clone, PartialEq)]
pub struct LocalProblem<const D: usize = 2, const L: usize = 3> {
    /// Receiver position `r_v` (apex of the cone constraint, eq. 12).
    pub anchor: Point<D>,
    /// Rows of `B_v`.
    pub rows: Vec<[f64; L]>,
    /// Entries of `g_v`, one per row.
    pub g: Vec<f64>,
    /// Which measurement each row came from.
    pub kinds: Vec<RowKind>,
    /// `H = B^T B`.
    pub h: LMat<L>,
    /// `c = B^T g`.
    pub c: Lifted<L>,
    /// `||g||^2`.
    pub g_sq: f64,
}

impl<const D: usize, const L: usize> LocalProblem<D, L> {
    /// Assemble `B_v`, `g_v` of eq. (9)-(10) for receiver `anchor` from its
    /// own measurements. `transmitters` are all transmitter positions `t_m`;
    /// `omega` is the DOA weight. In 3-D a DOA without an elevation gives no
    /// DOA rows.
    pub fn build(
        anchor: Point<D>,
        transmitters: &[Point<D>],
        omega: f64,
        meas: &NodeMeasurements,
    ) -> Self {
        const { check_dims::<D, L>() };
        let mut rows = Vec::with_capacity(meas.bistatic.len() + 3);
        let mut g = Vec::with_capacity(rows.capacity());
        let mut kinds = Vec::with_capacity(rows.capacity());
        let r_sq = anchor.norm_squared();
        for &(m, rho) in &meas.bistatic {
            let t = transmitters[m];
            let mut row = [0.0; L];
            for i in 0..D {
                row[i] = 2.0 * (t[i] - anchor[i]);
            }
            row[D] = -2.0 * rho;
            rows.push(row);
            g.push(t.norm_squared() - rho * rho - r_sq);
            kinds.push(RowKind::Bistatic(m));
        }
        if let Some(phi) = meas.doa {
            let (s, c) = phi.sin_cos();
            if D == 2 {
                rows.push(row_of([omega, 0.0, -omega * c]));
                g.push(omega * anchor[0]);
                kinds.push(RowKind::Doa(0));
                rows.push(row_of([0.0, omega, -omega * s]));
                g.push(omega * anchor[1]);
                kinds.push(RowKind::Doa(1));
            } else if let Some(psi) = meas.elevation {
                let (se, ce) = psi.sin_cos();
                for (k, n) in [[-s, c, 0.0], [-se * c, -se * s, ce]]
                    .into_iter()
                    .enumerate()
                {
                    rows.push(row_of([omega * n[0], omega * n[1], omega * n[2], 0.0]));
                    g.push(omega * (n[0] * anchor[0] + n[1] * anchor[1] + n[2] * anchor[2]));
                    kinds.push(RowKind::Doa(k as u8));
                }
            }
        }
        if let Some(r) = meas.range {
            let mut row = [0.0; L];
            row[D] = 1.0;
            rows.push(row);
            g.push(r);
            kinds.push(RowKind::Range);
        }
        Self::from_rows(anchor, rows, g, kinds)
    }

    /// [`LocalProblem::build`], with every row divided by its noise standard
    /// deviation to first order when `sigmas` is given (`algorithm.row_weights
    /// = "noise"`; beyond the paper), so that `f_v` weighs each measurement
    /// as the ML cost does:
    ///
    /// * a bistatic row by `2 rho_{m,v} sigma_rho` (its residual moves by
    ///   `2 (rho - d) d rho <= 2 rho d rho` when `rho` moves by `d rho`);
    /// * in 2-D both DOA rows by `omega d_hat sigma_phi`; in 3-D the azimuth
    ///   row by `omega d_hat cos(psi) sigma_phi` and the elevation row by
    ///   `omega d_hat sigma_psi`, where `d_hat` is the node's own range
    ///   estimate from this sample: the point at distance `d` along the DOA
    ///   ray `e` whose bistatic range through `t_m` is `rho_m`,
    ///   `d_m = (rho_m^2 - ||t_m - r||^2) / (2 (rho_m - (t_m - r) . e))`,
    ///   averaged over the transmitters where it is positive and finite (half
    ///   the mean bistatic range if none is; the DOA rows stay as they are if
    ///   the node has no bistatic range);
    /// * a one-way range row by `sigma_rho`.
    ///
    /// A divisor that is not finite and positive (a zero sigma) leaves its row
    /// as it is. The rows stay rows of the same lifted problem, so the exact
    /// prox (eq. 13) applies unchanged.
    pub fn build_weighted(
        anchor: Point<D>,
        transmitters: &[Point<D>],
        omega: f64,
        meas: &NodeMeasurements,
        sigmas: Option<&Sigmas>,
    ) -> Self {
        let p = Self::build(anchor, transmitters, omega, meas);
        let Some(sig) = sigmas else {
            return p;
        };
        let psi = meas.elevation.unwrap_or(0.0);
        let d_hat = meas.doa.and_then(|phi| {
            let e = crate::model::measure::direction::<D>(phi, psi);
            let ds: Vec<f64> = meas
                .bistatic
                .iter()
                .filter_map(|&(m, rho)| {
                    let tr = transmitters.get(m)? - anchor;
                    let d = (rho * rho - tr.norm_squared()) / (2.0 * (rho - tr.dot(&e)));
                    (d.is_finite() && d > 0.0).then_some(d)
                })
                .collect();
            if !ds.is_empty() {
                Some(ds.iter().sum::<f64>() / ds.len() as f64)
            } else if !meas.bistatic.is_empty() {
                Some(
                    meas.bistatic.iter().map(|b| b.1).sum::<f64>()
                        / (2.0 * meas.bistatic.len() as f64),
                )
            } else {
                None
            }
        });
        let divisor = |kind: &RowKind, row: &[f64; L]| match kind {
            RowKind::Bistatic(_) => Some(-row[D] * sig.range),
            RowKind::Doa(_) if D == 2 => d_hat.map(|d| omega * d * sig.doa),
            RowKind::Doa(0) => d_hat.map(|d| omega * d * psi.cos() * sig.doa),
            RowKind::Doa(_) => d_hat.map(|d| omega * d * sig.elevation),
            RowKind::Range => Some(sig.range),
        };
        let mut rows = p.rows;
        let mut g = p.g;
        for ((row, gi), kind) in rows.iter_mut().zip(g.iter_mut()).zip(&p.kinds) {
            if let Some(s) = divisor(kind, row).filter(|s| s.is_finite() && *s > 0.0) {
                for x in row.iter_mut() {
                    *x /= s;
                }
                *gi /= s;
            }
        }
        Self::from_rows(anchor, rows, g, p.kinds)
    }

    /// Build from explicit rows (used by tests and robust solvers that drop rows).
    pub fn from_rows(
        anchor: Point<D>,
        rows: Vec<[f64; L]>,
        g: Vec<f64>,
        kinds: Vec<RowKind>,
    ) -> Self {
        const { check_dims::<D, L>() };
        let mut h = LMat::<L>::zeros();
        let mut c = Lifted::<L>::zeros();
        let mut g_sq = 0.0;
        for (row, &gi) in rows.iter().zip(&g) {
            let b = Lifted::<L>::from_column_slice(row);
            h += b * b.transpose();
            c += b * gi;
            g_sq += gi * gi;
        }
        LocalProblem {
            anchor,
            rows,
            g,
            kinds,
            h,
            c,
            g_sq,
        }
    }

    /// An empty cost (`f_v = 0`): a node without measurements; its prox is the identity.
    pub fn empty(anchor: Point<D>) -> Self {
        Self::from_rows(anchor, Vec::new(), Vec::new(), Vec::new())
    }

    /// The node's own fix of this sample, where a deployed node starts
    /// (`algorithm.init = "first_fix"`): the relaxed least-squares solution
    /// `H^{-1} c` of eq. (9), without the cone constraint (12), when the node
    /// has at least `L` rows and `H` is positive definite with a finite
    /// solution; otherwise the centroid of `transmitters` (the receiver
    /// itself if there are none), with `d` its distance to the receiver.
    pub fn first_fix(&self, transmitters: &[Point<D>]) -> Lifted<L> {
        if self.rows.len() >= L
            && let Some(ch) = self.h.cholesky()
        {
            let x = ch.solve(&self.c);
            if x.iter().all(|v| v.is_finite()) {
                return x;
            }
        }
        let centre = if transmitters.is_empty() {
            self.anchor
        } else {
            transmitters.iter().sum::<Point<D>>() / transmitters.len() as f64
        };
        lift(&centre, (centre - self.anchor).norm())
    }

    /// `f_v(theta~) = 1/2 ||B theta~ - g||^2`.
    pub fn cost(&self, theta: &Lifted<L>) -> f64 {
        0.5 * self.residuals(theta).iter().map(|e| e * e).sum::<f64>()
    }

    /// The prox objective `f_v(theta~) + 1/(2 gamma) ||theta~ - u||^2`.
    pub fn prox_objective(&self, theta: &Lifted<L>, u: &Lifted<L>, gamma: f64) -> f64 {
        self.cost(theta) + (theta - u).norm_squared() / (2.0 * gamma)
    }

    /// Residuals `B theta~ - g`, one per row.
    pub fn residuals(&self, theta: &Lifted<L>) -> Vec<f64> {
        self.rows
            .iter()
            .zip(&self.g)
            .map(|(r, gi)| {
                // Left to right, as `r[0] th[0] + r[1] th[1] + ...`.
                let mut acc = r[0] * theta[0];
                for i in 1..L {
                    acc += r[i] * theta[i];
                }
                acc - gi
            })
            .collect()
    }

    /// The cone constraint of eq. (12): `||theta~[0:D] - r_v|| - theta~[D]`.
    pub fn cone_violation(&self, theta: &Lifted<L>) -> f64 {
        (crate::model::geometry::pos::<D, L>(theta) - self.anchor).norm() - theta[D]
    }
}

/// A row of `L` entries from the first `L` of `vals` (the 2-D and 3-D DOA
/// rows are written out in full; only the matching length is ever used).
fn row_of<const L: usize, const K: usize>(vals: [f64; K]) -> [f64; L] {
    let mut row = [0.0; L];
    for (r, v) in row.iter_mut().zip(vals) {
        *r = v;
    }
    row
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::geometry::{Vec2, Vec3};
    use crate::model::measure::{Geometry, SampleMeasurements, Sigmas};
    use approx::assert_relative_eq;

    #[test]
    fn the_first_fix_of_noise_free_rows_is_the_lifted_true_position() {
        let g = Geometry::mourya2017();
        let x = Vec2::new(512.0, 433.0);
        let s = SampleMeasurements::noise_free(&g, &x, true, false);
        for (v, r) in g.receivers.iter().enumerate() {
            // Two bistatic rows and two DOA rows: B theta~ = g at theta~ = [x, d].
            let p: LocalProblem = LocalProblem::build(*r, &g.transmitters, 1.0, &s.nodes[v]);
            let fix = p.first_fix(&g.transmitters);
            let want = Vec3::new(x.x, x.y, (x - r).norm());
            for k in 0..3 {
                // H = B^T B squares the conditioning of rows of scale 1e3 and 1.
                assert_relative_eq!(fix[k], want[k], max_relative = 1e-6);
            }
        }
    }

    #[test]
    fn noise_weights_divide_each_row_by_its_first_order_noise_std() {
        let g = Geometry::mourya2017();
        let x = Vec2::new(512.0, 433.0);
        let s = SampleMeasurements::noise_free(&g, &x, true, true);
        let sig = Sigmas {
            elevation: 0.0,
            range: 5.0,
            doa: 0.5,
        };
        let r = g.receivers[2];
        let plain: LocalProblem = LocalProblem::build(r, &g.transmitters, 2.0, &s.nodes[2]);
        let w: LocalProblem =
            LocalProblem::build_weighted(r, &g.transmitters, 2.0, &s.nodes[2], Some(&sig));
        assert_eq!(w.kinds, plain.kinds);
        // Noise-free data: the range estimate along the DOA ray is exact.
        let d = (x - r).norm();
        for (i, kind) in plain.kinds.iter().enumerate() {
            let div = match kind {
                RowKind::Bistatic(m) => 2.0 * s.nodes[2].bistatic[*m].1 * sig.range,
                RowKind::Doa(_) => 2.0 * d * sig.doa,
                RowKind::Range => sig.range,
            };
            for k in 0..3 {
                assert_relative_eq!(w.rows[i][k], plain.rows[i][k] / div, max_relative = 1e-9);
            }
            assert_relative_eq!(w.g[i], plain.g[i] / div, max_relative = 1e-9);
        }
        // Without sigmas, or with zero sigmas, nothing changes.
        assert_eq!(
            LocalProblem::build_weighted(r, &g.transmitters, 2.0, &s.nodes[2], None),
            plain
        );
        let zero = Sigmas {
            elevation: 0.0,
            range: 0.0,
            doa: 0.0,
        };
        assert_eq!(
            LocalProblem::build_weighted(r, &g.transmitters, 2.0, &s.nodes[2], Some(&zero)),
            plain
        );
    }

    #[test]
    fn a_node_with_fewer_than_three_rows_starts_at_the_transmitters_centroid() {
        let g = Geometry::mourya2017();
        let x = Vec2::new(512.0, 433.0);
        let s = SampleMeasurements::noise_free(&g, &x, false, false);
        let r = g.receivers[0];
        let p: LocalProblem = LocalProblem::build(r, &g.transmitters, 1.0, &s.nodes[0]);
        assert_eq!(p.rows.len(), 2);
        let c = Vec2::new(1000.0, 1000.0);
        assert_eq!(
            p.first_fix(&g.transmitters),
            Vec3::new(c.x, c.y, (c - r).norm())
        );
        // No transmitters and no rows: the receiver itself.
        assert_eq!(
            LocalProblem::<2, 3>::empty(r).first_fix(&[]),
            Vec3::new(r.x, r.y, 0.0)
        );
    }
}
