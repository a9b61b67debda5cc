//! sonarnet: an emulated distributed multistatic sonar network.
//!
//! Receivers track a moving target with asynchronous randomized Douglas-Rachford
//! gossip (Mourya et al., CAMSAP 2017, "Mourya 2017"), each local step an exact
//! generalized trust-region subproblem (GTRS) solve.
//!
//! # Example: a scenario-driven test
//!
//! The library's entry point is [`scenario::Scenario::run`]: it runs a
//! scenario with its seed on the engine the options name, scores every track
//! and checks the scenario's `[expect]` block, and writes nothing
//! ([`scenario::Scenario::run_and_write`] writes the results directory too).
//! `examples/scenario_test.rs` is a longer version.
//!
//! ```
//! use sonarnet::pipeline::RunOptions;
//! use sonarnet::scenario::Scenario;
//!
//! let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/mourya2017-spiral.toml");
//! let sc = Scenario::from_file(path)?.with_samples(20)?;
//! let out = sc.run(&RunOptions::inprocess());
//! assert!(out.run.error.is_none());
//! assert_eq!(out.run.record.thetas.len(), 20);
//! // theta_bar of the last sample is within 50 m of the truth.
//! let est = sonarnet::model::metrics::theta_bar(&out.run.record.thetas[19]);
//! let truth = sc.realize().truth.unwrap()[19];
//! assert!((est - truth).norm() < 50.0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![deny(clippy::float_cmp)]

// The BLAS/LAPACK symbols clarabel's PSD cone calls (pure Rust, on faer):
// named here so that every binary linking the library links them.
extern crate dense_lapack;

pub mod cli;
pub mod engine;
pub mod estimators;
pub mod fuzz;
pub mod model;
pub mod pipeline;
pub mod plot;
pub mod protocol;
pub mod report;
pub mod runtime;
pub mod scenario;
pub mod transport;
pub mod world;

/// The book's chapters that hold Rust code (`docs/src/`), compiled and run
/// as doctests so that the guide cannot drift from the API.
#[cfg(doctest)]
#[doc = include_str!("../docs/src/library.md")]
pub struct BookLibraryChapter;
