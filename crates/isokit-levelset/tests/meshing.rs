//! Isosurface meshing: watertightness, 2-manifoldness, orientation, accuracy, boundary
//! closing, NaN handling, brick-grid equivalence and determinism.

use std::collections::HashMap;
use std::f64::consts::PI;

use glam::Vec3;
use isokit_field::primitives::{Sphere, Torus};
use isokit_field::rng::SplitMix64;
use isokit_field::{BrickGrid, Field, Grid, sample_into};
use isokit_io::{MeshReport, TriMesh};
use isokit_levelset::meshing::{
    MeshOptions, MeshingError, mesh_area, mesh_brick_grid, mesh_grid, mesh_volume,
};

const CLOSED: MeshOptions = MeshOptions {
    iso: 0.0,
    close_boundary: true,
};
const OPEN: MeshOptions = MeshOptions {
    iso: 0.0,
    close_boundary: false,
};

fn opts(iso: f32, close_boundary: bool) -> MeshOptions {
    MeshOptions {
        iso,
        close_boundary,
    }
}

/// `n³` samples over `[-1, 1]³`.
fn cube_grid(n: usize) -> Grid {
    Grid::new([n; 3], Vec3::splat(-1.0), 2.0 / (n - 1) as f32).unwrap()
}

fn sampled(field: &dyn Field, n: usize) -> Grid {
    let mut g = cube_grid(n);
    sample_into(field, &mut g);
    g
}

fn from_fn(n: usize, f: impl Fn(Vec3) -> f32) -> Grid {
    let mut g = cube_grid(n);
    for ([i, j, k], _) in g.clone().iter() {
        let p = g.position(i, j, k);
        g.set(i, j, k, f(p));
    }
    g
}

/// Random i.i.d. samples in [-1, 1]: every face pattern, many ambiguous faces.
fn random_grid(seed: u64, n: usize) -> Grid {
    let mut rng = SplitMix64::new(seed);
    let data = (0..n * n * n).map(|_| rng.range(-1.0, 1.0)).collect();
    Grid::from_data([n; 3], Vec3::new(0.5, -2.0, 3.0), 0.25, data).unwrap()
}

/// `1 − Σ wᵢ exp(−|p − cᵢ|² / σᵢ²)`: blobs that merge and split as the isovalue moves.
fn gaussians(seed: u64, count: usize) -> impl Fn(Vec3) -> f32 {
    let mut rng = SplitMix64::new(seed);
    let blobs: Vec<(Vec3, f32, f32)> = (0..count)
        .map(|_| {
            (
                rng.point_in(Vec3::splat(-0.6), Vec3::splat(0.6)),
                rng.range(0.2, 0.45),
                rng.range(0.6, 1.4),
            )
        })
        .collect();
    move |p| {
        1.0 - blobs
            .iter()
            .map(|&(c, s, w)| w * (-(p - c).length_squared() / (s * s)).exp())
            .sum::<f32>()
    }
}

/// Checks that every vertex's link (the edges opposite it in its triangles) is one cycle,
/// or, with `allow_paths`, one path for vertices on the boundary. Returns the number of
/// boundary vertices.
fn check_links(mesh: &TriMesh, allow_paths: bool) -> usize {
    let mut links: Vec<Vec<(u32, u32)>> = vec![Vec::new(); mesh.positions.len()];
    for &[a, b, c] in &mesh.triangles {
        links[a as usize].push((b, c));
        links[b as usize].push((c, a));
        links[c as usize].push((a, b));
    }
    let mut boundary = 0;
    for (v, link) in links.iter().enumerate() {
        assert!(!link.is_empty(), "vertex {v} is unreferenced");
        let mut next: HashMap<u32, u32> = HashMap::new();
        let mut has_prev: HashMap<u32, bool> = HashMap::new();
        for &(s, e) in link {
            assert!(
                next.insert(s, e).is_none(),
                "vertex {v}: link branches at {s}"
            );
            assert!(
                has_prev.insert(e, true).is_none(),
                "vertex {v}: link merges at {e}"
            );
        }
        let starts: Vec<u32> = next
            .keys()
            .copied()
            .filter(|s| !has_prev.contains_key(s))
            .collect();
        let start = match starts.len() {
            0 => link[0].0,
            1 if allow_paths => {
                boundary += 1;
                starts[0]
            }
            _ => panic!("vertex {v}: link is {} paths", starts.len().max(1)),
        };
        // Walk from the start: a single cycle (or path) visits every link edge.
        let mut steps = 0;
        let mut at = start;
        while let Some(&e) = next.get(&at) {
            steps += 1;
            at = e;
            if at == start || steps > link.len() {
                break;
            }
        }
        assert_eq!(steps, link.len(), "vertex {v}: link is not one cycle");
    }
    boundary
}

/// Everything a closed export mesh must be: watertight, 2-manifold, consistently
/// oriented, outward (positive volume), every vertex's link one cycle.
fn check_closed(mesh: &TriMesh) -> MeshReport {
    let r = mesh.validate();
    assert!(r.watertight, "not watertight:\n{r}");
    assert_eq!(r.boundary_edges, 0);
    assert_eq!(r.non_manifold_edges, 0);
    assert!(r.consistently_oriented, "not oriented:\n{r}");
    assert_eq!(r.invalid_triangles, 0);
    assert_eq!(r.duplicate_triangles, 0);
    assert_eq!(r.unreferenced_vertices, 0);
    assert_eq!(r.non_finite_vertices, 0);
    assert_eq!(r.euler_characteristic % 2, 0, "odd χ:\n{r}");
    check_links(mesh, false);
    assert!(mesh_volume(mesh) > 0.0, "inward orientation");
    r
}

/// Vertices not on a grid edge (fewer than two coordinates on grid lines): centroids added
/// for loops that could not be triangulated from their own vertices.
fn off_edge_vertices(mesh: &TriMesh, g: &Grid) -> usize {
    mesh.positions
        .iter()
        .filter(|p| {
            let u = (**p - g.origin()) / g.spacing();
            let on = u
                .to_array()
                .iter()
                .filter(|c| (**c - c.round()).abs() < 1e-3)
                .count();
            on < 2
        })
        .count()
}

/// Triangles as sorted triples of vertex positions, independent of vertex and triangle
/// order (rotated so the smallest index leads, then sorted).
fn canonical(mesh: &TriMesh) -> Vec<[[u32; 3]; 3]> {
    let mut out: Vec<[[u32; 3]; 3]> = mesh
        .triangles
        .iter()
        .map(|t| {
            let p = t.map(|i| mesh.positions[i as usize].to_array().map(f32::to_bits));
            let r = (0..3).min_by_key(|&s| p[s]).unwrap_or(0);
            [p[r], p[(r + 1) % 3], p[(r + 2) % 3]]
        })
        .collect();
    out.sort_unstable();
    out
}

#[test]
fn sphere_is_closed_outward_and_accurate() {
    let r = 0.8f64;
    let g = sampled(&Sphere::new(Vec3::ZERO, r as f32).unwrap(), 64);
    let m = mesh_grid(&g, &CLOSED).unwrap();
    let rep = check_closed(&m);
    assert_eq!(rep.genus(), Some(0));
    assert_eq!(rep.components, 1);
    assert_eq!(rep.degenerate_triangles, 0);
    assert_eq!(off_edge_vertices(&m, &g), 0);
    // Every triangle faces away from the centre.
    for t in &m.triangles {
        let [a, b, c] = t.map(|i| m.positions[i as usize]);
        assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
    }
    let (v, a) = (mesh_volume(&m), mesh_area(&m));
    let (ve, ae) = (4.0 / 3.0 * PI * r.powi(3), 4.0 * PI * r * r);
    let (dv, da) = ((v - ve) / ve, (a - ae) / ae);
    eprintln!(
        "sphere r=0.8 on 64³ (h = {:.4}): {} vertices, {} triangles; volume error {dv:+.2e}, area error {da:+.2e}",
        g.spacing(),
        rep.vertices,
        rep.triangles
    );
    // Linear interpolation cuts chords inside the sphere: both a little low, O(h²).
    assert!(dv < 0.0 && dv > -1.5e-3, "volume error {dv}");
    assert!(da.abs() < 2e-3, "area error {da}");
    // Second order: halving h cuts the volume error about fourfold.
    let g32 = sampled(&Sphere::new(Vec3::ZERO, r as f32).unwrap(), 32);
    let dv32 = (mesh_volume(&mesh_grid(&g32, &CLOSED).unwrap()) - ve) / ve;
    assert!(dv32.abs() > 2.5 * dv.abs(), "32³ {dv32}, 64³ {dv}");
}

#[test]
fn torus_has_genus_one() {
    let (big, small) = (0.6f64, 0.25f64);
    let g = sampled(
        &Torus::new(Vec3::ZERO, big as f32, small as f32).unwrap(),
        64,
    );
    let m = mesh_grid(&g, &CLOSED).unwrap();
    let rep = check_closed(&m);
    assert_eq!(rep.genus(), Some(1), "{rep}");
    assert_eq!(rep.degenerate_triangles, 0);
    let ve = 2.0 * PI * PI * big * small * small;
    let ae = 4.0 * PI * PI * big * small;
    let (dv, da) = ((mesh_volume(&m) - ve) / ve, (mesh_area(&m) - ae) / ae);
    eprintln!(
        "torus 0.6/0.25 on 64³: {} triangles; volume error {dv:+.2e}, area error {da:+.2e}",
        rep.triangles
    );
    assert!(dv.abs() < 5e-3 && da.abs() < 5e-3);
}

#[test]
fn smooth_random_fields_are_manifold_at_every_isovalue() {
    for seed in 0..4 {
        let f = gaussians(seed, 5);
        let g = from_fn(40, &f);
        let mut last_volume = 0.0;
        for iso in [-0.8, -0.3, 0.0, 0.4, 0.8, 0.95] {
            let m = mesh_grid(&g, &opts(iso, true)).unwrap();
            if m.is_empty() {
                continue;
            }
            let rep = check_closed(&m);
            assert_eq!(off_edge_vertices(&m, &g), 0, "seed {seed} iso {iso}");
            // Raising the isovalue grows the inside.
            let v = mesh_volume(&m);
            assert!(
                v >= last_volume,
                "seed {seed} iso {iso}: {v} < {last_volume}"
            );
            last_volume = v;
            eprintln!(
                "gaussians seed {seed} iso {iso}: {} triangles, {} components, χ = {}",
                rep.triangles, rep.components, rep.euler_characteristic
            );
        }
        assert!(last_volume > 0.0);
    }
}

#[test]
fn random_iid_grids_are_manifold_closed() {
    let box_volume = (11.0f64 * 0.25).powi(3);
    for seed in 0..6 {
        let g = random_grid(seed, 12);
        let mut last = 0.0;
        for iso in [-0.6, -0.2, 0.0, 0.3, 0.7] {
            let m = mesh_grid(&g, &opts(iso, true)).unwrap();
            let rep = check_closed(&m);
            // Raising the isovalue moves every crossing outward, turns samples inside and
            // joins more inside samples across faces: the enclosed volume grows.
            let v = mesh_volume(&m);
            assert!(
                v > last && v < box_volume,
                "seed {seed} iso {iso}: volume {v}, previous {last}"
            );
            last = v;
            if seed == 0 {
                eprintln!(
                    "random 12³ iso {iso}: {} triangles, {} components, χ = {}, {} centroid vertices",
                    rep.triangles,
                    rep.components,
                    rep.euler_characteristic,
                    off_edge_vertices(&m, &g)
                );
            }
        }
    }
}

#[test]
fn random_iid_grids_open_only_on_the_box() {
    for seed in 10..14 {
        let g = random_grid(seed, 12);
        let b = g.bounds();
        let m = mesh_grid(&g, &opts(0.1, false)).unwrap();
        let rep = m.validate();
        assert!(rep.boundary_edges > 0);
        assert_eq!(rep.non_manifold_edges, 0);
        assert!(rep.consistently_oriented);
        check_links(&m, true);
        // Every boundary edge lies in a face of the box.
        let mut count: HashMap<(u32, u32), i32> = HashMap::new();
        for t in &m.triangles {
            for k in 0..3 {
                let (u, v) = (t[k], t[(k + 1) % 3]);
                *count.entry((u.min(v), u.max(v))).or_default() += 1;
            }
        }
        for (&(u, v), &c) in &count {
            if c == 1 {
                let (p, q) = (m.positions[u as usize], m.positions[v as usize]);
                let on_face = (0..3).any(|a| {
                    let lo = (p[a] - b.min[a]).abs() < 1e-5 && (q[a] - b.min[a]).abs() < 1e-5;
                    let hi = (p[a] - b.max[a]).abs() < 1e-5 && (q[a] - b.max[a]).abs() < 1e-5;
                    lo || hi
                });
                assert!(on_face, "boundary edge {p} – {q} inside the box");
            }
        }
    }
}

#[test]
fn samples_exactly_at_the_isovalue() {
    // Values from {-1, 0, 1}: a third of the samples sit exactly on the isovalue.
    for seed in 0..4 {
        let mut rng = SplitMix64::new(100 + seed);
        let data = (0..14 * 14 * 14)
            .map(|_| rng.below(3) as f32 - 1.0)
            .collect();
        let g = Grid::from_data([14; 3], Vec3::ZERO, 0.5, data).unwrap();
        let m = mesh_grid(&g, &CLOSED).unwrap();
        let rep = check_closed(&m);
        // Zero samples are outside; the crossings on their edges are kept 1/1024 cell off
        // the sample (they used to sit on it, coincident: the defect this now rules out).
        assert_eq!(rep.duplicate_vertices, 0);
        assert_eq!(rep.degenerate_triangles, 0);
        // Same at a non-zero isovalue hit exactly.
        let shifted = Grid::from_data(
            [14; 3],
            Vec3::ZERO,
            0.5,
            g.data().iter().map(|v| v * 0.5 + 0.5).collect(),
        )
        .unwrap();
        let m2 = mesh_grid(&shifted, &opts(0.5, true)).unwrap();
        check_closed(&m2);
        assert_eq!(m2.triangles.len(), m.triangles.len());
    }
    // A sphere sampled on a grid where many samples lie exactly on it (r = 6 voxels, integer
    // points on the sphere such as (6, 0, 0) and (2, 4, 4)).
    let g = {
        let mut g = Grid::new([17; 3], Vec3::splat(-8.0), 1.0).unwrap();
        for ([i, j, k], _) in g.clone().iter() {
            let p = g.position(i, j, k);
            g.set(i, j, k, p.length_squared() - 36.0);
        }
        g
    };
    let zeros = g.data().iter().filter(|&&v| v == 0.0).count();
    assert!(zeros > 20, "{zeros}");
    let m = mesh_grid(&g, &CLOSED).unwrap();
    assert_eq!(check_closed(&m).genus(), Some(0));
}

#[test]
fn shapes_touching_the_box_close_or_stay_open() {
    let r = 0.8f64;
    // Half a sphere (cut by the face x = 1), a quarter (two faces) and an eighth (a corner).
    for (centre, fraction) in [
        (Vec3::new(1.0, 0.0, 0.0), 0.5),
        (Vec3::new(1.0, -1.0, 0.0), 0.25),
        (Vec3::new(1.0, -1.0, 1.0), 0.125),
    ] {
        let g = sampled(&Sphere::new(centre, r as f32).unwrap(), 48);
        let closed = mesh_grid(&g, &CLOSED).unwrap();
        let rep = check_closed(&closed);
        assert_eq!(rep.genus(), Some(0));
        assert_eq!(rep.degenerate_triangles, 0);
        let ve = fraction * 4.0 / 3.0 * PI * r.powi(3);
        let dv = (mesh_volume(&closed) - ve) / ve;
        assert!(dv.abs() < 5e-3, "{fraction} sphere: volume error {dv}");
        // The caps lie in the box and cover the cut disc(s).
        let b = g.bounds();
        assert!(
            closed
                .positions
                .iter()
                .all(|p| p.cmpge(b.min - 1e-6).all() && p.cmple(b.max + 1e-6).all())
        );

        let open = mesh_grid(&g, &OPEN).unwrap();
        let orep = open.validate();
        assert!(orep.boundary_edges > 0 && orep.non_manifold_edges == 0);
        assert!(orep.consistently_oriented);
        assert!(open.triangles.len() < closed.triangles.len());
        check_links(&open, true);
        // The open surface is the closed one minus the caps.
        let open_area = mesh_area(&open);
        let sphere_area = fraction * 4.0 * PI * r * r;
        assert!((open_area - sphere_area).abs() < 5e-3 * sphere_area);
        eprintln!(
            "{fraction} sphere at the box: closed {} triangles (volume error {dv:+.2e}), open {} triangles, {} boundary edges",
            rep.triangles, orep.triangles, orep.boundary_edges
        );
    }
}

#[test]
fn one_sign_grids() {
    let n = 9;
    let pos = Grid::filled([n; 3], Vec3::ZERO, 0.5, 1.0).unwrap();
    assert!(mesh_grid(&pos, &CLOSED).unwrap().is_empty());
    assert!(mesh_grid(&pos, &OPEN).unwrap().is_empty());
    let neg = Grid::filled([n; 3], Vec3::ZERO, 0.5, -1.0).unwrap();
    assert!(mesh_grid(&neg, &OPEN).unwrap().is_empty());
    // All inside and closed: the grid's box itself.
    let m = mesh_grid(&neg, &CLOSED).unwrap();
    let rep = check_closed(&m);
    assert_eq!(rep.genus(), Some(0));
    assert_eq!(rep.degenerate_triangles, 0);
    assert!((mesh_volume(&m) - 64.0).abs() < 1e-9);
    assert!((mesh_area(&m) - 96.0).abs() < 1e-9);
    // One vertex per boundary sample.
    assert_eq!(rep.vertices, n * n * n - (n - 2).pow(3));
}

#[test]
fn nan_samples_read_as_outside() {
    // All inside except one NaN sample: a box with an octahedral cavity around it whose
    // vertices sit at the middle of the six edges (volume h³ / 6).
    let h = 0.5;
    let mut g = Grid::filled([7; 3], Vec3::ZERO, h, -1.0).unwrap();
    g.set(3, 3, 3, f32::NAN);
    let m = mesh_grid(&g, &CLOSED).unwrap();
    let rep = check_closed(&m);
    assert_eq!(rep.components, 2);
    let want = 27.0 - (h as f64).powi(3) / 6.0;
    assert!((mesh_volume(&m) - want).abs() < 1e-9, "{}", mesh_volume(&m));

    // A sphere with scattered NaN samples stays closed, manifold and finite.
    let mut g = sampled(&Sphere::new(Vec3::ZERO, 0.7).unwrap(), 32);
    let mut rng = SplitMix64::new(5);
    for _ in 0..300 {
        let n = rng.below(g.len());
        g.data_mut()[n] = f32::NAN;
    }
    let m = mesh_grid(&g, &CLOSED).unwrap();
    check_closed(&m);
    let bricks = BrickGrid::from_grid(&g, 8, 1, f32::INFINITY, 1.0).unwrap();
    assert_eq!(
        canonical(&mesh_brick_grid(&bricks, &CLOSED).unwrap()),
        canonical(&m)
    );

    // Infinite samples are fine too.
    let mut g = sampled(&Sphere::new(Vec3::ZERO, 0.7).unwrap(), 24);
    g.set(12, 12, 12, f32::NEG_INFINITY);
    g.set(0, 0, 0, f32::INFINITY);
    check_closed(&mesh_grid(&g, &CLOSED).unwrap());
}

#[test]
fn bad_input_is_refused() {
    let g = cube_grid(8);
    for iso in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let e = mesh_grid(&g, &opts(iso, true)).unwrap_err();
        assert!(matches!(e, MeshingError::BadIso(_)));
        assert!(e.to_string().contains("finite"), "{e}");
    }
    for dims in [[1, 5, 5], [5, 1, 5], [5, 5, 1]] {
        let g = Grid::filled(dims, Vec3::ZERO, 1.0, -1.0).unwrap();
        for close in [true, false] {
            let e = mesh_grid(&g, &opts(0.0, close)).unwrap_err();
            assert_eq!(e, MeshingError::GridTooSmall { dims });
            assert!(e.to_string().contains("at least 2"), "{e}");
        }
        let b = BrickGrid::from_grid(&g, 4, 1, f32::INFINITY, 1.0).unwrap();
        assert!(mesh_brick_grid(&b, &CLOSED).is_err());
    }
    // The smallest grid works.
    let g = Grid::from_data(
        [2; 3],
        Vec3::ZERO,
        1.0,
        vec![-1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
    )
    .unwrap();
    for close in [true, false] {
        let m = mesh_grid(&g, &opts(0.0, close)).unwrap();
        assert!(!m.is_empty());
    }
    check_closed(&mesh_grid(&g, &CLOSED).unwrap());
}

#[test]
fn brick_grid_matches_dense() {
    let sphere = Sphere::new(Vec3::new(0.1, -0.05, 0.0), 0.62).unwrap();
    let blobs = gaussians(3, 5);
    let cases: Vec<(&str, Grid)> = vec![
        ("sphere", sampled(&sphere, 61)),
        ("gaussians", from_fn(45, &blobs)),
        // Touches the box: caps across brick boundaries and the padding.
        (
            "corner sphere",
            sampled(&Sphere::new(Vec3::new(1.0, -1.0, 0.3), 0.9).unwrap(), 37),
        ),
    ];
    let mut compared = 0;
    for (name, g) in &cases {
        let h = g.spacing();
        for (brick, apron) in [(8, 1), (4, 0), (32, 2)] {
            for (iso, band, background) in [
                (0.0, 2.0 * h, 2.0 * h),
                (0.5 * h, 3.0 * h, 3.0 * h),
                // Background on the inside: absent bricks read inside, marked ones outside.
                (0.0, 2.0 * h, -2.0 * h),
            ] {
                let b = BrickGrid::from_grid(g, brick, apron, band, background).unwrap();
                if brick <= 8 {
                    assert!(b.brick_count() < b.brick_dims().iter().product::<usize>());
                }
                let dense_grid = b.to_grid().unwrap();
                for close in [true, false] {
                    let o = opts(iso, close);
                    let sparse = mesh_brick_grid(&b, &o).unwrap();
                    let dense = mesh_grid(&dense_grid, &o).unwrap();
                    let what = format!(
                        "{name}, brick {brick} apron {apron}, iso {iso}, background {background}, close {close}"
                    );
                    assert_eq!(sparse.positions, dense.positions, "{what}");
                    let mut st = sparse.triangles.clone();
                    let mut dt = dense.triangles.clone();
                    st.sort_unstable();
                    dt.sort_unstable();
                    assert_eq!(st, dt, "{what}");
                    let (vs, vd) = (mesh_volume(&sparse), mesh_volume(&dense));
                    assert!((vs - vd).abs() <= 1e-6 * vd.abs().max(1.0), "{what}");
                    if close {
                        check_closed(&sparse);
                    }
                    compared += 1;
                }
            }
        }
    }
    assert_eq!(compared, 54);
    // The band sphere's mesh is the sphere's (the band holds the whole surface).
    let g = sampled(&sphere, 61);
    let b = BrickGrid::from_grid(&g, 8, 1, 2.0 * g.spacing(), 2.0 * g.spacing()).unwrap();
    let full = mesh_grid(&g, &CLOSED).unwrap();
    assert_eq!(
        canonical(&mesh_brick_grid(&b, &CLOSED).unwrap()),
        canonical(&full)
    );
}

#[test]
fn large_bricks_with_uniform_inside_regions() {
    // Inside everywhere but a small ball (a cavity) in one corner brick: the other bricks
    // are dropped and marked inside, larger than the meshing blocks; with closing, the box
    // itself is meshed through them.
    let g = from_fn(100, |p| 0.2 - (p - Vec3::splat(-0.6)).length());
    let h = g.spacing();
    for (brick, apron) in [(64, 1), (32, 0)] {
        let b = BrickGrid::from_grid(&g, brick, apron, 2.0 * h, 2.0 * h).unwrap();
        assert!(b.brick_count() < b.brick_dims().iter().product::<usize>());
        for close in [true, false] {
            let o = opts(0.0, close);
            let sparse = mesh_brick_grid(&b, &o).unwrap();
            let dense = mesh_grid(&b.to_grid().unwrap(), &o).unwrap();
            assert_eq!(
                sparse.positions, dense.positions,
                "brick {brick}, close {close}"
            );
            assert_eq!(canonical(&sparse), canonical(&dense));
            if close {
                let rep = check_closed(&sparse);
                assert_eq!(rep.components, 2);
                let cavity = 4.0 / 3.0 * PI * 0.2f64.powi(3);
                assert!((mesh_volume(&sparse) - (8.0 - cavity)).abs() < 1e-2 * cavity);
            } else {
                assert_eq!(sparse.validate().genus(), Some(0));
            }
        }
    }
}

#[test]
fn brick_grid_with_nan_in_an_inside_brick() {
    // A stored brick whose min/max say "all inside" but which holds a NaN (outside): the
    // cavity around it must still be meshed.
    let mut g = Grid::filled([20; 3], Vec3::ZERO, 0.1, -1.0).unwrap();
    g.set(10, 10, 10, f32::NAN);
    let b = BrickGrid::from_grid(&g, 8, 1, f32::INFINITY, 1.0).unwrap();
    let sparse = mesh_brick_grid(&b, &CLOSED).unwrap();
    let dense = mesh_grid(&g, &CLOSED).unwrap();
    assert_eq!(check_closed(&sparse).components, 2);
    assert_eq!(canonical(&sparse), canonical(&dense));
    assert_eq!(sparse.positions, dense.positions);
}

#[test]
fn output_is_deterministic_across_thread_counts() {
    let g = from_fn(50, gaussians(9, 6));
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| mesh_grid(&g, &CLOSED).unwrap())
    };
    let one = run(1);
    assert!(!one.is_empty());
    assert_eq!(run(4), one);
    assert_eq!(run(3), one);
    let b = BrickGrid::from_grid(&g, 8, 1, 0.2, 0.2).unwrap();
    let sparse = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| mesh_brick_grid(&b, &CLOSED).unwrap())
    };
    assert_eq!(sparse(1), sparse(4));
}

#[test]
#[ignore = "timing; run with `cargo test -p isokit-levelset --test meshing -- --ignored --nocapture`"]
fn timing_256() {
    let n = 256;
    let g = sampled(&Sphere::new(Vec3::ZERO, 0.8).unwrap(), n);
    let t = std::time::Instant::now();
    let m = mesh_grid(&g, &CLOSED).unwrap();
    let dense = t.elapsed();
    let h = g.spacing();
    let b = BrickGrid::from_grid(&g, 8, 1, 2.0 * h, 2.0 * h).unwrap();
    let t = std::time::Instant::now();
    let s = mesh_brick_grid(&b, &CLOSED).unwrap();
    let sparse = t.elapsed();
    assert_eq!(s.positions, m.positions);
    let r = 0.8f64;
    let dv = (mesh_volume(&m) - 4.0 / 3.0 * PI * r.powi(3)) / (4.0 / 3.0 * PI * r.powi(3));
    let da = (mesh_area(&m) - 4.0 * PI * r * r) / (4.0 * PI * r * r);
    eprintln!(
        "sphere r=0.8 on {n}³: {} triangles; mesh_grid {dense:.2?}, mesh_brick_grid {sparse:.2?} \
         ({} threads); volume error {dv:+.2e}, area error {da:+.2e}",
        m.triangles.len(),
        rayon::current_num_threads()
    );
}
