//! Fuzz target: [`sonarnet::fuzz::user_files`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| sonarnet::fuzz::user_files(data));
