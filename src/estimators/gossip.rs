//! The Douglas-Rachford gossip itself (seed 002 Sec. II-B, eq. 7 and 11):
//! its [`Mode`], the consensus averages and the update of `u`. Every node
//! core computes them here, so both ends of an exchange and every engine give
//! bit-identical values.

use crate::model::geometry::{Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// Gossip mode of the Douglas-Rachford engine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Mode {
    /// Every node updates every iteration; positions averaged over all nodes.
    Sync,
    /// One random edge `(v, w)` per iteration (seed 002 eq. 11).
    Async,
}

impl Mode {
    /// Lower-case name as used in files.
    pub fn as_str(self) -> &'static str {
        match self {
            Mode::Sync => "sync",
            Mode::Async => "async",
        }
    }
}

/// The average `a = (r_v[0:2] + r_w[0:2]) / 2` of a pairwise exchange
/// (seed 002 eq. 11, second line). IEEE addition is commutative, so both
/// ends compute bit-identical values.
pub fn pair_average(r_a: &Vec3, r_b: &Vec3) -> Vec2 {
    Vec2::new((r_a[0] + r_b[0]) / 2.0, (r_a[1] + r_b[1]) / 2.0)
}

/// The sync consensus average: the mean of the position parts of all
/// reflected points, summed in node-id order.
pub fn mean_position<'a>(rs: impl Iterator<Item = &'a Vec3>) -> Vec2 {
    let mut s = Vec2::zeros();
    let mut n = 0usize;
    for r in rs {
        s.x += r[0];
        s.y += r[1];
        n += 1;
    }
    s / n.max(1) as f64
}

/// The DR update `u += z - theta` with `z = (a, r[2])` (seed 002 eq. 7 / 11).
pub fn dr_update(u: &mut Vec3, theta: &Vec3, r: &Vec3, a: Vec2) {
    let z = Vec3::new(a.x, a.y, r[2]);
    *u += z - theta;
}
