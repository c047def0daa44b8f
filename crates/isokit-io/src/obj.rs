//! Wavefront OBJ: a reader of `v` and `f` lines that keeps every vertex, and a plain writer.

use std::path::Path;

use glam::Vec3;

use crate::util::show;
use crate::{IoError, TriMesh, atomic_write};

/// Reads the geometry of an OBJ file: every `v` line in order (unreferenced vertices
/// included: nothing is dropped) and every `f` line, polygons triangulated (`crate::mesh::fan`). Indices
/// are 1-based or negative (relative to the vertices read so far); texture and normal
/// indices (`v/vt/vn`), other statements, groups and materials are ignored. A file with `v`
/// lines and no faces gives a mesh without triangles (a point cloud: [`read_obj_points`]).
pub(crate) fn read_obj(bytes: &[u8], path: &Path) -> Result<TriMesh, IoError> {
    let text = std::str::from_utf8(bytes)
        .map_err(|e| IoError::malformed(path, format!("OBJ file is not UTF-8 text ({e})")))?;
    let mut mesh = TriMesh::default();
    let mut face: Vec<u32> = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let bad = |why: String| IoError::malformed(path, format!("OBJ line {}: {why}", n + 1));
        let line = line.split('#').next().unwrap_or("");
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let mut c = [0f32; 3];
                for (a, v) in c.iter_mut().enumerate() {
                    let w = words
                        .next()
                        .ok_or_else(|| bad(format!("a vertex needs 3 coordinates, found {a}")))?;
                    *v = w
                        .parse()
                        .map_err(|_| bad(format!("{:?} is not a number", show(w.as_bytes()))))?;
                }
                if mesh.positions.len() >= u32::MAX as usize {
                    return Err(bad("more than 2^32 - 1 vertices".into()));
                }
                mesh.positions.push(Vec3::from_array(c));
            }
            Some("f") => {
                face.clear();
                let count = mesh.positions.len() as i64;
                for w in words {
                    let first = w.split('/').next().unwrap_or("");
                    let i: i64 = first.parse().map_err(|_| {
                        bad(format!("{:?} is not a vertex index", show(w.as_bytes())))
                    })?;
                    let g = if i > 0 { i - 1 } else { count + i };
                    if i == 0 || !(0..count).contains(&g) {
                        return Err(bad(format!(
                            "face refers to vertex {i}, but {count} vertices precede it"
                        )));
                    }
                    face.push(g as u32);
                }
                if face.len() < 3 {
                    return Err(bad(format!(
                        "a face needs at least 3 vertices, found {}",
                        face.len()
                    )));
                }
                crate::mesh::fan(&face, &mut mesh.triangles);
            }
            _ => {}
        }
    }
    if mesh.positions.is_empty() {
        return Err(IoError::malformed(
            path,
            "OBJ file holds no vertices ('v' lines)",
        ));
    }
    Ok(mesh)
}

/// An OBJ file's vertices as a point cloud (faces, if any, are ignored).
pub(crate) fn read_obj_points(bytes: &[u8], path: &Path) -> Result<crate::PointCloud, IoError> {
    let mesh = read_obj(bytes, path)?;
    Ok(crate::PointCloud {
        points: mesh.positions,
        normals: None,
    })
}

/// Whether OBJ text has an `f` line (a mesh) rather than only vertices (a point cloud).
pub(crate) fn has_faces(bytes: &[u8]) -> bool {
    bytes.split(|&b| b == b'\n').any(|l| {
        l.trim_ascii_start()
            .strip_prefix(b"f")
            .is_some_and(|r| r.first().is_some_and(u8::is_ascii_whitespace))
    })
}

pub(crate) fn write_obj(path: &Path, mesh: &TriMesh) -> Result<(), IoError> {
    crate::mesh::check_indices(mesh, path)?;
    atomic_write(path, |w| {
        writeln!(w, "# written by isokit")?;
        for p in &mesh.positions {
            writeln!(w, "v {} {} {}", p.x, p.y, p.z)?;
        }
        for t in &mesh.triangles {
            writeln!(w, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
        }
        Ok(())
    })
}
