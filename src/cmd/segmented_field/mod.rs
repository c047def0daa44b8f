//! Segmented distance fields (003 Eq. 4) on the command line: sampled from surface patches (a
//! PLY whose faces carry `region_front` and `region_back`) or read from the NRRD file that
//! `isokit sdf PATCHES.ply --segmented` writes (its header's `field:=segmented`,
//! `delta:=δ`, `period:=D`, world units); `--seg-morph B --seg-morph-t T` blends two of them with
//! the region index carried through (003 Sec. 5.2).

mod sources;

use sources::from_labels;
pub use sources::{read, sample_patches, write};

use anyhow::{Context, Result, bail};
use isokit_field::Grid;
use isokit_levelset::segmented::{Segmentation, morph_segmented};
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
    /// --segmented: the input volume holds labels (a whole number from 0 to 4095 per
    /// sample, a segmented CT): its interfaces are meshed by surface nets and their
    /// segmented distance sampled on the volume's own lattice.
    #[arg(long)]
    pub from_labels: bool,
}

impl SegmentedKnobs {
    /// The knobs given, by flag (for refusals where they do not apply).
    pub fn given(&self) -> [(bool, &'static str); 5] {
        [
            (self.seg_delta.is_some(), "--seg-delta"),
            (self.seg_period.is_some(), "--seg-period"),
            (self.seg_morph.is_some(), "--seg-morph"),
            (self.seg_morph_t.is_some(), "--seg-morph-t"),
            (self.from_labels, "--from-labels"),
        ]
    }

    /// 003 Eq. 4's constants for a lattice of spacing `h` (`--seg-delta`, `--seg-period`,
    /// in spacings).
    pub(super) fn segmentation(&self, h: f32) -> Result<Segmentation> {
        let (delta, period) = (
            self.seg_delta.unwrap_or(4.0),
            self.seg_period.unwrap_or(8.0),
        );
        Segmentation::new(delta * h, period * h)
            .with_context(|| format!("--seg-delta {delta} --seg-period {period} (in spacings)"))
    }
}

/// Refuses a segmented field (an NRRD whose header says `field:=segmented`) given without
/// `--segmented`: its values are region indices and distances, not one field to contour.
pub fn refuse_unflagged(path: &Path) -> Result<()> {
    let nrrd = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("nrrd") || e.eq_ignore_ascii_case("nhdr"));
    if nrrd
        && isokit_io::read_nrrd_key_values(path)
            .is_ok_and(|kv| kv.iter().any(|(k, v)| k == "field" && v == "segmented"))
    {
        bail!(
            "{} is a segmented field (its header says field:=segmented): add --segmented",
            path.display()
        );
    }
    Ok(())
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
    if crate::cmd::tets::is_tets(path) {
        bail!(
            "--segmented takes surface patches (.ply), a segmented field (`isokit sdf --segmented`) or a label volume with --from-labels; {} is a tetrahedral grid",
            path.display()
        );
    }
    let patches = isokit_io::MeshFormat::from_path(path).is_ok();
    let (grid, seg) = if knobs.from_labels {
        if patches || res.is_some() {
            bail!(
                "--from-labels reads a label volume (.nrrd .nhdr .npy .nii .nii.gz) on its own lattice{}",
                if patches {
                    ", not surface patches"
                } else {
                    "; --res does not apply"
                }
            );
        }
        from_labels(path, knobs)?
    } else if patches {
        sample_patches(path, res, knobs)?
    } else {
        let sampling = [(res.is_some(), "--res")];
        for (given, flag) in sampling
            .into_iter()
            .chain(knobs.given().into_iter().take(2))
        {
            if given {
                bail!(
                    "{flag} applies to surface patches (.ply) and --from-labels; {} is a sampled field",
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
    // Near the blend's surfaces (within two spacings), where the two differ in region and
    // one of them is clamped, their surfaces are more than δ apart: the blend there holds no
    // true distance to an interface.
    let near = 2.0 * grid.spacing();
    let far = grid
        .data()
        .iter()
        .zip(b.data())
        .zip(blend.data())
        .filter(|((x, y), z)| {
            match (seg.decode(**x), seg.decode(**y), seg.decode(**z)) {
                // At the clamp, to the f32 rounding of `D r + δ`.
                (Some((i, d)), Some((j, e)), Some((_, f))) => {
                    i != j && f < near && d.max(e) >= seg.delta() * (1.0 - 1e-4)
                }
                _ => false,
            }
        })
        .count();
    if far > 0 {
        eprintln!(
            "warning: in {far} samples near the blend's surfaces the two fields' surfaces are more than δ = {} apart, so the blend there is not exact (003 Sec. 5.2 blends distances clamped at δ); sample both with a larger --seg-delta (and --seg-period)",
            seg.delta()
        );
    }
    Ok((blend, seg))
}
