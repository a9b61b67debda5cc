//! Seeded random streams.
//!
//! A run has one seed. Every random stream (measurement noise of node `n`,
//! the async schedule, the realtime clock of node `n`, the target motion, ...)
//! is derived from that seed, a [`Stream`] tag and an index by SplitMix64
//! mixing, and drives a portable `Xoshiro256PlusPlus` generator. The same seed
//! therefore gives the same numbers on every platform and in every engine.
//! Library code never touches OS entropy.

use rand::SeedableRng;
use rand::rngs::Xoshiro256PlusPlus;

/// The generator used everywhere in sonarnet.
pub type SonarRng = Xoshiro256PlusPlus;

/// Which random stream of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u64)]
pub enum Stream {
    /// Measurement noise of one receiver (index = node id).
    Measurement = 1,
    /// The async pairwise schedule (index 0).
    Schedule = 2,
    /// Realtime Poisson clock and neighbour choice of one node (index = node id).
    NodeClock = 3,
    /// Random target motion (index 0).
    Motion = 4,
    /// Random graph generation (index 0).
    Graph = 5,
    /// Choice of NLOS links and other per-trial draws (index 0).
    Links = 6,
    /// Anything else a module needs; give it a distinct index.
    Aux = 7,
    /// The fate of one frame on the acoustic channel (index from the link
    /// and the frame's number on it, [`crate::model::channel`]).
    Channel = 8,
    /// Fault draws: `link_loss` fates (keyed by link and frame number) and the
    /// random nemesis (index 0).
    Faults = 9,
    /// CSMA backoffs on the acoustic channel (keyed by node and its backoff
    /// count, [`crate::model::mac`]).
    Mac = 10,
}

/// SplitMix64's output function: a bijective mix of 64 bits.
pub fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The seed of stream `stream`, index `index`, of a run with seed `seed`.
pub fn derive_seed(seed: u64, stream: Stream, index: u64) -> u64 {
    splitmix64(splitmix64(splitmix64(seed) ^ (stream as u64)) ^ index)
}

/// The uniform draw in `[0, 1)` of stream `stream` for item number `k` on
/// the directed link `from -> to` of a run with seed `seed`: the same item
/// gets the same draw wherever it is decided, whatever else happened
/// meanwhile (channel fates, fault losses).
pub fn link_draw(seed: u64, stream: Stream, from: u32, to: u32, k: u64) -> f64 {
    let key = splitmix64((u64::from(from) << 32) | u64::from(to)) ^ k;
    (derive_seed(seed, stream, key) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A generator for one stream of a run.
pub fn stream_rng(seed: u64, stream: Stream, index: u64) -> SonarRng {
    SonarRng::seed_from_u64(derive_seed(seed, stream, index))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::RngExt;

    #[test]
    fn same_seed_stream_and_index_give_the_same_numbers() {
        let a: Vec<u64> = (0..4)
            .map(|_| 0)
            .scan(stream_rng(7, Stream::Measurement, 3), |r, _: u64| {
                Some(r.random::<u64>())
            })
            .collect();
        let b: Vec<u64> = (0..4)
            .map(|_| 0)
            .scan(stream_rng(7, Stream::Measurement, 3), |r, _: u64| {
                Some(r.random::<u64>())
            })
            .collect();
        assert_eq!(a, b);
    }

    #[test]
    fn different_nodes_get_different_streams() {
        let mut a = stream_rng(7, Stream::Measurement, 3);
        let mut b = stream_rng(7, Stream::Measurement, 4);
        let mut c = stream_rng(7, Stream::Schedule, 3);
        let (x, y, z): (u64, u64, u64) = (a.random(), b.random(), c.random());
        assert_ne!(x, y);
        assert_ne!(x, z);
    }
}
