//! The flags of `isokit render --segmented` and what they may not be combined with.

use super::Args;
use anyhow::{Result, bail};

/// The flags of `isokit render --segmented`.
#[derive(clap::Args, Debug)]
pub struct SegmentedArgs {
    /// The input is a PLY of surface patches with the face properties `region_front` and
    /// `region_back` (sampled at --res, default 64), a segmented field (`isokit sdf
    /// --segmented`) or with --from-labels a label volume: render the surfaces between the
    /// regions (junctions, boundaries).
    #[arg(long)]
    pub segmented: bool,
    /// --segmented: find the surface through 003's vertex generation diagram, a table of
    /// this many entries per region period, instead of evaluating 003 Eq. 5–7 per step.
    #[arg(long, requires = "segmented")]
    pub diagram: Option<usize>,
    /// --segmented: the surfaces' opacity; below 1 the first --layers surfaces along each
    /// ray are composited front to back, so inner interfaces show through [default: 1].
    #[arg(long, requires = "segmented")]
    pub opacity: Option<f32>,
    /// --opacity: surfaces composited per ray, 1 to 16 [default: 8].
    #[arg(long, requires = "opacity")]
    pub layers: Option<usize>,
    #[command(flatten)]
    pub knobs: crate::cmd::segmented_field::SegmentedKnobs,
}

/// Linear RGB tints of the region pairs, in the order of the pairs.
pub const TINTS: [[f32; 3]; 8] = [
    [0.90, 0.35, 0.25],
    [0.25, 0.55, 0.90],
    [0.35, 0.80, 0.35],
    [0.95, 0.80, 0.25],
    [0.70, 0.40, 0.85],
    [0.25, 0.80, 0.80],
    [0.95, 0.55, 0.75],
    [0.60, 0.60, 0.60],
];

/// Whether the input is rendered as a segmented field (`--segmented`); its knobs without it
/// are refused.
pub fn segmented(a: &Args) -> Result<bool> {
    if !a.segmented.segmented
        && let Some((_, flag)) = a.segmented.knobs.given().into_iter().find(|g| g.0)
    {
        bail!("{flag} applies to --segmented");
    }
    if !a.segmented.segmented {
        crate::cmd::segmented_field::refuse_unflagged(&a.input)?;
    }
    Ok(a.segmented.segmented)
}

/// Refuses the flags `--segmented` does not take.
pub fn refuse(a: &Args) -> Result<()> {
    if a.mode == super::args::RenderMode::Dvr {
        bail!("--mode dvr is not available for --segmented (the surfaces between regions)");
    }
    a.refuse_dvr_flags_except(&[])?;
    let extra = [
        (a.iso.is_some(), "--iso (the surfaces lie between regions)"),
        (a.array.is_some(), "--array"),
        (a.inside != crate::cmd::args::InsideArg::Below, "--inside"),
        (a.lattice.any(), "a spherical lattice"),
    ];
    // --res is the patches' sampling here.
    let one_ray = super::tets::one_ray_flags(a)?;
    for &(given, flag) in one_ray.iter().filter(|f| f.1 != "--res").chain(&extra) {
        if given {
            bail!("{flag} is not available for --segmented (one ray per pixel, between regions)");
        }
    }
    Ok(())
}

/// The surfaces' opacity and how many layers are composited (1 for opaque surfaces).
pub fn composite_knobs(a: &Args) -> Result<(f32, usize)> {
    let opacity = a.segmented.opacity.unwrap_or(1.0);
    if !(opacity > 0.0 && opacity <= 1.0) {
        bail!("--opacity {opacity}: must be above 0 and at most 1");
    }
    match (opacity < 1.0, a.segmented.layers) {
        (true, layers) => Ok((opacity, layers.unwrap_or(8))),
        (false, Some(_)) => {
            bail!("--layers composites translucent surfaces: give --opacity below 1")
        }
        (false, None) => Ok((opacity, 1)),
    }
}
