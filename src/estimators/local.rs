//! The local least-squares cost of one receiver, seed 002 eq. (9)-(10).
//!
//! For node `v` with lifted variable `theta~ = [x, y, d]` (`d = ||theta - r_v||`):
//!
//! * one row per bistatic range `rho_{m,v}`: `[2 (t_m - r_v)^T, -2 rho_{m,v}]`,
//!   `g = ||t_m||^2 - rho_{m,v}^2 - ||r_v||^2`;
//! * two DOA rows: `omega [1, 0, -cos phi]`, `omega [0, 1, -sin phi]`,
//!   `g = omega x_r`, `omega y_r`;
//! * one row per one-way range `r_v` (TOA, seed 000): `[0, 0, 1]`, `g = r_v`.
//!
//! `f_v(theta~) = 1/2 ||B_v theta~ - g_v||^2`.

use crate::model::geometry::{Mat3, Vec2, Vec3};
use crate::model::measure::NodeMeasurements;

/// What kind of measurement produced a row of `B_v` (used by robust solvers
/// and diagnostics).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowKind {
    /// Bistatic range through transmitter `m`.
    Bistatic(usize),
    /// First (cos) or second (sin) DOA row.
    Doa(u8),
    /// One-way range.
    Range,
}

/// The local cost `f_v(theta~) = 1/2 ||B theta~ - g||^2` of one node, with the
/// normal-equation data `H = B^T B`, `c = B^T g` precomputed for the prox.
#[derive(Debug, Clone, PartialEq)]
pub struct LocalProblem {
    /// Receiver position `r_v` (apex of the cone constraint, eq. 12).
    pub anchor: Vec2,
    /// Rows of `B_v`.
    pub rows: Vec<[f64; 3]>,
    /// Entries of `g_v`, one per row.
    pub g: Vec<f64>,
    /// Which measurement each row came from.
    pub kinds: Vec<RowKind>,
    /// `H = B^T B`.
    pub h: Mat3,
    /// `c = B^T g`.
    pub c: Vec3,
    /// `||g||^2`.
    pub g_sq: f64,
}

impl LocalProblem {
    /// Assemble `B_v`, `g_v` of eq. (9) for receiver `anchor` from its own
    /// measurements. `transmitters` are all transmitter positions `t_m`;
    /// `omega` is the DOA weight.
    pub fn build(
        anchor: Vec2,
        transmitters: &[Vec2],
        omega: f64,
        meas: &NodeMeasurements,
    ) -> LocalProblem {
        let mut rows = Vec::with_capacity(meas.bistatic.len() + 3);
        let mut g = Vec::with_capacity(rows.capacity());
        let mut kinds = Vec::with_capacity(rows.capacity());
        let r_sq = anchor.norm_squared();
        for &(m, rho) in &meas.bistatic {
            let t = transmitters[m];
            rows.push([2.0 * (t.x - anchor.x), 2.0 * (t.y - anchor.y), -2.0 * rho]);
            g.push(t.norm_squared() - rho * rho - r_sq);
            kinds.push(RowKind::Bistatic(m));
        }
        if let Some(phi) = meas.doa {
            let (s, c) = phi.sin_cos();
            rows.push([omega, 0.0, -omega * c]);
            g.push(omega * anchor.x);
            kinds.push(RowKind::Doa(0));
            rows.push([0.0, omega, -omega * s]);
            g.push(omega * anchor.y);
            kinds.push(RowKind::Doa(1));
        }
        if let Some(r) = meas.range {
            rows.push([0.0, 0.0, 1.0]);
            g.push(r);
            kinds.push(RowKind::Range);
        }
        Self::from_rows(anchor, rows, g, kinds)
    }

    /// Build from explicit rows (used by tests and robust solvers that drop rows).
    pub fn from_rows(
        anchor: Vec2,
        rows: Vec<[f64; 3]>,
        g: Vec<f64>,
        kinds: Vec<RowKind>,
    ) -> LocalProblem {
        let mut h = Mat3::zeros();
        let mut c = Vec3::zeros();
        let mut g_sq = 0.0;
        for (row, &gi) in rows.iter().zip(&g) {
            let b = Vec3::new(row[0], row[1], row[2]);
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
    pub fn empty(anchor: Vec2) -> LocalProblem {
        Self::from_rows(anchor, Vec::new(), Vec::new(), Vec::new())
    }

    /// `f_v(theta~) = 1/2 ||B theta~ - g||^2`.
    pub fn cost(&self, theta: &Vec3) -> f64 {
        0.5 * self.residuals(theta).iter().map(|e| e * e).sum::<f64>()
    }

    /// The prox objective `f_v(theta~) + 1/(2 gamma) ||theta~ - u||^2`.
    pub fn prox_objective(&self, theta: &Vec3, u: &Vec3, gamma: f64) -> f64 {
        self.cost(theta) + (theta - u).norm_squared() / (2.0 * gamma)
    }

    /// Residuals `B theta~ - g`, one per row.
    pub fn residuals(&self, theta: &Vec3) -> Vec<f64> {
        self.rows
            .iter()
            .zip(&self.g)
            .map(|(r, gi)| r[0] * theta[0] + r[1] * theta[1] + r[2] * theta[2] - gi)
            .collect()
    }

    /// The cone constraint of eq. (12): `||theta~[0:2] - r_v|| - theta~[2]`.
    pub fn cone_violation(&self, theta: &Vec3) -> f64 {
        (Vec2::new(theta[0], theta[1]) - self.anchor).norm() - theta[2]
    }
}
