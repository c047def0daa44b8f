//! cargo-fuzz target `molecule_gz`: [`isokit_fuzz::molecule_gz`].
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::molecule_gz(data));
