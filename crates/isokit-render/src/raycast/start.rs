//! Where each ray's block walk may start: the active blocks projected onto tiles of the
//! image, the CPU twin's proxy geometry for empty-space skipping in front of the surface.
//!
//! The GPU ray casters of 002 (Sec. 6.3.1) start every ray at the rasterized front faces of
//! the active blocks' boxes, so that no thread walks the empty space between the eye and the
//! first block that can hold the surface. The CPU twin walks blocks with a DDA that jumps
//! over cubes of inactive blocks ([`crate::kernel::jump`]), but a ray that misses every
//! active block still walks the whole volume, and one that hits walks everything in front.
//! [`StartRaster`] projects the box of every active block onto tiles of
//! [`StartRaster::TILE`]² pixels and keeps per tile the smallest distance from the eye to
//! one of those boxes: no ray of a tile can meet an active block before that distance, and a
//! tile that no box covers has no ray that meets one at all.
//!
//! The raster keeps per tile the largest such distance as well: past it no ray of the tile
//! meets an active block, so the walk ends there as a miss instead of crossing the inactive
//! blocks behind the surface to the volume's far side (the rays that pass the silhouette).
//!
//! The walk then starts at that distance in the block it lies in ([`crate::kernel::cell_at`]),
//! found by the same plane crossings as the walk's own ([`crate::kernel::plane_t`]), so the
//! active blocks are entered at the same ray parameters and sampled bit for bit as by the
//! whole walk: the image does not change, only the blocks visited before the first active
//! one. Both bounds carry margins far above f32 rounding (a pixel of the tile rectangle,
//! 1e-4 relative and 0.1 voxel of the distance).

use glam::Vec3;

use super::cpu::{Uniforms, block_is_active, range_inside};

/// Per tile of the image, the smallest ray parameter (voxels) at which a ray of the tile can
/// reach an active block (`+∞` when none can), and the largest at which it can still be in
/// one (`−∞` when none can).
#[derive(Clone, Debug)]
pub struct StartRaster {
    tiles_x: u32,
    near: Vec<f32>,
    far: Vec<f32>,
    misses_final: bool,
}

impl StartRaster {
    /// Tile edge in pixels.
    pub const TILE: u32 = 8;
    /// Relative margin taken off every distance.
    const RELATIVE_MARGIN: f32 = 1e-4;
    /// Absolute margin taken off every distance, in voxels.
    const ABSOLUTE_MARGIN: f32 = 0.1;

    /// The raster of the active blocks for the camera of `u` (see the module docs), or
    /// `None` where it cannot help or does not apply: empty-space skipping off (every block
    /// is active), several views (every subpixel has its own eye).
    pub fn build(u: &Uniforms, block_range: &[[f32; 2]], block_info: &[[f32; 4]]) -> Option<Self> {
        if u.flags & super::cpu::FLAG_SKIP_EMPTY == 0 || u.views > 1 || u.subpixels != 1 {
            return None;
        }
        let caps = u.flags & super::cpu::FLAG_CAPS != 0;
        Some(Self::raster(u, caps, |idx, boundary| {
            // With caps, a ray entering the volume in a block inside the solid hits there:
            // such blocks on the volume's faces count too, where every ray enters through a
            // face (see `misses_final`).
            block_is_active(u, block_info, block_range, idx)
                || (caps && boundary && range_inside(u, block_range[idx]))
        }))
    }

    /// The raster of the blocks `blocks` marks (by [`crate::kernel::block_index`]) for the
    /// camera of `u`: per tile, the smallest and the largest ray parameter at which a ray of
    /// the tile can be in one of them (`±∞`: none can); `None` for several views or subpixels.
    pub fn of_blocks(u: &Uniforms, blocks: &[bool]) -> Option<Self> {
        if u.views > 1 || u.subpixels != 1 {
            return None;
        }
        Some(Self::raster(u, false, |idx, _| blocks[idx]))
    }

    /// The raster of the blocks for which `include(index, on the volume's faces)` holds;
    /// `caps`: whether rays test their first block for lying inside the solid.
    fn raster(u: &Uniforms, caps: bool, include: impl Fn(usize, bool) -> bool) -> Self {
        let t = Self::TILE;
        let (tiles_x, tiles_y) = (u.width.div_ceil(t), u.height.div_ceil(t));
        let mut near = vec![f32::INFINITY; tiles_x as usize * tiles_y as usize];
        let mut far = vec![f32::NEG_INFINITY; near.len()];
        let eye = (Vec3::from_array(u.eye) - Vec3::from_array(u.origin)) / u.spacing;
        let right = Vec3::from_array(u.right);
        let up = Vec3::from_array(u.up);
        let forward = Vec3::from_array(u.forward);
        let [bx, by, bz] = u.block_dims.map(|v| v as usize);
        let top = Vec3::new(
            (u.dims[0] - 1) as f32,
            (u.dims[1] - 1) as f32,
            (u.dims[2] - 1) as f32,
        );
        let b = u.block as f32;
        // With caps on, a ray's first block is tested for lying inside the solid. Where every
        // ray enters through the volume's faces (a perspective eye outside the box) those
        // blocks are among the boundary blocks rastered here, so a tile that no box covers
        // holds only misses; otherwise (an eye inside the box, orthographic rays starting
        // inside it) the first block is tested as the walk does it.
        let outside = if u.ortho == 0 {
            (0..3).any(|a| eye[a] < 0.0 || eye[a] > top[a])
        } else {
            // Orthographic rays start on the plane through the eye across `forward`: outside
            // when the whole box lies in front of it.
            (0..8).all(|c| {
                let corner = Vec3::new(
                    if c & 1 == 0 { 0.0 } else { top.x },
                    if c & 2 == 0 { 0.0 } else { top.y },
                    if c & 4 == 0 { 0.0 } else { top.z },
                );
                (corner - eye).dot(forward) > 0.0
            })
        };
        let misses_final = !caps || outside;
        // Pixel coordinates of a camera-space point (x, y) on the image plane: the inverse
        // of `subpixel_ray`'s `sx = (2 (px + 0.5) / w − 1) · h · aspect` (and `sy`).
        let (w, h) = (u.width as f32, u.height as f32);
        let to_px = |sx: f32| (sx / (u.half_height * u.aspect) + 1.0) * 0.5 * w - 0.5;
        let to_py = |sy: f32| (1.0 - sy / u.half_height) * 0.5 * h - 0.5;
        for z in 0..bz {
            for y in 0..by {
                for x in 0..bx {
                    let idx = x + bx * (y + by * z);
                    let boundary =
                        x == 0 || y == 0 || z == 0 || x + 1 == bx || y + 1 == by || z + 1 == bz;
                    if !include(idx, boundary) {
                        continue;
                    }
                    let lo = Vec3::new(x as f32, y as f32, z as f32) * b;
                    let hi = (lo + b).min(top);
                    let (rect, dist, dist_far) =
                        footprint(u.ortho != 0, u.spacing, eye, right, up, forward, lo, hi);
                    let t_lo = dist - Self::RELATIVE_MARGIN * dist.abs() - Self::ABSOLUTE_MARGIN;
                    let t_hi =
                        dist_far + Self::RELATIVE_MARGIN * dist_far.abs() + Self::ABSOLUTE_MARGIN;
                    let (x0, x1, y0, y1) = match rect {
                        Some([sx0, sx1, sy0, sy1]) => {
                            // Screen y grows downwards: sy1 (top) gives the smaller row.
                            let (px0, px1) = (to_px(sx0) - 1.0, to_px(sx1) + 1.0);
                            let (py0, py1) = (to_py(sy1) - 1.0, to_py(sy0) + 1.0);
                            if px1 < 0.0 || py1 < 0.0 || px0 >= w || py0 >= h {
                                continue;
                            }
                            let tile = |p: f32, n: u32| ((p.max(0.0) as u32) / t).min(n - 1);
                            (
                                tile(px0, tiles_x),
                                tile(px1, tiles_x),
                                tile(py0, tiles_y),
                                tile(py1, tiles_y),
                            )
                        }
                        None => (0, tiles_x - 1, 0, tiles_y - 1),
                    };
                    for ty in y0..=y1 {
                        let row = (ty * tiles_x) as usize..;
                        let cols = x0 as usize..=x1 as usize;
                        for v in &mut near[row.clone()][cols.clone()] {
                            *v = v.min(t_lo);
                        }
                        for v in &mut far[row][cols] {
                            *v = v.max(t_hi);
                        }
                    }
                }
            }
        }
        Self {
            tiles_x,
            near,
            far,
            misses_final,
        }
    }

    /// True when a pixel whose [`StartRaster::near`] is `+∞` misses: caps are off, or every
    /// ray enters the volume through a face whose blocks inside the solid are rastered.
    #[inline]
    pub fn misses_final(&self) -> bool {
        self.misses_final
    }

    /// The smallest ray parameter at which a ray of pixel `(px, py)` can reach an active
    /// block (with caps, also a block inside the solid on the volume's faces; `+∞`: none can).
    #[inline]
    pub fn near(&self, px: u32, py: u32) -> f32 {
        let t = Self::TILE;
        self.near[(py / t * self.tiles_x + px / t) as usize]
    }

    /// The largest ray parameter at which a ray of pixel `(px, py)` can still be in an
    /// active block (with caps, also a block inside the solid on the volume's faces; `−∞`:
    /// none can): past it the ray meets none.
    #[inline]
    pub fn far(&self, px: u32, py: u32) -> f32 {
        let t = Self::TILE;
        self.far[(py / t * self.tiles_x + px / t) as usize]
    }
}

/// The image-plane rectangle `[x0, x1, y0, y1]` (camera units: `x / z` and `y / z` in
/// perspective, `x` and `y` in world units in orthographic projection) of the box `[lo, hi]`
/// (grid coordinates, as `eye`; `spacing` converts) and the smallest and largest ray
/// parameters of a point of the box: its distances from the eye in perspective (the
/// largest at a corner), its depths along `forward` orthographically. The rectangle is
/// `None` (the whole image) where a corner of a perspective view lies at or near the eye's
/// plane.
#[expect(
    clippy::too_many_arguments,
    reason = "the camera's frame and the box, each a plain value"
)]
fn footprint(
    ortho: bool,
    spacing: f32,
    eye: Vec3,
    right: Vec3,
    up: Vec3,
    forward: Vec3,
    lo: Vec3,
    hi: Vec3,
) -> (Option<[f32; 4]>, f32, f32) {
    let mut rect = [
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
    ];
    let (mut whole, mut z_min, mut z_max, mut d_max) =
        (false, f32::INFINITY, f32::NEG_INFINITY, 0f32);
    for c in 0..8 {
        let p = Vec3::new(
            if c & 1 == 0 { lo.x } else { hi.x },
            if c & 2 == 0 { lo.y } else { hi.y },
            if c & 4 == 0 { lo.z } else { hi.z },
        );
        let v = p - eye;
        let (x, y, z) = (v.dot(right), v.dot(up), v.dot(forward));
        z_min = z_min.min(z);
        z_max = z_max.max(z);
        d_max = d_max.max(v.length());
        let (sx, sy) = if ortho {
            // Orthographic image-plane offsets are world units; these are grid units.
            (x * spacing, y * spacing)
        } else if z > 1e-2 {
            (x / z, y / z)
        } else {
            whole = true;
            (0.0, 0.0)
        };
        rect = [
            rect[0].min(sx),
            rect[1].max(sx),
            rect[2].min(sy),
            rect[3].max(sy),
        ];
    }
    if ortho {
        // Orthographic rays start on the image plane through the eye and go along
        // `forward`: the parameter of a point is its depth.
        return (Some(rect), z_min, z_max);
    }
    let dist = (eye.clamp(lo, hi) - eye).length();
    ((!whole).then_some(rect), dist, d_max)
}
