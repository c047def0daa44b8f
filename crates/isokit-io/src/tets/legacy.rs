//! VTK legacy unstructured grids (`# vtk DataFile Version …`, `DATASET UNSTRUCTURED_GRID`):
//! ASCII or big-endian binary; cells as the old `CELLS n size` lists or version 5.1's
//! `OFFSETS` and `CONNECTIVITY` arrays; point attributes (`SCALARS`, `FIELD` arrays) kept
//! when they have one component, the others (and cell data) skipped by their sizes.

use std::path::Path;

use super::{Num, Parts, check_budget, decode};
use crate::IoError;
use crate::util::show;

struct Cursor<'a> {
    b: &'a [u8],
    pos: usize,
    binary: bool,
    path: &'a Path,
}

impl<'a> Cursor<'a> {
    fn bad(&self, msg: impl std::fmt::Display) -> IoError {
        IoError::malformed(self.path, format!("byte {}: {msg}", self.pos))
    }

    /// The rest of the current line (without its end), moving past it.
    fn line(&mut self) -> &'a [u8] {
        let start = self.pos;
        let end = self.b[start..]
            .iter()
            .position(|&c| c == b'\n')
            .map_or(self.b.len(), |i| start + i);
        self.pos = (end + 1).min(self.b.len());
        let l = &self.b[start..end];
        l.strip_suffix(b"\r").unwrap_or(l)
    }

    fn token(&mut self) -> Option<&'a str> {
        while self.pos < self.b.len() && self.b[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        let start = self.pos;
        while self.pos < self.b.len() && !self.b[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        (self.pos > start).then(|| std::str::from_utf8(&self.b[start..self.pos]).unwrap_or("?"))
    }

    fn want(&mut self, what: &str) -> Result<&'a str, IoError> {
        self.token()
            .ok_or_else(|| self.bad(format!("the file ends where {what} was expected")))
    }

    fn count(&mut self, what: &str) -> Result<u128, IoError> {
        let t = self.want(what)?;
        t.parse::<u128>()
            .map_err(|_| self.bad(format!("{what} {:?} is not a count", show(t.as_bytes()))))
    }

    fn num_type(&mut self) -> Result<Num, IoError> {
        let t = self.want("a data type")?;
        Ok(match t.to_ascii_lowercase().as_str() {
            "char" => Num::I8,
            "unsigned_char" => Num::U8,
            "short" => Num::I16,
            "unsigned_short" => Num::U16,
            "int" | "vtktypeint32" => Num::I32,
            "unsigned_int" | "vtktypeuint32" => Num::U32,
            "long" | "vtktypeint64" | "vtkidtype" => Num::I64,
            "unsigned_long" | "vtktypeuint64" => Num::U64,
            "float" => Num::F32,
            "double" => Num::F64,
            other => {
                return Err(self.bad(format!(
                    "data type {:?} is not read (char … double, vtktypeint64)",
                    show(other.as_bytes())
                )));
            }
        })
    }

    /// `count` numbers of type `ty`: text tokens, or big-endian bytes starting after the
    /// line that announced them.
    fn numbers(&mut self, count: u128, ty: Num, what: &str) -> Result<Vec<f64>, IoError> {
        let left = (self.b.len() - self.pos) as u128;
        if self.binary {
            self.line();
            check_budget(count, ty.size(), what, self.path)?;
            let bytes = count.saturating_mul(ty.size() as u128);
            if bytes > (self.b.len() - self.pos) as u128 {
                return Err(self.bad(format!(
                    "{what}: {count} values need {bytes} bytes, the file has {} left",
                    self.b.len() - self.pos
                )));
            }
            let n = bytes as usize;
            let out = decode(ty, &self.b[self.pos..self.pos + n], true);
            self.pos += n;
            Ok(out)
        } else {
            // Each value takes a digit and a separator.
            if count > left.div_ceil(2) + 1 {
                return Err(self.bad(format!(
                    "{what}: {count} values cannot fit the {left} bytes left"
                )));
            }
            check_budget(count, ty.size(), what, self.path)?;
            let mut out = Vec::with_capacity(count as usize);
            for _ in 0..count {
                let t = self.want(what)?;
                let v: f64 = t.parse().map_err(|_| {
                    self.bad(format!("{what}: {:?} is not a number", show(t.as_bytes())))
                })?;
                out.push(v);
            }
            Ok(out)
        }
    }
}

pub(super) fn read(bytes: &[u8], path: &Path) -> Result<Parts, IoError> {
    let mut c = Cursor {
        b: bytes,
        pos: 0,
        binary: false,
        path,
    };
    let first = c.line();
    let version = first
        .strip_prefix(b"# vtk DataFile Version ")
        .and_then(|v| std::str::from_utf8(v).ok())
        .and_then(|v| v.trim().parse::<f64>().ok())
        .ok_or_else(|| {
            IoError::malformed(
                path,
                format!(
                    "not a VTK legacy file: the first line is {:?}, not \"# vtk DataFile Version x.y\"",
                    show(first)
                ),
            )
        })?;
    c.line(); // the title
    c.binary = match c.want("ASCII or BINARY")?.to_ascii_uppercase().as_str() {
        "ASCII" => false,
        "BINARY" => true,
        other => {
            return Err(c.bad(format!(
                "{:?} is neither ASCII nor BINARY",
                show(other.as_bytes())
            )));
        }
    };
    if !c.want("DATASET")?.eq_ignore_ascii_case("DATASET") {
        return Err(c.bad("DATASET expected"));
    }
    let kind = c.want("the dataset type")?;
    if !kind.eq_ignore_ascii_case("UNSTRUCTURED_GRID") {
        return Err(IoError::Unsupported {
            path: path.to_path_buf(),
            what: format!(
                "DATASET {}: a tetrahedral grid is an UNSTRUCTURED_GRID",
                show(kind.as_bytes())
            ),
        });
    }
    let mut parts = Parts::default();
    let (mut have_points, mut have_cells, mut have_types) = (false, false, false);
    // Point or cell attributes follow POINT_DATA / CELL_DATA: how many tuples, and whether
    // they are kept.
    let mut section: Option<(u128, bool)> = None;
    while let Some(key) = c.token() {
        match key.to_ascii_uppercase().as_str() {
            "POINTS" => {
                let n = c.count("the point count")?;
                let ty = c.num_type()?;
                parts.points = c.numbers(n.saturating_mul(3), ty, "POINTS")?;
                have_points = true;
            }
            "CELLS" => {
                let (a, b) = (c.count("the cell count")?, c.count("the cell list size")?);
                if version >= 5.0 {
                    for (name, slot) in [("OFFSETS", 0), ("CONNECTIVITY", 1)] {
                        let k = c.want(name)?;
                        if !k.eq_ignore_ascii_case(name) {
                            return Err(
                                c.bad(format!("{name} expected, found {:?}", show(k.as_bytes())))
                            );
                        }
                        let ty = c.num_type()?;
                        let v = c.numbers(if slot == 0 { a } else { b }, ty, name)?;
                        if slot == 0 {
                            parts.offsets = v;
                        } else {
                            parts.connectivity = v;
                        }
                    }
                } else {
                    let list = c.numbers(b, Num::I32, "CELLS")?;
                    let (offsets, conn) = split_cell_list(&list, a, &c)?;
                    parts.offsets = offsets;
                    parts.connectivity = conn;
                }
                have_cells = true;
            }
            "CELL_TYPES" => {
                let n = c.count("the cell type count")?;
                parts.types = c.numbers(n, Num::I32, "CELL_TYPES")?;
                have_types = true;
            }
            "POINT_DATA" => section = Some((c.count("the point data count")?, true)),
            "CELL_DATA" => section = Some((c.count("the cell data count")?, false)),
            "METADATA" => skip_metadata(&mut c),
            "FIELD" => {
                c.want("the field name")?;
                let arrays = c.count("the field's array count")?;
                for _ in 0..arrays {
                    let name = c.want("an array name")?.to_string();
                    let comps = c.count("the component count")?;
                    let tuples = c.count("the tuple count")?;
                    let ty = c.num_type()?;
                    let v = c.numbers(comps.saturating_mul(tuples), ty, &name)?;
                    if let Some((n, true)) = section
                        && comps == 1
                        && tuples == n
                    {
                        parts.arrays.push((name, v));
                    }
                    skip_metadata_if_next(&mut c);
                }
            }
            attr @ ("SCALARS"
            | "VECTORS"
            | "NORMALS"
            | "TENSORS"
            | "TEXTURE_COORDINATES"
            | "GLOBAL_IDS"
            | "PEDIGREE_IDS"
            | "COLOR_SCALARS"
            | "LOOKUP_TABLE") => {
                let Some((n, keep)) = section else {
                    return Err(c.bad(format!("{attr} before POINT_DATA or CELL_DATA")));
                };
                let name = c.want("the attribute's name")?.to_string();
                match attr {
                    "SCALARS" => {
                        let ty = c.num_type()?;
                        // An optional component count, then LOOKUP_TABLE.
                        let save = c.pos;
                        let mut comps = 1;
                        match c.token() {
                            Some(t) if t.eq_ignore_ascii_case("LOOKUP_TABLE") => {
                                c.want("the lookup table's name")?;
                            }
                            Some(t) => {
                                comps = t.parse::<u128>().map_err(|_| {
                                    c.bad(format!(
                                        "{:?} is not a component count",
                                        show(t.as_bytes())
                                    ))
                                })?;
                                let save2 = c.pos;
                                match c.token() {
                                    Some(t) if t.eq_ignore_ascii_case("LOOKUP_TABLE") => {
                                        c.want("the lookup table's name")?;
                                    }
                                    _ => c.pos = save2,
                                }
                            }
                            None => c.pos = save,
                        }
                        let v = c.numbers(n.saturating_mul(comps), ty, &name)?;
                        if keep && comps == 1 {
                            parts.arrays.push((name, v));
                        }
                    }
                    "VECTORS" | "NORMALS" => {
                        let ty = c.num_type()?;
                        c.numbers(n.saturating_mul(3), ty, &name)?;
                    }
                    "TENSORS" => {
                        let ty = c.num_type()?;
                        c.numbers(n.saturating_mul(9), ty, &name)?;
                    }
                    "TEXTURE_COORDINATES" => {
                        let dim = c.count("the coordinate count")?;
                        let ty = c.num_type()?;
                        c.numbers(n.saturating_mul(dim), ty, &name)?;
                    }
                    "GLOBAL_IDS" | "PEDIGREE_IDS" => {
                        let ty = c.num_type()?;
                        c.numbers(n, ty, &name)?;
                    }
                    "COLOR_SCALARS" => {
                        let m = c.count("the colour component count")?;
                        let ty = if c.binary { Num::U8 } else { Num::F32 };
                        c.numbers(n.saturating_mul(m), ty, &name)?;
                    }
                    _ => {
                        // A lookup table: `size` RGBA entries.
                        let size = c.count("the lookup table size")?;
                        let ty = if c.binary { Num::U8 } else { Num::F32 };
                        c.numbers(size.saturating_mul(4), ty, &name)?;
                    }
                }
                skip_metadata_if_next(&mut c);
            }
            other => {
                return Err(c.bad(format!("unknown keyword {:?}", show(other.as_bytes()))));
            }
        }
    }
    for (have, what) in [
        (have_points, "POINTS"),
        (have_cells, "CELLS"),
        (have_types, "CELL_TYPES"),
    ] {
        if !have {
            return Err(IoError::malformed(path, format!("no {what} section")));
        }
    }
    Ok(parts)
}

/// The old cell list (`n i0 i1 … `, per cell) as offsets and connectivity.
fn split_cell_list(
    list: &[f64],
    cells: u128,
    c: &Cursor<'_>,
) -> Result<(Vec<f64>, Vec<f64>), IoError> {
    if cells > list.len() as u128 {
        return Err(c.bad(format!("{cells} cells in a list of {} numbers", list.len())));
    }
    let mut offsets = Vec::with_capacity(cells as usize + 1);
    let mut conn = Vec::with_capacity(list.len());
    let mut i = 0usize;
    offsets.push(0.0);
    for cell in 0..cells {
        let Some(&k) = list.get(i) else {
            return Err(c.bad(format!("CELLS: the list ends at cell {cell} of {cells}")));
        };
        if !(k >= 0.0 && k.fract() == 0.0 && (i as f64 + 1.0 + k) <= list.len() as f64) {
            return Err(c.bad(format!("CELLS: cell {cell} claims {k} points")));
        }
        conn.extend_from_slice(&list[i + 1..i + 1 + k as usize]);
        offsets.push(conn.len() as f64);
        i += 1 + k as usize;
    }
    if i != list.len() {
        return Err(c.bad(format!(
            "CELLS: the list holds {} numbers, its {cells} cells use {i}",
            list.len()
        )));
    }
    Ok((offsets, conn))
}

/// Version 5.1's `METADATA` block: lines up to an empty one.
fn skip_metadata(c: &mut Cursor<'_>) {
    c.line();
    while c.pos < c.b.len() {
        if c.line().iter().all(|b| b.is_ascii_whitespace()) {
            break;
        }
    }
}

fn skip_metadata_if_next(c: &mut Cursor<'_>) {
    let save = c.pos;
    match c.token() {
        Some(t) if t.eq_ignore_ascii_case("METADATA") => skip_metadata(c),
        _ => c.pos = save,
    }
}
