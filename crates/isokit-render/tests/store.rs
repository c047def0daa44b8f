//! Ray casting a Zarr store read on demand: the frame equals the frame of the same samples
//! held in memory, bit for bit, with a chunk cache far smaller than the field (chunks are
//! decoded again after eviction), on both twins; a corrupt chunk is reported, not a panic.

use glam::Vec3;
use isokit_io::lattice::Lattice;
use isokit_io::zarr::{ZarrOptions, ZarrSource, write_zarr};
use isokit_render::{BrickCache, Layout, RenderOptions, Volume};
use std::sync::Arc;

mod common;
use common::twin::twins;
use common::*;

fn store(dir: &std::path::Path, name: &str) -> (std::path::PathBuf, isokit_field::Grid) {
    store_sharded(dir, name, 1)
}

fn store_sharded(
    dir: &std::path::Path,
    name: &str,
    shard: usize,
) -> (std::path::PathBuf, isokit_field::Grid) {
    let g = two_spheres();
    let v = isokit_io::Volume::from_grid(&g);
    let meta = Lattice {
        band: None,
        ..Lattice::of(&v)
    };
    let path = dir.join(name);
    write_zarr(
        &path,
        &v,
        &meta,
        ZarrOptions {
            chunk: 16,
            gzip: Some(1),
            shard,
            fingerprint: None,
        },
    )
    .unwrap();
    (path, g)
}

fn scratch(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("isokit-render-store-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn a_store_read_on_demand_renders_the_frame_of_the_samples_in_memory() {
    let dir = scratch("frame");
    let (path, grid) = store(&dir, "s.zarr");
    let cam = perspective(Vec3::new(0.4, 0.5, 2.6), 96, 80);
    let opts = RenderOptions::default();
    // Two chunks of 16³ at most: 64 chunks in the field.
    let source = Arc::new(ZarrSource::open(&path, 2 * 16 * 16 * 16 * 4).unwrap());
    assert_eq!(source.cache_chunks(), 2);
    let streamed = Volume::from_store(source.clone(), Layout::default()).unwrap();
    let dense = Volume::from_grid(grid, Layout::default()).unwrap();
    let mut ran = 0;
    for mut t in twins("a_store_read_on_demand_renders_the_frame_of_the_samples_in_memory") {
        let a = t.render(&streamed, &cam, &opts).unwrap();
        let b = t.render(&dense, &cam, &opts).unwrap();
        assert_eq!(a.stats.hits, b.stats.hits);
        assert!(a.stats.hits > 400, "{} hits", a.stats.hits);
        assert!(
            a.gbuffer.pixels() == b.gbuffer.pixels(),
            "gpu {}: the G-buffers differ",
            t.is_gpu()
        );
        ran += 1;
    }
    assert!(ran >= 1);
    // Every chunk was decoded, and some again after eviction: the cache stayed small.
    assert!(source.loads() > 64, "{} chunk loads", source.loads());
    assert!(source.error().is_none());
    // A sharded store (2³ chunks a file), read by the chunks inside the shards: the same.
    let (path2, _) = store_sharded(&dir, "sh.zarr", 2);
    let sharded = Arc::new(ZarrSource::open(&path2, 2 * 16 * 16 * 16 * 4).unwrap());
    let v2 = Volume::from_store(sharded.clone(), Layout::default()).unwrap();
    let mut cpu = twins("a_sharded_store").next().unwrap();
    let a = cpu.render(&v2, &cam, &opts).unwrap();
    let b = cpu.render(&dense, &cam, &opts).unwrap();
    assert!(
        a.gbuffer.pixels() == b.gbuffer.pixels(),
        "the sharded store's frame differs"
    );
    assert!(sharded.error().is_none());
    // The CPU renderer's own entry point with a brick cache of the store.
    let mut cache = BrickCache::for_volume(&streamed);
    let f = isokit_render::render(&streamed, &mut cache, &cam, &opts).unwrap();
    assert!(f.stats.hits > 400);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_corrupt_chunk_reads_as_nan_and_is_reported() {
    let dir = scratch("corrupt");
    let (path, _) = store(&dir, "c.zarr");
    let chunk = path.join("field/c/1/1/1");
    assert!(chunk.is_file());
    std::fs::write(&chunk, b"not gzip").unwrap();
    let source = Arc::new(ZarrSource::open(&path, 1 << 20).unwrap());
    let v = Volume::from_store(source.clone(), Layout::default()).unwrap();
    let e = source
        .error()
        .expect("the block scan read the corrupt chunk");
    assert!(e.contains("chunk [1, 1, 1]"), "{e}");
    assert!(v.data().get_clamped(glam::IVec3::new(20, 20, 20)).is_nan());
    let _ = std::fs::remove_dir_all(&dir);
}
