//! cargo-fuzz target `inr`: [`isokit_fuzz::inr`].
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::inr(data));
