//! Zarr v3 stores: written and read back bit for bit, chunks outside the band not written,
//! replaced only whole, a killed writer's partial store detected and resumed, hostile stores
//! refused with an error (never a panic).

mod common;

use common::TempDir;
use glam::Vec3;
use isokit_field::curvature::Inside;
use isokit_io::lattice::Lattice;
use isokit_io::zarr::{ZarrOptions, ZarrWriter, partial_path, read_zarr, write_zarr, zarr_info};
use isokit_io::{Volume, read_volume};
use std::fs;
use std::path::Path;

/// A sphere of radius 0.5 clamped to a band of 0.1, on a lattice whose sides are not
/// multiples of the chunk.
fn sphere_band(dims: [usize; 3]) -> (Volume, Lattice) {
    let h = 0.02;
    let origin = Vec3::new(-0.7, -0.6, -0.55);
    let band = 0.1f32;
    let mut data = Vec::with_capacity(dims.iter().product());
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = origin + h * Vec3::new(i as f32, j as f32, k as f32);
                data.push((p.length() - 0.5).clamp(-band, band));
            }
        }
    }
    let v = Volume {
        dims,
        origin,
        spacing: Vec3::splat(h),
        data,
    };
    let meta = Lattice {
        band: Some(band),
        sign: Some("pseudonormal".into()),
        ..Lattice::of(&v)
    };
    (v, meta)
}

/// The samples of `v` that chunk `idx` of `w` holds (its block, x fastest).
fn block_of(v: &Volume, w: &ZarrWriter, idx: [usize; 3]) -> Vec<f32> {
    let (first, dims) = w.chunk_block(idx);
    let [nx, ny, _] = v.dims;
    let mut out = Vec::new();
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            let s = first[0] + nx * (first[1] + y + ny * (first[2] + z));
            out.extend_from_slice(&v.data[s..s + dims[0]]);
        }
    }
    out
}

fn opts(chunk: usize) -> ZarrOptions {
    ZarrOptions {
        chunk,
        gzip: Some(1),
        shard: 1,
        fingerprint: None,
    }
}

#[test]
fn a_band_field_reads_back_bit_for_bit_and_chunks_beyond_the_band_are_not_written() {
    let t = TempDir::new("zarr-roundtrip");
    let (v, meta) = sphere_band([70, 61, 56]);
    for (chunk, gzip) in [(8, Some(1)), (16, None), (64, Some(9))] {
        let path = t.path(&format!("s{chunk}.zarr"));
        let o = ZarrOptions {
            chunk,
            gzip,
            shard: 1,
            fingerprint: None,
        };
        let w = write_zarr(&path, &v, &meta, o).unwrap();
        let (back, lattice, has) = read_zarr(&path).unwrap();
        assert!(has);
        assert_eq!(back.dims, v.dims);
        assert_eq!(back.origin, v.origin);
        assert_eq!(back.spacing, v.spacing);
        assert!(
            back.data
                .iter()
                .zip(&v.data)
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "chunk {chunk}: samples differ"
        );
        assert_eq!(lattice, meta);
        // Through the generic reader too.
        assert_eq!(read_volume(&path).unwrap(), back);
        let info = zarr_info(&path).unwrap();
        assert!(info.complete && info.missing.is_empty() && info.missing_chunks == 0);
        assert_eq!(info.array, "/field");
        assert_eq!(info.chunks as usize, w.chunks);
        assert_eq!(info.present as usize, w.written);
        assert_eq!(info.fill, Some(f64::from(0.1f32)));
        // The corners' chunks lie wholly beyond the band: not written.
        assert!(
            chunk > 16 || w.written < w.chunks,
            "chunk {chunk}: {} of {} written",
            w.written,
            w.chunks
        );
        println!(
            "chunk {chunk}: {} of {} chunks written",
            w.written, w.chunks
        );
        assert!(!partial_path(&path).exists());
    }
}

#[test]
fn chunks_wholly_inside_are_written_so_absent_never_means_the_wrong_sign() {
    let t = TempDir::new("zarr-inside");
    // A big sphere: the centre chunks hold only -band.
    let (mut v, meta) = sphere_band([64, 64, 64]);
    let c = Vec3::new(-0.7, -0.6, -0.55) + 0.02 * 31.5;
    for k in 0..64 {
        for j in 0..64 {
            for i in 0..64 {
                let p =
                    Vec3::new(-0.7, -0.6, -0.55) + 0.02 * Vec3::new(i as f32, j as f32, k as f32);
                v.data[i + 64 * (j + 64 * k)] = ((p - c).length() - 0.6).clamp(-0.1, 0.1);
            }
        }
    }
    let path = t.path("inside.zarr");
    let w = write_zarr(&path, &v, &meta, opts(8)).unwrap();
    // Per chunk of 8³: all at +band (absent), all at -band (must be present), or mixed.
    let (mut outside, mut inside) = (0, 0);
    for n in 0..w.chunks {
        let (cz, cy, cx) = (n / 64, (n / 8) % 8, n % 8);
        let vals: Vec<f32> = (0..512)
            .map(|m| {
                let (i, j, k) = (cx * 8 + m % 8, cy * 8 + (m / 8) % 8, cz * 8 + m / 64);
                v.data[i + 64 * (j + 64 * k)]
            })
            .collect();
        outside += usize::from(vals.iter().all(|&x| x == 0.1));
        inside += usize::from(vals.iter().all(|&x| x == -0.1));
    }
    assert!(
        inside > 0 && outside > 0,
        "inside {inside}, outside {outside}"
    );
    assert_eq!(w.written, w.chunks - outside);
    assert_eq!(
        zarr_info(&path).unwrap().present as usize,
        w.chunks - outside
    );
    let (back, _, _) = read_zarr(&path).unwrap();
    assert_eq!(back.data, v.data);
}

#[test]
fn a_store_is_replaced_whole_and_other_directories_are_not_replaced() {
    let t = TempDir::new("zarr-replace");
    let (v, meta) = sphere_band([40, 30, 20]);
    let path = t.path("f.zarr");
    write_zarr(&path, &v, &meta, opts(16)).unwrap();
    let mut v2 = v.clone();
    v2.data.iter_mut().for_each(|x| *x = -*x);
    write_zarr(&path, &v2, &meta, opts(8)).unwrap();
    let (back, _, _) = read_zarr(&path).unwrap();
    assert_eq!(back.data, v2.data);
    assert_eq!(zarr_info(&path).unwrap().chunk_shape, [8, 8, 8]);
    assert_eq!(t.entries(), vec!["f.zarr".to_string()]);
    // A folder that is not a store is never replaced.
    let dir = t.path("mine.zarr");
    fs::create_dir(&dir).unwrap();
    fs::write(dir.join("notes.txt"), "keep").unwrap();
    let e = write_zarr(&dir, &v, &meta, opts(8))
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a Zarr store"), "{e}");
    assert_eq!(fs::read_to_string(dir.join("notes.txt")).unwrap(), "keep");
    // Bad knobs are refused before anything is made.
    for (chunk, gzip) in [(0, Some(1)), (513, Some(1)), (8, Some(10))] {
        let p = t.path("k.zarr");
        let o = ZarrOptions {
            chunk,
            gzip,
            shard: 1,
            fingerprint: None,
        };
        assert!(write_zarr(&p, &v, &meta, o).is_err());
        assert!(!p.exists() && !partial_path(&p).exists());
    }
}

#[test]
fn a_killed_writers_store_lists_its_missing_chunks_and_resume_finishes_it() {
    let t = TempDir::new("zarr-resume");
    let (v, meta) = sphere_band([50, 40, 33]);
    let path = t.path("r.zarr");
    let block = |w: &ZarrWriter, idx| block_of(&v, w, idx);
    // A writer that stops after 5 of its chunks, as a killed run does (no finish).
    let w = ZarrWriter::create(&path, &meta, opts(16)).unwrap();
    let all = w.pending();
    assert_eq!(all.len(), 4 * 3 * 3);
    for &idx in &all[..5] {
        w.write_chunk(idx, &block(&w, idx)).unwrap();
    }
    drop(w);
    assert!(!path.exists());
    let partial = partial_path(&path);
    let info = zarr_info(&partial).unwrap();
    assert!(!info.complete);
    assert_eq!(info.missing_chunks as usize, all.len() - 5);
    assert_eq!(
        info.missing[0],
        [all[5][0] as u64, all[5][1] as u64, all[5][2] as u64]
    );
    let e = read_zarr(&partial).unwrap_err().to_string();
    assert!(e.contains("incomplete"), "{e}");
    // Resuming with another lattice is refused; with the same one only the rest is left.
    let mut other = meta.clone();
    other.band = Some(0.2);
    assert!(ZarrWriter::resume(&path, &other, opts(16)).is_err());
    assert!(ZarrWriter::resume(&path, &meta, opts(8)).is_err());
    let w = ZarrWriter::resume(&path, &meta, opts(16)).unwrap();
    let rest = w.pending();
    assert_eq!(rest, all[5..].to_vec());
    for &idx in &rest {
        w.write_chunk(idx, &block(&w, idx)).unwrap();
    }
    w.finish().unwrap();
    let (back, _, _) = read_zarr(&path).unwrap();
    assert_eq!(back.data, v.data);
    assert!(!partial.exists());
    // A writer that did not write every chunk cannot finish.
    let w = ZarrWriter::create(&t.path("q.zarr"), &meta, opts(16)).unwrap();
    assert!(w.finish().is_err());
}

#[test]
fn a_store_without_lattice_attributes_reads_with_origin_zero_and_spacing_one() {
    let t = TempDir::new("zarr-plain");
    let (v, meta) = sphere_band([20, 10, 6]);
    let path = t.path("p.zarr");
    write_zarr(&path, &v, &meta, opts(8)).unwrap();
    // Strip every attribute from the group and the array.
    for f in ["zarr.json", "field/zarr.json"] {
        let p = path.join(f);
        let mut j: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(&p).unwrap()).unwrap();
        j.as_object_mut().unwrap().remove("attributes");
        fs::write(&p, j.to_string()).unwrap();
    }
    let (back, lattice, has) = read_zarr(&path).unwrap();
    assert!(!has);
    assert_eq!(back.origin, Vec3::ZERO);
    assert_eq!(back.spacing, Vec3::ONE);
    assert_eq!(back.data, v.data);
    assert_eq!(lattice.band, None);
    assert_eq!(lattice.inside, Inside::Below);
}

/// Some chunk file below `dir`.
fn a_chunk_file(dir: &Path) -> std::path::PathBuf {
    let mut at = dir.to_path_buf();
    while at.is_dir() {
        at = fs::read_dir(&at).unwrap().next().unwrap().unwrap().path();
    }
    at
}

fn edit_json(path: &Path, f: impl FnOnce(&mut serde_json::Value)) {
    let mut j: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(path).unwrap()).unwrap();
    f(&mut j);
    fs::write(path, j.to_string()).unwrap();
}

#[test]
fn hostile_stores_are_refused_with_an_error() {
    let t = TempDir::new("zarr-hostile");
    let (v, meta) = sphere_band([20, 18, 16]);
    let fresh = |name: &str| {
        let p = t.path(name);
        write_zarr(&p, &v, &meta, opts(8)).unwrap();
        p
    };
    let refused = |p: &Path, needle: &str| {
        let err = read_zarr(p).map(|_| ()).unwrap_err();
        let source = std::error::Error::source(&err).map(|s| s.to_string());
        let e = format!("{err}: {}", source.unwrap_or_default());
        assert!(e.to_lowercase().contains(needle), "{}: {e}", p.display());
    };
    refused(&t.path("missing.zarr"), "no such");
    fs::create_dir(t.path("empty.zarr")).unwrap();
    refused(&t.path("empty.zarr"), "not a zarr store");
    let p = fresh("json.zarr");
    fs::write(p.join("field/zarr.json"), "{not json").unwrap();
    refused(&p, "error parsing metadata for field/zarr.json");
    let p = fresh("root.zarr");
    fs::write(p.join("zarr.json"), "[1, 2").unwrap();
    refused(&p, "neither an array nor a group");
    let p = fresh("dims.zarr");
    edit_json(&p.join("zarr.json"), |j| {
        j["attributes"]["dims"] = serde_json::json!([1, 2, 3])
    });
    refused(&p, "do not match");
    let p = fresh("spacing.zarr");
    edit_json(&p.join("zarr.json"), |j| {
        j["attributes"]["spacing"] = serde_json::json!([0, 1, 1])
    });
    refused(&p, "spacing");
    let p = fresh("type.zarr");
    edit_json(&p.join("field/zarr.json"), |j| {
        j["data_type"] = "int16".into();
        j["fill_value"] = 0.into();
    });
    refused(&p, "int16");
    let p = fresh("chunk.zarr");
    let chunk = a_chunk_file(&p.join("field/c"));
    fs::write(&chunk, b"\x1f\x8b\x08\0garbage").unwrap();
    refused(&p, "deflate");
    let p = fresh("short.zarr");
    let chunk = a_chunk_file(&p.join("field/c"));
    let raw = fs::read(&chunk).unwrap();
    fs::write(&chunk, &raw[..raw.len() / 2]).unwrap();
    refused(&p, "deflate");
    let p = fresh("huge.zarr");
    edit_json(&p.join("field/zarr.json"), |j| {
        j["shape"] = serde_json::json!([1u64 << 40, 1u64 << 40, 1u64 << 40])
    });
    edit_json(&p.join("zarr.json"), |j| {
        j["attributes"]["dims"] = serde_json::json!([1u64 << 40, 1u64 << 40, 1u64 << 40]);
    });
    assert!(read_zarr(&p).is_err());
    let p = fresh("rect.zarr");
    edit_json(&p.join("field/zarr.json"), |j| {
        j["chunk_grid"] = serde_json::json!({"name": "rectilinear", "configuration":
            {"kind": "inline", "chunk_shapes": [[8, 8, 2], [8, 8, 2], [8, 8]]}});
    });
    assert!(read_zarr(&p).is_err());
    assert!(zarr_info(&p).is_err());
    assert!(isokit_io::zarr::ZarrSource::open(&p, 1 << 20).is_err());
    let p = fresh("bigchunk.zarr");
    edit_json(&p.join("field/zarr.json"), |j| {
        j["chunk_grid"]["configuration"]["chunk_shape"] = serde_json::json!([1u64 << 22, 8, 8]);
    });
    refused(&p, "chunks of");
    assert!(isokit_io::zarr::ZarrSource::open(&p, 1 << 20).is_err());
    let p = fresh("manychunks.zarr");
    edit_json(&p.join("field/zarr.json"), |j| {
        j["shape"] = serde_json::json!([1u64 << 12, 1u64 << 12, 1u64 << 12]);
        j["chunk_grid"]["configuration"]["chunk_shape"] = serde_json::json!([1, 1, 1]);
        j.as_object_mut().unwrap().remove("attributes");
    });
    edit_json(&p.join("zarr.json"), |j| {
        j.as_object_mut().unwrap().remove("attributes");
    });
    let e = zarr_info(&p).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("chunks"), "{e}");
    let p = fresh("twod.zarr");
    edit_json(&p.join("field/zarr.json"), |j| {
        j["shape"] = serde_json::json!([18, 20]);
        j["chunk_grid"]["configuration"]["chunk_shape"] = serde_json::json!([8, 8]);
        j["dimension_names"] = serde_json::json!(["y", "x"]);
    });
    assert!(read_zarr(&p).is_err());
}

#[test]
fn a_progress_file_cut_short_or_garbled_never_marks_an_unwritten_chunk_done() {
    let t = TempDir::new("zarr-progress");
    let (v, meta) = sphere_band([40, 36, 30]);
    let path = t.path("g.zarr");
    let o = ZarrOptions {
        fingerprint: Some(7),
        ..opts(16)
    };
    let w = ZarrWriter::create(&path, &meta, o).unwrap();
    let all = w.pending();
    let block = |w: &ZarrWriter, idx| block_of(&v, w, idx);
    for &idx in &all[..3] {
        w.write_chunk(idx, &block(&w, idx)).unwrap();
    }
    // A chunk outside the grid is refused, not a panic.
    assert!(w.write_chunk([9, 9, 9], &[]).is_err());
    drop(w);
    // Lines outside the grid, of the wrong length or flag, and one cut short by a kill
    // (which the next append would otherwise complete into a valid-looking line).
    let progress = partial_path(&path).join(".isokit-progress");
    let mut f = fs::OpenOptions::new().append(true).open(&progress).unwrap();
    std::io::Write::write_all(&mut f, b"99 0 0 1\n1 1\n1 1 1 7\nx y z 1\n1 1 ").unwrap();
    drop(f);
    let info = zarr_info(&partial_path(&path)).unwrap();
    assert_eq!(info.missing_chunks as usize, all.len() - 3);
    // Another input (fingerprint) cannot resume it; the same one finishes it.
    let other = ZarrOptions {
        fingerprint: Some(8),
        ..o
    };
    let e = ZarrWriter::resume(&path, &meta, other)
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(e.contains("input"), "{e}");
    let w = ZarrWriter::resume(&path, &meta, o).unwrap();
    assert_eq!(w.pending(), all[3..].to_vec());
    for idx in w.pending() {
        w.write_chunk(idx, &block(&w, idx)).unwrap();
    }
    w.finish().unwrap();
    assert_eq!(read_zarr(&path).unwrap().0.data, v.data);
    assert!(!path.join(".isokit-progress").exists());
}

#[test]
fn a_sharded_store_reads_back_bit_for_bit_in_fewer_files() {
    let t = TempDir::new("zarr-shard");
    let (v, meta) = sphere_band([70, 61, 56]);
    let (plain, sharded) = (t.path("p.zarr"), t.path("s.zarr"));
    write_zarr(&plain, &v, &meta, opts(8)).unwrap();
    let o = ZarrOptions {
        shard: 4,
        ..opts(8)
    };
    let w = write_zarr(&sharded, &v, &meta, o).unwrap();
    let (back, _, _) = read_zarr(&sharded).unwrap();
    assert!(
        back.data
            .iter()
            .zip(&v.data)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
    let (pi, si) = (zarr_info(&plain).unwrap(), zarr_info(&sharded).unwrap());
    assert_eq!(si.chunk_shape, [32, 32, 32]);
    assert_eq!(si.subchunk_shape, Some([8, 8, 8]));
    assert_eq!(pi.subchunk_shape, None);
    assert_eq!(si.present as usize, w.written);
    println!(
        "{} chunk files against {} shard files",
        pi.present, si.present
    );
    assert!(
        si.present * 4 < pi.present,
        "{} shards, {} chunks",
        si.present,
        pi.present
    );
    // Read on demand, chunk by chunk inside the shards: the same samples.
    let src = isokit_io::zarr::ZarrSource::open(&sharded, 1 << 20).unwrap();
    for (i, j, k) in [(0, 0, 0), (69, 60, 55), (35, 30, 28), (33, 1, 50)] {
        assert_eq!(src.get(i, j, k), v.data[i + 70 * (j + 61 * k)]);
    }
    // A shard wider than the largest chunk, or of no chunk, is refused.
    for shard in [0, 64] {
        let o = ZarrOptions { shard, ..opts(8) };
        assert!(write_zarr(&t.path("bad.zarr"), &v, &meta, o).is_err());
    }
}
