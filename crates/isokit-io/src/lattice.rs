//! The lattice sidecar of NPY volumes: NumPy files carry no geometry, so a volume written
//! as `d.npy` gets `d.npy.json` beside it, and [`crate::read_volume`] applies it when present.
//!
//! ```json
//! {"origin": [-1.0, -0.75, -0.5], "spacing": [0.03125, 0.03125, 0.03125],
//!  "dims": [65, 49, 33], "axis_order": "zyx", "band": 0.125, "inside": "below",
//!  "sign": "pseudonormal"}
//! ```
//!
//! - `origin` `[x, y, z]`: the world position of sample `(0, 0, 0)`;
//! - `spacing` `[x, y, z]`: the distance between neighbouring samples along each axis;
//! - `dims` `[nx, ny, nz]`: samples along x, y, z;
//! - `axis_order` `"zyx"`: the array's shape is `(nz, ny, nx)` in C order, so x is fastest
//!   in memory (the only order written or read);
//! - `band`: the narrow band's half-width (values are exact within it and `±band` beyond),
//!   or `null` for a field computed everywhere;
//! - `inside`: `"below"` (distance fields, negative inside) or `"above"` (densities);
//! - `sign`: how a mesh's distance was signed (`"pseudonormal"`, `"winding"`,
//!   `"unsigned"`), or `null`.
//!
//! This is the one lattice description that NRRD key-value fields, the Python package's
//! field objects and future stores share; readers ignore keys they do not know.

use std::path::{Path, PathBuf};

use glam::Vec3;
use isokit_field::curvature::Inside;
use serde_json::{Value, json};

use crate::util::read_file;
use crate::{IoError, Volume, atomic_write, npy};

/// The lattice and meaning of a volume's samples, as an NPY sidecar holds them.
#[derive(Clone, Debug, PartialEq)]
pub struct Lattice {
    /// World position of sample `(0, 0, 0)`.
    pub origin: [f32; 3],
    /// Distance between neighbouring samples along x, y, z.
    pub spacing: [f32; 3],
    /// Samples along x, y, z.
    pub dims: [usize; 3],
    /// Narrow-band half-width, `None` for a field computed everywhere.
    pub band: Option<f32>,
    /// Which side of the surface holds the inside.
    pub inside: Inside,
    /// How a mesh's distance was signed (`pseudonormal`, `winding`, `unsigned`), if known.
    pub sign: Option<String>,
}

impl Lattice {
    /// The lattice of `volume` (no band, inside below, no sign method).
    pub fn of(volume: &Volume) -> Self {
        Self {
            origin: volume.origin.to_array(),
            spacing: volume.spacing.to_array(),
            dims: volume.dims,
            band: None,
            inside: Inside::Below,
            sign: None,
        }
    }

    /// The lattice of `volume` with the band, inside and sign of `meta` (whose geometry
    /// fields are ignored).
    pub fn with_geometry_of(meta: &Self, volume: &Volume) -> Self {
        Self {
            origin: volume.origin.to_array(),
            spacing: volume.spacing.to_array(),
            dims: volume.dims,
            ..meta.clone()
        }
    }

    /// `"below"` or `"above"`, as the sidecar spells [`Lattice::inside`].
    pub fn inside_name(&self) -> &'static str {
        match self.inside {
            Inside::Below => "below",
            Inside::Above => "above",
        }
    }

    /// The sidecar's JSON object.
    pub fn to_json(&self) -> Value {
        let num = |x: f32| short_json(x);
        json!({
            "origin": self.origin.map(num),
            "spacing": self.spacing.map(num),
            "dims": self.dims,
            "axis_order": "zyx",
            "band": self.band.map(num),
            "inside": self.inside_name(),
            "sign": self.sign,
        })
    }

    /// Reads a sidecar's JSON text; `path` names the sidecar in errors.
    pub fn from_json(text: &str, path: &Path) -> Result<Self, IoError> {
        let bad = |m: String| IoError::malformed(path, m);
        let v: Value = serde_json::from_str(text).map_err(|e| bad(format!("invalid JSON: {e}")))?;
        let obj = v
            .as_object()
            .ok_or_else(|| bad("a lattice sidecar is a JSON object".into()))?;
        let triple = |key: &str| -> Result<[f64; 3], IoError> {
            let a = obj
                .get(key)
                .and_then(Value::as_array)
                .filter(|a| a.len() == 3)
                .ok_or_else(|| bad(format!("`{key}` must be an array of three numbers")))?;
            let mut out = [0.0; 3];
            for (o, x) in out.iter_mut().zip(a) {
                *o = x
                    .as_f64()
                    .ok_or_else(|| bad(format!("`{key}` must be an array of three numbers")))?;
            }
            Ok(out)
        };
        let origin = triple("origin")?.map(|x| x as f32);
        let spacing = triple("spacing")?.map(|x| x as f32);
        let dims_f = triple("dims")?;
        if dims_f
            .iter()
            .any(|&d| d < 1.0 || d.fract() != 0.0 || d > 1e12)
        {
            return Err(bad("`dims` must be three positive integers".into()));
        }
        let dims = dims_f.map(|d| d as usize);
        match obj.get("axis_order").map(|a| a.as_str()) {
            None | Some(Some("zyx")) => {}
            Some(other) => {
                return Err(IoError::unsupported(
                    path,
                    format!(
                        "axis_order {}: only \"zyx\" (shape (nz, ny, nx), x fastest) is read",
                        other.map_or_else(|| "(not a string)".to_owned(), |s| format!("{s:?}"))
                    ),
                ));
            }
        }
        let band = match obj.get("band") {
            None | Some(Value::Null) => None,
            Some(b) => Some(
                b.as_f64()
                    .filter(|b| b.is_finite() && *b > 0.0)
                    .ok_or_else(|| bad("`band` must be a positive number or null".into()))?
                    as f32,
            ),
        };
        let inside = match obj.get("inside").map(|i| i.as_str()) {
            None | Some(Some("below")) => Inside::Below,
            Some(Some("above")) => Inside::Above,
            Some(_) => return Err(bad("`inside` must be \"below\" or \"above\"".into())),
        };
        let sign = match obj.get("sign") {
            None | Some(Value::Null) => None,
            Some(Value::String(s)) => Some(s.clone()),
            Some(_) => return Err(bad("`sign` must be a string or null".into())),
        };
        Ok(Self {
            origin,
            spacing,
            dims,
            band,
            inside,
            sign,
        })
    }
}

/// An f32 as the JSON number of its shortest decimal form (`0.15`, not the f64 widening
/// `0.15000000596046448`); it reads back as the same f32. Non-finite values become `null`.
fn short_json(x: f32) -> Value {
    format!("{x}")
        .parse::<f64>()
        .ok()
        .and_then(serde_json::Number::from_f64)
        .map_or(Value::Null, Value::Number)
}

/// The sidecar of an NPY file: `d.npy` → `d.npy.json`.
pub fn sidecar_path(npy: &Path) -> PathBuf {
    let mut s = npy.as_os_str().to_owned();
    s.push(".json");
    PathBuf::from(s)
}

/// Reads the sidecar of `npy` when there is one (`Ok(None)` when there is none).
pub fn read_sidecar(npy: &Path) -> Result<Option<Lattice>, IoError> {
    let path = sidecar_path(npy);
    if !path.is_file() {
        return Ok(None);
    }
    let bytes = read_file(&path)?;
    let text = std::str::from_utf8(&bytes)
        .map_err(|_| IoError::malformed(&path, "a lattice sidecar must be UTF-8 JSON"))?;
    Lattice::from_json(text, &path).map(Some)
}

/// Applies a sidecar's origin and spacing to a volume read from `npy`, after checking that
/// its dimensions match the array's.
pub(crate) fn apply(volume: &mut Volume, lattice: &Lattice, npy: &Path) -> Result<(), IoError> {
    if lattice.dims != volume.dims {
        return Err(IoError::malformed(
            &sidecar_path(npy),
            format!(
                "dims {:?} do not match the array's {:?} (shape (nz, ny, nx) = ({}, {}, {}))",
                lattice.dims, volume.dims, volume.dims[2], volume.dims[1], volume.dims[0]
            ),
        ));
    }
    volume.origin = Vec3::from(lattice.origin);
    volume.spacing = Vec3::from(lattice.spacing);
    volume
        .check()
        .map_err(|e| IoError::malformed(&sidecar_path(npy), format!("the lattice is invalid: {e}")))
}

/// Refuses a band that is not finite and positive, naming `path`.
pub(crate) fn check_band(lattice: &Lattice, path: &Path) -> Result<(), IoError> {
    match lattice.band {
        Some(b) if !(b.is_finite() && b > 0.0) => Err(IoError::invalid_input(
            path,
            format!("band {b} must be finite and positive"),
        )),
        _ => Ok(()),
    }
}

/// Writes `volume` atomically as an f32 NPY array of shape `(nz, ny, nx)` and its lattice
/// sidecar `<path>.json` (origin, spacing and dims from the volume; band, inside and sign
/// from `lattice`, whose geometry fields are ignored).
pub fn write_npy_volume(path: &Path, volume: &Volume, lattice: &Lattice) -> Result<(), IoError> {
    volume
        .check()
        .map_err(|e| IoError::invalid_input(path, e.to_string()))?;
    check_band(lattice, path)?;
    let [nx, ny, nz] = volume.dims;
    npy::write_npy_f32(path, &[nz, ny, nx], &volume.data)?;
    let meta = Lattice::with_geometry_of(lattice, volume);
    let side = sidecar_path(path);
    let text = serde_json::to_string_pretty(&meta.to_json())
        .map_err(|e| IoError::invalid_input(&side, e.to_string()))?;
    atomic_write(&side, |w| {
        w.write_all(text.as_bytes())?;
        w.write_all(b"\n")
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn volume() -> Volume {
        Volume {
            dims: [3, 2, 4],
            origin: Vec3::new(-1.0, -0.75, 0.5),
            spacing: Vec3::splat(0.25),
            data: (0..24).map(|i| i as f32 - 10.0).collect(),
        }
    }

    #[test]
    fn npy_volumes_keep_their_lattice_through_the_sidecar() {
        let d = std::env::temp_dir().join(format!("isokit-lattice-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let p = d.join("d.npy");
        let v = volume();
        let meta = Lattice {
            band: Some(0.5),
            sign: Some("winding".into()),
            inside: Inside::Above,
            ..Lattice::of(&v)
        };
        write_npy_volume(&p, &v, &meta).unwrap();
        assert_eq!(sidecar_path(&p), d.join("d.npy.json"));
        let side = read_sidecar(&p).unwrap().unwrap();
        assert_eq!(side, meta);
        let text = std::fs::read_to_string(d.join("d.npy.json")).unwrap();
        let j: Value = serde_json::from_str(&text).unwrap();
        assert_eq!(j["axis_order"], "zyx");
        assert_eq!(j["dims"], json!([3, 2, 4]));
        assert_eq!(j["inside"], "above");
        // The reader applies it: world coordinates, not voxel units.
        let back = crate::read_volume(&p).unwrap();
        assert_eq!(back, v);
        // Without a sidecar: origin 0, spacing 1, as before.
        std::fs::remove_file(d.join("d.npy.json")).unwrap();
        let bare = crate::read_volume(&p).unwrap();
        assert_eq!((bare.origin, bare.spacing), (Vec3::ZERO, Vec3::ONE));
        assert_eq!(bare.data, v.data);
        std::fs::remove_dir_all(&d).unwrap();
    }

    #[test]
    fn bad_sidecars_are_errors_that_name_the_sidecar() {
        let p = Path::new("x.npy.json");
        for (text, want) in [
            ("[1, 2]", "JSON object"),
            (
                "{\"origin\": [0, 0], \"spacing\": [1, 1, 1], \"dims\": [1, 1, 1]}",
                "origin",
            ),
            (
                "{\"origin\": [0, 0, 0], \"spacing\": [1, 1, 1], \"dims\": [1.5, 1, 1]}",
                "dims",
            ),
            (
                "{\"origin\": [0, 0, 0], \"spacing\": [1, 1, 1], \"dims\": [1, 1, 1], \"axis_order\": \"xyz\"}",
                "axis_order",
            ),
            (
                "{\"origin\": [0, 0, 0], \"spacing\": [1, 1, 1], \"dims\": [1, 1, 1], \"inside\": \"in\"}",
                "inside",
            ),
            ("{", "invalid JSON"),
        ] {
            let e = Lattice::from_json(text, p).unwrap_err().to_string();
            assert!(e.contains(want) && e.contains("x.npy.json"), "{text}: {e}");
        }
        let mut v = volume();
        let wrong = Lattice {
            dims: [4, 2, 3],
            ..Lattice::of(&v)
        };
        let e = apply(&mut v, &wrong, Path::new("d.npy"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("d.npy.json") && e.contains("do not match"),
            "{e}"
        );
    }
}
