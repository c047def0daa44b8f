//! `isokit octree INPUT --max-level L …`: an adaptively sampled field in a hashed octree,
//! with its size, build time and error against the exact field.

mod args;
mod bench;
mod mesh;
mod summary;

pub use args::Args;
pub use bench::{BenchArgs, bench};

use super::check_output;
use anyhow::{Result, bail};
use isokit_io::Volume;
use isokit_octree::{
    BuildOptions, Construction, HashedOctree, Octree, bound_misses, errors, test_points,
};
use isokit_scene::input::open_field;
use serde_json::json;

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    let mesh_out = a.output.as_deref().filter(|o| super::is_mesh_output(o));
    if let Some(o) = &a.output {
        if mesh_out.is_some() {
            check_output(o, &super::MESH_OUTPUTS)?;
        } else {
            let mut allowed = crate::cmd::volume_args::VOLUME_OUTPUTS.to_vec();
            allowed.extend(super::MESH_OUTPUTS);
            check_output(o, &allowed)?;
            a.out.check(o)?;
        }
    }
    if mesh_out.is_none() && (a.mesher.is_some() || a.mesh_error.is_some()) {
        bail!(
            "--mesher and --mesh-error apply to a mesh output (-o out.obj, .ply, .stl, .off, .glb, .gltf)"
        );
    }
    let mesh_error = super::mesher_args::MesherOpts {
        mesher: a.mesher,
        error: a.mesh_error,
    }
    .error()
    .map_err(|e| anyhow::anyhow!("{}", e.to_string().replace("--error", "--mesh-error")))?;
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
    if mesh_out.is_some() {
        mesh::check_level(export_level)?;
    }
    let inp = open_field(&a.input, a.knobs.options())?;
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
    let tree = HashedOctree::build_job(&*inp.field, bounds, &opts, &super::progress::job())?;
    let st = tree.stats().clone();
    let test_band = a.test_band.unwrap_or(2.0 * h);
    if !(test_band.is_finite() && test_band > 0.0) {
        bail!("--test-band {test_band} must be finite and positive");
    }
    let pts = test_points(
        &*inp.field,
        inp.mesh.as_ref(),
        domain.bounds(),
        test_band,
        a.test_points,
        a.seed,
    );
    let e = errors(&tree, &*inp.field, &pts);
    let (max_error, rms_error) = (e.max, e.rms);
    let miss = bound_misses(&tree, &*inp.field, &pts, opts.error as f64);
    let mut meshed = None;
    let exported = match &a.output {
        Some(o) if mesh_out.is_some() => {
            meshed = Some(mesh::mesh_tree(
                &tree,
                &*inp.field,
                export_level,
                a.mesher.unwrap_or_default(),
                mesh_error,
                o,
            )?);
            Some((o.display().to_string(), [(1usize << export_level) + 1; 3]))
        }
        Some(o) => {
            let g = tree.to_grid(export_level)?;
            let dims = g.dims();
            a.out.write(o, &Volume::from(g), None, None)?;
            Some((o.display().to_string(), dims))
        }
        None => None,
    };
    let (cells_bytes, nodes_bytes) = tree.memory_split();
    let mut v = json!({
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
        "test_cell_cache_hit_rate": e.cell_hit_rate,
        "test_node_cache_hit_rate": e.node_hit_rate,
        "threads": rayon::current_num_threads(),
        "output": exported.as_ref().map(|(p, _)| p.clone()),
        "export_level": exported.as_ref().map(|_| export_level),
        "export_dims": exported.as_ref().map(|(_, d)| *d),
    });
    // Where the maximum level, not the bound, stopped the refinement.
    v["bound_missed_cells"] = miss.missed_cells.into();
    v["bound_missed_cells_at_max_level"] = miss.missed_at_max_level.into();
    v["level_for_bound"] = miss.level_for_bound.into();
    if let Some(serde_json::Value::Object(m)) = meshed {
        v.as_object_mut()
            .into_iter()
            .for_each(|o| o.extend(m.clone()));
    }
    if a.json {
        println!("{v}");
    } else {
        summary::print(&v);
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
