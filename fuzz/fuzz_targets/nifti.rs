//! cargo-fuzz target `nifti`: [`isokit_fuzz::nifti`].
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::nifti(data));
