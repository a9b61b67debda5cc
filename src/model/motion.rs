//! Target motion models: the true track `x_k*`, `k = 0..samples`.

use crate::model::error::KeyError;
use crate::model::geometry::{Vec2, v2};
use crate::model::rng::SonarRng;
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// A target motion model (`[target] motion = { model = "...", ... }`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case", deny_unknown_fields)]
pub enum Motion {
    /// Mourya 2017 Sec. III-C: `x = R cos t + x0`, `y = R sin t + y0`, then
    /// `R += dR`, `t += dt` after every sample.
    Spiral {
        /// `[x0, y0]`.
        #[serde(with = "crate::model::xy")]
        center: [f64; 2],
        /// Initial radius `R` (default 0: the track starts at the centre).
        #[serde(default)]
        r0: f64,
        /// Radius increment per sample `dR`.
        dr: f64,
        /// Initial angle `t` (radians, default 0).
        #[serde(default)]
        t0: f64,
        /// Angle increment per sample `dt` (radians).
        dt: f64,
    },
    /// `x_k = start + k * velocity` (velocity in metres per sample).
    ConstantVelocity {
        /// Position at sample 0.
        #[serde(with = "crate::model::xy")]
        start: [f64; 2],
        /// Displacement per sample.
        #[serde(with = "crate::model::xy")]
        velocity: [f64; 2],
    },
    /// A polyline traversed at constant speed: sample 0 at the first point,
    /// the last sample at the last point, linear interpolation by arc length.
    Waypoints {
        /// At least two points.
        #[serde(with = "crate::model::xy::list")]
        points: Vec<[f64; 2]>,
    },
    /// Pun-So 2022 eq. (19): `x_{t+1} = x_t + c / sqrt(2 (t + 1)) u_t` with `u_t`
    /// uniform on the unit circle, `t = 1..T-1` (sample `k` is `t = k + 1`).
    RandomWalk {
        /// `x_1`.
        #[serde(with = "crate::model::xy")]
        start: [f64; 2],
        /// Step scale `c`.
        c: f64,
    },
    /// Pun-So 2020 Examples 1-2: `x_{t+1} = x_t + (-1)^{b_t} c / sqrt(2t) [1, 1]`,
    /// `b_t ~ Bernoulli(1/2)` (sample `k` steps with `t = k + 1`).
    DiagonalWalk {
        /// Position at sample 0.
        #[serde(with = "crate::model::xy")]
        start: [f64; 2],
        /// Step scale `c` (Pun-So 2020: 0.0025).
        c: f64,
    },
    /// Pun-So 2020 Example 3: `x_{t+1} = x_t + d_t`, `d_t` uniform on `[-h, h]^2`.
    UniformBoxWalk {
        /// Position at sample 0.
        #[serde(with = "crate::model::xy")]
        start: [f64; 2],
        /// Half width `h` (Pun-So 2020: 0.0025).
        half_width: f64,
    },
    /// Gholami 2015 Fig. 11: `x_k = x0 + k dx`, `y_k = a x_k^2 + b x_k + c`.
    QuadraticPath {
        /// `x` at sample 0.
        x0: f64,
        /// `x` increment per sample.
        dx: f64,
        /// `[a, b, c]` (Gholami 2015: `[-0.0004, 0.3, 10]`).
        coefficients: [f64; 3],
    },
    /// A target that does not move.
    Static {
        /// Its position.
        #[serde(with = "crate::model::xy")]
        position: [f64; 2],
    },
    /// A static target at a position drawn uniformly in the box `[min, max]`
    /// from the run seed (a new position for every Monte Carlo trial).
    UniformStatic {
        /// Lower corner.
        #[serde(with = "crate::model::xy")]
        min: [f64; 2],
        /// Upper corner.
        #[serde(with = "crate::model::xy")]
        max: [f64; 2],
    },
}

impl Motion {
    /// Check the parameters; the [`KeyError`] names the key (under the
    /// motion's table) and why.
    pub fn validate(&self) -> Result<(), KeyError> {
        let finite = |name: &str, v: &[f64]| {
            if v.iter().all(|x| x.is_finite()) {
                Ok(())
            } else {
                Err(KeyError::new(name, format!("must be finite, got {v:?}")))
            }
        };
        match self {
            Motion::Spiral {
                center,
                r0,
                dr,
                t0,
                dt,
            } => {
                finite("center", center)?;
                finite("r0/dr/t0/dt", &[*r0, *dr, *t0, *dt])
            }
            Motion::ConstantVelocity { start, velocity } => {
                finite("start", start)?;
                finite("velocity", velocity)
            }
            Motion::Waypoints { points } => {
                if points.len() < 2 {
                    return Err(KeyError::new(
                        "points",
                        format!("needs at least 2 entries, got {}", points.len()),
                    ));
                }
                for p in points {
                    finite("points", p)?;
                }
                Ok(())
            }
            Motion::RandomWalk { start, c } => {
                finite("start", start)?;
                if !(c.is_finite() && *c >= 0.0) {
                    return Err(KeyError::new(
                        "c",
                        format!("must be finite and >= 0, got {c}"),
                    ));
                }
                Ok(())
            }
            Motion::DiagonalWalk { start, c } => {
                finite("start", start)?;
                if !(c.is_finite() && *c >= 0.0) {
                    return Err(KeyError::new(
                        "c",
                        format!("must be finite and >= 0, got {c}"),
                    ));
                }
                Ok(())
            }
            Motion::UniformBoxWalk { start, half_width } => {
                finite("start", start)?;
                if !(half_width.is_finite() && *half_width >= 0.0) {
                    return Err(KeyError::new(
                        "half_width",
                        format!("must be finite and >= 0, got {half_width}"),
                    ));
                }
                Ok(())
            }
            Motion::QuadraticPath {
                x0,
                dx,
                coefficients,
            } => {
                finite("x0/dx", &[*x0, *dx])?;
                finite("coefficients", coefficients)
            }
            Motion::Static { position } => finite("position", position),
            Motion::UniformStatic { min, max } => {
                finite("min", min)?;
                finite("max", max)?;
                if min[0] <= max[0] && min[1] <= max[1] {
                    Ok(())
                } else {
                    Err(KeyError::new(
                        "min",
                        format!("{min:?} must be below max {max:?}"),
                    ))
                }
            }
        }
    }

    fn walk(start: &[f64; 2], m: Walk, samples: usize, rng: &mut SonarRng) -> Vec<Vec2> {
        let mut x = v2(*start);
        let mut out = Vec::with_capacity(samples);
        for k in 0..samples {
            out.push(x);
            x += m.displacement(k, rng);
        }
        out
    }

    /// The true positions at samples `0..samples`. `rng` drives random motion
    /// (derive it from the run seed with `Stream::Motion`).
    pub fn track(&self, samples: usize, rng: &mut SonarRng) -> Vec<Vec2> {
        match self {
            Motion::Spiral {
                center,
                r0,
                dr,
                t0,
                dt,
            } => {
                let (mut r, mut t) = (*r0, *t0);
                (0..samples)
                    .map(|_| {
                        let p = Vec2::new(r * t.cos() + center[0], r * t.sin() + center[1]);
                        r += dr;
                        t += dt;
                        p
                    })
                    .collect()
            }
            Motion::ConstantVelocity { start, velocity } => (0..samples)
                .map(|k| v2(*start) + v2(*velocity) * k as f64)
                .collect(),
            Motion::Waypoints { points } => {
                let pts: Vec<Vec2> = points.iter().map(|p| v2(*p)).collect();
                let seg: Vec<f64> = pts.windows(2).map(|w| (w[1] - w[0]).norm()).collect();
                let total: f64 = seg.iter().sum();
                (0..samples)
                    .map(|k| {
                        let frac = if samples > 1 {
                            k as f64 / (samples - 1) as f64
                        } else {
                            0.0
                        };
                        let mut s = frac * total;
                        for (i, &len) in seg.iter().enumerate() {
                            if s <= len || i + 1 == seg.len() {
                                let a = if len > 0.0 { (s / len).min(1.0) } else { 0.0 };
                                return pts[i] + (pts[i + 1] - pts[i]) * a;
                            }
                            s -= len;
                        }
                        pts[pts.len() - 1]
                    })
                    .collect()
            }
            // The displacements are the library's one implementation of seed
            // 000 eq. (19) and Pun-So 2020 Sec. V ([`Walk`]).
            Motion::RandomWalk { start, c } => {
                Self::walk(start, Walk::SqrtDecayCircle { c: *c }, samples, rng)
            }
            Motion::DiagonalWalk { start, c } => {
                Self::walk(start, Walk::SqrtDecayDiagonal { c: *c }, samples, rng)
            }
            Motion::UniformBoxWalk { start, half_width } => Self::walk(
                start,
                Walk::UniformBox {
                    half_width: *half_width,
                },
                samples,
                rng,
            ),
            Motion::QuadraticPath {
                x0,
                dx,
                coefficients: [a, b, c],
            } => (0..samples)
                .map(|k| {
                    let x = x0 + k as f64 * dx;
                    Vec2::new(x, a * x * x + b * x + c)
                })
                .collect(),
            Motion::UniformStatic { min, max } => {
                let mut draw = |lo: f64, hi: f64| {
                    if hi > lo {
                        rng.random_range(lo..hi)
                    } else {
                        lo
                    }
                };
                let p = Vec2::new(draw(min[0], max[0]), draw(min[1], max[1]));
                vec![p; samples]
            }
            Motion::Static { position } => vec![v2(*position); samples],
        }
    }
}

/// Random target motions of Pun-So 2022 Sec. V and Pun-So 2020 Sec. V. Every
/// variant is a random walk `x_{k+1} = x_k + d_k` on 0-based positions
/// `k = 0, 1, ...` (the first position is the given start).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Walk {
    /// Pun-So 2022 eq. (19): `x_{t+1}^* = x_t^* + c / sqrt(2(t+1)) u_t` with
    /// 1-based `t` and `u_t` uniform on the unit circle; i.e.
    /// `||d_k|| = c / sqrt(2(k+2))`. Sec. V-A: `c = 0.005`; Sec. V-B: `0.1`, `0.5`.
    SqrtDecayCircle {
        /// Scale `c`.
        c: f64,
    },
    /// Pun-So 2020 Examples 1-2: `d_t = (-1)^{b_t} c / sqrt(2t) [1, 1]`,
    /// `b_t ~ Bernoulli(1/2)`, with `c = 0.0025`. The paper indexes `t` from 0,
    /// which divides by zero; here step `k` (0-based) uses `t = k + 1`.
    SqrtDecayDiagonal {
        /// Scale `c`.
        c: f64,
    },
    /// Pun-So 2020 Example 3: `d_t` uniform on `[-h, h]^2` (`h = 0.0025`).
    UniformBox {
        /// Half width `h`.
        half_width: f64,
    },
}

impl Walk {
    /// The scale `c` or half width `h`.
    pub fn scale(&self) -> f64 {
        match *self {
            Walk::SqrtDecayCircle { c } | Walk::SqrtDecayDiagonal { c } => c,
            Walk::UniformBox { half_width } => half_width,
        }
    }

    /// The random displacement `d_k` from 0-based position `k` to `k + 1`.
    pub fn displacement<R: RngExt + ?Sized>(&self, k: usize, rng: &mut R) -> Vec2 {
        match *self {
            Walk::SqrtDecayCircle { c } => {
                let phi = rng.random_range(0.0..std::f64::consts::TAU);
                let (s, co) = phi.sin_cos();
                Vec2::new(co, s) * (c / (2.0 * (k as f64 + 2.0)).sqrt())
            }
            Walk::SqrtDecayDiagonal { c } => {
                let sign = if rng.random_bool(0.5) { -1.0 } else { 1.0 };
                let a = sign * c / (2.0 * (k as f64 + 1.0)).sqrt();
                Vec2::new(a, a)
            }
            Walk::UniformBox { half_width: h } => {
                if h > 0.0 {
                    Vec2::new(rng.random_range(-h..=h), rng.random_range(-h..=h))
                } else {
                    Vec2::zeros()
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::rng::{Stream, stream_rng};
    use approx::assert_relative_eq;

    #[test]
    fn the_spiral_starts_at_its_centre_and_grows_by_dr_per_sample() {
        let m = Motion::Spiral {
            center: [500.0, 500.0],
            r0: 0.0,
            dr: 2.5,
            t0: 0.0,
            dt: 0.25,
        };
        let tr = m.track(5, &mut stream_rng(0, Stream::Motion, 0));
        assert_relative_eq!(tr[0].x, 500.0);
        assert_relative_eq!(tr[0].y, 500.0);
        let k: f64 = 4.0;
        assert_relative_eq!(tr[4].x, 2.5 * k * (0.25 * k).cos() + 500.0, epsilon = 1e-12);
        assert_relative_eq!(tr[4].y, 2.5 * k * (0.25 * k).sin() + 500.0, epsilon = 1e-12);
    }

    #[test]
    fn waypoints_are_hit_at_the_ends_and_interpolated_by_arc_length() {
        let m = Motion::Waypoints {
            points: vec![[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]],
        };
        let tr = m.track(5, &mut stream_rng(0, Stream::Motion, 0));
        assert_relative_eq!(tr[0], Vec2::new(0.0, 0.0));
        assert_relative_eq!(tr[2], Vec2::new(10.0, 0.0), epsilon = 1e-12);
        assert_relative_eq!(tr[3], Vec2::new(10.0, 5.0), epsilon = 1e-12);
        assert_relative_eq!(tr[4], Vec2::new(10.0, 10.0), epsilon = 1e-12);
    }

    #[test]
    fn random_walk_steps_have_the_length_of_eq_19() {
        let m = Motion::RandomWalk {
            start: [2.0, 1.0],
            c: 0.005,
        };
        let tr = m.track(50, &mut stream_rng(3, Stream::Motion, 0));
        assert_relative_eq!(tr[0], Vec2::new(2.0, 1.0));
        for k in 0..49 {
            let t = (k + 1) as f64;
            assert_relative_eq!(
                (tr[k + 1] - tr[k]).norm(),
                0.005 / (2.0 * (t + 1.0)).sqrt(),
                epsilon = 1e-15
            );
        }
    }

    #[test]
    fn seed_001_walks_take_diagonal_and_boxed_steps() {
        let m = Motion::DiagonalWalk {
            start: [2.0, 1.0],
            c: 0.0025,
        };
        let tr = m.track(20, &mut stream_rng(1, Stream::Motion, 0));
        for k in 0..19 {
            let d = tr[k + 1] - tr[k];
            assert_relative_eq!(d.x, d.y);
            assert_relative_eq!(
                d.x.abs(),
                0.0025 / (2.0 * (k + 1) as f64).sqrt(),
                epsilon = 1e-15
            );
        }
        let m = Motion::UniformBoxWalk {
            start: [2.0, 1.0],
            half_width: 0.0025,
        };
        let tr = m.track(200, &mut stream_rng(1, Stream::Motion, 0));
        assert!(tr.windows(2).all(|w| (w[1] - w[0]).amax() <= 0.0025));
    }

    #[test]
    fn the_quadratic_path_and_uniform_static_target_follow_their_definitions() {
        let m = Motion::QuadraticPath {
            x0: 0.0,
            dx: 10.0,
            coefficients: [-0.0004, 0.3, 10.0],
        };
        let tr = m.track(3, &mut stream_rng(0, Stream::Motion, 0));
        assert_relative_eq!(tr[2], Vec2::new(20.0, -0.0004 * 400.0 + 6.0 + 10.0));
        let u = Motion::UniformStatic {
            min: [0.0, 0.0],
            max: [100.0, 50.0],
        };
        let a = u.track(4, &mut stream_rng(0, Stream::Motion, 0));
        let b = u.track(4, &mut stream_rng(1, Stream::Motion, 0));
        assert!(a.iter().all(|p| *p == a[0]));
        assert!(a[0].x >= 0.0 && a[0].x < 100.0 && a[0].y >= 0.0 && a[0].y < 50.0);
        assert!((a[0] - b[0]).norm() > 0.0);
    }

    #[test]
    fn constant_velocity_and_static_tracks_are_exact() {
        let cv = Motion::ConstantVelocity {
            start: [1.0, 2.0],
            velocity: [0.5, -1.0],
        };
        let tr = cv.track(3, &mut stream_rng(0, Stream::Motion, 0));
        assert_relative_eq!(tr[2], Vec2::new(2.0, 0.0));
        let st = Motion::Static {
            position: [3.0, 4.0],
        };
        assert_eq!(st.track(2, &mut stream_rng(0, Stream::Motion, 0)).len(), 2);
    }

    #[test]
    fn bad_parameters_are_rejected_with_the_key_name() {
        let m = Motion::Waypoints {
            points: vec![[0.0, 0.0]],
        };
        assert_eq!(m.validate().unwrap_err().key, "points");
        let m = Motion::RandomWalk {
            start: [0.0, f64::NAN],
            c: 1.0,
        };
        assert_eq!(m.validate().unwrap_err().key, "start");
    }
}
