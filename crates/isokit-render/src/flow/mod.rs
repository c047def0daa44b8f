//! The `flow` shading mode's line integral convolution (002 Sec. 6.4, Fig. 6.12), the one
//! shading pass that needs neighbouring pixels: `shaders/flow.wgsl`, its CPU twin [`cpu`] and
//! its host code [`gpu`]. The public items are re-exported from [`crate::shade`], which
//! describes the mode.

pub(crate) mod cpu;
pub(crate) mod gpu;
