//! cargo-fuzz target `off`: [`isokit_fuzz::off`].
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::off(data));
