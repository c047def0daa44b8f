//! Frames after an edit of the field: the pixels of the last frame whose rays meet no
//! changed block are taken as they were, the others traced again (CPU twin).
//!
//! A ray's result depends only on the blocks its walk enters before it stops: their
//! samples (the search, the refinement and the derivatives at the hit read the block's
//! tricubic support and nothing else, [`kernel::locate`]), their ranges and slope bounds
//! (computed from the same support, [`Volume`]'s block scan) and, for inactive blocks, that
//! they are inactive. Where the walk starts ([`crate::StartRaster`]) and how far it jumps
//! over inactive blocks ([`kernel::jump`]) change no sample. So a ray of the same
//! uniforms whose path up to its old stopping point crosses only blocks whose support
//! holds the same samples, bit for bit, gives the same pixel: it is copied, not traced.

use crate::kernel::{self, GSample, Uniforms};
use crate::{Frame, GBuffer, Image, Layout, Shading, StartRaster, Volume, VolumeData};
use glam::Vec3;
use rayon::prelude::*;

/// A margin (voxels) on a ray's stopping parameter, far above its rounding ([`StartRaster`]'s
/// distances carry their own, 0.1 voxel and more). The samples of the crossing's bracket and
/// its refinement may lie a step past the hit, but in the hit's block, which the ray
/// entered before the hit: a block the raster's distance accounts for.
const FACE_MARGIN: f32 = 1e-2;

/// A finished frame kept for the next one ([`crate::render_reusing`]): the volume it
/// showed, its uniforms and its G-buffer (before shading).
#[derive(Clone, Debug)]
pub struct KeptFrame {
    volume: Volume,
    uniforms: Uniforms,
    gbuffer: GBuffer,
    /// The shaded image and the shading it was made with, once kept.
    image: Option<(Image, Shading)>,
    /// The image buffer of the frame kept before, for [`KeptFrame::keep_image`] to copy into.
    spare: Option<Image>,
    /// The frame was traced from a downsampled assignment of the cache (bricks at half
    /// resolution, their neighbours' hanging samples matched): other samples than the
    /// volume's, so none of its pixels is taken.
    downsampled: bool,
}

impl KeptFrame {
    /// Keeps `frame`, traced from `volume`. The volume is kept (its samples are compared
    /// with the next frame's): a band's samples are shared with it, a dense grid's copied,
    /// unless `earlier` already holds the same volume. The copies of the G-buffer (and of
    /// the image, [`KeptFrame::keep_image`]) go into `earlier`'s buffers.
    pub fn new(volume: &Volume, frame: &Frame, earlier: Option<KeptFrame>) -> Self {
        let downsampled = frame.stats.bricks_downsampled > 0;
        match earlier {
            Some(mut k) => {
                if k.volume.id() != volume.id() {
                    k.volume = volume.clone();
                }
                k.uniforms = frame.uniforms;
                k.gbuffer.clone_from(&frame.gbuffer);
                k.spare = k.image.take().map(|(i, _)| i).or(k.spare);
                k.downsampled = downsampled;
                k
            }
            None => Self {
                volume: volume.clone(),
                uniforms: frame.uniforms,
                gbuffer: frame.gbuffer.clone(),
                image: None,
                spare: None,
                downsampled,
            },
        }
    }

    /// Keeps the frame's shaded image too, made with `shading` ([`crate::shade_reusing`]).
    pub fn keep_image(&mut self, image: &Image, shading: &Shading) {
        let kept = match self.spare.take() {
            Some(mut i) => {
                i.width = image.width;
                i.height = image.height;
                i.pixels.clone_from(&image.pixels);
                i
            }
            None => image.clone(),
        };
        self.image = Some((kept, shading.clone()));
    }

    /// The kept G-buffer's pixels and image, where they were traced with uniforms `u` and
    /// shaded with `shading`.
    pub(crate) fn image_for(
        &self,
        u: &Uniforms,
        shading: &Shading,
    ) -> Option<(&[GSample], &Image)> {
        match &self.image {
            Some((image, sh)) if self.uniforms == *u && sh == shading => {
                Some((self.gbuffer.pixels(), image))
            }
            _ => None,
        }
    }

    /// The kept volume.
    pub fn volume(&self) -> &Volume {
        &self.volume
    }

    /// The uniforms the kept frame was traced with.
    pub fn uniforms(&self) -> &Uniforms {
        &self.uniforms
    }
}

/// The blocks of `after` whose tricubic support (`[block·b − 1, block·b + block + 1]` per
/// axis, as [`Volume`]'s block scan reads it) holds a sample that differs from `before`'s
/// bit for bit; `None` when the two volumes do not share a lattice and layout, or either
/// combines a second field (then every block counts as changed).
pub fn changed_blocks(before: &Volume, after: &Volume) -> Option<Vec<bool>> {
    if before.layout() != after.layout() || before.combine().is_some() || after.combine().is_some()
    {
        return None;
    }
    if before.id() == after.id() {
        return Some(vec![false; after.block_ranges().len()]);
    }
    if let Some(c) = after.changes_after(before.id()) {
        return Some(c.to_vec());
    }
    changed_between(before.data(), after.data(), after.layout())
}

/// [`changed_blocks`] of two volumes' samples under `layout`; `None` when they do not share
/// a lattice.
pub(crate) fn changed_between(
    before: &VolumeData,
    after: &VolumeData,
    layout: Layout,
) -> Option<Vec<bool>> {
    if before.dims() != after.dims()
        || before.origin() != after.origin()
        || before.spacing().to_bits() != after.spacing().to_bits()
    {
        return None;
    }
    let dims = after.dims();
    let b = layout.block as i64;
    let bd = dims.map(|d| (d - 1).div_ceil(layout.block));
    let nx = dims[0];
    // Blocks `c` whose support holds sample `s`: `c·b − 1 ≤ s ≤ c·b + b + 1`, so from
    // `ceil((s − b − 1) / b)` to `floor((s + 1) / b)`.
    let blocks_of = |s: usize, n: usize| {
        let s = s as i64;
        let lo = (s - 2).div_euclid(b).max(0);
        let hi = (s + 1).div_euclid(b).min(n as i64 - 1);
        lo as usize..=hi as usize
    };
    // Per z-row of samples (in parallel), the blocks its changed samples mark.
    let marks: Vec<Vec<usize>> = (0..dims[2])
        .into_par_iter()
        .map_init(
            || (vec![0f32; nx], vec![0f32; nx]),
            |(ra, rb), z| {
                let mut marked = Vec::new();
                for y in 0..dims[1] {
                    before.read_row(0, y as i32, z as i32, ra);
                    after.read_row(0, y as i32, z as i32, rb);
                    let mut x = 0;
                    while x < nx {
                        if ra[x].to_bits() == rb[x].to_bits() {
                            x += 1;
                            continue;
                        }
                        // Every block whose support holds sample (x, y, z); then on past
                        // the samples whose blocks those already are.
                        let xs = blocks_of(x, bd[0]);
                        for cz in blocks_of(z, bd[2]) {
                            for cy in blocks_of(y, bd[1]) {
                                for cx in xs.clone() {
                                    marked.push(cx + bd[0] * (cy + bd[1] * cz));
                                }
                            }
                        }
                        x = ((*xs.end() as i64 + 1) * b - 1).max(x as i64 + 1) as usize;
                    }
                }
                marked
            },
        )
        .collect();
    let mut changed = vec![false; bd.iter().product()];
    for n in marks.into_iter().flatten() {
        changed[n] = true;
    }
    Some(changed)
}

/// What a frame may take from a kept one.
pub(crate) struct Reuse<'k> {
    pixels: &'k [GSample],
    samples: &'k [u32],
    /// The changed blocks rastered onto tiles of the image: per tile, the smallest ray
    /// parameter at which a ray of the tile can reach one ([`StartRaster::of_blocks`]).
    changed: StartRaster,
}

impl<'k> Reuse<'k> {
    /// The reuse of `kept` for a frame of `volume` with uniforms `u`; `None` when nothing
    /// can be reused (other uniforms, another lattice, several views or subpixels, a kept
    /// frame traced from a downsampled cache).
    pub(crate) fn new(kept: &'k KeptFrame, volume: &Volume, u: &Uniforms) -> Option<Self> {
        if kept.uniforms != *u || kept.downsampled {
            return None;
        }
        let changed = changed_blocks(&kept.volume, volume)?;
        Some(Self {
            pixels: kept.gbuffer.pixels(),
            samples: kept.gbuffer.samples(),
            changed: StartRaster::of_blocks(u, &changed)?,
        })
    }

    /// The kept pixel `i` (ray `(px, py)`) and its sample count, when its ray stopped
    /// before it could reach a changed block: at its hit (past it by [`FACE_MARGIN`], the
    /// end of the refinement's bracket lies in the hit's block), at its cap (where it
    /// entered the volume), or, for a miss, when no changed block lies on its tile.
    pub(crate) fn pixel(&self, u: &Uniforms, i: usize, px: u32, py: u32) -> Option<(GSample, u32)> {
        let kept = *self.pixels.get(i)?;
        let near = self.changed.near(px, py);
        if near == f32::INFINITY {
            return Some((kept, self.samples[i]));
        }
        let t_stop = if kernel::is_surface_id(kept.id) {
            // The hit's parameter: its depth is `t · spacing` (the world position would
            // round far from the origin).
            kept.depth / u.spacing + FACE_MARGIN
        } else if kept.id == kernel::ID_CAP {
            // Where the ray entered the volume.
            let (ro, d) = kernel::pixel_ray(u, px, py);
            let o = (ro - Vec3::from_array(u.origin)) / u.spacing;
            kernel::ray_box(u, o, d).map_or(f32::INFINITY, |b| b.0 + FACE_MARGIN)
        } else {
            f32::INFINITY
        };
        (t_stop < near).then(|| (kept, self.samples[i]))
    }
}
