//! Errors of the renderer.

use isokit_field::FieldError;
use isokit_io::IoError;

/// Largest image side in pixels that [`check_image_size`] accepts.
pub const MAX_IMAGE_SIDE: u32 = 16_384;

/// Largest image in pixels that [`check_image_size`] accepts (64 Mpixel: the G-buffer then
/// holds about 3.3 GiB).
pub const MAX_IMAGE_PIXELS: u64 = 1 << 26;

/// What can go wrong when rendering.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// The image is empty or too large; refused before anything is allocated.
    #[error(
        "image size {width}x{height} is not supported: each side must be 1 to {MAX_IMAGE_SIDE} pixels and the image at most {MAX_IMAGE_PIXELS} pixels"
    )]
    ImageSize {
        /// Requested width.
        width: u64,
        /// Requested height.
        height: u64,
    },
    /// A parameter is out of range.
    #[error("{name} = {value}: {why}")]
    BadParameter {
        /// The parameter.
        name: &'static str,
        /// Its value as given.
        value: String,
        /// What it must be.
        why: &'static str,
    },
    /// The volume cannot be ray cast (e.g. fewer than 2 samples along an axis).
    #[error("volume of {dims:?} samples: {why}")]
    BadVolume {
        /// Its dimensions.
        dims: [usize; 3],
        /// What is wrong.
        why: &'static str,
    },
    /// From the field core (grids, camera).
    #[error(transparent)]
    Field(#[from] FieldError),
    /// From file output.
    #[error(transparent)]
    Io(#[from] IoError),
    /// From the GPU (no adapter, a device or shader error, a limit exceeded).
    #[error(transparent)]
    Gpu(#[from] isokit_gpu::GpuError),
}

impl RenderError {
    pub(crate) fn bad(name: &'static str, value: impl ToString, why: &'static str) -> Self {
        Self::BadParameter {
            name,
            value: value.to_string(),
            why,
        }
    }
}

/// Bytes held per pixel while rendering, for the memory budget: the G-buffer sample (64),
/// its sample count, the shaded linear and 8-bit images and working copies.
pub const BYTES_PER_PIXEL: u64 = 128;

/// Checks an image size against [`MAX_IMAGE_SIDE`] and [`MAX_IMAGE_PIXELS`], and what it
/// holds ([`BYTES_PER_PIXEL`] each) against the memory budget ([`isokit_field::memory`]),
/// before anything is allocated; takes `u64` so that any number a user types can be checked.
///
/// ```
/// use isokit_render::check_image_size;
/// assert!(check_image_size(512, 512).is_ok());
/// assert!(check_image_size(0, 512).is_err());
/// assert!(check_image_size(1 << 40, 1 << 40).is_err());
/// ```
pub fn check_image_size(width: u64, height: u64) -> Result<(u32, u32), RenderError> {
    let side = 1..=u64::from(MAX_IMAGE_SIDE);
    if !side.contains(&width)
        || !side.contains(&height)
        || width.saturating_mul(height) > MAX_IMAGE_PIXELS
    {
        return Err(RenderError::ImageSize { width, height });
    }
    isokit_field::memory::check(
        &format!("the G-buffer and image of {width}x{height} pixels"),
        u128::from(width * height) * u128::from(BYTES_PER_PIXEL),
        "render a smaller image (--width, --height), or raise the budget",
    )?;
    Ok((width as u32, height as u32))
}
