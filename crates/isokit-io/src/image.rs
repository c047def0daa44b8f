//! Images: PNG (sRGB 8-bit RGBA) and OpenEXR (named linear f32 channels). Row 0 is the top
//! row in both.

use std::io::Cursor as IoCursor;
use std::path::Path;

use crate::IoError;
use crate::atomic::atomic_write_bytes;
use crate::util::read_file;

/// Encodes an 8-bit RGBA image (row 0 at the top, `width * height * 4` bytes) as PNG and
/// writes it atomically.
pub fn write_png(path: &Path, width: u32, height: u32, rgba8: &[u8]) -> Result<(), IoError> {
    let buf = encode(width, height, rgba8).map_err(|m| IoError::invalid_input(path, m))?;
    atomic_write_bytes(path, &buf)
}

/// The PNG file [`write_png`] would write, in memory (e.g. for a notebook's `_repr_png_`);
/// `name` names the image in errors.
pub fn encode_png(width: u32, height: u32, rgba8: &[u8], name: &str) -> Result<Vec<u8>, IoError> {
    encode(width, height, rgba8).map_err(|m| IoError::invalid_input(Path::new(name), m))
}

fn encode(width: u32, height: u32, rgba8: &[u8]) -> Result<Vec<u8>, String> {
    let want = width as u128 * height as u128 * 4;
    if width == 0 || height == 0 {
        return Err(format!("image size {width}x{height} is empty"));
    }
    if rgba8.len() as u128 != want {
        return Err(format!(
            "{} bytes for a {width}x{height} RGBA image (need {want})",
            rgba8.len()
        ));
    }
    let mut buf = Vec::with_capacity(rgba8.len() / 2 + 1024);
    {
        let mut enc = png::Encoder::new(&mut buf, width, height);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let mut w = enc
            .write_header()
            .map_err(|e| format!("PNG encoder: {e}"))?;
        w.write_image_data(rgba8)
            .map_err(|e| format!("PNG encoder: {e}"))?;
        w.finish().map_err(|e| format!("PNG encoder: {e}"))?;
    }
    Ok(buf)
}

/// Reads a PNG as 8-bit RGBA (row 0 at the top): gray, gray+alpha, RGB and palette images
/// are expanded, 16-bit samples reduced to 8 bits, missing alpha set to 255. Returns
/// `(width, height, pixels)`. For an animated PNG, the first frame.
pub fn read_png(path: &Path) -> Result<(u32, u32, Vec<u8>), IoError> {
    let bytes = read_file(path)?;
    read_png_bytes(&bytes, path.to_string_lossy().as_ref())
}

/// [`read_png`] on bytes in memory; `name` is used in messages.
pub fn read_png_bytes(bytes: &[u8], name: &str) -> Result<(u32, u32, Vec<u8>), IoError> {
    let path = Path::new(name);
    let bad = |e: png::DecodingError| IoError::malformed(path, format!("PNG: {e}"));
    let mut dec = png::Decoder::new(IoCursor::new(bytes));
    dec.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = dec.read_info().map_err(bad)?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| IoError::malformed(path, "PNG: image too large"))?;
    // Deflate expands at most about 1032:1: refuse headers that promise more pixels than the
    // compressed data could possibly hold, before allocating the output.
    if size as u128 > 1100 * bytes.len() as u128 + (1 << 16) {
        let info = reader.info();
        return Err(IoError::malformed(
            path,
            format!(
                "PNG: header promises {}x{} pixels, more than {} bytes of data can hold",
                info.width,
                info.height,
                bytes.len()
            ),
        ));
    }
    let mut buf = vec![0u8; size];
    let info = reader.next_frame(&mut buf).map_err(bad)?;
    let (w, h) = (info.width, info.height);
    let px = w as usize * h as usize;
    let data = &buf[..info.buffer_size().min(buf.len())];
    let rgba: Vec<u8> = match info.color_type {
        png::ColorType::Rgba => data.get(..px * 4).map(<[u8]>::to_vec).unwrap_or_default(),
        png::ColorType::Rgb => data
            .chunks_exact(3)
            .take(px)
            .flat_map(|c| [c[0], c[1], c[2], 255])
            .collect(),
        png::ColorType::GrayscaleAlpha => data
            .chunks_exact(2)
            .take(px)
            .flat_map(|c| [c[0], c[0], c[0], c[1]])
            .collect(),
        png::ColorType::Grayscale => data.iter().take(px).flat_map(|&g| [g, g, g, 255]).collect(),
        png::ColorType::Indexed => {
            return Err(IoError::unsupported(
                path,
                "PNG palette image that could not be expanded",
            ));
        }
    };
    if rgba.len() != px * 4 {
        return Err(IoError::malformed(
            path,
            "PNG: decoded data is shorter than the image",
        ));
    }
    Ok((w, h, rgba))
}

/// Encodes a linear value in `[0, 1]` as an 8-bit sRGB value (values outside are clamped,
/// NaN becomes 0): the sRGB curve (IEC 61966-2-1) rounded to the nearest code.
///
/// The curve is monotone, so the code of `v` is the number of codes' thresholds at or below
/// it (the smallest linear value each code starts at, found once from the curve itself).
/// A table over the float's top bits holds the code at the start of each run of 2¹⁶ floats
/// and the one threshold inside it: a lookup and a comparison instead of a power per
/// channel, and the same code bit for bit.
pub fn linear_to_srgb8(v: f32) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    let run = srgb8_runs()[(v.to_bits() >> RUN_BITS) as usize];
    match run.next {
        Some(t) => run.code + u8::from(v >= t),
        // Two thresholds or more in the run (none with 2¹⁶ floats; kept for safety).
        None => srgb8_thresholds().partition_point(|&t| t <= v) as u8,
    }
}

/// Floats per run of the table of [`linear_to_srgb8`]: `2^RUN_BITS`.
const RUN_BITS: u32 = 16;

/// A run of [`linear_to_srgb8`]'s table: the code of its first float and the threshold of
/// the next code (`+∞` past the last code) where the run holds at most one threshold,
/// `None` where it holds more.
#[derive(Clone, Copy)]
struct Run {
    code: u8,
    next: Option<f32>,
}

fn srgb8_runs() -> &'static [Run] {
    static RUNS: std::sync::OnceLock<Vec<Run>> = std::sync::OnceLock::new();
    RUNS.get_or_init(|| {
        let t = srgb8_thresholds();
        let one = 1f32.to_bits();
        (0..=one >> RUN_BITS)
            .map(|r| {
                let first = f32::from_bits(r << RUN_BITS);
                let last = f32::from_bits((((r + 1) << RUN_BITS) - 1).min(one));
                let code = t.partition_point(|&x| x <= first);
                let next = t.get(code).copied().unwrap_or(f32::INFINITY);
                let single = t.get(code + 1).is_none_or(|&after| after > last);
                Run {
                    code: code as u8,
                    next: single.then_some(next),
                }
            })
            .collect()
    })
}

/// [`linear_to_srgb8`] by the curve's formula.
pub fn linear_to_srgb8_formula(v: f32) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    let s = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5).clamp(0.0, 255.0) as u8
}

/// For each code `k` in 1..=255, the smallest `v` in `[0, 1]` that
/// [`linear_to_srgb8_formula`] encodes as `k` or more (bisection over the bit patterns of
/// non-negative floats, which order as the values do).
fn srgb8_thresholds() -> &'static [f32; 255] {
    static THRESHOLDS: std::sync::OnceLock<[f32; 255]> = std::sync::OnceLock::new();
    THRESHOLDS.get_or_init(|| {
        std::array::from_fn(|i| {
            let code = (i + 1) as u8;
            // The formula gives 0 at 0 and 255 at 1.
            let (mut lo, mut hi) = (0u32, 1f32.to_bits());
            while hi - lo > 1 {
                let mid = lo + (hi - lo) / 2;
                if linear_to_srgb8_formula(f32::from_bits(mid)) >= code {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            f32::from_bits(hi)
        })
    })
}

/// Decodes an 8-bit sRGB value to linear in `[0, 1]`.
pub fn srgb8_to_linear(v: u8) -> f32 {
    let s = v as f32 / 255.0;
    if s <= 0.040_45 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

/// Writes an OpenEXR image of named f32 channels (e.g. `"Z"`, `"N.X"`, `"R"`), each holding
/// `width * height` linear values with row 0 at the top, losslessly compressed (RLE), and
/// writes it atomically. Channel names must be non-empty, unique and Latin-1.
pub fn write_exr(
    path: &Path,
    width: usize,
    height: usize,
    channels: &[(&str, &[f32])],
) -> Result<(), IoError> {
    write_exr_with_camera(path, width, height, channels, None)
}

/// The camera of an image, as the OpenEXR standard attributes `worldToCamera` and
/// `worldToNDC` (OpenEXR, "Standard Attributes": 4×4 float matrices, `m44f`).
///
/// Imath's convention: points are row vectors multiplied on the left, `p' = p · M`, and
/// the 16 floats are row after row, so the translation is in floats 12, 13, 14. That is
/// the column-major storage of the column-vector matrix `M` with `p' = M · p`
/// (`glam::Mat4::to_cols_array`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExrCamera {
    /// World to camera space (the view matrix: camera at the origin looking down −z, +y up).
    pub world_to_camera: [f32; 16],
    /// World to normalized device coordinates (the projection times the view matrix).
    pub world_to_ndc: [f32; 16],
}

/// [`write_exr`] with the camera's matrices in the header ([`ExrCamera`]) when given.
pub fn write_exr_with_camera(
    path: &Path,
    width: usize,
    height: usize,
    channels: &[(&str, &[f32])],
    camera: Option<&ExrCamera>,
) -> Result<(), IoError> {
    use exr::prelude::*;
    if width == 0 || height == 0 {
        return Err(IoError::invalid_input(
            path,
            format!("image size {width}x{height} is empty"),
        ));
    }
    let Some(px) = width.checked_mul(height) else {
        return Err(IoError::invalid_input(path, "image size overflows"));
    };
    if channels.is_empty() {
        return Err(IoError::invalid_input(path, "no channels to write"));
    }
    let mut list: Vec<AnyChannel<FlatSamples>> = Vec::with_capacity(channels.len());
    for (i, (name, data)) in channels.iter().enumerate() {
        if data.len() != px {
            return Err(IoError::invalid_input(
                path,
                format!(
                    "channel {name:?} holds {} values for {width}x{height} = {px} pixels",
                    data.len()
                ),
            ));
        }
        if name.is_empty() || name.len() > 255 {
            return Err(IoError::invalid_input(
                path,
                format!("channel name {name:?} must have 1 to 255 bytes"),
            ));
        }
        if channels[..i].iter().any(|(n, _)| n == name) {
            return Err(IoError::invalid_input(
                path,
                format!("channel name {name:?} is repeated"),
            ));
        }
        let text = Text::new_or_none(name)
            .filter(|t| !t.as_slice().contains(&0))
            .ok_or_else(|| {
                IoError::invalid_input(path, format!("channel name {name:?} is not Latin-1 text"))
            })?;
        list.push(AnyChannel::new(text, FlatSamples::F32(data.to_vec())));
    }
    if camera.is_some_and(|c| {
        !(c.world_to_camera.iter().all(|v| v.is_finite())
            && c.world_to_ndc.iter().all(|v| v.is_finite()))
    }) {
        return Err(IoError::invalid_input(
            path,
            "the camera matrices must be finite",
        ));
    }
    let attributes = LayerAttributes {
        world_to_camera: camera.map(|c| c.world_to_camera),
        world_to_normalized_device: camera.map(|c| c.world_to_ndc),
        ..LayerAttributes::default()
    };
    let layer = Layer::new(
        (width, height),
        attributes,
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(list.into()),
    );
    let image = Image::from_layer(layer);
    let mut buf = IoCursor::new(Vec::new());
    image
        .write()
        .non_parallel()
        .to_buffered(&mut buf)
        .map_err(|e| IoError::invalid_input(path, format!("EXR encoder: {e}")))?;
    atomic_write_bytes(path, &buf.into_inner())
}

/// What [`read_exr_info`] reads from an OpenEXR header (the pixels are not read).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ExrInfo {
    /// Width of the first layer in pixels.
    pub width: usize,
    /// Height of the first layer in pixels.
    pub height: usize,
    /// Channel names of all layers, in file order (e.g. `["N.X", "N.Y", "N.Z", "Z"]`).
    pub channels: Vec<String>,
    /// Number of layers (parts); 1 for the files [`write_exr`] writes.
    pub layers: usize,
}

/// The pixels of an OpenEXR file's first layer, as [`read_exr`] decodes them.
#[derive(Clone, Debug, PartialEq)]
pub struct ExrImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// The channels in file order (EXR sorts them by name), each `width * height` values
    /// with row 0 at the top; half-float and integer channels are converted to f32.
    pub channels: Vec<(String, Vec<f32>)>,
    /// The camera, when the header has both `worldToCamera` and `worldToNDC`
    /// ([`write_exr_with_camera`] writes them).
    pub camera: Option<ExrCamera>,
}

impl ExrImage {
    /// The channel called `name`, if the image has one.
    pub fn channel(&self, name: &str) -> Option<&[f32]> {
        self.channels
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.as_slice())
    }
}

/// The most samples (pixels times channels) [`read_exr`] decodes: the header is checked
/// before any pixel is allocated.
pub const MAX_EXR_SAMPLES: usize = 1 << 28;

/// Reads the first layer of an OpenEXR file with all its channels (flat images only, as
/// [`write_exr`] writes them). Refuses, from the header alone, images of more than
/// [`MAX_EXR_SAMPLES`] samples.
pub fn read_exr(path: &Path) -> Result<ExrImage, IoError> {
    let bytes = std::fs::read(path).map_err(|e| IoError::io(path, e))?;
    read_exr_bytes(&bytes, &path.display().to_string())
}

/// [`read_exr`] on bytes in memory; `name` is used in messages.
pub fn read_exr_bytes(bytes: &[u8], name: &str) -> Result<ExrImage, IoError> {
    use exr::prelude::*;
    let path = Path::new(name);
    let info = read_exr_info_bytes(bytes, name)?;
    let samples = info
        .width
        .checked_mul(info.height)
        .and_then(|px| px.checked_mul(info.channels.len()));
    if samples.is_none_or(|n| n > MAX_EXR_SAMPLES) {
        return Err(IoError::invalid_input(
            path,
            format!(
                "EXR of {}x{} pixels with {} channels is larger than {MAX_EXR_SAMPLES} samples",
                info.width,
                info.height,
                info.channels.len()
            ),
        ));
    }
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .non_parallel()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(|e| IoError::malformed(path, format!("EXR: {e}")))?;
    let layer = image.layer_data;
    let (width, height) = (layer.size.0, layer.size.1);
    let a = &layer.attributes;
    let camera = match (a.world_to_camera, a.world_to_normalized_device) {
        (Some(world_to_camera), Some(world_to_ndc)) => Some(ExrCamera {
            world_to_camera,
            world_to_ndc,
        }),
        _ => None,
    };
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect();
    Ok(ExrImage {
        width,
        height,
        channels,
        camera,
    })
}

/// Reads the header of an OpenEXR file: size and channel names, without decoding pixels
/// ([`read_exr`] decodes them).
pub fn read_exr_info(path: &Path) -> Result<ExrInfo, IoError> {
    let file = std::fs::File::open(path).map_err(|e| IoError::io(path, e))?;
    exr_info(exr::meta::MetaData::read_from_unbuffered(file, false), path)
}

/// [`read_exr_info`] on bytes in memory; `name` is used in messages.
pub fn read_exr_info_bytes(bytes: &[u8], name: &str) -> Result<ExrInfo, IoError> {
    let path = Path::new(name);
    exr_info(exr::meta::MetaData::read_from_buffered(bytes, false), path)
}

fn exr_info(
    meta: exr::error::Result<exr::meta::MetaData>,
    path: &Path,
) -> Result<ExrInfo, IoError> {
    let meta = meta.map_err(|e| match e {
        exr::error::Error::Io(e) if e.kind() != std::io::ErrorKind::UnexpectedEof => {
            IoError::io(path, e)
        }
        exr::error::Error::Io(_) => IoError::malformed(path, "EXR: file ends inside the header"),
        exr::error::Error::NotSupported(what) => IoError::unsupported(path, format!("EXR {what}")),
        other => IoError::malformed(path, format!("EXR: {other}")),
    })?;
    let Some(first) = meta.headers.first() else {
        return Err(IoError::malformed(path, "EXR: no layer header"));
    };
    Ok(ExrInfo {
        width: first.layer_size.0,
        height: first.layer_size.1,
        channels: meta
            .headers
            .iter()
            .flat_map(|h| h.channels.list.iter().map(|c| c.name.to_string()))
            .collect(),
        layers: meta.headers.len(),
    })
}

#[cfg(test)]
mod png_tests {
    use super::*;

    #[test]
    fn encoded_png_reads_back() {
        let rgba: Vec<u8> = (0..3 * 2 * 4).map(|i| (i * 10) as u8).collect();
        let bytes = encode_png(3, 2, &rgba, "mem.png").unwrap();
        assert_eq!(read_png_bytes(&bytes, "mem.png").unwrap(), (3, 2, rgba));
        let e = encode_png(3, 2, &[0; 5], "mem.png")
            .unwrap_err()
            .to_string();
        assert!(e.contains("mem.png") && e.contains("need 24"), "{e}");
    }
}
