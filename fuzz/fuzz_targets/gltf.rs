//! cargo-fuzz target `gltf`: [`isokit_fuzz::gltf`].
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::gltf(data));
