//! `isokit sdf PATCHES.ply --segmented -o field.nrrd`: the segmented distance field (003 Eq. 4)
//! of surface patches, written with `field:=segmented`, `delta:=` and `period:=` in its NRRD
//! header, for `isokit mesh` and `isokit render` to read with `--segmented`.

use super::Args;
use super::args::{Backend, Method, Sides};
use crate::cmd::mesh_args::Sign;
use crate::cmd::segmented_field::{load, write};
use crate::cmd::volume_args::Compression;
use anyhow::{Result, bail};
use std::time::Instant;

/// Samples the patches in `a.mesh` and writes their field.
pub fn run(a: &Args) -> Result<()> {
    crate::cmd::check_output(&a.output, &[".nrrd"])?;
    let defaults = isokit_kdtree::tree::BuildParams::default();
    for (given, flag) in [
        (a.method != Method::Kdtree, "--method prism"),
        (a.band.is_some(), "--band"),
        (a.dense, "--dense"),
        (a.backend == Backend::Gpu, "--backend gpu"),
        (a.lattice.padding.is_some(), "--padding"),
        (a.lattice.placement.bounds.is_some(), "--bounds"),
        (a.lattice.placement.like.is_some(), "--like"),
        (a.knobs.sign != Sign::Auto, "--sign"),
        (a.knobs.leaf_size != defaults.leaf_size, "--leaf-size"),
        (a.knobs.max_overlap != defaults.max_overlap, "--max-overlap"),
        (a.knobs.beta != 2.0, "--beta"),
        (a.prism_sides != Sides::Exact, "--prism-sides"),
        (a.no_gap_repair, "--no-gap-repair"),
        (
            a.res.is_some() && a.segmented_knobs.from_labels,
            "--res with --from-labels (the labels' own lattice)",
        ),
    ] {
        if given {
            bail!(
                "{flag} does not apply to --segmented (the patches' distances come from their kd-tree, on a lattice of --res samples over their padded box)"
            );
        }
    }
    let ply = isokit_io::MeshFormat::from_path(&a.mesh).ok() == Some(isokit_io::MeshFormat::Ply);
    if !ply && !a.segmented_knobs.from_labels {
        bail!(
            "--segmented samples surface patches: a PLY whose faces carry region_front and region_back (or a label volume with --from-labels), not {}",
            a.mesh.display()
        );
    }
    let t = Instant::now();
    let (grid, seg) = load(&a.mesh, a.res, &a.segmented_knobs)?;
    let secs = t.elapsed().as_secs_f64();
    let encoding = match a.out.compression {
        Compression::None => isokit_io::NrrdEncoding::Raw,
        Compression::Fast => isokit_io::NrrdEncoding::Gzip,
        Compression::Best => isokit_io::NrrdEncoding::GzipBest,
    };
    write(&a.output, &grid, &seg, encoding)?;
    let d = grid.dims();
    let regions: std::collections::BTreeSet<i32> = grid
        .data()
        .iter()
        .filter_map(|&f| seg.decode(f).map(|(r, _)| r))
        .collect();
    eprintln!(
        "segmented distance (delta {}, period {}) on {} x {} x {} samples, regions {:?}, in {secs:.2} s -> {}",
        seg.delta(),
        seg.period(),
        d[0],
        d[1],
        d[2],
        regions,
        a.output.display()
    );
    Ok(())
}
