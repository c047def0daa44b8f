//! `isokit octree INPUT --max-level L …`: an adaptively sampled field in a hashed octree,
//! with its size, build time and error against the exact field.

use super::check_output;
use super::mesh_args::MeshKnobs;
use super::sample::{Shape, primitive};
use anyhow::{Context, Result, bail};
use clap::ValueEnum;
use glam::Vec3;
use isokit_field::filter::{Filter, SampledField};
use isokit_field::rng::SplitMix64;
use isokit_field::{Aabb, Field};
use isokit_io::{FileKind, TriMesh, Volume, detect_kind, read_mesh, read_volume, write_volume};
use isokit_kdtree::MeshSdf;
use isokit_octree::{BuildOptions, Construction, HashedOctree, Octree};
use serde_json::json;
use std::path::{Path, PathBuf};

/// Arguments of `isokit octree`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A mesh (.obj .gltf .glb .ply .stl .off: exact distance through the kd-tree), a volume
    /// (.nrrd .nhdr .npy .nii .nii.gz: its trilinear reconstruction, which is then also the
    /// reference for the error), or a primitive name with its default size (sphere, box,
    /// rounded-box, torus, capsule, cylinder, cone, ellipsoid; see `isokit sample --help`).
    /// Scenes come with a later issue.
    pub input: String,
    /// Finest level (the root is level 0; 2^L cells a side), at most 21.
    #[arg(long)]
    pub max_level: u32,
    /// Cells above this level are always subdivided [default: min(2, max level)].
    #[arg(long)]
    pub min_level: Option<u32>,
    /// Error bound in world units: half for the cells' trilinear reconstruction at their test
    /// points, half for hanging nodes [default: a tenth of a finest cell].
    #[arg(long)]
    pub error: Option<f32>,
    /// Extra levels of test points per cell (for small features of general fields), 0 to 4.
    #[arg(long, default_value_t = 0)]
    pub lookahead: u32,
    /// Half-width of the band around the surface where the bound holds, in world units
    /// [default: two finest cells].
    #[arg(long)]
    pub band: Option<f32>,
    /// Half-width of the band where the test points lie [default: two finest cells].
    #[arg(long)]
    pub test_band: Option<f32>,
    /// Evaluate the whole finest grid and coalesce (guaranteed feature capture; refused when
    /// the dense grid is too large).
    #[arg(long)]
    pub bottom_up: bool,
    /// Leave hanging nodes interpolated without refining their coarse leaves (the thesis's
    /// construction; the bound then holds only where no hanging node is near).
    #[arg(long)]
    pub no_hanging_refinement: bool,
    /// Stop with an error beyond this many cells (a tree costs about 20 to 60 bytes per cell
    /// while it is built).
    #[arg(long, default_value_t = isokit_octree::DEFAULT_MAX_CELLS)]
    pub max_cells: usize,
    /// Margin around the input's bounds in world units [default: 10% of the diagonal for
    /// meshes and primitives, 0 for volumes].
    #[arg(long)]
    pub padding: Option<f32>,
    /// Export the tree sampled on a grid (.nrrd or .npy).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Level of the exported grid (2^level + 1 samples a side) [default: min(max level, 8)].
    #[arg(long)]
    pub export_level: Option<u32>,
    /// Random test points within the band (independent of the construction).
    #[arg(long, default_value_t = 20_000)]
    pub test_points: usize,
    /// Seed of the test points.
    #[arg(long, default_value_t = 2026)]
    pub seed: u64,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    pub knobs: MeshKnobs,
}

/// The field to sample and what it is.
pub struct Input {
    /// The field.
    pub field: Box<dyn Field>,
    /// The mesh, when the input is one (test points are drawn on its triangles).
    pub mesh: Option<TriMesh>,
    /// Bounds to cover before padding.
    pub bounds: Aabb,
    /// Default padding.
    pub pad: f32,
    /// One line about the input.
    pub what: String,
    /// What the errors are measured against.
    pub reference: &'static str,
}

/// Reads or makes the input.
pub fn input(name: &str, knobs: &MeshKnobs) -> Result<Input> {
    let path = Path::new(name);
    if path.exists() {
        return match detect_kind(path)? {
            FileKind::Mesh => {
                let mesh = read_mesh(path)?;
                let sdf = MeshSdf::new(&mesh, knobs.options()).with_context(|| name.to_string())?;
                let bounds = sdf.bounds();
                let what = format!(
                    "mesh {name}: {} triangles, sign {} ({})",
                    mesh.triangles.len(),
                    sdf.sign_method().name(),
                    sdf.sign_reason()
                );
                Ok(Input {
                    pad: 0.1 * bounds.diagonal(),
                    bounds,
                    field: Box::new(sdf),
                    mesh: Some(mesh),
                    what,
                    reference: "exact distance (kd-tree)",
                })
            }
            FileKind::Volume => {
                let v: Volume = read_volume(path)?;
                let dims = v.dims;
                let grid = if v.is_uniform() {
                    v.into_grid()?
                } else {
                    let s = v.spacing.min_element();
                    v.resample_uniform(s)?
                };
                let bounds = grid.bounds();
                let what = format!(
                    "volume {name}: {} x {} x {} samples, trilinear",
                    dims[0], dims[1], dims[2]
                );
                Ok(Input {
                    field: Box::new(SampledField::new(grid, Filter::Trilinear)),
                    mesh: None,
                    bounds,
                    pad: 0.0,
                    what,
                    reference: "the volume's trilinear reconstruction (no exact reference)",
                })
            }
            FileKind::PointCloud => {
                bail!("{name}: point clouds become fields with the points crate (a later issue)")
            }
            FileKind::Image => bail!("{name}: an image is not a field"),
        };
    }
    let Ok(shape) = Shape::from_str(name, true) else {
        bail!(
            "{name}: no such file, and not a primitive name (sphere, box, rounded-box, torus, capsule, cylinder, cone, ellipsoid)"
        );
    };
    if shape == Shape::Plane {
        bail!("a plane is unbounded: an octree needs a bounded shape");
    }
    // The primitive with `isokit sample`'s defaults.
    #[derive(clap::Parser)]
    struct Defaults {
        #[command(flatten)]
        a: super::sample::Args,
    }
    let d =
        <Defaults as clap::Parser>::try_parse_from(["isokit", shape.name(), "-o", "unused.nrrd"])
            .context("default shape options")?;
    let p = primitive(&d.a)?;
    let bounds = p.bounds();
    Ok(Input {
        field: Box::new(p),
        mesh: None,
        pad: 0.1 * bounds.diagonal(),
        bounds,
        what: format!("{} ({})", shape.name(), shape.usage()),
        reference: "exact distance (analytic)",
    })
}

/// `n` random points within `band` of the surface: on the mesh's triangles moved by up to
/// `band`, or by rejection from uniform points in `domain` (at most 2000 rounds of 65536).
pub fn test_points(inp: &Input, domain: Aabb, band: f32, n: usize, seed: u64) -> Vec<Vec3> {
    let mut r = SplitMix64::new(seed);
    if let Some(mesh) = &inp.mesh {
        if !mesh.triangles.is_empty() {
            let mut out = Vec::with_capacity(n);
            let mut tries = 0;
            while out.len() < n && tries < 100 * n {
                tries += 1;
                let t = mesh.triangles[r.below(mesh.triangles.len())];
                let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
                let (u, v) = (r.next_f32().sqrt(), r.next_f32());
                let on = (1.0 - u) * a + u * (1.0 - v) * b + u * v * c;
                let p = on + r.unit_vector() * (band * r.next_f32().cbrt());
                if domain.contains(p) {
                    out.push(p);
                }
            }
            return out;
        }
    }
    let mut out = Vec::with_capacity(n);
    for _ in 0..2000 {
        if out.len() >= n {
            break;
        }
        let cand: Vec<Vec3> = (0..65536)
            .map(|_| r.point_in(domain.min, domain.max))
            .collect();
        let mut v = vec![0.0f32; cand.len()];
        inp.field.values(&cand, &mut v);
        out.extend(
            cand.iter()
                .zip(&v)
                .filter(|(_, v)| v.abs() <= band)
                .map(|(p, _)| *p),
        );
    }
    out.truncate(n);
    out
}

/// Max and RMS of `|tree − field|` at `pts`, and the accessor's cache hit rates (cell, node).
pub fn errors(tree: &HashedOctree, field: &dyn Field, pts: &[Vec3]) -> (f64, f64, f64, f64) {
    let mut exact = vec![0.0f32; pts.len()];
    field.values(pts, &mut exact);
    let mut a = tree.accessor();
    let (mut max, mut sum) = (0.0f64, 0.0f64);
    for (&p, &e) in pts.iter().zip(&exact) {
        let d = (a.value(p) - e).abs() as f64;
        max = max.max(d);
        sum += d * d;
    }
    let rms = if pts.is_empty() {
        f64::NAN
    } else {
        (sum / pts.len() as f64).sqrt()
    };
    (
        if pts.is_empty() { f64::NAN } else { max },
        rms,
        a.cell_stats().hit_rate(),
        a.node_stats().hit_rate(),
    )
}

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    if let Some(o) = &a.output {
        check_output(o, &[".nrrd", ".npy"])?;
    }
    let l = a.max_level;
    if l > isokit_octree::MAX_LEVEL {
        bail!(
            "--max-level {l} is too deep: at most {}",
            isokit_octree::MAX_LEVEL
        );
    }
    let export_level = a.export_level.unwrap_or(l.min(8));
    if a.output.is_some() && export_level > l {
        bail!("--export-level {export_level} is finer than --max-level {l}");
    }
    let inp = input(&a.input, &a.knobs)?;
    if !inp.field.bounds().is_finite() {
        bail!("{}: unbounded field", a.input);
    }
    let pad = a.padding.unwrap_or(inp.pad);
    if !(pad.is_finite() && pad >= 0.0) {
        bail!("--padding {pad} must be finite and non-negative");
    }
    let bounds = inp.bounds.expanded(pad);
    let domain = isokit_octree::Domain::cube_around(bounds, l)?;
    let h = domain.finest_spacing() as f32;
    let band = a.band.unwrap_or(2.0 * h);
    let opts = BuildOptions {
        min_level: a.min_level.unwrap_or(l.min(2)),
        error: a.error.unwrap_or(0.1 * h),
        lookahead: a.lookahead,
        band,
        construction: if a.bottom_up {
            Construction::BottomUp
        } else {
            Construction::TopDown
        },
        refine_hanging: !a.no_hanging_refinement,
        max_cells: a.max_cells,
        ..BuildOptions::new(l)
    };
    let tree = HashedOctree::build(&*inp.field, bounds, &opts)?;
    let st = tree.stats().clone();
    let test_band = a.test_band.unwrap_or(2.0 * h);
    if !(test_band.is_finite() && test_band > 0.0) {
        bail!("--test-band {test_band} must be finite and positive");
    }
    let pts = test_points(&inp, domain.bounds(), test_band, a.test_points, a.seed);
    let (max_error, rms_error, cell_hits, node_hits) = errors(&tree, &*inp.field, &pts);
    let exported = match &a.output {
        Some(o) => {
            let g = tree.to_grid(export_level)?;
            let dims = g.dims();
            write_volume(o, &Volume::from(g))?;
            Some((o.display().to_string(), dims))
        }
        None => None,
    };
    let (cells_bytes, nodes_bytes) = tree.memory_split();
    let v = json!({
        "input": a.input,
        "what": inp.what,
        "reference": inp.reference,
        "exact_reference": inp.reference.starts_with("exact"),
        "construction": if a.bottom_up { "bottom-up" } else { "top-down" },
        "max_level": l,
        "min_level": opts.min_level,
        "error_bound": opts.error,
        "lookahead": opts.lookahead,
        "band": band,
        "test_band": test_band,
        "narrow_keys": tree.narrow_keys(),
        "refine_hanging": opts.refine_hanging,
        "domain_origin": domain.origin().to_array(),
        "domain_side": domain.side(),
        "finest_spacing": h,
        "cells": tree.cell_count(),
        "leaves": st.leaves_per_level.iter().sum::<u64>(),
        "leaves_per_level": st.leaves_per_level,
        "nodes": tree.node_count(),
        "hanging_nodes": st.hanging_nodes,
        "memory_bytes": tree.memory_bytes(),
        "cell_set_bytes": cells_bytes,
        "node_map_bytes": nodes_bytes,
        "bytes_per_cell": tree.bytes_per_cell(),
        "build_seconds": st.seconds,
        "finalize_passes": st.passes,
        "evaluations": st.evaluations,
        "dense_samples": ((1u64 << l) + 1).pow(3),
        "dense_fraction": st.dense_fraction,
        "test_points": pts.len(),
        "max_error": max_error,
        "rms_error": rms_error,
        "build_cell_cache_hit_rate": st.cell_cache.hit_rate(),
        "build_node_cache_hit_rate": st.node_cache.hit_rate(),
        "test_cell_cache_hit_rate": cell_hits,
        "test_node_cache_hit_rate": node_hits,
        "threads": rayon::current_num_threads(),
        "output": exported.as_ref().map(|(p, _)| p.clone()),
        "export_level": exported.as_ref().map(|_| export_level),
    });
    if a.json {
        println!("{v}");
    } else {
        println!("{}", inp.what);
        println!(
            "domain: cube of side {} at {:?}, levels {}..={l}, finest cell {h:.4e}",
            domain.side(),
            domain.origin().to_array(),
            opts.min_level
        );
        println!(
            "{} cells ({} leaves, per level {:?}), {} nodes ({} hanging), {:.1} bytes per cell",
            tree.cell_count(),
            st.leaves_per_level.iter().sum::<u64>(),
            st.leaves_per_level,
            tree.node_count(),
            st.hanging_nodes,
            tree.bytes_per_cell()
        );
        println!(
            "built in {:.3} s ({} finalize passes), {} field evaluations = {:.4}% of the dense {}^3 grid",
            st.seconds,
            st.passes,
            st.evaluations,
            100.0 * st.dense_fraction,
            (1u64 << l) + 1
        );
        println!(
            "error at {} random points within {test_band:.3e} of the surface, against {}: max {max_error:.3e}, rms {rms_error:.3e} (bound {:.3e})",
            pts.len(),
            inp.reference,
            opts.error
        );
        if let Some((p, d)) = &exported {
            println!(
                "-> {p} ({} x {} x {}, level {export_level})",
                d[0], d[1], d[2]
            );
        }
    }
    if pts.len() < a.test_points {
        eprintln!(
            "note: found only {} of {} test points within the band",
            pts.len(),
            a.test_points
        );
    }
    Ok(())
}

/// Arguments of `isokit bench octree`.
#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    /// Random cell accesses per tree and variant (002 Table 3.1 used 50 million).
    #[arg(long, default_value_t = 2_000_000)]
    pub accesses: usize,
    /// First maximum level measured.
    #[arg(long, default_value_t = 5)]
    pub first_level: u32,
    /// Last maximum level measured (the trees grow about 4x per level).
    #[arg(long, default_value_t = 10)]
    pub last_level: u32,
    /// Seed of the access points.
    #[arg(long, default_value_t = 2026)]
    pub seed: u64,
    /// Timing runs per variant; the fastest counts.
    #[arg(long, default_value_t = 3)]
    pub repeat: usize,
    /// Print one JSON object.
    #[arg(long)]
    pub json: bool,
}

/// Points near the surface: on a unit sphere's surface or the mesh's triangles, moved by up
/// to `reach`.
fn access_points(mesh: Option<&TriMesh>, reach: f32, n: usize, seed: u64) -> Vec<Vec3> {
    let mut r = SplitMix64::new(seed);
    (0..n)
        .map(|_| {
            let on = match mesh {
                Some(m) => {
                    let t = m.triangles[r.below(m.triangles.len())];
                    let [a, b, c] = t.map(|v| m.positions[v as usize]);
                    let (u, v) = (r.next_f32().sqrt(), r.next_f32());
                    (1.0 - u) * a + u * (1.0 - v) * b + u * v * c
                }
                None => r.unit_vector(),
            };
            on + r.unit_vector() * (reach * r.next_f32())
        })
        .collect()
}

/// Seconds for `locate` over all points on one thread, and a checksum of the cells found.
fn time_locate(pts: &[Vec3], mut locate: impl FnMut(Vec3) -> isokit_octree::Cell) -> (f64, u64) {
    let t = std::time::Instant::now();
    let mut sum = 0u64;
    for &p in pts {
        let c = locate(p);
        sum = sum.wrapping_mul(31).wrapping_add(
            c.level as u64
                ^ ((c.pos.x as u64) << 8)
                ^ ((c.pos.y as u64) << 24)
                ^ ((c.pos.z as u64) << 40),
        );
    }
    (t.elapsed().as_secs_f64(), std::hint::black_box(sum))
}

/// Seconds for `value` over all points on one thread, and their sum.
fn time_value(pts: &[Vec3], mut value: impl FnMut(Vec3) -> f32) -> (f64, f64) {
    let t = std::time::Instant::now();
    let mut sum = 0.0f64;
    for &p in pts {
        sum += value(p) as f64;
    }
    (t.elapsed().as_secs_f64(), std::hint::black_box(sum))
}

/// `isokit bench octree`: 002 Table 3.1 on this machine.
pub fn bench(a: BenchArgs) -> Result<()> {
    use isokit_octree::LinkedOctree;
    if a.accesses == 0 || a.repeat == 0 {
        bail!("--accesses and --repeat must be at least 1");
    }
    if a.first_level > a.last_level || a.last_level > 12 {
        bail!(
            "levels {}..={}: need first <= last <= 12",
            a.first_level,
            a.last_level
        );
    }
    let sphere = isokit_field::primitives::Sphere::new(Vec3::ZERO, 1.0)?;
    let mesh = isokit_io::generate::tube(|u| isokit_io::generate::trefoil(u, 0.5), 0.18, 192, 16);
    let sdf = MeshSdf::new(&mesh, isokit_kdtree::MeshOptions::default())?;
    let datasets: Vec<(&str, &dyn Field, Option<&TriMesh>)> = vec![
        ("sphere", &sphere, None),
        ("trefoil tube (6144 triangles)", &sdf, Some(&mesh)),
    ];
    let mut rows = Vec::new();
    for (name, field, m) in datasets {
        // A cube twice the object's longest side, centred on it (a sphere of radius 1 in
        // [-2, 2]^3).
        let b = field.bounds();
        let bounds = b.expanded(0.5 * b.size().max_element());
        let reach = 0.01 * b.diagonal();
        let pts = access_points(m, reach, a.accesses, a.seed);
        for level in a.first_level..=a.last_level {
            // The thesis's construction: every cell the surface may pass is subdivided to
            // the finest level; hanging nodes interpolated.
            let opts = BuildOptions {
                refine_hanging: false,
                ..BuildOptions::new(level)
            };
            let h = HashedOctree::build(field, bounds, &opts)?;
            let t = std::time::Instant::now();
            let k = LinkedOctree::from_hashed(&h);
            let convert = t.elapsed().as_secs_f64();
            let (mut hs, mut bs, mut cs, mut ks, mut hv, mut kv) = (
                f64::INFINITY,
                f64::INFINITY,
                f64::INFINITY,
                f64::INFINITY,
                f64::INFINITY,
                f64::INFINITY,
            );
            let mut hit_rate = 0.0;
            for _ in 0..a.repeat {
                // Interleaved, so that drift of the machine hits all variants alike.
                let (t, hsum) = time_locate(&pts, |p| h.locate(p));
                hs = hs.min(t);
                let (t, ksum) = time_locate(&pts, |p| k.locate(p));
                ks = ks.min(t);
                let (t, bsum) = time_locate(&pts, |p| h.locate_binary(p));
                bs = bs.min(t);
                let mut acc = h.accessor();
                let (t, csum) = time_locate(&pts, |p| acc.locate(p));
                cs = cs.min(t);
                hit_rate = acc.cell_stats().hit_rate();
                if hsum != ksum || bsum != ksum || csum != ksum {
                    bail!(
                        "{name}, level {level}: the trees located different cells: this is a bug"
                    );
                }
                let (t, hvs) = time_value(&pts, |p| h.value(p));
                hv = hv.min(t);
                let (t, kvs) = time_value(&pts, |p| k.value(p));
                kv = kv.min(t);
                if hvs.to_bits() != kvs.to_bits() {
                    bail!("{name}, level {level}: the trees gave different values: this is a bug");
                }
            }
            let mean_level =
                pts.iter().map(|&p| h.locate(p).level as f64).sum::<f64>() / pts.len() as f64;
            rows.push(json!({
                "dataset": name,
                "level": level,
                "cells": h.cell_count(),
                "nodes": h.node_count(),
                "build_seconds": h.stats().seconds,
                "convert_seconds": convert,
                "average_access_level_from_finest": level as f64 - mean_level,
                "hashed_seconds": hs,
                "hashed_binary_seconds": bs,
                "hashed_cached_seconds": cs,
                "cell_cache_hit_rate": hit_rate,
                "linked_seconds": ks,
                "speedup": ks / hs.max(1e-12),
                "speedup_binary": ks / bs.max(1e-12),
                "hashed_value_seconds": hv,
                "linked_value_seconds": kv,
                "hashed_bytes_per_cell": h.bytes_per_cell(),
                "linked_bytes_per_cell": k.bytes_per_cell(),
                "memory_ratio": h.bytes_per_cell() / k.bytes_per_cell(),
            }));
            if !a.json {
                eprintln!(
                    "{name} level {level}: {} cells, locate hashed {hs:.3} s, linked {ks:.3} s ({:.2}x); {:.1} vs {:.1} bytes/cell",
                    h.cell_count(),
                    ks / hs.max(1e-12),
                    h.bytes_per_cell(),
                    k.bytes_per_cell()
                );
            }
        }
    }
    let col =
        |key: &str| -> Vec<serde_json::Value> { rows.iter().map(|r| r[key].clone()).collect() };
    let v = json!({
        "accesses": a.accesses,
        "repeat": a.repeat,
        "threads_timed": 1,
        "construction": "error 0, band 0, Lipschitz culling, hanging nodes interpolated (thesis)",
        "datasets": col("dataset"),
        "levels": col("level"),
        "cells": col("cells"),
        "hashed_seconds": col("hashed_seconds"),
        "hashed_binary_seconds": col("hashed_binary_seconds"),
        "hashed_cached_seconds": col("hashed_cached_seconds"),
        "linked_seconds": col("linked_seconds"),
        "speedup": col("speedup"),
        "hashed_value_seconds": col("hashed_value_seconds"),
        "linked_value_seconds": col("linked_value_seconds"),
        "hashed_bytes_per_cell": col("hashed_bytes_per_cell"),
        "linked_bytes_per_cell": col("linked_bytes_per_cell"),
        "memory_ratio": col("memory_ratio"),
        "rows": rows,
    });
    if a.json {
        println!("{v}");
    } else {
        println!(
            "{:<32} {:>5} {:>10} {:>10} {:>10} {:>8} {:>9} {:>9}",
            "dataset", "level", "cells", "hashed s", "linked s", "speedup", "hash B/c", "link B/c"
        );
        for r in &rows {
            println!(
                "{:<32} {:>5} {:>10} {:>10.3} {:>10.3} {:>8.2} {:>9.1} {:>9.1}",
                r["dataset"].as_str().unwrap_or(""),
                r["level"],
                r["cells"],
                r["hashed_seconds"].as_f64().unwrap_or(f64::NAN),
                r["linked_seconds"].as_f64().unwrap_or(f64::NAN),
                r["speedup"].as_f64().unwrap_or(f64::NAN),
                r["hashed_bytes_per_cell"].as_f64().unwrap_or(f64::NAN),
                r["linked_bytes_per_cell"].as_f64().unwrap_or(f64::NAN),
            );
        }
        println!(
            "{} random accesses near the surface per tree, one thread, fastest of {}",
            a.accesses, a.repeat
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn knobs() -> MeshKnobs {
        #[derive(clap::Parser)]
        struct K {
            #[command(flatten)]
            k: MeshKnobs,
        }
        <K as clap::Parser>::try_parse_from(["t"]).unwrap().k
    }

    #[test]
    fn every_bounded_primitive_is_an_input() {
        for s in Shape::value_variants() {
            let r = input(s.name(), &knobs());
            if *s == Shape::Plane {
                assert!(r.is_err());
            } else {
                let i = r.unwrap();
                assert!(i.bounds.is_finite() && i.field.is_exact(), "{}", s.name());
            }
        }
        assert!(input("no-such-thing", &knobs()).is_err());
    }
}
