//! Marching cubes at the extremes: surfaces through lattice nodes, edges and faces, and
//! isovalues exactly at sample values. Every mesh must stay watertight, 2-manifold and
//! consistently oriented after coincident vertices are merged (as trimesh does on load),
//! with no degenerate triangles.

use glam::Vec3;
use isokit_field::primitives::Cuboid;
use isokit_field::rng::SplitMix64;
use isokit_field::{BrickGrid, Grid, TriMesh, sample_into};
use isokit_levelset::meshing::{MeshOptions, mesh_brick_grid, mesh_grid, mesh_volume};
use isokit_levelset::weld::merge_coincident;

/// Asserts the guarantees on a mesh and on its merged copy; returns the merged report's
/// component count.
fn check(mesh: &TriMesh, what: &str) -> usize {
    let r = mesh.validate();
    assert!(r.triangles > 0, "{what}: empty mesh");
    assert_eq!(r.duplicate_vertices, 0, "{what}: {r}");
    assert_eq!(r.degenerate_triangles, 0, "{what}: {r}");
    assert!(r.watertight && r.consistently_oriented, "{what}: {r}");
    let merged = merge_coincident(mesh);
    let m = merged.validate();
    assert_eq!(merged.positions.len(), mesh.positions.len(), "{what}");
    assert_eq!(m.degenerate_triangles, 0, "{what} merged: {m}");
    assert!(
        m.watertight && m.consistently_oriented && m.non_manifold_edges == 0,
        "{what} merged: {m}"
    );
    m.components
}

/// A grid whose samples are `f(i, j, k)` computed in f64 from the node indices (so zeros
/// are exact), stored as f32.
fn lattice(dims: [usize; 3], origin: Vec3, h: f32, f: impl Fn(f64, f64, f64) -> f64) -> Grid {
    let mut data = Vec::with_capacity(dims.iter().product());
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                data.push(f(i as f64, j as f64, k as f64) as f32);
            }
        }
    }
    Grid::from_data(dims, origin, h, data).unwrap()
}

/// Exact box distance in lattice units: centre `c`, half sides `half` (cells).
fn box_cells(p: [f64; 3], c: [f64; 3], half: [f64; 3]) -> f64 {
    let q: [f64; 3] = std::array::from_fn(|a| (p[a] - c[a]).abs() - half[a]);
    let out = q.iter().map(|v| v.max(0.0).powi(2)).sum::<f64>().sqrt();
    out + q[0].max(q[1]).max(q[2]).min(0.0)
}

/// The case of the report: a box face at x = 0.75 on a lattice from −1.05 with spacing
/// 0.0125 (every face, edge and corner of the box lies on lattice nodes).
#[test]
fn box_on_the_lattice_stays_watertight_after_merging() {
    let h = 0.0125f32;
    let n = 169; // −1.05 ..= 1.05
    let g = lattice([n; 3], Vec3::splat(-1.05), h, |i, j, k| {
        h as f64 * box_cells([i, j, k], [84.0; 3], [60.0, 40.0, 20.0])
    });
    let zeros = g.data().iter().filter(|&&v| v == 0.0).count();
    assert!(zeros > 10_000, "{zeros} samples on the surface");
    let mesh = mesh_grid(&g, &MeshOptions::default()).unwrap();
    assert_eq!(check(&mesh, "box"), 1);
    // Sampled in f32 world coordinates, as scenes are: the face nodes read 0 or a rounding
    // error either side, so crossings pile up at nodes along the faces.
    let mut sampled = g.clone();
    let cuboid = Cuboid::new(Vec3::ZERO, Vec3::new(0.75, 0.5, 0.25)).unwrap();
    sample_into(&cuboid, &mut sampled);
    let tiny = sampled
        .data()
        .iter()
        .filter(|v| v.abs() < 1e-6 && **v != 0.0)
        .count();
    eprintln!("f32 sampling: {tiny} samples within 1e-6 of the surface but not on it");
    let mesh32 = mesh_grid(&sampled, &MeshOptions::default()).unwrap();
    assert_eq!(check(&mesh32, "box sampled in f32"), 1);
    // The volume of the box within the marching-cubes displacement at nodes (1/1024 cell).
    let exact = 8.0 * 0.75 * 0.5 * 0.25;
    let v = mesh_volume(&mesh);
    assert!(
        (v - exact).abs() < 0.01 * exact,
        "volume {v}, exact {exact}"
    );
    // Every vertex within 1/1000 of a cell of the exact box.
    let worst = mesh
        .positions
        .iter()
        .map(|p| {
            let c = [p.x as f64, p.y as f64, p.z as f64].map(|x| (x + 1.05) / h as f64);
            box_cells(c, [84.0; 3], [60.0, 40.0, 20.0]).abs()
        })
        .fold(0.0, f64::max);
    assert!(worst < 1e-3, "worst vertex {worst} cells off the box");
    // The same through a brick grid.
    let bricks = BrickGrid::from_grid(&g, 8, 1, 2.0 * h, 2.0 * h).unwrap();
    let sparse = mesh_brick_grid(&bricks, &MeshOptions::default()).unwrap();
    assert_eq!(check(&sparse, "box, brick grid"), 1);
}

/// Planes through lattice faces (x = node), lattice edges (x + y = node sum) and lattice
/// nodes only (x + y + z = node sum), each closed by the grid boundary.
#[test]
fn planes_through_nodes_edges_and_faces() {
    let dims = [9, 10, 11];
    type Plane = fn(f64, f64, f64) -> f64;
    let planes: [(&str, Plane); 6] = [
        ("x = 4", |i, _, _| i - 4.0),
        ("y = 0 (boundary)", |_, j, _| j),
        ("x + y = 9", |i, j, _| (i + j - 9.0) / 2f64.sqrt()),
        ("x - z = 2", |i, _, k| (i - k - 2.0) / 2f64.sqrt()),
        ("x + y + z = 13", |i, j, k| (i + j + k - 13.0) / 3f64.sqrt()),
        ("x + 2y - 2z = 1", |i, j, k| {
            (i + 2.0 * j - 2.0 * k - 1.0) / 3.0
        }),
    ];
    for (name, f) in planes {
        for neg in [false, true] {
            let g = lattice(dims, Vec3::new(0.5, -2.0, 3.0), 0.25, |i, j, k| {
                let v = f(i, j, k);
                if neg { -v } else { v }
            });
            assert!(g.data().contains(&0.0), "{name}");
            let mesh = mesh_grid(&g, &MeshOptions::default()).unwrap();
            if mesh.triangles.is_empty() {
                // "y = 0" negated: nothing below 0 except beyond the grid.
                assert!(g.data().iter().all(|&v| v >= 0.0), "{name}");
                continue;
            }
            check(&mesh, &format!("{name}, negated {neg}"));
        }
    }
}

/// Integer-valued samples meshed at every value they take (many samples exactly at the
/// isovalue), including the data's minimum and maximum, dense and open and brick grids.
#[test]
fn isovalues_exactly_at_sample_values() {
    for seed in 0..6 {
        let mut rng = SplitMix64::new(seed);
        let n = 10;
        // Smooth-ish integer field: a sphere's distance rounded, plus noise in some seeds.
        let data: Vec<f32> = (0..n * n * n)
            .map(|m| {
                let (i, j, k) = (m % n, (m / n) % n, m / (n * n));
                let d = ((i as f32 - 4.5).powi(2)
                    + (j as f32 - 4.5).powi(2)
                    + (k as f32 - 4.5).powi(2))
                .sqrt();
                let noise = if seed >= 3 { rng.range(-1.5, 1.5) } else { 0.0 };
                (d - 3.0 + noise).round()
            })
            .collect();
        let g = Grid::from_data([n; 3], Vec3::ZERO, 1.0, data.clone()).unwrap();
        let lo = data.iter().copied().fold(f32::INFINITY, f32::min);
        let hi = data.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        let mut iso = lo;
        while iso <= hi {
            let opts = MeshOptions {
                iso,
                ..MeshOptions::default()
            };
            let mesh = mesh_grid(&g, &opts).unwrap();
            if iso == lo {
                // Nothing lies below the minimum.
                assert!(mesh.triangles.is_empty(), "seed {seed} iso {iso}");
            } else {
                check(&mesh, &format!("seed {seed} iso {iso}"));
                if iso == 0.0 {
                    // Bricks are kept around 0 only (the band), so compare there.
                    let bricks = BrickGrid::from_grid(&g, 4, 1, 2.0, 2.0).unwrap();
                    let sparse = mesh_brick_grid(&bricks, &opts).unwrap();
                    check(&sparse, &format!("seed {seed} brick grid"));
                    assert!(sparse.positions == mesh.positions, "seed {seed} brick grid");
                }
            }
            // Open surfaces: no duplicates or degenerate triangles either, and every edge
            // has at most two triangles after the merge.
            let open = mesh_grid(
                &g,
                &MeshOptions {
                    iso,
                    close_boundary: false,
                },
            )
            .unwrap();
            if !open.triangles.is_empty() {
                let r = merge_coincident(&open).validate();
                assert_eq!(r.degenerate_triangles, 0, "seed {seed} iso {iso} open: {r}");
                assert_eq!(r.non_manifold_edges, 0, "seed {seed} iso {iso} open: {r}");
                assert_eq!(
                    open.validate().duplicate_vertices,
                    0,
                    "seed {seed} iso {iso}"
                );
            }
            iso += 1.0;
        }
    }
}

/// Infinite samples put crossings at the finite end; those vertices are kept apart too.
#[test]
fn infinite_samples_give_no_coincident_vertices() {
    let n = 8;
    let g = lattice([n; 3], Vec3::ZERO, 0.5, |i, j, k| {
        let d = box_cells([i, j, k], [3.5; 3], [2.0; 3]);
        if d > 0.0 { f64::INFINITY } else { d }
    });
    let mesh = mesh_grid(&g, &MeshOptions::default()).unwrap();
    check(&mesh, "infinite outside");
}
