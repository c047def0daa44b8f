//! Coincident vertices: merging them as mesh tools do on load (trimesh's default `process`,
//! STL readers), and keeping a mesher's vertices apart so that the merge changes nothing.
//!
//! [`merge_coincident`] welds vertices with bit-identical positions ([`pos_key`]: −0 equal
//! to +0) and keeps every triangle, remapped, so a triangle whose corners merge shows up as
//! degenerate in [`TriMesh::validate`] and its edges go missing from the topology: a mesh
//! that is watertight by index but not by position fails the check after the merge.
//!
//! ```
//! use glam::Vec3;
//! use isokit_field::TriMesh;
//! use isokit_levelset::weld::merge_coincident;
//! // Two copies of one point: after the merge, one vertex and a degenerate triangle.
//! let m = TriMesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::ZERO], vec![[0, 1, 2]]);
//! let w = merge_coincident(&m);
//! assert_eq!(w.positions.len(), 2);
//! assert_eq!(w.validate().degenerate_triangles, 1);
//! ```

use glam::Vec3;
use isokit_field::TriMesh;
use isokit_field::mesh::pos_key;
use std::collections::HashMap;

/// The mesh with coincident vertices merged (first occurrence kept, order preserved) and
/// every triangle remapped, none dropped. Triangles with an out-of-range index are kept as
/// they are (the validation counts them).
pub fn merge_coincident(mesh: &TriMesh) -> TriMesh {
    let mut first: HashMap<[u32; 3], u32> = HashMap::with_capacity(mesh.positions.len());
    let mut positions = Vec::new();
    let map: Vec<u32> = mesh
        .positions
        .iter()
        .map(|&p| {
            *first.entry(pos_key(p)).or_insert_with(|| {
                positions.push(p);
                (positions.len() - 1) as u32
            })
        })
        .collect();
    let triangles = mesh
        .triangles
        .iter()
        .map(|t| {
            if t.iter().all(|&i| (i as usize) < map.len()) {
                t.map(|i| map[i as usize])
            } else {
                *t
            }
        })
        .collect();
    TriMesh::new(positions, triangles)
}

/// Coordinate `a` of `p`, a vertex on the lattice edge along axis `a` between node
/// coordinates `n0` and `n1` (f32, as rounded), moved one f32 step towards the edge's
/// interior where it equals either end. Unchanged when the ends themselves coincide in f32.
pub(crate) fn off_nodes(mut p: Vec3, a: usize, n0: f32, n1: f32) -> Vec3 {
    if n0 == n1 {
        return p;
    }
    let up = n1 > n0;
    let x = p[a];
    if x == n0 {
        p[a] = if up { x.next_up() } else { x.next_down() };
    } else if x == n1 {
        p[a] = if up { x.next_down() } else { x.next_up() };
    }
    p
}
