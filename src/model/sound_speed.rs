//! A depth-dependent speed of sound, and a path's travel time through it.
//!
//! Mackenzie (1981), "Nine-term equation for sound speed in the oceans",
//! J. Acoust. Soc. Am. 70(3), 807-812, for temperature `T` (degrees C),
//! salinity `S` (psu) and depth `D` (m):
//!
//! `c = 1448.96 + 4.591 T - 5.304e-2 T^2 + 2.374e-4 T^3 + 1.340 (S - 35)
//!    + 1.630e-2 D + 1.675e-7 D^2 - 1.025e-2 T (S - 35) - 7.139e-13 T D^3`
//!
//! m/s, stated for `T` in [2, 30], `S` in [25, 40], `D` in [0, 8000] (its
//! check value: 1550.744 m/s at 25 degrees C, 35 psu, 1000 m). With `T` and
//! `S` the same throughout the water column, the speed varies with depth
//! only, and a straight path of length `L` from depth `z_a` to `z_b` takes
//!
//! `t = L / (z_b - z_a) * integral_{z_a}^{z_b} dz / c(z)`
//!
//! (the path's depth is linear in its length), `L / c(z_a)` when it is
//! level. The integral is taken by Simpson's rule on 64 intervals, exact to
//! rounding for a speed this smooth. Rays do not bend here: the straight
//! path is the one the channel's other terms (distance, spreading) use.

use crate::model::error::{KeyError, in_range};
use crate::model::xy::Pt;
use serde::{Deserialize, Serialize};

/// `[channel] sound_speed_profile`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case", deny_unknown_fields)]
pub enum SoundSpeedProfile {
    /// Mackenzie 1981 (module docs).
    Mackenzie {
        /// Temperature, degrees C, in [-2, 40].
        temperature_c: f64,
        /// Salinity, psu, in [0, 45].
        salinity_psu: f64,
        /// The depth of a 2-D scenario's nodes, m, in [0, 12000] (a 3-D
        /// scenario takes each node's own, `-z`).
        #[serde(default)]
        depth_m: f64,
    },
}

/// Mackenzie 1981's speed of sound, m/s (module docs).
pub fn mackenzie_m_per_s(t: f64, s: f64, d: f64) -> f64 {
    1448.96 + 4.591 * t - 5.304e-2 * t * t
        + 2.374e-4 * t * t * t
        + 1.340 * (s - 35.0)
        + 1.630e-2 * d
        + 1.675e-7 * d * d
        - 1.025e-2 * t * (s - 35.0)
        - 7.139e-13 * t * d * d * d
}

/// Simpson intervals of the travel-time integral.
const INTERVALS: usize = 64;

impl SoundSpeedProfile {
    /// Checks the numbers; the [`KeyError`] names the key.
    pub fn validate(&self) -> Result<(), KeyError> {
        let SoundSpeedProfile::Mackenzie {
            temperature_c,
            salinity_psu,
            depth_m,
        } = *self;
        let key = |k: &str| format!("channel.sound_speed_profile.{k}");
        in_range(&key("temperature_c"), temperature_c, -2.0, 40.0)?;
        in_range(&key("salinity_psu"), salinity_psu, 0.0, 45.0)?;
        in_range(&key("depth_m"), depth_m, 0.0, 12_000.0)
    }

    /// The speed at depth `d` (m, positive down).
    pub fn speed(&self, d: f64) -> f64 {
        let SoundSpeedProfile::Mackenzie {
            temperature_c,
            salinity_psu,
            ..
        } = *self;
        mackenzie_m_per_s(temperature_c, salinity_psu, d)
    }

    /// A node's depth: `-z` in 3-D (0 above the surface), `depth_m` in 2-D.
    fn depth(&self, p: &Pt) -> f64 {
        let SoundSpeedProfile::Mackenzie { depth_m, .. } = *self;
        if p.dim() == 3 {
            (-p[2]).max(0.0)
        } else {
            depth_m
        }
    }

    /// Seconds along the straight path from `a` to `b` (module docs).
    pub fn travel_time_s(&self, a: &Pt, b: &Pt) -> f64 {
        let l = a.distance(b);
        let (za, zb) = (self.depth(a), self.depth(b));
        if (zb - za).abs() <= 1e-9 * l.max(1.0) {
            return l / self.speed(0.5 * (za + zb));
        }
        let h = (zb - za) / INTERVALS as f64;
        let mut sum = 0.0;
        for k in 0..=INTERVALS {
            let w = if k == 0 || k == INTERVALS {
                1.0
            } else if k % 2 == 1 {
                4.0
            } else {
                2.0
            };
            sum += w / self.speed(za + h * k as f64);
        }
        l / (zb - za) * (sum * h / 3.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn profile(t: f64, s: f64) -> SoundSpeedProfile {
        SoundSpeedProfile::Mackenzie {
            temperature_c: t,
            salinity_psu: s,
            depth_m: 0.0,
        }
    }

    #[test]
    fn mackenzie_gives_its_published_check_value() {
        // Mackenzie 1981: 1550.744 m/s at 25 degrees C, 35 psu, 1000 m.
        assert_relative_eq!(
            mackenzie_m_per_s(25.0, 35.0, 1000.0),
            1550.744,
            epsilon = 5e-4
        );
    }

    #[test]
    fn a_level_path_takes_its_length_over_the_speed_at_its_depth() {
        let p = profile(10.0, 35.0);
        let (a, b) = (Pt::xyz(0.0, 0.0, -200.0), Pt::xyz(3000.0, 4000.0, -200.0));
        assert_relative_eq!(
            p.travel_time_s(&a, &b),
            5000.0 / mackenzie_m_per_s(10.0, 35.0, 200.0),
            max_relative = 1e-14
        );
    }

    #[test]
    fn a_slanted_path_takes_the_mean_slowness_along_its_depths() {
        // From 10 m to 4000 m deep over 5 km: against a midpoint sum of the
        // slowness along the path on 200000 pieces (which shares nothing with
        // Simpson's rule but the speed).
        let p = profile(4.0, 35.0);
        let (a, b) = (Pt::xyz(0.0, 0.0, -10.0), Pt::xyz(3000.0, 0.0, -4000.0));
        let l = a.distance(&b);
        let n = 200_000;
        let brute: f64 = (0..n)
            .map(|k| {
                let z = 10.0 + (4000.0 - 10.0) * (k as f64 + 0.5) / n as f64;
                l / n as f64 / mackenzie_m_per_s(4.0, 35.0, z)
            })
            .sum();
        assert_relative_eq!(p.travel_time_s(&a, &b), brute, max_relative = 1e-10);
        // Deeper water is faster here: the path beats the surface speed.
        assert!(p.travel_time_s(&a, &b) < l / mackenzie_m_per_s(4.0, 35.0, 10.0));
        assert_relative_eq!(
            p.travel_time_s(&a, &b),
            p.travel_time_s(&b, &a),
            max_relative = 1e-14
        );
    }

    #[test]
    fn out_of_range_water_is_refused_naming_the_key() {
        let e = profile(60.0, 35.0).validate().expect_err("too hot");
        assert_eq!(e.key, "channel.sound_speed_profile.temperature_c");
        assert!(profile(10.0, 35.0).validate().is_ok());
    }
}
