//! cargo-fuzz target `nrrd`: [`isokit_fuzz::nrrd`].
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::nrrd(data));
