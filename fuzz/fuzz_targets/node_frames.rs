//! Fuzz target: [`sonarnet::fuzz::node_frames`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| sonarnet::fuzz::node_frames(data));
