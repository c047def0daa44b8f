//! # isokit-shaders
//!
//! Every WGSL source of isokit, embedded as a `&'static str`: the kernels at the top level of
//! `shaders/` and the pieces they share in `shaders/common/`. Nothing else: the crate has no
//! dependencies and does not assemble, compile or validate anything.
//!
//! What it is not for: assembly. A kernel's program is its pieces joined in order, after the
//! constants its Rust side generates (workgroup sizes, op codes, flag bits), so that Rust is
//! the single source of truth; that happens in the crate owning the kernel, with
//! `isokit_gpu::ShaderSource`, which also validates the result with naga in the unit tests.
//! `shaders/README.md` maps every file to its kernel, its host code and its CPU twin.
//!
//! ```
//! // The ray caster's trace kernel is assembled from three of these (plus Rust constants).
//! assert!(isokit_shaders::RAYCAST.contains("fn trace("));
//! assert!(isokit_shaders::common::CURVATURE.contains("fn curvature("));
//! assert!(isokit_shaders::ALL.iter().any(|(path, _)| *path == "common/prism.wgsl"));
//! ```
#![warn(missing_docs)]

/// `raycast_common.wgsl`: what the ray caster's and the splatter's kernels share — the
/// `Uniforms`, the G-buffer pixel `GPixel`, the pixel and subpixel rays (multi-view), float
/// helpers.
pub const RAYCAST_COMMON: &str = include_str!("../raycast_common.wgsl");

/// `raycast.wgsl`: the isosurface ray caster, one pass over the pending rays (entry point
/// `trace`).
pub const RAYCAST: &str = include_str!("../raycast.wgsl");

/// `shade.wgsl`: deferred shading of a ray-cast G-buffer (entry point `shade`).
pub const SHADE: &str = include_str!("../shade.wgsl");

/// `flow.wgsl`: the `flow` shading mode's line integral convolution (entry point `flow`).
pub const FLOW: &str = include_str!("../flow.wgsl");

/// `splat.wgsl`: quadric splatting, a render pipeline (entry points `vs_splat`, `fs_gbuffer`,
/// `fs_shadow`).
pub const SPLAT: &str = include_str!("../splat.wgsl");

/// `splat_shade.wgsl`: deferred shading of a splat frame with soft shadows and outlines
/// (entry points `shade_splat_filtered`, `shade_splat_loads`).
pub const SPLAT_SHADE: &str = include_str!("../splat_shade.wgsl");

/// `dvr.wgsl`: direct volume rendering, one ray per invocation (entry point `dvr`).
pub const DVR: &str = include_str!("../dvr.wgsl");

/// `tets.wgsl`: ray casting the isosurface of a tetrahedral grid and volume rendering
/// through its cells, one ray per invocation (entry points `tet_iso`, `tet_dvr`).
pub const TETS: &str = include_str!("../tets.wgsl");

/// `segmented.wgsl`: ray casting the surfaces between the regions of a segmented distance
/// field, one ray per invocation (entry point `segmented`).
pub const SEGMENTED: &str = include_str!("../segmented.wgsl");

/// `prism_scan.wgsl`: prism scan conversion of one slab of slices (entry point `scan`).
pub const PRISM_SCAN: &str = include_str!("../prism_scan.wgsl");

/// The pieces in `shaders/common/`: shared by several kernels, without entry points.
pub mod common {
    /// `common/curvature.wgsl`: normal and principal curvatures from gradient and Hessian
    /// (`curvature`, with `any_orthonormal`, `hypot`, `Curvature`), used by `raycast.wgsl`
    /// and `splat.wgsl`.
    pub const CURVATURE: &str = include_str!("../common/curvature.wgsl");

    /// `common/shade_structs.wgsl`: `ShadeParams` and `Light`, used by `shade.wgsl` and
    /// `splat_shade.wgsl`.
    pub const SHADE_STRUCTS: &str = include_str!("../common/shade_structs.wgsl");

    /// `common/shade_functions.wgsl`: the per-sample shading (`light_at` … `shade_pixel`),
    /// used by `shade.wgsl` and `splat_shade.wgsl`; reads the module's `S` and `lights`.
    pub const SHADE_FUNCTIONS: &str = include_str!("../common/shade_functions.wgsl");

    /// `common/bspline.wgsl`: the cubic B-spline weights and their derivatives
    /// (`bspline_weights`, `bspline_weights_d1`, `bspline_weights_d2`), used by
    /// `raycast.wgsl` and `dvr.wgsl`.
    pub const BSPLINE: &str = include_str!("../common/bspline.wgsl");

    /// `common/transfer.wgsl`: the transfer function (`tf_eval`, `segment`, `opacity_at`)
    /// and the shading of a composited sample (`shade_sample`), used by `dvr.wgsl` and
    /// `tets.wgsl`; reads the kernel's `tf` and `P.n_tf`.
    pub const TRANSFER: &str = include_str!("../common/transfer.wgsl");

    /// `common/slab.wgsl`: where a ray meets an axis-aligned box (`slab`, `safe_inv`),
    /// used by `dvr.wgsl`, `tets.wgsl` and `segmented.wgsl`.
    pub const SLAB: &str = include_str!("../common/slab.wgsl");

    /// `common/prism.wgsl`: `struct Prism`, the distance to a triangle in its local frame, row
    /// spans and packed keys, used by `prism_scan.wgsl`.
    pub const PRISM: &str = include_str!("../common/prism.wgsl");
}

/// Every file, as (path relative to `shaders/`, source), kernels first: what a test walks to
/// make sure each one is part of a validated program.
pub const ALL: &[(&str, &str)] = &[
    ("raycast_common.wgsl", RAYCAST_COMMON),
    ("raycast.wgsl", RAYCAST),
    ("shade.wgsl", SHADE),
    ("flow.wgsl", FLOW),
    ("splat.wgsl", SPLAT),
    ("splat_shade.wgsl", SPLAT_SHADE),
    ("dvr.wgsl", DVR),
    ("tets.wgsl", TETS),
    ("segmented.wgsl", SEGMENTED),
    ("prism_scan.wgsl", PRISM_SCAN),
    ("common/curvature.wgsl", common::CURVATURE),
    ("common/bspline.wgsl", common::BSPLINE),
    ("common/transfer.wgsl", common::TRANSFER),
    ("common/slab.wgsl", common::SLAB),
    ("common/shade_structs.wgsl", common::SHADE_STRUCTS),
    ("common/shade_functions.wgsl", common::SHADE_FUNCTIONS),
    ("common/prism.wgsl", common::PRISM),
];

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// The `.wgsl` files under `dir`, as paths relative to `root` with `/` separators.
    fn wgsl_files(root: &Path, dir: &Path, out: &mut Vec<String>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                wgsl_files(root, &path, out);
            } else if path.extension().is_some_and(|e| e == "wgsl") {
                let rel = path.strip_prefix(root).unwrap();
                let parts: Vec<_> = rel.iter().map(|p| p.to_string_lossy()).collect();
                out.push(parts.join("/"));
            }
        }
    }

    #[test]
    fn every_file_is_listed_once_and_matches_the_disk() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let mut on_disk = Vec::new();
        wgsl_files(root, root, &mut on_disk);
        on_disk.sort();
        let mut listed: Vec<String> = ALL.iter().map(|(p, _)| p.to_string()).collect();
        listed.sort();
        assert_eq!(listed, on_disk);
        for (path, src) in ALL {
            let file = std::fs::read_to_string(root.join(path)).unwrap();
            assert_eq!(*src, file, "{path}");
            assert!(
                src.starts_with("//"),
                "{path} opens without its header comment"
            );
        }
    }

    #[test]
    fn shared_pieces_are_defined_once() {
        // Each shared function lives in exactly one file, so a kernel cannot silently keep a
        // diverging copy.
        for name in [
            "fn curvature(",
            "fn bspline_weights(",
            "fn hypot(",
            "fn any_orthonormal(",
            "struct ShadeParams",
            "struct Light ",
            "fn shade_pixel(",
            "fn light_at(",
            "struct Uniforms",
            "struct GPixel",
            "struct Prism",
            "fn tf_eval(",
            "fn segment(",
            "fn shade_sample(",
            "fn slab(",
        ] {
            let holders: Vec<&str> = ALL
                .iter()
                .filter(|(_, src)| src.contains(name))
                .map(|(p, _)| *p)
                .collect();
            assert_eq!(holders.len(), 1, "{name}: {holders:?}");
        }
    }
}
