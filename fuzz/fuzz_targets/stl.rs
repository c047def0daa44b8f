//! cargo-fuzz target `stl`: [`isokit_fuzz::stl`].
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::stl(data));
