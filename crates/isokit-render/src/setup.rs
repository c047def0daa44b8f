//! From a scene file's `camera`, `lights` and `shading` tables to render settings.

use crate::{Light, RenderError, Shading, ShadingMode};
use glam::Vec3;
use isokit_field::{Aabb, Camera, Projection};
use isokit_levelset::scene::schema::{CameraSpec, LightSpec, ShadingSpec};

/// Perspective or orthographic projection of a camera given by eye, target, up and a
/// vertical field of view.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ProjectionKind {
    /// Pinhole camera with the given field of view.
    #[default]
    Perspective,
    /// Parallel projection showing what the perspective view shows in the plane of the
    /// target: `2 · |target − eye| · tan(fov/2)` world units vertically.
    Orthographic,
}

impl std::str::FromStr for ProjectionKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "perspective" | "persp" => Ok(Self::Perspective),
            "orthographic" | "ortho" => Ok(Self::Orthographic),
            _ => Err(format!(
                "unknown projection {s:?} (expected perspective or orthographic)"
            )),
        }
    }
}

/// A camera from eye, target, up and vertical field of view in degrees.
pub fn camera_from(
    eye: Vec3,
    target: Vec3,
    up: Vec3,
    fov_degrees: f32,
    kind: ProjectionKind,
    width: u32,
    height: u32,
) -> Result<Camera, RenderError> {
    if !(fov_degrees.is_finite() && fov_degrees > 0.0 && fov_degrees < 180.0) {
        return Err(RenderError::bad(
            "fov",
            fov_degrees,
            "must lie strictly between 0 and 180 degrees",
        ));
    }
    let projection = match kind {
        ProjectionKind::Perspective => Projection::Perspective {
            fov_y_degrees: fov_degrees,
        },
        ProjectionKind::Orthographic => Projection::Orthographic {
            height: 2.0 * (target - eye).length() * (0.5 * fov_degrees.to_radians()).tan(),
        },
    };
    Ok(Camera::look_at(eye, target, up, projection, width, height)?)
}

/// The scene's camera, or when it has none a camera framing `bounds` from the front
/// upper right (45° field of view).
pub fn camera_for_scene(
    spec: Option<&CameraSpec>,
    bounds: Aabb,
    kind: ProjectionKind,
    width: u32,
    height: u32,
) -> Result<Camera, RenderError> {
    match spec {
        Some(c) => camera_from(
            Vec3::from(c.eye),
            Vec3::from(c.target),
            Vec3::from(c.up),
            c.fov,
            kind,
            width,
            height,
        ),
        None => {
            let projection = match kind {
                ProjectionKind::Perspective => Projection::Perspective {
                    fov_y_degrees: 45.0,
                },
                ProjectionKind::Orthographic => Projection::Orthographic { height: 1.0 },
            };
            let from = Vec3::new(1.0, 0.7, 1.4);
            Ok(Camera::framing(bounds, from, projection, width, height)?)
        }
    }
}

/// Shading from the scene's `shading` table and `lights` (missing values take
/// [`Shading::default`]'s).
pub fn shading_for_scene(
    spec: Option<&ShadingSpec>,
    lights: &[LightSpec],
) -> Result<Shading, RenderError> {
    let mut sh = Shading::default();
    if let Some(s) = spec {
        if let Some(m) = &s.mode {
            sh.mode = m
                .parse::<ShadingMode>()
                .map_err(|_| RenderError::bad("shading.mode", m, "is not a shading mode"))?;
        }
        if let Some(c) = s.color {
            sh.color = Vec3::from(c);
        }
        if let Some(a) = s.ambient {
            sh.ambient = a;
        }
        if let Some(e) = s.shininess {
            sh.shininess = e;
        }
    }
    for (i, l) in lights.iter().enumerate() {
        if l.direction.is_none() && l.position.is_none() {
            return Err(RenderError::bad(
                "lights",
                i,
                "a light needs a direction (directional) or a position (point)",
            ));
        }
        sh.lights.push(Light {
            direction: l.direction.map(Vec3::from),
            position: l.position.map(Vec3::from),
            color: Vec3::from(l.color),
            intensity: l.intensity,
        });
    }
    sh.check()?;
    Ok(sh)
}
