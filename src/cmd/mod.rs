//! One module per subcommand, and the argument groups they share (`args`, `*_args`,
//! `sample_options`).

pub mod args;
pub mod bench;
pub mod bench_render;
pub mod camera_args;
pub mod clip_args;
pub mod convert;
pub mod csg_args;
pub mod demo;
pub mod info;
pub mod labels;
pub mod lattice_args;
pub mod mesh;
pub mod mesh_args;
pub mod mesher_args;
pub mod molecule;
pub mod multiview_args;
pub mod octree;
pub mod points;
pub mod progress;
pub mod query;
pub mod raycast_args;
pub mod render;
pub mod sample;
pub mod sample_options;
pub mod scene;
pub mod scene_store;
pub mod sdf;
pub mod segmented_field;
pub mod store;
pub mod tets;
pub mod view;
pub mod volume_args;
pub mod volume_out;

use anyhow::{Context, bail};
use glam::Vec3;

/// Parses "x,y,z" (or a single number for all three) into a vector.
pub fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let nums: Result<Vec<f32>, _> = parts.iter().map(|p| p.parse::<f32>()).collect();
    let nums = nums.map_err(|e| format!("'{s}' is not a vector x,y,z: {e}"))?;
    let v = match nums.as_slice() {
        [a] => Vec3::splat(*a),
        [a, b, c] => Vec3::new(*a, *b, *c),
        _ => return Err(format!("'{s}' is not a vector: give x,y,z or one number")),
    };
    if !v.is_finite() {
        return Err(format!("'{s}' must be finite"));
    }
    Ok(v)
}

/// The mesh extensions a command's `-o` takes (the formats `isokit_io::write_mesh` writes).
pub const MESH_OUTPUTS: [&str; 6] = [".obj", ".ply", ".stl", ".off", ".glb", ".gltf"];

/// Whether `path` names a mesh output (one of [`MESH_OUTPUTS`]), not a volume.
pub fn is_mesh_output(path: &std::path::Path) -> bool {
    isokit_io::MeshFormat::from_path(path).is_ok()
}

/// Checks that an output path has a known extension before any work is done, so a long
/// run never fails at the end on a typo. An empty `allowed` accepts any extension.
pub fn check_output(path: &std::path::Path, allowed: &[&str]) -> anyhow::Result<()> {
    let name = path.to_string_lossy().to_ascii_lowercase();
    if !allowed.is_empty() && !allowed.iter().any(|e| name.ends_with(e)) {
        bail!(
            "{}: unknown output format; use one of {}",
            path.display(),
            allowed.join(", ")
        );
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::metadata(dir)
            .with_context(|| format!("{}: output folder does not exist", dir.display()))?;
    }
    Ok(())
}

/// The empty output grid over `bounds` (of the input `input`) padded by `padding` (default:
/// 10% of the diagonal), `res` samples along the longest side. Made before any expensive
/// work, so an absurd size is refused at once. Bounds that are not finite (a coordinate
/// near f32's limit) are the input's problem and name it, not the padding.
pub fn padded_grid(
    input: &std::path::Path,
    bounds: isokit_field::Aabb,
    res: usize,
    padding: Option<f32>,
) -> anyhow::Result<isokit_field::Grid> {
    if bounds.is_empty() {
        bail!("{}: has no finite vertex or point", input.display());
    }
    if !(bounds.is_finite() && bounds.diagonal().is_finite()) {
        bail!(
            "{}: its bounds {} are too large to sample (coordinates near f32's limit of 3.4e38)",
            input.display(),
            bounds
        );
    }
    let pad = padding.unwrap_or(0.1 * bounds.diagonal());
    if let Some(why) = isokit_field::Grid::padding_problem(bounds, res, pad) {
        bail!("--padding {pad} {why}");
    }
    Ok(isokit_field::Grid::covering(bounds, res, pad)?)
}

/// A volume as a uniform grid (anisotropic volumes resampled, with a note).
pub fn uniform_grid(v: isokit_io::Volume) -> anyhow::Result<isokit_field::Grid> {
    Ok(if v.is_uniform() {
        v.into_grid()?
    } else {
        let h = v.spacing.min_element();
        eprintln!(
            "note: resampling the anisotropic volume (spacing {}) to a uniform spacing {h}",
            v.spacing
        );
        v.resample_uniform(h)?
    })
}

#[cfg(test)]
mod tests {
    /// The commands stay thin: every file under `src/cmd/` (one folder deep) parses
    /// arguments, builds settings, calls the library and prints, in at most 200 lines (as
    /// rustfmt leaves them). Logic beyond that belongs in a library crate.
    #[test]
    fn command_files_are_short() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/cmd");
        let mut files = Vec::new();
        for e in std::fs::read_dir(&root).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                files.extend(std::fs::read_dir(&p).unwrap().map(|e| e.unwrap().path()));
            } else {
                files.push(p);
            }
        }
        let long: Vec<String> = files
            .iter()
            .filter(|p| p.extension().is_some_and(|x| x == "rs"))
            .map(|p| (p, std::fs::read_to_string(p).unwrap().lines().count()))
            .filter(|(_, n)| *n > 200)
            .map(|(p, n)| format!("{}: {n} lines", p.display()))
            .collect();
        assert!(files.len() > 20, "{} files in src/cmd", files.len());
        assert!(long.is_empty(), "over 200 lines: {long:?}");
    }
}
