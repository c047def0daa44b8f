//! cargo-fuzz target `nifti_gz`: [`isokit_fuzz::nifti_gz`].
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::nifti_gz(data));
