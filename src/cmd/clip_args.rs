//! `--clip SCENE|VOLUME [--clip-invert]`: clipping a volume by a closed shape while
//! rendering it (Westermann and Ertl 1998, Sec. 2.1; `isokit_render::clip`).

use super::volume_args::VolumeIn;
use anyhow::{Context, Result};
use glam::Vec3;
use isokit_field::{Aabb, Field, Grid};
use isokit_render::clip::Clip;
use isokit_scene::{Scene, SceneFormat};
use std::path::{Path, PathBuf};

/// The clip of `isokit render`.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ClipArgs {
    /// Clip the volume by a shape: keep only where its field is positive (outside a closed
    /// shape, on the side a plane's normal points to). A scene file (planes, boxes, meshes
    /// through their signed distance, any CSG) or a volume (resampled onto the rendered
    /// volume's lattice when it has another). In --mode dvr no sample where the clip cuts
    /// contributes; an isosurface is cut open and its cut face (the cap) shaded with the
    /// volume's values on it.
    #[arg(long, value_name = "SCENE|VOLUME")]
    pub clip: Option<PathBuf>,
    /// Keep where the clip's field is negative (inside the clip shape) instead.
    #[arg(long, requires = "clip")]
    pub clip_invert: bool,
}

/// A scene's field clamped a few voxels from its surface: the clip only needs its sign
/// and, near the surface, its value (clamping keeps both, and keeps the bound on the
/// slope), so meshes and deep CSG trees are pruned by their bounding boxes.
struct Clamped<'a>(&'a Scene, f32);

impl Field for Clamped<'_> {
    fn value(&self, p: Vec3) -> f32 {
        self.0.value_clamped(p, self.1)
    }
    fn bounds(&self) -> Aabb {
        self.0.field().bounds()
    }
}

/// Voxels from the clip's surface beyond which a scene's clip field is clamped.
const CLAMP_VOXELS: f32 = 4.0;

impl ClipArgs {
    /// The clip on `volume`'s lattice, when `--clip` is given.
    pub fn load(&self, volume: &Grid, reader: &VolumeIn) -> Result<Option<Clip>> {
        let Some(path) = &self.clip else {
            return Ok(None);
        };
        let ctx = || format!("--clip {}", path.display());
        let clip = if SceneFormat::from_path(path).is_some() {
            let scene = Scene::load(path).with_context(ctx)?;
            let field = Clamped(&scene, CLAMP_VOXELS * volume.spacing());
            Clip::from_field(&field, volume, self.clip_invert)
        } else {
            let grid = reader.read_grid(path).with_context(ctx)?;
            Clip::resampled(&grid, volume, self.clip_invert)
        };
        Ok(Some(clip.with_context(ctx)?))
    }

    /// The clip's file, to watch beside the input.
    pub fn file(&self) -> Option<&Path> {
        self.clip.as_deref()
    }
}
