//! Marching tetrahedra against exact references: a sphere's distance field (the surface
//! is closed, oriented and near the sphere), linear fields (the interpolant is exact, so
//! every corner lies on the plane, on any grid, inverted cells included), samples exactly
//! at the isovalue, and the job's cancellation.

use glam::Vec3;
use isokit_field::primitives::Sphere;
use isokit_field::{Grid, Job, TetGrid, TetSplit, TriMesh, sample_into};
use isokit_levelset::meshing::{MeshOptions, MeshingError, mesh_grid, mesh_volume};
use isokit_levelset::tets::{mesh_tets, mesh_tets_job};
use isokit_levelset::weld::merge_coincident;

const SPLITS: [TetSplit; 2] = [TetSplit::Five, TetSplit::Six];

fn sphere_grid(n: usize, r: f32) -> Grid {
    let h = 2.0 / (n - 1) as f32;
    let mut g = Grid::new([n, n, n], Vec3::splat(-1.0), h).unwrap();
    sample_into(&Sphere::new(Vec3::ZERO, r).unwrap(), &mut g);
    g
}

fn max_radial_error(mesh: &TriMesh, r: f32) -> f32 {
    mesh.positions
        .iter()
        .map(|p| (p.length() - r).abs())
        .fold(0.0, f32::max)
}

#[test]
fn a_sphere_is_one_closed_outward_surface_as_close_as_marching_cubes() {
    let (n, r) = (33, 0.6);
    let g = sphere_grid(n, r);
    let h = g.spacing();
    let cubes = mesh_grid(&g, &MeshOptions::default()).unwrap();
    let cubes_err = max_radial_error(&cubes, r);
    let exact = 4.0 / 3.0 * std::f64::consts::PI * f64::from(r).powi(3);
    for split in SPLITS {
        let t = TetGrid::from_grid(&g, split).unwrap();
        let mesh = mesh_tets(&t, 0.0).unwrap();
        let rep = mesh.validate();
        assert!(rep.is_clean(), "{split:?}: {rep}");
        assert_eq!(rep.genus(), Some(0), "{split:?}: {rep}");
        assert_eq!(rep.duplicate_vertices, 0, "{split:?}: {rep}");
        // Outward: the divergence theorem gives the enclosed volume with a positive sign.
        let v = mesh_volume(&mesh);
        assert!(
            (v - exact).abs() < 0.01 * exact,
            "{split:?}: {v} vs {exact}"
        );
        // Each corner interpolates |x| − r linearly along an edge of length ℓ ≤ h√3, whose
        // curvature is at most 1/r near the surface: the error is second order, ℓ² / (8 r)
        // = 0.00244 here. Measured: 0.00143 (Five), 0.00222 (Six, whose long diagonals
        // cross more often), against marching cubes' 0.00076 on axis edges (ℓ = h).
        // Volume: 0.89999 (Five), 0.89988 (Six) of 0.90478.
        let err = max_radial_error(&mesh, r);
        let bound = 3.0 * h * h / (8.0 * r);
        assert!(err < bound, "{split:?}: {err} vs {bound}");
        assert!(
            err < 4.0 * cubes_err,
            "{split:?}: {err} vs cubes {cubes_err}"
        );
    }
}

/// A grid of jittered points: the regular grid's cells, each point moved by up to
/// `jitter` spacings, then every third cell listed in the inverted order.
fn jittered(n: usize, jitter: f32, split: TetSplit) -> TetGrid {
    let g = Grid::new([n, n, n], Vec3::splat(-1.0), 2.0 / (n - 1) as f32).unwrap();
    let t = TetGrid::from_grid(&g, split).unwrap();
    let h = g.spacing();
    let mut state = 0x2545_f491_4f6c_dd1d_u64;
    let mut rnd = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32 - 0.5
    };
    let points = t
        .points()
        .iter()
        .map(|&p| p + jitter * h * Vec3::new(rnd(), rnd(), rnd()))
        .collect::<Vec<_>>();
    let cells = t
        .tets()
        .iter()
        .enumerate()
        .map(|(i, &[a, b, c, d])| {
            if i % 3 == 0 {
                [b, a, c, d]
            } else {
                [a, b, c, d]
            }
        })
        .collect();
    TetGrid::new(points, cells, vec![0.0; t.points().len()], "plane").unwrap()
}

#[test]
fn corners_of_a_linear_field_lie_on_its_plane_on_any_grid_and_face_the_outside() {
    let normal = Vec3::new(0.3, -0.5, 0.81).normalize();
    let offset = 0.137;
    for split in SPLITS {
        let mut t = jittered(12, 0.3, split);
        let rep = t.report();
        assert!(
            rep.inverted > 0 && rep.degenerate == 0,
            "{split:?}: {rep:?}"
        );
        let values = t
            .points()
            .iter()
            .map(|&p| normal.dot(p) - offset)
            .collect::<Vec<_>>();
        t.values_mut().copy_from_slice(&values);
        let mesh = mesh_tets(&t, 0.0).unwrap();
        assert!(!mesh.triangles.is_empty());
        // Every corner is on the plane, except where a point lies nearer the plane than
        // 1/1024 of its edge: that corner is held 1/1024 of the edge (≤ 0.41 · 2⁻¹⁰ here)
        // away from the point, so it sits that close to a grid point.
        let mut held = 0;
        for &p in &mesh.positions {
            let off = (normal.dot(p) - offset).abs();
            if off > 2e-6 {
                let near = t
                    .points()
                    .iter()
                    .map(|q| q.distance(p))
                    .fold(f32::MAX, f32::min);
                assert!(
                    near < 4.1e-4 && off <= near,
                    "{split:?}: {p} off {off}, near {near}"
                );
                held += 1;
            }
        }
        assert!(
            held * 50 < mesh.positions.len(),
            "{split:?}: {held} held corners"
        );
        let rep = mesh.validate();
        assert!(rep.consistently_oriented, "{split:?}: {rep}");
        assert_eq!(rep.components, 1, "{split:?}: {rep}");
        assert_eq!(rep.degenerate_triangles, 0, "{split:?}: {rep}");
        // The outside is `value ≥ iso`, on the normal's side: every triangle faces it.
        for (i, &[a, b, c]) in mesh.triangles.iter().enumerate() {
            let [a, b, c] = [a, b, c].map(|k| mesh.positions[k as usize]);
            let facing = (b - a).cross(c - a).dot(normal);
            assert!(facing > 0.0, "{split:?}: triangle {i} faces {facing}");
        }
    }
}

#[test]
fn samples_exactly_at_the_isovalue_give_no_collapsed_or_open_triangles() {
    // Integer values on integer isovalues: a third of the points sit on the surface.
    let g0 = Grid::new([9, 9, 9], Vec3::ZERO, 1.0).unwrap();
    for split in SPLITS {
        let mut t = TetGrid::from_grid(&g0, split).unwrap();
        let values = t
            .points()
            .iter()
            .map(|p| ((p.x - 4.0).abs() + (p.y - 4.0).abs() + (p.z - 4.0).abs()).round())
            .collect::<Vec<_>>();
        t.values_mut().copy_from_slice(&values);
        for iso in [1.0, 2.0, 3.0] {
            let mesh = merge_coincident(&mesh_tets(&t, iso).unwrap());
            let rep = mesh.validate();
            assert!(rep.is_clean(), "{split:?} iso {iso}: {rep}");
            assert_eq!(rep.genus(), Some(0), "{split:?} iso {iso}: {rep}");
        }
    }
}

#[test]
fn nothing_crosses_far_from_the_surface_and_bad_requests_are_refused() {
    let g = sphere_grid(9, 0.5);
    let t = TetGrid::from_grid(&g, TetSplit::Six).unwrap();
    assert!(mesh_tets(&t, -10.0).unwrap().triangles.is_empty());
    assert!(mesh_tets(&t, 10.0).unwrap().triangles.is_empty());
    assert!(matches!(
        mesh_tets(&t, f32::NAN),
        Err(MeshingError::BadIso(_))
    ));
    let job = Job::new();
    job.cancel();
    assert!(matches!(
        mesh_tets_job(&t, 0.0, &job),
        Err(MeshingError::Cancelled(_))
    ));
}

#[test]
fn a_nan_point_is_outside_and_leaves_a_closed_surface_around_it() {
    let g = sphere_grid(17, 0.6);
    let mut t = TetGrid::from_grid(&g, TetSplit::Six).unwrap();
    // The centre point (deep inside) becomes NaN: the surface gains a small closed pocket
    // around it, facing into it, and stays closed and oriented.
    let centre = t.points().iter().position(|p| p.length() < 1e-6).unwrap();
    t.values_mut()[centre] = f32::NAN;
    let mesh = mesh_tets(&t, 0.0).unwrap();
    let rep = mesh.validate();
    assert!(rep.is_clean(), "{rep}");
    assert_eq!(rep.components, 2, "{rep}");
}
