//! sonarnet: an emulated distributed multistatic sonar network.
//!
//! Receivers track a moving target with asynchronous randomized Douglas-Rachford
//! gossip (Mourya et al., CAMSAP 2017, "seed 002"), each local step an exact
//! generalized trust-region subproblem (GTRS) solve.
#![deny(clippy::float_cmp)]

pub mod bench;
pub mod bounds;
pub mod central;
pub mod cli;
pub mod codec;
pub mod engine;
pub mod error;
pub mod geometry;
pub mod graph;
pub mod local;
pub mod measure;
pub mod metrics;
pub mod motion;
pub mod noise;
pub mod online;
pub mod plot;
pub mod protocol;
pub mod prox;
pub mod report;
pub mod rng;
pub mod robust;
pub mod run;
pub mod scenario;
pub mod synth;
pub mod transport;
pub mod wire;
