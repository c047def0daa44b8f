//! The camera on the command line (`isokit render`, `isokit molecule`): eye, target, up,
//! field of view, projection and the orthographic view's height; the same camera as a scene
//! file's `camera` table ([`CameraSpec`]).

use super::parse_vec3;
use anyhow::{Result, bail};
use glam::Vec3;
use isokit_scene::{CameraSpec, ProjectionKind};

/// The camera.
#[derive(clap::Args, Debug, Clone)]
pub struct CameraArgs {
    /// Eye position "x,y,z" [default: the scene's `camera`, else a camera framing the
    /// bounds].
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true)]
    pub eye: Option<Vec3>,
    /// The point looked at "x,y,z" (with --eye) [default: 0,0,0].
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true, requires = "eye")]
    pub target: Option<Vec3>,
    /// Up direction "x,y,z" (with --eye) [default: 0,1,0].
    #[arg(long, value_parser = parse_vec3, allow_hyphen_values = true, requires = "eye")]
    pub up: Option<Vec3>,
    /// Vertical field of view in degrees (with --eye) [default: 45].
    #[arg(long, requires = "eye")]
    pub fov: Option<f32>,
    /// Projection: perspective or orthographic (same eye, target and field of view).
    #[arg(long, default_value = "perspective")]
    pub projection: String,
    /// With --projection orthographic and --eye: the view's height in world units
    /// [default: what the perspective view shows in the plane of the target,
    /// 2·|target − eye|·tan(fov/2)].
    #[arg(long, requires = "eye")]
    pub ortho_height: Option<f32>,
}

impl CameraArgs {
    /// The camera of a `width` × `height` image: the one given, else one framing `bounds`.
    pub fn camera_for(
        &self,
        bounds: isokit_field::Aabb,
        width: u32,
        height: u32,
    ) -> Result<isokit_field::Camera> {
        Ok(isokit_scene::camera_for(
            self.spec()?.as_ref(),
            bounds,
            self.projection()?,
            width,
            height,
        )?)
    }

    /// The projection.
    pub fn projection(&self) -> Result<ProjectionKind> {
        self.projection.parse().map_err(anyhow::Error::msg)
    }

    /// The camera given (a scene file's `camera` table with the same values renders the
    /// same image), `None` without `--eye`; checked.
    pub fn spec(&self) -> Result<Option<CameraSpec>> {
        let kind = self.projection()?;
        if let Some(h) = self.ortho_height {
            if kind != ProjectionKind::Orthographic {
                bail!("--ortho-height {h} needs --projection orthographic");
            }
            if !(h.is_finite() && h > 0.0) {
                bail!("--ortho-height {h}: must be finite and positive (world units)");
            }
        }
        if let Some(f) = self.fov
            && !(f.is_finite() && f > 0.0 && f < 180.0)
        {
            bail!("--fov {f}: must lie strictly between 0 and 180 degrees");
        }
        let Some(eye) = self.eye else {
            return Ok(None);
        };
        let target = self.target.unwrap_or(Vec3::ZERO);
        let up = self.up.unwrap_or(Vec3::Y);
        if (target - eye).length() < 1e-12 {
            bail!("--eye and --target must differ (both are {eye})");
        }
        if (target - eye).cross(up).length() < 1e-12 {
            bail!("--up {up} must not be parallel to the view direction (--target minus --eye)");
        }
        Ok(Some(CameraSpec {
            eye: eye.to_array(),
            target: target.to_array(),
            up: up.to_array(),
            fov: self.fov.unwrap_or(45.0),
            ortho_height: self.ortho_height,
        }))
    }
}
