//! cargo-fuzz target `pdb`: [`isokit_fuzz::pdb`].
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::pdb(data));
