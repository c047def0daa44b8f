//! NumPy `.npy` arrays: reading any numeric dtype, writing f32.

use std::path::Path;

use glam::Vec3;
use isokit_field::checked_len;

use crate::util::{Endian, Scalar, read_file};
use crate::{IoError, Volume, atomic_write};

/// An n-dimensional array read from a `.npy` file, in C order (last index fastest), with
/// every value converted to f64 (exact for all dtypes but 64-bit integers beyond 2^53).
#[derive(Clone, Debug, PartialEq)]
pub struct NpyArray {
    /// The shape, outermost first (NumPy's `shape`).
    pub shape: Vec<usize>,
    /// The values in C order.
    pub data: Vec<f64>,
}

impl NpyArray {
    /// The rows of an `(n, 3)` array as points (e.g. query points), or `None` for any
    /// other shape.
    pub fn as_points(&self) -> Option<Vec<Vec3>> {
        match self.shape.as_slice() {
            [_, 3] => Some(
                self.data
                    .chunks_exact(3)
                    .map(|c| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32))
                    .collect(),
            ),
            _ => None,
        }
    }
}

/// Reads a `.npy` file: versions 1–3, C order only (a Fortran-order array is refused with a
/// clear error), dtypes `f4`, `f8`, `i1`–`i8`, `u1`–`u8` and `b1` in either byte order.
pub fn read_npy(path: &Path) -> Result<NpyArray, IoError> {
    let bytes = read_file(path)?;
    read_npy_from(&bytes, path)
}

/// Reads a `.npy` array from bytes in memory; `name` is used in messages.
pub fn read_npy_bytes(bytes: &[u8], name: &str) -> Result<NpyArray, IoError> {
    read_npy_from(bytes, Path::new(name))
}

fn read_npy_from(bytes: &[u8], path: &Path) -> Result<NpyArray, IoError> {
    let p = parse(bytes, path)?;
    let data = p
        .data
        .chunks_exact(p.scalar.size())
        .map(|c| p.scalar.decode(c, p.endian))
        .collect();
    Ok(NpyArray {
        shape: p.shape,
        data,
    })
}

pub(crate) fn read_npy_volume(bytes: &[u8], path: &Path) -> Result<Volume, IoError> {
    let p = parse(bytes, path)?;
    let [nz, ny, nx] = p.shape[..] else {
        return Err(IoError::malformed(
            path,
            format!(
                "a volume .npy must be 3-D (nz, ny, nx); this one has shape {:?}",
                p.shape
            ),
        ));
    };
    let dims = [nx, ny, nz];
    checked_len(dims).map_err(|e| IoError::malformed(path, e.to_string()))?;
    isokit_field::check_grid_budget(dims).map_err(|e| IoError::malformed(path, e.to_string()))?;
    Ok(Volume {
        dims,
        origin: Vec3::ZERO,
        spacing: Vec3::ONE,
        data: p.scalar.decode_all_f32(p.data, p.endian),
    })
}

struct Parsed<'a> {
    shape: Vec<usize>,
    scalar: Scalar,
    endian: Endian,
    data: &'a [u8],
}

/// A Python literal, the subset that `.npy` headers use.
#[derive(Debug)]
enum Lit {
    Str(String),
    Int(u64),
    Bool(bool),
    None,
    Seq(Vec<Lit>),
    Dict(Vec<(Lit, Lit)>),
}

struct LitParser<'a> {
    s: &'a [u8],
    pos: usize,
}

impl LitParser<'_> {
    fn ws(&mut self) {
        while self.pos < self.s.len() && self.s[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
    }
    fn peek(&mut self) -> Option<u8> {
        self.ws();
        self.s.get(self.pos).copied()
    }
    fn eat(&mut self, c: u8) -> bool {
        if self.peek() == Some(c) {
            self.pos += 1;
            true
        } else {
            false
        }
    }
    fn value(&mut self, depth: usize) -> Option<Lit> {
        if depth > 16 {
            return None;
        }
        match self.peek()? {
            b'{' => {
                self.pos += 1;
                let mut items = Vec::new();
                loop {
                    if self.eat(b'}') {
                        return Some(Lit::Dict(items));
                    }
                    let k = self.value(depth + 1)?;
                    if !self.eat(b':') {
                        return None;
                    }
                    let v = self.value(depth + 1)?;
                    items.push((k, v));
                    if !self.eat(b',') {
                        return self.eat(b'}').then_some(Lit::Dict(items));
                    }
                }
            }
            open @ (b'(' | b'[') => {
                let close = if open == b'(' { b')' } else { b']' };
                self.pos += 1;
                let mut items = Vec::new();
                loop {
                    if self.eat(close) {
                        return Some(Lit::Seq(items));
                    }
                    items.push(self.value(depth + 1)?);
                    if !self.eat(b',') {
                        return self.eat(close).then_some(Lit::Seq(items));
                    }
                }
            }
            q @ (b'\'' | b'"') => {
                self.pos += 1;
                let start = self.pos;
                let len = self.s[start..].iter().position(|&c| c == q)?;
                self.pos = start + len + 1;
                Some(Lit::Str(
                    String::from_utf8_lossy(&self.s[start..start + len]).into_owned(),
                ))
            }
            c if c.is_ascii_digit() => {
                let start = self.pos;
                while self.pos < self.s.len() && self.s[self.pos].is_ascii_digit() {
                    self.pos += 1;
                }
                let v = std::str::from_utf8(&self.s[start..self.pos])
                    .ok()?
                    .parse()
                    .ok()?;
                // Python 2 long suffix.
                if self.s.get(self.pos) == Some(&b'L') {
                    self.pos += 1;
                }
                Some(Lit::Int(v))
            }
            _ => {
                for (word, lit) in [
                    ("True", Lit::Bool(true)),
                    ("False", Lit::Bool(false)),
                    ("None", Lit::None),
                ] {
                    if self.s[self.pos..].starts_with(word.as_bytes()) {
                        self.pos += word.len();
                        return Some(lit);
                    }
                }
                None
            }
        }
    }
}

fn dtype(descr: &str) -> Option<(Scalar, Endian)> {
    let b = descr.as_bytes();
    let (endian, rest) = match b.first()? {
        b'<' | b'=' | b'|' => (Endian::Little, &descr[1..]),
        b'>' => (Endian::Big, &descr[1..]),
        _ => (Endian::Little, descr),
    };
    let s = match rest {
        "f4" => Scalar::F32,
        "f8" => Scalar::F64,
        "i1" => Scalar::I8,
        "u1" | "b1" => Scalar::U8,
        "i2" => Scalar::I16,
        "u2" => Scalar::U16,
        "i4" => Scalar::I32,
        "u4" => Scalar::U32,
        "i8" => Scalar::I64,
        "u8" => Scalar::U64,
        _ => return None,
    };
    Some((s, endian))
}

fn parse<'a>(bytes: &'a [u8], path: &Path) -> Result<Parsed<'a>, IoError> {
    let bad = |msg: String| IoError::malformed(path, format!("NPY: {msg}"));
    if bytes.is_empty() {
        return Err(bad("file is empty".into()));
    }
    if !bytes.starts_with(b"\x93NUMPY") {
        return Err(bad("missing the \\x93NUMPY magic: not a .npy file".into()));
    }
    let (Some(&major), Some(_)) = (bytes.get(6), bytes.get(7)) else {
        return Err(bad("file ends inside the preamble".into()));
    };
    let (hlen, hstart): (usize, usize) = match major {
        1 => match bytes.get(8..10) {
            Some(b) => (u16::from_le_bytes([b[0], b[1]]) as usize, 10),
            None => return Err(bad("file ends inside the preamble".into())),
        },
        2 | 3 => match bytes.get(8..12) {
            Some(b) => (u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize, 12),
            None => return Err(bad("file ends inside the preamble".into())),
        },
        v => {
            return Err(IoError::unsupported(
                path,
                format!("NPY format version {v}"),
            ));
        }
    };
    let Some(header) = bytes.get(hstart..hstart.saturating_add(hlen)) else {
        return Err(bad(format!(
            "header of {hlen} bytes does not fit the file of {} bytes",
            bytes.len()
        )));
    };
    let mut lp = LitParser { s: header, pos: 0 };
    let Some(Lit::Dict(items)) = lp.value(0) else {
        return Err(bad("header is not a Python dict literal".into()));
    };
    let mut descr = None;
    let mut fortran = None;
    let mut shape = None;
    for (k, v) in items {
        let Lit::Str(k) = k else { continue };
        match (k.as_str(), v) {
            ("descr", Lit::Str(d)) => descr = Some(d),
            ("descr", _) => {
                return Err(IoError::unsupported(
                    path,
                    "structured NPY dtype (need a plain numeric dtype)",
                ));
            }
            ("fortran_order", Lit::Bool(b)) => fortran = Some(b),
            ("shape", Lit::Seq(dims)) => {
                let mut s = Vec::with_capacity(dims.len().min(32));
                for d in dims {
                    match d {
                        Lit::Int(v) if v <= usize::MAX as u64 => s.push(v as usize),
                        _ => return Err(bad("shape holds a non-integer".into())),
                    }
                }
                shape = Some(s);
            }
            _ => {}
        }
    }
    let (Some(descr), Some(fortran), Some(shape)) = (descr, fortran, shape) else {
        return Err(bad(
            "header lacks 'descr', 'fortran_order' or 'shape'".into()
        ));
    };
    if fortran {
        return Err(IoError::unsupported(
            path,
            "Fortran-order NPY array (save it in C order, e.g. np.save(f, np.ascontiguousarray(a)))",
        ));
    }
    let (scalar, endian) = dtype(&descr).ok_or_else(|| {
        IoError::unsupported(
            path,
            format!("NPY dtype {descr:?} (need f4, f8 or an integer type)"),
        )
    })?;
    let count = shape
        .iter()
        .try_fold(1u128, |acc, &d| acc.checked_mul(d as u128));
    let body = &bytes[hstart + hlen..];
    let need = count.and_then(|c| c.checked_mul(scalar.size() as u128));
    match need {
        Some(n) if n <= body.len() as u128 => Ok(Parsed {
            shape,
            scalar,
            endian,
            data: &body[..n as usize],
        }),
        _ => Err(bad(format!(
            "shape {shape:?} of {descr} needs {} bytes but only {} follow the header",
            need.map_or("too many".to_string(), |n| n.to_string()),
            body.len()
        ))),
    }
}

fn shape_tuple(shape: &[usize]) -> String {
    match shape {
        [one] => format!("({one},)"),
        _ => format!(
            "({})",
            shape
                .iter()
                .map(|d| d.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// Writes an f32 array (`<f4`, C order) atomically as a version 1.0 `.npy` file. The
/// product of `shape` must equal `data.len()`.
pub fn write_npy_f32(path: &Path, shape: &[usize], data: &[f32]) -> Result<(), IoError> {
    let n = shape.iter().try_fold(1usize, |acc, &d| acc.checked_mul(d));
    if n != Some(data.len()) {
        return Err(IoError::invalid_input(
            path,
            format!("shape {shape:?} does not match {} values", data.len()),
        ));
    }
    let mut header = format!(
        "{{'descr': '<f4', 'fortran_order': False, 'shape': {}, }}",
        shape_tuple(shape)
    );
    // Pad so that the data starts on a 64-byte boundary; the header ends with '\n'.
    let total = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - total % 64) % 64));
    header.push('\n');
    if header.len() > u16::MAX as usize {
        return Err(IoError::invalid_input(
            path,
            "shape too long for an NPY 1.0 header",
        ));
    }
    atomic_write(path, |w| {
        w.write_all(b"\x93NUMPY\x01\x00")?;
        w.write_all(&(header.len() as u16).to_le_bytes())?;
        w.write_all(header.as_bytes())?;
        for v in data {
            w.write_all(&v.to_le_bytes())?;
        }
        Ok(())
    })
}
