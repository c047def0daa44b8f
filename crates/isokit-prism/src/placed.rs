//! Prisms placed on a grid: the record the CPU twin and the WGSL kernel share (`Prism` in
//! `shaders/common/prism.wgsl`), in grid units relative to an anchor lattice point so that
//! f32 keeps its precision at any grid size.

use crate::build::WorldPrism;
use bytemuck::{Pod, Zeroable};
use glam::{DMat3, DVec3};

/// Grid geometry: node-centered, sample `(i, j, k)` at `origin + spacing * (i, j, k)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridGeometry {
    /// Samples along x, y, z.
    pub dims: [usize; 3],
    /// Position of sample (0, 0, 0).
    pub origin: glam::Vec3,
    /// Distance between neighbouring samples.
    pub spacing: f32,
}

/// Outward margin of every plane, in grid units: samples within it of a plane shared by
/// two prisms are scanned by both, so f32 rounding never drops one between them.
pub const PLANE_MARGIN: f64 = 1e-3;

/// One prism on the grid (`#[repr(C)]`, 320 bytes; its WGSL twin is `struct Prism`).
///
/// Coordinates are grid units relative to the lattice point `base`: a sample `q = (i, j, k)`
/// is inside when `plane.xyz · (q − base) ≥ plane.w` for the five planes, and its local
/// coordinates are `(axis_r, axis_s, axis_t) · (q − base − frac)`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuPrism {
    /// Three sides then the two caps: normal (xyz) and offset (w).
    pub planes: [[f32; 4]; 5],
    /// Anchor lattice point (xyz) and the triangle's index (w).
    pub base: [i32; 4],
    /// Local origin minus `base` (xyz), grid units.
    pub frac: [f32; 4],
    /// Local `r` axis (unit).
    pub axis_r: [f32; 4],
    /// Local `s` axis (unit).
    pub axis_s: [f32; 4],
    /// Local `t` axis (unit, the face normal).
    pub axis_t: [f32; 4],
    /// `a`, `b`, `h` of the triangle in grid units (xyz).
    pub shape: [f32; 4],
    /// `1 / (a² + h²)`, `1 / (b² + h²)` (xy; 0 when the side has no length).
    pub inv: [f32; 4],
    /// Pseudonormals of AB, BC, CA, A, B, C in the local frame (zero: unsigned).
    pub normals: [[f32; 4]; 6],
    /// First sample of the bounding box (xyz, inclusive).
    pub lo: [i32; 4],
    /// Last sample of the bounding box (xyz, inclusive); below `lo` on an axis when the
    /// prism misses the grid.
    pub hi: [i32; 4],
}

// The WGSL twin, member by member (`Prism` in `shaders/common/prism.wgsl`; checked by the
// GPU host code's unit tests).
isokit_gpu::wgsl_layout!(GpuPrism as "Prism" {
    planes: "array<vec4<f32>, 5>",
    base: "vec4<i32>",
    frac: "vec4<f32>",
    axis_r: "vec4<f32>",
    axis_s: "vec4<f32>",
    axis_t: "vec4<f32>",
    shape: "vec4<f32>",
    inv: "vec4<f32>",
    normals: "array<vec4<f32>, 6>",
    lo: "vec4<i32>",
    hi: "vec4<i32>",
});

impl GpuPrism {
    /// Whether the prism touches slices `k0..=k1`.
    pub fn spans(&self, k0: i32, k1: i32) -> bool {
        self.lo[2] <= k1 && self.hi[2] >= k0 && self.lo[0] <= self.hi[0] && self.lo[1] <= self.hi[1]
    }
}

fn v4(v: DVec3, w: f64) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w as f32]
}

/// Places a world prism on the grid.
pub(crate) fn place(p: &WorldPrism, triangle: u32, g: &GridGeometry) -> GpuPrism {
    let h = g.spacing as f64;
    let o = g.origin.as_dvec3();
    let f = &p.frame;
    let to_grid = |x: DVec3| (x - o) / h;
    let origin_g = to_grid(f.origin);
    let base = origin_g.round();
    let base_w = o + base * h;
    let frac = origin_g - base;
    // Planes: n·(x − anchor) ≥ −shift with x = base_w + h·q' ⇔ n·q' ≥ (n·(anchor − base_w) − shift)/h.
    let mut planes = [[0.0f32; 4]; 5];
    let mut planes64 = [(DVec3::ZERO, 0.0f64); 5];
    for (k, pl) in p.planes.iter().enumerate() {
        let c = if pl.normal == DVec3::ZERO {
            -1.0
        } else {
            (pl.normal.dot(pl.anchor - base_w) - pl.shift) / h - PLANE_MARGIN
        };
        planes64[k] = (pl.normal, c);
        planes[k] = v4(pl.normal, c);
    }
    // Bounding box: the band box of the triangle, tightened by the polytope's corners.
    let mut lo = to_grid(p.lo) - base;
    let mut hi = to_grid(p.hi) - base;
    if !p.degenerate
        && let Some((plo, phi)) = polytope_box(&planes64)
    {
        lo = lo.max(plo);
        hi = hi.min(phi);
    }
    let dims = g.dims.map(|d| d as i64 - 1);
    let clamp = |x: f64, a: usize| -> i32 {
        if x.is_nan() {
            return 0;
        }
        x.clamp(-1.0, dims[a] as f64 + 1.0) as i32
    };
    let base_i = [base.x as i64, base.y as i64, base.z as i64];
    let mut lo_i = [0i32; 4];
    let mut hi_i = [-1i32; 4];
    if !p.empty {
        for a in 0..3 {
            let l = (lo[a] - 1e-6).ceil() + base_i[a] as f64;
            let u = (hi[a] + 1e-6).floor() + base_i[a] as f64;
            lo_i[a] = clamp(l, a).max(0);
            hi_i[a] = clamp(u, a).min(dims[a] as i32);
        }
    }
    let inv = crate::local::inverses((f.a / h) as f32, (f.b / h) as f32, (f.h / h) as f32);
    let local = DMat3::from_cols(f.r, f.s, f.t).transpose();
    let normals = p.normals.map(|n| v4(local * n, 0.0));
    GpuPrism {
        planes,
        base: [
            base_i[0] as i32,
            base_i[1] as i32,
            base_i[2] as i32,
            triangle as i32,
        ],
        frac: v4(frac, 0.0),
        axis_r: v4(f.r, 0.0),
        axis_s: v4(f.s, 0.0),
        axis_t: v4(f.t, 0.0),
        shape: [(f.a / h) as f32, (f.b / h) as f32, (f.h / h) as f32, 0.0],
        inv: [inv.0, inv.1, 0.0, 0.0],
        normals,
        lo: lo_i,
        hi: hi_i,
    }
}

/// Bounding box of `{q : n·q ≥ c}` over the five planes, from its corners (every triple of
/// planes), or `None` when no corner exists (unbounded or degenerate).
fn polytope_box(planes: &[(DVec3, f64); 5]) -> Option<(DVec3, DVec3)> {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let mut any = false;
    for x in 0..5 {
        for y in x + 1..5 {
            for z in y + 1..5 {
                let m = DMat3::from_cols(planes[x].0, planes[y].0, planes[z].0).transpose();
                let det = m.determinant();
                if det.abs() < 1e-12 {
                    continue;
                }
                let q = m.inverse() * DVec3::new(planes[x].1, planes[y].1, planes[z].1);
                let scale = 1.0 + q.abs().max_element();
                if planes.iter().all(|(n, c)| n.dot(q) >= c - 1e-9 * scale) {
                    lo = lo.min(q);
                    hi = hi.max(q);
                    any = true;
                }
            }
        }
    }
    any.then_some((lo, hi))
}
