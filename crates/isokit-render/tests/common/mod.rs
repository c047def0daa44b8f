//! Scenes and cameras shared by the render tests, and the two backends of their conformance
//! suites ([`twin`]).
// Each test binary uses a different subset.
#![allow(dead_code)]

pub mod twin;

use glam::Vec3;
use isokit_field::{Camera, Grid, Projection};
use isokit_render::{Layout, Volume};

/// Radius of [`sphere_grid`]'s sphere.
pub const R: f32 = 0.7;

/// A grid of `n³` samples over `[-1, 1]³` holding `f`.
pub fn grid_of(n: usize, f: impl Fn(Vec3) -> f32) -> Grid {
    let h = 2.0 / (n - 1) as f32;
    let mut g = Grid::new([n; 3], Vec3::splat(-1.0), h).unwrap();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let p = g.position(i, j, k);
                g.set(i, j, k, f(p));
            }
        }
    }
    g
}

/// The sphere of radius [`R`] at the origin, `n³` samples.
pub fn sphere_grid(n: usize) -> Grid {
    grid_of(n, |p| p.length() - R)
}

/// Two spheres of different radii, 64³ samples.
pub fn two_spheres() -> Grid {
    grid_of(64, |p| {
        let a = (p - Vec3::new(-0.45, 0.1, 0.0)).length() - 0.35;
        let b = (p - Vec3::new(0.5, -0.2, -0.3)).length() - 0.25;
        a.min(b)
    })
}

/// A 40° perspective camera at `eye` looking at the origin.
pub fn perspective(eye: Vec3, w: u32, h: u32) -> Camera {
    Camera::look_at(
        eye,
        Vec3::ZERO,
        Vec3::Y,
        Projection::Perspective {
            fov_y_degrees: 40.0,
        },
        w,
        h,
    )
    .unwrap()
}

/// An orthographic camera at `eye` looking at `target`, `height` world units tall.
pub fn orthographic(eye: Vec3, target: Vec3, height: f32, w: u32, h: u32) -> Camera {
    Camera::look_at(
        eye,
        target,
        Vec3::Y,
        Projection::Orthographic { height },
        w,
        h,
    )
    .unwrap()
}

/// A dense volume with the default layout.
pub fn volume(g: Grid) -> Volume {
    Volume::from_grid(g, Layout::default()).unwrap()
}

/// The angle between two vectors in degrees (atan2 in f64: resolves well below 0.01°).
pub fn angle_degrees(a: Vec3, b: Vec3) -> f32 {
    let (a, b) = (a.as_dvec3(), b.as_dvec3());
    a.cross(b).length().atan2(a.dot(b)).to_degrees() as f32
}

/// Centre and radius of the first sphere of [`csg_pair`].
pub const CSG_A: (Vec3, f32) = (Vec3::new(-0.2, 0.0, 0.0), 0.5);
/// Centre and radius of the second sphere of [`csg_pair`].
pub const CSG_B: (Vec3, f32) = (Vec3::new(0.3, 0.1, 0.15), 0.4);

/// Two overlapping spheres ([`CSG_A`], [`CSG_B`]) as exact signed distances on the same
/// 64³ lattice: the operands of the CSG tests.
pub fn csg_pair() -> (Grid, Grid) {
    let sdf = |(c, r): (Vec3, f32)| move |p: Vec3| (p - c).length() - r;
    (grid_of(64, sdf(CSG_A)), grid_of(64, sdf(CSG_B)))
}

/// A mesh's band sampled lazily on the lattice a scene of just the mesh uses by default
/// (`isokit scene`: `res` samples along the longest side, band 4 voxels, the mesh's box
/// padded by the band and 2 voxels, bricks of 4, apron 0), with band-limited kd-tree
/// queries; also the fraction of the dense grid evaluated.
pub fn mesh_band(path: &std::path::Path, res: usize) -> (isokit_field::BrickGrid, f64) {
    let m = isokit_io::read_mesh(path).unwrap();
    let sdf = isokit_kdtree::MeshSdf::new(&m, Default::default()).unwrap();
    let shape = isokit_field::Field::bounds(&sdf);
    let h0 = shape.size().max_element() / (res - 1) as f32;
    let band = 4.0 * h0;
    let (dims, origin, h) =
        isokit_field::Grid::covering_geometry(shape, res, band + 2.0 * h0).unwrap();
    let reach = 0.5 * 4.0 * h * 3f32.sqrt();
    struct Clamped<'a>(&'a isokit_kdtree::MeshSdf, f32);
    impl isokit_field::Field for Clamped<'_> {
        fn value(&self, p: Vec3) -> f32 {
            isokit_field::value_clamped(self.0, p, self.1)
        }
        fn bounds(&self) -> isokit_field::Aabb {
            isokit_field::Field::bounds(self.0)
        }
    }
    let cap = (band + reach) * 1.001 + h;
    let bricks = isokit_field::BrickGrid::sample_field(
        &Clamped(&sdf, cap),
        dims,
        origin,
        h,
        4,
        0,
        band,
        band,
    )
    .unwrap();
    let f = bricks.evaluated_fraction();
    (bricks, f)
}

/// The largest difference of any channel between two RGBA images.
pub fn max_diff(a: &[glam::Vec4], b: &[glam::Vec4]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (*x - *y).abs().max_element())
        .fold(0.0, f32::max)
}

/// How two volume renderings of one view differ: the largest colour/opacity difference,
/// the pixels where only one passes opacity 0.5, and the largest depth difference where
/// both do, in units of `spacing`.
pub fn dvr_difference(
    a: &isokit_render::dvr::DvrImage,
    b: &isokit_render::dvr::DvrImage,
    spacing: f32,
) -> (f32, usize, f32) {
    let masks = a
        .depth
        .iter()
        .zip(&b.depth)
        .filter(|(x, y)| x.is_finite() != y.is_finite())
        .count();
    let dz = a
        .depth
        .iter()
        .zip(&b.depth)
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .map(|(x, y)| (x - y).abs() / spacing)
        .fold(0.0f32, f32::max);
    (max_diff(&a.rgba, &b.rgba), masks, dz)
}

/// Cameras that exercise the raster: far and near perspective views, an eye inside the
/// volume (blocks beside and behind the eye's plane), a view along an axis, orthographic.
pub fn cameras(w: u32, h: u32) -> Vec<(&'static str, Camera)> {
    vec![
        ("far", perspective(Vec3::new(1.9, 1.3, 3.6), w, h)),
        ("near", perspective(Vec3::new(0.4, 0.3, 1.6), w, h)),
        ("inside", perspective(Vec3::new(0.15, -0.1, 0.85), w, h)),
        ("axis", perspective(Vec3::new(0.0, 0.0, 3.0), w, h)),
        (
            "ortho",
            orthographic(Vec3::new(2.0, 1.0, 2.5), Vec3::ZERO, 2.2, w, h),
        ),
    ]
}
