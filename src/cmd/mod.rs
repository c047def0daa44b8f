//! One module per subcommand.

pub mod bench;
pub mod convert;
pub mod info;
pub mod mesh_args;
pub mod octree;
pub mod points;
pub mod progress;
pub mod query;
pub mod sample;
pub mod sdf;

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
