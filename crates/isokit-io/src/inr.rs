//! INRIMAGE-4 volumes (`.inr`, `.inr.gz`), the format of INRIA's image library that CGAL's
//! mesh generation reads and its sample data ships in.
//!
//! A file is a text header of `KEY=VALUE` lines opened by `#INRIMAGE-4#{` and closed by
//! `##}`, padded with newlines to a multiple of 256 bytes, then the samples, x fastest:
//!
//! ```text
//! #INRIMAGE-4#{
//! XDIM=64
//! YDIM=64
//! ZDIM=64
//! VDIM=1
//! TYPE=float
//! PIXSIZE=32 bits
//! CPU=decm
//! VX=3.94305
//! VY=3.94305
//! VZ=3.65079
//! ##}
//! ```
//!
//! Read here: `XDIM`, `YDIM`, `ZDIM` (at least 1), `VDIM` 1 (one value per sample),
//! `TYPE` `float` (`PIXSIZE` 32 or 64 bits), `unsigned fixed` or `signed fixed` (8, 16,
//! 32 or 64 bits), `CPU` (`decm`, `alpha`, `pc` little-endian; `sun`, `sgi` big-endian;
//! little-endian when absent), the spacing `VX`, `VY`, `VZ` (1 when absent) and the origin
//! `TX`, `TY`, `TZ` (0 when absent; CGAL writes them). `SCALE=2**0` is the only scale
//! (fixed-point images with another scale are refused). Lines starting with `#` are
//! comments. Gzipped files inflate only up to the size the header claims, after that
//! size is checked against the memory budget.

use std::collections::HashMap;
use std::path::Path;

use glam::Vec3;
use isokit_field::checked_len;

use crate::util::{Endian, Scalar, gunzip, show};
use crate::{IoError, Volume};

/// The header's block size: headers are padded to a multiple of it.
const BLOCK: usize = 256;

/// The most header blocks read (a file whose header does not close within 64 KiB is not
/// an INRIMAGE file).
const MAX_HEADER: usize = 256 * BLOCK;

const MAGIC: &[u8] = b"#INRIMAGE-4#{";

pub(crate) fn read_inr(bytes: &[u8], path: &Path) -> Result<Volume, IoError> {
    let bad = |msg: String| IoError::malformed(path, format!("INRIMAGE: {msg}"));
    if bytes.is_empty() {
        return Err(bad("file is empty".into()));
    }
    let gz = bytes.starts_with(&[0x1f, 0x8b]);
    let head: std::borrow::Cow<'_, [u8]> = if gz {
        gunzip(bytes, 0, MAX_HEADER, path)?.0.into()
    } else {
        bytes[..bytes.len().min(MAX_HEADER)].into()
    };
    if !head.starts_with(MAGIC) {
        return Err(bad(format!(
            "missing the #INRIMAGE-4#{{ magic: first bytes are {:?}",
            show(&head[..head.len().min(13)])
        )));
    }
    let close = find(&head, b"\n##}")
        .ok_or_else(|| bad("the header does not close with ##} within 64 KiB".into()))?;
    // The header ends at the block boundary after its closing line.
    let header_len = (close + 4).div_ceil(BLOCK) * BLOCK;
    let text = std::str::from_utf8(&head[MAGIC.len()..close])
        .map_err(|_| bad("the header is not text".into()))?;
    let mut fields: HashMap<&str, &str> = HashMap::new();
    for (n, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let (k, v) = line.split_once('=').ok_or_else(|| {
            bad(format!(
                "header line {} is not KEY=VALUE: {:?}",
                n + 1,
                crate::shown_text(line)
            ))
        })?;
        fields.insert(k.trim(), v.trim());
    }
    let get = |k: &str| fields.get(k).copied();
    let dim = |k: &str| -> Result<usize, IoError> {
        let v = get(k).ok_or_else(|| bad(format!("header lacks {k}")))?;
        v.parse::<usize>().ok().filter(|&d| d >= 1).ok_or_else(|| {
            bad(format!(
                "{k}={} is not a positive integer",
                crate::shown_text(v)
            ))
        })
    };
    let dims = [dim("XDIM")?, dim("YDIM")?, dim("ZDIM")?];
    match get("VDIM") {
        None | Some("1") => {}
        Some(v) => {
            return Err(IoError::unsupported(
                path,
                format!(
                    "INRIMAGE with VDIM={} (only one value per sample is read)",
                    crate::shown_text(v)
                ),
            ));
        }
    }
    let bits = match get("PIXSIZE") {
        None => None,
        Some(p) => Some(
            p.strip_suffix("bits")
                .map(str::trim)
                .and_then(|b| b.parse::<u32>().ok())
                .ok_or_else(|| bad(format!("PIXSIZE={} is not 'N bits'", crate::shown_text(p))))?,
        ),
    };
    let kind = get("TYPE").ok_or_else(|| bad("header lacks TYPE".into()))?;
    let scalar = match (kind, bits) {
        ("float", None | Some(32)) => Scalar::F32,
        ("float", Some(64)) => Scalar::F64,
        ("unsigned fixed", Some(8)) => Scalar::U8,
        ("unsigned fixed", Some(16)) => Scalar::U16,
        ("unsigned fixed", Some(32)) => Scalar::U32,
        ("unsigned fixed", Some(64)) => Scalar::U64,
        ("signed fixed", Some(8)) => Scalar::I8,
        ("signed fixed", Some(16)) => Scalar::I16,
        ("signed fixed", Some(32)) => Scalar::I32,
        ("signed fixed", Some(64)) => Scalar::I64,
        _ => {
            return Err(IoError::unsupported(
                path,
                format!(
                    "INRIMAGE TYPE={} with PIXSIZE={} (float of 32 or 64 bits, signed or unsigned fixed of 8 to 64 bits are read)",
                    crate::shown_text(kind),
                    bits.map_or_else(|| "(none)".to_owned(), |b| format!("{b} bits"))
                ),
            ));
        }
    };
    match get("SCALE") {
        None | Some("2**0") => {}
        Some(s) => {
            return Err(IoError::unsupported(
                path,
                format!(
                    "INRIMAGE SCALE={} (only 2**0 is read)",
                    crate::shown_text(s)
                ),
            ));
        }
    }
    let endian = match get("CPU") {
        None | Some("decm" | "alpha" | "pc") => Endian::Little,
        Some("sun" | "sgi") => Endian::Big,
        Some(c) => {
            return Err(bad(format!(
                "CPU={} is not decm, alpha, pc, sun or sgi",
                crate::shown_text(c)
            )));
        }
    };
    let num = |k: &str, default: f32| -> Result<f32, IoError> {
        match get(k) {
            None => Ok(default),
            Some(v) => v
                .parse::<f32>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    bad(format!(
                        "{k}={} is not a finite number",
                        crate::shown_text(v)
                    ))
                }),
        }
    };
    let spacing = Vec3::new(num("VX", 1.0)?, num("VY", 1.0)?, num("VZ", 1.0)?);
    if spacing.min_element() <= 0.0 {
        return Err(bad(format!(
            "the voxel size {spacing} must be positive (VX, VY, VZ)"
        )));
    }
    let origin = Vec3::new(num("TX", 0.0)?, num("TY", 0.0)?, num("TZ", 0.0)?);
    let n = checked_len(dims).map_err(|e| bad(e.to_string()))?;
    isokit_field::check_grid_budget(dims).map_err(|e| bad(e.to_string()))?;
    let need = n * scalar.size();
    let inflated;
    let raw: &[u8] = if gz {
        let (d, skipped) = gunzip(bytes, header_len as u64, need, path)?;
        if (skipped as usize) < header_len || d.len() < need {
            return Err(bad(format!(
                "decompressed data holds {} bytes but the header needs {} ({dims:?} samples of {} bits after a {header_len}-byte header)",
                skipped as usize + d.len(),
                header_len + need,
                8 * scalar.size()
            )));
        }
        inflated = d;
        &inflated
    } else {
        bytes
            .get(header_len..header_len + need)
            .ok_or_else(|| {
                bad(format!(
                    "file holds {} bytes but the header needs {} ({dims:?} samples of {} bits after a {header_len}-byte header)",
                    bytes.len(),
                    header_len + need,
                    8 * scalar.size()
                ))
            })?
    };
    let vol = Volume {
        dims,
        origin,
        spacing,
        data: scalar.decode_all_f32(raw, endian),
    };
    Ok(vol)
}

/// The position of `needle` in `hay`.
fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An INRIMAGE file: `lines` between the magic and `##}`, padded to 256 bytes, then
    /// `data`.
    fn inr(lines: &str, data: &[u8]) -> Vec<u8> {
        let mut h = format!("#INRIMAGE-4#{{\n{lines}");
        let body = h.len() + 4;
        h.push_str(&"\n".repeat(body.div_ceil(BLOCK) * BLOCK - body));
        h.push_str("##}\n");
        let mut b = h.into_bytes();
        assert_eq!(b.len() % BLOCK, 0);
        b.extend_from_slice(data);
        b
    }

    fn read(b: &[u8]) -> Result<Volume, IoError> {
        read_inr(b, Path::new("t.inr"))
    }

    #[test]
    fn reads_types_byte_orders_spacing_and_origin() {
        let f: Vec<u8> = [1.5f32, -2.0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let v = read(&inr(
            "XDIM=2\nYDIM=1\nZDIM=1\nVDIM=1\nTYPE=float\nPIXSIZE=32 bits\nCPU=decm\nVX=0.5\nVY=2\nVZ=3\nTX=1\nTY=-2\nTZ=4\n",
            &f,
        ))
        .unwrap();
        assert_eq!(v.dims, [2, 1, 1]);
        assert_eq!(v.data, vec![1.5, -2.0]);
        assert_eq!(v.spacing, Vec3::new(0.5, 2.0, 3.0));
        assert_eq!(v.origin, Vec3::new(1.0, -2.0, 4.0));
        // Big-endian 16-bit signed, no spacing: 1.
        let be: Vec<u8> = [-300i16, 7].iter().flat_map(|v| v.to_be_bytes()).collect();
        let v = read(&inr(
            "XDIM=1\nYDIM=2\nZDIM=1\nTYPE=signed fixed\nPIXSIZE=16 bits\nSCALE=2**0\nCPU=sun\n",
            &be,
        ))
        .unwrap();
        assert_eq!(v.data, vec![-300.0, 7.0]);
        assert_eq!(v.spacing, Vec3::ONE);
        // 8-bit unsigned, gzipped, a header longer than one block.
        let long = format!(
            "XDIM=2\nYDIM=2\nZDIM=1\nTYPE=unsigned fixed\nPIXSIZE=8 bits\n#{}\n",
            "c".repeat(300)
        );
        let plain = inr(&long, &[0, 10, 200, 255]);
        assert_eq!(plain.len(), 2 * BLOCK + 4);
        let mut gz = Vec::new();
        {
            use std::io::Write;
            let mut e = flate2::write::GzEncoder::new(&mut gz, flate2::Compression::fast());
            e.write_all(&plain).unwrap();
            e.finish().unwrap();
        }
        for b in [&plain, &gz] {
            assert_eq!(read(b).unwrap().data, vec![0.0, 10.0, 200.0, 255.0]);
        }
    }

    #[test]
    fn refuses_what_it_cannot_read_in_one_line() {
        let one = [0u8; 4];
        let cases: &[(&[u8], &str)] = &[
            (b"", "empty"),
            (b"P6\n1 1\n", "magic"),
            (b"#INRIMAGE-4#{\nXDIM=1\n", "does not close"),
            (&inr("XDIM=1\nYDIM=1\nTYPE=float\n", &one), "lacks ZDIM"),
            (&inr("XDIM=0\nYDIM=1\nZDIM=1\nTYPE=float\n", &one), "XDIM=0"),
            (
                &inr("XDIM=1\nYDIM=1\nZDIM=1\nVDIM=3\nTYPE=float\n", &one),
                "VDIM=3",
            ),
            (
                &inr(
                    "XDIM=1\nYDIM=1\nZDIM=1\nTYPE=float\nPIXSIZE=16 bits\n",
                    &one,
                ),
                "PIXSIZE=16",
            ),
            (
                &inr(
                    "XDIM=1\nYDIM=1\nZDIM=1\nTYPE=unsigned fixed\nPIXSIZE=8 bits\nSCALE=2**3\n",
                    &one,
                ),
                "SCALE",
            ),
            (
                &inr("XDIM=1\nYDIM=1\nZDIM=1\nTYPE=float\nCPU=vax\n", &one),
                "CPU=vax",
            ),
            (
                &inr("XDIM=1\nYDIM=1\nZDIM=1\nTYPE=float\nVX=-1\n", &one),
                "positive",
            ),
            (
                &inr("XDIM=1\nYDIM=1\nZDIM=1\nTYPE=float\nVX=nan\n", &one),
                "finite",
            ),
            (
                &inr("XDIM=2\nYDIM=1\nZDIM=1\nTYPE=float\n", &one),
                "header needs",
            ),
            (&inr("no equals sign\n", &one), "KEY=VALUE"),
            (
                &inr("XDIM=100000\nYDIM=100000\nZDIM=100000\nTYPE=float\n", &one),
                "too large",
            ),
        ];
        for (bytes, want) in cases {
            let e = read(bytes).unwrap_err().to_string();
            assert!(e.contains(want), "{want:?} not in {e:?}");
            assert!(!e.contains('\n'), "{e:?}");
        }
    }
}
