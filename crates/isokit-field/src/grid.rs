//! Dense node-centered grids of f32 samples.

use crate::{Aabb, FieldError};
use glam::{IVec3, Vec3};

/// Largest number of samples a [`Grid`] may hold (2^31, 8 GiB of f32). Larger requests are
/// refused with [`FieldError::TooLarge`] before anything is allocated.
pub const MAX_SAMPLES: usize = 1 << 31;

/// Largest number of samples along one axis of a [`Grid`] or [`crate::BrickGrid`]:
/// `i32::MAX / 2` (about 1.07e9). Filters and brick grids address samples with signed 32-bit
/// coordinates (`dims - 1`, taps at `i - 1 .. i + 2`, aprons at `B·c - A`); this limit keeps
/// all of them far from overflow. (An axis this long already needs the other two to be 1 or
/// 2 to stay under [`MAX_SAMPLES`].)
pub const MAX_AXIS: usize = i32::MAX as usize / 2;

/// Smallest and largest finite value of a slice, or `None` when none is finite.
pub fn finite_min_max(values: &[f32]) -> Option<(f32, f32)> {
    let (lo, hi) = values
        .iter()
        .filter(|v| v.is_finite())
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    (lo <= hi).then_some((lo, hi))
}

/// Checks dimensions against [`MAX_SAMPLES`] and [`MAX_AXIS`] and returns the sample count.
/// Errors: [`FieldError::EmptyDims`] (an axis is 0), [`FieldError::AxisTooLong`],
/// [`FieldError::TooLarge`].
pub fn checked_len(dims: [usize; 3]) -> Result<usize, FieldError> {
    if dims.contains(&0) {
        return Err(FieldError::EmptyDims(dims));
    }
    if dims.iter().any(|&d| d > MAX_AXIS) {
        // Reported as too large when the product is over the limit too (the usual case).
        let n = dims
            .iter()
            .fold(1u128, |acc, &d| acc.saturating_mul(d as u128));
        if n <= MAX_SAMPLES as u128 {
            return Err(FieldError::AxisTooLong {
                dims,
                limit: MAX_AXIS,
            });
        }
    }
    let n = dims
        .iter()
        .fold(1u128, |acc, &d| acc.saturating_mul(d as u128));
    if n > MAX_SAMPLES as u128 {
        return Err(FieldError::TooLarge {
            dims,
            samples: n,
            limit: MAX_SAMPLES,
            limit_gib: (MAX_SAMPLES * 4) >> 30,
        });
    }
    Ok(n as usize)
}

/// Checks a dense f32 grid of `dims` against the memory budget ([`crate::memory::check`]).
pub fn check_grid_budget(dims: [usize; 3]) -> Result<(), FieldError> {
    crate::memory::check(
        &format!(
            "a dense grid of {} x {} x {} samples",
            dims[0], dims[1], dims[2]
        ),
        crate::memory::grid_bytes(dims),
        "lower the resolution, sample a narrow band instead of a dense grid, or raise the budget",
    )
}

/// A dense, node-centered grid: sample `(i, j, k)` sits at `origin + spacing * (i, j, k)`
/// and is stored at index `i + nx * (j + ny * k)` (x fastest).
///
/// ```
/// use isokit_field::Grid;
/// use glam::Vec3;
/// let mut g = Grid::new([4, 4, 4], Vec3::ZERO, 0.5).unwrap();
/// g.set(1, 2, 3, 7.0);
/// assert_eq!(g.get(1, 2, 3), 7.0);
/// assert_eq!(g.position(1, 2, 3), Vec3::new(0.5, 1.0, 1.5));
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    dims: [usize; 3],
    origin: Vec3,
    spacing: f32,
    data: Vec<f32>,
}

fn check_geometry(origin: Vec3, spacing: f32) -> Result<(), FieldError> {
    if !(spacing.is_finite() && spacing > 0.0) {
        return Err(FieldError::BadSpacing(spacing));
    }
    if !origin.is_finite() {
        return Err(FieldError::BadOrigin(origin.to_array()));
    }
    Ok(())
}

impl Grid {
    /// A grid filled with zeros.
    pub fn new(dims: [usize; 3], origin: Vec3, spacing: f32) -> Result<Self, FieldError> {
        Self::filled(dims, origin, spacing, 0.0)
    }

    /// A grid filled with `value`. Besides the size limits of [`checked_len`], the grid
    /// must fit the memory budget ([`crate::memory`]): [`FieldError::OverBudget`] otherwise,
    /// before anything is allocated.
    pub fn filled(
        dims: [usize; 3],
        origin: Vec3,
        spacing: f32,
        value: f32,
    ) -> Result<Self, FieldError> {
        check_geometry(origin, spacing)?;
        let n = checked_len(dims)?;
        check_grid_budget(dims)?;
        Ok(Self {
            dims,
            origin,
            spacing,
            data: vec![value; n],
        })
    }

    /// A grid around existing samples (x fastest).
    pub fn from_data(
        dims: [usize; 3],
        origin: Vec3,
        spacing: f32,
        data: Vec<f32>,
    ) -> Result<Self, FieldError> {
        check_geometry(origin, spacing)?;
        let want = checked_len(dims)?;
        if data.len() != want {
            return Err(FieldError::DataLength {
                dims,
                want,
                got: data.len(),
            });
        }
        Ok(Self {
            dims,
            origin,
            spacing,
            data,
        })
    }

    /// An empty grid covering `bounds` grown by `pad` on every side, with `res` samples along
    /// the longest axis and the same spacing on the others (at least 2 samples per axis).
    pub fn covering(bounds: Aabb, res: usize, pad: f32) -> Result<Self, FieldError> {
        let (dims, origin, spacing) = Self::covering_geometry(bounds, res, pad)?;
        Self::new(dims, origin, spacing)
    }

    /// The dimensions, origin and spacing [`Grid::covering`] would use, checked against the
    /// size limits but without allocating (for sparse grids over the same lattice).
    pub fn covering_geometry(
        bounds: Aabb,
        res: usize,
        pad: f32,
    ) -> Result<([usize; 3], Vec3, f32), FieldError> {
        let b = bounds.expanded(pad.max(0.0));
        if b.is_empty() || !b.is_finite() {
            return Err(FieldError::BadBounds(bounds));
        }
        if res < 2 {
            return Err(FieldError::BadParameter {
                name: "res",
                value: res.to_string(),
                why: "need at least 2 samples along the longest axis",
            });
        }
        let size = b.size();
        let longest = size.max_element();
        let spacing = if longest > 0.0 {
            longest / (res - 1) as f32
        } else {
            1.0
        };
        let dims: [usize; 3] = std::array::from_fn(|a| {
            ((size[a] / spacing).ceil() as usize)
                .saturating_add(1)
                .clamp(2, res.max(2))
        });
        // Centre the lattice on the box.
        let span = Vec3::new(
            (dims[0] - 1) as f32,
            (dims[1] - 1) as f32,
            (dims[2] - 1) as f32,
        ) * spacing;
        let origin = b.center() - 0.5 * span;
        checked_len(dims)?;
        Ok((dims, origin, spacing))
    }

    /// Why padding `pad` is unusable for a grid of `res` samples over `bounds`, if it is:
    /// not finite, negative, or so large that the padded lattice's spacing exceeds the
    /// diagonal of `bounds` (the shape would fall between two samples). `None` when fine.
    ///
    /// ```
    /// use isokit_field::{Aabb, Grid};
    /// use glam::Vec3;
    /// let b = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
    /// assert!(Grid::padding_problem(b, 64, 0.5).is_none());
    /// assert!(Grid::padding_problem(b, 64, 1e30).is_some());
    /// assert!(Grid::padding_problem(b, 64, f32::NAN).is_some());
    /// ```
    pub fn padding_problem(bounds: Aabb, res: usize, pad: f32) -> Option<String> {
        if !(pad.is_finite() && pad >= 0.0) {
            return Some("must be finite and non-negative".into());
        }
        let diag = bounds.diagonal();
        let longest = bounds.expanded(pad).size().max_element();
        let spacing = longest / res.saturating_sub(1).max(1) as f32;
        (diag.is_finite() && diag > 0.0 && (spacing > diag || spacing.is_nan())).then(|| {
            format!(
                "makes the sample spacing {spacing:e} larger than the shape itself (diagonal {diag}); use a padding below {:.4}",
                0.5 * (diag * res.saturating_sub(1).max(1) as f32 - bounds.size().max_element())
            )
        })
    }

    /// Samples along x, y, z.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }
    /// World position of sample (0, 0, 0).
    pub fn origin(&self) -> Vec3 {
        self.origin
    }
    /// Distance between neighbouring samples (uniform on all axes).
    pub fn spacing(&self) -> f32 {
        self.spacing
    }
    /// All samples, x fastest.
    pub fn data(&self) -> &[f32] {
        &self.data
    }
    /// All samples, mutable, x fastest.
    pub fn data_mut(&mut self) -> &mut [f32] {
        &mut self.data
    }
    /// Takes the sample buffer.
    pub fn into_data(self) -> Vec<f32> {
        self.data
    }
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.data.len()
    }
    /// Never true for a constructed grid (kept for API symmetry with slices).
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// Linear index of sample (i, j, k). Panics in debug builds when out of range.
    #[inline]
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        debug_assert!(i < self.dims[0] && j < self.dims[1] && k < self.dims[2]);
        i + self.dims[0] * (j + self.dims[1] * k)
    }

    /// Sample (i, j, k). Panics when out of range.
    #[inline]
    pub fn get(&self, i: usize, j: usize, k: usize) -> f32 {
        self.data[self.index(i, j, k)]
    }

    /// Sample at integer coordinates clamped to the grid (edge extension). Used by filters.
    #[inline]
    pub fn get_clamped(&self, c: IVec3) -> f32 {
        let i = c.x.clamp(0, self.dims[0] as i32 - 1) as usize;
        let j = c.y.clamp(0, self.dims[1] as i32 - 1) as usize;
        let k = c.z.clamp(0, self.dims[2] as i32 - 1) as usize;
        self.data[i + self.dims[0] * (j + self.dims[1] * k)]
    }

    /// Sets sample (i, j, k). Panics when out of range.
    #[inline]
    pub fn set(&mut self, i: usize, j: usize, k: usize, v: f32) {
        let idx = self.index(i, j, k);
        self.data[idx] = v;
    }

    /// World position of sample (i, j, k).
    #[inline]
    pub fn position(&self, i: usize, j: usize, k: usize) -> Vec3 {
        self.origin + self.spacing * Vec3::new(i as f32, j as f32, k as f32)
    }

    /// Continuous grid coordinates of a world point (sample (i, j, k) is at `(i, j, k)`).
    #[inline]
    pub fn to_grid(&self, p: Vec3) -> Vec3 {
        (p - self.origin) / self.spacing
    }

    /// The box spanned by the samples.
    pub fn bounds(&self) -> Aabb {
        let n = Vec3::new(
            (self.dims[0] - 1) as f32,
            (self.dims[1] - 1) as f32,
            (self.dims[2] - 1) as f32,
        );
        Aabb::new(self.origin, self.origin + n * self.spacing)
    }

    /// Smallest and largest finite sample, or `None` when no sample is finite.
    pub fn min_max(&self) -> Option<(f32, f32)> {
        finite_min_max(&self.data)
    }

    /// Clamps every sample to `[-band, band]` (in parallel): a lazily sampled band, whose
    /// kept bricks hold exact values a little beyond `band`, then reads "the field within
    /// `band`, `±band` beyond" everywhere, as a dense sampling clamped the same way would.
    pub fn clamp_to_band(&mut self, band: f32) {
        use rayon::prelude::*;
        self.data
            .par_iter_mut()
            .for_each(|v| *v = v.clamp(-band, band));
    }

    /// Iterates `((i, j, k), value)` in storage order.
    pub fn iter(&self) -> impl Iterator<Item = ([usize; 3], f32)> + '_ {
        let [nx, ny, _] = self.dims;
        self.data
            .iter()
            .enumerate()
            .map(move |(n, &v)| ([n % nx, (n / nx) % ny, n / (nx * ny)], v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clamps_to_the_band() {
        let mut g =
            Grid::from_data([2, 2, 1], Vec3::ZERO, 1.0, vec![-3.0, -0.5, 0.25, 7.0]).unwrap();
        g.clamp_to_band(1.0);
        assert_eq!(g.data(), &[-1.0, -0.5, 0.25, 1.0]);
    }

    #[test]
    fn refuses_absurd_sizes_before_allocating() {
        let e = Grid::new([100_000, 100_000, 100_000], Vec3::ZERO, 1.0).unwrap_err();
        assert!(matches!(e, FieldError::TooLarge { .. }), "{e}");
        let e = Grid::new([usize::MAX, usize::MAX, 2], Vec3::ZERO, 1.0).unwrap_err();
        assert!(matches!(e, FieldError::TooLarge { .. }));
        assert_eq!(
            Grid::new([0, 3, 3], Vec3::ZERO, 1.0).unwrap_err(),
            FieldError::EmptyDims([0, 3, 3])
        );
        assert!(Grid::new([2, 2, 2], Vec3::ZERO, 0.0).is_err());
        assert!(Grid::new([2, 2, 2], Vec3::ZERO, f32::NAN).is_err());
        assert!(Grid::new([2, 2, 2], Vec3::splat(f32::INFINITY), 1.0).is_err());
    }

    /// An axis of 2^31 samples is within MAX_SAMPLES but would overflow `dims as i32 - 1`
    /// (a debug-build panic in `get_clamped` and the brick grid): refused up front.
    #[test]
    fn refuses_axes_beyond_i32_range() {
        for dims in [[1 << 31, 1, 1], [1, 1 << 30, 2], [1, 1, MAX_AXIS + 1]] {
            assert_eq!(
                checked_len(dims),
                Err(FieldError::AxisTooLong {
                    dims,
                    limit: MAX_AXIS
                }),
                "{dims:?}"
            );
            assert!(crate::BrickGrid::new(dims, Vec3::ZERO, 1.0, 8, 1, 0.0).is_err());
        }
        assert_eq!(checked_len([MAX_AXIS, 2, 1]), Ok(2 * MAX_AXIS));
        let msg = checked_len([1 << 31, 1, 1]).unwrap_err().to_string();
        assert!(
            msg.contains("axis") && msg.contains(&MAX_AXIS.to_string()),
            "{msg}"
        );
        // Too large overall stays TooLarge.
        assert!(matches!(
            checked_len([1 << 40, 1 << 40, 1]),
            Err(FieldError::TooLarge { .. })
        ));
    }

    #[test]
    fn x_fastest_layout() {
        let g = Grid::from_data(
            [2, 3, 4],
            Vec3::ZERO,
            1.0,
            (0..24).map(|v| v as f32).collect(),
        )
        .unwrap();
        assert_eq!(g.get(1, 0, 0), 1.0);
        assert_eq!(g.get(0, 1, 0), 2.0);
        assert_eq!(g.get(0, 0, 1), 6.0);
        for ([i, j, k], v) in g.iter() {
            assert_eq!(g.get(i, j, k), v);
        }
        assert!(Grid::from_data([2, 3, 4], Vec3::ZERO, 1.0, vec![0.0; 23]).is_err());
    }

    #[test]
    fn covering_spans_the_padded_box() {
        let b = Aabb::new(Vec3::splat(-1.0), Vec3::new(1.0, 0.5, 0.0));
        let g = Grid::covering(b, 65, 0.1).unwrap();
        assert_eq!(g.dims()[0], 65);
        let gb = g.bounds();
        let want = b.expanded(0.1);
        assert!((gb.min - want.min).abs().max_element() <= g.spacing() * 0.5 + 1e-6);
        assert!(gb.min.cmple(want.min + Vec3::splat(1e-5)).all());
        assert!(gb.max.cmpge(want.max - Vec3::splat(1e-5)).all());
        assert!(Grid::covering(Aabb::INFINITE, 10, 0.0).is_err());
        assert!(Grid::covering(Aabb::EMPTY, 10, 0.0).is_err());
        assert!(Grid::covering(b, 1, 0.0).is_err());
    }

    #[test]
    fn min_max_skips_non_finite() {
        let g = Grid::from_data([2, 1, 1], Vec3::ZERO, 1.0, vec![f32::NAN, 3.0]).unwrap();
        assert_eq!(g.min_max(), Some((3.0, 3.0)));
        let g = Grid::from_data([1, 1, 1], Vec3::ZERO, 1.0, vec![f32::NAN]).unwrap();
        assert_eq!(g.min_max(), None);
    }
}
