//! Errors of octree construction and export.

use isokit_field::FieldError;

/// What can go wrong when building or exporting an octree from user parameters and fields.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum OctreeError {
    /// The build's [`isokit_field::Job`] was cancelled.
    #[error(transparent)]
    Cancelled(#[from] isokit_field::Cancelled),
    /// A parameter is out of its valid range.
    #[error("invalid parameter {name} = {value}: {why}")]
    BadParameter {
        /// Parameter name.
        name: &'static str,
        /// Its value, printed.
        value: String,
        /// What is allowed.
        why: &'static str,
    },
    /// The domain to sample is empty or not finite.
    #[error("domain {0} is empty or not finite; give explicit bounds")]
    BadDomain(isokit_field::Aabb),
    /// The field returned NaN or an infinite value at a sample.
    #[error("the field is not finite at ({x}, {y}, {z}): {value}")]
    NonFinite {
        /// Sample position x.
        x: f32,
        /// Sample position y.
        y: f32,
        /// Sample position z.
        z: f32,
        /// The value returned.
        value: f32,
    },
    /// The tree would grow beyond the cell budget ([`crate::BuildOptions::max_cells`]).
    #[error(
        "the octree would have more than {limit} cells; raise the error bound, lower the max level or raise the cell limit"
    )]
    TooManyCells {
        /// The budget.
        limit: usize,
    },
    /// A grid could not be made (too large, bad geometry).
    #[error(transparent)]
    Field(#[from] FieldError),
}

impl OctreeError {
    /// A [`OctreeError::BadParameter`] with the value printed with `{:?}`.
    pub(crate) fn bad(name: &'static str, value: impl std::fmt::Debug, why: &'static str) -> Self {
        OctreeError::BadParameter {
            name,
            value: format!("{value:?}"),
            why,
        }
    }
}
