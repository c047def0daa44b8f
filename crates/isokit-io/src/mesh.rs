//! Triangle meshes: format dispatch, and the mesh readers' and writers' entry points (the
//! [`TriMesh`] type itself is `isokit-field`'s).

use std::path::Path;

use crate::util::{extension, read_file};
use crate::{IoError, TriMesh, gltf_read, gltf_write, obj, off, ply, stl};
use glam::Vec3;

/// The mesh file formats this crate reads, chosen by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MeshFormat {
    /// Wavefront OBJ (`.obj`): every vertex; polygons triangulated.
    Obj,
    /// glTF 2.0 JSON (`.gltf`) with embedded (data URI) or external buffers.
    Gltf,
    /// Binary glTF 2.0 (`.glb`).
    Glb,
    /// Stanford PLY (`.ply`): ASCII, binary little- and big-endian.
    Ply,
    /// STL (`.stl`): binary or ASCII.
    Stl,
    /// Object File Format (`.off`, also COFF/NOFF/CNOFF headers).
    Off,
}

impl MeshFormat {
    /// The extensions [`MeshFormat::from_path`] accepts, for messages.
    pub const EXTENSIONS: &'static str = ".obj, .gltf, .glb, .ply, .stl or .off";

    /// The format named by a path's extension (case-insensitive).
    pub fn from_path(path: &Path) -> Result<Self, IoError> {
        let ext = extension(path).unwrap_or_default();
        Ok(match ext.as_str() {
            "obj" => MeshFormat::Obj,
            "gltf" => MeshFormat::Gltf,
            "glb" => MeshFormat::Glb,
            "ply" => MeshFormat::Ply,
            "stl" => MeshFormat::Stl,
            "off" => MeshFormat::Off,
            _ => {
                return Err(IoError::UnknownFormat {
                    path: path.to_path_buf(),
                    expected: Self::EXTENSIONS,
                });
            }
        })
    }

    /// Whether [`write_mesh`] can write this format.
    pub fn can_write(self) -> bool {
        true
    }
}

/// Reads a triangle mesh, choosing the format by extension (see [`MeshFormat`]).
///
/// Polygons are triangulated (a fan, or levels of ears above 16 vertices). Every returned
/// index is in range. What each reader
/// supports:
/// - OBJ: `v` and `f` (any polygon, `v/vt/vn` forms, negative indices), all objects and
///   groups merged into one mesh; texture coordinates, normals, lines, points and materials
///   are ignored. Vertices are renumbered in order of first use by a face, so unreferenced
///   vertices are dropped.
/// - glTF/GLB: every triangle primitive (`TRIANGLES`, also strips and fans) reachable from
///   the default scene (the first scene when none is marked default; every mesh when there is
///   no scene), with node world transforms applied. Buffers come from the GLB binary chunk,
///   base64 data URIs or external files next to the glTF file. Positions must be f32 VEC3;
///   indices u8/u16/u32. Sparse accessors are refused.
/// - PLY: ASCII and binary of either byte order; vertex `x y z` of any numeric type; faces
///   from a `vertex_indices` (or `vertex_index`) list of any count/index type; all other
///   elements and properties are skipped.
/// - STL: binary or ASCII (binary when `84 + 50 n` equals the file length, even if the file
///   starts with `solid`); identical vertices are welded (by bit pattern; `-0.0 == 0.0`).
/// - OFF: `OFF`, `COFF`, `NOFF`, `CNOFF`, `STOFF`… headers (extra columns ignored), `#`
///   comments, counts on the header line or the next.
pub fn read_mesh(path: &Path) -> Result<TriMesh, IoError> {
    let format = MeshFormat::from_path(path)?;
    let bytes = read_file(path)?;
    read_mesh_from(&bytes, format, path)
}

/// Reads a mesh from bytes already in memory; `name` is used in messages (and, for glTF,
/// as the location that external buffer files are relative to).
pub fn read_mesh_bytes(bytes: &[u8], format: MeshFormat, name: &str) -> Result<TriMesh, IoError> {
    read_mesh_from(bytes, format, Path::new(name))
}

fn read_mesh_from(bytes: &[u8], format: MeshFormat, path: &Path) -> Result<TriMesh, IoError> {
    match format {
        MeshFormat::Obj => obj::read_obj(bytes, path),
        MeshFormat::Gltf | MeshFormat::Glb => gltf_read::read_gltf(bytes, path),
        MeshFormat::Ply => ply::read_ply_mesh(bytes, path),
        MeshFormat::Stl => stl::read_stl(bytes, path),
        MeshFormat::Off => off::read_off(bytes, path),
    }
}

/// Writes a mesh atomically, choosing the format by extension: `.obj` (`v` and `f` lines),
/// `.ply` (binary little-endian, with angle-weighted vertex normals `nx ny nz`), `.stl`
/// (binary), `.off`, `.glb` and `.gltf` (glTF 2.0 with `NORMAL`, one buffer: embedded as a
/// base64 data URI in `.gltf`).
///
/// Refuses (without touching the file) a mesh with an out-of-range index. See also
/// [`write_ply_ascii`] and [`write_stl_ascii`].
pub fn write_mesh(path: &Path, mesh: &TriMesh) -> Result<(), IoError> {
    match MeshFormat::from_path(path)? {
        MeshFormat::Obj => obj::write_obj(path, mesh),
        MeshFormat::Ply => ply::write_ply_mesh(path, mesh, false),
        MeshFormat::Stl => stl::write_stl(path, mesh, false),
        MeshFormat::Off => off::write_off(path, mesh),
        MeshFormat::Gltf => gltf_write::write_gltf(path, mesh, None, false),
        MeshFormat::Glb => gltf_write::write_gltf(path, mesh, None, true),
    }
}

/// Writes a mesh with an 8-bit sRGB colour per vertex where the format holds colours:
/// binary PLY (`red green blue`), glTF and GLB (`COLOR_0`, linear float); the other
/// formats are written by [`write_mesh`] without them.
pub fn write_mesh_colored(path: &Path, mesh: &TriMesh, colors: &[[u8; 3]]) -> Result<(), IoError> {
    match MeshFormat::from_path(path)? {
        MeshFormat::Ply => ply::write_ply_mesh_colored(path, mesh, Some(colors), false),
        MeshFormat::Gltf => gltf_write::write_gltf(path, mesh, Some(colors), false),
        MeshFormat::Glb => gltf_write::write_gltf(path, mesh, Some(colors), true),
        _ => write_mesh(path, mesh),
    }
}

/// Writes a binary PLY mesh with an sRGB colour per vertex (`property uchar red`, `green`,
/// `blue` after `x y z`) atomically; `colors` holds one per vertex (else an error, and the
/// file is not touched). The readers here ignore the colours.
pub fn write_ply_colored(path: &Path, mesh: &TriMesh, colors: &[[u8; 3]]) -> Result<(), IoError> {
    ply::write_ply_mesh_colored(path, mesh, Some(colors), false)
}

/// Reads a PLY mesh with the scalar face properties `names` (e.g. `region_front` and
/// `region_back`): the mesh and, per name, one value per triangle (a polygon's value for
/// each triangle it is cut into). A missing property is an error naming it.
pub fn read_ply_face_properties(
    path: &Path,
    names: &[&str],
) -> Result<(TriMesh, Vec<Vec<f64>>), IoError> {
    if MeshFormat::from_path(path)? != MeshFormat::Ply {
        return Err(IoError::UnknownFormat {
            path: path.to_path_buf(),
            expected: ".ply (face properties are read from PLY files)",
        });
    }
    let bytes = read_file(path)?;
    ply::read_ply_mesh_with(&bytes, path, names)
}

/// Writes a binary PLY mesh whose faces carry the two regions they separate, as `property
/// int region_a` and `property int region_b` after `vertex_indices` (`regions` holds one
/// pair per triangle, else an error and the file is not touched), atomically. Other PLY
/// readers (trimesh, Open3D, VTK) read the extra face properties or skip them; the readers
/// here skip them.
pub fn write_ply_regions(path: &Path, mesh: &TriMesh, regions: &[[i32; 2]]) -> Result<(), IoError> {
    ply::write_ply_mesh_regions(path, mesh, regions)
}

/// Writes an ASCII PLY mesh (`float x y z`, `list uchar int vertex_indices`) atomically.
pub fn write_ply_ascii(path: &Path, mesh: &TriMesh) -> Result<(), IoError> {
    ply::write_ply_mesh(path, mesh, true)
}

/// Writes an ASCII STL mesh atomically (facet normals computed from the vertices).
pub fn write_stl_ascii(path: &Path, mesh: &TriMesh) -> Result<(), IoError> {
    stl::write_stl(path, mesh, true)
}

/// Polygons with more vertices than this are triangulated by ear levels instead of a fan.
const FAN_LIMIT: usize = 16;

/// Triangulates a polygon given as indices, appending to `out`, keeping its orientation:
/// a fan around the first vertex for small polygons; above 16 vertices, by levels of ears
/// (triangles of three consecutive vertices, every other vertex cut off per level, until 16
/// remain and are fanned). A fan of thousands of slivers shares one vertex, which no spatial
/// index can separate (a 400,000-vertex polygon made every distance query test most of its
/// triangles); the ears of each level are local, and only the last few levels are large.
/// Both are the same surface for a planar convex polygon.
pub(crate) fn fan(poly: &[u32], out: &mut Vec<[u32; 3]>) {
    let fan_of = |ring: &[u32], out: &mut Vec<[u32; 3]>| {
        for w in 1..ring.len().saturating_sub(1) {
            out.push([ring[0], ring[w], ring[w + 1]]);
        }
    };
    if poly.len() <= FAN_LIMIT {
        fan_of(poly, out);
        return;
    }
    let mut ring = poly.to_vec();
    while ring.len() > FAN_LIMIT {
        let m = ring.len();
        let mut next = Vec::with_capacity(m / 2 + 2);
        let mut i = 0;
        while i + 2 < m {
            out.push([ring[i], ring[i + 1], ring[i + 2]]);
            next.push(ring[i]);
            i += 2;
        }
        next.extend_from_slice(&ring[i..]);
        ring = next;
    }
    fan_of(&ring, out);
}

/// A face normal (unit, or zero for a degenerate triangle).
pub(crate) fn face_normal(a: Vec3, b: Vec3, c: Vec3) -> Vec3 {
    (b - a).cross(c - a).normalize_or_zero()
}

/// Refuses a mesh whose indices are out of range (writers call this first).
pub(crate) fn check_indices(mesh: &TriMesh, path: &Path) -> Result<(), IoError> {
    match mesh.index_problem() {
        Some(m) => Err(IoError::invalid_input(path, m)),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn large_polygons_become_ear_levels_of_the_same_orientation() {
        for n in [3usize, 4, 16, 17, 18, 1001] {
            let poly: Vec<u32> = (0..n as u32).collect();
            let mut t = Vec::new();
            fan(&poly, &mut t);
            assert_eq!(t.len(), n - 2);
            // A regular polygon in the xy plane: every triangle faces +z, and they tile it.
            let p = |i: u32| {
                let a = std::f64::consts::TAU * f64::from(i) / n as f64;
                glam::DVec2::new(a.cos(), a.sin())
            };
            let mut area = 0.0;
            for [a, b, c] in &t {
                let cross = (p(*b) - p(*a)).perp_dot(p(*c) - p(*a));
                assert!(cross > 0.0, "{n}: {a} {b} {c}");
                area += 0.5 * cross;
            }
            let exact = 0.5 * n as f64 * (std::f64::consts::TAU / n as f64).sin();
            assert!((area - exact).abs() < 1e-9, "{n}: {area} vs {exact}");
            // No vertex is shared by a fan of slivers: one ear per level, then the last fan.
            let levels = (n as f64 / FAN_LIMIT as f64).log2().ceil().max(0.0) as usize;
            for v in 0..n as u32 {
                let k = t.iter().filter(|x| x.contains(&v)).count();
                assert!(
                    k <= 2 * levels + FAN_LIMIT,
                    "{n}: vertex {v} in {k} triangles"
                );
            }
        }
    }
}
