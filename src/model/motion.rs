//! Target motion models: the true track `x_k*`, `k = 0..samples`, in 2-D
//! or 3-D. The points of a model are written `[x, y]` or `[x, y, z]`
//! ([`Pt`]); [`Motion::track`] is generic over the dimension `D` and reads
//! them in `D` dimensions once the scenario has checked that they all have
//! `D` coordinates ([`Motion::points`]). Every 2-D track is computed by the
//! same arithmetic as before depth existed, bit for bit.

use crate::model::error::KeyError;
use crate::model::geometry::Point;
use crate::model::rng::SonarRng;
use crate::model::xy::Pt;
use rand::RngExt;
use serde::{Deserialize, Serialize};

/// A target motion model (`[target] motion = { model = "...", ... }`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case", deny_unknown_fields)]
pub enum Motion {
    /// Mourya 2017 Sec. III-C: `x = R cos t + x0`, `y = R sin t + y0`, then
    /// `R += dR`, `t += dt` after every sample. In 3-D a helix:
    /// `z = z0 + k dz` (`dz = 0`: at the fixed depth `z0`).
    Spiral {
        /// `[x0, y0]` or `[x0, y0, z0]`.
        center: Pt,
        /// Depth increment per sample `dz` (3-D only; default 0; negative
        /// descends, as `z` points up).
        #[serde(default, skip_serializing_if = "is_zero")]
        dz: f64,
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
        start: Pt,
        /// Displacement per sample.
        velocity: Pt,
    },
    /// A polyline traversed at constant speed: sample 0 at the first point,
    /// the last sample at the last point, linear interpolation by arc length.
    Waypoints {
        /// At least two points.
        points: Vec<Pt>,
    },
    /// Pun-So 2022 eq. (19): `x_{t+1} = x_t + c / sqrt(2 (t + 1)) u_t` with `u_t`
    /// uniform on the unit circle (the unit sphere in 3-D), `t = 1..T-1`
    /// (sample `k` is `t = k + 1`).
    RandomWalk {
        /// `x_1`.
        start: Pt,
        /// Step scale `c`.
        c: f64,
    },
    /// Pun-So 2020 Examples 1-2: `x_{t+1} = x_t + (-1)^{b_t} c / sqrt(2t) [1, 1]`
    /// (`[1, 1, 1]` in 3-D), `b_t ~ Bernoulli(1/2)` (sample `k` steps with
    /// `t = k + 1`).
    DiagonalWalk {
        /// Position at sample 0.
        start: Pt,
        /// Step scale `c` (Pun-So 2020: 0.0025).
        c: f64,
    },
    /// Pun-So 2020 Example 3: `x_{t+1} = x_t + d_t`, `d_t` uniform on `[-h, h]^D`.
    UniformBoxWalk {
        /// Position at sample 0.
        start: Pt,
        /// Half width `h` (Pun-So 2020: 0.0025).
        half_width: f64,
    },
    /// Gholami 2015 Fig. 11: `x_k = x0 + k dx`, `y_k = a x_k^2 + b x_k + c`;
    /// in 3-D at the fixed height `z`.
    QuadraticPath {
        /// `x` at sample 0.
        x0: f64,
        /// `x` increment per sample.
        dx: f64,
        /// `[a, b, c]` (Gholami 2015: `[-0.0004, 0.3, 10]`).
        coefficients: [f64; 3],
        /// The path's `z` (3-D only, where it is required).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        z: Option<f64>,
    },
    /// A target that does not move.
    Static {
        /// Its position.
        position: Pt,
    },
    /// A static target at a position drawn uniformly in the box `[min, max]`
    /// from the run seed (a new position for every Monte Carlo trial).
    UniformStatic {
        /// Lower corner.
        min: Pt,
        /// Upper corner.
        max: Pt,
    },
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// The point at arc length `s` along the polyline `pts` (segment lengths
/// `seg`), clamped to its ends; the one implementation of a walk along
/// waypoints (the target's [`Motion::Waypoints`], a receiver's
/// [`crate::model::drift::Drift::Waypoints`]).
pub fn point_along<const D: usize>(pts: &[Point<D>], seg: &[f64], mut s: f64) -> Point<D> {
    for (i, &len) in seg.iter().enumerate() {
        if s <= len || i + 1 == seg.len() {
            let a = if len > 0.0 { (s / len).min(1.0) } else { 0.0 };
            return pts[i] + (pts[i + 1] - pts[i]) * a;
        }
        s -= len;
    }
    pts[pts.len() - 1]
}

impl Motion {
    /// The model's points with their keys (under the motion's table), for
    /// the scenario's check that every point has its dimension; the
    /// quadratic path counts as 3-D when it gives `z`.
    pub fn points(&self) -> Vec<(String, Pt)> {
        let one = |k: &str, p: &Pt| vec![(k.to_string(), *p)];
        match self {
            Motion::Spiral { center, .. } => one("center", center),
            Motion::ConstantVelocity { start, velocity } => {
                let mut v = one("start", start);
                v.extend(one("velocity", velocity));
                v
            }
            Motion::Waypoints { points } => points
                .iter()
                .enumerate()
                .map(|(i, p)| (format!("points[{i}]"), *p))
                .collect(),
            Motion::RandomWalk { start, .. }
            | Motion::DiagonalWalk { start, .. }
            | Motion::UniformBoxWalk { start, .. } => one("start", start),
            Motion::QuadraticPath { z, .. } => vec![(
                "z".to_string(),
                match z {
                    Some(z) => Pt::xyz(0.0, 0.0, *z),
                    None => Pt::xy(0.0, 0.0),
                },
            )],
            Motion::Static { position } => one("position", position),
            Motion::UniformStatic { min, max } => {
                let mut v = one("min", min);
                v.extend(one("max", max));
                v
            }
        }
    }

    /// Check the parameters for a scenario of dimension `dim` (2 or 3); the
    /// [`KeyError`] names the key (under the motion's table) and why.
    pub fn validate(&self, dim: usize) -> Result<(), KeyError> {
        for (key, p) in self.points() {
            if p.dim() != dim {
                let why = if key == "z" && dim == 3 {
                    "a 3-D scenario needs the path's z".to_string()
                } else {
                    format!(
                        "the scenario is {dim}-D (its receivers have {dim} coordinates), \
                         this point has {}",
                        p.dim()
                    )
                };
                return Err(KeyError::new(&key, why));
            }
            if !p.is_finite() {
                return Err(KeyError::new(
                    &key,
                    format!("must be finite, got {:?}", p.coords()),
                ));
            }
        }
        let finite = |name: &str, v: &[f64]| {
            if v.iter().all(|x| x.is_finite()) {
                Ok(())
            } else {
                Err(KeyError::new(name, format!("must be finite, got {v:?}")))
            }
        };
        let non_negative = |name: &str, c: f64| {
            if c.is_finite() && c >= 0.0 {
                Ok(())
            } else {
                Err(KeyError::new(
                    name,
                    format!("must be finite and >= 0, got {c}"),
                ))
            }
        };
        match self {
            Motion::Spiral {
                r0, dr, t0, dt, dz, ..
            } => {
                finite("r0/dr/t0/dt", &[*r0, *dr, *t0, *dt])?;
                finite("dz", &[*dz])?;
                if dim == 2 && *dz != 0.0 {
                    return Err(KeyError::new(
                        "dz",
                        "a helix needs a 3-D scenario (center [x, y, z]); this one is 2-D",
                    ));
                }
                Ok(())
            }
            Motion::Waypoints { points } if points.len() < 2 => Err(KeyError::new(
                "points",
                format!("needs at least 2 entries, got {}", points.len()),
            )),
            Motion::RandomWalk { c, .. } | Motion::DiagonalWalk { c, .. } => non_negative("c", *c),
            Motion::UniformBoxWalk { half_width, .. } => non_negative("half_width", *half_width),
            Motion::QuadraticPath {
                x0,
                dx,
                coefficients,
                ..
            } => {
                finite("x0/dx", &[*x0, *dx])?;
                finite("coefficients", coefficients)
            }
            Motion::UniformStatic { min, max } => {
                if min.coords().iter().zip(max.coords()).all(|(a, b)| a <= b) {
                    Ok(())
                } else {
                    Err(KeyError::new(
                        "min",
                        format!("{:?} must be below max {:?}", min.coords(), max.coords()),
                    ))
                }
            }
            Motion::ConstantVelocity { .. } | Motion::Waypoints { .. } | Motion::Static { .. } => {
                Ok(())
            }
        }
    }

    fn walk<const D: usize>(
        start: &Pt,
        m: Walk,
        samples: usize,
        rng: &mut SonarRng,
    ) -> Vec<Point<D>> {
        let mut x = start.point::<D>();
        let mut out = Vec::with_capacity(samples);
        for k in 0..samples {
            out.push(x);
            x += m.displacement::<D, _>(k, rng);
        }
        out
    }

    /// The true positions at samples `0..samples` in `D` dimensions (the
    /// model's points have `D` coordinates: [`Motion::validate`]). `rng`
    /// drives random motion (derive it from the run seed with
    /// `Stream::Motion`).
    pub fn track<const D: usize>(&self, samples: usize, rng: &mut SonarRng) -> Vec<Point<D>> {
        match self {
            Motion::Spiral {
                center,
                r0,
                dr,
                t0,
                dt,
                dz,
            } => {
                let (mut r, mut t) = (*r0, *t0);
                let c = center.point::<D>();
                (0..samples)
                    .map(|k| {
                        let mut p = c;
                        p[0] = r * t.cos() + center[0];
                        p[1] = r * t.sin() + center[1];
                        if D == 3 {
                            p[2] = c[2] + k as f64 * dz;
                        }
                        r += dr;
                        t += dt;
                        p
                    })
                    .collect()
            }
            Motion::ConstantVelocity { start, velocity } => (0..samples)
                .map(|k| start.point::<D>() + velocity.point::<D>() * k as f64)
                .collect(),
            Motion::Waypoints { points } => {
                let pts: Vec<Point<D>> = points.iter().map(Pt::point::<D>).collect();
                let seg: Vec<f64> = pts.windows(2).map(|w| (w[1] - w[0]).norm()).collect();
                let total: f64 = seg.iter().sum();
                (0..samples)
                    .map(|k| {
                        let frac = if samples > 1 {
                            k as f64 / (samples - 1) as f64
                        } else {
                            0.0
                        };
                        point_along(&pts, &seg, frac * total)
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
                z,
            } => (0..samples)
                .map(|k| {
                    let x = x0 + k as f64 * dx;
                    Point::<D>::from_fn(|i, _| match i {
                        0 => x,
                        1 => a * x * x + b * x + c,
                        _ => z.unwrap_or(0.0),
                    })
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
                // Coordinates drawn in order x, y(, z).
                let (lo, hi) = (min.point::<D>(), max.point::<D>());
                let mut p = lo;
                for i in 0..D {
                    p[i] = draw(lo[i], hi[i]);
                }
                vec![p; samples]
            }
            Motion::Static { position } => vec![position.point::<D>(); samples],
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

    /// The random displacement `d_k` from 0-based position `k` to `k + 1`,
    /// in `D` = 2 or 3 dimensions. The circle's direction is `phi` uniform in
    /// `[0, 2 pi)`; the sphere's is Archimedes' `(sqrt(1 - w^2) cos phi,
    /// sqrt(1 - w^2) sin phi, w)` with `w` uniform in `[-1, 1]` (drawn after
    /// `phi`), which is uniform on the sphere.
    pub fn displacement<const D: usize, R: RngExt + ?Sized>(
        &self,
        k: usize,
        rng: &mut R,
    ) -> Point<D> {
        match *self {
            Walk::SqrtDecayCircle { c } => {
                let phi = rng.random_range(0.0..std::f64::consts::TAU);
                let (s, co) = phi.sin_cos();
                let scale = c / (2.0 * (k as f64 + 2.0)).sqrt();
                if D == 2 {
                    return Point::<D>::from_fn(|i, _| [co, s][i]) * scale;
                }
                let w: f64 = rng.random_range(-1.0..=1.0);
                let rho = (1.0 - w * w).max(0.0).sqrt();
                Point::<D>::from_fn(|i, _| [rho * co, rho * s, w][i]) * scale
            }
            Walk::SqrtDecayDiagonal { c } => {
                let sign = if rng.random_bool(0.5) { -1.0 } else { 1.0 };
                let a = sign * c / (2.0 * (k as f64 + 1.0)).sqrt();
                Point::<D>::repeat(a)
            }
            Walk::UniformBox { half_width: h } => {
                if h > 0.0 {
                    Point::<D>::from_fn(|_, _| rng.random_range(-h..=h))
                } else {
                    Point::<D>::zeros()
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::geometry::Vec2;
    use crate::model::rng::{Stream, stream_rng};
    use approx::assert_relative_eq;

    #[test]
    fn the_spiral_starts_at_its_centre_and_grows_by_dr_per_sample() {
        let m = Motion::Spiral {
            center: Pt::from([500.0, 500.0]),
            r0: 0.0,
            dr: 2.5,
            t0: 0.0,
            dt: 0.25,
            dz: 0.0,
        };
        let tr = m.track::<2>(5, &mut stream_rng(0, Stream::Motion, 0));
        assert_relative_eq!(tr[0].x, 500.0);
        assert_relative_eq!(tr[0].y, 500.0);
        let k: f64 = 4.0;
        assert_relative_eq!(tr[4].x, 2.5 * k * (0.25 * k).cos() + 500.0, epsilon = 1e-12);
        assert_relative_eq!(tr[4].y, 2.5 * k * (0.25 * k).sin() + 500.0, epsilon = 1e-12);
    }

    #[test]
    fn waypoints_are_hit_at_the_ends_and_interpolated_by_arc_length() {
        let m = Motion::Waypoints {
            points: vec![[0.0, 0.0].into(), [10.0, 0.0].into(), [10.0, 10.0].into()],
        };
        let tr = m.track::<2>(5, &mut stream_rng(0, Stream::Motion, 0));
        assert_relative_eq!(tr[0], Vec2::new(0.0, 0.0));
        assert_relative_eq!(tr[2], Vec2::new(10.0, 0.0), epsilon = 1e-12);
        assert_relative_eq!(tr[3], Vec2::new(10.0, 5.0), epsilon = 1e-12);
        assert_relative_eq!(tr[4], Vec2::new(10.0, 10.0), epsilon = 1e-12);
    }

    #[test]
    fn random_walk_steps_have_the_length_of_eq_19() {
        let m = Motion::RandomWalk {
            start: Pt::from([2.0, 1.0]),
            c: 0.005,
        };
        let tr = m.track::<2>(50, &mut stream_rng(3, Stream::Motion, 0));
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
            start: Pt::from([2.0, 1.0]),
            c: 0.0025,
        };
        let tr = m.track::<2>(20, &mut stream_rng(1, Stream::Motion, 0));
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
            start: Pt::from([2.0, 1.0]),
            half_width: 0.0025,
        };
        let tr = m.track::<2>(200, &mut stream_rng(1, Stream::Motion, 0));
        assert!(tr.windows(2).all(|w| (w[1] - w[0]).amax() <= 0.0025));
    }

    #[test]
    fn the_quadratic_path_and_uniform_static_target_follow_their_definitions() {
        let m = Motion::QuadraticPath {
            x0: 0.0,
            dx: 10.0,
            coefficients: [-0.0004, 0.3, 10.0],
            z: None,
        };
        let tr = m.track::<2>(3, &mut stream_rng(0, Stream::Motion, 0));
        assert_relative_eq!(tr[2], Vec2::new(20.0, -0.0004 * 400.0 + 6.0 + 10.0));
        let u = Motion::UniformStatic {
            min: Pt::from([0.0, 0.0]),
            max: Pt::from([100.0, 50.0]),
        };
        let a = u.track::<2>(4, &mut stream_rng(0, Stream::Motion, 0));
        let b = u.track::<2>(4, &mut stream_rng(1, Stream::Motion, 0));
        assert!(a.iter().all(|p| *p == a[0]));
        assert!(a[0].x >= 0.0 && a[0].x < 100.0 && a[0].y >= 0.0 && a[0].y < 50.0);
        assert!((a[0] - b[0]).norm() > 0.0);
    }

    #[test]
    fn constant_velocity_and_static_tracks_are_exact() {
        let cv = Motion::ConstantVelocity {
            start: Pt::from([1.0, 2.0]),
            velocity: Pt::from([0.5, -1.0]),
        };
        let tr = cv.track::<2>(3, &mut stream_rng(0, Stream::Motion, 0));
        assert_relative_eq!(tr[2], Vec2::new(2.0, 0.0));
        let st = Motion::Static {
            position: Pt::from([3.0, 4.0]),
        };
        assert_eq!(
            st.track::<2>(2, &mut stream_rng(0, Stream::Motion, 0))
                .len(),
            2
        );
    }

    #[test]
    fn bad_parameters_are_rejected_with_the_key_name() {
        let m = Motion::Waypoints {
            points: vec![[0.0, 0.0].into()],
        };
        assert_eq!(m.validate(2).unwrap_err().key, "points");
        let m = Motion::RandomWalk {
            start: Pt::from([0.0, f64::NAN]),
            c: 1.0,
        };
        assert_eq!(m.validate(2).unwrap_err().key, "start");
    }

    #[test]
    fn the_3d_spiral_is_a_helix_with_dz_per_sample_over_the_2d_spiral() {
        let helix = Motion::Spiral {
            center: Pt::xyz(500.0, 400.0, -100.0),
            r0: 10.0,
            dr: 2.5,
            t0: 0.3,
            dt: 0.25,
            dz: -4.0,
        };
        helix.validate(3).expect("valid helix");
        let flat = Motion::Spiral {
            center: Pt::xy(500.0, 400.0),
            r0: 10.0,
            dr: 2.5,
            t0: 0.3,
            dt: 0.25,
            dz: 0.0,
        };
        let h = helix.track::<3>(30, &mut stream_rng(0, Stream::Motion, 0));
        let f = flat.track::<2>(30, &mut stream_rng(0, Stream::Motion, 0));
        for (k, (p, q)) in h.iter().zip(&f).enumerate() {
            // The plan view is the 2-D spiral, bit for bit.
            assert_eq!(p[0].to_bits(), q[0].to_bits());
            assert_eq!(p[1].to_bits(), q[1].to_bits());
            assert_relative_eq!(p[2], -100.0 - 4.0 * k as f64, epsilon = 1e-12);
        }
    }

    #[test]
    fn a_3d_random_walk_steps_by_eq_19_in_directions_spread_over_the_sphere() {
        let m = Motion::RandomWalk {
            start: Pt::xyz(2.0, 1.0, -3.0),
            c: 0.005,
        };
        let tr = m.track::<3>(4001, &mut stream_rng(5, Stream::Motion, 0));
        let mut mean = Point::<3>::zeros();
        let mut second = [0.0; 3];
        for k in 0..4000 {
            let d = tr[k + 1] - tr[k];
            let len = 0.005 / (2.0 * (k as f64 + 2.0)).sqrt();
            assert_relative_eq!(d.norm(), len, epsilon = 1e-15);
            let u = d / len;
            mean += u / 4000.0;
            for i in 0..3 {
                second[i] += u[i] * u[i] / 4000.0;
            }
        }
        // Uniform on the sphere: mean 0 and E[u_i^2] = 1/3 per axis (the
        // standard errors are 0.009 and 0.0047; 5 of them allowed).
        assert!(mean.amax() < 0.045, "{mean:?}");
        assert!(
            second.iter().all(|s| (s - 1.0 / 3.0).abs() < 0.024),
            "{second:?}"
        );
    }

    #[test]
    fn a_3d_box_walk_diagonal_walk_and_uniform_static_target_use_every_axis() {
        let b = Motion::UniformBoxWalk {
            start: Pt::xyz(0.0, 0.0, 0.0),
            half_width: 1.0,
        };
        let tr = b.track::<3>(300, &mut stream_rng(2, Stream::Motion, 0));
        assert!(tr.windows(2).all(|w| (w[1] - w[0]).amax() <= 1.0));
        assert!(tr.windows(2).any(|w| (w[1][2] - w[0][2]).abs() > 0.5));
        let d = Motion::DiagonalWalk {
            start: Pt::xyz(0.0, 0.0, 0.0),
            c: 1.0,
        };
        let tr = d.track::<3>(5, &mut stream_rng(2, Stream::Motion, 0));
        let step = tr[1] - tr[0];
        assert_relative_eq!(step[2], step[0]);
        assert_relative_eq!(step[0].abs(), 1.0 / 2f64.sqrt());
        let u = Motion::UniformStatic {
            min: Pt::xyz(0.0, 0.0, -200.0),
            max: Pt::xyz(100.0, 50.0, -100.0),
        };
        let p = u.track::<3>(3, &mut stream_rng(0, Stream::Motion, 0))[0];
        assert!((-200.0..-100.0).contains(&p[2]), "{p:?}");
        let q = Motion::QuadraticPath {
            x0: 0.0,
            dx: 10.0,
            coefficients: [0.0, 1.0, 0.0],
            z: Some(-7.0),
        };
        assert_relative_eq!(
            q.track::<3>(2, &mut stream_rng(0, Stream::Motion, 0))[1][2],
            -7.0
        );
    }

    #[test]
    fn points_of_the_wrong_dimension_a_2d_helix_and_a_3d_path_without_z_are_named() {
        let m = Motion::Waypoints {
            points: vec![Pt::xyz(0.0, 0.0, 0.0), Pt::xy(1.0, 1.0)],
        };
        let e = m.validate(3).expect_err("mixed");
        assert_eq!(e.key, "points[1]");
        assert!(
            e.reason.contains("3-D") && e.reason.contains("has 2"),
            "{e:?}"
        );
        let m = Motion::Spiral {
            center: Pt::xy(0.0, 0.0),
            r0: 0.0,
            dr: 1.0,
            t0: 0.0,
            dt: 0.1,
            dz: -1.0,
        };
        assert_eq!(m.validate(2).expect_err("2-D helix").key, "dz");
        let q = Motion::QuadraticPath {
            x0: 0.0,
            dx: 1.0,
            coefficients: [0.0; 3],
            z: None,
        };
        assert_eq!(q.validate(3).expect_err("no z").key, "z");
        q.validate(2).expect("a 2-D path needs no z");
    }
}
