//! The one integration-test binary (ripgrep style): shared helpers in `util`,
//! one module per area.

mod acoustic;
mod bad_input;
mod baselines;
mod bounds_ref;
mod docs;
mod drift;
mod engine;
mod faults;
mod first_hour;
mod fuzz_corpus;
mod golden;
mod interrupt;
mod layers;
mod paper;
mod processes;
mod replay;
mod report;
mod scenarios;
mod sweep;
mod three_d;
mod three_d_cli;
mod transport;
mod util;
mod workflow;
#[cfg(feature = "zenoh")]
mod zenoh;
