//! Point clouds as plain data: [`PointCloud`] (points and optional normals). Reading and
//! writing cloud files is `isokit-io`'s job.

use glam::Vec3;

use crate::Aabb;

/// Points with optional per-point normals (same length as `points` when present).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointCloud {
    /// Point positions in world units.
    pub points: Vec<Vec3>,
    /// One normal per point, when the file has them (not necessarily unit length).
    pub normals: Option<Vec<Vec3>>,
}

impl PointCloud {
    /// The box around all finite points.
    pub fn bounds(&self) -> Aabb {
        Aabb::from_points(&self.points)
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when there are no points.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The problem with the normals, if any: a count that differs from the points'.
    pub fn normals_problem(&self) -> Option<String> {
        match &self.normals {
            Some(n) if n.len() != self.points.len() => Some(format!(
                "{} normals for {} points",
                n.len(),
                self.points.len()
            )),
            _ => None,
        }
    }
}
