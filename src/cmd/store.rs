//! `isokit info FIELD.zarr`: a Zarr store's lattice, chunks and completeness (a killed
//! writer's partial store lists the chunks it had not finished).

use anyhow::{Result, bail};
use isokit_io::zarr::{ZarrSource, partial_path, zarr_info};
use serde_json::{Value, json};
use std::path::{Path, PathBuf};

/// True when `path` names a Zarr store or a writer's partial store.
pub fn is_store_name(path: &Path) -> bool {
    let name = path.to_string_lossy().to_ascii_lowercase();
    name.ends_with(".zarr") || name.ends_with(".zarr.partial")
}

/// The store to describe: `path`, or its partial store when only that exists.
fn located(path: &Path) -> Result<PathBuf> {
    if path.exists() {
        return Ok(path.to_path_buf());
    }
    let partial = partial_path(path);
    if partial.is_dir() {
        return Ok(partial);
    }
    bail!("{}: no such Zarr store", path.display());
}

/// Describes a store: text and JSON (`kind` `"zarr"`).
pub fn describe(path: &Path) -> Result<(String, Value)> {
    let at = located(path)?;
    let info = zarr_info(&at)?;
    let l = &info.lattice;
    let shown = &info.missing;
    let mut v = json!({
        "kind": "zarr",
        "store": at.display().to_string(),
        "dims": l.dims,
        "origin": l.to_json()["origin"],
        "spacing": l.to_json()["spacing"],
        "lattice_attributes": info.has_lattice,
        "band": l.band,
        "inside": l.inside_name(),
        "sign": l.sign,
        "array": info.array,
        "data_type": info.data_type,
        "chunk_shape": info.chunk_shape,
        "subchunk_shape": info.subchunk_shape,
        "chunks": info.chunks,
        "chunks_present": info.present,
        "fill_value": info.fill,
        "complete": info.complete,
        "missing_chunks": info.missing_chunks,
        "missing": shown,
    });
    let mut t = format!(
        "{}: Zarr store\n  samples: {} x {} x {}\n  origin: {:?}\n  spacing: {:?}{}\n  band: {}, inside {}, sign {}\n  array {}: {}, chunks of {} (z, y, x): {} of {} present (absent ones hold the fill value {})",
        at.display(),
        l.dims[0],
        l.dims[1],
        l.dims[2],
        l.origin,
        l.spacing,
        if info.has_lattice {
            ""
        } else {
            " (no lattice attributes: origin 0, spacing 1)"
        },
        l.band.map_or("none".into(), |b| b.to_string()),
        l.inside_name(),
        l.sign.as_deref().unwrap_or("none"),
        info.array,
        info.data_type,
        match info.subchunk_shape {
            Some(s) => format!("{:?}, sharded in chunks of {s:?}", info.chunk_shape),
            None => format!("{:?}", info.chunk_shape),
        },
        info.present,
        info.chunks,
        info.fill.map_or("(not a number)".into(), |f| f.to_string()),
    );
    if info.complete {
        // Chunk by chunk: a store larger than memory is summarized too.
        let source = ZarrSource::open(&at, 0)?;
        let (range, nan) = source.summary();
        let range = range.map(|(lo, hi)| [lo, hi]);
        v["range"] = json!(range);
        v["non_finite_samples"] = json!(nan);
        let vol = isokit_io::Volume {
            dims: l.dims,
            origin: source.origin(),
            spacing: source.spacing(),
            data: Vec::new(),
        };
        v["bounds"] = super::info::bounds_json(&vol.bounds());
        t += &format!(
            "\n  range: {}\n  non-finite samples: {nan}\n  complete",
            range.map_or("no finite samples".into(), |[a, b]| format!("{a} .. {b}"))
        );
    } else {
        t += &format!(
            "\n  INCOMPLETE: its writer did not finish; {} of {} chunks missing{}{}",
            info.missing_chunks,
            info.chunks,
            if shown.is_empty() {
                ""
            } else {
                ", first (z, y, x): "
            },
            shown
                .iter()
                .map(|c| format!("{c:?}"))
                .collect::<Vec<_>>()
                .join(" ")
        );
    }
    Ok((t, v))
}
