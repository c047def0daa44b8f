//! cargo-fuzz target `obj`: [`isokit_fuzz::obj`].
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::obj(data));
