//! Errors of the point-cloud field.

use thiserror::Error;

/// What can go wrong building a field or normals from a point cloud.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum PointsError {
    /// The cloud has no points.
    #[error("the point cloud is empty")]
    Empty,
    /// A point has a NaN or infinite coordinate.
    #[error("point {index} is not finite ({x}, {y}, {z})")]
    NonFinitePoint {
        /// Index of the point.
        index: usize,
        /// Its x coordinate.
        x: f32,
        /// Its y coordinate.
        y: f32,
        /// Its z coordinate.
        z: f32,
    },
    /// A given normal is NaN, infinite or (near) zero length, so it has no direction.
    #[error("normal {index} has no direction (zero, NaN or infinite)")]
    BadNormal {
        /// Index of the point.
        index: usize,
    },
    /// The numbers of points and normals differ.
    #[error("{normals} normals for {points} points")]
    NormalCount {
        /// Number of points.
        points: usize,
        /// Number of normals.
        normals: usize,
    },
    /// Normals were asked to come from the file but it has none.
    #[error("the point cloud has no normals (estimate them instead)")]
    NoNormals,
    /// Too few points for the requested operation.
    #[error("{what} needs at least {need} points, the cloud has {have}")]
    TooFewPoints {
        /// What needed them.
        what: &'static str,
        /// How many are needed.
        need: usize,
        /// How many there are.
        have: usize,
    },
    /// A parameter is out of its range.
    #[error("invalid parameter: {0}")]
    Parameter(String),
}
