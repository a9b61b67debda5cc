//! Measurements seen by one receiver at one sample.

use serde::{Deserialize, Serialize};

/// What receiver `n` measured at one sample. Only that receiver's own data:
/// this is exactly what the coordinator sends to node `n`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct NodeMeasurements {
    /// Bistatic ranges `rho_{m,n} = ||theta - t_m|| + ||theta - r_n|| + noise`
    /// as `(transmitter index m, rho)`.
    pub bistatic: Vec<(usize, f64)>,
    /// Direction of arrival `phi_n = atan2(theta_y - r_ny, theta_x - r_nx) + noise` (radians).
    pub doa: Option<f64>,
    /// One-way range `||theta - r_n|| + noise` (TOA), if measured.
    pub range: Option<f64>,
}

impl NodeMeasurements {
    /// True when the receiver measured nothing at this sample.
    pub fn is_empty(&self) -> bool {
        self.bistatic.is_empty() && self.doa.is_none() && self.range.is_none()
    }
}

use crate::model::geometry::Vec2;

/// Fixed positions of the network: transmitters `t_m` and receivers `r_n`
/// (the receivers are the nodes of the gossip graph).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Geometry {
    /// Transmitter positions `t_m` (may be empty for a pure TOA network).
    pub transmitters: Vec<Vec2>,
    /// Receiver positions `r_n`.
    pub receivers: Vec<Vec2>,
}

impl Geometry {
    /// The network of Mourya 2017 Sec. III-C (Fig. 1): transmitters at `(0, 0)`
    /// and `(2000, 2000)` m, six receivers around them. The one copy of it for
    /// tests and benches (`scenarios/mourya2017-spiral.toml` states it too).
    pub fn mourya2017() -> Self {
        Geometry {
            transmitters: vec![Vec2::new(0.0, 0.0), Vec2::new(2000.0, 2000.0)],
            receivers: vec![
                Vec2::new(-1000.0, -1000.0),
                Vec2::new(1500.0, -1000.0),
                Vec2::new(-1000.0, 1000.0),
                Vec2::new(1500.0, 1000.0),
                Vec2::new(1500.0, 2500.0),
                Vec2::new(2500.0, 1500.0),
            ],
        }
    }

    /// The centroid of every sensor, receivers and transmitters alike (the
    /// origin for an empty geometry): POCS's first starting point.
    pub fn centroid(&self) -> Vec2 {
        let n = self.receivers.len() + self.transmitters.len();
        self.receivers
            .iter()
            .chain(&self.transmitters)
            .fold(Vec2::zeros(), |s, p| s + *p)
            / n.max(1) as f64
    }

    /// The body of a scenario's `[geometry]` table:
    /// `transmitters = [[x, y], ...]` and `receivers = [[x, y], ...]`.
    pub fn toml_table(&self) -> String {
        let list = |ps: &[Vec2]| {
            let items: Vec<String> = ps
                .iter()
                .map(|p| format!("[{:?}, {:?}]", p.x, p.y))
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
    pub fn noise_free(geometry: &Geometry, x: &Vec2, with_doa: bool, with_range: bool) -> Self {
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
    /// DOA noise (radians).
    pub doa: f64,
}

/// Noise-free bistatic range `||x - t|| + ||x - r||`.
pub fn bistatic_range(x: &Vec2, t: &Vec2, r: &Vec2) -> f64 {
    (x - t).norm() + (x - r).norm()
}

/// Noise-free one-way range `||x - a||`.
pub fn one_way_range(x: &Vec2, a: &Vec2) -> f64 {
    (x - a).norm()
}

/// Noise-free DOA `atan2(x_y - r_y, x_x - r_x)` at receiver `r`.
pub fn doa(x: &Vec2, r: &Vec2) -> f64 {
    (x.y - r.y).atan2(x.x - r.x)
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
