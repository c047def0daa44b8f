//! `isokit render PATCHES.ply --segmented -o image.png`: the surfaces between the regions of
//! surface patches (a PLY whose faces carry `region_front` and `region_back`), ray cast in
//! their segmented distance field (003 Sec. 4, `isokit_render::segmented`), each region
//! pair in a colour of its own, on the GPU twin or the CPU's as `--backend` says;
//! `--gbuffer` adds the channels `region_a` and `region_b`.

use super::Args;
use super::segmented_args::{TINTS, composite_knobs, refuse};
use anyhow::Result;
use isokit_levelset::segmented::renumber;
use isokit_render::segmented::SegmentedCaster;
use isokit_render::{Shading, camera_uniforms, shade};
use serde_json::json;
use std::collections::BTreeMap;
use std::time::Instant;

/// Renders `a.input` (surface patches) as `--segmented` says.
pub fn run(a: &Args, width: u32, height: u32) -> Result<()> {
    refuse(a)?;
    let mode = super::tets::shading_without_curvature(
        a,
        "the surfaces between regions are found without curvature",
    )?;
    let t = Instant::now();
    let (mut grid, seg) = crate::cmd::segmented_field::load(&a.input, a.res, &a.segmented.knobs)?;
    // 003's step 6: dense indices, so the diagram spans no unused region.
    let old = renumber(&mut grid, &seg)?;
    let prepare = t.elapsed().as_secs_f64();
    let caster = SegmentedCaster::new(&grid, seg, a.segmented.diagram)?;
    let camera = a.camera.camera_for(grid.bounds(), width, height)?;
    let u = camera_uniforms(&camera)?;
    let mut renderer = crate::cmd::args::open_renderer(a.backend)?;
    let backend = renderer.backend();
    let (opacity, n) = composite_knobs(a)?;
    let t = Instant::now();
    let mut layers = match renderer.gpu() {
        Some(gpu) => gpu.render_segmented_layers(&caster, &u, n)?,
        None => caster.render_layers(&u, &crate::cmd::progress::job(), n)?,
    };
    let trace = t.elapsed().as_secs_f64();
    // The pairs in the patches' own numbering, each with its pixels.
    for layer in &mut layers {
        for p in layer.pairs.iter_mut().flatten() {
            *p = p.map(|r| old[r as usize]);
        }
    }
    let img = &layers[0];
    let pairs = &img.pairs;
    let mut counts: BTreeMap<[i32; 2], usize> = BTreeMap::new();
    for p in pairs.iter().flatten() {
        *counts.entry(*p).or_default() += 1;
    }
    // A colour per pair seen in any layer, in the order of the pairs.
    let seen: std::collections::BTreeSet<[i32; 2]> = layers
        .iter()
        .flat_map(|l| l.pairs.iter().flatten().copied())
        .collect();
    let tint: BTreeMap<[i32; 2], [f32; 3]> = seen
        .iter()
        .enumerate()
        .map(|(i, p)| (*p, TINTS[i % TINTS.len()]))
        .collect();
    let sh = Shading {
        mode,
        ..Shading::default()
    };
    let mut shaded = Vec::with_capacity(layers.len());
    for layer in &layers {
        let mut image = shade(&layer.gbuffer, &u, &sh)?;
        for (px, pair) in image.pixels.iter_mut().zip(&layer.pairs) {
            if let Some(c) = pair.and_then(|p| tint.get(&p)) {
                (0..3).for_each(|k| px[k] *= c[k]);
            }
        }
        shaded.push(image);
    }
    let image = if opacity < 1.0 {
        let [r, g, b, _] = sh.background;
        isokit_render::segmented::composite(&layers, &shaded, opacity, glam::Vec3::new(r, g, b))?
    } else {
        shaded.remove(0)
    };
    image.write_png(&a.output)?;
    if let Some(g) = &a.gbuffer {
        let side = |k: usize| -> Vec<f32> {
            pairs
                .iter()
                .map(|p| p.map_or(-1.0, |p| p[k] as f32))
                .collect()
        };
        let (ra, rb) = (side(0), side(1));
        img.gbuffer
            .write_exr_with_channels(g, &camera, &[("region_a", &ra), ("region_b", &rb)])?;
    }
    let hits: usize = counts.values().sum();
    let samples: u64 = img.gbuffer.samples().iter().map(|&s| u64::from(s)).sum();
    let per_ray = samples as f64 / f64::from(width * height);
    let d = grid.dims();
    let how = a.segmented.diagram.map_or("003 Eq. 5-7".to_owned(), |n| {
        format!("the vertex generation diagram, {n} levels per period")
    });
    let list: Vec<String> = counts
        .iter()
        .map(|(p, n)| format!("{}|{}: {n} pixels", p[0], p[1]))
        .collect();
    eprintln!(
        "segmented distance on {} x {} x {} samples ({} regions), ray cast by {how} ({backend}), {width}x{height}: {hits} surface pixels, {per_ray:.1} samples/ray; sample {prepare:.2} s, trace {trace:.3} s -> {}\n  {}",
        d[0],
        d[1],
        d[2],
        old.len(),
        a.output.display(),
        list.join("\n  ")
    );
    if a.stats {
        let v = json!({
            "device": backend,
            "dims": d,
            "regions": old,
            "pairs": counts.iter().map(|(p, n)| json!({"regions": p, "pixels": n})).collect::<Vec<_>>(),
            "hits": hits,
            "samples_per_ray": per_ray,
            "diagram": a.segmented.diagram,
            "opacity": opacity,
            "layer_hits": layers.iter().map(|l| l.pairs.iter().flatten().count()).collect::<Vec<_>>(),
            "prepare_seconds": prepare,
            "trace_seconds": trace,
            "width": width,
            "height": height,
            "output": a.output.display().to_string(),
        });
        println!("{v}");
    }
    Ok(())
}
