//! Scan conversion of prisms, `shaders/prism_scan.wgsl` with `shaders/common/prism.wgsl`: the
//! CPU twin (`scan/cpu.rs`, whose items are re-exported here: the same row spans, the same
//! f32 arithmetic in the same order, the same packed keys) and the kernel's host code
//! ([`gpu`], `scan/gpu.rs`, also reachable as [`crate::gpu`]).
//!
//! | WGSL | CPU twin | GPU host code |
//! | --- | --- | --- |
//! | `shaders/common/prism.wgsl` | [`crate::local`] (`distance2`), [`row_span`], [`sample_key`], [`pack`]; the record [`crate::GpuPrism`] | — (a piece) |
//! | `shaders/prism_scan.wgsl` | [`scan_slab`] | [`gpu::PrismGpu`] |

mod cpu;
pub mod gpu;

pub use cpu::*;
