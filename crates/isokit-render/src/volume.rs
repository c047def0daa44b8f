//! The volume a ray caster reads: samples of a node-centered grid (dense or a sparse band)
//! with the two-level subdivision of 002 Sec. 6.2: small *blocks* carrying min/max for
//! empty-space skipping, and larger *bricks*, the unit of the brick cache.

use crate::RenderError;
use glam::{IVec3, Vec3};
use isokit_field::{Aabb, BrickGrid, Grid};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// Block and brick sizes in cells (002 Sec. 6.2): blocks of `block³` cells carry min/max for
/// empty-space skipping; bricks of `brick³` cells are the unit of the cache.
///
/// A brick is stored with the samples `[brick·c − 1, brick·c + brick + 1]` per axis
/// (`brick + 3`, [`Layout::brick_side`]): one sample of apron before and two after, exactly
/// the support of the tricubic B-spline on the brick's cells, so no filter ever reads
/// outside its brick.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Layout {
    /// Block edge in cells: a power of two from 2 to 32 (default 8).
    pub block: usize,
    /// Brick edge in cells: a power of two from `block` to 128 (default 32).
    pub brick: usize,
}

impl Default for Layout {
    fn default() -> Self {
        Self {
            block: 8,
            brick: 32,
        }
    }
}

impl Layout {
    /// Checks the sizes.
    pub fn check(&self) -> Result<(), RenderError> {
        if !(self.block.is_power_of_two() && (2..=32).contains(&self.block)) {
            return Err(RenderError::bad(
                "block size",
                self.block,
                "must be a power of two from 2 to 32",
            ));
        }
        if !(self.brick.is_power_of_two() && (self.block..=128).contains(&self.brick)) {
            return Err(RenderError::bad(
                "brick size",
                self.brick,
                "must be a power of two from the block size to 128",
            ));
        }
        Ok(())
    }

    /// Samples per axis of a stored brick: `brick + 3` (apron 1 before, 2 after).
    pub fn brick_side(&self) -> usize {
        self.brick + 3
    }

    /// Samples of a stored brick: `brick_side()³`.
    pub fn brick_samples(&self) -> usize {
        self.brick_side().pow(3)
    }

    /// Blocks per brick along one axis.
    pub fn blocks_per_brick(&self) -> usize {
        self.brick / self.block
    }
}

/// Where the samples come from.
#[derive(Clone, Debug)]
pub enum VolumeData {
    /// A dense grid (a volume file, or a dense scene sampling).
    Dense(Grid),
    /// A sparse band (a lazily sampled scene): unsampled space reads as the grid's
    /// background, with the sign it keeps.
    Band(BrickGrid),
}

impl VolumeData {
    /// Samples along x, y, z.
    pub fn dims(&self) -> [usize; 3] {
        match self {
            Self::Dense(g) => g.dims(),
            Self::Band(b) => b.dims(),
        }
    }

    /// Position of sample (0, 0, 0).
    pub fn origin(&self) -> Vec3 {
        match self {
            Self::Dense(g) => g.origin(),
            Self::Band(b) => b.origin(),
        }
    }

    /// Sample spacing.
    pub fn spacing(&self) -> f32 {
        match self {
            Self::Dense(g) => g.spacing(),
            Self::Band(b) => b.spacing(),
        }
    }

    /// Sample at integer coordinates clamped to the grid (edge extension, like a texture
    /// with clamp-to-edge addressing and [`Grid::get_clamped`]).
    #[inline]
    pub fn get_clamped(&self, c: IVec3) -> f32 {
        match self {
            Self::Dense(g) => g.get_clamped(c),
            Self::Band(b) => {
                let d = b.dims();
                let at = |v: i32, n: usize| v.clamp(0, n as i32 - 1) as usize;
                b.get(at(c.x, d[0]), at(c.y, d[1]), at(c.z, d[2]))
            }
        }
    }
}

static NEXT_ID: AtomicU64 = AtomicU64::new(1);

/// A sampled field ready for ray casting: the samples, the block grid with min/max per
/// block, and the brick grid the cache loads from.
///
/// Cells, not samples, are subdivided: a grid of `n` samples along an axis has `n − 1`
/// cells, `ceil((n − 1) / block)` blocks and `ceil((n − 1) / brick)` bricks (the last ones
/// partial). Block `b` covers the cells `[block·b, block·b + block)`.
///
/// The min/max of a block is taken over every sample any filter reads for a point in its
/// cells, i.e. the tricubic support `[block·b − 1, block·b + block + 1]` (clamped to the
/// grid). The trilinear and tricubic B-spline reconstructions are convex combinations of
/// those samples, so a block whose range does not contain the isovalue cannot hold the
/// surface — for either filter. Non-finite samples are ignored.
#[derive(Clone, Debug)]
pub struct Volume {
    data: VolumeData,
    layout: Layout,
    dims: [usize; 3],
    block_dims: [usize; 3],
    brick_dims: [usize; 3],
    /// `[min, max]` per block, x fastest.
    block_range: Vec<[f32; 2]>,
    range: Option<(f32, f32)>,
    id: u64,
}

impl Volume {
    /// A volume over a dense grid.
    pub fn from_grid(grid: Grid, layout: Layout) -> Result<Self, RenderError> {
        Self::new(VolumeData::Dense(grid), layout)
    }

    /// A volume over a sparse band (e.g. [`isokit_levelset::scene::Scene::sample`]).
    pub fn from_brick_grid(grid: BrickGrid, layout: Layout) -> Result<Self, RenderError> {
        Self::new(VolumeData::Band(grid), layout)
    }

    /// A volume over either kind of samples; computes the block min/max (one pass over the
    /// samples, in parallel).
    pub fn new(data: VolumeData, layout: Layout) -> Result<Self, RenderError> {
        layout.check()?;
        let dims = data.dims();
        if dims.iter().any(|&d| d < 2) {
            return Err(RenderError::BadVolume {
                dims,
                why: "need at least 2 samples along every axis to hold a cell",
            });
        }
        let cells = dims.map(|d| d - 1);
        let block_dims = cells.map(|c| c.div_ceil(layout.block));
        let brick_dims = cells.map(|c| c.div_ceil(layout.brick));
        let n_blocks = block_dims.iter().product::<usize>();
        if brick_dims.iter().product::<usize>() >= u32::MAX as usize
            || n_blocks >= u32::MAX as usize
        {
            return Err(RenderError::BadVolume {
                dims,
                why: "too many blocks for 32-bit indices; use larger blocks",
            });
        }
        let b = layout.block as i32;
        let [bx, by, _] = block_dims;
        let block_range: Vec<[f32; 2]> = (0..n_blocks)
            .into_par_iter()
            .map(|n| {
                let c = IVec3::new(
                    (n % bx) as i32,
                    ((n / bx) % by) as i32,
                    (n / (bx * by)) as i32,
                );
                let lo = (c * b - IVec3::ONE).max(IVec3::ZERO);
                let top = IVec3::new(dims[0] as i32, dims[1] as i32, dims[2] as i32) - 1;
                let hi = (c * b + IVec3::splat(b + 1)).min(top);
                let (mut mn, mut mx) = (f32::INFINITY, f32::NEG_INFINITY);
                for k in lo.z..=hi.z {
                    for j in lo.y..=hi.y {
                        for i in lo.x..=hi.x {
                            let v = data.get_clamped(IVec3::new(i, j, k));
                            if v.is_finite() {
                                mn = mn.min(v);
                                mx = mx.max(v);
                            }
                        }
                    }
                }
                [mn, mx]
            })
            .collect();
        let range =
            block_range
                .iter()
                .filter(|r| r[0] <= r[1])
                .fold(None, |acc: Option<(f32, f32)>, r| match acc {
                    None => Some((r[0], r[1])),
                    Some((a, b)) => Some((a.min(r[0]), b.max(r[1]))),
                });
        Ok(Self {
            data,
            layout,
            dims,
            block_dims,
            brick_dims,
            block_range,
            range,
            id: NEXT_ID.fetch_add(1, Ordering::Relaxed),
        })
    }

    /// The samples.
    pub fn data(&self) -> &VolumeData {
        &self.data
    }
    /// Block and brick sizes.
    pub fn layout(&self) -> Layout {
        self.layout
    }
    /// Samples along x, y, z.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }
    /// Position of sample (0, 0, 0).
    pub fn origin(&self) -> Vec3 {
        self.data.origin()
    }
    /// Sample spacing (world units).
    pub fn spacing(&self) -> f32 {
        self.data.spacing()
    }
    /// The box spanned by the samples: rays are cast inside it.
    pub fn bounds(&self) -> Aabb {
        let n = Vec3::new(
            (self.dims[0] - 1) as f32,
            (self.dims[1] - 1) as f32,
            (self.dims[2] - 1) as f32,
        );
        Aabb::new(self.origin(), self.origin() + n * self.spacing())
    }
    /// Blocks along x, y, z.
    pub fn block_dims(&self) -> [usize; 3] {
        self.block_dims
    }
    /// Bricks along x, y, z.
    pub fn brick_dims(&self) -> [usize; 3] {
        self.brick_dims
    }
    /// Number of bricks.
    pub fn brick_count(&self) -> usize {
        self.brick_dims.iter().product()
    }
    /// `[min, max]` of the samples each block's filters read, per block, x fastest
    /// (`[+inf, −inf]` for a block without finite samples). The GPU twin's block buffer.
    pub fn block_ranges(&self) -> &[[f32; 2]] {
        &self.block_range
    }
    /// Smallest and largest finite sample, or `None` when none is finite.
    pub fn value_range(&self) -> Option<(f32, f32)> {
        self.range
    }
    /// A number unique to this volume in this process (the cache uses it to notice that it
    /// is handed another volume).
    pub fn id(&self) -> u64 {
        self.id
    }

    /// Linear index of brick `c` (x fastest).
    pub fn brick_index(&self, c: [usize; 3]) -> usize {
        c[0] + self.brick_dims[0] * (c[1] + self.brick_dims[1] * c[2])
    }

    /// Brick coordinates of linear brick index `n`.
    pub fn brick_coord(&self, n: usize) -> [usize; 3] {
        let [bx, by, _] = self.brick_dims;
        [n % bx, (n / bx) % by, n / (bx * by)]
    }

    /// The world box of brick `n`'s cells.
    pub fn brick_bounds(&self, n: usize) -> Aabb {
        let c = self.brick_coord(n);
        let r = self.layout.brick;
        let lo = Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) * r as f32;
        let top = Vec3::new(
            (self.dims[0] - 1) as f32,
            (self.dims[1] - 1) as f32,
            (self.dims[2] - 1) as f32,
        );
        let hi = (lo + Vec3::splat(r as f32)).min(top);
        let (o, h) = (self.origin(), self.spacing());
        Aabb::new(o + lo * h, o + hi * h)
    }

    /// Fills `out` (`brick_side()³` values, x fastest) with the stored samples of brick `n`:
    /// grid samples `brick·c − 1 ..= brick·c + brick + 1` per axis, clamped to the grid.
    /// This is the upload of one brick into the cache.
    pub fn fill_brick(&self, n: usize, out: &mut [f32]) {
        let s = self.layout.brick_side();
        debug_assert_eq!(out.len(), s * s * s);
        let c = self.brick_coord(n);
        let lo = IVec3::new(c[0] as i32, c[1] as i32, c[2] as i32) * self.layout.brick as i32
            - IVec3::ONE;
        for (m, v) in out.iter_mut().enumerate() {
            let l = IVec3::new((m % s) as i32, ((m / s) % s) as i32, (m / (s * s)) as i32);
            *v = self.data.get_clamped(lo + l);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(dims: [usize; 3]) -> Grid {
        let n = dims.iter().product::<usize>();
        let data = (0..n)
            .map(|m| (m % dims[0]) as f32 + 100.0 * (m / (dims[0] * dims[1])) as f32)
            .collect();
        Grid::from_data(dims, Vec3::ZERO, 0.5, data).unwrap()
    }

    #[test]
    fn block_ranges_cover_the_tricubic_support() {
        let g = ramp([21, 9, 17]);
        let v = Volume::from_grid(g.clone(), Layout { block: 4, brick: 8 }).unwrap();
        assert_eq!(v.block_dims(), [5, 2, 4]);
        assert_eq!(v.brick_dims(), [3, 1, 2]);
        // Block (1, 0, 2): cells x 4..8, z 8..12; support x 3..=9, z 7..=13.
        let r = v.block_ranges()[1 + 5 * 2 * 2];
        assert_eq!(r, [3.0 + 700.0, 9.0 + 1300.0]);
        // The last block along x holds cells 16..20 and reads samples 15..=20 (clamped).
        let r = v.block_ranges()[4];
        assert_eq!(r, [15.0, 20.0 + 500.0]);
        assert_eq!(v.value_range(), Some((0.0, 20.0 + 1600.0)));
    }

    #[test]
    fn bricks_hold_their_apron() {
        let g = ramp([21, 9, 17]);
        let layout = Layout { block: 4, brick: 8 };
        let v = Volume::from_grid(g.clone(), layout).unwrap();
        let s = layout.brick_side();
        let mut out = vec![0.0; s * s * s];
        for n in 0..v.brick_count() {
            v.fill_brick(n, &mut out);
            let c = v.brick_coord(n);
            for (m, &x) in out.iter().enumerate() {
                let l = IVec3::new((m % s) as i32, ((m / s) % s) as i32, (m / (s * s)) as i32);
                let gi = IVec3::new(c[0] as i32, c[1] as i32, c[2] as i32) * 8 - 1 + l;
                assert_eq!(x, g.get_clamped(gi));
            }
        }
    }

    #[test]
    fn bad_layouts_and_flat_volumes_are_refused() {
        let g = ramp([8, 8, 8]);
        for (block, brick) in [(3, 32), (8, 4), (64, 64), (8, 256), (1, 8)] {
            assert!(Volume::from_grid(g.clone(), Layout { block, brick }).is_err());
        }
        let flat = Grid::new([8, 8, 1], Vec3::ZERO, 1.0).unwrap();
        let e = Volume::from_grid(flat, Layout::default()).unwrap_err();
        assert!(e.to_string().contains("at least 2 samples"), "{e}");
    }
}
