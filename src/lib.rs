//! sonarnet: an emulated distributed multistatic sonar network.
//!
//! Receivers track a moving target with asynchronous randomized Douglas-Rachford
//! gossip (Mourya et al., CAMSAP 2017, "seed 002"), each local step an exact
//! generalized trust-region subproblem (GTRS) solve.
#![deny(clippy::float_cmp)]

pub mod geometry;
pub mod local;
pub mod measure;
pub mod prox;
pub mod rng;
pub mod robust;
pub mod noise;
pub mod wire;
