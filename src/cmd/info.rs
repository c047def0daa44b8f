//! `isokit info FILE`: describe any mesh, cloud, volume or image.

use anyhow::{Result, bail};
use isokit_field::Aabb;
use isokit_io::lattice::{read_sidecar, sidecar_path};
use isokit_io::{FileKind, VolumeFormat, detect_kind, read_exr_info, read_png};
use serde_json::{Value, json};
use std::path::PathBuf;

/// Arguments of `isokit info`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Mesh (.obj .gltf .glb .ply .stl .off), cloud (.ply .xyz), volume (.nrrd .nhdr .npy
    /// .nii .nii.gz .inr .inr.gz), Zarr store (.zarr, or a writer's .zarr.partial),
    /// tetrahedral grid (.vtk .vtu) or image (.png; .exr: header only).
    pub file: PathBuf,
    /// Tetrahedral grids: the point array (default: the first with one component).
    #[arg(long)]
    pub array: Option<String>,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Meshes: also count the pairs of triangles that intersect other than in shared
    /// vertices and edges (exact predicates; `self_intersections` in --json).
    #[arg(long)]
    pub self_intersections: bool,
    #[command(flatten)]
    pub volume: super::volume_args::VolumeIn,
}

pub(super) fn bounds_json(b: &Aabb) -> Value {
    if b.is_empty() {
        Value::Null
    } else {
        json!({ "min": b.min.to_array(), "max": b.max.to_array() })
    }
}

pub(super) fn bounds_text(b: &Aabb) -> String {
    if b.is_empty() {
        "empty".into()
    } else {
        format!(
            "{:?} .. {:?} (size {:?})",
            b.min.to_array(),
            b.max.to_array(),
            b.size().to_array()
        )
    }
}

fn is_exr(path: &std::path::Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    let path = &a.file;
    let kind = if super::store::is_store_name(path) {
        None
    } else {
        Some(detect_kind(path)?)
    };
    if a.array.is_some() && kind != Some(FileKind::TetGrid) {
        bail!("--array applies to tetrahedral grids (.vtk .vtu)");
    }
    let Some(kind) = kind else {
        return print(&a, super::store::describe(path)?);
    };
    let (text, value) = match kind {
        FileKind::Mesh => super::mesher_args::describe_mesh(path, a.self_intersections)?,
        FileKind::TetGrid => super::tets::describe(path, a.array.as_deref())?,
        FileKind::PointCloud => super::points::describe(path)?,
        FileKind::Volume => {
            let vol = a.volume.read(path)?;
            let npy = VolumeFormat::from_path(path).ok() == Some(VolumeFormat::Npy);
            let side = if npy { read_sidecar(path)? } else { None };
            let nan = vol.data.iter().filter(|x| !x.is_finite()).count();
            let b = vol.bounds();
            let range = vol.min_max().map(|(lo, hi)| [lo, hi]);
            let uniform = vol.is_uniform();
            let sph = super::lattice_args::LatticeArgs::default().spherical(path)?;
            let mut v = json!({
                "kind": "volume",
                "dims": vol.dims,
                "origin": vol.origin.to_array(),
                "spacing": vol.spacing.to_array(),
                "uniform_spacing": uniform,
                "bounds": bounds_json(&b),
                "range": range,
                "non_finite_samples": nan,
                "sidecar": npy.then(|| side.is_some()),
                "band": side.as_ref().and_then(|s| s.band),
                "inside": side.as_ref().map(|s| s.inside_name()),
                "sign": side.as_ref().and_then(|s| s.sign.clone()),
            });
            let lattice = match (&side, npy) {
                (Some(s), _) => format!(
                    "\n  lattice: from {} (band {}, inside {}, sign {})",
                    sidecar_path(path).display(),
                    s.band.map_or("none".into(), |b| b.to_string()),
                    s.inside_name(),
                    s.sign.as_deref().unwrap_or("none")
                ),
                (None, true) => "\n  lattice: no sidecar (origin and spacing from --origin/--spacing, else 0 and 1)".into(),
                (None, false) => String::new(),
            };
            let lattice = match sph {
                Some(l) => {
                    v["lattice"] = super::lattice_args::lattice_json(&l);
                    format!(
                        "{lattice}
  spherical lattice (header): r {} .. {}, theta {} .. {}, phi {} .. {} degrees (origin and spacing are not used)",
                        l.r[0], l.r[1], l.theta[0], l.theta[1], l.phi[0], l.phi[1]
                    )
                }
                None => lattice,
            };
            let t = format!(
                "{}: volume\n  samples: {} x {} x {}\n  origin: {:?}\n  spacing: {:?}{}\n  bounds: {}\n  range: {}\n  non-finite samples: {}{lattice}",
                path.display(),
                vol.dims[0],
                vol.dims[1],
                vol.dims[2],
                vol.origin.to_array(),
                vol.spacing.to_array(),
                if uniform {
                    ""
                } else {
                    " (anisotropic: resampled to the smallest when rendered or used as a distance field)"
                },
                bounds_text(&b),
                range.map_or("no finite samples".into(), |[a, b]| format!("{a} .. {b}")),
                nan
            );
            (t, v)
        }
        FileKind::Image if is_exr(path) => {
            // EXR: the header only (isokit writes EXR but does not decode it).
            let e = read_exr_info(path)?;
            (
                format!(
                    "{}: image (OpenEXR)\n  size: {} x {}\n  channels: {}{}",
                    path.display(),
                    e.width,
                    e.height,
                    e.channels.join(", "),
                    if e.layers > 1 {
                        format!("\n  layers: {} (size of the first)", e.layers)
                    } else {
                        String::new()
                    }
                ),
                json!({
                    "kind": "image",
                    "format": "exr",
                    "width": e.width,
                    "height": e.height,
                    "channels": e.channels,
                    "layers": e.layers,
                }),
            )
        }
        FileKind::Image => {
            let (w, h, _) = read_png(path)?;
            (
                format!("{}: image (PNG)\n  size: {w} x {h}", path.display()),
                json!({ "kind": "image", "format": "png", "width": w, "height": h }),
            )
        }
    };
    print(&a, (text, value))
}

fn print(a: &Args, (text, mut value): (String, Value)) -> Result<()> {
    if a.json {
        value["file"] = json!(a.file.display().to_string());
        println!("{value}");
    } else {
        println!("{text}");
    }
    Ok(())
}
