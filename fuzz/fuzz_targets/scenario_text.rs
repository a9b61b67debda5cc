//! Fuzz target: [`sonarnet::fuzz::scenario_text`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| sonarnet::fuzz::scenario_text(data));
