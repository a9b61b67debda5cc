//! Receivers that drift: a sonobuoy field carried by the current, or AUVs
//! on their survey lines (`[[geometry.drift]]`).
//!
//! A drifting receiver starts at its listed position `r_n` (sample 0) and
//! moves with the sample index `k`, like the target's motion models:
//! - `velocity = v`: `r_n(k) = r_n + k v` (metres per sample);
//! - `waypoints = [w_1, ...]`, `speed = s`: along the polyline
//!   `r_n, w_1, w_2, ...` at `s` metres per sample (arc length `k s`),
//!   holding at the last waypoint once it is reached.
//!
//! Both the measurement model (the true positions synthesize the data) and
//! the node (its anchor `r_v` in the local cost of Mourya 2017 eq. (9)-(10))
//! use the position at each sample, computed by [`Drift::position`]; a
//! receiver is taken to know where it is (a buoy's GPS fix, an AUV's
//! navigation). The gossip graph does not change over a run.

use crate::model::error::KeyError;
use crate::model::geometry::Point;
use crate::model::motion::point_along;
use crate::model::xy::Pt;
use serde::{Deserialize, Serialize};

/// Most waypoints of one receiver's drift.
pub const MAX_WAYPOINTS: usize = 10_000;

/// One `[[geometry.drift]]` entry as written: the receiver and either
/// `velocity`, or `waypoints` with `speed`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriftCfg {
    /// The receiver's index in `geometry.receivers` (0-based).
    pub receiver: usize,
    /// Displacement per sample (metres), `[vx, vy]` or `[vx, vy, vz]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity: Option<Pt>,
    /// Points to visit after the receiver's own position, in order.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub waypoints: Option<Vec<Pt>>,
    /// Speed along the waypoints (metres per sample, > 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed: Option<f64>,
}

/// How a receiver moves, checked ([`DriftCfg::validate`]); its points have
/// the scenario's dimension.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Drift {
    /// `r_n(k) = r_n + k v`.
    Velocity {
        /// `v`, metres per sample.
        velocity: Pt,
    },
    /// Along `r_n, points...` at `speed` metres per sample.
    Waypoints {
        /// The waypoints after the start.
        points: Vec<Pt>,
        /// Metres per sample.
        speed: f64,
    },
}

impl DriftCfg {
    /// The checked drift of a receiver in a `dim`-D scenario of `receivers`
    /// receivers; the [`KeyError`] names the key under the entry.
    pub fn validate(&self, dim: usize, receivers: usize) -> Result<Drift, KeyError> {
        if self.receiver >= receivers {
            return Err(KeyError::new(
                "receiver",
                format!(
                    "is {}, the scenario has {receivers} receivers (indices 0..{})",
                    self.receiver,
                    receivers.saturating_sub(1)
                ),
            ));
        }
        let point = |key: &str, p: &Pt| {
            if p.dim() != dim {
                Err(KeyError::new(
                    key,
                    format!("has {} coordinates, the scenario is {dim}-D", p.dim()),
                ))
            } else if !p.is_finite() {
                Err(KeyError::new(
                    key,
                    format!("must be finite, got {:?}", p.coords()),
                ))
            } else {
                Ok(*p)
            }
        };
        match (&self.velocity, &self.waypoints, self.speed) {
            (Some(v), None, None) => Ok(Drift::Velocity {
                velocity: point("velocity", v)?,
            }),
            (None, Some(w), Some(speed)) => {
                if w.is_empty() || w.len() > MAX_WAYPOINTS {
                    return Err(KeyError::new(
                        "waypoints",
                        format!("needs 1 to {MAX_WAYPOINTS} points, got {}", w.len()),
                    ));
                }
                if !(speed.is_finite() && speed > 0.0) {
                    return Err(KeyError::new(
                        "speed",
                        format!("must be finite and > 0 (metres per sample), got {speed}"),
                    ));
                }
                let points = w
                    .iter()
                    .enumerate()
                    .map(|(i, p)| point(&format!("waypoints[{i}]"), p))
                    .collect::<Result<_, _>>()?;
                Ok(Drift::Waypoints { points, speed })
            }
            (None, Some(_), None) => Err(KeyError::new(
                "speed",
                "waypoints need a speed (metres per sample)",
            )),
            (Some(_), None, Some(_)) => Err(KeyError::new(
                "speed",
                "speed goes with waypoints; a velocity gives its own",
            )),
            (None, None, _) => Err(KeyError::new(
                "velocity",
                "give velocity = [...], or waypoints = [[...], ...] and speed",
            )),
            (Some(_), Some(_), _) => Err(KeyError::new(
                "waypoints",
                "give either velocity or waypoints, not both",
            )),
        }
    }
}

impl Drift {
    /// [`Drift::position`] on the dimension-free coordinates of the
    /// protocol and the channel (2 or 3, `start`'s).
    pub fn position_pt(&self, start: &Pt, k: usize) -> Pt {
        match start.dim() {
            3 => Pt::of(&self.position(&start.point::<3>(), k)),
            _ => Pt::of(&self.position(&start.point::<2>(), k)),
        }
    }

    /// The samples in `0..samples` around which this drift turns: the two
    /// samples either side of each waypoint reached (none for a velocity).
    /// Between them the receiver moves on a straight line at constant speed.
    pub fn turns<const D: usize>(&self, start: &Point<D>, samples: usize) -> Vec<usize> {
        let Drift::Waypoints { points, speed } = self else {
            return Vec::new();
        };
        let mut out = Vec::new();
        let mut at = *start;
        let mut length = 0.0;
        for p in points {
            let q = p.point::<D>();
            length += (q - at).norm();
            at = q;
            let k = length / speed;
            for s in [k.floor(), k.ceil()] {
                if s.is_finite() && s >= 0.0 && (s as usize) < samples {
                    out.push(s as usize);
                }
            }
        }
        out
    }

    /// The position at sample `k` of a receiver that starts at `start`.
    pub fn position<const D: usize>(&self, start: &Point<D>, k: usize) -> Point<D> {
        match self {
            Drift::Velocity { velocity } => start + velocity.point::<D>() * k as f64,
            Drift::Waypoints { points, speed } => {
                let pts: Vec<Point<D>> = std::iter::once(*start)
                    .chain(points.iter().map(Pt::point::<D>))
                    .collect();
                let seg: Vec<f64> = pts.windows(2).map(|w| (w[1] - w[0]).norm()).collect();
                point_along(&pts, &seg, speed * k as f64)
            }
        }
    }
}

/// The checked `[[geometry.drift]]` of a scenario: one entry per receiver
/// (`None` for those that stay put), or empty when none drifts. The
/// [`KeyError`] names `geometry.drift[i].KEY`.
pub fn resolve(
    cfgs: &[DriftCfg],
    dim: usize,
    receivers: usize,
) -> Result<Vec<Option<Drift>>, KeyError> {
    if cfgs.is_empty() {
        return Ok(Vec::new());
    }
    let mut out = vec![None; receivers];
    for (i, c) in cfgs.iter().enumerate() {
        let d = c
            .validate(dim, receivers)
            .map_err(|e| e.under(&format!("geometry.drift[{i}]")))?;
        if out[c.receiver].is_some() {
            return Err(KeyError::new(
                format!("geometry.drift[{i}].receiver"),
                format!("receiver {} already drifts in an earlier entry", c.receiver),
            ));
        }
        out[c.receiver] = Some(d);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::geometry::{Vec2, Vec3};
    use approx::assert_relative_eq;

    #[test]
    fn a_velocity_moves_the_receiver_k_steps_from_its_start() {
        let d = Drift::Velocity {
            velocity: Pt::xyz(0.5, -0.25, -1.0),
        };
        let p = d.position(&Vec3::new(10.0, 20.0, -30.0), 8);
        assert_relative_eq!(p, Vec3::new(14.0, 18.0, -38.0), epsilon = 1e-12);
    }

    #[test]
    fn waypoints_are_followed_at_their_speed_and_the_last_one_is_held() {
        let d = Drift::Waypoints {
            points: vec![Pt::xy(3.0, 0.0), Pt::xy(3.0, 4.0)],
            speed: 2.0,
        };
        let start = Vec2::new(0.0, 0.0);
        // 7 m of path: 3 along x, then 4 along y.
        assert_relative_eq!(d.position(&start, 0), start, epsilon = 1e-12);
        assert_relative_eq!(d.position(&start, 1), Vec2::new(2.0, 0.0), epsilon = 1e-12);
        assert_relative_eq!(d.position(&start, 2), Vec2::new(3.0, 1.0), epsilon = 1e-12);
        assert_relative_eq!(d.position(&start, 3), Vec2::new(3.0, 3.0), epsilon = 1e-12);
        for k in [4, 5, 1000] {
            assert_relative_eq!(d.position(&start, k), Vec2::new(3.0, 4.0), epsilon = 1e-12);
        }
    }

    #[test]
    fn the_samples_where_distances_peak_are_the_ends_and_either_side_of_each_waypoint() {
        let d = Drift::Waypoints {
            points: vec![Pt::xy(3.0, 0.0), Pt::xy(3.0, 4.0)],
            speed: 2.0,
        };
        // 3 m then 7 m of path at 2 m a sample: samples 1.5 and 3.5.
        assert_eq!(d.turns(&Vec2::new(0.0, 0.0), 10), vec![1, 2, 3, 4]);
        let g = crate::model::measure::Geometry::new(
            vec![],
            vec![Vec2::new(0.0, 0.0), Vec2::new(9.0, 9.0)],
        );
        assert_eq!(g.extreme_samples(10), vec![0]);
        let g = g.with_drift(vec![Some(d), None]);
        assert_eq!(g.extreme_samples(10), vec![0, 1, 2, 3, 4, 9]);
        // Receiver 0 goes to (3, 4) and holds: at sample 9 it is there.
        assert_relative_eq!(g.at(9).receivers[0], Vec2::new(3.0, 4.0), epsilon = 1e-12);
        assert_eq!(
            Drift::Velocity {
                velocity: Pt::xyz(1.0, 0.0, -1.0)
            }
            .position_pt(&Pt::xyz(0.0, 0.0, -5.0), 3),
            Pt::xyz(3.0, 0.0, -8.0)
        );
    }

    fn cfg(receiver: usize) -> DriftCfg {
        DriftCfg {
            receiver,
            velocity: None,
            waypoints: None,
            speed: None,
        }
    }

    #[test]
    fn an_entry_is_refused_with_its_key_when_it_is_incomplete_or_out_of_range() {
        let at = |cfgs: &[DriftCfg], dim| resolve(cfgs, dim, 3).unwrap_err().key;
        assert_eq!(at(&[cfg(0)], 2), "geometry.drift[0].velocity");
        assert_eq!(at(&[cfg(5)], 2), "geometry.drift[0].receiver");
        let wp = DriftCfg {
            waypoints: Some(vec![Pt::xy(1.0, 1.0)]),
            ..cfg(1)
        };
        assert_eq!(at(std::slice::from_ref(&wp), 2), "geometry.drift[0].speed");
        let slow = DriftCfg {
            speed: Some(0.0),
            ..wp.clone()
        };
        assert_eq!(at(&[slow], 2), "geometry.drift[0].speed");
        let v = DriftCfg {
            velocity: Some(Pt::xy(1.0, 0.0)),
            ..cfg(1)
        };
        assert_eq!(
            at(std::slice::from_ref(&v), 3),
            "geometry.drift[0].velocity"
        );
        assert_eq!(at(&[v.clone(), v], 2), "geometry.drift[1].receiver");
        let flat = DriftCfg {
            waypoints: Some(vec![Pt::xy(1.0, 1.0), Pt::xyz(0.0, 0.0, 1.0)]),
            speed: Some(1.0),
            ..cfg(0)
        };
        assert_eq!(at(&[flat], 2), "geometry.drift[0].waypoints[1]");
    }

    #[test]
    fn receivers_without_an_entry_stay_put() {
        let v = DriftCfg {
            velocity: Some(Pt::xy(1.0, 0.0)),
            ..cfg(1)
        };
        let d = resolve(&[v], 2, 3).unwrap();
        assert!(d[0].is_none() && d[1].is_some() && d[2].is_none());
        assert!(resolve(&[], 2, 3).unwrap().is_empty());
    }
}
