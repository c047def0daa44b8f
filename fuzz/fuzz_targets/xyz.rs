//! cargo-fuzz target `xyz`: [`isokit_fuzz::xyz`].
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::xyz(data));
