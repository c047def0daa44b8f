//! The G-buffer: one [`GSample`] per pixel, written by the ray caster and read by deferred
//! shading; saved as OpenEXR.

use crate::RenderError;
use crate::kernel::GSample;
use isokit_field::Camera;
use std::path::Path;

/// EXR channel names of the G-buffer, in the order [`GBuffer::channels`] returns them:
/// world position, unit world normal, distance along the ray, principal curvatures, hit mask.
pub const GBUFFER_CHANNELS: [&str; 10] = [
    "P.X", "P.Y", "P.Z", "N.X", "N.Y", "N.Z", "Z", "K1", "K2", "A",
];

/// Per-pixel results of a rendering, row 0 at the top.
///
/// GPU layout (for the twin): the same data as four `rgba32float` textures,
/// `(P.xyz, Z)`, `(N.xyz, A)`, `(K1, K2, id, samples)`, `(dir1.xyz, 0)`.
#[derive(Debug, PartialEq)]
pub struct GBuffer {
    width: u32,
    height: u32,
    pixels: Vec<GSample>,
    samples: Vec<u32>,
    /// Per pixel the fraction of its rays that hit ([`crate::supersample`]); `None`: one
    /// ray per pixel, 1 on hits and 0 on misses.
    coverage: Option<Vec<f32>>,
}

impl Clone for GBuffer {
    fn clone(&self) -> Self {
        Self {
            width: self.width,
            height: self.height,
            pixels: self.pixels.clone(),
            samples: self.samples.clone(),
            coverage: self.coverage.clone(),
        }
    }

    /// Copies into the buffers `self` already has (a live viewer keeps a frame per edit:
    /// no fresh pages to fault in where the sizes match).
    fn clone_from(&mut self, source: &Self) {
        self.width = source.width;
        self.height = source.height;
        self.pixels.clone_from(&source.pixels);
        self.samples.clone_from(&source.samples);
        self.coverage.clone_from(&source.coverage);
    }
}

impl GBuffer {
    /// A G-buffer from its pixels (row-major, row 0 at the top) and per-pixel sample counts.
    ///
    /// # Panics
    /// When the lengths do not match `width · height` (a programming error, not input).
    pub fn new(width: u32, height: u32, pixels: Vec<GSample>, samples: Vec<u32>) -> Self {
        let n = width as usize * height as usize;
        assert!(pixels.len() == n && samples.len() == n, "G-buffer size");
        Self {
            width,
            height,
            pixels,
            samples,
            coverage: None,
        }
    }

    /// The G-buffer with per-pixel coverage, the fraction of each pixel's rays that hit
    /// (the `A` channel), from [`crate::supersample::resolve_gbuffer`].
    ///
    /// # Panics
    /// When the length does not match `width · height` (a programming error, not input).
    pub fn with_coverage(mut self, coverage: Vec<f32>) -> Self {
        assert!(coverage.len() == self.pixels.len(), "coverage size");
        self.coverage = Some(coverage);
        self
    }

    /// The `A` channel: per pixel the fraction of its rays that hit (1 or 0 with one ray
    /// per pixel).
    pub fn coverage(&self) -> Vec<f32> {
        match &self.coverage {
            Some(c) => c.clone(),
            None => self
                .pixels
                .iter()
                .map(|p| if p.is_hit() { 1.0 } else { 0.0 })
                .collect(),
        }
    }
    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }
    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }
    /// All pixels, row-major.
    pub fn pixels(&self) -> &[GSample] {
        &self.pixels
    }
    /// Pixel `(x, y)`.
    pub fn get(&self, x: u32, y: u32) -> &GSample {
        &self.pixels[x as usize + self.width as usize * y as usize]
    }
    /// Field evaluations per pixel.
    pub fn samples(&self) -> &[u32] {
        &self.samples
    }
    /// Pixels that hit something (surface or cap).
    pub fn hit_count(&self) -> usize {
        self.pixels.iter().filter(|p| p.is_hit()).count()
    }

    /// The channels [`GBUFFER_CHANNELS`] names, as linear f32 planes. Pixels that hit
    /// nothing hold 0 in every channel (`A = 0`); `A` is the coverage
    /// ([`GBuffer::coverage`]).
    pub fn channels(&self) -> [Vec<f32>; 10] {
        let plane = |f: &dyn Fn(&GSample) -> f32| -> Vec<f32> {
            self.pixels
                .iter()
                .map(|p| if p.is_hit() { f(p) } else { 0.0 })
                .collect()
        };
        [
            plane(&|p| p.position.x),
            plane(&|p| p.position.y),
            plane(&|p| p.position.z),
            plane(&|p| p.normal.x),
            plane(&|p| p.normal.y),
            plane(&|p| p.normal.z),
            plane(&|p| p.depth),
            plane(&|p| p.k1),
            plane(&|p| p.k2),
            self.coverage(),
        ]
    }

    /// Checks that an OpenEXR image (e.g. [`isokit_io::read_exr`] of a file
    /// [`GBuffer::write_exr`] wrote) holds exactly this G-buffer: the same size and, for every
    /// channel of [`GBUFFER_CHANNELS`], every pixel's value bit for bit (the sample's field
    /// where the pixel hits, 0 where it misses; `A` is the coverage). The error names the
    /// first difference.
    pub fn matches_exr(&self, image: &isokit_io::ExrImage) -> Result<(), String> {
        if (image.width, image.height) != (self.width as usize, self.height as usize) {
            return Err(format!(
                "size {}x{} in the file, {}x{} in memory",
                image.width, image.height, self.width, self.height
            ));
        }
        for (name, plane) in GBUFFER_CHANNELS.iter().zip(self.channels()) {
            let data = image
                .channel(name)
                .ok_or_else(|| format!("channel {name} is missing"))?;
            for (i, (&want, &v)) in plane.iter().zip(data).enumerate() {
                if v.to_bits() != want.to_bits() {
                    let (x, y) = (i % self.width as usize, i / self.width as usize);
                    return Err(format!(
                        "channel {name} at pixel ({x}, {y}): {v} in the file, {want} in memory"
                    ));
                }
            }
        }
        Ok(())
    }

    /// Writes the G-buffer as OpenEXR with the channels [`GBUFFER_CHANNELS`] (atomically).
    pub fn write_exr(&self, path: &Path) -> Result<(), RenderError> {
        self.write_exr_camera(path, None, &[])
    }

    /// [`GBuffer::write_exr`] with `camera`'s view and projection matrices in the header
    /// ([`exr_camera`]).
    pub fn write_exr_with_camera(&self, path: &Path, camera: &Camera) -> Result<(), RenderError> {
        self.write_exr_camera(path, Some(&exr_camera(camera)), &[])
    }

    /// [`GBuffer::write_exr_with_camera`] with more channels after the G-buffer's (each a
    /// name and one value per pixel, rows from the top).
    pub fn write_exr_with_channels(
        &self,
        path: &Path,
        camera: &Camera,
        extra: &[(&str, &[f32])],
    ) -> Result<(), RenderError> {
        self.write_exr_camera(path, Some(&exr_camera(camera)), extra)
    }

    fn write_exr_camera(
        &self,
        path: &Path,
        camera: Option<&isokit_io::ExrCamera>,
        extra: &[(&str, &[f32])],
    ) -> Result<(), RenderError> {
        let planes = self.channels();
        let list: Vec<(&str, &[f32])> = GBUFFER_CHANNELS
            .iter()
            .zip(planes.iter())
            .map(|(n, p)| (*n, p.as_slice()))
            .chain(extra.iter().copied())
            .collect();
        isokit_io::write_exr_with_camera(
            path,
            self.width as usize,
            self.height as usize,
            &list,
            camera,
        )?;
        Ok(())
    }
}

/// The near plane of [`exr_camera`]'s projection, as a fraction of the distance from the eye
/// to the target (the far plane is at [`EXR_FAR`] times that distance).
pub const EXR_NEAR: f32 = 0.01;
/// The far plane of [`exr_camera`]'s projection, in distances from the eye to the target.
pub const EXR_FAR: f32 = 100.0;

/// A camera as the OpenEXR header attributes `worldToCamera` ([`Camera::view_matrix`]) and
/// `worldToNDC` ([`Camera::projection_matrix`] times the view matrix, depth in [0, 1], the
/// near and far planes at [`EXR_NEAR`] and [`EXR_FAR`] times the distance from the eye to
/// the target).
pub fn exr_camera(camera: &Camera) -> isokit_io::ExrCamera {
    let d = (camera.target() - camera.eye()).length();
    let view = camera.view_matrix();
    let proj = camera.projection_matrix(EXR_NEAR * d, EXR_FAR * d);
    isokit_io::ExrCamera {
        world_to_camera: view.to_cols_array(),
        world_to_ndc: (proj * view).to_cols_array(),
    }
}
