//! Tetrahedral grids (`.vtk`, `.vtu`) in `isokit info` and `isokit mesh`.

use anyhow::{Result, bail};
use isokit_io::{TetFormat, read_tets};
use serde_json::{Value, json};
use std::path::Path;

/// True when `path` names a tetrahedral grid (by extension).
pub fn is_tets(path: &Path) -> bool {
    TetFormat::from_path(path).is_ok()
}

/// `isokit info` of a tetrahedral grid: cells, points, the scalar and its range, bad cells.
pub fn describe(path: &Path, array: Option<&str>) -> Result<(String, Value)> {
    let g = read_tets(path, array)?;
    let r = g.report();
    let b = g.bounds();
    let range = r.range.map(|(lo, hi)| [lo, hi]);
    let v = json!({
        "kind": "tets",
        "cells": r.cells,
        "points": r.points,
        "array": g.array(),
        "range": range,
        "non_finite_values": r.non_finite_values,
        "inverted_cells": r.inverted,
        "degenerate_cells": r.degenerate,
        "boundary_faces": r.boundary_faces,
        "over_shared_faces": r.over_shared_faces,
        "unused_points": r.unused_points,
        "bounds": super::info::bounds_json(&b),
    });
    let t = format!(
        "{}: tetrahedral grid\n  cells: {}\n  points: {} ({} unused)\n  scalar: {}\n  range: {}\n  non-finite values: {}\n  bad cells: {} inverted, {} degenerate\n  faces: {} on the boundary, {} shared by more than two cells\n  bounds: {:?} .. {:?}",
        path.display(),
        r.cells,
        r.points,
        r.unused_points,
        g.array(),
        range.map_or("no finite values".into(), |[a, b]| format!("{a} .. {b}")),
        r.non_finite_values,
        r.inverted,
        r.degenerate,
        r.boundary_faces,
        r.over_shared_faces,
        b.min.to_array(),
        b.max.to_array(),
    );
    Ok((t, v))
}

/// `isokit mesh tets.vtu --iso V`: marching tetrahedra (`inside_above` flips the sides).
pub fn mesh(
    path: &Path,
    array: Option<&str>,
    iso: f32,
    inside_above: bool,
) -> Result<isokit_field::TriMesh> {
    let mut g = read_tets(path, array)?;
    // Inverted cells are meshed by their own orientation; degenerate ones may leave gaps.
    // (Overlapping cells need the face topology, a sort of every face: `isokit info`.)
    let r = g.report_cells();
    if r.degenerate > 0 {
        eprintln!(
            "warning: {} degenerate cells ({} inverted): the surface may be open there; `isokit info {}` checks the faces too",
            r.degenerate,
            r.inverted,
            path.display()
        );
    }
    let mut iso = iso;
    if inside_above {
        g.values_mut().iter_mut().for_each(|v| *v = -*v);
        iso = -iso;
    }
    if r.range.is_none() {
        bail!("{}: no finite value in array {}", path.display(), g.array());
    }
    Ok(isokit_levelset::tets::mesh_tets_job(
        &g,
        iso,
        &super::progress::job(),
    )?)
}
