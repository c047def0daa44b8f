//! The isosurface ray caster, `shaders/raycast.wgsl` (with `shaders/raycast_common.wgsl` and
//! `shaders/common/curvature.wgsl`):
//! - [`cpu`]: the per-pixel kernel's CPU twin, public as [`crate::kernel`];
//! - [`render`]: options, uniforms and the passes over the image that both twins share, and
//!   the CPU's passes (rayon over pixels);
//! - [`gpu`]: the kernel's host code (assembly, buffers, the pass loop on the GPU), public
//!   through [`crate::gpu`];
//! - [`reuse`]: the pixels of a kept frame that an edit of the field left as they were
//!   (CPU only);
//! - [`start`]: where each ray's walk may start, the active blocks projected onto tiles of
//!   the image (CPU only; the image is the same with or without it).

pub mod cpu;
pub(crate) mod gpu;
pub(crate) mod render;
pub(crate) mod reuse;
pub mod start;
