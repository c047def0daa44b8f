//! cargo-fuzz target `vtk`: [`isokit_fuzz::vtk`] (legacy VTK unstructured grids).
#![no_main]
libfuzzer_sys::fuzz_target!(|data: &[u8]| isokit_fuzz::vtk(data));
