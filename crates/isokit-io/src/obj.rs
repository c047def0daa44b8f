//! Wavefront OBJ through tobj, and a plain `v`/`f` writer.

use std::path::Path;

use glam::Vec3;

use crate::{IoError, TriMesh, atomic_write};

/// Keeps only what a triangle mesh needs (`v` lines and the position part of `f` lines), so
/// tobj never sees texture or normal indices, materials, lines or points.
fn sanitize(bytes: &[u8], path: &Path) -> Result<String, IoError> {
    let text = std::str::from_utf8(bytes)
        .map_err(|e| IoError::malformed(path, format!("OBJ file is not UTF-8 text ({e})")))?;
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                // x y z, or x y z w; vertex colours are dropped (tobj refuses a file where
                // only some vertices carry them).
                let w: Vec<&str> = words.take(5).collect();
                let keep = if w.len() == 4 { 4 } else { w.len().min(3) };
                out.push('v');
                for c in &w[..keep] {
                    out.push(' ');
                    out.push_str(c);
                }
                out.push('\n');
            }
            Some("f") => {
                out.push('f');
                for w in words {
                    out.push(' ');
                    out.push_str(w.split('/').next().unwrap_or(""));
                }
                out.push('\n');
            }
            _ => {}
        }
    }
    Ok(out)
}

pub(crate) fn read_obj(bytes: &[u8], path: &Path) -> Result<TriMesh, IoError> {
    let text = sanitize(bytes, path)?;
    if text.is_empty() {
        return Err(IoError::malformed(
            path,
            "OBJ file holds no vertices ('v' lines) and no faces",
        ));
    }
    let opts = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| IoError::malformed(path, format!("OBJ file cannot be parsed: {e}")))?;
    let mut mesh = TriMesh::default();
    for m in &models {
        let p = &m.mesh.positions;
        let base = mesh.positions.len();
        mesh.positions
            .extend(p.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])));
        let n = mesh.positions.len();
        for t in m.mesh.indices.chunks_exact(3) {
            let mut tri = [0u32; 3];
            for (k, &i) in t.iter().enumerate() {
                let g = base + i as usize;
                if g >= n || g > u32::MAX as usize {
                    return Err(IoError::malformed(
                        path,
                        format!(
                            "OBJ face refers to vertex {} of {}",
                            i as usize + 1,
                            n - base
                        ),
                    ));
                }
                tri[k] = g as u32;
            }
            mesh.triangles.push(tri);
        }
    }
    Ok(mesh)
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
