//! The G-buffer: one [`GSample`] per pixel, written by the ray caster and read by deferred
//! shading; saved as OpenEXR.

use crate::RenderError;
use crate::kernel::GSample;
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
#[derive(Clone, Debug, PartialEq)]
pub struct GBuffer {
    width: u32,
    height: u32,
    pixels: Vec<GSample>,
    samples: Vec<u32>,
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
    /// nothing hold 0 in every channel (`A = 0`).
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
            plane(&|_| 1.0),
        ]
    }

    /// Checks that an OpenEXR image (e.g. [`isokit_io::read_exr`] of a file
    /// [`GBuffer::write_exr`] wrote) holds exactly this G-buffer: the same size and, for every
    /// channel of [`GBUFFER_CHANNELS`], every pixel's value bit for bit (the sample's field
    /// where the pixel hits, 0 where it misses; `A` is 1 on hits). The error names the first
    /// difference.
    pub fn matches_exr(&self, image: &isokit_io::ExrImage) -> Result<(), String> {
        if (image.width, image.height) != (self.width as usize, self.height as usize) {
            return Err(format!(
                "size {}x{} in the file, {}x{} in memory",
                image.width, image.height, self.width, self.height
            ));
        }
        let fields: [fn(&GSample) -> f32; 10] = [
            |p| p.position.x,
            |p| p.position.y,
            |p| p.position.z,
            |p| p.normal.x,
            |p| p.normal.y,
            |p| p.normal.z,
            |p| p.depth,
            |p| p.k1,
            |p| p.k2,
            |_| 1.0,
        ];
        for (name, field) in GBUFFER_CHANNELS.iter().zip(fields) {
            let data = image
                .channel(name)
                .ok_or_else(|| format!("channel {name} is missing"))?;
            for (i, (p, &v)) in self.pixels.iter().zip(data).enumerate() {
                let want = if p.is_hit() { field(p) } else { 0.0 };
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
        let planes = self.channels();
        let list: Vec<(&str, &[f32])> = GBUFFER_CHANNELS
            .iter()
            .zip(planes.iter())
            .map(|(n, p)| (*n, p.as_slice()))
            .collect();
        isokit_io::write_exr(path, self.width as usize, self.height as usize, &list)?;
        Ok(())
    }
}
