//! cargo-fuzz target `scene_json`: [`isokit_fuzz::scene_json`].
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::scene_json(data));
