//! Orbit, pan and zoom about a target point, starting from (and reset to) a camera.

use glam::{Quat, Vec3};

/// A camera orbiting its target: the eye's offset from the target rotated by mouse drags,
/// the target moved by panning, the distance scaled by zooming.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    /// The point looked at.
    pub target: Vec3,
    /// The eye's offset from the target.
    pub offset: Vec3,
    /// Up direction.
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov: f32,
}

impl Orbit {
    /// From an eye, a target and an up direction.
    pub fn new(eye: Vec3, target: Vec3, up: Vec3, fov: f32) -> Self {
        let offset = eye - target;
        let offset = if offset.length() > 0.0 && offset.is_finite() {
            offset
        } else {
            Vec3::Z
        };
        let up = if up.cross(offset).length() > 1e-6 {
            up.normalize()
        } else {
            offset.any_orthonormal_vector()
        };
        Self {
            target,
            offset,
            up,
            fov,
        }
    }

    /// The eye position.
    pub fn eye(&self) -> Vec3 {
        self.target + self.offset
    }

    /// Rotates by `dx`, `dy` radians: about the up direction, then about the view's right
    /// axis (stopping short of the poles, so the up direction stays valid).
    pub fn rotate(&mut self, dx: f32, dy: f32) {
        let yaw = Quat::from_axis_angle(self.up, -dx);
        let mut o = yaw * self.offset;
        let right = self.up.cross(o).normalize_or_zero();
        if right != Vec3::ZERO {
            let pitched = Quat::from_axis_angle(right, dy) * o;
            // Keep at least ~3° from the up axis.
            if pitched.normalize().dot(self.up).abs() < 0.998 {
                o = pitched;
            }
        }
        self.offset = o;
    }

    /// Moves the target (and eye) by `dx`, `dy` in units of the view's height at the target.
    pub fn pan(&mut self, dx: f32, dy: f32) {
        let d = self.offset.length();
        let h = 2.0 * d * (0.5 * self.fov.to_radians()).tan();
        let forward = -self.offset.normalize();
        let right = forward.cross(self.up).normalize_or_zero();
        let up = right.cross(forward);
        self.target += h * (-dx * right + dy * up);
    }

    /// Scales the distance to the target by `factor` (below 1: closer).
    pub fn zoom(&mut self, factor: f32) {
        if factor.is_finite() && factor > 0.0 {
            let o = self.offset * factor;
            if o.length() > 1e-6 && o.length() < 1e12 {
                self.offset = o;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotating_keeps_the_distance_and_zooming_scales_it() {
        let mut o = Orbit::new(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y, 45.0);
        o.rotate(0.7, 0.3);
        assert!((o.offset.length() - 3.0).abs() < 1e-5);
        assert!(o.eye().x.abs() > 0.5, "yawed: {:?}", o.eye());
        o.zoom(0.5);
        assert!((o.offset.length() - 1.5).abs() < 1e-5);
        // Pitching past the pole is refused.
        for _ in 0..100 {
            o.rotate(0.0, 0.2);
        }
        assert!(o.offset.normalize().dot(Vec3::Y).abs() < 0.999);
    }

    #[test]
    fn panning_moves_target_and_eye_together() {
        let mut o = Orbit::new(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y, 45.0);
        let before = o.offset;
        o.pan(0.1, 0.0);
        assert_eq!(o.offset, before);
        assert!(o.target.x < 0.0 && o.target.y.abs() < 1e-6);
    }
}
