//! The arguments of `isokit render`.

pub use super::dvr::ClassificationArg;
use crate::cmd::args::{Backend, InsideArg, shading_names};
use crate::cmd::camera_args::CameraArgs;
use crate::cmd::csg_args::CsgArgs;
use crate::cmd::multiview_args::MultiViewArgs;
use crate::cmd::raycast_args::RaycastArgs;
use std::path::PathBuf;

/// What `isokit render` draws.
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RenderMode {
    /// The ray-cast isosurface, shaded.
    #[default]
    Isosurface,
    /// Direct volume rendering with a transfer function (--tf), volumes and tetrahedral
    /// grids.
    Dvr,
}

/// Arguments of `isokit render`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// A scene file (.json, .toml), a volume (.nrrd .nhdr .npy .nii .nii.gz .inr .inr.gz), a
    /// tetrahedral grid (.vtk .vtu: ray cast through its cells) or, with --segmented, surface
    /// patches (.ply).
    pub input: PathBuf,
    /// Tetrahedral grids: the point array (default: the first with one component).
    #[arg(long)]
    pub array: Option<String>,
    /// Output image (.png).
    #[arg(short, long)]
    pub output: PathBuf,
    /// What to draw: the isosurface, or a direct volume rendering (volumes and tetrahedral
    /// grids).
    #[arg(long, value_enum, default_value_t = RenderMode::Isosurface)]
    pub mode: RenderMode,
    /// --mode dvr: the transfer function, a JSON file `{"points": [[value, r, g, b,
    /// sigma], ...]}` (linear-RGB emission, sigma the extinction per world unit) or a preset:
    /// ct-bone, ct-skin (Hounsfield units), mri-brain (0–1 over the volume's range),
    /// distance-shell (signed distances).
    #[arg(long)]
    pub tf: Option<String>,
    /// --mode dvr: post-classification or pre-integration [default: post for volumes,
    /// preintegrated for tetrahedral grids].
    #[arg(long, value_enum)]
    pub classification: Option<ClassificationArg>,
    /// --mode dvr: step along the ray in world units [default: one voxel].
    #[arg(long)]
    pub step: Option<f32>,
    /// --mode dvr, pre-integrated: entries per value axis of the table [default: 256 for
    /// volumes, 128 for tetrahedral grids; 0 for grids integrates each cell's segment alone].
    #[arg(long)]
    pub table_size: Option<usize>,
    /// --mode dvr, pre-integrated volumes: the table's entries each integrated, or built
    /// incrementally (Lum et al. 2004: faster, less exact) [default: integrated].
    #[arg(long, value_parser = ["integrated", "incremental"])]
    pub table_build: Option<String>,
    /// --mode dvr --shading phong: the gradient, tricubic (the B-spline's: smooth) or central
    /// (differences of the trilinear values) [default: tricubic].
    #[arg(long, value_parser = ["tricubic", "central"])]
    pub gradient: Option<String>,
    /// Image width in pixels.
    #[arg(long, default_value_t = crate::cmd::args::DEFAULT_WIDTH)]
    pub width: u64,
    /// Image height in pixels.
    #[arg(long, default_value_t = crate::cmd::args::DEFAULT_HEIGHT)]
    pub height: u64,
    /// Antialiasing: rays per pixel, a k × k grid (1, 4, 9, 16, 25, 36, 49 or 64); the
    /// image is their mean, the G-buffer's A channel the fraction that hit (coverage).
    #[arg(long, default_value_t = 1)]
    pub samples: u32,
    /// Shading mode [default: the scene's `shading.mode`, else phong].
    #[arg(long, value_parser = shading_names())]
    pub shading: Option<String>,
    /// Isovalue [default: 0, or for a volume whose values do not reach 0 the middle of its
    /// range].
    #[arg(long)]
    pub iso: Option<f32>,
    /// Which side of the isovalue is inside.
    #[arg(long, value_enum, default_value_t = InsideArg::Below)]
    pub inside: InsideArg,
    /// Backend: auto (`ISOKIT_BACKEND=cpu|gpu` when set, else a hardware GPU when one
    /// exists and the CPU otherwise), cpu, gpu (any adapter, software ones included; an
    /// error without one).
    #[arg(long, value_enum, default_value_t = Backend::Auto)]
    pub backend: Backend,
    /// Also write the G-buffer as OpenEXR (channels P.X P.Y P.Z N.X N.Y N.Z Z K1 K2 A; with
    /// --mode dvr R G B A Z; the camera as the header attributes worldToCamera and
    /// worldToNDC).
    #[arg(long)]
    pub gbuffer: Option<PathBuf>,
    /// Render again whenever the input or a file it references changes (polling), keeping
    /// the last good image when a rendering fails. Stop with Ctrl-C.
    #[arg(long)]
    pub watch: bool,
    /// With --watch: stop after this many renderings (for scripts and tests).
    #[arg(long, hide = true)]
    pub watch_renders: Option<u32>,
    /// Scene sampling: samples along the longest side [default: `sampling.resolution`,
    /// else 128].
    #[arg(long)]
    pub res: Option<usize>,
    #[command(flatten)]
    pub camera: CameraArgs,
    #[command(flatten)]
    pub knobs: RaycastArgs,
    #[command(flatten)]
    pub multiview: MultiViewArgs,
    #[command(flatten)]
    pub csg: CsgArgs,
    #[command(flatten)]
    pub clip: crate::cmd::clip_args::ClipArgs,
    #[command(flatten)]
    pub volume: crate::cmd::volume_args::VolumeIn,
    #[command(flatten)]
    pub lattice: crate::cmd::lattice_args::LatticeArgs,
    #[command(flatten)]
    pub segmented: super::segmented_args::SegmentedArgs,
    /// Print what the rendering did as one JSON object on stdout.
    #[arg(long)]
    pub stats: bool,
    /// Trace this many more frames of the same camera after the first, the brick cache
    /// kept (warm frames); --stats lists their `warm_trace_seconds`.
    #[arg(long, default_value_t = 0)]
    pub warm_frames: u32,
}

impl Args {
    /// What `--mode dvr` takes of `--shading` (phong or nothing) and `--tf` (required), for
    /// volumes and tetrahedral grids alike.
    pub fn dvr_shading_and_tf(&self) -> anyhow::Result<(bool, &str)> {
        let shade = match self.shading.as_deref() {
            None => false,
            Some("phong") => true,
            Some(m) => anyhow::bail!(
                "--shading {m}: --mode dvr shades with phong (the gradient) or not at all"
            ),
        };
        let Some(tf) = self.tf.as_deref() else {
            anyhow::bail!(
                "--mode dvr needs --tf FILE|PRESET (a JSON file {{\"points\": [[value, r, g, b, sigma], ...]}}, or one of {})",
                isokit_render::dvr::TF_PRESETS.join(", ")
            );
        };
        Ok((shade, tf))
    }

    /// Refuses the flags of `--mode dvr` in the isosurface mode (all but those `except`
    /// names, which that isosurface takes).
    pub fn refuse_dvr_flags_except(&self, except: &[&str]) -> anyhow::Result<()> {
        for (given, flag) in [
            (self.tf.is_some(), "--tf"),
            (self.classification.is_some(), "--classification"),
            (self.step.is_some(), "--step"),
            (self.table_size.is_some(), "--table-size"),
            (self.gradient.is_some(), "--gradient"),
            (self.table_build.is_some(), "--table-build"),
        ] {
            if given && !except.contains(&flag) {
                anyhow::bail!("{flag} applies to --mode dvr; the isosurface mode does not take it");
            }
        }
        Ok(())
    }

    /// Refuses inputs that do not go together: `--csg` with a scene, `--array` with
    /// anything but a tetrahedral grid (which does not come here).
    pub fn check_inputs(&self, is_scene: fn(&std::path::Path) -> bool) -> anyhow::Result<()> {
        if self.csg.csg.is_some() {
            if is_scene(&self.input) {
                anyhow::bail!(
                    "--csg combines two volumes; {} is a scene (use its union/intersection/difference/morph nodes instead)",
                    self.input.display()
                );
            }
            if self.csg.with.as_deref().is_some_and(is_scene) {
                anyhow::bail!("--with must be a volume, not a scene");
            }
        }
        if self.array.is_some() {
            anyhow::bail!("--array applies to tetrahedral grids (.vtk .vtu)");
        }
        self.csg.combine()?;
        Ok(())
    }
}
