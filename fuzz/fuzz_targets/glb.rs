//! cargo-fuzz target `glb`: [`isokit_fuzz::glb`].
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::glb(data));
