//! cargo-fuzz target `mmcif`: [`isokit_fuzz::mmcif`].
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::mmcif(data));
