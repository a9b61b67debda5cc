//! The world being observed, as plain data and pure functions: positions and
//! the gossip graph, what a receiver measures and how noisy it is, how the
//! target moves, the acoustic channel between the nodes, the seeded random
//! streams, measurement synthesis (the
//! [`synth::Realization`] of a run) and the track metrics. The lowest layer:
//! it imports nothing else of the crate.

pub mod acoustics;
pub mod channel;
pub mod coords;
pub mod drift;
pub mod error;
pub mod fault;
pub mod geometry;
pub mod graph;
pub mod linalg;
pub mod mac;
pub mod measure;
pub mod metrics;
pub mod motion;
pub mod names;
pub mod nanos;
pub mod noise;
pub mod reception;
pub mod rng;
pub mod sound_speed;
pub mod synth;
pub mod xy;
