//! Small shared helpers: file reading, extensions, a bounds-checked byte cursor, scalar
//! decoding, text tokens.

use std::io::Read;
use std::path::Path;

use crate::IoError;

/// Text as one line for a message: its control characters (a newline that a hostile file
/// put in a name, a key or a reference) are written as escapes (`\n`, `\u{1b}`), so that an
/// error quoting it stays one line.
pub fn shown_text(s: &str) -> std::borrow::Cow<'_, str> {
    if !s.chars().any(char::is_control) {
        return s.into();
    }
    s.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect::<String>()
        .into()
}

/// A path as one line of text for a message ([`shown_text`] of its lossy UTF-8 form).
pub fn shown_path(path: &Path) -> String {
    shown_text(&path.to_string_lossy()).into_owned()
}

/// Reads a whole file; an operating-system failure becomes [`IoError::Io`] naming the file.
///
/// A regular file's size is checked against the memory budget
/// ([`isokit_field::memory`]) before reading; anything else (a pipe, a device such as
/// `/dev/zero`) is read up to the budget and refused beyond it, so no input can claim
/// unbounded memory.
pub fn read_file(path: &Path) -> Result<Vec<u8>, IoError> {
    let mut f = std::fs::File::open(path).map_err(|e| IoError::io(path, e))?;
    let meta = f.metadata().map_err(|e| IoError::io(path, e))?;
    let budget = isokit_field::memory::budget();
    let over = |bytes: u128| {
        isokit_field::memory::check_within(
            budget,
            &format!("reading {}", shown_path(path)),
            bytes,
            "read a smaller file, or raise the budget",
        )
        .map_err(|e| IoError::invalid_input(path, e.to_string()))
    };
    if meta.is_file() {
        over(u128::from(meta.len()))?;
    }
    let mut out = Vec::new();
    (&mut f)
        .take(budget.saturating_add(1))
        .read_to_end(&mut out)
        .map_err(|e| IoError::io(path, e))?;
    if out.len() as u64 > budget {
        over(out.len() as u128)?;
    }
    Ok(out)
}

/// Reads a file that another file refers to (a glTF buffer, a detached NRRD's data): it
/// must be a regular file, and with `exact = Some(n)` only its first `n` bytes are read
/// (refused when it is shorter); otherwise the whole file ([`read_file`]). Errors are
/// [`IoError::Malformed`] naming the referring file `from` and `what` refers.
pub(crate) fn read_referenced(
    from: &Path,
    what: &str,
    file: &Path,
    exact: Option<u64>,
) -> Result<Vec<u8>, IoError> {
    let bad = |why: String| IoError::malformed(from, format!("{what} {}: {why}", shown_path(file)));
    let meta = std::fs::metadata(file).map_err(|e| bad(format!("cannot be read: {e}")))?;
    if !meta.is_file() {
        return Err(bad("is not a regular file".into()));
    }
    let Some(n) = exact else {
        return read_file(file).map_err(|e| match e {
            IoError::Io { source, .. } => bad(format!("cannot be read: {source}")),
            other => other,
        });
    };
    if meta.len() < n {
        return Err(bad(format!(
            "holds {} bytes, fewer than the {n} declared",
            meta.len()
        )));
    }
    isokit_field::memory::check(
        &format!("reading {}", shown_path(file)),
        u128::from(n),
        "read a smaller file, or raise the budget",
    )
    .map_err(|e| bad(e.to_string()))?;
    let mut out = Vec::new();
    std::fs::File::open(file)
        .and_then(|f| f.take(n).read_to_end(&mut out))
        .map_err(|e| bad(format!("cannot be read: {e}")))?;
    if (out.len() as u64) < n {
        return Err(bad(format!(
            "holds {} bytes, fewer than the {n} declared",
            out.len()
        )));
    }
    Ok(out)
}

/// The lower-case extension, with `.nii.gz` and `.inr.gz` kept as one extension (`nii.gz`,
/// `inr.gz`); other `.X.gz` names give `gz`.
/// The rest of the name need not be UTF-8 (extensions are ASCII; other bytes are ignored).
pub(crate) fn extension(path: &Path) -> Option<String> {
    let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
    for two in ["nii.gz", "inr.gz"] {
        if name.ends_with(&format!(".{two}")) && name.len() > two.len() + 1 {
            return Some(two.to_string());
        }
    }
    let ext = path.extension()?.to_string_lossy().to_ascii_lowercase();
    Some(ext)
}

/// Byte order of binary data.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Endian {
    Little,
    Big,
}

/// A numeric sample type shared by the binary formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

impl Scalar {
    pub(crate) fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::I64 | Scalar::U64 | Scalar::F64 => 8,
        }
    }

    pub(crate) fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }

    /// Decodes one value; `b` must hold at least `self.size()` bytes (callers slice with
    /// `chunks_exact`), otherwise NaN.
    #[inline]
    pub(crate) fn decode(self, b: &[u8], e: Endian) -> f64 {
        macro_rules! get {
            ($t:ty, $n:expr) => {{
                let Some(arr) = b.get(..$n).and_then(|s| <[u8; $n]>::try_from(s).ok()) else {
                    return f64::NAN;
                };
                match e {
                    Endian::Little => <$t>::from_le_bytes(arr),
                    Endian::Big => <$t>::from_be_bytes(arr),
                }
            }};
        }
        match self {
            Scalar::I8 => get!(i8, 1) as f64,
            Scalar::U8 => get!(u8, 1) as f64,
            Scalar::I16 => get!(i16, 2) as f64,
            Scalar::U16 => get!(u16, 2) as f64,
            Scalar::I32 => get!(i32, 4) as f64,
            Scalar::U32 => get!(u32, 4) as f64,
            Scalar::I64 => get!(i64, 8) as f64,
            Scalar::U64 => get!(u64, 8) as f64,
            Scalar::F32 => get!(f32, 4) as f64,
            Scalar::F64 => get!(f64, 8),
        }
    }

    /// Decodes `bytes` (a whole number of samples) into f32 samples.
    pub(crate) fn decode_all_f32(self, bytes: &[u8], e: Endian) -> Vec<f32> {
        bytes
            .chunks_exact(self.size())
            .map(|c| self.decode(c, e) as f32)
            .collect()
    }
}

/// A bounds-checked reader over a byte slice whose errors name the file.
pub(crate) struct Cursor<'a> {
    pub(crate) data: &'a [u8],
    pub(crate) pos: usize,
    pub(crate) path: &'a Path,
    /// Format name for messages, e.g. "binary STL".
    pub(crate) what: &'static str,
}

impl<'a> Cursor<'a> {
    pub(crate) fn new(data: &'a [u8], path: &'a Path, what: &'static str) -> Self {
        Self {
            data,
            pos: 0,
            path,
            what,
        }
    }

    pub(crate) fn remaining(&self) -> usize {
        self.data.len().saturating_sub(self.pos)
    }

    pub(crate) fn take(&mut self, n: usize) -> Result<&'a [u8], IoError> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.data.len());
        match end {
            Some(end) => {
                let s = &self.data[self.pos..end];
                self.pos = end;
                Ok(s)
            }
            None => Err(IoError::malformed(
                self.path,
                format!(
                    "{} data ends early: needed {} more bytes at offset {} but only {} remain",
                    self.what,
                    n,
                    self.pos,
                    self.remaining()
                ),
            )),
        }
    }

    pub(crate) fn array<const N: usize>(&mut self) -> Result<[u8; N], IoError> {
        let s = self.take(N)?;
        let mut a = [0u8; N];
        a.copy_from_slice(s);
        Ok(a)
    }

    pub(crate) fn u32_le(&mut self) -> Result<u32, IoError> {
        Ok(u32::from_le_bytes(self.array()?))
    }

    pub(crate) fn scalar(&mut self, t: Scalar, e: Endian) -> Result<f64, IoError> {
        let b = self.take(t.size())?;
        Ok(t.decode(b, e))
    }
}

/// Whitespace-separated tokens of a byte slice.
pub(crate) fn tokens(bytes: &[u8]) -> impl Iterator<Item = &[u8]> {
    bytes
        .split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
}

/// Parses a token as a float (accepts integers, `nan`, `inf`).
pub(crate) fn parse_f64(tok: &[u8]) -> Option<f64> {
    std::str::from_utf8(tok).ok()?.parse::<f64>().ok()
}

/// Decompresses gzip data (one or more members), discarding the first `skip` output bytes
/// and keeping at most `limit` after them, so a small file cannot claim unbounded memory.
/// Returns the kept bytes and the number actually skipped; corrupt data is
/// [`IoError::Malformed`] naming `path`.
///
/// Callers pass the size they expect (for volumes the size the header claims, already
/// checked against [`isokit_field::MAX_SAMPLES`]), or a cap plus one to detect data that
/// inflates past the cap. Nothing is allocated up front: the buffer grows with the bytes
/// actually inflated, so memory follows the real data, never the claim.
pub fn gunzip(
    data: &[u8],
    skip: u64,
    limit: usize,
    path: &Path,
) -> Result<(Vec<u8>, u64), IoError> {
    let bad = |e: std::io::Error| {
        IoError::malformed(path, format!("gzip data cannot be decompressed: {e}"))
    };
    let mut dec = flate2::read::MultiGzDecoder::new(data);
    let skipped = std::io::copy(&mut (&mut dec).take(skip), &mut std::io::sink()).map_err(bad)?;
    let mut out = Vec::new();
    dec.take(limit as u64).read_to_end(&mut out).map_err(bad)?;
    Ok((out, skipped))
}

/// Bytes as shown in error messages: UTF-8 decoded lossily, cut after 60 bytes with `…`.
pub fn show(bytes: &[u8]) -> String {
    let s = String::from_utf8_lossy(&bytes[..bytes.len().min(60)]).into_owned();
    if bytes.len() > 60 {
        format!("{s}…")
    } else {
        s
    }
}
