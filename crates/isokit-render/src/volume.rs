//! The volume a ray caster reads: samples of a node-centered grid (dense or a sparse band)
//! with the two-level subdivision of 002 Sec. 6.2: small *blocks* carrying min/max for
//! empty-space skipping, and larger *bricks*, the unit of the brick cache.

use crate::RenderError;
use glam::{IVec3, Vec3};
use isokit_field::{Aabb, BrickGrid, Grid};
use rayon::prelude::*;
use std::borrow::Cow;
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

    /// Samples per axis of a *half-resolution* brick (the downsampling cache policy,
    /// [`crate::CachePolicy::Downsample`]): `brick / 2 + 3`, every second grid sample
    /// (spacing 2h) with the same apron, one coarse sample before and two after.
    pub fn half_side(&self) -> usize {
        self.brick / 2 + 3
    }

    /// Samples of a half-resolution brick: `half_side()³`.
    pub fn half_samples(&self) -> usize {
        self.half_side().pow(3)
    }
}

/// The trilinear interpolation of the *coarse lattice* (the grid samples with even indices,
/// clamped to the grid) at integer sample `g`: the value a half-resolution brick
/// reconstructs there. Along an axis where `g` is even the coarse fraction is 0, where it
/// is odd 0.5; the lerps run x, then y, then z, as the kernel's fetch, so the value is bit
/// for bit what the kernel's trilinear fetch in the coarse cell returns at that point.
fn coarse_interp(data: &VolumeData, g: IVec3) -> f32 {
    let e = IVec3::new(
        g.x.div_euclid(2) * 2,
        g.y.div_euclid(2) * 2,
        g.z.div_euclid(2) * 2,
    );
    let t = (g - e).as_vec3() * 0.5;
    let s = |dx: i32, dy: i32, dz: i32| data.get_clamped(e + 2 * IVec3::new(dx, dy, dz));
    let lerp = |a: f32, b: f32, t: f32| a + t * (b - a);
    let x00 = lerp(s(0, 0, 0), s(1, 0, 0), t.x);
    let x10 = lerp(s(0, 1, 0), s(1, 1, 0), t.x);
    let x01 = lerp(s(0, 0, 1), s(1, 0, 1), t.x);
    let x11 = lerp(s(0, 1, 1), s(1, 1, 1), t.x);
    lerp(lerp(x00, x10, t.y), lerp(x01, x11, t.y), t.z)
}

/// The cubic B-spline *subdivision* of the coarse lattice at integer sample `g`: the fine
/// control point that makes a cubic B-spline on the fine lattice equal to the B-spline of
/// the coarse samples (knot insertion), per axis `(c₋₁ + 6c₀ + c₁)/8` at an even index and
/// `(c₀ + c₁)/2` at an odd one (tensor product, coarse samples clamped to the grid).
fn coarse_subdivision(data: &VolumeData, g: IVec3) -> f32 {
    let taps = |v: i32| -> ([i32; 3], [f32; 3], usize) {
        if v.rem_euclid(2) == 0 {
            ([v - 2, v, v + 2], [0.125, 0.75, 0.125], 3)
        } else {
            ([v - 1, v + 1, 0], [0.5, 0.5, 0.0], 2)
        }
    };
    let (tx, ty, tz) = (taps(g.x), taps(g.y), taps(g.z));
    let mut sum = 0.0f32;
    for iz in 0..tz.2 {
        let mut sy = 0.0f32;
        for iy in 0..ty.2 {
            let mut sx = 0.0f32;
            for ix in 0..tx.2 {
                sx += tx.1[ix] * data.get_clamped(IVec3::new(tx.0[ix], ty.0[iy], tz.0[iz]));
            }
            sy += ty.1[iy] * sx;
        }
        sum += tz.1[iz] * sy;
    }
    sum
}

/// Where the samples come from.
#[derive(Clone, Debug)]
pub enum VolumeData {
    /// A dense grid (a volume file, or a dense scene sampling).
    Dense(Grid),
    /// A sparse band (a lazily sampled scene): unsampled space reads as the grid's
    /// background, with the sign it keeps. Stored samples are read clamped to
    /// `±|background|`: a band's bricks hold values past the band (up to the sampler's cap)
    /// where unsampled space beside them reads the background, and clamped the field is
    /// continuous and as Lipschitz as the distance it samples (what sphere tracing steps
    /// by), while the isosurfaces within the band keep their shape wherever the filters'
    /// taps stay within the band (for `ρ = 0` and a band of at least 2√3 voxels,
    /// everywhere).
    Band(BrickGrid),
    /// Samples read on demand from a Zarr store through a bounded cache of decoded chunks
    /// (a field larger than memory; see [`Volume::from_store`]). With the `zarr` feature.
    #[cfg(feature = "zarr")]
    Store(std::sync::Arc<isokit_io::zarr::ZarrSource>),
}

impl VolumeData {
    /// Samples along x, y, z.
    pub fn dims(&self) -> [usize; 3] {
        match self {
            Self::Dense(g) => g.dims(),
            Self::Band(b) => b.dims(),
            #[cfg(feature = "zarr")]
            Self::Store(s) => s.dims(),
        }
    }

    /// Position of sample (0, 0, 0).
    pub fn origin(&self) -> Vec3 {
        match self {
            Self::Dense(g) => g.origin(),
            Self::Band(b) => b.origin(),
            #[cfg(feature = "zarr")]
            Self::Store(s) => s.origin(),
        }
    }

    /// Sample spacing.
    pub fn spacing(&self) -> f32 {
        match self {
            Self::Dense(g) => g.spacing(),
            Self::Band(b) => b.spacing(),
            // Uniform (checked by `Volume::from_store`); the mean, as a volume file's
            // spacing becomes a grid's (`isokit_io::Volume::into_grid`).
            #[cfg(feature = "zarr")]
            Self::Store(s) => {
                let h = s.spacing();
                (h.x + h.y + h.z) / 3.0
            }
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
                clamp_band(
                    b.get(at(c.x, d[0]), at(c.y, d[1]), at(c.z, d[2])),
                    b.background(),
                )
            }
            #[cfg(feature = "zarr")]
            Self::Store(s) => {
                let d = s.dims();
                let at = |v: i32, n: usize| v.clamp(0, n as i32 - 1) as usize;
                s.get(at(c.x, d[0]), at(c.y, d[1]), at(c.z, d[2]))
            }
        }
    }
}

/// A band's sample as the ray caster reads it: clamped to `±|background|`, the value of
/// unsampled space (NaN stays NaN; see [`VolumeData::Band`]).
#[inline]
fn clamp_band(v: f32, background: f32) -> f32 {
    let m = background.abs();
    if v > m {
        m
    } else if v < -m {
        -m
    } else {
        v
    }
}

impl VolumeData {
    /// Samples `(x0 + i, y, z)` for `i` in `0..out.len()`, every index clamped to the grid
    /// (as [`VolumeData::get_clamped`]): rows copied from the grid's or the band's storage.
    pub fn read_row(&self, x0: i32, y: i32, z: i32, out: &mut [f32]) {
        let n = out.len() as i32;
        let dims = self.dims();
        let top = |a: usize| dims[a] as i32 - 1;
        let (y, z) = (y.clamp(0, top(1)), z.clamp(0, top(2)));
        // The part of the row inside the grid: [a, b).
        let a = x0.clamp(0, top(0) + 1);
        let b = (x0 + n).clamp(0, top(0) + 1);
        let (yu, zu) = (y as usize, z as usize);
        match self {
            Self::Dense(g) => {
                let row = g.index(0, yu, zu);
                let data = &g.data()[row..row + dims[0]];
                if a < b {
                    out[(a - x0) as usize..(b - x0) as usize]
                        .copy_from_slice(&data[a as usize..b as usize]);
                }
            }
            Self::Band(bg) => {
                let bs = bg.brick_size() as i32;
                let side = bg.brick_size() + 2 * bg.apron();
                let mut x = a;
                while x < b {
                    let bx = x / bs;
                    let end = ((bx + 1) * bs).min(b);
                    let c = [bx as usize, yu / bg.brick_size(), zu / bg.brick_size()];
                    let dst = &mut out[(x - x0) as usize..(end - x0) as usize];
                    match bg.brick_at(c) {
                        Some(k) => {
                            let (li, lj, lk) = (
                                (x - bx * bs) as usize + bg.apron(),
                                yu % bg.brick_size() + bg.apron(),
                                zu % bg.brick_size() + bg.apron(),
                            );
                            let at = li + side * (lj + side * lk);
                            let src = &bg.brick_data(k)[at..at + dst.len()];
                            let m = bg.background();
                            for (o, &v) in dst.iter_mut().zip(src) {
                                *o = clamp_band(v, m);
                            }
                        }
                        None if bg.is_inside(c) => dst.fill(-bg.background()),
                        None => dst.fill(bg.background()),
                    }
                    x = end;
                }
            }
            #[cfg(feature = "zarr")]
            Self::Store(st) => {
                if a < b {
                    st.read_row(
                        a as usize,
                        yu,
                        zu,
                        &mut out[(a - x0) as usize..(b - x0) as usize],
                    );
                }
            }
        }
        // Clamp-to-edge on both ends.
        if a > x0 {
            let v = self.get_clamped(IVec3::new(0, y, z));
            let m = ((a - x0) as usize).min(out.len());
            out[..m].fill(v);
        }
        if b < x0 + n {
            let v = self.get_clamped(IVec3::new(top(0), y, z));
            out[((b - x0).max(0) as usize)..].fill(v);
        }
    }

    /// Samples `lo + (i, j, k)` for `(i, j, k)` in `0..n` per axis, clamped to the grid, x
    /// fastest, into `out` (`n[0]·n[1]·n[2]` values).
    pub fn read_box(&self, lo: IVec3, n: [usize; 3], out: &mut [f32]) {
        debug_assert_eq!(out.len(), n[0] * n[1] * n[2]);
        for (r, row) in out.chunks_mut(n[0]).enumerate() {
            let (j, k) = ((r % n[1]) as i32, (r / n[1]) as i32);
            self.read_row(lo.x, lo.y + j, lo.z + k, row);
        }
    }
}

impl From<Grid> for VolumeData {
    fn from(g: Grid) -> Self {
        Self::Dense(g)
    }
}

impl From<BrickGrid> for VolumeData {
    fn from(b: BrickGrid) -> Self {
        Self::Band(b)
    }
}

impl From<Volume> for VolumeData {
    fn from(v: Volume) -> Self {
        v.data
    }
}

/// How a volume's second field B is combined with its first field A, per sample, during ray
/// casting (002 Sec. 6.4.3, with the operators of ERRATA 1).
///
/// With the isovalue ρ and the inside sign s (+1 when the inside lies below ρ, −1 above),
/// both fields become residuals `a' = s(a − ρ)`, `b' = s(b − ρ)` (negative inside) and are
/// combined into `c`; the combined field is `ρ + s·c`. Min and max of two signed distance
/// fields are exact outside the union and inside the intersection, and only bounds
/// elsewhere (which is all the ray caster needs: the zero set is exact).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Combine {
    /// A ∪ B: `min(a', b')`.
    Union,
    /// A ∩ B: `max(a', b')` (002's printed `min` is the union: ERRATA 1).
    Intersection,
    /// A − B: `max(a', −b')`.
    Difference,
    /// Linear morph `(1 − t)·a' + t·b'`, `t` in `[0, 1]` (002 Fig. 6.18).
    Morph(f32),
}

impl Combine {
    /// The code of [`crate::Uniforms::combine`] ([`crate::kernel::COMBINE_UNION`], …).
    pub fn code(self) -> u32 {
        use crate::kernel::{
            COMBINE_DIFFERENCE, COMBINE_INTERSECTION, COMBINE_MORPH, COMBINE_UNION,
        };
        match self {
            Combine::Union => COMBINE_UNION,
            Combine::Intersection => COMBINE_INTERSECTION,
            Combine::Difference => COMBINE_DIFFERENCE,
            Combine::Morph(_) => COMBINE_MORPH,
        }
    }

    /// The morph parameter `t` (0 for the other operations).
    pub fn morph_t(self) -> f32 {
        match self {
            Combine::Morph(t) => t,
            _ => 0.0,
        }
    }

    /// Checks the morph parameter.
    pub fn check(self) -> Result<(), RenderError> {
        let t = self.morph_t();
        if !(0.0..=1.0).contains(&t) {
            return Err(RenderError::bad("morph t", t, "must lie in [0, 1]"));
        }
        Ok(())
    }

    /// Sound bounds of the combined residual `c` over a block, from bounds of `a'` and `b'`
    /// (interval arithmetic: min, max and the non-negative linear combination are monotone
    /// in each argument).
    pub fn interval(self, a: [f32; 2], b: [f32; 2]) -> [f32; 2] {
        match self {
            Combine::Union => [a[0].min(b[0]), a[1].min(b[1])],
            Combine::Intersection => [a[0].max(b[0]), a[1].max(b[1])],
            Combine::Difference => [a[0].max(-b[1]), a[1].max(-b[0])],
            Combine::Morph(t) => [(1.0 - t) * a[0] + t * b[0], (1.0 - t) * a[1] + t * b[1]],
        }
    }
}

impl std::str::FromStr for Combine {
    type Err = String;
    /// `union`, `intersection`, `difference`, `morph` (t = 0.5; set it with
    /// `Combine::Morph(t)`).
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "union" => Ok(Self::Union),
            "intersection" => Ok(Self::Intersection),
            "difference" => Ok(Self::Difference),
            "morph" => Ok(Self::Morph(0.5)),
            _ => Err(format!(
                "unknown CSG operation {s:?} (expected union, intersection, difference or morph)"
            )),
        }
    }
}

/// The second field of a volume and how it combines with the first.
#[derive(Clone, Debug)]
struct Operand {
    data: VolumeData,
    combine: Combine,
    /// `[min, max]` per block of B, as [`Volume::block_ranges`] for A.
    block_range: Vec<[f32; 2]>,
    /// Slope bounds per block of B, as [`Volume::block_slopes`] for A.
    block_slope: Vec<[f32; 3]>,
    /// Per block: B has a non-finite sample in the block's support. The kernel's `combine`
    /// takes A's value where B is not finite (NaN compares false), so such blocks must be
    /// active wherever A alone would be.
    nonfinite: Vec<bool>,
}

/// What one pass over a block's tricubic support finds (see [`Volume`]).
#[derive(Clone, Copy, Debug)]
struct BlockScan {
    /// `[min, max]` of the finite samples (`[+inf, −inf]` when none is finite).
    range: [f32; 2],
    /// Per axis, the largest `|difference|` of neighbouring samples along it (field units
    /// per voxel); `+inf` when a sample is not finite.
    slope: [f32; 3],
    /// A sample is not finite.
    nonfinite: bool,
}

/// `[min, max]` and the per-axis slope bound of every block of `data` over its tricubic
/// support `[block·b − 1, block·b + block + 1]` per axis, clamped to the grid (see
/// [`Volume`]), in parallel over z-rows of blocks.
fn block_scan(
    data: &VolumeData,
    layout: Layout,
    dims: [usize; 3],
    block_dims: [usize; 3],
) -> Vec<BlockScan> {
    let all: Vec<usize> = (0..block_dims.iter().product::<usize>()).collect();
    block_scan_of(data, layout, dims, block_dims, &all)
}

/// [`block_scan`] of the blocks `blocks` (linear indices), in their order.
fn block_scan_of(
    data: &VolumeData,
    layout: Layout,
    dims: [usize; 3],
    block_dims: [usize; 3],
    blocks: &[usize],
) -> Vec<BlockScan> {
    let b = layout.block as i32;
    let [bx, by, _] = block_dims;
    let top = IVec3::new(dims[0] as i32, dims[1] as i32, dims[2] as i32) - 1;
    blocks
        .par_iter()
        .with_min_len(bx)
        .map_init(Vec::new, |buf, &n| {
            let c = IVec3::new(
                (n % bx) as i32,
                ((n / bx) % by) as i32,
                (n / (bx * by)) as i32,
            );
            let lo = (c * b - IVec3::ONE).max(IVec3::ZERO);
            let hi = (c * b + IVec3::splat(b + 1)).min(top);
            let size = (hi - lo + IVec3::ONE).as_uvec3();
            let [nx, ny, nz] = [size.x as usize, size.y as usize, size.z as usize];
            buf.resize(nx * ny * nz, 0.0);
            data.read_box(lo, [nx, ny, nz], buf);
            scan_samples(buf, [nx, ny, nz])
        })
        .collect()
}

/// [`BlockScan`] of a box of samples (x fastest, `n` per axis).
fn scan_samples(s: &[f32], n: [usize; 3]) -> BlockScan {
    let [nx, ny, nz] = n;
    let (mut mn, mut mx) = (f32::INFINITY, f32::NEG_INFINITY);
    let mut nonfinite = false;
    let mut slope = [0f32; 3];
    let max_diff = |a: &[f32], b: &[f32], m: &mut f32| {
        for (x, y) in a.iter().zip(b) {
            let d = (y - x).abs();
            if d > *m {
                *m = d;
            }
        }
    };
    for k in 0..nz {
        for j in 0..ny {
            let r = (k * ny + j) * nx;
            let row = &s[r..r + nx];
            for &v in row {
                if v.is_finite() {
                    mn = mn.min(v);
                    mx = mx.max(v);
                } else {
                    nonfinite = true;
                }
            }
            max_diff(&row[..nx - 1], &row[1..], &mut slope[0]);
            if j + 1 < ny {
                max_diff(row, &s[r + nx..r + 2 * nx], &mut slope[1]);
            }
            if k + 1 < nz {
                max_diff(row, &s[r + nx * ny..r + nx * ny + nx], &mut slope[2]);
            }
        }
    }
    if nonfinite {
        slope = [f32::INFINITY; 3];
    }
    BlockScan {
        range: [mn, mx],
        slope,
        nonfinite,
    }
}

/// Per block and axis, the slope bound of the combination of two fields (see
/// [`Volume::trace_slopes`]).
pub(crate) fn combined_slopes(c: Combine, a: &[[f32; 3]], b: &[[f32; 3]]) -> Vec<[f32; 3]> {
    a.iter()
        .zip(b)
        .map(|(a, b)| match c {
            Combine::Morph(t) => [0, 1, 2].map(|i| (1.0 - t) * a[i] + t * b[i]),
            _ => [0, 1, 2].map(|i| a[i].max(b[i])),
        })
        .collect()
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
///
/// The same pass records per block and axis the largest difference of neighbouring samples
/// in that support ([`Volume::block_slopes`]): the partial derivative of either
/// reconstruction along an axis is a convex combination of such differences (the cubic
/// B-spline's derivative is the quadratic B-spline of the differences), so
/// `Σ |d_i| · slope_i` bounds the slope of the reconstructed field along a unit direction
/// `d` anywhere in the block: the Lipschitz bound sphere tracing steps by.
#[derive(Clone, Debug)]
pub struct Volume {
    data: VolumeData,
    layout: Layout,
    dims: [usize; 3],
    block_dims: [usize; 3],
    brick_dims: [usize; 3],
    /// `[min, max]` per block, x fastest.
    block_range: Vec<[f32; 2]>,
    /// Per block and axis, the largest difference of neighbouring samples in its support.
    block_slope: Vec<[f32; 3]>,
    range: Option<(f32, f32)>,
    /// The second field of on-the-fly CSG or morphing, if any.
    operand: Option<Operand>,
    id: u64,
    /// The id of the volume this one was built after ([`Volume::new_after`]) and the blocks
    /// whose support differs from it.
    changes: Option<(u64, std::sync::Arc<Vec<bool>>)>,
}

impl Volume {
    /// A volume over a dense grid.
    pub fn from_grid(grid: Grid, layout: Layout) -> Result<Self, RenderError> {
        Self::new(VolumeData::Dense(grid), layout)
    }

    /// A volume over a sparse band (e.g. a scene's lazily sampled band).
    pub fn from_brick_grid(grid: BrickGrid, layout: Layout) -> Result<Self, RenderError> {
        Self::new(VolumeData::Band(grid), layout)
    }

    /// A volume over a Zarr store read on demand ([`VolumeData::Store`]): only the chunks
    /// the block scan and the brick cache ask for are decoded, and at most the source's
    /// cache of them is held. The store's spacing must be uniform. With the `zarr` feature.
    #[cfg(feature = "zarr")]
    pub fn from_store(
        source: std::sync::Arc<isokit_io::zarr::ZarrSource>,
        layout: Layout,
    ) -> Result<Self, RenderError> {
        let h = source.spacing();
        if h.max_element() - h.min_element() > isokit_io::ISOTROPY_TOL * h.max_element() {
            return Err(RenderError::BadVolume {
                dims: source.dims(),
                why: "a store read on demand needs the same spacing on every axis",
            });
        }
        Self::new(VolumeData::Store(source), layout)
    }

    /// For a volume over a Zarr store read on demand (`VolumeData::Store`): why a chunk
    /// could not be read, if one could not (its samples read as NaN). `None` otherwise.
    pub fn store_error(&self) -> Option<String> {
        match &self.data {
            #[cfg(feature = "zarr")]
            VolumeData::Store(s) => s.error(),
            _ => None,
        }
    }

    /// A volume over either kind of samples; computes the block min/max (one pass over the
    /// samples, in parallel).
    pub fn new(data: VolumeData, layout: Layout) -> Result<Self, RenderError> {
        Self::new_after(data, layout, None)
    }

    /// [`Volume::new`] for a new version of `before`'s field: where both share the
    /// lattice and layout and neither combines a second field, the samples are compared
    /// first ([`crate::changed_blocks`]) and only the blocks whose support changed are
    /// scanned, the others keep `before`'s ranges and slopes (the same values a scan gives);
    /// the changed blocks are kept for [`crate::render_reusing`] after `before`'s frame.
    pub fn new_after(
        data: VolumeData,
        layout: Layout,
        before: Option<&Volume>,
    ) -> Result<Self, RenderError> {
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
        let changes = before
            .filter(|v| v.operand.is_none() && v.layout == layout)
            .and_then(|v| {
                let c = crate::raycast::reuse::changed_between(&v.data, &data, layout)?;
                Some((v, c))
            });
        let (block_range, block_slope): (Vec<_>, Vec<_>) = match &changes {
            Some((v, changed)) => {
                let todo: Vec<usize> = (0..n_blocks).filter(|&n| changed[n]).collect();
                let (mut ranges, mut slopes) = (v.block_range.clone(), v.block_slope.clone());
                for (n, s) in todo
                    .iter()
                    .zip(block_scan_of(&data, layout, dims, block_dims, &todo))
                {
                    (ranges[*n], slopes[*n]) = (s.range, s.slope);
                }
                (ranges, slopes)
            }
            None => block_scan(&data, layout, dims, block_dims)
                .into_iter()
                .map(|s| (s.range, s.slope))
                .unzip(),
        };
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
            block_slope,
            range,
            operand: None,
            id: NEXT_ID.fetch_add(1, Ordering::Relaxed),
            changes: changes.map(|(v, c)| (v.id, std::sync::Arc::new(c))),
        })
    }

    /// The id of the volume this one was built after ([`Volume::new_after`]), where the
    /// samples were compared.
    pub fn built_after(&self) -> Option<u64> {
        self.changes.as_ref().map(|c| c.0)
    }

    /// The blocks whose support holds samples other than those of the volume with id `id`,
    /// where this volume was built after it ([`Volume::new_after`]).
    pub(crate) fn changes_after(&self, id: u64) -> Option<&[bool]> {
        match &self.changes {
            Some((before, c)) if *before == id => Some(c),
            _ => None,
        }
    }

    /// This volume with a second field `b` on the same lattice (same dimensions, origin and
    /// spacing; refused otherwise), combined with the first per sample during ray casting:
    /// CSG or morphing on the fly (002 Sec. 6.4.3, see [`Combine`]). The brick cache then
    /// holds both fields per slot ([`Volume::slot_samples`]); the hit's normal and
    /// curvatures come from the operand that owns it (the object map, `id`
    /// [`crate::kernel::ID_SURFACE`] for A, [`crate::kernel::ID_SURFACE_B`] for B), or for a
    /// morph from the same combination of both operands' derivatives.
    ///
    /// ```
    /// use isokit_field::{Grid, sample_into, primitives::Sphere};
    /// use isokit_render::{Combine, Layout, Volume};
    /// use glam::Vec3;
    ///
    /// let sphere = |c: Vec3| {
    ///     let mut g = Grid::new([32; 3], Vec3::splat(-1.0), 2.0 / 31.0).unwrap();
    ///     sample_into(&Sphere::new(c, 0.5).unwrap(), &mut g);
    ///     g
    /// };
    /// let a = Volume::from_grid(sphere(Vec3::ZERO), Layout::default()).unwrap();
    /// let cut = a.with_operand(sphere(Vec3::X * 0.4), Combine::Difference).unwrap();
    /// assert_eq!(cut.combine(), Some(Combine::Difference));
    /// assert_eq!(cut.slot_samples(), 2 * cut.layout().brick_samples());
    /// ```
    pub fn with_operand(
        mut self,
        b: impl Into<VolumeData>,
        combine: Combine,
    ) -> Result<Volume, RenderError> {
        combine.check()?;
        let b = b.into();
        let h = self.spacing();
        if b.dims() != self.dims {
            return Err(RenderError::BadVolume {
                dims: b.dims(),
                why: "the second CSG/morph operand must have the first's dimensions (the same lattice)",
            });
        }
        if (b.spacing() - h).abs() > 1e-5 * h
            || (b.origin() - self.origin()).abs().max_element() > 1e-4 * h
        {
            return Err(RenderError::BadVolume {
                dims: b.dims(),
                why: "the second CSG/morph operand must have the first's origin and spacing (the same lattice)",
            });
        }
        let scan = block_scan(&b, self.layout, self.dims, self.block_dims);
        self.operand = Some(Operand {
            data: b,
            combine,
            block_range: scan.iter().map(|s| s.range).collect(),
            block_slope: scan.iter().map(|s| s.slope).collect(),
            nonfinite: scan.iter().map(|s| s.nonfinite).collect(),
        });
        // Another pool layout: caches must reload.
        self.id = NEXT_ID.fetch_add(1, Ordering::Relaxed);
        self.changes = None;
        Ok(self)
    }

    /// Changes the combination of a volume with a second field (e.g. the morph parameter of
    /// an animation) without touching the samples: the volume keeps its id, so caches keep
    /// their bricks. An error without a second field, or for a bad morph parameter.
    pub fn set_combine(&mut self, combine: Combine) -> Result<(), RenderError> {
        combine.check()?;
        match &mut self.operand {
            Some(op) => {
                op.combine = combine;
                Ok(())
            }
            None => Err(RenderError::bad(
                "combine",
                format!("{combine:?}"),
                "the volume has no second field (Volume::with_operand)",
            )),
        }
    }

    /// The combination with the second field, if the volume has one.
    pub fn combine(&self) -> Option<Combine> {
        self.operand.as_ref().map(|o| o.combine)
    }

    /// The second field's samples, if any.
    pub fn operand_data(&self) -> Option<&VolumeData> {
        self.operand.as_ref().map(|o| &o.data)
    }

    /// Fields stored per brick slot: 1, or 2 with a second field.
    pub fn channels(&self) -> usize {
        1 + usize::from(self.operand.is_some())
    }

    /// Samples of one brick-cache slot: `channels() · brick_samples()` (channel A first,
    /// then B).
    pub fn slot_samples(&self) -> usize {
        self.channels() * self.layout.brick_samples()
    }

    /// The block ranges the ray caster skips by for isovalue `iso` and inside sign
    /// `inside_sign` (±1): [`Volume::block_ranges`] for a single field; with a second field,
    /// bounds of the combined field `ρ + s·c` per block from interval arithmetic on both
    /// operands' ranges ([`Combine::interval`]), widened by a few ulps so rounding can never
    /// make them unsound. A block with no finite sample in either field gets
    /// `[+∞, −∞]` (never active).
    pub fn trace_ranges(&self, iso: f32, inside_sign: f32) -> Cow<'_, [[f32; 2]]> {
        let Some(op) = &self.operand else {
            return Cow::Borrowed(&self.block_range);
        };
        Cow::Owned(self.combined_ranges(&self.block_range, &op.block_range, iso, inside_sign))
    }

    /// The second field's `[min, max]` per block, if any (as [`Volume::block_ranges`]).
    pub(crate) fn operand_block_ranges(&self) -> Option<&[[f32; 2]]> {
        self.operand.as_ref().map(|o| o.block_range.as_slice())
    }

    /// The second field's slope bounds per block, if any (as [`Volume::block_slopes`]).
    pub(crate) fn operand_block_slopes(&self) -> Option<&[[f32; 3]]> {
        self.operand.as_ref().map(|o| o.block_slope.as_slice())
    }

    /// [`Volume::trace_ranges`] from given per-block ranges of the fields (`b` only with a
    /// second field): the cache's ranges of what it stores under the downsampling policy.
    pub(crate) fn trace_ranges_of(
        &self,
        a: &[[f32; 2]],
        b: &[[f32; 2]],
        iso: f32,
        inside_sign: f32,
    ) -> Vec<[f32; 2]> {
        match &self.operand {
            None => a.to_vec(),
            Some(_) => self.combined_ranges(a, b, iso, inside_sign),
        }
    }

    fn combined_ranges(
        &self,
        ra: &[[f32; 2]],
        rb: &[[f32; 2]],
        iso: f32,
        inside_sign: f32,
    ) -> Vec<[f32; 2]> {
        let Some(op) = &self.operand else {
            return ra.to_vec();
        };
        let s = inside_sign;
        let to_res = |r: [f32; 2]| {
            let (x, y) = (s * (r[0] - iso), s * (r[1] - iso));
            [x.min(y), x.max(y)]
        };
        let morph = matches!(op.combine, Combine::Morph(_));
        ra.iter()
            .zip(rb)
            .zip(&op.nonfinite)
            .map(|((&a, &b), &b_nonfinite)| {
                if a[0] > a[1] {
                    return [f32::INFINITY, f32::NEG_INFINITY];
                }
                // Where B is not finite, min/max/difference take A's value (a morph gives
                // NaN there: nothing to add).
                let a_alone = b_nonfinite && !morph;
                if b[0] > b[1] {
                    if !a_alone {
                        return [f32::INFINITY, f32::NEG_INFINITY];
                    }
                    return a;
                }
                let mut c = op.combine.interval(to_res(a), to_res(b));
                if a_alone {
                    let ar = to_res(a);
                    c = [c[0].min(ar[0]), c[1].max(ar[1])];
                }
                let (x, y) = (iso + s * c[0], iso + s * c[1]);
                let m = a[0].abs().max(a[1].abs()).max(b[0].abs()).max(b[1].abs());
                let eps = 8.0 * f32::EPSILON * (m + iso.abs());
                [x.min(y) - eps, x.max(y) + eps]
            })
            .collect()
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
    /// (`[+inf, −inf]` for a block without finite samples), of the first field. What the
    /// ray caster skips by is [`Volume::trace_ranges`] (the same with a single field).
    pub fn block_ranges(&self) -> &[[f32; 2]] {
        &self.block_range
    }
    /// Per block (x fastest) and axis, the largest `|difference|` of neighbouring samples
    /// along that axis in the block's tricubic support, field units per voxel (`+inf` where
    /// a sample is not finite), of the first field: a bound of either reconstruction's
    /// partial derivative there (see [`Volume`]). What the ray caster steps by is
    /// [`Volume::trace_slopes`] (the same with a single field).
    pub fn block_slopes(&self) -> &[[f32; 3]] {
        &self.block_slope
    }
    /// The slope bounds of the field the ray caster searches, per block: those of
    /// [`Volume::block_slopes`] for a single field; with a second field per axis the larger
    /// of both operands' (union, intersection, difference: the minimum or maximum of two
    /// functions is no steeper than the steeper one) or `(1 − t)·a + t·b` (a morph).
    pub fn trace_slopes(&self) -> Cow<'_, [[f32; 3]]> {
        match &self.operand {
            None => Cow::Borrowed(&self.block_slope),
            Some(op) => Cow::Owned(combined_slopes(
                op.combine,
                &self.block_slope,
                &op.block_slope,
            )),
        }
    }
    /// Smallest and largest finite sample (of the first field), or `None` when none is finite.
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

    /// Fills `out` ([`Volume::slot_samples`] values) with the stored samples of brick `n`:
    /// grid samples `brick·c − 1 ..= brick·c + brick + 1` per axis, clamped to the grid, x
    /// fastest (`brick_side()³` values); with a second field its samples follow, in the
    /// same order. This is the upload of one brick into the cache.
    pub fn fill_brick(&self, n: usize, out: &mut [f32]) {
        debug_assert_eq!(out.len(), self.slot_samples());
        let lo = self.brick_corner(n) - IVec3::ONE;
        self.fill_lattice(out, self.layout.brick_side(), lo, 1);
    }

    /// Fills `out` with `side³` samples per field, grid sample `lo + stride·(i, j, k)`
    /// (clamped to the grid) for `i, j, k` in `0..side`, x fastest, the second field's after
    /// the first's: full bricks have stride 1, half-resolution ones stride 2.
    fn fill_lattice(&self, out: &mut [f32], s: usize, lo: IVec3, stride: i32) {
        let (a, b) = out.split_at_mut(s * s * s);
        let fill = |data: &VolumeData, out: &mut [f32]| {
            if stride == 1 {
                return data.read_box(lo, [s; 3], out);
            }
            for (m, v) in out.iter_mut().enumerate() {
                let l = IVec3::new((m % s) as i32, ((m / s) % s) as i32, (m / (s * s)) as i32);
                *v = data.get_clamped(lo + stride * l);
            }
        };
        fill(&self.data, a);
        if let Some(op) = &self.operand {
            fill(&op.data, b);
        }
    }

    /// Samples of one half-resolution slot: `channels() · half_samples()` (see
    /// [`Layout::half_side`]).
    pub fn half_slot_samples(&self) -> usize {
        self.channels() * self.layout.half_samples()
    }

    /// Grid coordinates of brick `n`'s first cell (its corner sample).
    fn brick_corner(&self, n: usize) -> IVec3 {
        let c = self.brick_coord(n);
        IVec3::new(c[0] as i32, c[1] as i32, c[2] as i32) * self.layout.brick as i32
    }

    /// Fills `out` ([`Volume::half_slot_samples`] values) with brick `n` at half resolution:
    /// coarse sample `m` (per axis, `0 ..= brick / 2 + 2`) is grid sample
    /// `brick·c + 2(m − 1)` clamped to the grid, x fastest; a second field's follow. The
    /// coarse samples are a subset of the grid's (every second one, on the global lattice
    /// of even indices), not averages, so a half-resolution brick and a full-resolution
    /// one agree wherever both hold a coarse sample.
    pub fn fill_brick_half(&self, n: usize, out: &mut [f32]) {
        debug_assert_eq!(out.len(), self.half_slot_samples());
        let lo = self.brick_corner(n) - IVec3::splat(2);
        self.fill_lattice(out, self.layout.half_side(), lo, 2);
    }

    /// True when grid sample `g` lies in the closed box (cells' corners, clamped to the
    /// grid) of a half-resolution brick (`is_half`) dilated by `d` samples.
    fn in_half_box(&self, g: IVec3, d: i32, is_half: &impl Fn(usize) -> bool) -> bool {
        let r = self.layout.brick as i32;
        // Per axis the bricks whose dilated closed cell range holds g (at most 3).
        let cand = |a: usize| -> ([usize; 3], usize) {
            let (v, n) = (g[a], self.brick_dims[a] as i32);
            let top = self.dims[a] as i32 - 1;
            let mut out = ([0; 3], 0);
            for k in (v.div_euclid(r) - 1)..=(v.div_euclid(r) + 1) {
                if k >= 0 && k < n && k * r - d <= v && v <= (k * r + r).min(top) + d {
                    out.0[out.1] = k as usize;
                    out.1 += 1;
                }
            }
            out
        };
        let (cx, cy, cz) = (cand(0), cand(1), cand(2));
        for &z in &cz.0[..cz.1] {
            for &y in &cy.0[..cy.1] {
                for &x in &cx.0[..cx.1] {
                    if is_half(self.brick_index([x, y, z])) {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// [`Volume::fill_brick`] for a full-resolution brick beside half-resolution ones
    /// (`is_half(brick)`), with its **hanging samples matched** to what the half-resolution
    /// bricks reconstruct with the search filter `filter`, so that both sides of a shared
    /// face (or edge, or corner) reconstruct the same field there and the isosurface has no
    /// cracks. Samples are replaced by a rule on their grid position alone, so every brick
    /// that stores a sample stores the same value:
    ///
    /// - [`crate::Filter::Trilinear`]: every stored sample (face and apron alike) in the
    ///   closed box of a half-resolution brick becomes that brick's trilinear
    ///   reconstruction there, the trilinear interpolation of the coarse lattice (linear
    ///   along a shared face; coarse samples keep their values). The fine bilinear
    ///   interpolant of a coarse bilinear function is that function: both sides agree
    ///   exactly on the face (to the rounding of a lerp at fraction 1).
    /// - [`crate::Filter::Tricubic`]: the B-spline reads one sample before and two after a
    ///   cell, so a face's values depend on three planes of samples; every stored sample
    ///   within one sample of a half-resolution brick's closed box becomes the cubic
    ///   B-spline subdivision of the coarse lattice (knot insertion: `(c₋₁ + 6c₀ + c₁)/8`,
    ///   `(c₀ + c₁)/2` per axis). The fine B-spline of subdivided control points *is* the
    ///   coarse B-spline, so both sides agree on the face to rounding. The full brick's
    ///   surface changes within a sample of the face (it is smoothed like the coarse one).
    ///
    /// The residual mismatch is a filter's matching seen through the other filter (e.g. a
    /// trilinear shading filter after a tricubic search): it moves normals, not the
    /// surface the search found; what it amounts to is measured in the tests.
    pub fn fill_brick_matched(
        &self,
        n: usize,
        is_half: impl Fn(usize) -> bool,
        filter: crate::Filter,
        out: &mut [f32],
    ) {
        self.fill_brick(n, out);
        let s = self.layout.brick_side();
        let s3 = s * s * s;
        let lo = self.brick_corner(n) - IVec3::ONE;
        let (a, b) = out.split_at_mut(s3);
        let (d, rule): (i32, fn(&VolumeData, IVec3) -> f32) = match filter {
            crate::Filter::Trilinear => (0, coarse_interp),
            crate::Filter::Tricubic => (1, coarse_subdivision),
        };
        for m in 0..s3 {
            let l = IVec3::new((m % s) as i32, ((m / s) % s) as i32, (m / (s * s)) as i32);
            let g = lo + l;
            if self.in_half_box(g, d, &is_half) {
                a[m] = rule(&self.data, g);
                if let Some(op) = &self.operand {
                    b[m] = rule(&op.data, g);
                }
            }
        }
    }

    /// The **detail** of brick `n`, the measure the downsampling policy ranks bricks by
    /// (least detail is downsampled first): the largest deviation
    /// `|f(g) − f̃(g)|` over the brick's grid samples `g` (its cells' corners) of the
    /// samples from the trilinear interpolation `f̃` of the coarse lattice (every second
    /// sample), i.e. the error of the trilinear reconstruction at half resolution at the
    /// samples it drops; the larger of both fields' with a second field. Non-finite samples
    /// are ignored. 0 for a brick linear along every axis (and any flat one).
    pub fn brick_detail(&self, n: usize) -> f32 {
        let c = self.brick_corner(n);
        let r = self.layout.brick as i32;
        let top = IVec3::new(
            self.dims[0] as i32 - 1,
            self.dims[1] as i32 - 1,
            self.dims[2] as i32 - 1,
        );
        let hi = (c + IVec3::splat(r)).min(top);
        let mut worst = 0.0f32;
        let mut scan = |data: &VolumeData| {
            for k in c.z..=hi.z {
                for j in c.y..=hi.y {
                    for i in c.x..=hi.x {
                        let g = IVec3::new(i, j, k);
                        let d = (data.get_clamped(g) - coarse_interp(data, g)).abs();
                        if d.is_finite() {
                            worst = worst.max(d);
                        }
                    }
                }
            }
        };
        scan(&self.data);
        if let Some(op) = &self.operand {
            scan(&op.data);
        }
        worst
    }

    /// `[min, max]` and the slope bounds per block of brick `n` over what the filters read
    /// of its *stored* samples `stored` (full resolution, or half when `half`), per field,
    /// written into `ra`, `sa` and `rb`, `sb` (`rb`, `sb` only with a second field) at the
    /// blocks' indices. Sound bounds for skipping and sphere tracing in blocks of a brick
    /// stored downsampled or with hanging samples matched (a half-resolution brick's
    /// differences span two voxels: its slopes per voxel are half of them).
    #[expect(
        clippy::too_many_arguments,
        reason = "both fields' ranges and slopes, as the cache keeps them"
    )]
    pub(crate) fn stored_block_stats(
        &self,
        n: usize,
        half: bool,
        stored: &[f32],
        ra: &mut [[f32; 2]],
        sa: &mut [[f32; 3]],
        rb: &mut [[f32; 2]],
        sb: &mut [[f32; 3]],
    ) {
        let lay = self.layout;
        let side = if half {
            lay.half_side()
        } else {
            lay.brick_side()
        };
        let s3 = side * side * side;
        let corner = self.brick_corner(n);
        let top = IVec3::new(
            self.dims[0] as i32 - 1,
            self.dims[1] as i32 - 1,
            self.dims[2] as i32 - 1,
        );
        let b = lay.block as i32;
        let per = lay.blocks_per_brick() as i32;
        let bc = corner / b;
        let scale = if half { 0.5 } else { 1.0 };
        let mut buf = Vec::new();
        for kz in 0..per {
            for ky in 0..per {
                for kx in 0..per {
                    let cell = bc + IVec3::new(kx, ky, kz);
                    if cell.x >= self.block_dims[0] as i32
                        || cell.y >= self.block_dims[1] as i32
                        || cell.z >= self.block_dims[2] as i32
                    {
                        continue;
                    }
                    let lo = cell * b;
                    let hi = (lo + IVec3::splat(b)).min(top);
                    // Stored index range the filters read for points of this block.
                    let (s0, s1) = if half {
                        let clo = (lo - corner) / 2;
                        let chi = (hi - corner + IVec3::ONE) / 2;
                        (clo, chi + IVec3::splat(2))
                    } else {
                        (lo - corner, hi - corner + IVec3::splat(2))
                    };
                    let s1 = s1.min(IVec3::splat(side as i32 - 1));
                    let idx = cell.x as usize
                        + self.block_dims[0]
                            * (cell.y as usize + self.block_dims[1] * cell.z as usize);
                    let size = (s1 - s0 + IVec3::ONE).as_uvec3();
                    let nn = [size.x as usize, size.y as usize, size.z as usize];
                    let mut scan = |ch: &[f32]| {
                        buf.clear();
                        for z in s0.z..=s1.z {
                            for y in s0.y..=s1.y {
                                let r = s0.x as usize + side * (y as usize + side * z as usize);
                                buf.extend_from_slice(&ch[r..r + nn[0]]);
                            }
                        }
                        let st = scan_samples(&buf, nn);
                        (st.range, st.slope.map(|v| v * scale))
                    };
                    (ra[idx], sa[idx]) = scan(&stored[..s3]);
                    if self.operand.is_some() {
                        (rb[idx], sb[idx]) = scan(&stored[s3..2 * s3]);
                    }
                }
            }
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
