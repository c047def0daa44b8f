//! Where segmented fields come from: surface patches, label volumes and the NRRD files
//! [`write`] makes.

use super::SegmentedKnobs;
use anyhow::{Context, Result, bail};
use isokit_field::Grid;
use isokit_levelset::segmented::Segmentation;
use isokit_scene::segmented::Patches;
use std::path::Path;

/// Samples the patches in the PLY at `path` (see [`load`]); regions that meet where no
/// patch separates them are merged, with a note.
pub fn sample_patches(
    path: &Path,
    res: Option<usize>,
    knobs: &SegmentedKnobs,
) -> Result<(Grid, Segmentation)> {
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
    let mut grid = crate::cmd::padded_grid(path, mesh.bounds(), res.unwrap_or(64), None)?;
    let seg = knobs.segmentation(grid.spacing())?;
    let name = path.display().to_string();
    let patches = Patches::new(&mesh, front, back, &name)?;
    let merges = patches.sample(&mut grid, &seg, &crate::cmd::progress::job())?;
    for (from, into) in &merges {
        eprintln!(
            "note: region {from} meets region {into} where no patch separates them: merged into {into}"
        );
    }
    Ok((grid, seg))
}

/// The segmented field of the label volume at `path` (`isokit_scene::segmented::from_labels`,
/// relaxed 16 times as `isokit mesh --labels` is by default).
pub(super) fn from_labels(path: &Path, knobs: &SegmentedKnobs) -> Result<(Grid, Segmentation)> {
    let v = crate::cmd::volume_args::VolumeIn::default().read(path)?;
    if !v.is_uniform() {
        bail!(
            "{}: --from-labels needs one spacing on all axes (labels are never resampled), not {}",
            path.display(),
            v.spacing
        );
    }
    let labels = v.into_grid()?;
    let seg = knobs.segmentation(labels.spacing())?;
    let opts = isokit_levelset::labels::LabelOptions::default();
    let grid =
        isokit_scene::segmented::from_labels(&labels, &seg, &opts, &crate::cmd::progress::job())
            .with_context(|| path.display().to_string())?;
    Ok((grid, seg))
}

/// Reads a segmented field written by [`write`]: a uniform lattice (never resampled:
/// interpolating across regions makes values of neither) with its δ and D.
pub fn read(path: &Path) -> Result<(Grid, Segmentation)> {
    let kv = match isokit_io::read_nrrd_key_values(path) {
        Ok(kv) => kv,
        Err(e) if path.exists() => {
            bail!(
                "{}: not a segmented field, an NRRD written by `isokit sdf PATCHES.ply --segmented` ({e})",
                path.display()
            )
        }
        Err(e) => return Err(e.into()),
    };
    let get = |k: &str| kv.iter().find(|(key, _)| key == k).map(|(_, v)| v.as_str());
    if get("field") != Some("segmented") {
        bail!(
            "{}: not a segmented field (its NRRD header has no field:=segmented; `isokit sdf PATCHES.ply --segmented` writes one)",
            path.display()
        );
    }
    let number = |k: &str| -> Result<f32> {
        get(k)
            .and_then(|v| v.trim().parse::<f32>().ok())
            .with_context(|| format!("{}: the header's {k}:= is not a number", path.display()))
    };
    let seg = Segmentation::new(number("delta")?, number("period")?)
        .with_context(|| path.display().to_string())?;
    let v = crate::cmd::volume_args::VolumeIn::default().read(path)?;
    if !v.is_uniform() {
        bail!(
            "{}: a segmented field needs one spacing on all axes (it is never resampled), not {}",
            path.display(),
            v.spacing
        );
    }
    let regions = isokit_levelset::segmented::MAX_REGIONS;
    if let Some((i, f)) = v.data.iter().enumerate().find(|(_, f)| {
        seg.decode(**f)
            .is_some_and(|(r, _)| !(0..regions).contains(&r))
    }) {
        bail!(
            "{}: sample {i} ({f}) decodes to a region beyond {} (with period {}); not a segmented field of isokit",
            path.display(),
            regions - 1,
            seg.period()
        );
    }
    Ok((v.into_grid()?, seg))
}

/// Writes `grid` as an NRRD (atomically, encoded as `encoding` says) with
/// `field:=segmented`, `delta:=` and `period:=` in its header.
pub fn write(
    path: &Path,
    grid: &Grid,
    seg: &Segmentation,
    encoding: isokit_io::NrrdEncoding,
) -> Result<()> {
    let (d, p) = (seg.delta().to_string(), seg.period().to_string());
    let pairs = [
        ("field", "segmented"),
        ("delta", d.as_str()),
        ("period", p.as_str()),
    ];
    let vol = isokit_io::Volume::from(grid.clone());
    isokit_io::write_nrrd_key_values(path, &vol, encoding, &pairs)?;
    Ok(())
}
