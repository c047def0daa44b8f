//! cargo-fuzz target `vtu`: [`isokit_fuzz::vtu`] (VTK XML unstructured grids).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::vtu(data));
