//! Deferred shading (002 Sec. 6.4): every pixel's colour from its G-buffer sample alone,
//! with image-space cost. [`shade_pixel`] is the per-pixel function the GPU twin mirrors.
//!
//! | mode | what |
//! | --- | --- |
//! | `phong` | Blinn-Phong with the scene's lights |
//! | `tone` | Gooch cool-to-warm tone shading (GGSC98) |
//! | `normal` | the unit normal as colour, `0.5 + 0.5·n` |
//! | `curvature` | 2D transfer function of `(k1, k2)`: hue by shape index, saturation by curvedness |
//! | `mean`, `gaussian`, `k1`, `k2` | 1D diverging colour map (blue < 0 < red) of one measure |
//! | `ridges` | tone shading with ridge (`k1 ≫ 0`) and valley (`k2 ≪ 0`) regions coloured (KWTM03) |
//! | `silhouette` | tone shading with contours whose thickness follows the view curvature (KWTM03) |
//! | `accessibility` | tone shading darkened where both curvatures are strongly negative (approximate accessibility, Mil94) |
//! | `reflection` | reflection of a procedural environment (sky, ground, horizontal stripes: reflection lines) |
//! | `texture` | a solid texture (3D checkerboard of period 2/κ, world coordinates), diffusely lit |
//! | `flow` | curvature-aligned flow: tone shading modulated by a dense noise texture smeared along the direction of maximum principal curvature, in image space ([`flow_image`]) |
//!
//! Curvature maps are scaled by [`Shading::curvature_scale`] κ: a curvature of κ (radius
//! 1/κ) saturates the map. [`default_curvature_scale`] picks 20 / (volume diagonal).
//!
//! ## Curvature-aligned flow (002 Sec. 6.4, Fig. 6.12)
//! The one mode that is not per pixel: the steady state, for one frame, of image-based flow
//! advection (van Wijk 2003; Laramee et al. 2003), i.e. a line integral convolution (LIC)
//! of white noise along the principal direction of `k1` seen on the screen.
//! 1. **Field** ([`flow_field`], [`flow_direction`]): each pixel's `dir1` is projected onto
//!    the image plane (orthographic: `(dir1·right, −dir1·up)`; perspective: the derivative
//!    of the projection of the hit point moving along `dir1`) and normalized, in pixel
//!    coordinates (x right, y down). The field is undefined (the pixel gets no flow) where
//!    the ray missed, where the surface is umbilic ([`flow_umbilic`]: `|k1 − k2|` below
//!    `0.05·κ + 0.01·(|k1| + |k2|)`, so `dir1` is rounding noise; caps, of zero curvature,
//!    too) and where `dir1` points nearly along the view (projected length below
//!    [`FLOW_MIN_PROJECTED`]).
//! 2. **Noise** ([`flow_noise`]): a deterministic white noise, an integer hash of the pixel
//!    coordinates quantized to 16 bits (fixed to the screen).
//! 3. **Streamlines** ([`flow_lic`]): from the pixel's centre, [`FLOW_STEPS`] Euler steps of
//!    one pixel forward and as many backward; each step reads the field of the pixel it
//!    lands in (nearest-pixel sampling, `floor` of the position) and stops at the image's
//!    border and at a pixel whose flow key ([`FlowPixel::key`]: the id, or none) differs
//!    from the start's: misses, other object-map ids (caps, the other CSG operand) and
//!    umbilic pixels are never read (parts of one surface share an id, so a streamline may
//!    cross a depth discontinuity of the same surface, e.g. at a silhouette). Principal
//!    directions have no sign, so each step's direction is flipped when it points against
//!    the previous one; where the field is not orientable (around umbilics) seams remain,
//!    as 002 notes. The LIC value is the box-filtered mean of the noise over the pixels
//!    visited (the start included, at most `2·FLOW_STEPS + 1`).
//! 4. **Colour** ([`flow_modulate`]): the tone shading times
//!    `0.5 + clamp(0.5 + FLOW_CONTRAST·(lic − 0.5), 0, 1)`; pixels without flow keep the
//!    plain tone shading.
//!
//! [`shade_pixel`] alone gives the plain tone shading in this mode (which is also what the
//! splat shading, per pixel, shows for it). Multi-view G-buffers are refused: their
//! subpixels belong to different views, so there is no single image to advect in.
//! The GPU twin projects the field on the host with [`flow_field`] (the G-buffer is on
//! the host anyway), so both twins trace the same streamlines from bit-identical input.
//!
//! ## Where the code is
//! (paths under `crates/isokit-render/src/`)
//!
//! | WGSL | CPU twin | GPU host code |
//! | --- | --- | --- |
//! | `shaders/shade.wgsl`, `shaders/common/shade_structs.wgsl`, `shaders/common/shade_functions.wgsl` | `shade/cpu.rs` | `shade/gpu.rs` |
//! | `shaders/flow.wgsl` | `flow/cpu.rs` | `flow/gpu.rs` |

pub(crate) mod cpu;
pub(crate) mod gpu;

pub use crate::flow::cpu::{
    FLOW_MIN_PROJECTED, FLOW_STEPS, FlowPixel, flow_direction, flow_field, flow_hash, flow_image,
    flow_lic, flow_noise, flow_umbilic,
};
pub use cpu::*;
