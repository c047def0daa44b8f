//! cargo-fuzz target `ply`: [`isokit_fuzz::ply`].
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::ply(data));
