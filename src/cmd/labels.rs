//! `isokit mesh LABELS.nrrd --labels -o out.ply`: the surface between the regions of a label
//! volume (`isokit_levelset::labels`, surface nets on labels), written as a PLY whose faces
//! carry the two regions they separate (`region_a < region_b`, int32); `isokit mesh
//! PATCHES.ply --segmented -o out.ply`: the same from surface patches through their
//! segmented distance field (`isokit_scene::segmented`, `isokit_levelset::segmented`).

use super::mesh::{Args, Inside};
use anyhow::{Context, Result, bail};
use isokit_levelset::labels::{LabelMesh, LabelOptions, label_surface_spaced};
use isokit_levelset::segmented::mesh_segmented;
use std::time::Instant;

/// Refuses the flags that do not apply to meshing regions (`what`: `--labels` or
/// `--segmented`).
fn refuse(a: &Args, what: &str, extra: &[(bool, &str)]) -> Result<()> {
    super::check_output(&a.output, &[".ply"])?;
    let common = [
        (a.iso != 0.0, "--iso"),
        (a.inside != Inside::Below, "--inside"),
        (a.open, "--open"),
        (a.mesher.mesher.is_some(), "--mesher"),
        (a.array.is_some(), "--array"),
    ];
    for &(given, flag) in common.iter().chain(extra) {
        if given {
            bail!("{flag} does not apply to {what} (the surface lies between the regions)");
        }
    }
    Ok(())
}

/// Meshes `a.field` as labels.
pub fn run(a: &Args) -> Result<()> {
    let res = [(a.res.is_some(), "--res")];
    let extra: Vec<(bool, &str)> = res.into_iter().chain(a.segmented_knobs.given()).collect();
    refuse(a, "--labels", &extra)?;
    if super::tets::is_tets(&a.field) {
        bail!(
            "--labels meshes label volumes (.nrrd .nhdr .npy .nii .nii.gz), not tetrahedral grids"
        );
    }
    // Surface nets need no uniform spacing: a CT's thicker slices are kept as they are.
    let v = a.volume.read(&a.field)?;
    v.check()?;
    let t = Instant::now();
    let mut opts = LabelOptions::default();
    if let Some(n) = a.smooth {
        opts.smoothing = n;
    }
    let job = super::progress::job();
    let m = label_surface_spaced(v.dims, v.origin, v.spacing, &v.data, &opts, &job)
        .with_context(|| a.field.display().to_string())?;
    let secs = t.elapsed().as_secs_f64();
    if m.mesh.triangles.is_empty() {
        eprintln!("warning: every sample is label 0 (outside); the mesh is empty");
    }
    report(a, &m, secs, &format!("{} smoothing passes", opts.smoothing))
}

/// Writes the mesh and prints its counts and region pairs.
fn report(a: &Args, m: &LabelMesh, secs: f64, how: &str) -> Result<()> {
    isokit_io::write_ply_regions(&a.output, &m.mesh, &m.regions)?;
    let pairs = m.pairs();
    let list: Vec<String> = pairs
        .iter()
        .map(|(p, n, area)| format!("{}|{}: {n} triangles, area {area:.6}", p[0], p[1]))
        .collect();
    eprintln!(
        "{} vertices, {} triangles between {} region pairs in {secs:.3} s ({how}) -> {}\n  {}",
        m.mesh.positions.len(),
        m.mesh.triangles.len(),
        pairs.len(),
        a.output.display(),
        list.join("\n  ")
    );
    Ok(())
}

/// Meshes the patches in `a.field` through their segmented distance field.
pub fn run_segmented(a: &Args) -> Result<()> {
    refuse(
        a,
        "--segmented",
        &[
            (a.smooth.is_some(), "--smooth"),
            (a.volume.origin.is_some(), "--origin"),
            (a.volume.spacing.is_some(), "--spacing"),
        ],
    )?;
    let t = Instant::now();
    let (grid, seg) = super::segmented_field::load(&a.field, a.res, &a.segmented_knobs)?;
    let job = super::progress::job();
    let m = mesh_segmented(&grid, &seg, &job)?;
    if m.mesh.triangles.is_empty() {
        eprintln!(
            "warning: no surface between regions (are the patches degenerate, or region_front and region_back the same on every face?); the mesh is empty"
        );
    }
    let d = grid.dims();
    report(
        a,
        &m,
        t.elapsed().as_secs_f64(),
        &format!(
            "segmented distance on {} x {} x {} samples",
            d[0], d[1], d[2]
        ),
    )
}
