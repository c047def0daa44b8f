//! `isokit mesh LABELS.nrrd --labels -o out.ply`: the surface between the regions of a label
//! volume (`isokit_levelset::labels`, surface nets on labels), written as a PLY whose faces
//! carry the two regions they separate (`region_a < region_b`, int32).

use super::mesh::{Args, Inside};
use anyhow::{Result, bail};
use isokit_levelset::labels::{LabelOptions, label_surface};
use std::time::Instant;

/// Meshes `a.field` as labels.
pub fn run(a: &Args) -> Result<()> {
    super::check_output(&a.output, &[".ply"])?;
    for (given, flag) in [
        (a.iso != 0.0, "--iso"),
        (a.inside != Inside::Below, "--inside"),
        (a.open, "--open"),
        (a.mesher != super::mesher_args::MesherArg::Mc, "--mesher"),
        (a.array.is_some(), "--array"),
    ] {
        if given {
            bail!("{flag} does not apply to --labels (the surface lies between the regions)");
        }
    }
    if super::tets::is_tets(&a.field) {
        bail!(
            "--labels meshes label volumes (.nrrd .nhdr .npy .nii .nii.gz), not tetrahedral grids"
        );
    }
    let grid = a.volume.read(&a.field)?.into_grid()?;
    let t = Instant::now();
    let mut opts = LabelOptions::default();
    if let Some(n) = a.smooth {
        opts.smoothing = n;
    }
    let m = label_surface(&grid, &opts, &super::progress::job())?;
    let secs = t.elapsed().as_secs_f64();
    if m.mesh.triangles.is_empty() {
        eprintln!("warning: every sample is label 0 (outside); the mesh is empty");
    }
    isokit_io::write_ply_regions(&a.output, &m.mesh, &m.regions)?;
    let pairs = m.pairs();
    let list: Vec<String> = pairs
        .iter()
        .map(|(p, n, area)| format!("{}|{}: {n} triangles, area {area:.6}", p[0], p[1]))
        .collect();
    eprintln!(
        "{} vertices, {} triangles between {} region pairs in {secs:.3} s ({} smoothing passes) -> {}\n  {}",
        m.mesh.positions.len(),
        m.mesh.triangles.len(),
        pairs.len(),
        opts.smoothing,
        a.output.display(),
        list.join("\n  ")
    );
    Ok(())
}
