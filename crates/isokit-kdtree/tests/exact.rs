//! The tree's answers against brute force over all triangles: random soups and the shipped
//! meshes, points on vertices, edges and faces, far away, and at 1e-6 and 1e6 scale.

use glam::{DVec3, Vec3};
use isokit_field::rng::SplitMix64;
use isokit_io::{TriMesh, read_mesh};
use isokit_kdtree::mesh::brute_force_distance;
use isokit_kdtree::{BuildParams, MeshOptions, MeshSdf, QueryStats, SignMode};
use std::path::Path;

fn soup(n: usize, seed: u64) -> TriMesh {
    let mut r = SplitMix64::new(seed);
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for t in 0..n as u32 {
        let c = r.point_in(Vec3::ZERO, Vec3::ONE);
        let size = if t % 10 == 0 { 0.5 } else { 0.05 };
        for _ in 0..3 {
            positions.push(c + r.unit_vector() * size * r.next_f32());
        }
        triangles.push([3 * t, 3 * t + 1, 3 * t + 2]);
    }
    TriMesh {
        positions,
        triangles,
    }
}

fn shipped(name: &str) -> TriMesh {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../data")
        .join(name);
    read_mesh(&p).unwrap()
}

/// Query points: uniform in the padded box, far away, on every kind of feature.
fn probes(mesh: &TriMesh, r: &mut SplitMix64) -> Vec<DVec3> {
    let b = mesh.bounds();
    let d = b.diagonal();
    let mut pts: Vec<DVec3> = (0..150)
        .map(|_| {
            r.point_in(b.min - Vec3::splat(0.2 * d), b.max + Vec3::splat(0.2 * d))
                .as_dvec3()
        })
        .collect();
    for _ in 0..20 {
        pts.push((b.center() + r.unit_vector() * (100.0 * d)).as_dvec3());
    }
    for _ in 0..40 {
        let t = mesh.triangles[r.below(mesh.triangles.len())];
        let [a, b, c] = t.map(|i| mesh.positions[i as usize].as_dvec3());
        pts.push(a); // on a vertex
        pts.push(0.5 * (a + b)); // on an edge
        pts.push((a + b + c) / 3.0); // on the face
    }
    pts
}

fn scaled(mesh: &TriMesh, s: f32) -> TriMesh {
    TriMesh {
        positions: mesh.positions.iter().map(|p| *p * s).collect(),
        triangles: mesh.triangles.clone(),
    }
}

#[test]
fn distances_and_closest_points_match_brute_force() {
    let mut r = SplitMix64::new(20261123);
    let meshes = [
        ("soup", soup(400, 1)),
        ("sphere.obj", shipped("sphere.obj")),
        ("torus.off", shipped("torus.off")),
        ("open_cube.obj", shipped("open_cube.obj")),
        ("degenerate.off", shipped("degenerate.off")),
    ];
    for (name, mesh) in &meshes {
        for s in [1e-6f32, 1.0, 1e6] {
            let m = scaled(mesh, s);
            let diag = m.bounds().diagonal() as f64;
            let opts = |tree| MeshOptions {
                tree,
                sign: SignMode::Unsigned,
                ..Default::default()
            };
            let overlap = MeshSdf::new(&m, opts(BuildParams::default())).unwrap();
            let classic = MeshSdf::new(&m, opts(BuildParams::classic())).unwrap();
            for p in probes(&m, &mut r) {
                let want = brute_force_distance(&m, p);
                let mut st = QueryStats::default();
                let h = overlap.query(p, &mut st).unwrap();
                let c = classic.query(p, &mut st).unwrap();
                assert!(
                    (h.distance - want).abs() <= 1e-6 * want,
                    "{name} x{s}: {} vs {want} at {p}",
                    h.distance
                );
                assert_eq!(
                    h.distance, c.distance,
                    "{name} x{s}: overlap and classic trees differ at {p}"
                );
                // The closest point is on the mesh and at that distance.
                assert!(((h.point - p).length() - want).abs() <= 1e-6 * diag);
                let on = brute_force_distance(&m, h.point);
                assert!(
                    on <= 1e-9 * diag,
                    "{name} x{s}: closest point {} is {on} off the mesh",
                    h.point
                );
            }
        }
    }
}

#[test]
fn trefoil_signs_agree_between_pseudonormals_and_winding_numbers() {
    let mesh = shipped("trefoil.ply");
    let pn = MeshSdf::new(
        &mesh,
        MeshOptions {
            sign: SignMode::Pseudonormal,
            ..Default::default()
        },
    )
    .unwrap();
    let wn = MeshSdf::new(
        &mesh,
        MeshOptions {
            sign: SignMode::Winding,
            ..Default::default()
        },
    )
    .unwrap();
    let mut r = SplitMix64::new(9);
    let b = mesh.bounds();
    let diag = b.diagonal() as f64;
    let mut n = 0;
    for _ in 0..3000 {
        let p = r
            .point_in(b.min - Vec3::splat(0.1), b.max + Vec3::splat(0.1))
            .as_dvec3();
        let mut st = QueryStats::default();
        let (a, w) = (
            pn.query(p, &mut st).unwrap().distance,
            wn.query(p, &mut st).unwrap().distance,
        );
        if a.abs() > 1e-4 * diag {
            n += 1;
            assert_eq!(a.signum(), w.signum(), "at {p}: {a} vs {w}");
        }
    }
    assert!(n > 2900);
}
