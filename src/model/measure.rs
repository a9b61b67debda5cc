//! Measurements seen by one receiver at one sample.

use serde::{Deserialize, Serialize};

/// What receiver `n` measured at one sample. Only that receiver's own data:
/// this is exactly what the coordinator sends to node `n`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct NodeMeasurements {
    /// Bistatic ranges `rho_{m,n} = ||theta - t_m|| + ||theta - r_n|| + noise`
    /// as `(transmitter index m, rho)`.
    pub bistatic: Vec<(usize, f64)>,
    /// Direction of arrival `phi_n = atan2(theta_y - r_ny, theta_x - r_nx) + noise` (radians):
    /// the azimuth in 3-D.
    pub doa: Option<f64>,
    /// The DOA's elevation in 3-D, `atan2(theta_z - r_nz, ||(theta - r_n)_xy||) + noise`
    /// (radians, positive toward `+z`); `None` in 2-D.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub elevation: Option<f64>,
    /// One-way range `||theta - r_n|| + noise` (TOA), if measured.
    pub range: Option<f64>,
}

impl NodeMeasurements {
    /// Drop what no receiver of a network with `transmitters` transmitters
    /// can have measured: a bistatic range naming an unknown transmitter,
    /// and any value that is not finite (what a corrupted or hostile frame
    /// could carry). Returns how many values were dropped; measurements the
    /// coordinator synthesized or read from a checked trace lose nothing.
    pub fn retain_valid(&mut self, transmitters: usize) -> usize {
        let before = self.bistatic.len();
        self.bistatic
            .retain(|&(m, v)| m < transmitters && v.is_finite());
        let mut dropped = before - self.bistatic.len();
        for v in [&mut self.doa, &mut self.elevation, &mut self.range] {
            if v.is_some_and(|x| !x.is_finite()) {
                *v = None;
                dropped += 1;
            }
        }
        dropped
    }

    /// True when the receiver measured nothing at this sample.
    pub fn is_empty(&self) -> bool {
        self.bistatic.is_empty()
            && self.doa.is_none()
            && self.elevation.is_none()
            && self.range.is_none()
    }
}

use crate::model::drift::Drift;
use crate::model::geometry::{Point, Vec2};
use std::borrow::Cow;

/// Fixed positions of the network: transmitters `t_m` and receivers `r_n`
/// (the receivers are the nodes of the gossip graph), in `D` = 2 or 3
/// dimensions.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Geometry<const D: usize = 2> {
    /// Transmitter positions `t_m` (may be empty for a pure TOA network).
    pub transmitters: Vec<Point<D>>,
    /// Receiver positions `r_n` (at sample 0 for a receiver that drifts).
    pub receivers: Vec<Point<D>>,
    /// How the receivers drift ([`crate::model::drift`]): empty when none
    /// does, else one entry per receiver (`None`: it stays put). Positions
    /// at a sample: [`Geometry::at`].
    #[serde(skip)]
    pub drift: Vec<Option<Drift>>,
}

impl<const D: usize> Geometry<D> {
    /// Fixed transmitters and receivers.
    pub fn new(transmitters: Vec<Point<D>>, receivers: Vec<Point<D>>) -> Self {
        Geometry {
            transmitters,
            receivers,
            drift: Vec::new(),
        }
    }

    /// The same geometry with receivers drifting as `drift` says (one entry
    /// per receiver, or empty: [`crate::model::drift::resolve`]).
    pub fn with_drift(mut self, drift: Vec<Option<Drift>>) -> Self {
        self.drift = drift;
        self
    }

    /// Whether any receiver moves.
    pub fn drifts(&self) -> bool {
        self.drift.iter().any(Option::is_some)
    }

    /// Receiver `n`'s position at sample `k` (`r_n` if it does not drift).
    pub fn receiver_at(&self, n: usize, k: usize) -> Point<D> {
        match self.drift.get(n) {
            Some(Some(d)) => d.position(&self.receivers[n], k),
            _ => self.receivers[n],
        }
    }

    /// Samples of a run of `samples` samples at which every distance between
    /// two receivers takes its largest value: `[0]` when nothing drifts;
    /// else the first and last samples and those either side of every
    /// waypoint (between them every receiver moves on a straight line, so
    /// each distance is convex there and largest at an end).
    pub fn extreme_samples(&self, samples: usize) -> Vec<usize> {
        if !self.drifts() {
            return vec![0];
        }
        let mut out = vec![0, samples.saturating_sub(1)];
        for (n, d) in self.drift.iter().enumerate() {
            if let Some(d) = d {
                out.extend(d.turns(&self.receivers[n], samples));
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The positions at sample `k`, as a fixed geometry: this one itself
    /// when no receiver drifts. Everything that works on one sample
    /// (measurement synthesis, the centralised estimators, the baselines,
    /// the bounds, the CRLB) is given the geometry of that sample.
    pub fn at(&self, k: usize) -> Cow<'_, Geometry<D>> {
        if !self.drifts() {
            return Cow::Borrowed(self);
        }
        Cow::Owned(Geometry::new(
            self.transmitters.clone(),
            (0..self.receivers.len())
                .map(|n| self.receiver_at(n, k))
                .collect(),
        ))
    }

    /// The centroid of every sensor, receivers and transmitters alike (the
    /// origin for an empty geometry): POCS's first starting point.
    pub fn centroid(&self) -> Point<D> {
        let n = self.receivers.len() + self.transmitters.len();
        self.receivers
            .iter()
            .chain(&self.transmitters)
            .fold(Point::<D>::zeros(), |s, p| s + *p)
            / n.max(1) as f64
    }

    /// The body of a scenario's `[geometry]` table:
    /// `transmitters = [[x, y], ...]` and `receivers = [[x, y], ...]`
    /// (`[x, y, z]` in 3-D).
    pub fn toml_table(&self) -> String {
        let list = |ps: &[Point<D>]| {
            let items: Vec<String> = ps
                .iter()
                .map(|p| {
                    let cs: Vec<String> = p.iter().map(|c| format!("{c:?}")).collect();
                    format!("[{}]", cs.join(", "))
                })
                .collect();
            format!("[{}]", items.join(", "))
        };
        format!(
            "transmitters = {}\nreceivers = {}",
            list(&self.transmitters),
            list(&self.receivers)
        )
    }
}

impl Geometry<2> {
    /// The network of Mourya 2017 Sec. III-C (Fig. 1): transmitters at `(0, 0)`
    /// and `(2000, 2000)` m, six receivers around them. The one copy of it for
    /// tests and benches (`scenarios/mourya2017-spiral.toml` states it too).
    pub fn mourya2017() -> Self {
        Geometry::new(
            vec![Vec2::new(0.0, 0.0), Vec2::new(2000.0, 2000.0)],
            vec![
                Vec2::new(-1000.0, -1000.0),
                Vec2::new(1500.0, -1000.0),
                Vec2::new(-1000.0, 1000.0),
                Vec2::new(1500.0, 1000.0),
                Vec2::new(1500.0, 2500.0),
                Vec2::new(2500.0, 1500.0),
            ],
        )
    }
}

/// Every receiver's measurements at one sample; `nodes[n]` belongs to receiver `n`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SampleMeasurements {
    /// Per-receiver measurements, indexed by node id.
    pub nodes: Vec<NodeMeasurements>,
}

impl SampleMeasurements {
    /// What every receiver measures of a target at `x` without noise: the
    /// bistatic range from each transmitter (Mourya 2017 eq. 1), and the DOA
    /// (eq. 2) and one-way range where asked for. For tests and examples
    /// that need exact data.
    /// In 3-D the DOA is an azimuth and an elevation.
    pub fn noise_free<const D: usize>(
        geometry: &Geometry<D>,
        x: &Point<D>,
        with_doa: bool,
        with_range: bool,
    ) -> Self {
        SampleMeasurements {
            nodes: geometry
                .receivers
                .iter()
                .map(|r| NodeMeasurements {
                    bistatic: geometry
                        .transmitters
                        .iter()
                        .enumerate()
                        .map(|(m, t)| (m, bistatic_range(x, t, r)))
                        .collect(),
                    doa: with_doa.then(|| doa(x, r)),
                    elevation: (with_doa && D == 3).then(|| elevation(x, r)),
                    range: with_range.then(|| one_way_range(x, r)),
                })
                .collect(),
        }
    }
}

/// Noise standard deviations of one sample, as the centralised estimators
/// weight them (`1/sigma^2`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Sigmas {
    /// Bistatic and one-way range noise (metres).
    pub range: f64,
    /// DOA noise (radians; the azimuth's in 3-D).
    pub doa: f64,
    /// Elevation noise in 3-D (radians); 0 in 2-D.
    #[serde(default)]
    pub elevation: f64,
}

impl Sigmas {
    /// These sigmas with any value that is not finite and `>= 0` (what a
    /// corrupted frame could carry) set to 0, which weights nothing.
    pub fn valid(self) -> Sigmas {
        let ok = |v: f64| if v.is_finite() && v >= 0.0 { v } else { 0.0 };
        Sigmas {
            range: ok(self.range),
            doa: ok(self.doa),
            elevation: ok(self.elevation),
        }
    }
}

/// Noise-free bistatic range `||x - t|| + ||x - r||`.
pub fn bistatic_range<const D: usize>(x: &Point<D>, t: &Point<D>, r: &Point<D>) -> f64 {
    (x - t).norm() + (x - r).norm()
}

/// Noise-free one-way range `||x - a||`.
pub fn one_way_range<const D: usize>(x: &Point<D>, a: &Point<D>) -> f64 {
    (x - a).norm()
}

/// Noise-free DOA `atan2(x_y - r_y, x_x - r_x)` at receiver `r` (the azimuth in 3-D).
pub fn doa<const D: usize>(x: &Point<D>, r: &Point<D>) -> f64 {
    (x[1] - r[1]).atan2(x[0] - r[0])
}

/// Noise-free elevation `atan2(x_z - r_z, ||(x - r)_xy||)` at receiver `r`
/// (radians in `[-pi/2, pi/2]`, positive toward `+z`); 0 in 2-D.
pub fn elevation<const D: usize>(x: &Point<D>, r: &Point<D>) -> f64 {
    if D < 3 {
        return 0.0;
    }
    let (dx, dy) = (x[0] - r[0], x[1] - r[1]);
    (x[2] - r[2]).atan2(dx.hypot(dy))
}

/// The unit direction of azimuth `az` and elevation `el` (`el` ignored in
/// 2-D): `[cos el cos az, cos el sin az, sin el]`, `[cos az, sin az]` in 2-D.
pub fn direction<const D: usize>(az: f64, el: f64) -> Point<D> {
    let (sa, ca) = az.sin_cos();
    if D < 3 {
        return Point::<D>::from_fn(|i, _| if i == 0 { ca } else { sa });
    }
    let (se, ce) = el.sin_cos();
    Point::<D>::from_fn(|i, _| match i {
        0 => ce * ca,
        1 => ce * sa,
        _ => se,
    })
}

/// Wrap an angle to `(-pi, pi]`.
pub fn wrap_angle(a: f64) -> f64 {
    let two_pi = 2.0 * std::f64::consts::PI;
    let mut w = a.rem_euclid(two_pi);
    if w > std::f64::consts::PI {
        w -= two_pi;
    }
    w
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn the_measured_direction_and_range_give_back_the_target_in_2d_and_3d() {
        let r3 = Point::<3>::new(-100.0, 50.0, 300.0);
        for x3 in [
            Point::<3>::new(400.0, -250.0, 120.0),
            Point::<3>::new(-300.0, 60.0, 900.0),
            Point::<3>::new(-100.0, 50.0, 10.0),
        ] {
            let e = direction::<3>(doa(&x3, &r3), elevation(&x3, &r3));
            assert_relative_eq!(e.norm(), 1.0, max_relative = 1e-15);
            assert_relative_eq!(r3 + e * one_way_range(&x3, &r3), x3, max_relative = 1e-12);
        }
        let (r2, x2) = (Vec2::new(1.0, 2.0), Vec2::new(-3.0, 7.0));
        let e = direction::<2>(doa(&x2, &r2), 0.3);
        assert_relative_eq!(r2 + e * one_way_range(&x2, &r2), x2, max_relative = 1e-12);
        assert_eq!(elevation(&x2, &r2).to_bits(), 0.0f64.to_bits());
    }

    #[test]
    fn a_3d_receiver_measures_an_elevation_only_with_a_doa() {
        let g = Geometry::<3> {
            drift: Vec::new(),
            transmitters: vec![Point::<3>::new(0.0, 0.0, 0.0)],
            receivers: vec![Point::<3>::new(10.0, 0.0, 20.0)],
        };
        let x = Point::<3>::new(10.0, 10.0, 30.0);
        let with = SampleMeasurements::noise_free(&g, &x, true, false);
        // 45 degrees below the receiver's horizontal plane toward +z.
        assert_relative_eq!(
            with.nodes[0].elevation.expect("3-D DOA"),
            std::f64::consts::FRAC_PI_4,
            max_relative = 1e-15
        );
        let without = SampleMeasurements::noise_free(&g, &x, false, true);
        assert!(without.nodes[0].doa.is_none() && without.nodes[0].elevation.is_none());
        assert!(
            SampleMeasurements::noise_free(&Geometry::mourya2017(), &Vec2::zeros(), true, false)
                .nodes
                .iter()
                .all(|n| n.elevation.is_none())
        );
    }

    #[test]
    fn a_measurement_no_receiver_can_have_made_is_dropped_and_the_rest_kept_bit_for_bit() {
        let mut m = NodeMeasurements {
            bistatic: vec![(0, 1500.0), (255, 10.0), (1, f64::NAN), (1, 2100.5)],
            doa: Some(f64::INFINITY),
            elevation: Some(0.25),
            range: Some(900.0),
        };
        assert_eq!(m.retain_valid(2), 3);
        assert_eq!(m.bistatic.len(), 2);
        assert_eq!(m.bistatic[0].1.to_bits(), 1500.0f64.to_bits());
        assert_eq!(m.bistatic[1].1.to_bits(), 2100.5f64.to_bits());
        assert!(m.doa.is_none());
        assert!(m.elevation.is_some() && m.range.is_some());
        // A valid set loses nothing.
        let mut ok = m.clone();
        assert_eq!(ok.retain_valid(2), 0);
        assert_eq!(ok, m);
        let s = Sigmas {
            range: f64::NAN,
            doa: -1.0,
            elevation: 0.2,
        }
        .valid();
        assert_eq!(
            [s.range, s.doa, s.elevation].map(f64::to_bits),
            [0.0, 0.0, 0.2].map(f64::to_bits)
        );
    }
}
