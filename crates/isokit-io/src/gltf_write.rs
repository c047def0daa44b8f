//! glTF 2.0 writer (`.glb` binary container and `.gltf` JSON with the buffer embedded as a
//! base64 data URI): one mesh, one primitive of triangles with `POSITION`, `NORMAL`
//! (angle-weighted vertex normals) and, when given, `COLOR_0`, indexed by `u32`, all in one
//! binary buffer. Follows the glTF 2.0 specification (Khronos, 2021): §3.6 (buffers, buffer
//! views and accessors: 4-byte alignment, `min`/`max` required on `POSITION`), §3.7.2.1
//! (attribute semantics: `COLOR_0` is linear RGB) and §4.4 (the GLB container: 12-byte
//! header, a JSON chunk padded with spaces, a BIN chunk padded with zeros).

use std::path::Path;

use base64::Engine;
use glam::Vec3;
use serde_json::{Value, json};

use crate::{IoError, TriMesh, atomic_write, srgb8_to_linear};

const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const TRIANGLES: u32 = 4;

/// Angle-weighted vertex normals (Thürmer and Wüthrich, "Computing vertex normals from
/// polygonal meshes", 1998): each triangle adds its unit normal times its angle at the
/// vertex. A vertex of no non-degenerate triangle gets the zero vector.
pub fn vertex_normals(mesh: &TriMesh) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; mesh.positions.len()];
    let p = &mesh.positions;
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| p.get(i as usize).copied().unwrap_or(Vec3::NAN));
        let face = (b - a).cross(c - a).normalize_or_zero();
        if face == Vec3::ZERO {
            continue;
        }
        for (k, (u, v, w)) in [(a, b, c), (b, c, a), (c, a, b)].into_iter().enumerate() {
            let angle = (v - u).angle_between(w - u);
            if let Some(slot) = n.get_mut(t[k] as usize)
                && angle.is_finite()
            {
                *slot += face * angle;
            }
        }
    }
    n.iter_mut().for_each(|v| *v = v.normalize_or_zero());
    n
}

/// The glTF JSON document and its binary buffer for `mesh` (colours: one 8-bit sRGB triple
/// per vertex, written as linear float `COLOR_0`).
fn document(
    mesh: &TriMesh,
    colors: Option<&[[u8; 3]]>,
    path: &Path,
) -> Result<(Value, Vec<u8>), IoError> {
    crate::mesh::check_indices(mesh, path)?;
    let n = mesh.positions.len();
    if let Some(c) = colors
        && c.len() != n
    {
        return Err(IoError::invalid_input(
            path,
            format!("{} vertex colours for {n} vertices", c.len()),
        ));
    }
    let asset = json!({"version": "2.0", "generator": "isokit"});
    if mesh.triangles.is_empty() {
        // One empty node: glTF has no empty primitive (every accessor holds one element).
        return Ok((
            json!({"asset": asset, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{}]}),
            Vec::new(),
        ));
    }
    if let Some(i) = mesh.positions.iter().position(|p| !p.is_finite()) {
        return Err(IoError::invalid_input(
            path,
            format!("vertex {i} is not finite: glTF stores finite positions only"),
        ));
    }
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut push_view = |bin: &mut Vec<u8>, bytes: &[u8], target: u32| {
        let offset = bin.len();
        bin.extend_from_slice(bytes);
        views.push(
            json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len(), "target": target}),
        );
        views.len() - 1
    };
    let floats =
        |v: &mut dyn Iterator<Item = f32>| -> Vec<u8> { v.flat_map(|x| x.to_le_bytes()).collect() };
    let (lo, hi) = mesh
        .positions
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    let pos = floats(&mut mesh.positions.iter().flat_map(|p| p.to_array()));
    let v = push_view(&mut bin, &pos, ARRAY_BUFFER);
    accessors.push(
        json!({"bufferView": v, "componentType": FLOAT, "count": n, "type": "VEC3",
        "min": lo.to_array(), "max": hi.to_array()}),
    );
    let normals = vertex_normals(mesh);
    let nrm = floats(&mut normals.iter().flat_map(|p| p.to_array()));
    let v = push_view(&mut bin, &nrm, ARRAY_BUFFER);
    accessors.push(json!({"bufferView": v, "componentType": FLOAT, "count": n, "type": "VEC3"}));
    let mut attributes = json!({"POSITION": 0, "NORMAL": 1});
    if let Some(c) = colors {
        let lin = floats(&mut c.iter().flat_map(|rgb| rgb.map(srgb8_to_linear)));
        let v = push_view(&mut bin, &lin, ARRAY_BUFFER);
        accessors
            .push(json!({"bufferView": v, "componentType": FLOAT, "count": n, "type": "VEC3"}));
        attributes["COLOR_0"] = json!(accessors.len() - 1);
    }
    let idx: Vec<u8> = mesh
        .triangles
        .iter()
        .flat_map(|t| t.iter().flat_map(|i| i.to_le_bytes()))
        .collect();
    let v = push_view(&mut bin, &idx, ELEMENT_ARRAY_BUFFER);
    accessors.push(json!({"bufferView": v, "componentType": UNSIGNED_INT,
        "count": 3 * mesh.triangles.len(), "type": "SCALAR"}));
    let doc = json!({
        "asset": asset,
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": attributes, "indices": accessors.len() - 1, "mode": TRIANGLES}]}],
        "buffers": [{"byteLength": bin.len()}],
        "bufferViews": views,
        "accessors": accessors,
    });
    Ok((doc, bin))
}

/// Writes `mesh` atomically as glTF 2.0: binary `.glb` when `binary`, else `.gltf` with the
/// buffer embedded as a base64 data URI. `colors` (8-bit sRGB per vertex) become a linear
/// float `COLOR_0`. An empty mesh gives a scene of one node without a mesh.
pub(crate) fn write_gltf(
    path: &Path,
    mesh: &TriMesh,
    colors: Option<&[[u8; 3]]>,
    binary: bool,
) -> Result<(), IoError> {
    let (mut doc, bin) = document(mesh, colors, path)?;
    if !binary {
        if !bin.is_empty() {
            let data = base64::engine::general_purpose::STANDARD.encode(&bin);
            doc["buffers"][0]["uri"] =
                json!(format!("data:application/octet-stream;base64,{data}"));
        }
        let text = doc.to_string();
        return atomic_write(path, |w| w.write_all(text.as_bytes()));
    }
    let mut text = doc.to_string().into_bytes();
    text.resize(text.len().next_multiple_of(4), b' ');
    let bin_chunk = bin.len().next_multiple_of(4);
    let total = 12 + 8 + text.len() + if bin.is_empty() { 0 } else { 8 + bin_chunk };
    let total = u32::try_from(total).map_err(|_| {
        IoError::invalid_input(path, format!("{total} bytes: over GLB's 4 GiB limit"))
    })?;
    atomic_write(path, |w| {
        w.write_all(b"glTF")?;
        w.write_all(&2u32.to_le_bytes())?;
        w.write_all(&total.to_le_bytes())?;
        w.write_all(&(text.len() as u32).to_le_bytes())?;
        w.write_all(b"JSON")?;
        w.write_all(&text)?;
        if !bin.is_empty() {
            w.write_all(&(bin_chunk as u32).to_le_bytes())?;
            w.write_all(b"BIN\0")?;
            w.write_all(&bin)?;
            w.write_all(&vec![0u8; bin_chunk - bin.len()])?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normals_of_a_sphere_point_outwards() {
        let m = crate::generate::icosphere(Vec3::ZERO, 1.0, 2);
        for (p, n) in m.positions.iter().zip(vertex_normals(&m)) {
            assert!((n - p.normalize()).length() < 0.05, "{p} {n}");
        }
    }

    #[test]
    fn glb_round_trips_through_the_reader() {
        let d = std::env::temp_dir().join(format!("isokit-gltf-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let m = crate::generate::icosphere(Vec3::ZERO, 1.0, 1);
        let colors: Vec<[u8; 3]> = (0..m.positions.len()).map(|i| [i as u8, 40, 200]).collect();
        for (name, binary) in [("m.glb", true), ("m.gltf", false)] {
            let p = d.join(name);
            write_gltf(&p, &m, Some(&colors), binary).unwrap();
            let back = crate::read_mesh(&p).unwrap();
            assert_eq!(back.positions, m.positions);
            assert_eq!(back.triangles, m.triangles);
        }
        let bytes = std::fs::read(d.join("m.glb")).unwrap();
        assert_eq!(&bytes[..4], b"glTF");
        assert_eq!(bytes.len() % 4, 0);
        assert_eq!(
            u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize,
            bytes.len()
        );
        let empty = TriMesh::new(vec![], vec![]);
        write_gltf(&d.join("e.glb"), &empty, None, true).unwrap();
        let back = crate::read_mesh(&d.join("e.glb")).unwrap();
        assert!(back.triangles.is_empty());
        let bad = TriMesh::new(vec![Vec3::NAN; 3], vec![[0, 1, 2]]);
        assert!(write_gltf(&d.join("b.glb"), &bad, None, true).is_err());
        assert!(write_gltf(&d.join("c.glb"), &m, Some(&colors[1..]), true).is_err());
        std::fs::remove_dir_all(&d).unwrap();
    }
}
