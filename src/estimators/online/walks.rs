//! The target trajectories of Pun-So 2022 eq. (19) and Pun-So 2020 Sec. V, from the random
//! walks of [`crate::model::motion::Walk`].

use crate::estimators::online::TrackError;
use crate::estimators::online::check_x0;
use crate::model::geometry::Vec2;
use crate::model::motion::Walk;
use rand::RngExt;

/// `len` positions of the random walk `walk` starting at `start` (`len = 0`
/// gives an empty vector).
pub fn walk_trajectory<R: RngExt + ?Sized>(
    walk: Walk,
    start: Vec2,
    len: usize,
    rng: &mut R,
) -> Result<Vec<Vec2>, TrackError> {
    let scale = walk.scale();
    if !(scale.is_finite() && scale >= 0.0) {
        return Err(TrackError::BadParameter {
            name: "motion scale",
            reason: format!("must be finite and >= 0, got {scale}"),
        });
    }
    check_x0(&start)?;
    let mut out = Vec::with_capacity(len);
    if len == 0 {
        return Ok(out);
    }
    let mut x = start;
    out.push(x);
    for k in 0..len - 1 {
        x += walk.displacement(k, rng);
        out.push(x);
    }
    Ok(out)
}

/// Pun-So 2022 eq. (19) trajectory of `len` positions from `start` (a shorthand
/// for [`Walk::SqrtDecayCircle`]).
pub fn trajectory_eq19<R: RngExt + ?Sized>(
    start: Vec2,
    c: f64,
    len: usize,
    rng: &mut R,
) -> Result<Vec<Vec2>, TrackError> {
    walk_trajectory(Walk::SqrtDecayCircle { c }, start, len, rng)
}
