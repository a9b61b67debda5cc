//! How a receiver decides whether a frame survives the transmissions that
//! overlap it: by the gossip graph (every overlap destroys the frame) or by
//! its signal to interference plus noise ratio (SINR), as the field's
//! simulators judge it (DESERT's `MPhy` with its CHUNK interference model,
//! Aqua-Sim NG, ns-3 UAN).
//!
//! # The SINR rule
//! With `reception = { model = "sinr", threshold_db, detection_db }`, every
//! transmission reaches every node in the water, whatever the gossip graph.
//! A transmission from `k` arrives at `j` at the level `L = SL - TL(d_kj)` dB
//! (the source level and transmission loss of `loss = { model = "range" }`:
//! spreading, absorption at the path's depth), against the band noise `N` dB
//! of the same table. A frame from `i` to `j` is received if, at every
//! instant of its arrival `[a, b)`,
//!
//! `SINR(t) = P_i / (P_N + sum_k P_k(t)) >= 10^(threshold_db / 10)`,
//!
//! powers in linear units, the sum over the other arrivals at `j` that
//! overlap `t` and whose level is at least `detection_db` above the noise
//! (weaker ones are not detected and do not count). The interference is
//! piecewise constant over the arrival; the frame's SINR is its minimum over
//! the pieces (the worst chunk, as DESERT's CHUNK model takes each chunk's
//! own SINR and a frame fails with its worst chunk), recorded in
//! `messages.csv` as `sinr_db`. A strong frame therefore survives a weak
//! overlapping one (capture), and two of equal level destroy each other
//! when the threshold is above 0 dB.
//!
//! A frame that fails the rule is lost as `collision` when the noise alone
//! would have let it through (interference destroyed it), and as `loss`
//! otherwise (too weak against the noise). Half-duplex is judged first, as
//! under the graph rule; the random bit-error draw of the range loss comes
//! after, as before.

use crate::model::error::{KeyError, in_range};
use serde::{Deserialize, Serialize};

/// `[channel] reception`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "model", rename_all = "snake_case", deny_unknown_fields)]
pub enum Reception {
    /// A frame collides only with frames from the receiver's gossip
    /// neighbours, and every collision destroys both (the default).
    Graph {},
    /// The SINR rule of the module docs.
    Sinr {
        /// Minimum SINR over the arrival, dB, in [-50, 100] (default 10).
        #[serde(default = "default_threshold")]
        threshold_db: f64,
        /// Interferers below this level over the noise, dB, in [-50, 100]
        /// (default 3), are not counted.
        #[serde(default = "default_detection")]
        detection_db: f64,
    },
}

impl Default for Reception {
    fn default() -> Self {
        Reception::Graph {}
    }
}

fn default_threshold() -> f64 {
    10.0
}
fn default_detection() -> f64 {
    3.0
}

impl Reception {
    /// Today's graph rule (left out of a written scenario).
    pub fn is_graph(&self) -> bool {
        matches!(self, Reception::Graph {})
    }

    /// Checks the numbers; `has_levels` says whether the channel's loss
    /// model gives the levels (`loss = { model = "range" }`).
    pub fn validate(&self, has_levels: bool) -> Result<(), KeyError> {
        let Reception::Sinr {
            threshold_db,
            detection_db,
        } = *self
        else {
            return Ok(());
        };
        in_range("channel.reception.threshold_db", threshold_db, -50.0, 100.0)?;
        in_range("channel.reception.detection_db", detection_db, -50.0, 100.0)?;
        if !has_levels {
            return Err(KeyError::new(
                "channel.reception",
                "the sinr model takes its source level, transmission loss and noise from \
                 channel.loss = { model = \"range\", ... }: set that loss model",
            ));
        }
        Ok(())
    }
}

/// A power level in dB as linear power (relative to 1).
pub fn linear(db: f64) -> f64 {
    10f64.powf(db / 10.0)
}

/// The worst SINR (dB) over the arrival `[a, b)` of a signal of linear power
/// `signal`, against the noise power `noise` and the interferers
/// `(start, end, power)` (already filtered by detection; any that do not
/// overlap `[a, b)` are ignored): the interference is summed at the start of
/// the arrival and at every start of an interferer inside it, the instants
/// where it can grow.
pub fn worst_sinr_db(
    signal: f64,
    noise: f64,
    a: u64,
    b: u64,
    interferers: &[(u64, u64, f64)],
) -> f64 {
    let at = |t: u64| -> f64 {
        interferers
            .iter()
            .filter(|&&(s, e, _)| s <= t && t < e)
            .map(|&(_, _, p)| p)
            .sum()
    };
    let mut worst = at(a);
    for &(s, e, _) in interferers {
        if s > a && s < b && e > s {
            worst = worst.max(at(s));
        }
    }
    10.0 * (signal / (noise + worst)).log10()
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn the_worst_sinr_is_taken_where_the_overlapping_interferers_sum_highest() {
        // Signal 100, noise 1; interferers of power 4 over [10, 30) and 5
        // over [20, 50) within the arrival [0, 40): the worst instant is
        // [20, 30), with 9 of interference.
        let sinr = worst_sinr_db(100.0, 1.0, 0, 40, &[(10, 30, 4.0), (20, 50, 5.0)]);
        assert_relative_eq!(sinr, 10.0, max_relative = 1e-12);
        // Half-open: an interferer that ends at the arrival's start, or
        // starts at its end, does not count.
        let sinr = worst_sinr_db(100.0, 1.0, 10, 20, &[(0, 10, 50.0), (20, 30, 50.0)]);
        assert_relative_eq!(sinr, 20.0, max_relative = 1e-12);
    }

    #[test]
    fn the_sinr_rule_needs_the_range_loss_for_its_levels_and_checks_its_numbers() {
        let r = Reception::Sinr {
            threshold_db: 10.0,
            detection_db: 3.0,
        };
        assert!(r.validate(true).is_ok());
        assert_eq!(
            r.validate(false).expect_err("no levels").key,
            "channel.reception"
        );
        let bad = Reception::Sinr {
            threshold_db: f64::NAN,
            detection_db: 3.0,
        };
        assert_eq!(
            bad.validate(true).expect_err("NaN").key,
            "channel.reception.threshold_db"
        );
        assert!(Reception::Graph {}.validate(false).is_ok());
    }
}
