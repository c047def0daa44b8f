//! glTF 2.0 / GLB reader. The JSON is deserialized with `gltf-json`, but neither its
//! validation nor the `gltf` wrapper types are used (both index unchecked and can panic on
//! hostile files): every reference, buffer range and accessor is checked here by hand.
//! Buffers are resolved here too (GLB binary chunk, base64 data URIs, external files next
//! to the glTF file).

use std::path::{Path, PathBuf};

use base64::Engine;
use glam::{Mat4, Quat, Vec3};
use gltf::json::accessor::{ComponentType, GenericComponentType, Type};
use gltf::json::mesh::{Mode, Semantic};
use gltf::json::validation::Checked;
use gltf::json::{Accessor, Root};

use crate::util::read_referenced;
use crate::{IoError, TriMesh};

/// Instancing (one mesh under many nodes) may expand a small file into a huge mesh: refuse
/// more than this many output vertices.
const MAX_VERTICES: usize = 1 << 28;

/// Splits a GLB container into its JSON chunk and optional binary chunk.
fn parse_glb<'a>(bytes: &'a [u8], path: &Path) -> Result<(&'a [u8], Option<&'a [u8]>), IoError> {
    let bad = |msg: String| IoError::malformed(path, format!("GLB: {msg}"));
    let u32_at = |o: usize| -> Option<u32> {
        bytes
            .get(o..o + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let (Some(version), Some(length)) = (u32_at(4), u32_at(8)) else {
        return Err(bad("file ends inside the 12-byte header".into()));
    };
    if version != 2 {
        return Err(IoError::unsupported(
            path,
            format!("GLB version {version} (only 2 is read)"),
        ));
    }
    let length = length as usize;
    if length > bytes.len() || length < 12 {
        return Err(bad(format!(
            "header gives a length of {length} bytes but the file has {}",
            bytes.len()
        )));
    }
    let bytes = &bytes[..length];
    let mut pos = 12;
    let mut json = None;
    let mut bin = None;
    while pos < bytes.len() {
        let (Some(len), Some(ty)) = (u32_at(pos), u32_at(pos + 4)) else {
            return Err(bad(format!("truncated chunk header at offset {pos}")));
        };
        let start = pos + 8;
        let end = start
            .checked_add(len as usize)
            .filter(|&e| e <= bytes.len())
            .ok_or_else(|| {
                bad(format!(
                    "chunk at offset {pos} claims {len} bytes but only {} remain",
                    bytes.len().saturating_sub(start)
                ))
            })?;
        let data = &bytes[start..end];
        match &ty.to_le_bytes() {
            b"JSON" if json.is_none() => json = Some(data),
            b"BIN\0" if bin.is_none() && json.is_some() => bin = Some(data),
            _ => {} // unknown chunks are skipped, as the spec requires
        }
        pos = end;
    }
    let json = json.ok_or_else(|| bad("no JSON chunk".into()))?;
    Ok((json, bin))
}

/// Lazily loaded buffer data.
struct Buffers<'a> {
    data: Vec<Option<Vec<u8>>>,
    bin: Option<&'a [u8]>,
    path: &'a Path,
}

fn percent_decode(s: &str) -> Option<String> {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let h = std::str::from_utf8(b.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(h, 16).ok()?);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// An element of a JSON array by index, or an error naming what is missing.
fn get<'r, T>(list: &'r [T], i: usize, what: &str, path: &Path) -> Result<&'r T, IoError> {
    list.get(i).ok_or_else(|| {
        IoError::malformed(
            path,
            format!(
                "glTF refers to {what} {i}, but there are only {}",
                list.len()
            ),
        )
    })
}

impl Buffers<'_> {
    fn get(&mut self, root: &Root, i: usize) -> Result<&[u8], IoError> {
        let buffer = get(&root.buffers, i, "buffer", self.path)?;
        if self.data.len() <= i {
            self.data.resize(root.buffers.len(), None);
        }
        if self.data[i].is_none() {
            let loaded = self.load(buffer.uri.as_deref(), i, buffer.byte_length.0)?;
            if (loaded.len() as u64) < buffer.byte_length.0 {
                return Err(IoError::malformed(
                    self.path,
                    format!(
                        "glTF buffer {i} declares {} bytes but its data holds {}",
                        buffer.byte_length.0,
                        loaded.len()
                    ),
                ));
            }
            self.data[i] = Some(loaded);
        }
        Ok(self.data[i].as_deref().unwrap_or_default())
    }

    fn load(&self, uri: Option<&str>, i: usize, declared: u64) -> Result<Vec<u8>, IoError> {
        let Some(uri) = uri else {
            return self.bin.map(<[u8]>::to_vec).ok_or_else(|| {
                IoError::malformed(
                    self.path,
                    format!("glTF buffer {i} has no uri and there is no GLB binary chunk"),
                )
            });
        };
        if let Some(rest) = uri.strip_prefix("data:") {
            let Some((meta, payload)) = rest.split_once(',') else {
                return Err(IoError::malformed(
                    self.path,
                    format!("glTF buffer {i}: data URI without a comma"),
                ));
            };
            if !meta.ends_with(";base64") {
                return Err(IoError::unsupported(
                    self.path,
                    format!("glTF buffer {i}: data URI that is not base64"),
                ));
            }
            let engine = base64::engine::GeneralPurpose::new(
                &base64::alphabet::STANDARD,
                base64::engine::GeneralPurposeConfig::new()
                    .with_decode_padding_mode(base64::engine::DecodePaddingMode::Indifferent)
                    .with_decode_allow_trailing_bits(true),
            );
            engine.decode(payload.trim()).map_err(|e| {
                IoError::malformed(self.path, format!("glTF buffer {i}: bad base64 data ({e})"))
            })
        } else if uri.contains("://") {
            Err(IoError::unsupported(
                self.path,
                format!("glTF buffer {i}: remote URI {uri:?}"),
            ))
        } else {
            let rel = percent_decode(uri).ok_or_else(|| {
                IoError::malformed(self.path, format!("glTF buffer {i}: bad URI {uri:?}"))
            })?;
            let dir = self.path.parent().unwrap_or(Path::new(""));
            let file: PathBuf = dir.join(rel);
            // Exactly the declared bytes: a longer file (or a device) is not read further.
            read_referenced(
                self.path,
                &format!("glTF buffer {i}:"),
                &file,
                Some(declared),
            )
        }
    }
}

fn component(acc: &Accessor, i: usize, path: &Path) -> Result<(ComponentType, Type), IoError> {
    match (&acc.component_type, &acc.type_) {
        (Checked::Valid(GenericComponentType(c)), Checked::Valid(t)) => Ok((*c, *t)),
        _ => Err(IoError::malformed(
            path,
            format!("glTF accessor {i} has an invalid componentType or type"),
        )),
    }
}

fn component_size(c: ComponentType) -> usize {
    match c {
        ComponentType::I8 | ComponentType::U8 => 1,
        ComponentType::I16 | ComponentType::U16 => 2,
        ComponentType::U32 | ComponentType::F32 => 4,
    }
}

fn multiplicity(t: Type) -> usize {
    match t {
        Type::Scalar => 1,
        Type::Vec2 => 2,
        Type::Vec3 => 3,
        Type::Vec4 | Type::Mat2 => 4,
        Type::Mat3 => 9,
        Type::Mat4 => 16,
    }
}

/// The bytes of each element of accessor `i`, packed, bounds-checked against the buffer.
fn elements(
    root: &Root,
    buffers: &mut Buffers<'_>,
    i: usize,
    role: &str,
) -> Result<(Vec<u8>, usize), IoError> {
    let path = buffers.path;
    let acc = get(&root.accessors, i, "accessor", path)?;
    if acc.sparse.is_some() {
        return Err(IoError::unsupported(
            path,
            format!("sparse glTF accessor {i} ({role})"),
        ));
    }
    let Some(vi) = acc.buffer_view else {
        return Err(IoError::unsupported(
            path,
            format!("glTF accessor {i} ({role}) has no bufferView"),
        ));
    };
    let vi = vi.value();
    let view = get(&root.buffer_views, vi, "bufferView", path)?;
    let (c, t) = component(acc, i, path)?;
    let elem = component_size(c) * multiplicity(t);
    let stride = match view.byte_stride {
        Some(s) if s.0 > 0 => s.0,
        _ => elem,
    };
    if stride < elem {
        return Err(IoError::malformed(
            path,
            format!("glTF bufferView {vi} stride {stride} is below the element size {elem}"),
        ));
    }
    let buf = buffers.get(root, view.buffer.value())?;
    let vstart = view.byte_offset.map_or(0, |o| o.0);
    let vlen = view.byte_length.0;
    let vdata = vstart
        .checked_add(vlen)
        .filter(|&e| e <= buf.len() as u64)
        .map(|e| &buf[vstart as usize..e as usize])
        .ok_or_else(|| {
            IoError::malformed(
                path,
                format!(
                    "glTF bufferView {vi} ({vlen} bytes at offset {vstart}) lies outside its buffer of {} bytes",
                    buf.len()
                ),
            )
        })?;
    let count = acc.count.0;
    if count == 0 {
        return Ok((Vec::new(), elem));
    }
    let offset = acc.byte_offset.map_or(0, |o| o.0);
    let need = (count - 1)
        .checked_mul(stride as u64)
        .and_then(|v| v.checked_add(elem as u64))
        .and_then(|v| v.checked_add(offset));
    if need.is_none_or(|n| n > vdata.len() as u64) {
        return Err(IoError::malformed(
            path,
            format!(
                "glTF accessor {i} ({role}): {count} elements of {elem} bytes (stride {stride}) at offset {offset} do not fit bufferView {vi} of {} bytes",
                vdata.len()
            ),
        ));
    }
    // All of count * stride fits in memory already (it fits in the view), so no overflow.
    let (count, offset) = (count as usize, offset as usize);
    let mut out = Vec::with_capacity(count * elem);
    for k in 0..count {
        let o = offset + k * stride;
        out.extend_from_slice(&vdata[o..o + elem]);
    }
    Ok((out, elem))
}

fn read_positions(root: &Root, b: &mut Buffers<'_>, i: usize) -> Result<Vec<Vec3>, IoError> {
    let acc = get(&root.accessors, i, "accessor", b.path)?;
    let (c, t) = component(acc, i, b.path)?;
    if c != ComponentType::F32 || t != Type::Vec3 || acc.normalized {
        return Err(IoError::unsupported(
            b.path,
            format!("glTF POSITION accessor {i} is {c:?} {t:?} (only f32 VEC3 is read)"),
        ));
    }
    let (bytes, _) = elements(root, b, i, "POSITION")?;
    Ok(bytes
        .chunks_exact(12)
        .map(|c| {
            let f = |o: usize| f32::from_le_bytes([c[o], c[o + 1], c[o + 2], c[o + 3]]);
            Vec3::new(f(0), f(4), f(8))
        })
        .collect())
}

fn read_indices(root: &Root, b: &mut Buffers<'_>, i: usize) -> Result<Vec<u32>, IoError> {
    let acc = get(&root.accessors, i, "accessor", b.path)?;
    let (c, t) = component(acc, i, b.path)?;
    if t != Type::Scalar {
        return Err(IoError::malformed(
            b.path,
            format!("glTF index accessor {i} is {t:?}, not SCALAR"),
        ));
    }
    let (bytes, elem) = elements(root, b, i, "indices")?;
    Ok(match c {
        ComponentType::U8 => bytes.iter().map(|&v| v as u32).collect(),
        ComponentType::U16 => bytes
            .chunks_exact(elem)
            .map(|c| u16::from_le_bytes([c[0], c[1]]) as u32)
            .collect(),
        ComponentType::U32 => bytes
            .chunks_exact(elem)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect(),
        other => {
            return Err(IoError::malformed(
                b.path,
                format!(
                    "glTF index accessor {i} has component type {other:?} (need u8, u16 or u32)"
                ),
            ));
        }
    })
}

fn add_mesh(
    root: &Root,
    b: &mut Buffers<'_>,
    mi: usize,
    world: Mat4,
    out: &mut TriMesh,
) -> Result<(), IoError> {
    let mesh = get(&root.meshes, mi, "mesh", b.path)?;
    let flip = world.determinant() < 0.0;
    for (pi, prim) in mesh.primitives.iter().enumerate() {
        let mode = match prim.mode {
            Checked::Valid(m) => m,
            Checked::Invalid => {
                return Err(IoError::malformed(
                    b.path,
                    format!("glTF mesh {mi} primitive {pi} has an invalid mode"),
                ));
            }
        };
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            continue;
        }
        let Some(pacc) = prim.attributes.get(&Checked::Valid(Semantic::Positions)) else {
            return Err(IoError::malformed(
                b.path,
                format!("glTF mesh {mi} primitive {pi} has no POSITION"),
            ));
        };
        let positions = read_positions(root, b, pacc.value())?;
        let nv = positions.len();
        let idx: Vec<u32> = match prim.indices {
            Some(a) => read_indices(root, b, a.value())?,
            None => (0..nv as u32).collect(),
        };
        if let Some(&bad) = idx.iter().find(|&&i| i as usize >= nv) {
            return Err(IoError::malformed(
                b.path,
                format!("glTF mesh {mi} primitive {pi}: index {bad} out of range ({nv} vertices)"),
            ));
        }
        if out.positions.len() + nv > MAX_VERTICES {
            return Err(IoError::unsupported(
                b.path,
                format!("glTF scene expands to more than {MAX_VERTICES} vertices"),
            ));
        }
        let base = out.positions.len() as u32;
        out.positions
            .extend(positions.iter().map(|&p| world.transform_point3(p)));
        let mut push = |t: [u32; 3]| {
            let t = if flip { [t[0], t[2], t[1]] } else { t };
            out.triangles.push(t.map(|i| i + base));
        };
        let n = idx.len();
        match mode {
            Mode::Triangles => idx.chunks_exact(3).for_each(|c| push([c[0], c[1], c[2]])),
            Mode::TriangleStrip => {
                for i in 0..n.saturating_sub(2) {
                    let (a, c) = if i % 2 == 0 {
                        (i + 1, i + 2)
                    } else {
                        (i + 2, i + 1)
                    };
                    push([idx[i], idx[a], idx[c]]);
                }
            }
            _ => {
                for i in 1..n.saturating_sub(1) {
                    push([idx[0], idx[i], idx[i + 1]]);
                }
            }
        }
    }
    Ok(())
}

fn local_transform(node: &gltf::json::Node) -> Mat4 {
    if let Some(m) = node.matrix {
        return Mat4::from_cols_array(&m);
    }
    let t = Vec3::from_array(node.translation.unwrap_or([0.0; 3]));
    let s = Vec3::from_array(node.scale.unwrap_or([1.0; 3]));
    let q = node
        .rotation
        .map_or(Quat::IDENTITY, |r| Quat::from_array(r.0));
    let len = q.length();
    let q = if len.is_finite() && len > 0.0 {
        q / len
    } else {
        Quat::IDENTITY
    };
    Mat4::from_scale_rotation_translation(s, q, t)
}

pub(crate) fn read_gltf(bytes: &[u8], path: &Path) -> Result<TriMesh, IoError> {
    if bytes.is_empty() {
        return Err(IoError::malformed(path, "glTF file is empty"));
    }
    let (json, bin) = if bytes.starts_with(b"glTF") {
        parse_glb(bytes, path)?
    } else {
        (bytes, None)
    };
    let root: Root = gltf::json::deserialize::from_slice(json)
        .map_err(|e| IoError::malformed(path, format!("glTF JSON cannot be parsed: {e}")))?;
    let mut buffers = Buffers {
        data: Vec::new(),
        bin,
        path,
    };
    let mut out = TriMesh::default();
    let scene = match root.scene {
        Some(s) => Some(get(&root.scenes, s.value(), "scene", path)?),
        None => root.scenes.first(),
    };
    match scene {
        Some(scene) => {
            let mut visited = vec![false; root.nodes.len()];
            let mut stack: Vec<(usize, Mat4)> = scene
                .nodes
                .iter()
                .rev()
                .map(|n| (n.value(), Mat4::IDENTITY))
                .collect();
            while let Some((ni, parent)) = stack.pop() {
                let node = get(&root.nodes, ni, "node", path)?;
                if std::mem::replace(&mut visited[ni], true) {
                    return Err(IoError::malformed(
                        path,
                        format!(
                            "glTF node {ni} is reached twice: the node hierarchy must be a tree"
                        ),
                    ));
                }
                let world = parent * local_transform(node);
                if let Some(m) = node.mesh {
                    add_mesh(&root, &mut buffers, m.value(), world, &mut out)?;
                }
                if let Some(children) = &node.children {
                    stack.extend(children.iter().rev().map(|c| (c.value(), world)));
                }
            }
        }
        None => {
            for mi in 0..root.meshes.len() {
                add_mesh(&root, &mut buffers, mi, Mat4::IDENTITY, &mut out)?;
            }
        }
    }
    Ok(out)
}
