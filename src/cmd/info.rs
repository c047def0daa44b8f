//! `isokit info FILE`: describe any mesh, cloud, volume or image.

use anyhow::Result;
use isokit_field::Aabb;
use isokit_io::{FileKind, detect_kind, read_mesh, read_png, read_points, read_volume};
use serde_json::{Value, json};
use std::path::PathBuf;

/// Arguments of `isokit info`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Mesh (.obj .gltf .glb .ply .stl .off), cloud (.ply .xyz), volume (.nrrd .nhdr .npy
    /// .nii .nii.gz) or image (.png).
    pub file: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

fn bounds_json(b: &Aabb) -> Value {
    if b.is_empty() {
        Value::Null
    } else {
        json!({ "min": b.min.to_array(), "max": b.max.to_array() })
    }
}

fn bounds_text(b: &Aabb) -> String {
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

/// Runs the command.
pub fn run(a: Args) -> Result<()> {
    let path = &a.file;
    let (text, value) = match detect_kind(path)? {
        FileKind::Mesh => {
            let mesh = read_mesh(path)?;
            let r = mesh.validate();
            let v = json!({
                "kind": "mesh",
                "vertices": r.vertices,
                "triangles": r.triangles,
                "bounds": bounds_json(&r.bounds),
                "degenerate_triangles": r.degenerate_triangles,
                "duplicate_triangles": r.duplicate_triangles,
                "duplicate_vertices": r.duplicate_vertices,
                "unreferenced_vertices": r.unreferenced_vertices,
                "non_finite_vertices": r.non_finite_vertices,
                "boundary_edges": r.boundary_edges,
                "non_manifold_edges": r.non_manifold_edges,
                "components": r.components,
                "euler_characteristic": r.euler_characteristic,
                "watertight": r.watertight,
                "consistently_oriented": r.consistently_oriented,
            });
            (format!("{}: mesh\n{r}", path.display()), v)
        }
        FileKind::PointCloud => {
            let c = read_points(path)?;
            let b = Aabb::from_points(&c.points);
            let non_finite = c.points.iter().filter(|p| !p.is_finite()).count();
            let normals = c.normals.is_some();
            let v = json!({
                "kind": "points",
                "points": c.points.len(),
                "normals": normals,
                "non_finite_points": non_finite,
                "bounds": bounds_json(&b),
            });
            let t = format!(
                "{}: point cloud\n  points: {}\n  normals: {}\n  non-finite points: {}\n  bounds: {}",
                path.display(),
                c.points.len(),
                if normals { "yes" } else { "no" },
                non_finite,
                bounds_text(&b)
            );
            (t, v)
        }
        FileKind::Volume => {
            let vol = read_volume(path)?;
            let (lo, hi, nan) = vol.data.iter().fold(
                (f32::INFINITY, f32::NEG_INFINITY, 0usize),
                |(lo, hi, nan), &x| {
                    if x.is_finite() {
                        (lo.min(x), hi.max(x), nan)
                    } else {
                        (lo, hi, nan + 1)
                    }
                },
            );
            let ext = glam::Vec3::new(
                (vol.dims[0] - 1) as f32,
                (vol.dims[1] - 1) as f32,
                (vol.dims[2] - 1) as f32,
            ) * vol.spacing;
            let b = Aabb::new(vol.origin, vol.origin + ext);
            let range = (lo <= hi).then_some([lo, hi]);
            let uniform = (vol.spacing.max_element() - vol.spacing.min_element())
                <= 1e-4 * vol.spacing.max_element();
            let v = json!({
                "kind": "volume",
                "dims": vol.dims,
                "origin": vol.origin.to_array(),
                "spacing": vol.spacing.to_array(),
                "uniform_spacing": uniform,
                "bounds": bounds_json(&b),
                "range": range,
                "non_finite_samples": nan,
            });
            let t = format!(
                "{}: volume\n  samples: {} x {} x {}\n  origin: {:?}\n  spacing: {:?}{}\n  bounds: {}\n  range: {}\n  non-finite samples: {}",
                path.display(),
                vol.dims[0],
                vol.dims[1],
                vol.dims[2],
                vol.origin.to_array(),
                vol.spacing.to_array(),
                if uniform {
                    ""
                } else {
                    " (anisotropic: resampled when used as a distance field)"
                },
                bounds_text(&b),
                range.map_or("no finite samples".into(), |[a, b]| format!("{a} .. {b}")),
                nan
            );
            (t, v)
        }
        FileKind::Image => {
            let (w, h, _) = read_png(path)?;
            (
                format!("{}: image\n  size: {w} x {h}", path.display()),
                json!({ "kind": "image", "width": w, "height": h }),
            )
        }
    };
    if a.json {
        let mut v = value;
        v["file"] = json!(path.display().to_string());
        println!("{v}");
    } else {
        println!("{text}");
    }
    Ok(())
}
