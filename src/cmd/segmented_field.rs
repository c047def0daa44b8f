//! Segmented distance fields (003 Eq. 4) on the command line: sampled from surface patches (a
//! PLY whose faces carry `region_front` and `region_back`) or read from the NRRD file that
//! `isokit sdf PATCHES.ply --segmented` writes (its header's `field:=segmented`,
//! `delta:=δ`, `period:=D`, world units); `--seg-morph B --seg-morph-t T` blends two of them with
//! the region index carried through (003 Sec. 5.2).

use anyhow::{Context, Result, bail};
use isokit_field::Grid;
use isokit_levelset::segmented::{Segmentation, morph_segmented};
use isokit_scene::segmented::Patches;
use std::path::{Path, PathBuf};

/// How patches are sampled into a segmented field, and the morph.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct SegmentedKnobs {
    /// --segmented patches: 003 Eq. 4's distance clamp δ, in lattice spacings [default: 4].
    #[arg(long)]
    pub seg_delta: Option<f32>,
    /// --segmented patches: 003 Eq. 4's region period D, in lattice spacings, more than δ
    /// [default: 8].
    #[arg(long)]
    pub seg_period: Option<f32>,
    /// --segmented: blend the field with this segmented field (an NRRD of `isokit sdf
    /// --segmented` on the same lattice, with the same δ, D and region numbering; 003 Sec. 5.2).
    #[arg(long)]
    pub seg_morph: Option<PathBuf>,
    /// --seg-morph: the blend, from 0 (the input) to 1 (the --seg-morph field)
    /// [default: 0.5].
    #[arg(long)]
    pub seg_morph_t: Option<f32>,
}

impl SegmentedKnobs {
    /// The knobs given, by flag (for refusals where they do not apply).
    pub fn given(&self) -> [(bool, &'static str); 4] {
        [
            (self.seg_delta.is_some(), "--seg-delta"),
            (self.seg_period.is_some(), "--seg-period"),
            (self.seg_morph.is_some(), "--seg-morph"),
            (self.seg_morph_t.is_some(), "--seg-morph-t"),
        ]
    }
}

/// The segmented field of `path`: patches (`.ply`) sampled at `res` (default 64) along the
/// longest side of their box padded by 10% of its diagonal, or a segmented NRRD file read
/// as it is (`--res`, `--seg-delta` and `--seg-period` are refused there); then blended with
/// `--seg-morph` where given.
pub fn load(
    path: &Path,
    res: Option<usize>,
    knobs: &SegmentedKnobs,
) -> Result<(Grid, Segmentation)> {
    let (grid, seg) = if isokit_io::MeshFormat::from_path(path).is_ok() {
        sample_patches(path, res, knobs)?
    } else {
        for (given, flag) in [(res.is_some(), "--res")]
            .into_iter()
            .chain(knobs.given().into_iter().take(2))
        {
            if given {
                bail!(
                    "{flag} applies to surface patches (.ply); {} is a sampled field",
                    path.display()
                );
            }
        }
        read(path)?
    };
    if knobs.seg_morph_t.is_some() && knobs.seg_morph.is_none() {
        bail!("--seg-morph-t needs --seg-morph B (the segmented field to blend with)");
    }
    let Some(other) = &knobs.seg_morph else {
        return Ok((grid, seg));
    };
    let t = knobs.seg_morph_t.unwrap_or(0.5);
    let (b, seg_b) = read(other)?;
    if seg_b != seg {
        bail!(
            "--seg-morph {}: δ {} and D {} differ from the input's ({} and {}); sample both with the same --res, --seg-delta and --seg-period",
            other.display(),
            seg_b.delta(),
            seg_b.period(),
            seg.delta(),
            seg.period()
        );
    }
    let blend = morph_segmented(&grid, &b, &seg, t)
        .with_context(|| format!("--seg-morph {} --seg-morph-t {t}", other.display()))?;
    Ok((blend, seg))
}

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
    let mut grid = super::padded_grid(path, mesh.bounds(), res.unwrap_or(64), None)?;
    let h = grid.spacing();
    let (delta, period) = (
        knobs.seg_delta.unwrap_or(4.0),
        knobs.seg_period.unwrap_or(8.0),
    );
    let seg = Segmentation::new(delta * h, period * h)
        .with_context(|| format!("--seg-delta {delta} --seg-period {period} (in spacings)"))?;
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
    let v = isokit_io::read_volume(path)?;
    v.check()?;
    if !v.is_uniform() {
        bail!(
            "{}: a segmented field needs one spacing on all axes (it is never resampled), not {}",
            path.display(),
            v.spacing
        );
    }
    Ok((v.into_grid()?, seg))
}

/// Writes `grid` as an NRRD (raw, atomically) with `field:=segmented`, `delta:=` and
/// `period:=` in its header.
pub fn write(path: &Path, grid: &Grid, seg: &Segmentation) -> Result<()> {
    let (d, p) = (seg.delta().to_string(), seg.period().to_string());
    let pairs = [
        ("field", "segmented"),
        ("delta", d.as_str()),
        ("period", p.as_str()),
    ];
    let vol = isokit_io::Volume::from(grid.clone());
    isokit_io::write_nrrd_key_values(path, &vol, isokit_io::NrrdEncoding::Raw, &pairs)?;
    Ok(())
}
