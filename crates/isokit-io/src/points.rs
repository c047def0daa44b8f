//! Point clouds: PLY and XYZ.

use std::path::Path;

use glam::Vec3;

use crate::util::{extension, parse_f64, read_file, show};
use crate::{IoError, PointCloud, atomic_write, ply};

/// The point-cloud file formats, chosen by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PointFormat {
    /// Stanford PLY (`.ply`): vertex `x y z`, optional `nx ny nz`; faces ignored.
    Ply,
    /// Text (`.xyz`): one point per line, `x y z` or `x y z nx ny nz`, `#` comments.
    Xyz,
    /// Wavefront OBJ (`.obj`) read as its `v` lines (faces ignored); read only.
    Obj,
}

impl PointFormat {
    /// The extensions [`PointFormat::from_path`] accepts, for messages.
    pub const EXTENSIONS: &'static str = ".ply, .xyz or .obj (read only)";

    /// The format named by a path's extension (case-insensitive).
    pub fn from_path(path: &Path) -> Result<Self, IoError> {
        match extension(path).as_deref() {
            Some("ply") => Ok(PointFormat::Ply),
            Some("xyz") => Ok(PointFormat::Xyz),
            Some("obj") => Ok(PointFormat::Obj),
            _ => Err(IoError::UnknownFormat {
                path: path.to_path_buf(),
                expected: Self::EXTENSIONS,
            }),
        }
    }
}

/// Reads a point cloud by extension: `.ply` (ASCII or binary; the vertex element, with
/// normals when `nx ny nz` are all present; other elements such as faces are skipped),
/// `.xyz` (text, 3 or 6 whitespace- or comma-separated columns, the same on every line;
/// `#` starts a comment; a file without any point is an error) or `.obj` (every `v` line).
pub fn read_points(path: &Path) -> Result<PointCloud, IoError> {
    let format = PointFormat::from_path(path)?;
    let bytes = read_file(path)?;
    read_points_from(&bytes, format, path)
}

/// Reads a point cloud from bytes in memory; `name` is used in messages.
pub fn read_points_bytes(
    bytes: &[u8],
    format: PointFormat,
    name: &str,
) -> Result<PointCloud, IoError> {
    read_points_from(bytes, format, Path::new(name))
}

fn read_points_from(bytes: &[u8], format: PointFormat, path: &Path) -> Result<PointCloud, IoError> {
    match format {
        PointFormat::Ply => ply::read_ply_points(bytes, path),
        PointFormat::Xyz => read_xyz(bytes, path),
        PointFormat::Obj => crate::obj::read_obj_points(bytes, path),
    }
}

/// Writes a point cloud atomically by extension: `.ply` (binary little-endian, float
/// `x y z` and `nx ny nz` when present) or `.xyz` (text, 3 or 6 columns).
pub fn write_points(path: &Path, cloud: &PointCloud) -> Result<(), IoError> {
    match PointFormat::from_path(path)? {
        PointFormat::Ply => ply::write_ply_points(path, cloud),
        PointFormat::Xyz => write_xyz(path, cloud),
        PointFormat::Obj => Err(IoError::unsupported(
            path,
            "point clouds are written as .ply or .xyz, not .obj",
        )),
    }
}

fn read_xyz(bytes: &[u8], path: &Path) -> Result<PointCloud, IoError> {
    let mut points = Vec::with_capacity(bytes.len() / 24);
    let mut normals: Vec<Vec3> = Vec::new();
    let mut columns: Option<usize> = None;
    let mut vals = [0f32; 6];
    for (n, line) in bytes.split(|&b| b == b'\n').enumerate() {
        let line = match line.iter().position(|&b| b == b'#') {
            Some(c) => &line[..c],
            None => line,
        };
        let mut k = 0;
        for tok in line
            .split(|&b| b.is_ascii_whitespace() || b == b',')
            .filter(|t| !t.is_empty())
        {
            if k == 6 {
                k += 1;
                break;
            }
            vals[k] = parse_f64(tok).ok_or_else(|| {
                IoError::malformed(
                    path,
                    format!("XYZ line {}: {:?} is not a number", n + 1, show(tok)),
                )
            })? as f32;
            k += 1;
        }
        if k == 0 {
            continue;
        }
        if k != 3 && k != 6 {
            return Err(IoError::malformed(
                path,
                format!(
                    "XYZ line {}: expected 3 columns (x y z) or 6 (x y z nx ny nz), found {}",
                    n + 1,
                    if k > 6 {
                        "more than 6".to_string()
                    } else {
                        k.to_string()
                    }
                ),
            ));
        }
        match columns {
            None => columns = Some(k),
            Some(c) if c != k => {
                return Err(IoError::malformed(
                    path,
                    format!(
                        "XYZ line {}: {k} columns where earlier lines have {c}",
                        n + 1
                    ),
                ));
            }
            _ => {}
        }
        points.push(Vec3::new(vals[0], vals[1], vals[2]));
        if k == 6 {
            normals.push(Vec3::new(vals[3], vals[4], vals[5]));
        }
    }
    if points.is_empty() {
        return Err(IoError::malformed(path, "XYZ file holds no points"));
    }
    Ok(PointCloud {
        points,
        normals: (columns == Some(6)).then_some(normals),
    })
}

fn write_xyz(path: &Path, cloud: &PointCloud) -> Result<(), IoError> {
    check_normals(cloud, path)?;
    atomic_write(path, |w| {
        match &cloud.normals {
            Some(ns) => {
                writeln!(w, "# x y z nx ny nz")?;
                for (p, n) in cloud.points.iter().zip(ns) {
                    writeln!(w, "{} {} {} {} {} {}", p.x, p.y, p.z, n.x, n.y, n.z)?;
                }
            }
            None => {
                writeln!(w, "# x y z")?;
                for p in &cloud.points {
                    writeln!(w, "{} {} {}", p.x, p.y, p.z)?;
                }
            }
        }
        Ok(())
    })
}

/// Refuses a cloud whose normals do not match its points (writers call this first).
pub(crate) fn check_normals(cloud: &PointCloud, path: &Path) -> Result<(), IoError> {
    match cloud.normals_problem() {
        Some(m) => Err(IoError::invalid_input(path, m)),
        None => Ok(()),
    }
}
