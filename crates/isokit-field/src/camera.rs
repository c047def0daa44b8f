//! A look-at camera with perspective or orthographic projection, mapping pixels to rays.

use crate::{Aabb, FieldError};
use glam::{Mat4, Vec2, Vec3, Vec4};

/// How the camera projects.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Pinhole camera with a vertical field of view in degrees (0 < fov < 180).
    Perspective {
        /// Vertical field of view, degrees.
        fov_y_degrees: f32,
    },
    /// Parallel projection showing `height` world units vertically.
    Orthographic {
        /// Visible height in world units.
        height: f32,
    },
}

/// A ray `origin + t * dir` with unit `dir`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Start point.
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
}

impl Ray {
    /// Point at parameter `t`.
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + t * self.dir
    }
}

/// A camera looking from `eye` at `target`, with an image of `width` × `height` pixels.
///
/// Pixel coordinates have (0, 0) at the top-left corner of the image (row 0 at the top);
/// the centre of pixel (i, j) is at (i + 0.5, j + 0.5).
///
/// ```
/// use isokit_field::{Camera, Projection};
/// use glam::Vec3;
/// let cam = Camera::look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y,
///     Projection::Perspective { fov_y_degrees: 45.0 }, 64, 48).unwrap();
/// let ray = cam.ray(32.0, 24.0); // the image centre
/// assert!((ray.dir - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    eye: Vec3,
    target: Vec3,
    up: Vec3,
    projection: Projection,
    width: u32,
    height: u32,
    // Orthonormal frame: right, true up, and the viewing direction.
    right: Vec3,
    true_up: Vec3,
    forward: Vec3,
}

impl Camera {
    /// A camera at `eye` looking at `target` with `up` giving the vertical.
    ///
    /// Errors when the eye equals the target, `up` is parallel to the view direction, a
    /// value is not finite, the image is empty, or the projection parameter is out of range.
    pub fn look_at(
        eye: Vec3,
        target: Vec3,
        up: Vec3,
        projection: Projection,
        width: u32,
        height: u32,
    ) -> Result<Self, FieldError> {
        let bad = |name, value: String, why| Err(FieldError::BadParameter { name, value, why });
        if !(eye.is_finite() && target.is_finite() && up.is_finite()) {
            return bad("camera", format!("{eye} {target} {up}"), "must be finite");
        }
        if width == 0 || height == 0 {
            return bad(
                "image size",
                format!("{width}x{height}"),
                "must be at least 1x1",
            );
        }
        match projection {
            Projection::Perspective { fov_y_degrees: f }
                if !(f.is_finite() && f > 0.0 && f < 180.0) =>
            {
                return bad(
                    "fov",
                    f.to_string(),
                    "must lie strictly between 0 and 180 degrees",
                );
            }
            Projection::Orthographic { height: h } if !(h.is_finite() && h > 0.0) => {
                return bad("ortho height", h.to_string(), "must be finite and positive");
            }
            _ => {}
        }
        let forward = (target - eye).normalize_or_zero();
        if forward == Vec3::ZERO {
            return bad("target", format!("{target}"), "must differ from the eye");
        }
        let right = forward.cross(up).normalize_or_zero();
        if right == Vec3::ZERO || forward.cross(up.normalize()).length() < 1e-6 {
            return bad(
                "up",
                format!("{up}"),
                "must not be parallel to the view direction",
            );
        }
        let true_up = right.cross(forward);
        Ok(Self {
            eye,
            target,
            up,
            projection,
            width,
            height,
            right,
            true_up,
            forward,
        })
    }

    /// A camera looking at `bounds` from direction `from` (pointing from the target to the
    /// eye), far enough that the box's bounding sphere fills the view.
    pub fn framing(
        bounds: Aabb,
        from: Vec3,
        projection: Projection,
        width: u32,
        height: u32,
    ) -> Result<Self, FieldError> {
        if bounds.is_empty() || !bounds.is_finite() {
            return Err(FieldError::BadBounds(bounds));
        }
        let radius = (0.5 * bounds.diagonal()).max(1e-6);
        let dir = from.normalize_or(Vec3::Z);
        let aspect = width.max(1) as f32 / height.max(1) as f32;
        let (dist, proj) = match projection {
            Projection::Perspective { fov_y_degrees } => {
                let half = 0.5 * fov_y_degrees.to_radians();
                let half = if aspect < 1.0 {
                    (half.tan() * aspect).atan()
                } else {
                    half
                };
                (radius / half.sin().max(1e-3) * 1.05, projection)
            }
            Projection::Orthographic { .. } => (
                radius * 3.0,
                Projection::Orthographic {
                    height: 2.1 * radius / aspect.min(1.0),
                },
            ),
        };
        let up = if dir.cross(Vec3::Y).length() < 1e-3 {
            Vec3::Z
        } else {
            Vec3::Y
        };
        let c = bounds.center();
        Self::look_at(c + dir * dist, c, up, proj, width, height)
    }

    /// Eye position.
    pub fn eye(&self) -> Vec3 {
        self.eye
    }
    /// The point looked at.
    pub fn target(&self) -> Vec3 {
        self.target
    }
    /// The up vector as given.
    pub fn up(&self) -> Vec3 {
        self.up
    }
    /// Unit viewing direction.
    pub fn forward(&self) -> Vec3 {
        self.forward
    }
    /// The projection.
    pub fn projection(&self) -> Projection {
        self.projection
    }
    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }
    /// Image height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }
    /// Width over height.
    pub fn aspect(&self) -> f32 {
        self.width as f32 / self.height as f32
    }

    /// Half the view height at unit distance (perspective) or in world units (orthographic).
    fn half_height(&self) -> f32 {
        match self.projection {
            Projection::Perspective { fov_y_degrees } => (0.5 * fov_y_degrees.to_radians()).tan(),
            Projection::Orthographic { height } => 0.5 * height,
        }
    }

    /// The ray through pixel coordinates `(px, py)` (top-left origin; pass `i + 0.5` for a
    /// pixel centre).
    pub fn ray(&self, px: f32, py: f32) -> Ray {
        let h = self.half_height();
        let sx = (2.0 * px / self.width as f32 - 1.0) * h * self.aspect();
        let sy = (1.0 - 2.0 * py / self.height as f32) * h;
        match self.projection {
            Projection::Perspective { .. } => Ray {
                origin: self.eye,
                dir: (self.forward + sx * self.right + sy * self.true_up).normalize(),
            },
            Projection::Orthographic { .. } => Ray {
                origin: self.eye + sx * self.right + sy * self.true_up,
                dir: self.forward,
            },
        }
    }

    /// Projects a world point to pixel coordinates and its depth along the view direction.
    /// `None` for points behind (or at) a perspective eye.
    pub fn project(&self, p: Vec3) -> Option<(Vec2, f32)> {
        let d = p - self.eye;
        let depth = d.dot(self.forward);
        let (x, y) = (d.dot(self.right), d.dot(self.true_up));
        let h = self.half_height();
        let (sx, sy) = match self.projection {
            Projection::Perspective { .. } => {
                if depth <= 0.0 {
                    return None;
                }
                (x / depth, y / depth)
            }
            Projection::Orthographic { .. } => (x, y),
        };
        let px = (sx / (h * self.aspect()) + 1.0) * 0.5 * self.width as f32;
        let py = (1.0 - sy / h) * 0.5 * self.height as f32;
        Some((Vec2::new(px, py), depth))
    }

    /// Right-handed view matrix (world → camera, camera looks down −z).
    pub fn view_matrix(&self) -> Mat4 {
        glam::camera::rh::view::look_at_mat4(self.eye, self.target, self.true_up)
    }

    /// Right-handed projection matrix with depth in [0, 1] (wgpu convention).
    pub fn projection_matrix(&self, near: f32, far: f32) -> Mat4 {
        use glam::camera::rh::proj::directx;
        match self.projection {
            Projection::Perspective { fov_y_degrees } => {
                directx::perspective(fov_y_degrees.to_radians(), self.aspect(), near, far)
            }
            Projection::Orthographic { height } => {
                let (hw, hh) = (0.5 * height * self.aspect(), 0.5 * height);
                directx::orthographic(-hw, hw, -hh, hh, near, far)
            }
        }
    }

    /// Pixel coordinates of a point through the view and projection matrices (used to check
    /// that the matrices agree with [`Camera::ray`]).
    pub fn project_with_matrices(&self, p: Vec3, near: f32, far: f32) -> Option<Vec2> {
        let clip = self.projection_matrix(near, far) * self.view_matrix() * p.extend(1.0);
        if clip.w <= 0.0 {
            return None;
        }
        let ndc: Vec4 = clip / clip.w;
        Some(Vec2::new(
            (ndc.x + 1.0) * 0.5 * self.width as f32,
            (1.0 - ndc.y) * 0.5 * self.height as f32,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    fn cams() -> [Camera; 2] {
        let eye = Vec3::new(1.0, 2.0, 6.0);
        let t = Vec3::new(0.2, -0.1, 0.3);
        [
            Camera::look_at(
                eye,
                t,
                Vec3::Y,
                Projection::Perspective {
                    fov_y_degrees: 50.0,
                },
                80,
                60,
            )
            .unwrap(),
            Camera::look_at(
                eye,
                t,
                Vec3::Y,
                Projection::Orthographic { height: 3.0 },
                80,
                60,
            )
            .unwrap(),
        ]
    }

    #[test]
    fn rays_and_projection_round_trip() {
        let mut rng = SplitMix64::default();
        for cam in cams() {
            let c = cam.ray(40.0, 30.0);
            let to_target = (cam.target() - c.origin).normalize();
            assert!((c.dir - to_target).length() < 1e-5);
            for _ in 0..100 {
                let (px, py) = (rng.range(0.0, 80.0), rng.range(0.0, 60.0));
                let r = cam.ray(px, py);
                assert!((r.dir.length() - 1.0).abs() < 1e-5);
                let (pix, depth) = cam.project(r.at(rng.range(1.0, 9.0))).unwrap();
                assert!(
                    (pix - Vec2::new(px, py)).length() < 1e-2,
                    "{pix} vs {px},{py}"
                );
                assert!(depth > 0.0);
                let m = cam.project_with_matrices(r.at(3.0), 0.1, 100.0).unwrap();
                assert!((m - Vec2::new(px, py)).length() < 2e-2, "{m} vs {px},{py}");
            }
        }
    }

    #[test]
    fn row_zero_is_the_top() {
        let cam = Camera::look_at(
            Vec3::Z * 5.0,
            Vec3::ZERO,
            Vec3::Y,
            Projection::Perspective {
                fov_y_degrees: 60.0,
            },
            10,
            10,
        )
        .unwrap();
        assert!(cam.ray(5.0, 0.5).dir.y > 0.0);
        assert!(cam.ray(9.5, 5.0).dir.x > 0.0);
        let (p, _) = cam.project(Vec3::new(0.0, 1.0, 0.0)).unwrap();
        assert!(p.y < 5.0);
        assert!(cam.project(Vec3::Z * 6.0).is_none());
    }

    #[test]
    fn framing_sees_the_whole_box() {
        let b = Aabb::new(Vec3::new(-1.0, -2.0, -0.5), Vec3::new(3.0, 1.0, 0.5));
        for proj in [
            Projection::Perspective {
                fov_y_degrees: 40.0,
            },
            Projection::Orthographic { height: 1.0 },
        ] {
            for (w, h) in [(100, 50), (50, 100)] {
                let cam = Camera::framing(b, Vec3::new(1.0, 1.0, 1.0), proj, w, h).unwrap();
                for c in b.corners() {
                    let (p, _) = cam.project(c).unwrap();
                    assert!(
                        p.x >= 0.0 && p.x <= w as f32 && p.y >= 0.0 && p.y <= h as f32,
                        "{p}"
                    );
                }
            }
        }
    }

    #[test]
    fn bad_parameters_are_errors() {
        let p = Projection::Perspective {
            fov_y_degrees: 45.0,
        };
        assert!(Camera::look_at(Vec3::ZERO, Vec3::ZERO, Vec3::Y, p, 8, 8).is_err());
        assert!(Camera::look_at(Vec3::Z, Vec3::ZERO, Vec3::Z, p, 8, 8).is_err());
        assert!(Camera::look_at(Vec3::Z, Vec3::ZERO, Vec3::Y, p, 0, 8).is_err());
        assert!(Camera::look_at(Vec3::Z, Vec3::NAN, Vec3::Y, p, 8, 8).is_err());
        let bad = Projection::Perspective {
            fov_y_degrees: 180.0,
        };
        assert!(Camera::look_at(Vec3::Z, Vec3::ZERO, Vec3::Y, bad, 8, 8).is_err());
        let bad = Projection::Orthographic { height: -1.0 };
        assert!(Camera::look_at(Vec3::Z, Vec3::ZERO, Vec3::Y, bad, 8, 8).is_err());
        assert!(Camera::framing(Aabb::EMPTY, Vec3::Z, p, 8, 8).is_err());
    }
}
