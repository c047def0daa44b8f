//! Quadric splatting, the CPU twin (002 Ch. 7): quadrics into the shared [`GBuffer`], a
//! shadow map from a spot light with 64-sample soft shadows and the 8-sample penumbra test
//! (Sec. 7.3.2), Sobel silhouettes and creases with the 4-fetch trick (Sec. 7.3.3), and
//! deferred shading with a colour per object.
//!
//! ## Pipeline
//! 1. **Set-up** ([`setups`]): per quadric, in f64 on the host, its tight screen box and the
//!    f32 data of [`QuadricSetup`] (see [`crate::quadric`]). Quadrics wholly behind the
//!    near plane or off screen are culled.
//! 2. **Splat** ([`splat`]): every pixel whose centre lies in a quadric's box runs
//!    [`crate::quadric::intersect`] (a *fragment*); the nearest hit along the ray wins (ties:
//!    the lower index, as a GPU depth test `Less` over instances drawn in order). The CPU
//!    bins boxes into 16x16 tiles and runs tiles in parallel. The winner's G-buffer sample
//!    (position, normal, distance `Z`, principal curvatures, id) and object index are
//!    stored: [`SplatFrame`].
//! 3. **Shadow map** ([`ShadowMap::render`]): the same splat from the spot light's view,
//!    keeping the depth along the light's axis.
//! 4. **Shading** ([`shade_splat`]): per pixel, the ray caster's deferred modes with the
//!    object's colour ([`crate::shade::shade_pixel_color`]), darkened toward the ambient
//!    term by the filtered shadow ([`shadow_factor`]), and blended with the outline colour by
//!    [`outline_weight`].
//!
//! The per-pixel functions ([`fragment`], [`shadow_factor`], [`outline_weight`]) are plain
//! f32 functions over flat data, mirrored by `shaders/splat.wgsl` and
//! `shaders/splat_shade.wgsl`.
//!
//! [`GBuffer`]: crate::GBuffer
//! [`QuadricSetup`]: crate::quadric::QuadricSetup
//!
//! ## Where the code is
//! (paths under `crates/isokit-render/src/`)
//!
//! | WGSL | CPU twin | GPU host code |
//! | --- | --- | --- |
//! | `shaders/splat.wgsl` (with `raycast_common.wgsl`, `common/curvature.wgsl`) | `splat/cpu.rs` ([`fragment`], [`resolve`], [`ShadowMap::render`]) and `quadric.rs` ([`crate::quadric::intersect`]) | `splat/gpu.rs` ([`gpu`]) |
//! | `shaders/splat_shade.wgsl` (with `common/shade_structs.wgsl`, `common/shade_functions.wgsl`) | `splat/cpu.rs` ([`shade_splat`], [`shadow_factor`], [`outline_weight`]) | `splat/gpu.rs` |

pub(crate) mod cpu;
pub mod gpu;

pub use cpu::*;
