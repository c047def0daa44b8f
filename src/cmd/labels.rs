//! `isokit mesh LABELS.nrrd --labels -o out.ply`: the surface between the regions of a label
//! volume (`isokit_levelset::labels`, surface nets on labels), written as a PLY whose faces
//! carry the two regions they separate (`region_a < region_b`, int32); `isokit mesh
//! PATCHES.ply --segmented -o out.ply`: the same from surface patches through their
//! segmented distance field (`isokit_scene::segmented`, `isokit_levelset::segmented`).

use super::mesh::{Args, Inside};
use anyhow::{Context, Result, bail};
use isokit_levelset::labels::{LabelMesh, LabelOptions, label_surface_spaced};
use isokit_levelset::segmented::{Segmentation, mesh_segmented};
use isokit_scene::segmented::Patches;
use std::time::Instant;

/// Refuses the flags that do not apply to meshing regions (`what`: `--labels` or
/// `--segmented`).
fn refuse(a: &Args, what: &str, extra: &[(bool, &str)]) -> Result<()> {
    super::check_output(&a.output, &[".ply"])?;
    let common = [
        (a.iso != 0.0, "--iso"),
        (a.inside != Inside::Below, "--inside"),
        (a.open, "--open"),
        (a.mesher != super::mesher_args::MesherArg::Mc, "--mesher"),
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
    refuse(a, "--labels", &[(a.res.is_some(), "--res")])?;
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

/// The segmented distance field (003 Eq. 4, `δ` 4 and `D` 8 spacings) of the surface
/// patches in the PLY at `path` (faces with `region_front` and `region_back`), sampled at
/// `res` (default 64) along the longest side of their box padded by 10% of its diagonal;
/// regions that meet where no patch separates them are merged, with a note.
pub fn sample_patches(
    path: &std::path::Path,
    res: Option<usize>,
) -> Result<(isokit_field::Grid, Segmentation)> {
    let (mesh, props) =
        isokit_io::read_ply_face_properties(path, &["region_front", "region_back"])?;
    if mesh.triangles.is_empty() {
        bail!("{}: the mesh has no triangles", path.display());
    }
    let regions = |name: &str, v: &[f64]| -> Result<Vec<i32>> {
        v.iter()
            .map(|&x| {
                if x.fract() == 0.0 && (0.0..4096.0).contains(&x) {
                    Ok(x as i32)
                } else {
                    bail!(
                        "{}: {name} {x}: regions are whole numbers from 0 to 4095",
                        path.display()
                    )
                }
            })
            .collect()
    };
    let front = regions("region_front", &props[0])?;
    let back = regions("region_back", &props[1])?;
    let mut grid = super::padded_grid(path, mesh.bounds(), res.unwrap_or(64), None)?;
    let seg = Segmentation::for_spacing(grid.spacing())?;
    let name = path.display().to_string();
    let patches = Patches::new(&mesh, front, back, &name)?;
    let merges = patches.sample(&mut grid, &seg, &super::progress::job())?;
    for (from, into) in &merges {
        eprintln!(
            "note: region {from} meets region {into} where no patch separates them: merged into {into}"
        );
    }
    Ok((grid, seg))
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
    let (grid, seg) = sample_patches(&a.field, a.res)?;
    let job = super::progress::job();
    let m = mesh_segmented(&grid, &seg, &job)?;
    if m.mesh.triangles.is_empty() {
        eprintln!(
            "warning: no surface between regions (are region_front and region_back the same on every face?); the mesh is empty"
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
