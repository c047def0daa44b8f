//! Rendering a molecule: its atoms and bonds as quadrics, splatted and shaded by the
//! [`Renderer`] (CPU or GPU twin).

use crate::Renderer;
use isokit_field::Camera;
use isokit_molecule::{Molecule, MoleculeOptions, framing_camera, molecule_scene};
use isokit_render::splat::{
    OutlineOptions, ShadeStats, ShadowOptions, SplatFrame, SplatOptions, SplatScene, SplatShading,
    shade_splat, splat,
};
use isokit_render::{Image, RenderError, Shading, ShadingMode};
use serde::Serialize;

/// How to render a molecule.
#[derive(Clone, Debug)]
pub struct MoleculeSettings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Ball-and-stick or space-filling, and the sizes.
    pub model: MoleculeOptions,
    /// The deferred shading mode.
    pub mode: ShadingMode,
    /// Soft shadows from a spot light behind the camera.
    pub shadows: Option<ShadowOptions>,
    /// Silhouettes and creases.
    pub outlines: bool,
    /// The camera (default: one framing the molecule, 30° field of view, looking down −z).
    pub camera: Option<Camera>,
}

impl Default for MoleculeSettings {
    fn default() -> Self {
        Self {
            width: 512,
            height: 512,
            model: MoleculeOptions::default(),
            mode: ShadingMode::Phong,
            shadows: None,
            outlines: false,
            camera: None,
        }
    }
}

/// What a molecule frame did (the `--stats` object of `isokit molecule`, less what the
/// command adds).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MoleculeStats {
    /// Atoms.
    pub atoms: usize,
    /// Bonds.
    pub bonds: usize,
    /// Quadrics of the scene.
    pub quadrics: usize,
    /// Quadrics with a box on screen.
    pub drawn: usize,
    /// Fragments (pixel centres inside boxes).
    pub fragments: u64,
    /// Fragments whose ray hit their quadric.
    pub fragment_hits: u64,
    /// Pixels covered.
    pub covered_pixels: usize,
    /// Shadow-map samples taken.
    pub shadow_samples: u64,
    /// Pixels in a penumbra (all 64 shadow samples taken).
    pub penumbra_pixels: u64,
    /// Seconds of the set-up.
    pub setup_seconds: f64,
    /// Seconds of the splat.
    pub splat_seconds: f64,
    /// Seconds of the shadow map.
    pub shadow_map_seconds: f64,
    /// Seconds of the shading.
    pub shade_seconds: f64,
    /// `gpu` or `cpu`.
    pub backend: &'static str,
    /// The device.
    pub device: String,
}

/// A rendered molecule.
#[derive(Clone, Debug)]
pub struct MoleculeFrame {
    /// The shaded image.
    pub image: Image,
    /// The splat: G-buffer, object per pixel, camera uniforms.
    pub frame: SplatFrame,
    /// Counters and timing.
    pub stats: MoleculeStats,
    /// The camera.
    pub camera: Camera,
}

impl Renderer {
    /// Splats and shades a quadric scene from `camera`.
    pub fn splat(
        &mut self,
        scene: &SplatScene,
        camera: &Camera,
        opts: &SplatOptions,
        shading: &SplatShading,
    ) -> Result<(SplatFrame, Image, ShadeStats), RenderError> {
        match self.gpu() {
            Some(g) => {
                let f = g.splat(scene, camera, opts)?;
                let (image, st) = g.shade_splat(&f, scene, shading)?;
                Ok((f, image, st))
            }
            None => {
                let f = splat(scene, camera, opts)?;
                let (image, st) = shade_splat(&f, scene, shading)?;
                Ok((f, image, st))
            }
        }
    }

    /// Renders a molecule as quadrics (on a white background, in CPK colours).
    pub fn render_molecule(
        &mut self,
        mol: &Molecule,
        settings: &MoleculeSettings,
    ) -> Result<MoleculeFrame, RenderError> {
        let scene = molecule_scene(mol, &settings.model)?;
        let camera = match &settings.camera {
            Some(c) => *c,
            None => framing_camera(&scene, settings.width, settings.height)?,
        };
        let shading = SplatShading {
            shading: Shading {
                mode: settings.mode,
                background: [1.0, 1.0, 1.0, 1.0],
                ..Shading::default()
            },
            shadows: settings.shadows,
            outlines: settings.outlines.then(OutlineOptions::default),
        };
        let (frame, image, sh) = self.splat(&scene, &camera, &SplatOptions::default(), &shading)?;
        let st = &frame.stats;
        let stats = MoleculeStats {
            atoms: mol.atoms.len(),
            bonds: mol.bonds.len(),
            quadrics: st.quadrics,
            drawn: st.drawn,
            fragments: st.fragments,
            fragment_hits: st.hits,
            covered_pixels: frame.gbuffer.hit_count(),
            shadow_samples: sh.shadow_samples,
            penumbra_pixels: sh.penumbra_pixels,
            setup_seconds: st.setup_seconds,
            splat_seconds: st.splat_seconds,
            shadow_map_seconds: sh.shadow_map_seconds,
            shade_seconds: sh.shade_seconds,
            backend: self.backend(),
            device: self.device(),
        };
        Ok(MoleculeFrame {
            image,
            frame,
            stats,
            camera,
        })
    }
}

/// The camera of [`MoleculeSettings::camera`] for a camera `spec` (a scene file's or the
/// command line's) and a projection: `spec`'s camera; without one, for an orthographic
/// view the default framing's eye and target seen orthographically (30° field of view),
/// else `None` (the default framing, [`framing_camera`]).
pub fn molecule_camera(
    mol: &Molecule,
    model: &MoleculeOptions,
    spec: Option<&crate::CameraSpec>,
    kind: crate::ProjectionKind,
    width: u32,
    height: u32,
) -> Result<Option<Camera>, RenderError> {
    let spec = match (spec, kind) {
        (Some(s), _) => s.clone(),
        (None, crate::ProjectionKind::Perspective) => return Ok(None),
        (None, crate::ProjectionKind::Orthographic) => {
            let scene = molecule_scene(mol, model)?;
            let c = framing_camera(&scene, width, height)?;
            crate::CameraSpec {
                eye: c.eye().to_array(),
                target: c.target().to_array(),
                up: c.up().to_array(),
                fov: 30.0,
                ortho_height: None,
            }
        }
    };
    // The bounds only matter for a camera framing them, which `Some(spec)` is not.
    let bounds = isokit_field::Aabb::from_center_half(glam::Vec3::ZERO, glam::Vec3::ONE);
    Ok(Some(crate::camera_for(
        Some(&spec),
        bounds,
        kind,
        width,
        height,
    )?))
}
