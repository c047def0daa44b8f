//! Stanford PLY: ASCII and binary (both byte orders) reading of meshes and point clouds,
//! binary little-endian and ASCII writing.

use std::path::Path;

use glam::Vec3;

use crate::mesh::fan;
use crate::util::{Cursor, Endian, Scalar, parse_f64, show};
use crate::{IoError, PointCloud, TriMesh, atomic_write};

#[derive(Clone, Copy, Debug, PartialEq)]
enum Format {
    Ascii,
    Binary(Endian),
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Clone, Debug)]
struct Property {
    name: String,
    kind: Kind,
}

#[derive(Clone, Debug)]
pub(crate) struct Element {
    name: String,
    pub(crate) count: usize,
    props: Vec<Property>,
}

impl Element {
    /// Fewest bytes one instance takes in a binary file.
    fn min_size(&self) -> usize {
        self.props
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(s) => s.size(),
                Kind::List { count, .. } => count.size(),
            })
            .sum()
    }
    fn find(&self, name: &str) -> Option<usize> {
        self.props.iter().position(|p| p.name == name)
    }
}

pub(crate) struct Header {
    format: Format,
    pub(crate) elements: Vec<Element>,
    body: usize,
}

impl Header {
    pub(crate) fn face_count(&self) -> usize {
        self.elements
            .iter()
            .filter(|e| e.name == "face")
            .map(|e| e.count)
            .sum()
    }
}

fn scalar_type(name: &str) -> Option<Scalar> {
    Some(match name {
        "char" | "int8" => Scalar::I8,
        "uchar" | "uint8" => Scalar::U8,
        "short" | "int16" => Scalar::I16,
        "ushort" | "uint16" => Scalar::U16,
        "int" | "int32" => Scalar::I32,
        "uint" | "uint32" => Scalar::U32,
        "int64" | "long" => Scalar::I64,
        "uint64" | "ulong" => Scalar::U64,
        "float" | "float32" => Scalar::F32,
        "double" | "float64" => Scalar::F64,
        _ => return None,
    })
}

/// Parses the header (everything up to and including `end_header`).
pub(crate) fn parse_header(bytes: &[u8], path: &Path) -> Result<Header, IoError> {
    let bad = |line: usize, msg: String| {
        IoError::malformed(path, format!("PLY header line {line}: {msg}"))
    };
    let mut pos = 0;
    let mut line_no = 0;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some(nl) = bytes[pos..].iter().position(|&b| b == b'\n') else {
            return Err(IoError::malformed(
                path,
                if line_no == 0 && bytes.is_empty() {
                    "PLY file is empty".to_string()
                } else {
                    "PLY header has no end_header line".to_string()
                },
            ));
        };
        let raw = &bytes[pos..pos + nl];
        pos += nl + 1;
        line_no += 1;
        let line = std::str::from_utf8(raw)
            .map_err(|_| bad(line_no, "not ASCII text".into()))?
            .trim();
        let mut w = line.split_whitespace();
        let key = w.next().unwrap_or("");
        if line_no == 1 {
            if line != "ply" {
                return Err(IoError::malformed(
                    path,
                    format!(
                        "not a PLY file: first line is {:?}, expected \"ply\"",
                        show(raw)
                    ),
                ));
            }
            continue;
        }
        match key {
            "format" => {
                let f = match w.next() {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::Binary(Endian::Little),
                    Some("binary_big_endian") => Format::Binary(Endian::Big),
                    other => {
                        return Err(bad(line_no, format!("unknown format {other:?}")));
                    }
                };
                format = Some(f);
            }
            "comment" | "obj_info" | "" => {}
            "element" => {
                let name = w
                    .next()
                    .ok_or_else(|| bad(line_no, "element without a name".into()))?;
                let count = w
                    .next()
                    .and_then(|c| c.parse::<usize>().ok())
                    .ok_or_else(|| {
                        bad(
                            line_no,
                            format!("element {name} needs a non-negative count"),
                        )
                    })?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            "property" => {
                let Some(el) = elements.last_mut() else {
                    return Err(bad(line_no, "property before any element".into()));
                };
                let t = w.next().unwrap_or("");
                let kind = if t == "list" {
                    let (Some(c), Some(i)) = (w.next(), w.next()) else {
                        return Err(bad(
                            line_no,
                            "list property needs count and item types".into(),
                        ));
                    };
                    let count = scalar_type(c).filter(|s| s.is_integer());
                    let item = scalar_type(i);
                    match (count, item) {
                        (Some(count), Some(item)) => Kind::List { count, item },
                        _ => return Err(bad(line_no, format!("unknown list types {c} {i}"))),
                    }
                } else {
                    Kind::Scalar(
                        scalar_type(t)
                            .ok_or_else(|| bad(line_no, format!("unknown property type {t:?}")))?,
                    )
                };
                let name = w
                    .next()
                    .ok_or_else(|| bad(line_no, "property without a name".into()))?;
                el.props.push(Property {
                    name: name.to_string(),
                    kind,
                });
            }
            "end_header" => break,
            other => return Err(bad(line_no, format!("unknown keyword {other:?}"))),
        }
    }
    let format = format.ok_or_else(|| IoError::malformed(path, "PLY header has no format line"))?;
    // An element with instances but no properties takes no bytes: its count could never be
    // checked against the data (and reading it would loop `count` times over nothing).
    if let Some(e) = elements.iter().find(|e| e.count > 0 && e.props.is_empty()) {
        return Err(IoError::malformed(
            path,
            format!(
                "PLY element {} has {} instances but no properties",
                e.name, e.count
            ),
        ));
    }
    Ok(Header {
        format,
        elements,
        body: pos,
    })
}

/// The values of the body, ASCII or binary.
enum Body<'a> {
    Ascii {
        toks: Box<dyn Iterator<Item = &'a [u8]> + 'a>,
        path: &'a Path,
    },
    Binary(Cursor<'a>, Endian),
}

impl Body<'_> {
    fn next(&mut self, t: Scalar, ctx: &dyn Fn() -> String) -> Result<f64, IoError> {
        match self {
            Body::Binary(c, e) => {
                let e = *e;
                c.scalar(t, e).map_err(|_| {
                    IoError::malformed(c.path, format!("PLY data ends early ({})", ctx()))
                })
            }
            Body::Ascii { toks, path } => {
                let Some(tok) = toks.next() else {
                    return Err(IoError::malformed(
                        path,
                        format!("PLY data ends early ({})", ctx()),
                    ));
                };
                parse_f64(tok).ok_or_else(|| {
                    IoError::malformed(
                        path,
                        format!("PLY: {:?} is not a number ({})", show(tok), ctx()),
                    )
                })
            }
        }
    }

    fn skip_bytes(&mut self, n: usize) -> Result<(), IoError> {
        if let Body::Binary(c, _) = self {
            c.take(n)?;
        }
        Ok(())
    }
}

fn list_len(v: f64, path: &Path, ctx: &dyn Fn() -> String) -> Result<usize, IoError> {
    if v >= 0.0 && v.fract() == 0.0 && v <= u32::MAX as f64 {
        Ok(v as usize)
    } else {
        Err(IoError::malformed(
            path,
            format!("PLY: list length {v} is invalid ({})", ctx()),
        ))
    }
}

struct PlyData {
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
    triangles: Vec<[u32; 3]>,
    /// Per requested face property, its value for each triangle (a polygon's for each of
    /// the triangles it is cut into).
    face_values: Vec<Vec<f64>>,
}

fn read_ply(bytes: &[u8], path: &Path, want_faces: bool) -> Result<PlyData, IoError> {
    read_ply_with(bytes, path, want_faces, &[])
}

fn read_ply_with(
    bytes: &[u8],
    path: &Path,
    want_faces: bool,
    face_props: &[&str],
) -> Result<PlyData, IoError> {
    let header = parse_header(bytes, path)?;
    let body_bytes = &bytes[header.body.min(bytes.len())..];
    let remaining = body_bytes.len();

    // Refuse headers promising more than the file holds before allocating anything.
    let mut need: u128 = 0;
    for e in &header.elements {
        let per = match header.format {
            Format::Binary(_) => e.min_size(),
            Format::Ascii => 2 * e.props.len(),
        };
        need += e.count as u128 * per as u128;
    }
    if need > remaining as u128 + 1 {
        let counts: Vec<String> = header
            .elements
            .iter()
            .map(|e| format!("{} {}", e.count, e.name))
            .collect();
        return Err(IoError::malformed(
            path,
            format!(
                "PLY header promises {} (at least {need} bytes of data) but only {remaining} bytes follow",
                counts.join(", ")
            ),
        ));
    }

    let mut body = match header.format {
        Format::Ascii => Body::Ascii {
            toks: Box::new(
                body_bytes
                    .split(|b| b.is_ascii_whitespace())
                    .filter(|t| !t.is_empty()),
            ),
            path,
        },
        Format::Binary(e) => Body::Binary(Cursor::new(body_bytes, path, "binary PLY"), e),
    };

    let mut positions: Option<Vec<Vec3>> = None;
    let mut normals: Option<Vec<Vec3>> = None;
    let mut triangles = Vec::new();
    let mut poly: Vec<u32> = Vec::new();
    let mut face_values: Vec<Vec<f64>> = vec![Vec::new(); face_props.len()];

    for e in &header.elements {
        let is_vertex = e.name == "vertex" && positions.is_none();
        let is_face = want_faces && e.name == "face";
        if !is_vertex && !is_face {
            // Skip: fixed-size binary elements in one step, others value by value.
            if let (Format::Binary(_), true) = (
                header.format,
                e.props.iter().all(|p| matches!(p.kind, Kind::Scalar(_))),
            ) {
                body.skip_bytes(e.count * e.min_size())?;
                continue;
            }
            for i in 0..e.count {
                let ctx = || format!("element {} {i}", e.name);
                for p in &e.props {
                    match p.kind {
                        Kind::Scalar(t) => {
                            body.next(t, &ctx)?;
                        }
                        Kind::List { count, item } => {
                            let n = list_len(body.next(count, &ctx)?, path, &ctx)?;
                            if let Body::Binary(..) = body {
                                body.skip_bytes(n * item.size())?;
                            } else {
                                for _ in 0..n {
                                    body.next(item, &ctx)?;
                                }
                            }
                        }
                    }
                }
            }
            continue;
        }
        let cap = e.count.min(remaining / 2 + 1);
        if is_vertex {
            let scalar_at = |name: &str| -> Result<Option<usize>, IoError> {
                match e.find(name) {
                    Some(i) if matches!(e.props[i].kind, Kind::Scalar(_)) => Ok(Some(i)),
                    Some(_) => Err(IoError::malformed(
                        path,
                        format!("PLY: vertex property {name} is a list"),
                    )),
                    None => Ok(None),
                }
            };
            let (Some(ix), Some(iy), Some(iz)) =
                (scalar_at("x")?, scalar_at("y")?, scalar_at("z")?)
            else {
                return Err(IoError::malformed(
                    path,
                    "PLY vertex element lacks x, y or z",
                ));
            };
            let nidx = match (scalar_at("nx")?, scalar_at("ny")?, scalar_at("nz")?) {
                (Some(a), Some(b), Some(c)) => Some([a, b, c]),
                _ => None,
            };
            let mut pos = Vec::with_capacity(cap);
            let mut nor = nidx.map(|_| Vec::with_capacity(cap));
            let mut vals = vec![0f64; e.props.len()];
            for i in 0..e.count {
                let ctx = || format!("vertex {i}");
                for (k, p) in e.props.iter().enumerate() {
                    match p.kind {
                        Kind::Scalar(t) => vals[k] = body.next(t, &ctx)?,
                        Kind::List { count, item } => {
                            let n = list_len(body.next(count, &ctx)?, path, &ctx)?;
                            for _ in 0..n {
                                body.next(item, &ctx)?;
                            }
                        }
                    }
                }
                pos.push(Vec3::new(vals[ix] as f32, vals[iy] as f32, vals[iz] as f32));
                if let (Some(n), Some([a, b, c])) = (nor.as_mut(), nidx) {
                    n.push(Vec3::new(vals[a] as f32, vals[b] as f32, vals[c] as f32));
                }
            }
            positions = Some(pos);
            normals = nor;
        } else {
            let li = e
                .find("vertex_indices")
                .or_else(|| e.find("vertex_index"))
                .filter(|&i| matches!(e.props[i].kind, Kind::List { .. }))
                .ok_or_else(|| {
                    IoError::malformed(path, "PLY face element has no vertex_indices list")
                })?;
            let wanted: Vec<usize> = face_props
                .iter()
                .map(|name| {
                    e.find(name)
                        .filter(|&i| matches!(e.props[i].kind, Kind::Scalar(_)))
                        .ok_or_else(|| {
                            IoError::malformed(
                                path,
                                format!("PLY face element has no scalar property {name}"),
                            )
                        })
                })
                .collect::<Result<_, _>>()?;
            let mut vals = vec![0f64; e.props.len()];
            triangles.reserve(cap);
            for i in 0..e.count {
                let ctx = || format!("face {i}");
                let before = triangles.len();
                for (k, p) in e.props.iter().enumerate() {
                    match p.kind {
                        Kind::Scalar(t) => {
                            vals[k] = body.next(t, &ctx)?;
                        }
                        Kind::List { count, item } => {
                            let n = list_len(body.next(count, &ctx)?, path, &ctx)?;
                            if k != li {
                                for _ in 0..n {
                                    body.next(item, &ctx)?;
                                }
                                continue;
                            }
                            poly.clear();
                            for _ in 0..n {
                                let v = body.next(item, &ctx)?;
                                if !(v >= 0.0 && v.fract() == 0.0 && v <= u32::MAX as f64) {
                                    return Err(IoError::malformed(
                                        path,
                                        format!("PLY face {i}: vertex index {v} is invalid"),
                                    ));
                                }
                                poly.push(v as u32);
                            }
                            fan(&poly, &mut triangles);
                        }
                    }
                }
                for (out, &k) in face_values.iter_mut().zip(&wanted) {
                    out.extend(std::iter::repeat_n(vals[k], triangles.len() - before));
                }
            }
        }
    }

    let positions = positions.unwrap_or_default();
    let nv = positions.len();
    if let Some((i, t)) = triangles
        .iter()
        .enumerate()
        .find(|(_, t)| t.iter().any(|&v| v as usize >= nv))
    {
        return Err(IoError::malformed(
            path,
            format!("PLY triangle {i} {t:?} refers to a vertex beyond the {nv} vertices"),
        ));
    }
    if !face_props.is_empty() && !header.elements.iter().any(|e| e.name == "face") {
        return Err(IoError::malformed(path, "PLY file has no face element"));
    }
    Ok(PlyData {
        positions,
        normals,
        triangles,
        face_values,
    })
}

/// A PLY mesh and, for each name in `face_props`, the value of that scalar face property
/// for each triangle (a polygon's value repeated for each triangle it is cut into); a
/// missing property is an error naming it.
pub(crate) fn read_ply_mesh_with(
    bytes: &[u8],
    path: &Path,
    face_props: &[&str],
) -> Result<(TriMesh, Vec<Vec<f64>>), IoError> {
    let d = read_ply_with(bytes, path, true, face_props)?;
    Ok((
        TriMesh {
            positions: d.positions,
            triangles: d.triangles,
        },
        d.face_values,
    ))
}

pub(crate) fn read_ply_mesh(bytes: &[u8], path: &Path) -> Result<TriMesh, IoError> {
    let d = read_ply(bytes, path, true)?;
    Ok(TriMesh {
        positions: d.positions,
        triangles: d.triangles,
    })
}

pub(crate) fn read_ply_points(bytes: &[u8], path: &Path) -> Result<PointCloud, IoError> {
    let d = read_ply(bytes, path, false)?;
    Ok(PointCloud {
        points: d.positions,
        normals: d.normals,
    })
}

fn index_type(n: usize) -> &'static str {
    if n <= i32::MAX as usize {
        "int"
    } else {
        "uint"
    }
}

pub(crate) fn write_ply_mesh(path: &Path, mesh: &TriMesh, ascii: bool) -> Result<(), IoError> {
    write_ply_mesh_colored(path, mesh, None, ascii)
}

/// [`write_ply_mesh`] with an sRGB colour per vertex (`property uchar red, green, blue`)
/// when `colors` is given (one per vertex, checked).
pub(crate) fn write_ply_mesh_colored(
    path: &Path,
    mesh: &TriMesh,
    colors: Option<&[[u8; 3]]>,
    ascii: bool,
) -> Result<(), IoError> {
    write_ply(path, mesh, colors, None, ascii)
}

/// A binary PLY mesh whose faces carry two int32 properties `region_a` and `region_b`
/// after `vertex_indices` (one pair per triangle, checked).
pub(crate) fn write_ply_mesh_regions(
    path: &Path,
    mesh: &TriMesh,
    regions: &[[i32; 2]],
) -> Result<(), IoError> {
    write_ply(path, mesh, None, Some(regions), false)
}

fn write_ply(
    path: &Path,
    mesh: &TriMesh,
    colors: Option<&[[u8; 3]]>,
    regions: Option<&[[i32; 2]]>,
    ascii: bool,
) -> Result<(), IoError> {
    crate::mesh::check_indices(mesh, path)?;
    if let Some(r) = regions
        && r.len() != mesh.triangles.len()
    {
        return Err(IoError::invalid_input(
            path,
            format!(
                "{} region pairs for {} triangles",
                r.len(),
                mesh.triangles.len()
            ),
        ));
    }
    if let Some(c) = colors
        && c.len() != mesh.positions.len()
    {
        return Err(IoError::invalid_input(
            path,
            format!(
                "{} vertex colours for {} vertices",
                c.len(),
                mesh.positions.len()
            ),
        ));
    }
    let normals = crate::gltf_write::vertex_normals(mesh);
    atomic_write(path, |w| {
        let fmt = if ascii {
            "ascii"
        } else {
            "binary_little_endian"
        };
        let color_props = if colors.is_some() {
            "property uchar red\nproperty uchar green\nproperty uchar blue\n"
        } else {
            ""
        };
        let region_props = if regions.is_some() {
            "property int region_a\nproperty int region_b\n"
        } else {
            ""
        };
        write!(
            w,
            "ply\nformat {fmt} 1.0\ncomment written by isokit\nelement vertex {}\n\
             property float x\nproperty float y\nproperty float z\n\
             property float nx\nproperty float ny\nproperty float nz\n{color_props}element face {}\n\
             property list uchar {} vertex_indices\n{region_props}end_header\n",
            mesh.positions.len(),
            mesh.triangles.len(),
            index_type(mesh.positions.len())
        )?;
        if ascii {
            for (i, (p, n)) in mesh.positions.iter().zip(&normals).enumerate() {
                write!(w, "{} {} {} {} {} {}", p.x, p.y, p.z, n.x, n.y, n.z)?;
                match colors {
                    Some(c) => {
                        let [r, g, b] = c[i];
                        writeln!(w, " {r} {g} {b}")?
                    }
                    None => writeln!(w)?,
                }
            }
            for (f, t) in mesh.triangles.iter().enumerate() {
                write!(w, "3 {} {} {}", t[0], t[1], t[2])?;
                match regions {
                    Some(r) => writeln!(w, " {} {}", r[f][0], r[f][1])?,
                    None => writeln!(w)?,
                }
            }
        } else {
            for (i, (p, n)) in mesh.positions.iter().zip(&normals).enumerate() {
                for x in p.to_array().into_iter().chain(n.to_array()) {
                    w.write_all(&x.to_le_bytes())?;
                }
                if let Some(c) = colors {
                    w.write_all(&c[i])?;
                }
            }
            let mut rec = [0u8; 21];
            rec[0] = 3;
            let len = if regions.is_some() { 21 } else { 13 };
            for (f, t) in mesh.triangles.iter().enumerate() {
                for (k, i) in t.iter().enumerate() {
                    rec[1 + 4 * k..5 + 4 * k].copy_from_slice(&i.to_le_bytes());
                }
                if let Some(r) = regions {
                    rec[13..17].copy_from_slice(&r[f][0].to_le_bytes());
                    rec[17..21].copy_from_slice(&r[f][1].to_le_bytes());
                }
                w.write_all(&rec[..len])?;
            }
        }
        Ok(())
    })
}

pub(crate) fn write_ply_points(path: &Path, cloud: &PointCloud) -> Result<(), IoError> {
    crate::points::check_normals(cloud, path)?;
    atomic_write(path, |w| {
        write!(
            w,
            "ply\nformat binary_little_endian 1.0\ncomment written by isokit\nelement vertex {}\n\
             property float x\nproperty float y\nproperty float z\n",
            cloud.points.len()
        )?;
        if cloud.normals.is_some() {
            write!(
                w,
                "property float nx\nproperty float ny\nproperty float nz\n"
            )?;
        }
        writeln!(w, "end_header")?;
        for (i, p) in cloud.points.iter().enumerate() {
            for x in p.to_array() {
                w.write_all(&x.to_le_bytes())?;
            }
            if let Some(n) = &cloud.normals {
                for x in n[i].to_array() {
                    w.write_all(&x.to_le_bytes())?;
                }
            }
        }
        Ok(())
    })
}
