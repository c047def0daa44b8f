//! Reconstruction filters on a [`Grid`]: trilinear, tricubic B-spline (value, gradient and
//! Hessian, by direct 64-tap convolution and by the fast 8-fetch scheme of dissertation 002
//! Ch. 5 / Sigg & Hadwiger, GPU Gems 2 ch. 20) and Catmull-Rom, plus [`SampledField`], a
//! [`Grid`] seen through one of them as a [`Field`].
//!
//! ## Coordinates and borders
//! The functions that take `p_grid` work in continuous *grid coordinates*: sample
//! `(i, j, k)` sits at `(i, j, k)` (convert a world point with [`Grid::to_grid`]). Their
//! derivatives are in grid units (per sample spacing); [`Derivatives::to_world`] and the
//! `*_world` functions divide the gradient by the spacing and the Hessian by its square.
//! Outside the grid every filter reads the samples clamped to the edge
//! ([`Grid::get_clamped`], like a GPU texture with clamp-to-edge addressing), so values
//! stay finite but are no longer distances there, and derivatives across the border are
//! those of the clamped data. Non-finite coordinates give NaN, never a panic.
//!
//! ## The filters
//! - **Trilinear**: interpolating, C0; its gradient is piecewise constant along each axis.
//! - **Cubic B-spline**: C2, so gradient and Hessian are continuous, which curvature needs.
//!   It is *approximating, not interpolating*: at a sample it returns
//!   `(f[i-1] + 4 f[i] + f[i+1]) / 6` per axis, not `f[i]`. It reproduces linear functions
//!   exactly but smooths curved data: values shift by about `h² Δf / 6` (`Δ` the
//!   Laplacian, `h` the spacing), so the isosurface of a sampled SDF moves slightly (a
//!   sphere of radius 0.8 sampled at 64³ reads +4.2e-4 on its true surface, i.e. it
//!   shrinks). No prefilter is applied.
//! - **Catmull-Rom**: interpolating, C1; it may overshoot near sharp features and its
//!   Hessian jumps across cell faces.
//!
//! ## Weights (ERRATA 2 and 3)
//! The printed Eq. 5.2 and 5.9 of 002 carry wrong `w1` and `w1'`; the corrected forms are
//! used here: `w0 = (1-a)³/6`, `w1 = (3a³ − 6a² + 4)/6`, `w2 = (−3a³ + 3a² + 3a + 1)/6`,
//! `w3 = a³/6`; `w0' = −(1−a)²/2`, `w1' = (3a² − 4a)/2`, `w2' = (−3a² + 2a + 1)/2`,
//! `w3' = a²/2`; `w'' = (1−a, 3a−2, 1−3a, a)`.
//!
//! ## Two schemes for the tricubic B-spline
//! - **Direct** (`tricubic_bspline*`): the 64-tap convolution, accumulated in f64. This is
//!   the reference.
//! - **Fast** (`tricubic_bspline*_fast`): the CPU twin of the GPU shader, written as the
//!   shader is written (f32, scalar ops, no allocation). Per axis the four taps become two
//!   linear fetches ([`TwoFetch`]): `g0 = w0 + w1` at `i − 1 + w1/(w0 + w1)` and
//!   `g1 = w2 + w3` at `i + 1 + w3/(w2 + w3)` (ERRATA 4), combined as
//!   `g0·f0 + g1·f1`, which for value weights is `lerp(f0, f1, g1)` (ERRATA 5) and for
//!   derivative weights `g0·(f0 − f1)` (Listing 5.3). In 3D: value 8 trilinear fetches,
//!   each gradient component 8, each mixed second derivative 8, each pure second
//!   derivative 12 (`f'' = lin(x−1) − 2 lin(x) + lin(x+1)` along its axis, Listing 5.4,
//!   times the two-fetch scheme on the other two axes).
//!
//! The two schemes agree to about 1e-7 of the data's largest magnitude (tested at 1e-6).
//!
//! The fetch of the fast scheme takes the cell (integer) and the position inside it (in
//! `[0, 1]`) separately, as the shader's manual trilinear load (`textureLoad` ×8 and `mix`)
//! does; a hardware-filtered fetch at `(cell + t + 0.5) / dims` gives the same result up to
//! the hardware's weight precision (8 bits of fraction on most GPUs).

use crate::{Aabb, Field, Grid};
use glam::{DMat3, DVec3, IVec3, Mat3, Vec3};

// ---------------------------------------------------------------------------------------
// 1D weights, f32 (shader precision). The f64 twins below feed the direct convolution.
// ---------------------------------------------------------------------------------------

/// Cubic B-spline weights of the taps `i−1, i, i+1, i+2` at fractional position `a` in
/// `[0, 1]` (ERRATA 2: `w1 = (3a³ − 6a² + 4)/6`). They are non-negative and sum to 1.
pub fn bspline_weights(a: f32) -> [f32; 4] {
    let b = 1.0 - a;
    let a2 = a * a;
    let a3 = a2 * a;
    [
        b * b * b / 6.0,
        (3.0 * a3 - 6.0 * a2 + 4.0) / 6.0,
        (-3.0 * a3 + 3.0 * a2 + 3.0 * a + 1.0) / 6.0,
        a3 / 6.0,
    ]
}

/// First derivatives (d/da) of [`bspline_weights`] (ERRATA 3: `w1' = (3a² − 4a)/2`). They
/// sum to 0, with `w0', w1' <= 0` and `w2', w3' >= 0` on `[0, 1]`.
pub fn bspline_weights_d1(a: f32) -> [f32; 4] {
    let b = 1.0 - a;
    let a2 = a * a;
    [
        -0.5 * b * b,
        0.5 * (3.0 * a2 - 4.0 * a),
        0.5 * (-3.0 * a2 + 2.0 * a + 1.0),
        0.5 * a2,
    ]
}

/// Second derivatives of [`bspline_weights`]: `(1 − a, 3a − 2, 1 − 3a, a)`, summing to 0.
pub fn bspline_weights_d2(a: f32) -> [f32; 4] {
    [1.0 - a, 3.0 * a - 2.0, 1.0 - 3.0 * a, a]
}

/// Catmull-Rom weights of the taps `i−1, i, i+1, i+2` (interpolating: `(0, 1, 0, 0)` at
/// `a = 0`). They sum to 1 but `w0` and `w3` are negative inside the cell.
pub fn catmull_rom_weights(a: f32) -> [f32; 4] {
    let a2 = a * a;
    let a3 = a2 * a;
    [
        0.5 * (-a3 + 2.0 * a2 - a),
        0.5 * (3.0 * a3 - 5.0 * a2 + 2.0),
        0.5 * (-3.0 * a3 + 4.0 * a2 + a),
        0.5 * (a3 - a2),
    ]
}

/// First derivatives of [`catmull_rom_weights`], summing to 0.
pub fn catmull_rom_weights_d1(a: f32) -> [f32; 4] {
    let a2 = a * a;
    [
        0.5 * (-3.0 * a2 + 4.0 * a - 1.0),
        0.5 * (9.0 * a2 - 10.0 * a),
        0.5 * (-9.0 * a2 + 8.0 * a + 1.0),
        0.5 * (3.0 * a2 - 2.0 * a),
    ]
}

/// Second derivatives of [`catmull_rom_weights`], summing to 0.
pub fn catmull_rom_weights_d2(a: f32) -> [f32; 4] {
    [2.0 - 3.0 * a, 9.0 * a - 5.0, 4.0 - 9.0 * a, 3.0 * a - 1.0]
}

fn bspline_w64(a: f64) -> [f64; 4] {
    let b = 1.0 - a;
    let a2 = a * a;
    let a3 = a2 * a;
    [
        b * b * b / 6.0,
        (3.0 * a3 - 6.0 * a2 + 4.0) / 6.0,
        (-3.0 * a3 + 3.0 * a2 + 3.0 * a + 1.0) / 6.0,
        a3 / 6.0,
    ]
}

fn bspline_d1_64(a: f64) -> [f64; 4] {
    let b = 1.0 - a;
    let a2 = a * a;
    [
        -0.5 * b * b,
        0.5 * (3.0 * a2 - 4.0 * a),
        0.5 * (-3.0 * a2 + 2.0 * a + 1.0),
        0.5 * a2,
    ]
}

fn bspline_d2_64(a: f64) -> [f64; 4] {
    [1.0 - a, 3.0 * a - 2.0, 1.0 - 3.0 * a, a]
}

fn catmull_rom_w64(a: f64) -> [f64; 4] {
    let a2 = a * a;
    let a3 = a2 * a;
    [
        0.5 * (-a3 + 2.0 * a2 - a),
        0.5 * (3.0 * a3 - 5.0 * a2 + 2.0),
        0.5 * (-3.0 * a3 + 4.0 * a2 + a),
        0.5 * (a3 - a2),
    ]
}

fn catmull_rom_d1_64(a: f64) -> [f64; 4] {
    let a2 = a * a;
    [
        0.5 * (-3.0 * a2 + 4.0 * a - 1.0),
        0.5 * (9.0 * a2 - 10.0 * a),
        0.5 * (-9.0 * a2 + 8.0 * a + 1.0),
        0.5 * (3.0 * a2 - 2.0 * a),
    ]
}

fn catmull_rom_d2_64(a: f64) -> [f64; 4] {
    [2.0 - 3.0 * a, 9.0 * a - 5.0, 4.0 - 9.0 * a, 3.0 * a - 1.0]
}

fn linear_w64(a: f64) -> [f64; 2] {
    [1.0 - a, a]
}

fn linear_d1_64(_a: f64) -> [f64; 2] {
    [-1.0, 1.0]
}

fn linear_d2_64(_a: f64) -> [f64; 2] {
    [0.0, 0.0]
}

// ---------------------------------------------------------------------------------------
// Two-fetch parameters (the content of the paper's `tex_hg` lookup texture).
// ---------------------------------------------------------------------------------------

/// One axis of the fast scheme: the four taps `w0..w3` at `i−1..i+2` replaced by two linear
/// fetches, `g0` times the fetch at `i − 1 + t0` and `g1` times the fetch at `i + 1 + t1`.
///
/// This is valid when `w0, w1` share a sign and `w2, w3` share a sign (true for the cubic
/// B-spline and its first derivative, not for Catmull-Rom). In the paper's notation
/// `h0 = 1 − t0 + a` and `h1 = 1 + t1 − a` (002 Eq. 5.6; 001 prints `h1` wrongly, ERRATA 4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TwoFetch {
    /// Weight of the first fetch, `w0 + w1`.
    pub g0: f32,
    /// Weight of the second fetch, `w2 + w3` (`1 − g0` for values, `−g0` for derivatives).
    pub g1: f32,
    /// Position of the first fetch inside cell `i − 1`: `w1 / (w0 + w1)`, in `[0, 1]`.
    pub t0: f32,
    /// Position of the second fetch inside cell `i + 1`: `w3 / (w2 + w3)`, in `[0, 1]`.
    pub t1: f32,
}

impl TwoFetch {
    /// From four tap weights. `w0 + w1` and `w2 + w3` must not vanish (they are at least
    /// 1/6 for the B-spline and at least 1/2 in magnitude for its derivative).
    pub fn from_weights(w: [f32; 4]) -> Self {
        let g0 = w[0] + w[1];
        let g1 = w[2] + w[3];
        Self {
            g0,
            g1,
            t0: w[1] / g0,
            t1: w[3] / g1,
        }
    }

    /// Cubic B-spline value weights at fractional position `a`.
    pub fn bspline(a: f32) -> Self {
        Self::from_weights(bspline_weights(a))
    }

    /// Cubic B-spline first-derivative weights at fractional position `a` (`g1 = −g0`).
    pub fn bspline_d1(a: f32) -> Self {
        Self::from_weights(bspline_weights_d1(a))
    }
}

// ---------------------------------------------------------------------------------------
// Cells and the emulated texture fetch.
// ---------------------------------------------------------------------------------------

/// Splits grid coordinates into the cell `floor(p)` and the fractional part `a` in
/// `[0, 1]`. The cell is clamped to `[-3, dims + 1]` per axis: beyond that every tap of
/// every filter reads the same edge sample, so the result is unchanged and the integer
/// arithmetic cannot overflow.
#[inline]
fn split(grid: &Grid, p: Vec3) -> (IVec3, Vec3) {
    let f = p.floor();
    let a = p - f;
    let dims = grid.dims();
    let cell = |x: f32, n: usize| {
        let hi = (n as i64 + 1).min(i64::from(i32::MAX / 2)) as f32;
        x.max(-3.0).min(hi) as i32
    };
    (
        IVec3::new(cell(f.x, dims[0]), cell(f.y, dims[1]), cell(f.z, dims[2])),
        a,
    )
}

#[inline]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + t * (b - a)
}

/// The emulated texture fetch: trilinear interpolation inside cell `c` (corners `c` and
/// `c + 1` per axis, clamped to the edge) at position `t` in `[0, 1]³`.
///
/// WGSL twin: eight `textureLoad`s at `clamp(c + corner, 0, dims − 1)` and seven `mix`.
#[inline]
fn fetch(grid: &Grid, c: IVec3, t: Vec3) -> f32 {
    let s = |dx: i32, dy: i32, dz: i32| grid.get_clamped(c + IVec3::new(dx, dy, dz));
    let x00 = lerp(s(0, 0, 0), s(1, 0, 0), t.x);
    let x10 = lerp(s(0, 1, 0), s(1, 1, 0), t.x);
    let x01 = lerp(s(0, 0, 1), s(1, 0, 1), t.x);
    let x11 = lerp(s(0, 1, 1), s(1, 1, 1), t.x);
    lerp(lerp(x00, x10, t.y), lerp(x01, x11, t.y), t.z)
}

/// Trilinear interpolation at grid coordinates `p_grid` with clamp-to-edge: the emulated
/// GPU texture fetch that the fast tricubic scheme is built on.
///
/// ```
/// use isokit_field::{filter::trilinear, Grid};
/// use glam::Vec3;
/// let g = Grid::from_data([2, 1, 1], Vec3::ZERO, 1.0, vec![1.0, 3.0]).unwrap();
/// assert_eq!(trilinear(&g, Vec3::new(0.25, 0.0, 0.0)), 1.5);
/// assert_eq!(trilinear(&g, Vec3::new(-5.0, 0.0, 0.0)), 1.0); // clamped to the edge
/// ```
pub fn trilinear(grid: &Grid, p_grid: Vec3) -> f32 {
    let (c, t) = split(grid, p_grid);
    fetch(grid, c, t)
}

/// Gradient of the trilinear interpolant at `p_grid`, in grid units (f64 accumulation).
/// Piecewise: on a cell face it is the one of the cell `floor(p_grid)`.
pub fn trilinear_gradient(grid: &Grid, p_grid: Vec3) -> Vec3 {
    LINEAR.gradient(grid, p_grid).as_vec3()
}

/// Value, gradient and Hessian of the trilinear interpolant at `p_grid`, in grid units.
/// The Hessian has a zero diagonal and the cell's mixed terms.
pub fn trilinear_derivatives(grid: &Grid, p_grid: Vec3) -> Derivatives {
    LINEAR.derivatives(grid, p_grid)
}

// ---------------------------------------------------------------------------------------
// Direct convolution (f64 accumulation).
// ---------------------------------------------------------------------------------------

/// Value, gradient and Hessian (symmetric) of a reconstruction at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Derivatives {
    /// Reconstructed value.
    pub value: f32,
    /// Gradient, in grid units unless converted by [`Derivatives::to_world`].
    pub gradient: Vec3,
    /// Hessian (symmetric), in grid units unless converted by [`Derivatives::to_world`].
    pub hessian: Mat3,
}

impl Derivatives {
    /// From grid units to world units of a grid with this `spacing`: the gradient is
    /// divided by `spacing`, the Hessian by `spacing²`.
    pub fn to_world(self, spacing: f32) -> Self {
        let inv = 1.0 / f64::from(spacing);
        Self {
            value: self.value,
            gradient: (self.gradient.as_dvec3() * inv).as_vec3(),
            hessian: (self.hessian.as_dmat3() * (inv * inv)).as_mat3(),
        }
    }
}

type Weights<const N: usize> = fn(f64) -> [f64; N];

/// A separable kernel of `N` taps starting at `floor(p) + first`, with its derivatives.
struct Kernel<const N: usize> {
    first: i32,
    w: Weights<N>,
    d1: Weights<N>,
    d2: Weights<N>,
}

const LINEAR: Kernel<2> = Kernel {
    first: 0,
    w: linear_w64,
    d1: linear_d1_64,
    d2: linear_d2_64,
};

const BSPLINE: Kernel<4> = Kernel {
    first: -1,
    w: bspline_w64,
    d1: bspline_d1_64,
    d2: bspline_d2_64,
};

const CATMULL_ROM: Kernel<4> = Kernel {
    first: -1,
    w: catmull_rom_w64,
    d1: catmull_rom_d1_64,
    d2: catmull_rom_d2_64,
};

/// The `N³` samples of the support, clamped to the edge, indexed `[z][y][x]`.
type Block<const N: usize> = [[[f64; N]; N]; N];

impl<const N: usize> Kernel<N> {
    fn gather(&self, grid: &Grid, p: Vec3) -> (Block<N>, DVec3) {
        let (c, _) = split(grid, p);
        let p = p.as_dvec3();
        let a = p - p.floor();
        let base = c + IVec3::splat(self.first);
        let block = std::array::from_fn(|k| {
            std::array::from_fn(|j| {
                std::array::from_fn(|i| {
                    f64::from(grid.get_clamped(base + IVec3::new(i as i32, j as i32, k as i32)))
                })
            })
        });
        (block, a)
    }

    fn contract(s: &Block<N>, wx: &[f64; N], wy: &[f64; N], wz: &[f64; N]) -> f64 {
        let mut acc = 0.0;
        for (plane, &wzk) in s.iter().zip(wz) {
            let mut acc_y = 0.0;
            for (row, &wyj) in plane.iter().zip(wy) {
                let acc_x: f64 = row.iter().zip(wx).map(|(v, w)| v * w).sum();
                acc_y += wyj * acc_x;
            }
            acc += wzk * acc_y;
        }
        acc
    }

    fn value(&self, grid: &Grid, p: Vec3) -> f64 {
        let (s, a) = self.gather(grid, p);
        Self::contract(&s, &(self.w)(a.x), &(self.w)(a.y), &(self.w)(a.z))
    }

    fn gradient(&self, grid: &Grid, p: Vec3) -> DVec3 {
        let (s, a) = self.gather(grid, p);
        let w = [(self.w)(a.x), (self.w)(a.y), (self.w)(a.z)];
        let d = [(self.d1)(a.x), (self.d1)(a.y), (self.d1)(a.z)];
        DVec3::new(
            Self::contract(&s, &d[0], &w[1], &w[2]),
            Self::contract(&s, &w[0], &d[1], &w[2]),
            Self::contract(&s, &w[0], &w[1], &d[2]),
        )
    }

    fn derivatives(&self, grid: &Grid, p: Vec3) -> Derivatives {
        let (s, a) = self.gather(grid, p);
        let w = [(self.w)(a.x), (self.w)(a.y), (self.w)(a.z)];
        let d = [(self.d1)(a.x), (self.d1)(a.y), (self.d1)(a.z)];
        let dd = [(self.d2)(a.x), (self.d2)(a.y), (self.d2)(a.z)];
        let value = Self::contract(&s, &w[0], &w[1], &w[2]);
        let gradient = DVec3::new(
            Self::contract(&s, &d[0], &w[1], &w[2]),
            Self::contract(&s, &w[0], &d[1], &w[2]),
            Self::contract(&s, &w[0], &w[1], &d[2]),
        );
        let hxx = Self::contract(&s, &dd[0], &w[1], &w[2]);
        let hyy = Self::contract(&s, &w[0], &dd[1], &w[2]);
        let hzz = Self::contract(&s, &w[0], &w[1], &dd[2]);
        let hxy = Self::contract(&s, &d[0], &d[1], &w[2]);
        let hxz = Self::contract(&s, &d[0], &w[1], &d[2]);
        let hyz = Self::contract(&s, &w[0], &d[1], &d[2]);
        let hessian = DMat3::from_cols(
            DVec3::new(hxx, hxy, hxz),
            DVec3::new(hxy, hyy, hyz),
            DVec3::new(hxz, hyz, hzz),
        );
        Derivatives {
            value: value as f32,
            gradient: gradient.as_vec3(),
            hessian: hessian.as_mat3(),
        }
    }
}

/// Tricubic B-spline value at `p_grid` by direct 64-tap convolution (f64 accumulation).
/// Approximating: at a sample it is not the sample's value (see the module docs).
pub fn tricubic_bspline(grid: &Grid, p_grid: Vec3) -> f32 {
    BSPLINE.value(grid, p_grid) as f32
}

/// Tricubic B-spline gradient at `p_grid` in grid units, by direct convolution.
pub fn tricubic_bspline_gradient(grid: &Grid, p_grid: Vec3) -> Vec3 {
    BSPLINE.gradient(grid, p_grid).as_vec3()
}

/// Tricubic B-spline Hessian (symmetric) at `p_grid` in grid units, by direct convolution.
pub fn tricubic_bspline_hessian(grid: &Grid, p_grid: Vec3) -> Mat3 {
    BSPLINE.derivatives(grid, p_grid).hessian
}

/// Tricubic B-spline value, gradient and Hessian at `p_grid` in grid units, by direct
/// convolution (64 samples read once, 10 contractions in f64). The reference for the
/// fast scheme.
pub fn tricubic_bspline_derivatives(grid: &Grid, p_grid: Vec3) -> Derivatives {
    BSPLINE.derivatives(grid, p_grid)
}

/// [`tricubic_bspline_derivatives`] at a world point, in world units.
pub fn tricubic_bspline_derivatives_world(grid: &Grid, p_world: Vec3) -> Derivatives {
    tricubic_bspline_derivatives(grid, grid.to_grid(p_world)).to_world(grid.spacing())
}

/// Tricubic Catmull-Rom value at `p_grid` (interpolating; direct 64-tap convolution).
pub fn catmull_rom(grid: &Grid, p_grid: Vec3) -> f32 {
    CATMULL_ROM.value(grid, p_grid) as f32
}

/// Tricubic Catmull-Rom gradient at `p_grid` in grid units (continuous: the filter is C1).
pub fn catmull_rom_gradient(grid: &Grid, p_grid: Vec3) -> Vec3 {
    CATMULL_ROM.gradient(grid, p_grid).as_vec3()
}

/// Tricubic Catmull-Rom value, gradient and Hessian at `p_grid` in grid units. The Hessian
/// is that of the cell `floor(p_grid)`; it jumps across cell faces.
pub fn catmull_rom_derivatives(grid: &Grid, p_grid: Vec3) -> Derivatives {
    CATMULL_ROM.derivatives(grid, p_grid)
}

// ---------------------------------------------------------------------------------------
// Fast scheme: the CPU twin of the WGSL shader.
//
// Shader mapping (WGSL to come; names there should follow these):
//   split()            -> `let c = vec3<i32>(floor(p)); let a = p - floor(p);`
//   TwoFetch::bspline  -> `fn bspline_hg(a: f32) -> vec4<f32>` returning (g0, g1, t0, t1)
//   TwoFetch::bspline_d1 -> `fn bspline_dg(a: f32) -> vec4<f32>` (same layout)
//   Taps::two / three  -> the per-axis constants of the fetch loops
//   fetch()            -> `fn fetch(c: vec3<i32>, t: vec3<f32>) -> f32`
//                         (8 x textureLoad + 7 x mix; or one textureSampleLevel)
//   fetch_sum()        -> three nested constant-bound loops, innermost z:
//                         `sz += wz * fetch(c + off, t)`, then `sy += wy * sz`,
//                         `sx += wx * sy`
//   fast_derivatives() -> the 1 + 3 + 6 calls of fetch_sum with the axis taps picked
//                         per derivative (value: b b b; d/dx: d b b; d2/dxdy: d d b;
//                         d2/dx2: s b b)
// ---------------------------------------------------------------------------------------

/// Up to three linear fetches along one axis: cells `c + cell[n]`, positions `t[n]` in the
/// cell, weights `w[n]`.
#[derive(Clone, Copy, Debug)]
struct Taps {
    n: usize,
    cell: [i32; 3],
    t: [f32; 3],
    w: [f32; 3],
}

impl Taps {
    /// Two fetches at `i − 1 + t0` and `i + 1 + t1` (ERRATA 4), weights `g0, g1`: for
    /// value weights `g0·f0 + g1·f1 = lerp(f0, f1, g1)` (ERRATA 5), for derivative weights
    /// `g0·(f0 − f1)` (Listing 5.3).
    #[inline]
    fn two(f: TwoFetch) -> Self {
        Self {
            n: 2,
            cell: [-1, 1, 0],
            t: [f.t0, f.t1, 0.0],
            w: [f.g0, f.g1, 0.0],
        }
    }

    /// Second derivative (Listing 5.4): linear fetches at `x − 1, x, x + 1`, i.e. cells
    /// `i − 1, i, i + 1` at the same position `a`, weighted `(1, −2, 1)`.
    #[inline]
    fn three(a: f32) -> Self {
        Self {
            n: 3,
            cell: [-1, 0, 1],
            t: [a; 3],
            w: [1.0, -2.0, 1.0],
        }
    }
}

/// `Σx wx Σy wy Σz wz fetch(c + (cx, cy, cz), (tx, ty, tz))`: 8 fetches for two-fetch taps
/// on every axis, 12 when one axis has three.
#[inline]
fn fetch_sum(grid: &Grid, c: IVec3, x: &Taps, y: &Taps, z: &Taps) -> f32 {
    let mut sx = 0.0f32;
    for ix in 0..x.n {
        let mut sy = 0.0f32;
        for iy in 0..y.n {
            let mut sz = 0.0f32;
            for iz in 0..z.n {
                let cell = c + IVec3::new(x.cell[ix], y.cell[iy], z.cell[iz]);
                let t = Vec3::new(x.t[ix], y.t[iy], z.t[iz]);
                sz += z.w[iz] * fetch(grid, cell, t);
            }
            sy += y.w[iy] * sz;
        }
        sx += x.w[ix] * sy;
    }
    sx
}

/// Per-axis taps of the fast scheme at one point: B-spline value (`b`), first derivative
/// (`d`), second derivative (`s`).
struct FastTaps {
    c: IVec3,
    b: [Taps; 3],
    d: [Taps; 3],
    s: [Taps; 3],
}

impl FastTaps {
    #[inline]
    fn new(grid: &Grid, p: Vec3) -> Self {
        let (c, a) = split(grid, p);
        let a = a.to_array();
        Self {
            c,
            b: a.map(|a| Taps::two(TwoFetch::bspline(a))),
            d: a.map(|a| Taps::two(TwoFetch::bspline_d1(a))),
            s: a.map(Taps::three),
        }
    }

    #[inline]
    fn sum(&self, grid: &Grid, x: &Taps, y: &Taps, z: &Taps) -> f32 {
        fetch_sum(grid, self.c, x, y, z)
    }

    fn value(&self, grid: &Grid) -> f32 {
        let b = &self.b;
        self.sum(grid, &b[0], &b[1], &b[2])
    }

    fn gradient(&self, grid: &Grid) -> Vec3 {
        let (b, d) = (&self.b, &self.d);
        Vec3::new(
            self.sum(grid, &d[0], &b[1], &b[2]),
            self.sum(grid, &b[0], &d[1], &b[2]),
            self.sum(grid, &b[0], &b[1], &d[2]),
        )
    }

    fn hessian(&self, grid: &Grid) -> Mat3 {
        let (b, d, s) = (&self.b, &self.d, &self.s);
        let hxx = self.sum(grid, &s[0], &b[1], &b[2]);
        let hyy = self.sum(grid, &b[0], &s[1], &b[2]);
        let hzz = self.sum(grid, &b[0], &b[1], &s[2]);
        let hxy = self.sum(grid, &d[0], &d[1], &b[2]);
        let hxz = self.sum(grid, &d[0], &b[1], &d[2]);
        let hyz = self.sum(grid, &b[0], &d[1], &d[2]);
        Mat3::from_cols(
            Vec3::new(hxx, hxy, hxz),
            Vec3::new(hxy, hyy, hyz),
            Vec3::new(hxz, hyz, hzz),
        )
    }
}

/// Tricubic B-spline value at `p_grid` by the fast scheme: 8 trilinear fetches (f32).
pub fn tricubic_bspline_fast(grid: &Grid, p_grid: Vec3) -> f32 {
    FastTaps::new(grid, p_grid).value(grid)
}

/// Tricubic B-spline gradient at `p_grid` in grid units by the fast scheme: 8 trilinear
/// fetches per component (derivative two-fetch on its axis, B-spline on the others).
pub fn tricubic_bspline_gradient_fast(grid: &Grid, p_grid: Vec3) -> Vec3 {
    FastTaps::new(grid, p_grid).gradient(grid)
}

/// Tricubic B-spline Hessian at `p_grid` in grid units by the fast scheme: 8 trilinear
/// fetches per mixed and 12 per pure second derivative (60 in all).
pub fn tricubic_bspline_hessian_fast(grid: &Grid, p_grid: Vec3) -> Mat3 {
    FastTaps::new(grid, p_grid).hessian(grid)
}

/// Tricubic B-spline value, gradient and Hessian at `p_grid` in grid units by the fast
/// scheme (8 + 24 + 60 = 92 trilinear fetches, the axis weights computed once).
pub fn tricubic_bspline_derivatives_fast(grid: &Grid, p_grid: Vec3) -> Derivatives {
    let taps = FastTaps::new(grid, p_grid);
    Derivatives {
        value: taps.value(grid),
        gradient: taps.gradient(grid),
        hessian: taps.hessian(grid),
    }
}

/// [`tricubic_bspline_derivatives_fast`] at a world point, in world units.
pub fn tricubic_bspline_derivatives_fast_world(grid: &Grid, p_world: Vec3) -> Derivatives {
    tricubic_bspline_derivatives_fast(grid, grid.to_grid(p_world)).to_world(grid.spacing())
}

// ---------------------------------------------------------------------------------------
// Filter choice and the sampled field.
// ---------------------------------------------------------------------------------------

/// Reconstruction filter of a [`SampledField`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Filter {
    /// Trilinear: interpolating, C0, 8 samples.
    Trilinear,
    /// Tricubic B-spline: approximating (not interpolating), C2, 64 samples (direct
    /// convolution in f64). The filter for normals and curvature.
    #[default]
    CubicBSpline,
    /// Tricubic Catmull-Rom: interpolating, C1, 64 samples; may overshoot.
    CatmullRom,
}

impl Filter {
    /// Value, gradient and Hessian at `p_grid`, in grid units.
    pub fn derivatives(self, grid: &Grid, p_grid: Vec3) -> Derivatives {
        match self {
            Filter::Trilinear => trilinear_derivatives(grid, p_grid),
            Filter::CubicBSpline => tricubic_bspline_derivatives(grid, p_grid),
            Filter::CatmullRom => catmull_rom_derivatives(grid, p_grid),
        }
    }

    /// Value at `p_grid`.
    pub fn value(self, grid: &Grid, p_grid: Vec3) -> f32 {
        match self {
            Filter::Trilinear => trilinear(grid, p_grid),
            Filter::CubicBSpline => tricubic_bspline(grid, p_grid),
            Filter::CatmullRom => catmull_rom(grid, p_grid),
        }
    }

    /// A bound on `|∇f|` of the reconstruction, in units of the samples' own Lipschitz
    /// constant: if every difference between neighbouring samples along an axis is at most
    /// `L · spacing` (true with `L = 1` for samples of a signed distance), the reconstructed
    /// field is `lipschitz_factor() · L`-Lipschitz everywhere (edge clamping included, since
    /// clamped neighbours differ by 0 or by a real neighbour difference).
    ///
    /// Derivation, per axis (grid units, differences `D = f[i+1] − f[i]`, `|D| ≤ L`):
    /// - **Trilinear** and **cubic B-spline**: `∂f/∂x` is a combination of x-differences
    ///   with non-negative weights summing to 1 (for the B-spline, the derivative weights
    ///   telescope into the quadratic B-spline weights; the y and z weights are non-negative
    ///   too), so `|∂f/∂x| ≤ L`. With all three components bounded, `|∇f| ≤ √3 · L`.
    /// - **Catmull-Rom**: the derivative weights telescope into `c0 D0 + c1 D1 + c2 D2` with
    ///   `c0 = (3a−1)(a−1)/2`, `c1 = (1 + 6a − 6a²)/2`, `c2 = a(3a−2)/2` (sum 1), whose
    ///   absolute sum is at most 3/2 (at `a = 1/2`); the value weights across the other two
    ///   axes have absolute sum `1 + b(1−b) ≤ 5/4` each. So `|∂f/∂x| ≤ 3/2 · (5/4)² · L =
    ///   75/32 · L` and `|∇f| ≤ √3 · 75/32 · L ≈ 4.06 L`. Sound but not tight (the
    ///   maximising samples are not all 1-Lipschitz at once).
    pub fn lipschitz_factor(self) -> f32 {
        const SQRT_3: f32 = 1.732_050_8;
        match self {
            Filter::Trilinear | Filter::CubicBSpline => SQRT_3,
            Filter::CatmullRom => SQRT_3 * 75.0 / 32.0,
        }
    }

    /// Gradient at `p_grid`, in grid units.
    pub fn gradient(self, grid: &Grid, p_grid: Vec3) -> Vec3 {
        match self {
            Filter::Trilinear => trilinear_gradient(grid, p_grid),
            Filter::CubicBSpline => tricubic_bspline_gradient(grid, p_grid),
            Filter::CatmullRom => catmull_rom_gradient(grid, p_grid),
        }
    }
}

/// A [`Grid`] of samples seen through a reconstruction [`Filter`] as a [`Field`] in world
/// coordinates. Gradient and Hessian are the filter's analytic derivatives in world units.
///
/// - Outside the grid the samples are clamped to the edge, so far from the grid the value
///   is not a distance; keep queries inside [`Field::bounds`] (the grid's box by default).
/// - [`Field::lipschitz`] is [`Filter::lipschitz_factor`]: a sound bound on `|∇f|` when
///   the samples come from a 1-Lipschitz function such as a signed distance (each
///   neighbour difference along an axis at most the spacing): √3 for trilinear and
///   B-spline, about 4.06 for Catmull-Rom. Scale it for samples of an L-Lipschitz
///   function.
/// - [`Field::is_exact`] is false: a reconstruction is never the exact distance.
///
/// ```
/// use isokit_field::{filter::{Filter, SampledField}, Field, Grid};
/// use glam::Vec3;
/// // f = x on a 5³ grid of spacing 0.5 at the origin.
/// let data = (0..125).map(|n| 0.5 * (n % 5) as f32).collect();
/// let grid = Grid::from_data([5, 5, 5], Vec3::ZERO, 0.5, data).unwrap();
/// let f = SampledField::new(grid, Filter::CubicBSpline);
/// let p = Vec3::new(1.1, 1.0, 0.9);
/// assert!((f.value(p) - 1.1).abs() < 1e-5);
/// assert!((f.gradient(p) - Vec3::X).length() < 1e-5);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct SampledField {
    grid: Grid,
    filter: Filter,
    bounds: Aabb,
}

impl SampledField {
    /// A field from `grid` and `filter`, bounded by the grid's box.
    pub fn new(grid: Grid, filter: Filter) -> Self {
        let bounds = grid.bounds();
        Self {
            grid,
            filter,
            bounds,
        }
    }

    /// Replaces the bounds reported by [`Field::bounds`] (e.g. a tighter box around the
    /// surface).
    pub fn with_bounds(mut self, bounds: Aabb) -> Self {
        self.bounds = bounds;
        self
    }

    /// The samples.
    pub fn grid(&self) -> &Grid {
        &self.grid
    }

    /// Takes the samples back.
    pub fn into_grid(self) -> Grid {
        self.grid
    }

    /// The reconstruction filter.
    pub fn filter(&self) -> Filter {
        self.filter
    }

    /// Changes the reconstruction filter.
    pub fn set_filter(&mut self, filter: Filter) {
        self.filter = filter;
    }

    /// Value, gradient and Hessian at the world point `p`, in world units.
    pub fn derivatives(&self, p: Vec3) -> Derivatives {
        self.filter
            .derivatives(&self.grid, self.grid.to_grid(p))
            .to_world(self.grid.spacing())
    }
}

impl Field for SampledField {
    fn value(&self, p: Vec3) -> f32 {
        self.filter.value(&self.grid, self.grid.to_grid(p))
    }

    fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// [`Filter::lipschitz_factor`]: sound when the samples are 1-Lipschitz (see there).
    fn lipschitz(&self) -> f32 {
        self.filter.lipschitz_factor()
    }

    fn is_exact(&self) -> bool {
        false
    }

    fn gradient(&self, p: Vec3) -> Vec3 {
        let g = self.filter.gradient(&self.grid, self.grid.to_grid(p));
        (g.as_dvec3() / f64::from(self.grid.spacing())).as_vec3()
    }

    fn hessian(&self, p: Vec3) -> Mat3 {
        self.derivatives(p).hessian
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::curvature::curvature;
    use crate::rng::SplitMix64;

    /// The formulas as printed in the papers, kept to show that the checks below catch
    /// them (ERRATA 2–5).
    mod printed {
        /// 002 Eq. 5.2 as printed: `w1 = (3a³ − 3a² + 4)/6` (other weights as printed, which
        /// are right).
        pub fn bspline_weights_eq_5_2(a: f64) -> [f64; 4] {
            [
                (-a * a * a + 3.0 * a * a - 3.0 * a + 1.0) / 6.0,
                (3.0 * a * a * a - 3.0 * a * a + 4.0) / 6.0,
                (-3.0 * a * a * a + 3.0 * a * a + 3.0 * a + 1.0) / 6.0,
                a * a * a / 6.0,
            ]
        }
        /// 002 Eq. 5.9 as printed: `w1' = (3a² − 2a)/2`.
        pub fn bspline_weights_d1_eq_5_9(a: f64) -> [f64; 4] {
            [
                0.5 * (-a * a + 2.0 * a - 1.0),
                0.5 * (3.0 * a * a - 2.0 * a),
                0.5 * (-3.0 * a * a + 2.0 * a + 1.0),
                0.5 * a * a,
            ]
        }
    }

    const SWEEP: usize = 1000;

    fn sweep() -> impl Iterator<Item = f32> {
        (0..=SWEEP).map(|n| n as f32 / SWEEP as f32)
    }

    #[test]
    fn cubic_weight_sums_and_signs() {
        for a in sweep() {
            let sum = |w: [f32; 4]| w.iter().map(|&v| f64::from(v)).sum::<f64>();
            let w = bspline_weights(a);
            let d = bspline_weights_d1(a);
            let dd = bspline_weights_d2(a);
            assert!((sum(w) - 1.0).abs() < 1e-6, "a={a} {w:?}");
            assert!(sum(d).abs() < 1e-6, "a={a} {d:?}");
            assert!(sum(dd).abs() < 1e-6, "a={a} {dd:?}");
            assert!(w.iter().all(|&v| v >= 0.0), "a={a} {w:?}");
            assert!(d[0] <= 0.0 && d[1] <= 0.0, "a={a} {d:?}");
            assert!(d[2] >= 0.0 && d[3] >= 0.0, "a={a} {d:?}");
            let c = catmull_rom_weights(a);
            assert!((sum(c) - 1.0).abs() < 1e-6, "a={a} {c:?}");
            assert!(sum(catmull_rom_weights_d1(a)).abs() < 1e-6);
            assert!(sum(catmull_rom_weights_d2(a)).abs() < 1e-6);
            // f32 weights equal the f64 ones used by the direct convolution.
            let a64 = f64::from(a);
            for (x, y) in [
                (w, bspline_w64(a64)),
                (d, bspline_d1_64(a64)),
                (dd, bspline_d2_64(a64)),
                (c, catmull_rom_w64(a64)),
                (catmull_rom_weights_d1(a), catmull_rom_d1_64(a64)),
                (catmull_rom_weights_d2(a), catmull_rom_d2_64(a64)),
            ] {
                for i in 0..4 {
                    assert!((f64::from(x[i]) - y[i]).abs() < 1e-6);
                }
            }
            // The derivative two-fetch: g1 = −g0, offsets inside the cells.
            let f = TwoFetch::bspline_d1(a);
            assert!((f.g0 + f.g1).abs() < 1e-6 && f.g0 <= -0.5 + 1e-6);
            let v = TwoFetch::bspline(a);
            assert!((v.g0 + v.g1 - 1.0).abs() < 1e-6 && v.g0 >= 1.0 / 6.0 - 1e-6);
            for t in [f.t0, f.t1, v.t0, v.t1] {
                assert!((0.0..=1.0).contains(&t), "a={a} {f:?} {v:?}");
            }
        }
        // Moments: the B-spline reproduces linear functions, Catmull-Rom quadratics.
        for a in sweep().map(f64::from) {
            let x = [-1.0 - a, -a, 1.0 - a, 2.0 - a];
            let m1 = |w: [f64; 4]| (0..4).map(|i| w[i] * x[i]).sum::<f64>();
            let m2 = |w: [f64; 4]| (0..4).map(|i| w[i] * x[i] * x[i]).sum::<f64>();
            assert!(m1(bspline_w64(a)).abs() < 1e-12);
            assert!((m2(bspline_w64(a)) - 1.0 / 3.0).abs() < 1e-12); // smoothing h²/3
            assert!(m1(catmull_rom_w64(a)).abs() < 1e-12);
            assert!(m2(catmull_rom_w64(a)).abs() < 1e-12);
        }
    }

    /// Derivative weights are the derivatives of the weights (checked by central
    /// differences, not by trust in a printed formula).
    #[test]
    fn derivative_weights_match_finite_differences() {
        let h = 1e-5;
        for a in sweep().map(f64::from) {
            let a = a.clamp(h, 1.0 - h);
            type W = fn(f64) -> [f64; 4];
            let pairs: [(W, W); 4] = [
                (bspline_w64, bspline_d1_64),
                (bspline_d1_64, bspline_d2_64),
                (catmull_rom_w64, catmull_rom_d1_64),
                (catmull_rom_d1_64, catmull_rom_d2_64),
            ];
            for (f, df) in pairs {
                let (p, m, d) = (f(a + h), f(a - h), df(a));
                for i in 0..4 {
                    let fd = (p[i] - m[i]) / (2.0 * h);
                    assert!((fd - d[i]).abs() < 1e-6, "a={a} i={i} {fd} vs {}", d[i]);
                }
            }
        }
    }

    #[test]
    fn printed_w1_of_eq_5_2_is_not_a_partition_of_unity() {
        let worst = |w: fn(f64) -> [f64; 4]| {
            sweep()
                .map(|a| (w(f64::from(a)).iter().sum::<f64>() - 1.0).abs())
                .fold(0.0, f64::max)
        };
        assert!(worst(bspline_w64) < 1e-12);
        let printed = worst(printed::bspline_weights_eq_5_2);
        assert!(printed > 0.4, "printed Eq. 5.2 sums to 1 + a²/2: {printed}");
    }

    #[test]
    fn printed_w1_prime_of_eq_5_9_does_not_sum_to_zero() {
        let worst = |w: fn(f64) -> [f64; 4]| {
            sweep()
                .map(|a| w(f64::from(a)).iter().sum::<f64>().abs())
                .fold(0.0, f64::max)
        };
        assert!(worst(bspline_d1_64) < 1e-12);
        let printed = worst(printed::bspline_weights_d1_eq_5_9);
        assert!(printed > 0.9, "printed Eq. 5.9 sums to a: {printed}");
        // And it is not the derivative of the (corrected) w1.
        let (a, h) = (0.5, 1e-6);
        let fd = (bspline_w64(a + h)[1] - bspline_w64(a - h)[1]) / (2.0 * h);
        assert!((fd - bspline_d1_64(a)[1]).abs() < 1e-6);
        assert!((fd - printed::bspline_weights_d1_eq_5_9(a)[1]).abs() > 0.1);
    }

    // ----- 1D and 2D twins of the fast scheme (test helpers) -----

    fn random_data(n: usize, seed: u64) -> Vec<f32> {
        let mut rng = SplitMix64::new(seed);
        (0..n).map(|_| rng.range(-1.0, 1.0)).collect()
    }

    /// Linear fetch in cell `c` at `t`, clamp-to-edge.
    fn fetch1(data: &[f32], c: i32, t: f32) -> f32 {
        let s = |i: i32| data[i.clamp(0, data.len() as i32 - 1) as usize];
        lerp(s(c), s(c + 1), t)
    }

    fn taps1(data: &[f32], x: f32, w: fn(f64) -> [f64; 4]) -> f64 {
        let i = x.floor();
        let a = f64::from(x) - f64::from(i);
        let w = w(a);
        let s = |k: i32| f64::from(data[k.clamp(0, data.len() as i32 - 1) as usize]);
        (0..4).map(|k| w[k] * s(i as i32 - 1 + k as i32)).sum()
    }

    #[derive(Clone, Copy, PartialEq)]
    enum Variant {
        Corrected,
        /// 001 Sec. 2.1: `h1 = 1 − w3/(w2 + w3) − x`, i.e. the second fetch lands at
        /// `i + 1 − t1` instead of `i + 1 + t1`.
        PrintedH1,
        /// Listing 5.1: `lerp(tex_source0, tex_source1, g0)`.
        PrintedLerp,
    }

    /// Two linear fetches for the 1D B-spline value.
    fn two_fetch_1d(data: &[f32], x: f32, v: Variant) -> f32 {
        let i = x.floor();
        let f = TwoFetch::bspline(x - i);
        let i = i as i32;
        let f0 = fetch1(data, i - 1, f.t0);
        let f1 = match v {
            Variant::PrintedH1 => fetch1(data, i, 1.0 - f.t1),
            _ => fetch1(data, i + 1, f.t1),
        };
        match v {
            Variant::PrintedLerp => lerp(f0, f1, f.g0),
            _ => lerp(f0, f1, f.g1),
        }
    }

    /// Any 1D scheme through the shared axis taps.
    fn fetch_sum_1d(data: &[f32], c: i32, x: &Taps) -> f32 {
        (0..x.n)
            .map(|i| x.w[i] * fetch1(data, c + x.cell[i], x.t[i]))
            .sum()
    }

    fn max_abs(data: &[f32]) -> f64 {
        data.iter().map(|v| f64::from(v.abs())).fold(0.0, f64::max)
    }

    fn worst_1d(data: &[f32], scheme: impl Fn(f32) -> f32, reference: impl Fn(f32) -> f64) -> f64 {
        let mut rng = SplitMix64::new(3);
        let n = data.len() as f32;
        (0..5000)
            .map(|_| {
                let x = rng.range(-2.5, n + 1.5);
                (f64::from(scheme(x)) - reference(x)).abs()
            })
            .fold(0.0, f64::max)
            / max_abs(data)
    }

    #[test]
    fn two_fetch_1d_equals_four_taps() {
        let data = random_data(17, 21);
        let value = worst_1d(
            &data,
            |x| two_fetch_1d(&data, x, Variant::Corrected),
            |x| taps1(&data, x, bspline_w64),
        );
        let d1 = worst_1d(
            &data,
            |x| {
                let i = x.floor();
                fetch_sum_1d(&data, i as i32, &Taps::two(TwoFetch::bspline_d1(x - i)))
            },
            |x| taps1(&data, x, bspline_d1_64),
        );
        let d2 = worst_1d(
            &data,
            |x| {
                let i = x.floor();
                fetch_sum_1d(&data, i as i32, &Taps::three(x - i))
            },
            |x| taps1(&data, x, bspline_d2_64),
        );
        eprintln!(
            "1D 2-fetch vs 4-tap, max error / max|f|: value {value:.2e}, d1 {d1:.2e}, d2 {d2:.2e}"
        );
        assert!(value < 1e-6 && d1 < 1e-6 && d2 < 1e-6);
        // The shared taps give the same value as the explicit lerp form.
        for x in [0.3f32, 5.5, 9.99, -1.2] {
            let i = x.floor();
            let a = fetch_sum_1d(&data, i as i32, &Taps::two(TwoFetch::bspline(x - i)));
            assert!((a - two_fetch_1d(&data, x, Variant::Corrected)).abs() < 1e-6);
        }
    }

    #[test]
    fn printed_h1_of_001_breaks_the_two_fetch_identity() {
        let data = random_data(17, 22);
        let err = worst_1d(
            &data,
            |x| two_fetch_1d(&data, x, Variant::PrintedH1),
            |x| taps1(&data, x, bspline_w64),
        );
        eprintln!("printed h1 (001): max error / max|f| = {err:.3}");
        assert!(err > 0.05, "{err}");
    }

    #[test]
    fn printed_lerp_weight_of_listing_5_1_breaks_the_two_fetch_identity() {
        let data = random_data(17, 23);
        let err = worst_1d(
            &data,
            |x| two_fetch_1d(&data, x, Variant::PrintedLerp),
            |x| taps1(&data, x, bspline_w64),
        );
        eprintln!("printed lerp weight g0 (Listing 5.1): max error / max|f| = {err:.3}");
        assert!(err > 0.05, "{err}");
    }

    /// 2D: four bilinear fetches against the 16-tap sum, for value, gradient and Hessian.
    #[test]
    fn four_fetch_2d_equals_sixteen_taps() {
        let (nx, ny) = (9usize, 7usize);
        let data = random_data(nx * ny, 31);
        let s = |i: i32, j: i32| {
            let i = i.clamp(0, nx as i32 - 1) as usize;
            let j = j.clamp(0, ny as i32 - 1) as usize;
            data[i + nx * j]
        };
        let fetch2 = |ci: i32, cj: i32, tx: f32, ty: f32| {
            lerp(
                lerp(s(ci, cj), s(ci + 1, cj), tx),
                lerp(s(ci, cj + 1), s(ci + 1, cj + 1), tx),
                ty,
            )
        };
        let fast = |c: (i32, i32), x: &Taps, y: &Taps| {
            let mut sx = 0.0f32;
            for ix in 0..x.n {
                let mut sy = 0.0f32;
                for iy in 0..y.n {
                    sy += y.w[iy] * fetch2(c.0 + x.cell[ix], c.1 + y.cell[iy], x.t[ix], y.t[iy]);
                }
                sx += x.w[ix] * sy;
            }
            sx
        };
        let taps = |c: (i32, i32), wx: [f64; 4], wy: [f64; 4]| {
            let mut acc = 0.0;
            for (j, wyj) in (c.1 - 1..).zip(wy) {
                for (i, wxi) in (c.0 - 1..).zip(wx) {
                    acc += wxi * wyj * f64::from(s(i, j));
                }
            }
            acc
        };
        let mut rng = SplitMix64::new(32);
        let mut worst = [0.0f64; 6];
        for _ in 0..3000 {
            let p = [
                rng.range(-2.0, nx as f32 + 1.0),
                rng.range(-2.0, ny as f32 + 1.0),
            ];
            let f = p.map(f32::floor);
            let c = (f[0] as i32, f[1] as i32);
            let a = [p[0] - f[0], p[1] - f[1]];
            let b = a.map(|a| Taps::two(TwoFetch::bspline(a)));
            let d = a.map(|a| Taps::two(TwoFetch::bspline_d1(a)));
            let sd = a.map(Taps::three);
            let a64 = a.map(f64::from);
            let (w, dw, ddw) = (
                a64.map(bspline_w64),
                a64.map(bspline_d1_64),
                a64.map(bspline_d2_64),
            );
            let pairs = [
                (fast(c, &b[0], &b[1]), taps(c, w[0], w[1])),
                (fast(c, &d[0], &b[1]), taps(c, dw[0], w[1])),
                (fast(c, &b[0], &d[1]), taps(c, w[0], dw[1])),
                (fast(c, &sd[0], &b[1]), taps(c, ddw[0], w[1])),
                (fast(c, &b[0], &sd[1]), taps(c, w[0], ddw[1])),
                (fast(c, &d[0], &d[1]), taps(c, dw[0], dw[1])),
            ];
            for (k, (x, y)) in pairs.iter().enumerate() {
                worst[k] = worst[k].max((f64::from(*x) - y).abs() / max_abs(&data));
            }
        }
        eprintln!("2D 4-fetch vs 16-tap, max error / max|f| [f fx fy fxx fyy fxy]: {worst:?}");
        assert!(worst.iter().all(|&e| e < 1e-6), "{worst:?}");
    }

    fn random_grid(dims: [usize; 3], seed: u64) -> Grid {
        let data = random_data(dims.iter().product(), seed);
        Grid::from_data(dims, Vec3::new(0.5, -1.0, 2.0), 0.3, data).unwrap()
    }

    /// 3D: the fast scheme (8 fetches, 12 for pure second derivatives) against the direct
    /// 64-tap convolution, inside, near and outside the border.
    #[test]
    fn eight_fetch_3d_equals_sixty_four_taps() {
        let grid = random_grid([7, 8, 9], 41);
        let scale = max_abs(grid.data());
        let mut rng = SplitMix64::new(42);
        let (mut ev, mut eg, mut eh) = (0.0f64, 0.0f64, 0.0f64);
        let lo = Vec3::splat(-2.0);
        let hi = Vec3::new(8.0, 9.0, 10.0);
        for _ in 0..3000 {
            let p = rng.point_in(lo, hi);
            let d = tricubic_bspline_derivatives(&grid, p);
            let f = tricubic_bspline_derivatives_fast(&grid, p);
            // Reference in f64 straight from the 64-tap sums.
            let v64 = BSPLINE.value(&grid, p);
            let g64 = BSPLINE.gradient(&grid, p);
            ev = ev.max((f64::from(f.value) - v64).abs());
            eg = eg.max((f.gradient.as_dvec3() - g64).abs().max_element());
            let dh = (f.hessian.as_dmat3() - d.hessian.as_dmat3()).to_cols_array();
            eh = eh.max(dh.iter().fold(0.0, |m, v| m.max(v.abs())));
            // The single-purpose functions agree with the combined ones.
            assert_eq!(tricubic_bspline_fast(&grid, p), f.value);
            assert_eq!(tricubic_bspline_gradient_fast(&grid, p), f.gradient);
            assert_eq!(tricubic_bspline_hessian_fast(&grid, p), f.hessian);
            assert_eq!(tricubic_bspline(&grid, p), d.value);
            assert_eq!(tricubic_bspline_gradient(&grid, p), d.gradient);
            assert_eq!(tricubic_bspline_hessian(&grid, p), d.hessian);
        }
        let (ev, eg, eh) = (ev / scale, eg / scale, eh / scale);
        eprintln!(
            "3D 8-fetch vs 64-tap, max error / max|f|: value {ev:.2e}, gradient {eg:.2e}, Hessian {eh:.2e}"
        );
        assert!(ev < 1e-6 && eg < 1e-6 && eh < 1e-6);
    }

    /// Direct derivatives against central differences of the direct value (f64 inside).
    #[test]
    fn direct_derivatives_match_finite_differences() {
        let grid = random_grid([6, 7, 8], 51);
        let mut rng = SplitMix64::new(52);
        let h = 1.0 / 1024.0;
        for _ in 0..300 {
            // Stay away from cell faces so the one-sided pieces of C0/C1 filters do not mix.
            let c = rng
                .point_in(Vec3::splat(-1.0), Vec3::new(6.0, 7.0, 8.0))
                .floor();
            let p = c + rng.point_in(Vec3::splat(0.05), Vec3::splat(0.95));
            let e = [Vec3::X, Vec3::Y, Vec3::Z];
            let check = |name: &str, value: &dyn Fn(Vec3) -> f64, d: Derivatives| {
                let fd: [f64; 3] =
                    e.map(|e| (value(p + e * h) - value(p - e * h)) / (2.0 * f64::from(h)));
                let g = d.gradient.as_dvec3().to_array();
                for i in 0..3 {
                    assert!((fd[i] - g[i]).abs() < 1e-4, "{name} grad {fd:?} {g:?}");
                }
            };
            check(
                "bspline",
                &|q| BSPLINE.value(&grid, q),
                tricubic_bspline_derivatives(&grid, p),
            );
            check(
                "catmull-rom",
                &|q| CATMULL_ROM.value(&grid, q),
                catmull_rom_derivatives(&grid, p),
            );
            check(
                "trilinear",
                &|q| LINEAR.value(&grid, q),
                trilinear_derivatives(&grid, p),
            );
            // Hessians as differences of the f64 gradients.
            let bs = |q: Vec3| BSPLINE.gradient(&grid, q);
            let cr = |q: Vec3| CATMULL_ROM.gradient(&grid, q);
            let li = |q: Vec3| LINEAR.gradient(&grid, q);
            type Case<'a> = (&'a str, &'a dyn Fn(Vec3) -> DVec3, Mat3);
            let cases: [Case; 3] = [
                ("bspline", &bs, tricubic_bspline_hessian(&grid, p)),
                (
                    "catmull-rom",
                    &cr,
                    catmull_rom_derivatives(&grid, p).hessian,
                ),
                ("trilinear", &li, trilinear_derivatives(&grid, p).hessian),
            ];
            for (name, grad, hess) in cases {
                for (i, e) in e.iter().enumerate() {
                    let fd = (grad(p + *e * h) - grad(p - *e * h)) / (2.0 * f64::from(h));
                    let col = hess.col(i).as_dvec3();
                    assert!(
                        (fd - col).abs().max_element() < 1e-4,
                        "{name} H col {i}: {fd} vs {col}"
                    );
                }
            }
            // Trilinear value through the emulated fetch equals the f64 kernel.
            assert!((f64::from(trilinear(&grid, p)) - LINEAR.value(&grid, p)).abs() < 1e-6);
        }
    }

    /// f = a·p + c: trilinear and B-spline (both schemes) and Catmull-Rom reproduce it in
    /// the interior; Hessian ~0.
    #[test]
    fn linear_fields_are_reproduced_in_the_interior() {
        let (a, c0) = (Vec3::new(0.3, -0.7, 0.45), 0.2f32);
        let dims = [12usize, 10, 11];
        let (origin, spacing) = (Vec3::new(-1.0, 0.5, 2.0), 0.25f32);
        let mut grid = Grid::new(dims, origin, spacing).unwrap();
        for k in 0..dims[2] {
            for j in 0..dims[1] {
                for i in 0..dims[0] {
                    let p = grid.position(i, j, k).as_dvec3();
                    grid.set(i, j, k, (a.as_dvec3().dot(p) + f64::from(c0)) as f32);
                }
            }
        }
        let mut rng = SplitMix64::new(61);
        let exact = |p: Vec3| (a.as_dvec3().dot(p.as_dvec3()) + f64::from(c0)) as f32;
        let lo = Vec3::ONE;
        let hi = Vec3::new(
            dims[0] as f32 - 2.0,
            dims[1] as f32 - 2.0,
            dims[2] as f32 - 2.0,
        );
        let fields = [Filter::Trilinear, Filter::CubicBSpline, Filter::CatmullRom]
            .map(|f| SampledField::new(grid.clone(), f));
        for _ in 0..500 {
            let q = rng.point_in(lo, hi - Vec3::splat(1e-3));
            let p = origin + q * spacing;
            let want = exact(p);
            for d in [
                trilinear_derivatives(&grid, q).to_world(spacing),
                tricubic_bspline_derivatives_world(&grid, p),
                tricubic_bspline_derivatives_fast_world(&grid, p),
                catmull_rom_derivatives(&grid, q).to_world(spacing),
            ] {
                assert!((d.value - want).abs() < 1e-5, "{} vs {want}", d.value);
                assert!(
                    (d.gradient - a).abs().max_element() < 1e-4,
                    "{} vs {a}",
                    d.gradient
                );
                let h = d.hessian.to_cols_array();
                assert!(h.iter().all(|v| v.abs() < 1e-3), "{:?}", d.hessian);
            }
            assert!((trilinear(&grid, q) - want).abs() < 1e-5);
            for f in &fields {
                assert!((f.value(p) - want).abs() < 1e-5);
                assert!((f.gradient(p) - a).abs().max_element() < 1e-4);
                assert!(f.hessian(p).to_cols_array().iter().all(|v| v.abs() < 1e-3));
            }
        }
        // The clamped border breaks linearity: just outside the grid the value is flat.
        let d = tricubic_bspline_derivatives(&grid, Vec3::new(-1.5, 4.0, 4.0));
        assert!(d.gradient.x.abs() < 1e-5);
    }

    #[test]
    fn bspline_approximates_catmull_rom_and_trilinear_interpolate() {
        let grid = random_grid([5, 5, 5], 71);
        let mut worst_bspline = 0.0f32;
        for ([i, j, k], v) in grid.iter() {
            let q = Vec3::new(i as f32, j as f32, k as f32);
            assert!((trilinear(&grid, q) - v).abs() < 1e-6);
            assert!((catmull_rom(&grid, q) - v).abs() < 1e-6);
            worst_bspline = worst_bspline.max((tricubic_bspline(&grid, q) - v).abs());
        }
        assert!(
            worst_bspline > 0.1,
            "the B-spline smooths random data: {worst_bspline}"
        );
        // 1D check of the node value (f[i-1] + 4 f[i] + f[i+1]) / 6 on data varying in x only.
        let data: Vec<f32> = (0..27).map(|n| [0.0, 6.0, 0.0][n % 3]).collect();
        let g = Grid::from_data([3, 3, 3], Vec3::ZERO, 1.0, data).unwrap();
        assert!((tricubic_bspline(&g, Vec3::ONE) - 4.0).abs() < 1e-6);
        assert!((tricubic_bspline_fast(&g, Vec3::ONE) - 4.0).abs() < 1e-6);
    }

    #[test]
    fn far_and_non_finite_coordinates_do_not_panic() {
        let grid = random_grid([4, 3, 5], 81);
        let corner = grid.get(0, 0, 0);
        for q in [Vec3::splat(-1e30), Vec3::splat(-1e6), Vec3::splat(-3.5)] {
            assert_eq!(trilinear(&grid, q), corner);
            assert!((tricubic_bspline(&grid, q) - corner).abs() < 1e-6);
            assert!((tricubic_bspline_fast(&grid, q) - corner).abs() < 1e-6);
            assert!(tricubic_bspline_gradient(&grid, q).abs().max_element() < 1e-6);
            assert!(tricubic_bspline_gradient_fast(&grid, q).abs().max_element() < 1e-6);
        }
        let far = grid.get(3, 2, 4);
        for q in [
            Vec3::splat(1e30),
            Vec3::splat(7e5),
            Vec3::new(4.5, 3.5, 6.5),
        ] {
            assert_eq!(trilinear(&grid, q), far);
            assert!((catmull_rom(&grid, q) - far).abs() < 1e-6);
            assert!((tricubic_bspline_fast(&grid, q) - far).abs() < 1e-6);
        }
        for q in [Vec3::splat(f32::NAN), Vec3::new(f32::INFINITY, 0.0, 0.0)] {
            assert!(trilinear(&grid, q).is_nan());
            assert!(tricubic_bspline(&grid, q).is_nan());
            assert!(tricubic_bspline_derivatives_fast(&grid, q).value.is_nan());
            let _ = catmull_rom_derivatives(&grid, q);
        }
    }

    #[test]
    fn sampled_field_reports_bounds_units_and_exactness() {
        let grid = random_grid([6, 6, 6], 91);
        let f = SampledField::new(grid.clone(), Filter::CubicBSpline);
        assert_eq!(f.bounds(), grid.bounds());
        assert!(!f.is_exact());
        assert_eq!(f.lipschitz(), 3f32.sqrt());
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        assert_eq!(f.clone().with_bounds(b).bounds(), b);
        let p = grid.position(2, 3, 2) + Vec3::splat(0.1);
        let q = grid.to_grid(p);
        let s = grid.spacing();
        for filter in [Filter::Trilinear, Filter::CubicBSpline, Filter::CatmullRom] {
            let mut f = f.clone();
            f.set_filter(filter);
            assert_eq!(f.filter(), filter);
            let d = filter.derivatives(&grid, q);
            assert_eq!(f.value(p), filter.value(&grid, q));
            assert!((f.gradient(p) - d.gradient / s).length() < 1e-4);
            let want = d.hessian * (1.0 / (s * s));
            assert!(
                (f.hessian(p) - want)
                    .to_cols_array()
                    .iter()
                    .all(|v| v.abs() < 1e-3)
            );
            assert_eq!(f.derivatives(p), d.to_world(s));
        }
        assert_eq!(f.into_grid(), grid);
    }

    /// A sampled box SDF (1-Lipschitz samples) near a corner, where the distance is a cone
    /// around the corner point: random short pairs of points never change by more than
    /// `lipschitz() · |p − q|`. Trilinear reaches about √3 there (a bound of 1 was wrong).
    #[test]
    fn sampled_field_lipschitz_bound_holds_near_a_box_corner() {
        let h = 0.1f32;
        let n = 21usize;
        let origin = Vec3::splat(-1.0);
        let corner = DVec3::splat(0.5); // at sample (15, 15, 15)
        let mut data = Vec::with_capacity(n * n * n);
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let p = (origin + h * Vec3::new(i as f32, j as f32, k as f32)).as_dvec3();
                    let q = p.abs() - corner;
                    let d = q.max(DVec3::ZERO).length() + q.max_element().min(0.0);
                    data.push(d as f32);
                }
            }
        }
        let grid = Grid::from_data([n; 3], origin, h, data).unwrap();
        let c = corner.as_vec3();
        for filter in [Filter::Trilinear, Filter::CubicBSpline, Filter::CatmullRom] {
            let f = SampledField::new(grid.clone(), filter);
            let lip = f.lipschitz();
            let mut rng = SplitMix64::new(7);
            let mut worst = 0.0f32;
            let mut check = |p: Vec3, q: Vec3| {
                let (dv, dp) = ((f.value(p) - f.value(q)).abs(), p.distance(q));
                worst = worst.max(dv / dp);
                // 1e-5: f32 rounding of values of about 1 and of the points.
                assert!(
                    dv <= lip * dp + 1e-5,
                    "{filter:?}: {dv} > {lip} * {dp} at {p}, {q}"
                );
            };
            // Along the diagonal out of the corner: the steepest direction of the cone.
            for s in 1..40 {
                let t = s as f32 * 0.002;
                check(c + Vec3::splat(t), c + Vec3::splat(t + 0.001));
            }
            for _ in 0..20_000 {
                let p = rng.point_in(c - Vec3::splat(0.3), c + Vec3::splat(0.3));
                let q = p + rng.unit_vector() * rng.range(0.005, 0.1);
                check(p, q);
            }
            eprintln!(
                "{filter:?} near a box corner: max |f(p) - f(q)| / |p - q| = {worst:.4} (bound {lip:.4})"
            );
            if filter == Filter::Trilinear {
                assert!(
                    worst > 1.5,
                    "the corner cone should show about sqrt 3, got {worst}"
                );
            }
        }
    }

    /// Sphere SDF of radius 0.8 in [-1, 1]³ at 64³: B-spline normals within 0.5° and
    /// principal curvatures within 2% of 1/0.8, by both schemes.
    #[test]
    fn sampled_sphere_normals_and_curvature() {
        let n = 64usize;
        let spacing = 2.0 / 63.0;
        let radius = 0.8f64;
        let mut data = Vec::with_capacity(n * n * n);
        for k in 0..n {
            for j in 0..n {
                for i in 0..n {
                    let p = DVec3::new(i as f64, j as f64, k as f64) * (2.0 / 63.0) - DVec3::ONE;
                    data.push((p.length() - radius) as f32);
                }
            }
        }
        let grid = Grid::from_data([n; 3], Vec3::splat(-1.0), spacing as f32, data).unwrap();
        let mut rng = SplitMix64::new(101);
        let k_true = 1.0 / radius;
        type Scheme = fn(&Grid, Vec3) -> Derivatives;
        let schemes: [(&str, Scheme); 2] = [
            ("direct 64-tap", tricubic_bspline_derivatives_world),
            ("fast 8-fetch", tricubic_bspline_derivatives_fast_world),
        ];
        let dirs: Vec<Vec3> = (0..2000).map(|_| rng.unit_vector()).collect();
        for (name, scheme) in schemes {
            let (mut worst_angle, mut worst_k, mut worst_value) = (0.0f64, 0.0f64, 0.0f64);
            for dir in &dirs {
                let p = *dir * radius as f32;
                let d = scheme(&grid, p);
                let n_true = p.as_dvec3().normalize();
                let cos = d
                    .gradient
                    .as_dvec3()
                    .normalize()
                    .dot(n_true)
                    .clamp(-1.0, 1.0);
                worst_angle = worst_angle.max(cos.acos().to_degrees());
                let c = curvature(d.gradient, d.hessian).expect("sphere gradient is not flat");
                for k in [c.k1, c.k2] {
                    worst_k = worst_k.max((f64::from(k) - k_true).abs() / k_true);
                }
                worst_value = worst_value.max(f64::from(d.value.abs()));
            }
            eprintln!(
                "sphere r=0.8 at 64^3, tricubic B-spline {name}: max normal angle error {worst_angle:.2e} deg, \
                 max curvature error {:.3}% of 1/0.8, max |value| on the sphere {worst_value:.2e}",
                100.0 * worst_k
            );
            assert!(worst_angle < 0.5, "{name}: {worst_angle} deg");
            assert!(worst_k < 0.02, "{name}: {worst_k}");
        }
    }
}
