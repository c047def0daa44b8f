//! Errors of the field core.

/// What can go wrong when building grids and fields from user parameters.
#[derive(Clone, Debug, thiserror::Error, PartialEq)]
pub enum FieldError {
    /// A grid dimension is zero.
    #[error("grid dimensions {0:?} must all be at least 1")]
    EmptyDims([usize; 3]),
    /// The grid would hold more samples than [`crate::MAX_SAMPLES`]; refused before allocating.
    #[error(
        "grid of {dims:?} samples is too large ({samples} samples; the limit is {limit}, about {limit_gib} GiB of f32)"
    )]
    TooLarge {
        /// Requested dimensions.
        dims: [usize; 3],
        /// Their product (saturated at `u128::MAX`).
        samples: u128,
        /// The limit in samples.
        limit: usize,
        /// The limit in GiB of f32 storage.
        limit_gib: usize,
    },
    /// An axis has more than [`crate::MAX_AXIS`] samples (refused so that signed 32-bit
    /// sample coordinates, with room for filter taps and aprons, never overflow).
    #[error("grid dimensions {dims:?}: an axis of more than {limit} samples is not supported")]
    AxisTooLong {
        /// Requested dimensions.
        dims: [usize; 3],
        /// The limit per axis ([`crate::MAX_AXIS`]).
        limit: usize,
    },
    /// Spacing must be finite and positive.
    #[error("grid spacing {0} must be finite and positive")]
    BadSpacing(f32),
    /// Origin must be finite.
    #[error("grid origin {0:?} must be finite")]
    BadOrigin([f32; 3]),
    /// The sample buffer has the wrong length.
    #[error("sample buffer holds {got} values but dimensions {dims:?} need {want}")]
    DataLength {
        /// Dimensions.
        dims: [usize; 3],
        /// Expected length.
        want: usize,
        /// Actual length.
        got: usize,
    },
    /// Bounds to sample are empty or not finite.
    #[error("bounds {0} are empty or not finite; give explicit bounds")]
    BadBounds(crate::Aabb),
    /// A stage would hold more bytes than the memory budget ([`crate::memory`]); refused
    /// before allocating.
    #[error("{}", crate::memory::refusal(what, *bytes, *budget, fit))]
    OverBudget {
        /// What would not fit, e.g. "a dense grid of 1200 x 1200 x 1200 samples".
        what: String,
        /// The bytes it would hold.
        bytes: u128,
        /// The budget in force.
        budget: u64,
        /// How to make it fit.
        fit: String,
    },
    /// The computation's [`crate::Job`] was cancelled.
    #[error(transparent)]
    Cancelled(#[from] crate::Cancelled),
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
}

impl FieldError {
    /// A [`FieldError::BadParameter`] with the value printed with `{:?}`.
    pub(crate) fn bad(name: &'static str, value: impl std::fmt::Debug, why: &'static str) -> Self {
        FieldError::BadParameter {
            name,
            value: format!("{value:?}"),
            why,
        }
    }
}
