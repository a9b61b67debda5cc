//! Fuzz target: [`sonarnet::fuzz::command_line_values`].
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| sonarnet::fuzz::command_line_values(data));
