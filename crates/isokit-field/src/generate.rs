//! Small procedural meshes and clouds for tests, examples and the shipped `data/` files.
//!
//! Every closed surface here is watertight and consistently oriented with outward normals
//! (counter-clockwise seen from outside). All functions are deterministic.

use std::collections::HashMap;
use std::f32::consts::TAU;

use crate::rng::SplitMix64;
use glam::Vec3;

use crate::{PointCloud, TriMesh};

/// An icosphere: the icosahedron subdivided `level` times, projected onto the sphere.
/// Level `l` has `10·4^l + 2` vertices and `20·4^l` triangles (level 3: 642 and 1280).
/// Levels above 8 are clamped to 8 (1.3 M triangles).
pub fn icosphere(center: Vec3, radius: f32, level: usize) -> TriMesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut p: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|a| Vec3::from_array(*a).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..level.min(8) {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::with_capacity(f.len() * 3 / 2);
        let mut split = |a: u32, b: u32, p: &mut Vec<Vec3>| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                p.push(((p[a as usize] + p[b as usize]) * 0.5).normalize());
                (p.len() - 1) as u32
            })
        };
        let mut nf = Vec::with_capacity(f.len() * 4);
        for [a, b, c] in f {
            let ab = split(a, b, &mut p);
            let bc = split(b, c, &mut p);
            let ca = split(c, a, &mut p);
            nf.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = nf;
    }
    for q in &mut p {
        *q = center + *q * radius;
    }
    TriMesh::new(p, f)
}

/// Quads of a periodic `nu × nv` vertex lattice (vertex `(i, j)` at `i * nv + j`), split
/// into triangles ordered `(i, j) → (i+1, j) → (i+1, j+1)`.
fn periodic_grid(nu: usize, nv: usize) -> Vec<[u32; 3]> {
    let id = |i: usize, j: usize| ((i % nu) * nv + (j % nv)) as u32;
    let mut t = Vec::with_capacity(2 * nu * nv);
    for i in 0..nu {
        for j in 0..nv {
            let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            t.push([a, b, c]);
            t.push([a, c, d]);
        }
    }
    t
}

/// A torus around the z axis through the origin: tube centre at distance `major`, tube
/// radius `minor`, `n_major` segments around z and `n_minor` around the tube (each at
/// least 3). Euler characteristic 0 (genus 1).
pub fn torus(major: f32, minor: f32, n_major: usize, n_minor: usize) -> TriMesh {
    let (nu, nv) = (n_major.max(3), n_minor.max(3));
    let mut p = Vec::with_capacity(nu * nv);
    for i in 0..nu {
        let phi = TAU * i as f32 / nu as f32;
        for j in 0..nv {
            let theta = TAU * j as f32 / nv as f32;
            let rr = major + minor * theta.cos();
            p.push(Vec3::new(
                rr * phi.cos(),
                rr * phi.sin(),
                minor * theta.sin(),
            ));
        }
    }
    TriMesh::new(p, periodic_grid(nu, nv))
}

/// A closed tube of the given radius around a closed curve `curve(u)`, `u ∈ [0, 1)` (the
/// curve must satisfy `curve(0) == curve(1)`), with `segments` rings along the curve and
/// `sides` vertices per ring (each at least 3). Rings are oriented by parallel transport,
/// with the closing twist spread evenly, so the tube does not flip at inflections.
pub fn tube(curve: impl Fn(f32) -> Vec3, radius: f32, segments: usize, sides: usize) -> TriMesh {
    let (nu, nv) = (segments.max(3), sides.max(3));
    let c: Vec<Vec3> = (0..nu).map(|i| curve(i as f32 / nu as f32)).collect();
    let tangent = |i: usize| (c[(i + 1) % nu] - c[(i + nu - 1) % nu]).normalize_or(Vec3::X);
    // Parallel transport of a normal along the curve.
    let t0 = tangent(0);
    let mut n = t0.any_orthonormal_vector();
    let mut normals = Vec::with_capacity(nu + 1);
    normals.push(n);
    for i in 1..=nu {
        let (ta, tb) = (tangent(i - 1), tangent(i % nu));
        // Rotate n by the rotation taking ta to tb, then re-orthogonalize.
        let q = glam::Quat::from_rotation_arc(ta, tb);
        n = (q * n)
            .reject_from_normalized(tb)
            .normalize_or(tb.any_orthonormal_vector());
        normals.push(n);
    }
    // Twist mismatch after one loop, spread over the rings.
    let end = normals[nu];
    let b0 = t0.cross(normals[0]);
    let twist = end.dot(b0).atan2(end.dot(normals[0]));
    let mut p = Vec::with_capacity(nu * nv);
    for i in 0..nu {
        let t = tangent(i);
        let corr = glam::Quat::from_axis_angle(t, -twist * i as f32 / nu as f32);
        let n = corr * normals[i];
        let b = t.cross(n);
        for j in 0..nv {
            // Angle decreasing in j keeps the triangles' normals pointing outward.
            let a = -TAU * j as f32 / nv as f32;
            p.push(c[i] + radius * (a.cos() * n + a.sin() * b));
        }
    }
    TriMesh::new(p, periodic_grid(nu, nv))
}

/// A point of the trefoil knot, `u ∈ [0, 1)` once around:
/// `scale · (sin t + 2 sin 2t, cos t − 2 cos 2t, −sin 3t)` with `t = 2πu`.
pub fn trefoil(u: f32, scale: f32) -> Vec3 {
    let t = TAU * u;
    scale
        * Vec3::new(
            t.sin() + 2.0 * (2.0 * t).sin(),
            t.cos() - 2.0 * (2.0 * t).cos(),
            -(3.0 * t).sin(),
        )
}

/// The cube `[-half, half]^3` without its top (+z) face: 8 vertices, 10 triangles, one
/// square hole bounded by 4 edges, outward-oriented.
pub fn open_cube(half: f32) -> TriMesh {
    let positions = (0..8)
        .map(|i| {
            half * Vec3::new(
                if i & 1 != 0 { 1.0 } else { -1.0 },
                if i & 2 != 0 { 1.0 } else { -1.0 },
                if i & 4 != 0 { 1.0 } else { -1.0 },
            )
        })
        .collect();
    let quads = [
        [0, 2, 3, 1], // -z
        [0, 1, 5, 4], // -y
        [2, 6, 7, 3], // +y
        [0, 4, 6, 2], // -x
        [1, 3, 7, 5], // +x
    ];
    let triangles = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    TriMesh::new(positions, triangles)
}

/// A deliberately broken little mesh for testing robustness: the unit square in the
/// z = 0 plane (triangles 0–1) plus, in order, a zero-area triangle on three collinear
/// points (2), a triangle with a repeated index (3), a duplicate of triangle 0 in the
/// opposite orientation (4) and a sliver (5, valid but nearly flat). It has one vertex
/// duplicating another's position (5 duplicates 1), one unreferenced vertex (8) and no
/// non-finite coordinates. [`TriMesh::validate`] counts 2 degenerate triangles, 1 duplicate
/// triangle, 1 duplicate vertex and 1 unreferenced vertex.
pub fn degenerate_mesh() -> TriMesh {
    let positions = vec![
        Vec3::new(0.0, 0.0, 0.0),  // 0
        Vec3::new(1.0, 0.0, 0.0),  // 1
        Vec3::new(1.0, 1.0, 0.0),  // 2
        Vec3::new(0.0, 1.0, 0.0),  // 3
        Vec3::new(2.0, 0.0, 0.0),  // 4: collinear with 0 and 1
        Vec3::new(1.0, 0.0, 0.0),  // 5: same position as 1
        Vec3::new(3.0, 0.0, 0.0),  // 6
        Vec3::new(4.0, 1e-3, 0.0), // 7: sliver apex
        Vec3::new(9.0, 9.0, 9.0),  // 8: unreferenced
    ];
    let triangles = vec![
        [0, 1, 2],
        [0, 2, 3],
        [0, 1, 4],
        [3, 3, 2],
        [0, 2, 1],
        [5, 6, 7],
    ];
    TriMesh::new(positions, triangles)
}

/// `n` points uniformly distributed (by area) on the surface of the torus of [`torus`],
/// with outward unit normals, from a seeded generator.
pub fn torus_cloud(major: f32, minor: f32, n: usize, seed: u64) -> PointCloud {
    let mut rng = SplitMix64::new(seed);
    let mut points = Vec::with_capacity(n);
    let mut normals = Vec::with_capacity(n);
    let (big, small) = (major.abs(), minor.abs());
    while points.len() < n {
        let phi = TAU * rng.next_f32();
        let theta = TAU * rng.next_f32();
        // Area element ∝ (R + r cos θ): rejection sampling.
        let w = (big + small * theta.cos()) / (big + small).max(f32::MIN_POSITIVE);
        if rng.next_f32() > w {
            continue;
        }
        let nrm = Vec3::new(
            theta.cos() * phi.cos(),
            theta.cos() * phi.sin(),
            theta.sin(),
        );
        let centre = Vec3::new(major * phi.cos(), major * phi.sin(), 0.0);
        points.push(centre + minor * nrm);
        normals.push(nrm);
    }
    PointCloud {
        points,
        normals: Some(normals),
    }
}

/// `n` query points for benchmarks: even indices lie within `band` (a fraction of the
/// bounding diagonal) of the surface (a random point of a random triangle, moved by a random
/// offset), odd ones are uniform in the bounds padded by 10% on every side. Deterministic
/// for a seed. Empty for a mesh without triangles.
pub fn query_points(mesh: &TriMesh, n: usize, band: f32, seed: u64) -> Vec<Vec3> {
    if mesh.triangles.is_empty() {
        return Vec::new();
    }
    let mut r = SplitMix64::new(seed);
    let b = mesh.bounds();
    let d = b.diagonal();
    let pad = 0.1 * b.size();
    (0..n)
        .map(|i| {
            if i % 2 == 0 {
                let t = mesh.triangles[r.below(mesh.triangles.len())];
                let [a, bb, c] = t.map(|v| {
                    mesh.positions
                        .get(v as usize)
                        .copied()
                        .unwrap_or(Vec3::ZERO)
                });
                let (u, v) = (r.next_f32().sqrt(), r.next_f32());
                let on = (1.0 - u) * a + u * (1.0 - v) * bb + u * v * c;
                on + r.unit_vector() * (band * d * r.next_f32())
            } else {
                r.point_in(b.min - pad, b.max + pad)
            }
        })
        .collect()
}
