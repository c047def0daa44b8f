//! `--lattice spherical --r-range R0,R1 --theta-range T0,T1 --phi-range P0,P1`: volumes whose
//! samples lie on a spherical lattice (Westermann and Ertl 1998, Sec. 2.2;
//! `isokit_render::spherical`), also read from an NRRD header's key/value pairs of the same
//! names (`lattice:=spherical`, `r-range:=R0,R1`, …).

use anyhow::{Context, Result, bail};
use isokit_render::spherical::SphericalLattice;
use std::path::Path;

/// How a volume's samples are laid out.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum LatticeKind {
    /// Axis-aligned samples (origin and spacing): the default.
    Cartesian,
    /// Radius, polar angle and azimuth (the array's axes from fastest to slowest).
    Spherical,
}

/// The lattice flags of `isokit render`.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct LatticeArgs {
    /// The volume's lattice [default: the NRRD header's `lattice:=` key, else cartesian].
    /// spherical: the array's axes are radius, polar angle (from +z) and azimuth (from +x
    /// towards +y), fastest to slowest, around the world origin; rendered without resampling.
    #[arg(long, value_enum)]
    pub lattice: Option<LatticeKind>,
    /// Spherical lattice: the radii of the first and last sample, "R0,R1" [default: the NRRD
    /// header's `r-range:=`].
    #[arg(long, value_name = "R0,R1", allow_hyphen_values = true)]
    pub r_range: Option<String>,
    /// Spherical lattice: the polar angles of the first and last sample in degrees from +z,
    /// "T0,T1" within 0..180 [default: the NRRD header's `theta-range:=`].
    #[arg(long, value_name = "T0,T1", allow_hyphen_values = true)]
    pub theta_range: Option<String>,
    /// Spherical lattice: the azimuths of the first and last sample in degrees, "P0,P1"; when
    /// the samples go round the circle (P1 − P0 + one step = 360, or P1 − P0 = 360) there is
    /// no seam [default: the NRRD header's `phi-range:=`].
    #[arg(long, value_name = "P0,P1", allow_hyphen_values = true)]
    pub phi_range: Option<String>,
}

/// Two finite numbers "a,b".
fn pair(flag: &str, s: &str) -> Result<[f32; 2]> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let nums: Option<Vec<f32>> = parts.iter().map(|p| p.parse::<f32>().ok()).collect();
    match nums.as_deref() {
        Some(&[a, b]) if a.is_finite() && b.is_finite() => Ok([a, b]),
        _ => bail!(
            "{flag} {:?}: give two finite numbers \"a,b\"",
            s.chars().take(40).collect::<String>()
        ),
    }
}

impl LatticeArgs {
    /// True when a flag of a spherical lattice was given.
    pub fn any(&self) -> bool {
        self.lattice.is_some()
            || self.r_range.is_some()
            || self.theta_range.is_some()
            || self.phi_range.is_some()
    }

    /// The spherical lattice of the volume at `path`, or `None` for a Cartesian one: from
    /// the flags, with what they leave out taken from an NRRD header's key/value pairs.
    pub fn spherical(&self, path: &Path) -> Result<Option<SphericalLattice>> {
        let is_nrrd = matches!(
            isokit_io::VolumeFormat::from_path(path),
            Ok(isokit_io::VolumeFormat::Nrrd | isokit_io::VolumeFormat::Nhdr)
        );
        if !is_nrrd && !self.any() {
            return Ok(None);
        }
        let header = if is_nrrd && path.is_file() {
            isokit_io::read_nrrd_key_values(path)?
        } else {
            Vec::new()
        };
        let key = |k: &str| {
            header
                .iter()
                .find(|(name, _)| name == k)
                .map(|(_, v)| v.trim().to_string())
        };
        let kind = match (self.lattice, key("lattice").as_deref()) {
            (Some(k), _) => k,
            (None, None | Some("cartesian")) => LatticeKind::Cartesian,
            (None, Some("spherical")) => LatticeKind::Spherical,
            (None, Some(other)) => bail!(
                "{}: lattice:={} in the header (cartesian or spherical)",
                path.display(),
                isokit_io::shown_text(&other.chars().take(40).collect::<String>())
            ),
        };
        if kind == LatticeKind::Cartesian {
            if self.any() && self.lattice.is_none() {
                bail!(
                    "--r-range, --theta-range and --phi-range describe a spherical lattice: add --lattice spherical"
                );
            }
            return Ok(None);
        }
        let range = |flag: &str, given: &Option<String>| -> Result<[f32; 2]> {
            let name = &flag[2..];
            match (given, key(name)) {
                (Some(s), _) => pair(flag, s),
                (None, Some(v)) => pair(&format!("{name}:= in {}", path.display()), &v),
                (None, None) => bail!(
                    "a spherical lattice needs {flag} (or {name}:= in an NRRD header) for {}",
                    path.display()
                ),
            }
        };
        let lattice = SphericalLattice {
            r: range("--r-range", &self.r_range)?,
            theta: range("--theta-range", &self.theta_range)?,
            phi: range("--phi-range", &self.phi_range)?,
        };
        lattice
            .check()
            .with_context(|| path.display().to_string())?;
        Ok(Some(lattice))
    }
}

/// A spherical lattice as the `lattice` object of `--stats` and `isokit info --json`.
pub fn lattice_json(l: &SphericalLattice) -> serde_json::Value {
    serde_json::json!({
        "kind": "spherical",
        "r_range": l.r,
        "theta_range": l.theta,
        "phi_range": l.phi,
    })
}
