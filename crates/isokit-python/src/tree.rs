//! Walking a scene tree: file paths made absolute or relative, in-memory sources saved to
//! files.

use crate::errors::io_err;
use isokit_scene::node::{MeshNode, PointsNode, VolumeNode};
use isokit_scene::{Node, VolumeData};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::{Path, PathBuf};

/// Calls `f` on every node of the tree, parents before children, with the node's path as
/// errors name it (`shape.union[1].mesh`).
pub fn walk_mut(
    node: &mut Node,
    parent: &str,
    f: &mut dyn FnMut(&mut Node, &str) -> PyResult<()>,
) -> PyResult<()> {
    let path = format!("{parent}.{}", node.kind());
    f(node, &path)?;
    match node {
        Node::Union(v) | Node::Intersection(v) | Node::Difference(v) => {
            for (i, c) in v.iter_mut().enumerate() {
                walk_mut(c, &format!("{path}[{i}]"), f)?;
            }
        }
        Node::SmoothUnion(s) | Node::SmoothIntersection(s) | Node::SmoothDifference(s) => {
            for (i, c) in s.of.iter_mut().enumerate() {
                walk_mut(c, &format!("{path}.of[{i}]"), f)?;
            }
        }
        Node::Complement(c) => walk_mut(c, &path, f)?,
        Node::Offset { of, .. } | Node::Shell { of, .. } => walk_mut(of, &format!("{path}.of"), f)?,
        Node::Morph { from, to, .. } => {
            walk_mut(from, &format!("{path}.from"), f)?;
            walk_mut(to, &format!("{path}.to"), f)?;
        }
        Node::Transform(t) => walk_mut(&mut t.of, &format!("{path}.of"), f)?,
        Node::Octree(o) => walk_mut(&mut o.of, &format!("{path}.of"), f)?,
        _ => {}
    }
    Ok(())
}

/// The file path a source node names, for rewriting.
fn path_of(node: &mut Node) -> Option<&mut String> {
    match node {
        Node::Mesh(MeshNode { path: Some(p), .. })
        | Node::Points(PointsNode { path: Some(p), .. })
        | Node::Volume(VolumeNode { path: Some(p), .. })
        | Node::Include { path: p } => Some(p),
        _ => None,
    }
}

/// `p` made absolute against `dir` (without resolving links).
pub fn absolute(p: &str, dir: &Path) -> String {
    let path = Path::new(p);
    let joined = if path.is_absolute() {
        path.to_path_buf()
    } else {
        dir.join(path)
    };
    std::path::absolute(&joined)
        .unwrap_or(joined)
        .display()
        .to_string()
}

/// Every relative file path in the tree made absolute against `dir` (a scene file's folder).
pub fn absolutize(node: &mut Node, dir: &Path) -> PyResult<()> {
    walk_mut(node, "shape", &mut |n, _| {
        if let Some(p) = path_of(n) {
            *p = absolute(p, dir);
        }
        Ok(())
    })
}

/// Every absolute path below `dir` made relative to it (others stay absolute).
pub fn relativize(node: &mut Node, dir: &Path) -> PyResult<()> {
    let dir = std::path::absolute(dir).unwrap_or_else(|_| dir.to_path_buf());
    walk_mut(node, "shape", &mut |n, _| {
        if let Some(p) = path_of(n)
            && let Ok(rel) = Path::new(p.as_str()).strip_prefix(&dir)
        {
            *p = rel.display().to_string();
        }
        Ok(())
    })
}

/// Writes every in-memory source of the tree into `dir` (meshes as binary PLY, clouds as
/// PLY with normals, volumes as NRRD, each named by its kind and content hash) and makes
/// the nodes reference the files (absolute paths). An in-memory field (`Node::Field`) has no
/// file form: an error naming the node.
pub fn save_sources(node: &mut Node, dir: &Path) -> PyResult<Vec<PathBuf>> {
    std::fs::create_dir_all(dir)
        .map_err(|e| crate::errors::io_err(isokit_io::IoError::io(dir, e)))?;
    let mut written = Vec::new();
    walk_mut(node, "shape", &mut |n, path| {
        match n {
            Node::Mesh(m) => {
                if let Some(d) = m.data.take() {
                    let f = dir.join(format!("mesh_{:016x}.ply", d.hash));
                    isokit_io::write_mesh(&f, &d.data).map_err(io_err)?;
                    m.path = Some(absolute(&f.display().to_string(), Path::new(".")));
                    written.push(f);
                }
            }
            Node::Points(p) => {
                if let Some(d) = p.data.take() {
                    let f = dir.join(format!("points_{:016x}.ply", d.hash));
                    isokit_io::write_points(&f, &d.data).map_err(io_err)?;
                    p.path = Some(absolute(&f.display().to_string(), Path::new(".")));
                    written.push(f);
                }
            }
            Node::Volume(v) => {
                if let Some(d) = v.data.take() {
                    let f = dir.join(format!("volume_{:016x}.nrrd", d.hash));
                    let grid = match &*d.data {
                        VolumeData::Grid(g) => g.clone(),
                        VolumeData::Bricks(b) => b.to_grid().map_err(crate::errors::value_err)?,
                    };
                    isokit_io::write_volume(&f, &isokit_io::Volume::from(grid)).map_err(io_err)?;
                    v.path = Some(absolute(&f.display().to_string(), Path::new(".")));
                    written.push(f);
                }
            }
            Node::Field(fieldnode) => {
                return Err(PyValueError::new_err(format!(
                    "{path}: the field {:?} is computed in memory and has no file form; \
                     sample it (shape.sample()) and use isokit.volume(field) instead",
                    fieldnode.name
                )));
            }
            _ => {}
        }
        Ok(())
    })?;
    Ok(written)
}
