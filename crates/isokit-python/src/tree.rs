//! Walking a scene tree: file paths made absolute or relative, in-memory sources saved to
//! files.

use crate::errors::io_err;
use isokit_scene::node::{MeshNode, PointsNode, VolumeNode};
use isokit_scene::{Node, VolumeData};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::{Path, PathBuf};

/// Where a child sits in its parent's scene-file form: `[i]` of a list node (`union`),
/// `of[i]` of a blend, `of` of a one-child operation, `from`/`to` of a morph, or the node's
/// own value (`complement`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    /// The `i`-th element of the node's list (`{"union": [a, b]}`).
    Index(usize),
    /// The `i`-th element of the node's `of` list (`{"smooth_union": {"of": [a, b]}}`).
    OfIndex(usize),
    /// A named key of the node's table (`of`, `from`, `to`).
    Key(&'static str),
    /// The node's value itself (`{"complement": a}`).
    Value,
}

impl Slot {
    /// The suffix of the child's path in errors (`[1]`, `.of[1]`, `.of`, ``).
    pub fn dotted(self) -> String {
        match self {
            Slot::Index(i) => format!("[{i}]"),
            Slot::OfIndex(i) => format!(".of[{i}]"),
            Slot::Key(k) => format!(".{k}"),
            Slot::Value => String::new(),
        }
    }

    /// The JSON pointer of the child below its parent's (`/union/1`, `/twist/of`), for the
    /// parent's `kind`.
    pub fn pointer(self, kind: &str) -> String {
        match self {
            Slot::Index(i) => format!("/{kind}/{i}"),
            Slot::OfIndex(i) => format!("/{kind}/of/{i}"),
            Slot::Key(k) => format!("/{kind}/{k}"),
            Slot::Value => format!("/{kind}"),
        }
    }
}

/// The direct children of a node, mutable, in [`Node::children`]'s order, with their slots.
pub fn children_mut(node: &mut Node) -> Vec<(Slot, &mut Node)> {
    fn list(v: &mut [Node], of: bool) -> Vec<(Slot, &mut Node)> {
        v.iter_mut()
            .enumerate()
            .map(|(i, c)| (if of { Slot::OfIndex(i) } else { Slot::Index(i) }, c))
            .collect()
    }
    fn of(c: &mut Node) -> Vec<(Slot, &mut Node)> {
        vec![(Slot::Key("of"), c)]
    }
    match node {
        Node::Union(v) | Node::Intersection(v) | Node::Difference(v) => list(v, false),
        Node::SmoothUnion(s)
        | Node::SmoothIntersection(s)
        | Node::SmoothDifference(s)
        | Node::ChamferUnion(s)
        | Node::ChamferIntersection(s)
        | Node::ChamferDifference(s) => list(&mut s.of, true),
        Node::StairsUnion(s) | Node::StairsIntersection(s) | Node::StairsDifference(s) => {
            list(&mut s.of, true)
        }
        Node::Complement(c) => vec![(Slot::Value, &mut **c)],
        Node::Morph { from, to, .. } => {
            vec![
                (Slot::Key("from"), &mut **from),
                (Slot::Key("to"), &mut **to),
            ]
        }
        Node::Offset { of: c, .. } | Node::Shell { of: c, .. } => of(c),
        Node::Transform(t) => of(&mut t.of),
        Node::Octree(o) => of(&mut o.of),
        Node::Extrude(n) => of(&mut n.of),
        Node::Revolve(n) => of(&mut n.of),
        Node::Mirror(n) => of(&mut n.of),
        Node::Orient(n) => of(&mut n.of),
        Node::Affine(n) => of(&mut n.of),
        Node::Repeat(n) => of(&mut n.of),
        Node::Array(n) => of(&mut n.of),
        Node::CircularArray(n) => of(&mut n.of),
        Node::Twist(n) => of(&mut n.of),
        Node::Bend(n) => of(&mut n.of),
        Node::Taper(n) => of(&mut n.of),
        Node::Elongate(n) => of(&mut n.of),
        Node::Round(n) => of(&mut n.of),
        Node::Onion(n) => of(&mut n.of),
        Node::Colored(c) => children_mut(&mut c.of),
        _ => Vec::new(),
    }
}

/// Calls `f` on every node of the tree, parents before children, with the node's path as
/// errors name it (`shape.union[1].mesh`); a coloured node is visited as the node under
/// its colour.
pub fn walk_mut(
    node: &mut Node,
    parent: &str,
    f: &mut dyn FnMut(&mut Node, &str) -> PyResult<()>,
) -> PyResult<()> {
    if let Node::Colored(c) = node {
        return walk_mut(&mut c.of, parent, f);
    }
    let path = format!("{parent}.{}", node.kind());
    f(node, &path)?;
    for (slot, c) in children_mut(node) {
        walk_mut(c, &format!("{path}{}", slot.dotted()), f)?;
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
