//! Unstructured tetrahedral grids with point scalars ([`TetGrid`]) from VTK files: the
//! legacy format (`.vtk`, `DATASET UNSTRUCTURED_GRID`, ASCII and binary, versions up to 5.1
//! with its `OFFSETS`/`CONNECTIVITY` cells) and VTK XML (`.vtu`: ASCII, inline base64 and
//! appended raw or base64 data, uncompressed or zlib-compressed, 32- or 64-bit headers, as
//! VTK, ParaView, PyVista and meshio write them).
//!
//! Only tetrahedra (`VTK_TETRA`, type 10) are read; a file with other cells is refused with
//! the type it holds. The scalar is a point array with one component: the one named by the
//! caller, else the first in the file. Points are read as f32 (double-precision points are
//! rounded once). Counts are checked against the bytes present and the memory budget before
//! anything is allocated, and every index is range-checked.

mod legacy;
mod vtu;

use std::path::Path;

use glam::Vec3;
use isokit_field::TetGrid;

use crate::IoError;
// The number types of both formats.
use crate::util::{Scalar as Num, extension, read_file};

/// `VTK_TETRA`.
const TETRA: u8 = 10;

/// The tetrahedral-grid formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TetFormat {
    /// VTK legacy (`.vtk`).
    Legacy,
    /// VTK XML unstructured grid (`.vtu`).
    Vtu,
}

impl TetFormat {
    /// The format named by a path's extension (`.vtk`, `.vtu`; case-insensitive).
    pub fn from_path(path: &Path) -> Result<Self, IoError> {
        match extension(path).unwrap_or_default().as_str() {
            "vtk" => Ok(Self::Legacy),
            "vtu" => Ok(Self::Vtu),
            _ => Err(IoError::UnknownFormat {
                path: path.to_path_buf(),
                expected: "a tetrahedral grid (.vtk .vtu)",
            }),
        }
    }
}

/// Reads a tetrahedral grid; `array` names the point scalar (default: the first one-component
/// point array in the file).
///
/// ```no_run
/// let tets = isokit_io::read_tets(std::path::Path::new("tets.vtu"), None).unwrap();
/// println!("{} cells, scalar {}", tets.tets().len(), tets.array());
/// ```
pub fn read_tets(path: &Path, array: Option<&str>) -> Result<TetGrid, IoError> {
    let format = TetFormat::from_path(path)?;
    let bytes = read_file(path)?;
    read_tets_from(&bytes, format, array, path)
}

/// [`read_tets`] from bytes in memory; `name` is used in messages.
pub fn read_tets_bytes(
    bytes: &[u8],
    format: TetFormat,
    array: Option<&str>,
    name: &str,
) -> Result<TetGrid, IoError> {
    read_tets_from(bytes, format, array, Path::new(name))
}

fn read_tets_from(
    bytes: &[u8],
    format: TetFormat,
    array: Option<&str>,
    path: &Path,
) -> Result<TetGrid, IoError> {
    let parts = match format {
        TetFormat::Legacy => legacy::read(bytes, path)?,
        TetFormat::Vtu => vtu::read(bytes, path)?,
    };
    parts.assemble(array, path)
}

/// What both readers gather: points, cells (as offsets and connectivity), cell types and
/// the one-component point arrays.
#[derive(Default)]
struct Parts {
    points: Vec<f64>,
    offsets: Vec<f64>,
    connectivity: Vec<f64>,
    types: Vec<f64>,
    arrays: Vec<(String, Vec<f64>)>,
}

impl Parts {
    fn assemble(self, array: Option<&str>, path: &Path) -> Result<TetGrid, IoError> {
        let bad = |m: String| IoError::malformed(path, m);
        let n = self.points.len() / 3;
        let cells = self.types.len();
        if self.offsets.len() != cells + 1 {
            return Err(bad(format!(
                "{} cell types for {} cells",
                cells,
                self.offsets.len().saturating_sub(1)
            )));
        }
        if cells == 0 {
            return Err(bad("the grid has no cells".into()));
        }
        for (c, &t) in self.types.iter().enumerate() {
            if t != f64::from(TETRA) {
                return Err(IoError::Unsupported {
                    path: path.to_path_buf(),
                    what: format!(
                        "cell {c} has VTK cell type {t} ({}); only tetrahedra (type 10) are read",
                        cell_name(t)
                    ),
                });
            }
        }
        let mut tets = Vec::with_capacity(cells);
        for c in 0..cells {
            let (a, b) = (self.offsets[c], self.offsets[c + 1]);
            if !(a >= 0.0 && b == a + 4.0 && b <= self.connectivity.len() as f64) {
                return Err(bad(format!(
                    "cell {c}: offsets {a}..{b} do not give 4 points within the {} indices",
                    self.connectivity.len()
                )));
            }
            let mut t = [0u32; 4];
            for (k, slot) in t.iter_mut().enumerate() {
                let i = self.connectivity[a as usize + k];
                if !(i >= 0.0 && i < n as f64 && i.fract() == 0.0) {
                    return Err(bad(format!(
                        "cell {c}: point index {i} is not one of the {n} points"
                    )));
                }
                *slot = i as u32;
            }
            tets.push(t);
        }
        let names = || {
            self.arrays
                .iter()
                .map(|(name, _)| name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let chosen = match array {
            Some(want) => self
                .arrays
                .iter()
                .find(|(name, _)| name == want)
                .ok_or_else(|| {
                    bad(format!(
                        "no point array named {want:?} with one component (the file has: {})",
                        if self.arrays.is_empty() {
                            "none".into()
                        } else {
                            names()
                        }
                    ))
                })?,
            None => self.arrays.first().ok_or_else(|| {
                bad("no point scalar array (one value per point is needed)".into())
            })?,
        };
        if chosen.1.len() != n {
            return Err(bad(format!(
                "point array {:?} holds {} values for {n} points",
                chosen.0,
                chosen.1.len()
            )));
        }
        let points = self
            .points
            .chunks_exact(3)
            .map(|p| Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32))
            .collect();
        let values = chosen.1.iter().map(|&v| v as f32).collect();
        // The cells, and what checking them holds: 16 bytes per face while sorting the faces.
        check_budget(
            tets.len() as u128,
            16 + 4 * 16,
            "tetrahedral grid cells with their faces",
            path,
        )?;
        TetGrid::new(points, tets, values, chosen.0.clone()).map_err(|e| bad(e.to_string()))
    }
}

fn cell_name(t: f64) -> &'static str {
    match t as i64 {
        1 => "vertex",
        3 => "line",
        5 => "triangle",
        7 => "polygon",
        9 => "quad",
        12 => "hexahedron",
        13 => "wedge",
        14 => "pyramid",
        24 => "quadratic tetrahedron",
        42 => "polyhedron",
        _ => "not a tetrahedron",
    }
}

/// `bytes` (a whole number of values of `ty`) as f64, little- or big-endian.
fn decode(ty: Num, bytes: &[u8], big: bool) -> Vec<f64> {
    let e = if big {
        crate::util::Endian::Big
    } else {
        crate::util::Endian::Little
    };
    bytes
        .chunks_exact(ty.size())
        .map(|c| ty.decode(c, e))
        .collect()
}

/// Refuses `count` values of `size` bytes beyond the memory budget, before allocating.
fn check_budget(count: u128, size: usize, what: &str, path: &Path) -> Result<(), IoError> {
    isokit_field::memory::check_within(
        isokit_field::memory::budget(),
        what,
        count.saturating_mul(8.max(size as u128)),
        "read a smaller grid, or raise the budget",
    )
    .map_err(|e| IoError::invalid_input(path, e.to_string()))
}
