//! Cameras from eye, target, up and a field of view, perspective or orthographic.

use crate::RenderError;
use glam::Vec3;
use isokit_field::{Camera, Projection};

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
