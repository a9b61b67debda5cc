//! Fuzz target: [`sonarnet::fuzz::results_files`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| sonarnet::fuzz::results_files(data));
