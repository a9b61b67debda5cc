//! Measurement synthesis: the one implementation both engines use.
//!
//! Receiver `n`'s noise comes from its own stream
//! `stream_rng(seed, Stream::Measurement, n)`; per sample it draws, in order,
//! the bistatic ranges `m = 0..M`, then the DOA, then the one-way range.
//! Whether a link is NLOS comes from the run's [`NlosMask`] (drawn from the
//! run seed, stream `Links`).

use crate::model::geometry::Point;
use crate::model::measure::{self, Geometry, NodeMeasurements, SampleMeasurements, Sigmas};
use crate::model::noise::{NlosMask, NoiseModel};
use crate::model::rng::{Stream, stream_rng};
use serde::{Deserialize, Serialize};

/// Synthesize every receiver's measurements along `truth` (Mourya 2017 Sec. III-A:
/// `rho_{m,n} = ||theta - t_m|| + ||theta - r_n|| + noise`,
/// `phi_n = atan2(theta_y - r_ny, theta_x - r_nx) + noise`; Pun-So 2022: one-way
/// `||theta - r_n|| + noise`). In 3-D the DOA is an azimuth (as `phi_n`) and an
/// elevation [`measure::elevation`], drawn after the azimuth with its own
/// noise model (`elevation_noise`, the DOA's when not given). A drifting
/// receiver measures from its position at each sample ([`Geometry::at`]).
pub fn synthesize<const D: usize>(
    geometry: &Geometry<D>,
    truth: &[Point<D>],
    cfg: &MeasurementsCfg,
    nlos: &NlosMask,
    seed: u64,
) -> Vec<SampleMeasurements> {
    let zero = NoiseModel::gaussian(0.0);
    let range_noise = cfg.range_noise.as_ref().unwrap_or(&zero);
    let doa_noise = cfg.doa_noise.as_ref().unwrap_or(&zero);
    let elevation_noise = cfg.elevation_noise.as_ref().unwrap_or(doa_noise);
    let mut rngs: Vec<_> = (0..geometry.receivers.len())
        .map(|n| stream_rng(seed, Stream::Measurement, n as u64))
        .collect();
    truth
        .iter()
        .enumerate()
        .map(|(k, x)| SampleMeasurements {
            nodes: geometry
                .at(k)
                .receivers
                .iter()
                .zip(rngs.iter_mut())
                .enumerate()
                .map(|(n, (r, rng))| {
                    let mut nm = NodeMeasurements::default();
                    if cfg.bistatic {
                        for (m, t) in geometry.transmitters.iter().enumerate() {
                            let rho = measure::bistatic_range(x, t, r)
                                + range_noise.sample(k, nlos.is_nlos(m, n), rng);
                            nm.bistatic.push((m, rho));
                        }
                    }
                    if cfg.doa {
                        nm.doa = Some(measure::doa(x, r) + doa_noise.sample(k, false, rng));
                        if D == 3 {
                            nm.elevation = Some(
                                measure::elevation(x, r) + elevation_noise.sample(k, false, rng),
                            );
                        }
                    }
                    if cfg.range {
                        nm.range = Some(
                            measure::one_way_range(x, r)
                                + range_noise.sample(k, nlos.is_one_way_nlos(n), rng),
                        );
                    }
                    nm
                })
                .collect(),
        })
        .collect()
}

/// `[measurements]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasurementsCfg {
    /// Synthesize a bistatic range for every transmitter-receiver pair.
    #[serde(default = "crate::model::synth::default_true")]
    pub bistatic: bool,
    /// Synthesize a DOA at every receiver.
    #[serde(default)]
    pub doa: bool,
    /// Synthesize a one-way range (TOA) at every receiver.
    #[serde(default)]
    pub range: bool,
    /// DOA row weight `omega` of eq. (9).
    #[serde(default = "default_omega")]
    pub omega: f64,
    /// Noise of bistatic and one-way ranges (metres).
    #[serde(default)]
    pub range_noise: Option<NoiseModel>,
    /// Noise of DOAs (radians; the azimuth's in 3-D).
    #[serde(default)]
    pub doa_noise: Option<NoiseModel>,
    /// Noise of the DOA's elevation in 3-D (radians); `doa_noise` when not
    /// given. Refused in 2-D.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub elevation_noise: Option<NoiseModel>,
    /// Which links are NLOS (redrawn per run from the seed); the noise
    /// models' `is_nlos` argument.
    #[serde(default)]
    pub nlos_links: crate::model::noise::NlosLinks,
    /// A recorded trace CSV to use instead of synthesis.
    #[serde(default)]
    pub trace: Option<String>,
    /// The true track of the trace (CSV `sample,x,y`).
    #[serde(default)]
    pub truth: Option<String>,
}

pub(crate) fn default_true() -> bool {
    true
}

fn default_omega() -> f64 {
    1.0
}

/// The measurements and truth of one run (one seed).
#[derive(Debug, Clone, PartialEq)]
pub struct Realization<const D: usize = 2> {
    /// True positions per sample, if known.
    pub truth: Option<Vec<Point<D>>>,
    /// Every receiver's measurements per sample.
    pub measurements: Vec<SampleMeasurements>,
    /// Nominal noise sigmas per sample (weights of the centralised estimators).
    pub sigmas: Vec<Sigmas>,
    /// The NLOS links of this run (all LOS for a trace).
    pub nlos: crate::model::noise::NlosMask,
}

/// What the coordinator hands to the nodes of a run, in either dimension:
/// every receiver's measurements and the noise sigmas, per sample
/// ([`Realization::feed`]).
#[derive(Debug, Clone, Copy)]
pub struct Feed<'a> {
    /// Every receiver's measurements per sample.
    pub measurements: &'a [SampleMeasurements],
    /// Nominal noise sigmas per sample.
    pub sigmas: &'a [Sigmas],
}

impl<const D: usize> Realization<D> {
    /// The measurements and sigmas the nodes are fed.
    pub fn feed(&self) -> Feed<'_> {
        Feed {
            measurements: &self.measurements,
            sigmas: &self.sigmas,
        }
    }
}
