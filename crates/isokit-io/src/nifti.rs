//! NIfTI-1 single-file (`.nii`, `.nii.gz`) reader.

use std::io::Read;
use std::path::Path;

use glam::Vec3;
use isokit_field::checked_len;

use crate::nrrd::flip_negative_axes;
use crate::util::{Endian, Scalar};
use crate::{IoError, Volume};

const HDR: usize = 348;

struct Hdr<'a> {
    b: &'a [u8],
    e: Endian,
}

impl Hdr<'_> {
    fn i16(&self, o: usize) -> i16 {
        let a = [self.b[o], self.b[o + 1]];
        match self.e {
            Endian::Little => i16::from_le_bytes(a),
            Endian::Big => i16::from_be_bytes(a),
        }
    }
    fn f32(&self, o: usize) -> f32 {
        let a = [self.b[o], self.b[o + 1], self.b[o + 2], self.b[o + 3]];
        match self.e {
            Endian::Little => f32::from_le_bytes(a),
            Endian::Big => f32::from_be_bytes(a),
        }
    }
}

fn datatype(code: i16) -> Option<Scalar> {
    Some(match code {
        2 => Scalar::U8,
        4 => Scalar::I16,
        8 => Scalar::I32,
        16 => Scalar::F32,
        64 => Scalar::F64,
        256 => Scalar::I8,
        512 => Scalar::U16,
        768 => Scalar::U32,
        1024 => Scalar::I64,
        1280 => Scalar::U64,
        _ => return None,
    })
}

fn datatype_name(code: i16) -> &'static str {
    match code {
        0 => "unknown",
        1 => "binary (1 bit)",
        32 => "complex64",
        128 => "RGB24",
        1536 => "float128",
        1792 => "complex128",
        2048 => "complex256",
        2304 => "RGBA32",
        _ => "unknown code",
    }
}

pub(crate) fn read_nifti(bytes: &[u8], path: &Path) -> Result<Volume, IoError> {
    let bad = |msg: String| IoError::malformed(path, format!("NIfTI: {msg}"));
    if bytes.is_empty() {
        return Err(bad("file is empty".into()));
    }
    let gz = bytes.starts_with(&[0x1f, 0x8b]);
    // For gzip, decompress the header first, then exactly what the header asks for.
    let mut dec = flate2::read::MultiGzDecoder::new(bytes);
    let head: Vec<u8> = if gz {
        let mut h = Vec::with_capacity(HDR);
        (&mut dec)
            .take(HDR as u64)
            .read_to_end(&mut h)
            .map_err(|e| bad(format!("gzip data cannot be decompressed: {e}")))?;
        h
    } else {
        bytes[..bytes.len().min(HDR)].to_vec()
    };
    if head.len() < HDR {
        return Err(bad(format!(
            "file ends inside the {HDR}-byte header ({} bytes)",
            head.len()
        )));
    }
    let e = match (
        i32::from_le_bytes([head[0], head[1], head[2], head[3]]),
        i32::from_be_bytes([head[0], head[1], head[2], head[3]]),
    ) {
        (348, _) => Endian::Little,
        (_, 348) => Endian::Big,
        (540, _) | (_, 540) => {
            return Err(IoError::unsupported(path, "NIfTI-2 (only NIfTI-1 is read)"));
        }
        _ => return Err(bad("sizeof_hdr is not 348: not a NIfTI-1 file".into())),
    };
    let h = Hdr { b: &head, e };
    match &head[344..348] {
        b"n+1\0" => {}
        b"ni1\0" => {
            return Err(IoError::unsupported(
                path,
                "NIfTI-1 header/image pair (.hdr/.img); only single .nii files are read",
            ));
        }
        m => return Err(bad(format!("magic is {m:?}, expected \"n+1\\0\""))),
    }
    let ndim = h.i16(40);
    if !(1..=7).contains(&ndim) {
        return Err(bad(format!("dim[0] = {ndim} (must be 1 to 7)")));
    }
    let mut dims = [1usize; 3];
    for (a, o) in (42..42 + 2 * ndim as usize).step_by(2).enumerate() {
        let d = h.i16(o);
        if d < 1 {
            return Err(bad(format!("dim[{}] = {d} (must be at least 1)", a + 1)));
        }
        if a < 3 {
            dims[a] = d as usize;
        } else if d > 1 {
            return Err(IoError::unsupported(
                path,
                format!(
                    "{ndim}-D NIfTI with dim[{}] = {d} (only 3-D volumes are read)",
                    a + 1
                ),
            ));
        }
    }
    let n = checked_len(dims).map_err(|e| bad(e.to_string()))?;
    isokit_field::check_grid_budget(dims).map_err(|e| bad(e.to_string()))?;
    let code = h.i16(70);
    let scalar = datatype(code).ok_or_else(|| {
        IoError::unsupported(
            path,
            format!("NIfTI datatype {code} ({})", datatype_name(code)),
        )
    })?;
    let (origin, spacing) = geometry(&h).map_err(|msg| match msg {
        Geometry::Bad(m) => bad(m),
        Geometry::Rotated(m) => IoError::unsupported(path, m),
    })?;
    let vox_offset = h.f32(108);
    if !(vox_offset.is_finite() && vox_offset >= HDR as f32 && vox_offset < 1e15) {
        return Err(bad(format!(
            "vox_offset {vox_offset} is invalid (must be at least {HDR})"
        )));
    }
    let vox_offset = vox_offset as usize;
    let (slope, inter) = (h.f32(112), h.f32(116));

    let need = n * scalar.size();
    let end = vox_offset + need;
    let data: Vec<u8>;
    let raw: &[u8] = if gz {
        // Skip to vox_offset (without buffering the skipped bytes), then read exactly the
        // samples.
        let skipped = std::io::copy(
            &mut (&mut dec).take((vox_offset - HDR) as u64),
            &mut std::io::sink(),
        )
        .map_err(|e| bad(format!("gzip data cannot be decompressed: {e}")))?
            as usize;
        let mut d = Vec::new();
        (&mut dec)
            .take(need as u64)
            .read_to_end(&mut d)
            .map_err(|e| bad(format!("gzip data cannot be decompressed: {e}")))?;
        if skipped + HDR < vox_offset || d.len() < need {
            return Err(bad(format!(
                "decompressed data holds {} bytes but the header needs {end} ({dims:?} samples of datatype {code} from offset {vox_offset})",
                HDR + skipped + d.len()
            )));
        }
        data = d;
        &data
    } else {
        match bytes.get(vox_offset..end) {
            Some(r) => r,
            None => {
                return Err(bad(format!(
                    "file holds {} bytes but the header needs {end} ({dims:?} samples of datatype {code} from offset {vox_offset})",
                    bytes.len()
                )));
            }
        }
    };
    let mut samples = scalar.decode_all_f32(raw, e);
    if slope != 0.0 && slope.is_finite() && inter.is_finite() && !(slope == 1.0 && inter == 0.0) {
        for v in &mut samples {
            *v = *v * slope + inter;
        }
    }
    let mut vol = Volume {
        dims,
        origin,
        spacing,
        data: samples,
    };
    // Negative axis directions: reverse those axes so the spacing is positive and the origin
    // is the minimum corner, every sample keeping its world position.
    flip_negative_axes(&mut vol);
    Ok(vol)
}

enum Geometry {
    Bad(String),
    Rotated(String),
}

/// Voxel-to-world geometry, as (position of voxel (0,0,0), signed spacing per axis).
///
/// - `sform_code > 0`: the sform rows `srow_x/y/z`.
/// - else `qform_code > 0`: the quaternion (`quatern_b/c/d`), `pixdim[1..3]`, `qfac =
///   pixdim[0]` (0 read as 1) and `qoffset`.
/// - else (NIfTI "method 1", ANALYZE-compatible): `pixdim[1..3]` (absolute values; 0 read
///   as 1) and origin 0.
///
/// The 3×3 part must be diagonal (relative tolerance 1e-6 of its largest entry per column):
/// a rotated, permuted or sheared grid is refused. A negative diagonal entry (a mirrored
/// axis, common in radiological images) is kept as a negative spacing for the caller to
/// flip.
fn geometry(h: &Hdr) -> Result<(Vec3, Vec3), Geometry> {
    let (sform, qform) = (h.i16(254), h.i16(252));
    let (m, origin, src): ([[f64; 3]; 3], [f64; 3], &str) = if sform > 0 {
        // m[row][col]
        let row = |o: usize| [0, 1, 2, 3].map(|c| f64::from(h.f32(o + 4 * c)));
        let (x, y, z) = (row(280), row(296), row(312));
        (
            [[x[0], x[1], x[2]], [y[0], y[1], y[2]], [z[0], z[1], z[2]]],
            [x[3], y[3], z[3]],
            "sform",
        )
    } else if qform > 0 {
        let (b, c, d) = (
            f64::from(h.f32(256)),
            f64::from(h.f32(260)),
            f64::from(h.f32(264)),
        );
        if !(b.is_finite() && c.is_finite() && d.is_finite()) {
            return Err(Geometry::Bad("the qform quaternion is not finite".into()));
        }
        // As in nifti1_io: a = sqrt(1 − b² − c² − d²), renormalised when that is negative.
        let s = b * b + c * c + d * d;
        let (a, b, c, d) = if s > 1.0 {
            let n = s.sqrt();
            (0.0, b / n, c / n, d / n)
        } else {
            ((1.0 - s).sqrt(), b, c, d)
        };
        let r = [
            [
                a * a + b * b - c * c - d * d,
                2.0 * (b * c - a * d),
                2.0 * (b * d + a * c),
            ],
            [
                2.0 * (b * c + a * d),
                a * a + c * c - b * b - d * d,
                2.0 * (c * d - a * b),
            ],
            [
                2.0 * (b * d - a * c),
                2.0 * (c * d + a * b),
                a * a + d * d - b * b - c * c,
            ],
        ];
        let qfac = if h.f32(76) < 0.0 { -1.0 } else { 1.0 };
        // As in nifti1_io, a voxel size that is not positive is read as 1.
        let mut px = [0, 1, 2].map(|a| {
            let v = f64::from(h.f32(80 + 4 * a));
            if v.is_finite() && v > 0.0 { v } else { 1.0 }
        });
        px[2] *= qfac;
        let m = std::array::from_fn(|row| std::array::from_fn(|col| r[row][col] * px[col]));
        let o = [268, 272, 276].map(|o| f64::from(h.f32(o)));
        (m, o, "qform")
    } else {
        let mut spacing = Vec3::ONE;
        for a in 0..3 {
            let p = h.f32(80 + 4 * a).abs();
            if p.is_finite() && p > 0.0 {
                spacing[a] = p;
            }
        }
        return Ok((Vec3::ZERO, spacing));
    };
    if !origin.iter().all(|v| v.is_finite()) {
        return Err(Geometry::Bad(format!(
            "the {src} origin {origin:?} is not finite"
        )));
    }
    let mut spacing = Vec3::ONE;
    for col in 0..3 {
        let diag = m[col][col];
        let off = (0..3)
            .filter(|&r| r != col)
            .map(|r| m[r][col].abs())
            .fold(0.0, f64::max);
        if !(diag.is_finite() && off.is_finite()) {
            return Err(Geometry::Bad(format!(
                "the {src} matrix {m:?} is not finite"
            )));
        }
        if diag == 0.0 && off == 0.0 {
            return Err(Geometry::Bad(format!(
                "the {src} matrix {m:?} has a zero column {col}"
            )));
        }
        if off > 1e-6 * diag.abs() {
            return Err(Geometry::Rotated(format!(
                "NIfTI {src} {m:?} is not axis-aligned (rotated, permuted or sheared grids are not read; resample the volume first)"
            )));
        }
        spacing[col] = diag as f32;
        if !spacing[col].is_finite() || spacing[col] == 0.0 {
            return Err(Geometry::Bad(format!(
                "the {src} spacing {diag} of axis {col} is not a usable f32"
            )));
        }
    }
    Ok((origin.map(|v| v as f32).into(), spacing))
}
