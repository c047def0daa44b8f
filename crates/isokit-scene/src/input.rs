//! A field from a name on the command line: a mesh file (exact distance through the kd-tree),
//! a volume file (its trilinear reconstruction), a scene file, or a primitive of the
//! vocabulary with its default parameters.

use crate::primitives::PrimitiveKind;
use crate::{Scene, SceneError, SceneFormat};
use isokit_field::filter::{Filter, SampledField};
use isokit_field::{Aabb, Field, TriMesh};
use isokit_io::{FileKind, detect_kind, read_mesh, read_volume};
use isokit_kdtree::mesh::{MeshOptions, MeshSdf};
use std::path::Path;

/// A field to build something from, and what it is.
pub struct FieldInput {
    /// The field.
    pub field: Box<dyn Field>,
    /// The mesh, when the input is one (test points can be drawn on its triangles).
    pub mesh: Option<TriMesh>,
    /// The bounds to cover before padding.
    pub bounds: Aabb,
    /// The default padding: 10% of the diagonal for meshes, scenes and primitives, 0 for
    /// volumes.
    pub pad: f32,
    /// One line about the input.
    pub what: String,
    /// What errors against the field measure: `exact distance (…)` when it is one.
    pub reference: &'static str,
}

fn io(e: isokit_io::IoError) -> SceneError {
    let mut s = e.to_string();
    if let Some(c) = std::error::Error::source(&e) {
        s = format!("{s}: {c}");
    }
    SceneError::new("", "", s)
}

/// Opens `name` as a field (see the module docs); `mesh` are the kd-tree's options for a
/// mesh file. Unbounded primitives (the plane) are refused: nothing could be built over
/// them without bounds.
pub fn open_field(name: &str, mesh: MeshOptions) -> Result<FieldInput, SceneError> {
    let path = Path::new(name);
    if path.exists() {
        if SceneFormat::from_path(path).is_some() {
            let scene = Scene::load(path)?;
            let bounds = scene.bounds();
            let exact = scene.is_exact();
            return Ok(FieldInput {
                what: format!("scene {name}: {} sources", scene.sources().len()),
                field: Box::new(scene),
                mesh: None,
                pad: 0.1 * bounds.diagonal(),
                bounds,
                reference: if exact {
                    "exact distance (scene)"
                } else {
                    "the scene's field"
                },
            });
        }
        return match detect_kind(path).map_err(io)? {
            FileKind::Mesh => {
                let m = read_mesh(path).map_err(io)?;
                let sdf =
                    MeshSdf::new(&m, mesh).map_err(|e| SceneError::new(name, "", e.to_string()))?;
                let bounds = sdf.bounds();
                let what = format!(
                    "mesh {name}: {} triangles, sign {} ({})",
                    m.triangles.len(),
                    sdf.sign_method().name(),
                    sdf.sign_reason()
                );
                Ok(FieldInput {
                    pad: 0.1 * bounds.diagonal(),
                    bounds,
                    field: Box::new(sdf),
                    mesh: Some(m),
                    what,
                    reference: "exact distance (kd-tree)",
                })
            }
            FileKind::Volume => {
                let v = read_volume(path).map_err(io)?;
                let dims = v.dims;
                let grid = if v.is_uniform() {
                    v.into_grid()
                } else {
                    let s = v.spacing.min_element();
                    v.resample_uniform(s)
                }
                .map_err(io)?;
                // A field for an octree (or a query) must be finite, and hold a surface.
                let bad = grid.data().iter().filter(|x| !x.is_finite()).count();
                if bad > 0 {
                    return Err(SceneError::new(
                        name,
                        "",
                        format!(
                            "{bad} of its {} samples are not finite (NaN or infinite); a field needs finite samples",
                            grid.len()
                        ),
                    ));
                }
                if let Some((lo, hi)) = grid.min_max()
                    && (lo > 0.0 || hi < 0.0)
                {
                    return Err(SceneError::new(
                        name,
                        "",
                        format!(
                            "holds no surface: its samples range from {lo} to {hi} and never reach 0, the isovalue of a distance field"
                        ),
                    ));
                }
                let bounds = grid.bounds();
                Ok(FieldInput {
                    field: Box::new(SampledField::new(grid, Filter::Trilinear)),
                    mesh: None,
                    bounds,
                    pad: 0.0,
                    what: format!(
                        "volume {name}: {} x {} x {} samples, trilinear",
                        dims[0], dims[1], dims[2]
                    ),
                    reference: "the volume's trilinear reconstruction (no exact reference)",
                })
            }
            FileKind::PointCloud => Err(SceneError::new(
                name,
                "",
                "a point cloud: make it a field first (`isokit points`, or a scene with a points node)",
            )),
            FileKind::Image => Err(SceneError::new(name, "", "an image is not a field")),
            FileKind::TetGrid => Err(SceneError::new(
                name,
                "",
                "a tetrahedral grid is read by `isokit mesh`, `isokit render` and `isokit info`, not as a field",
            )),
        };
    }
    let names: Vec<&str> = PrimitiveKind::ALL
        .iter()
        .filter(|k| **k != PrimitiveKind::Plane)
        .map(|k| k.cli_name())
        .collect();
    let Some(kind) = PrimitiveKind::from_name(&name.to_ascii_lowercase()) else {
        return Err(SceneError::new(
            name,
            "",
            format!(
                "no such file, and not a primitive name ({})",
                names.join(", ")
            ),
        ));
    };
    if kind == PrimitiveKind::Plane {
        return Err(SceneError::new(
            name,
            "",
            "a plane is unbounded: an octree needs a bounded shape",
        ));
    }
    let p = kind
        .default_node()
        .build()
        .map_err(|e| SceneError::new(name, "", e.to_string()))?;
    let bounds = p.bounds();
    Ok(FieldInput {
        field: Box::new(p),
        mesh: None,
        pad: 0.1 * bounds.diagonal(),
        bounds,
        what: format!("{} ({})", kind.cli_name(), kind.usage()),
        reference: "exact distance (analytic)",
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_bounded_primitive_is_an_input() {
        for &k in PrimitiveKind::ALL {
            let r = open_field(k.cli_name(), MeshOptions::default());
            if k == PrimitiveKind::Plane {
                assert!(r.is_err());
            } else {
                let i = r.unwrap();
                assert!(
                    i.bounds.is_finite() && i.field.is_exact(),
                    "{}",
                    k.cli_name()
                );
            }
        }
        assert!(open_field("no-such-thing", MeshOptions::default()).is_err());
    }
}
