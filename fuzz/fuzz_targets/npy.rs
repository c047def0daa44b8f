//! cargo-fuzz target `npy`: [`isokit_fuzz::npy`].
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::npy(data));
