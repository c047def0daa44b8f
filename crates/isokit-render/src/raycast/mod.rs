//! The isosurface ray caster, `shaders/raycast.wgsl` (with `shaders/raycast_common.wgsl` and
//! `shaders/common/curvature.wgsl`):
//! - [`cpu`]: the per-pixel kernel's CPU twin, public as [`crate::kernel`];
//! - [`render`]: options, uniforms and the passes over the image that both twins share, and
//!   the CPU's passes (rayon over pixels);
//! - [`gpu`]: the kernel's host code (assembly, buffers, the pass loop on the GPU), public
//!   through [`crate::gpu`].

pub mod cpu;
pub(crate) mod gpu;
pub(crate) mod render;
