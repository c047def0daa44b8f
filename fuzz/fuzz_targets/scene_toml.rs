//! cargo-fuzz target `scene_toml`: [`isokit_fuzz::scene_toml`].
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::scene_toml(data));
