//! STL reader (binary and ASCII, with vertex welding) and writers.

use std::collections::HashMap;
use std::path::Path;

use glam::Vec3;

use crate::mesh::face_normal;
use crate::util::{Cursor, parse_f64, show};
use crate::{IoError, TriMesh, atomic_write};
use isokit_field::mesh::pos_key;

/// Builds an indexed mesh from triangle soup, welding bit-identical positions.
struct Welder {
    map: HashMap<[u32; 3], u32>,
    mesh: TriMesh,
}

impl Welder {
    fn with_capacity(tris: usize) -> Self {
        Self {
            map: HashMap::with_capacity(tris / 2 + 1),
            mesh: TriMesh {
                positions: Vec::with_capacity(tris / 2 + 1),
                triangles: Vec::with_capacity(tris),
            },
        }
    }
    fn vertex(&mut self, p: Vec3) -> u32 {
        let n = self.mesh.positions.len() as u32;
        let positions = &mut self.mesh.positions;
        *self.map.entry(pos_key(p)).or_insert_with(|| {
            positions.push(p);
            n
        })
    }
    fn triangle(&mut self, t: [Vec3; 3]) {
        let tri = t.map(|p| self.vertex(p));
        self.mesh.triangles.push(tri);
    }
}

/// True when the bytes look like a binary STL: the triangle count in the header matches the
/// file length exactly (some binary files start with "solid" too).
pub(crate) fn is_binary_stl(bytes: &[u8]) -> bool {
    if bytes.len() < 84 {
        return false;
    }
    let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
    84 + 50 * n == bytes.len() as u64
}

pub(crate) fn read_stl(bytes: &[u8], path: &Path) -> Result<TriMesh, IoError> {
    if bytes.is_empty() {
        return Err(IoError::malformed(path, "STL file is empty"));
    }
    let starts_solid = bytes.trim_ascii_start().starts_with(b"solid");
    if is_binary_stl(bytes) || (!starts_solid && bytes.len() >= 84) {
        read_binary(bytes, path)
    } else if starts_solid {
        // A binary file whose header starts with "solid" and that carries trailing bytes:
        // fall back to binary when the text does not parse but the binary layout fits.
        read_ascii(bytes, path).or_else(|e| {
            let fits = bytes.len() >= 84 && {
                let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
                84 + 50 * n <= bytes.len() as u64
            };
            if fits && bytes.contains(&0) {
                read_binary(bytes, path)
            } else {
                Err(e)
            }
        })
    } else {
        Err(IoError::malformed(
            path,
            format!(
                "not an STL file: {} bytes is too short for binary STL and it does not start with \"solid\"",
                bytes.len()
            ),
        ))
    }
}

fn read_binary(bytes: &[u8], path: &Path) -> Result<TriMesh, IoError> {
    let mut c = Cursor::new(bytes, path, "binary STL");
    c.take(80)?;
    let n = c.u32_le()? as u64;
    let need = 84 + 50 * n;
    if need > bytes.len() as u64 {
        return Err(IoError::malformed(
            path,
            format!(
                "binary STL header promises {n} triangles ({need} bytes) but the file has {} bytes",
                bytes.len()
            ),
        ));
    }
    let mut w = Welder::with_capacity(n as usize);
    for _ in 0..n {
        let rec = c.take(50)?;
        let v = |k: usize| {
            let f = |o: usize| {
                let o = 12 + 12 * k + 4 * o;
                f32::from_le_bytes([rec[o], rec[o + 1], rec[o + 2], rec[o + 3]])
            };
            Vec3::new(f(0), f(1), f(2))
        };
        w.triangle([v(0), v(1), v(2)]);
    }
    Ok(w.mesh)
}

fn read_ascii(bytes: &[u8], path: &Path) -> Result<TriMesh, IoError> {
    // Skip the "solid <name>" line: the name may contain any word.
    let body = match bytes.iter().position(|&b| b == b'\n') {
        Some(p) => &bytes[p + 1..],
        None => &[][..],
    };
    let mut w = Welder::with_capacity(body.len() / 200);
    let mut toks = body
        .split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty());
    let mut loop_pts: Vec<Vec3> = Vec::with_capacity(3);
    let mut in_loop = false;
    let mut facets = 0usize;
    let mut ended = false;
    while let Some(t) = toks.next() {
        match t {
            b"vertex" => {
                if !in_loop {
                    return Err(IoError::malformed(
                        path,
                        format!(
                            "ASCII STL: 'vertex' outside 'outer loop' in facet {}",
                            facets + 1
                        ),
                    ));
                }
                let mut p = [0f32; 3];
                for x in &mut p {
                    let tok = toks.next().unwrap_or_default();
                    *x = parse_f64(tok).ok_or_else(|| {
                        IoError::malformed(
                            path,
                            format!(
                                "ASCII STL: facet {}: expected a coordinate, found {:?}",
                                facets + 1,
                                show(tok)
                            ),
                        )
                    })? as f32;
                }
                loop_pts.push(Vec3::from_array(p));
            }
            b"outer" => {
                if toks.next() != Some(b"loop") {
                    return Err(IoError::malformed(
                        path,
                        format!(
                            "ASCII STL: facet {}: 'outer' not followed by 'loop'",
                            facets + 1
                        ),
                    ));
                }
                in_loop = true;
                loop_pts.clear();
            }
            b"endloop" => {
                if !in_loop || loop_pts.len() < 3 {
                    return Err(IoError::malformed(
                        path,
                        format!(
                            "ASCII STL: facet {} has {} vertices (need 3)",
                            facets + 1,
                            loop_pts.len()
                        ),
                    ));
                }
                for k in 1..loop_pts.len() - 1 {
                    w.triangle([loop_pts[0], loop_pts[k], loop_pts[k + 1]]);
                }
                in_loop = false;
            }
            b"endfacet" => facets += 1,
            // Files may hold several solids one after the other: read them all.
            b"endsolid" => ended = true,
            // "facet normal nx ny nz", "solid name" of a further solid, names: skip.
            _ => {}
        }
    }
    if in_loop {
        return Err(IoError::malformed(
            path,
            format!("ASCII STL ends inside facet {}", facets + 1),
        ));
    }
    if !ended && w.mesh.triangles.is_empty() {
        return Err(IoError::malformed(
            path,
            "ASCII STL has no facets and no 'endsolid'",
        ));
    }
    Ok(w.mesh)
}

pub(crate) fn write_stl(path: &Path, mesh: &TriMesh, ascii: bool) -> Result<(), IoError> {
    crate::mesh::check_indices(mesh, path)?;
    if !ascii && mesh.triangles.len() > u32::MAX as usize {
        return Err(IoError::invalid_input(
            path,
            "binary STL holds at most 2^32 - 1 triangles",
        ));
    }
    let tri = |t: &[u32; 3]| t.map(|i| mesh.positions[i as usize]);
    atomic_write(path, |w| {
        if ascii {
            writeln!(w, "solid isokit")?;
            for t in &mesh.triangles {
                let [a, b, c] = tri(t);
                let n = face_normal(a, b, c);
                writeln!(w, "  facet normal {} {} {}", n.x, n.y, n.z)?;
                writeln!(w, "    outer loop")?;
                for p in [a, b, c] {
                    writeln!(w, "      vertex {} {} {}", p.x, p.y, p.z)?;
                }
                writeln!(w, "    endloop")?;
                writeln!(w, "  endfacet")?;
            }
            writeln!(w, "endsolid isokit")?;
        } else {
            let mut header = [b' '; 80];
            let msg = b"binary STL written by isokit";
            header[..msg.len()].copy_from_slice(msg);
            w.write_all(&header)?;
            w.write_all(&(mesh.triangles.len() as u32).to_le_bytes())?;
            let mut rec = [0u8; 50];
            for t in &mesh.triangles {
                let [a, b, c] = tri(t);
                let n = face_normal(a, b, c);
                for (k, v) in [n, a, b, c].iter().enumerate() {
                    for (j, x) in v.to_array().iter().enumerate() {
                        let o = 12 * k + 4 * j;
                        rec[o..o + 4].copy_from_slice(&x.to_le_bytes());
                    }
                }
                w.write_all(&rec)?;
            }
        }
        Ok(())
    })
}
