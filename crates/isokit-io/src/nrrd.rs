//! NRRD (`.nrrd`, `.nhdr`) reader and writer.

use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use glam::Vec3;
use isokit_field::checked_len;

use crate::lattice::Lattice;
use crate::util::{Endian, Scalar, gunzip, parse_f64, read_referenced, show, tokens};
use crate::{IoError, NrrdEncoding, Volume, atomic_write};

fn nrrd_type(t: &str) -> Option<Scalar> {
    Some(match t {
        "signed char" | "int8" | "int8_t" | "char" => Scalar::I8,
        "uchar" | "unsigned char" | "uint8" | "uint8_t" => Scalar::U8,
        "short" | "short int" | "signed short" | "signed short int" | "int16" | "int16_t" => {
            Scalar::I16
        }
        "ushort" | "unsigned short" | "unsigned short int" | "uint16" | "uint16_t" => Scalar::U16,
        "int" | "signed int" | "int32" | "int32_t" => Scalar::I32,
        "uint" | "unsigned int" | "uint32" | "uint32_t" => Scalar::U32,
        "longlong"
        | "long long"
        | "long long int"
        | "signed long long"
        | "signed long long int"
        | "int64"
        | "int64_t" => Scalar::I64,
        "ulonglong" | "unsigned long long" | "unsigned long long int" | "uint64" | "uint64_t" => {
            Scalar::U64
        }
        "float" => Scalar::F32,
        "double" => Scalar::F64,
        _ => return None,
    })
}

#[derive(Clone, Copy, PartialEq)]
enum Encoding {
    Raw,
    Gzip,
    Ascii,
}

/// Parses "(a,b,c)" vectors separated by spaces; `none` entries give `None`.
fn vectors(v: &str) -> Option<Vec<Option<Vec<f64>>>> {
    let mut out = Vec::new();
    let mut rest = v.trim();
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix("none") {
            out.push(None);
            rest = r.trim_start();
            continue;
        }
        let r = rest.strip_prefix('(')?;
        let close = r.find(')')?;
        let comps: Option<Vec<f64>> = r[..close]
            .split(',')
            .map(|c| c.trim().parse::<f64>().ok())
            .collect();
        out.push(Some(comps?));
        rest = r[close + 1..].trim_start();
    }
    Some(out)
}

fn numbers(v: &str) -> Option<Vec<f64>> {
    v.split_whitespace()
        .map(|t| t.parse::<f64>().ok())
        .collect()
}

/// A header line's key and value when it is a key/value pair (`key:=value`): its `:=`
/// comes before any field separator (`: `, or a `:` ending the line), since a field's value
/// may hold `:=`.
fn key_value(line: &str) -> Option<(&str, &str)> {
    let kv = line.find(":=")?;
    let field = line
        .find(": ")
        .or_else(|| line.strip_suffix(':').map(|k| k.len()));
    field
        .is_none_or(|f| kv < f)
        .then(|| (&line[..kv], &line[kv + 2..]))
}

/// The most header bytes [`read_key_values`] reads.
const MAX_KEY_VALUE_HEADER: u64 = 1 << 20;

/// The key/value pairs (`key:=value`, NRRD0004 and later) of the NRRD header at `path`, in
/// the order they appear, read up to the blank line that ends the header (at most 1 MiB):
/// the data is not read. The keys and values are taken as written (escapes are not
/// decoded); a file that does not start with the NRRD magic is refused.
pub fn read_key_values(path: &Path) -> Result<Vec<(String, String)>, IoError> {
    use std::io::{BufRead, Read};
    let file = std::fs::File::open(path).map_err(|e| IoError::io(path, e))?;
    let mut reader = std::io::BufReader::new(file).take(MAX_KEY_VALUE_HEADER);
    let mut out = Vec::new();
    let mut line = Vec::new();
    let mut first = true;
    loop {
        line.clear();
        let n = reader
            .read_until(b'\n', &mut line)
            .map_err(|e| IoError::io(path, e))?;
        if n == 0 {
            break;
        }
        let text = line.strip_suffix(b"\n").unwrap_or(&line);
        let text = text.strip_suffix(b"\r").unwrap_or(text);
        if first {
            if !text.starts_with(b"NRRD000") {
                return Err(IoError::malformed(path, "NRRD: missing the NRRD000x magic"));
            }
            first = false;
            continue;
        }
        if text.is_empty() {
            break;
        }
        if text.starts_with(b"#") {
            continue;
        }
        let Ok(text) = std::str::from_utf8(text) else {
            continue;
        };
        if let Some((k, v)) = key_value(text) {
            out.push((k.to_string(), v.to_string()));
        }
    }
    Ok(out)
}

pub(crate) fn read_nrrd(bytes: &[u8], path: &Path) -> Result<Volume, IoError> {
    let bad = |msg: String| IoError::malformed(path, format!("NRRD: {msg}"));
    if bytes.is_empty() {
        return Err(bad("file is empty".into()));
    }
    if !(bytes.starts_with(b"NRRD000") && bytes.len() >= 8 && bytes[7].is_ascii_digit()) {
        return Err(bad(format!(
            "missing the NRRD000x magic: first bytes are {:?}",
            show(&bytes[..bytes.len().min(8)])
        )));
    }
    // Header lines up to a blank line (attached data follows) or the end of the file.
    let mut fields: HashMap<String, String> = HashMap::new();
    let mut pos = 0;
    let mut data_start = None;
    let mut line_no = 0;
    while pos < bytes.len() {
        let end = bytes[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map(|e| pos + e);
        let raw = &bytes[pos..end.unwrap_or(bytes.len())];
        pos = end.map_or(bytes.len(), |e| e + 1);
        line_no += 1;
        let raw = raw.strip_suffix(b"\r").unwrap_or(raw);
        if line_no == 1 {
            continue;
        }
        if raw.is_empty() {
            data_start = Some(pos);
            break;
        }
        if raw.starts_with(b"#") {
            continue;
        }
        let line = std::str::from_utf8(raw)
            .map_err(|_| bad(format!("header line {line_no} is not text")))?;
        if key_value(line).is_some() {
            continue;
        }
        let field = line
            .find(": ")
            .or_else(|| line.strip_suffix(':').map(|k| k.len()));
        let k_end = match field {
            Some(f) => f,
            None => {
                return Err(bad(format!(
                    "header line {line_no} is not 'field: value': {line:?}"
                )));
            }
        };
        let (k, v) = (&line[..k_end], line.get(k_end + 2..).unwrap_or(""));
        fields.insert(k.trim().to_string(), v.trim().to_string());
    }
    let get = |k: &str| fields.get(k).map(String::as_str);

    let dim: usize = get("dimension")
        .ok_or_else(|| bad("header lacks 'dimension'".into()))?
        .parse()
        .map_err(|_| bad("'dimension' is not an integer".into()))?;
    if dim != 3 {
        return Err(IoError::unsupported(
            path,
            format!("NRRD of dimension {dim} (need 3)"),
        ));
    }
    let t = get("type").ok_or_else(|| bad("header lacks 'type'".into()))?;
    let scalar =
        nrrd_type(t).ok_or_else(|| IoError::unsupported(path, format!("NRRD type {t:?}")))?;
    let sizes: Vec<usize> = get("sizes")
        .ok_or_else(|| bad("header lacks 'sizes'".into()))?
        .split_whitespace()
        .map(|s| s.parse::<usize>())
        .collect::<Result<_, _>>()
        .map_err(|_| bad("'sizes' must be three positive integers".into()))?;
    let [nx, ny, nz] = sizes[..] else {
        return Err(bad(format!(
            "'sizes' has {} entries for dimension 3",
            sizes.len()
        )));
    };
    let dims = [nx, ny, nz];
    let n = checked_len(dims).map_err(|e| bad(e.to_string()))?;
    isokit_field::check_grid_budget(dims).map_err(|e| bad(e.to_string()))?;
    let encoding = match get("encoding").ok_or_else(|| bad("header lacks 'encoding'".into()))? {
        "raw" => Encoding::Raw,
        "gzip" | "gz" => Encoding::Gzip,
        "ascii" | "text" | "txt" => Encoding::Ascii,
        other => {
            return Err(IoError::unsupported(
                path,
                format!("NRRD encoding {other:?}"),
            ));
        }
    };
    let endian = match get("endian") {
        Some("big") => Endian::Big,
        Some("little") | None => Endian::Little,
        Some(other) => return Err(bad(format!("unknown endian {other:?}"))),
    };
    let line_skip: usize = get("line skip")
        .or(get("lineskip"))
        .map(|v| {
            v.parse()
                .map_err(|_| bad("'line skip' is not a non-negative integer".into()))
        })
        .transpose()?
        .unwrap_or(0);
    let byte_skip: i64 = get("byte skip")
        .or(get("byteskip"))
        .map(|v| {
            v.parse()
                .map_err(|_| bad("'byte skip' is not an integer".into()))
        })
        .transpose()?
        .unwrap_or(0);
    if byte_skip < -1 {
        return Err(bad(format!("'byte skip' {byte_skip} must be -1 or more")));
    }

    // Geometry.
    let mut origin = Vec3::ZERO;
    let mut spacing = Vec3::ONE;
    if let Some(v) = get("space directions") {
        let vs =
            vectors(v).ok_or_else(|| bad(format!("cannot parse 'space directions': {v:?}")))?;
        if vs.len() != 3 {
            return Err(bad(format!(
                "'space directions' has {} entries for dimension 3",
                vs.len()
            )));
        }
        for (a, d) in vs.iter().enumerate() {
            let Some(d) = d else {
                return Err(IoError::unsupported(
                    path,
                    format!("NRRD axis {a} is not spatial ('none' direction)"),
                ));
            };
            if d.len() != 3 {
                return Err(IoError::unsupported(
                    path,
                    format!("NRRD space of dimension {} (need 3)", d.len()),
                ));
            }
            let diag = d[a];
            let off = (0..3)
                .filter(|&b| b != a)
                .map(|b| d[b].abs())
                .fold(0.0, f64::max);
            if !(diag.is_finite() && diag != 0.0 && off <= 1e-6 * diag.abs()) {
                return Err(IoError::unsupported(
                    path,
                    format!(
                        "NRRD space directions {v:?} are not axis-aligned (rotated, permuted or sheared grids are not read; resample the volume first)"
                    ),
                ));
            }
            spacing[a] = diag as f32;
        }
    } else if let Some(v) = get("spacings") {
        let s = numbers(v)
            .filter(|s| s.len() == 3)
            .ok_or_else(|| bad(format!("cannot parse 'spacings': {v:?}")))?;
        for a in 0..3 {
            if !(s[a].is_finite() && s[a] != 0.0) {
                return Err(bad(format!("spacing {} of axis {a} is not usable", s[a])));
            }
            spacing[a] = s[a] as f32;
        }
    }
    if let Some(v) = get("space origin") {
        let o = vectors(v)
            .and_then(|vs| match vs.as_slice() {
                [Some(o)] if o.len() == 3 => Some([o[0], o[1], o[2]]),
                _ => None,
            })
            .ok_or_else(|| bad(format!("cannot parse 'space origin': {v:?}")))?;
        origin = Vec3::new(o[0] as f32, o[1] as f32, o[2] as f32);
    } else if let Some(v) = get("axis mins").or(get("axismins")) {
        if let Some(m) = numbers(v).filter(|m| m.len() == 3 && m.iter().all(|x| x.is_finite())) {
            origin = Vec3::new(m[0] as f32, m[1] as f32, m[2] as f32);
        }
    }

    // The data: attached, or in a detached file.
    let detached: Option<Vec<u8>> = match get("data file").or(get("datafile")) {
        Some(name) => {
            if name.starts_with("LIST") || name.contains('%') || name.split_whitespace().count() > 1
            {
                return Err(IoError::unsupported(
                    path,
                    format!("NRRD multi-file data {name:?}"),
                ));
            }
            let file: PathBuf = path.parent().unwrap_or(Path::new("")).join(name);
            // Raw samples at a known offset: exactly the bytes the header declares. Other
            // layouts read the whole (regular) file, within the memory budget.
            let exact =
                (encoding == Encoding::Raw && line_skip == 0 && byte_skip >= 0).then(|| {
                    (n as u64)
                        .saturating_mul(scalar.size() as u64)
                        .saturating_add(byte_skip as u64)
                });
            Some(read_referenced(path, "data file", &file, exact)?)
        }
        None => None,
    };
    let mut data: &[u8] = match &detached {
        Some(d) => d,
        None => match data_start {
            Some(s) => &bytes[s..],
            None => {
                return Err(bad(
                    "header has no blank line before the data and no 'data file'".into(),
                ));
            }
        },
    };
    for _ in 0..line_skip {
        match data.iter().position(|&b| b == b'\n') {
            Some(p) => data = &data[p + 1..],
            None => {
                return Err(bad(format!(
                    "cannot skip {line_skip} lines: the data ends first"
                )));
            }
        }
    }
    let elem = scalar.size();
    let need = n as u128 * elem as u128;
    let decompressed;
    let raw: &[u8] = match encoding {
        Encoding::Ascii => &[],
        Encoding::Raw => data,
        Encoding::Gzip => {
            if byte_skip == -1 {
                return Err(bad(
                    "'byte skip: -1' cannot be used with gzip encoding".into()
                ));
            }
            let (d, skipped) = gunzip(data, byte_skip as u64, need as usize, path)?;
            if skipped < byte_skip as u64 {
                return Err(bad(format!(
                    "decompressed data holds {skipped} bytes, fewer than 'byte skip: {byte_skip}'"
                )));
            }
            decompressed = d;
            &decompressed
        }
    };
    let samples: Vec<f32> = if encoding == Encoding::Ascii {
        let data = data.get(byte_skip.max(0) as usize..).unwrap_or_default();
        let mut v = Vec::with_capacity(n.min(data.len() / 2 + 1));
        for tok in tokens(data).take(n) {
            let x =
                parse_f64(tok).ok_or_else(|| bad(format!("{:?} is not a number", show(tok))))?;
            v.push(x as f32);
        }
        if v.len() < n {
            return Err(bad(format!("ASCII data holds {} of {n} samples", v.len())));
        }
        v
    } else {
        let body = if byte_skip == -1 {
            raw.len().checked_sub(need as usize).map(|s| &raw[s..])
        } else if encoding == Encoding::Gzip {
            Some(raw) // byte skip already applied while decompressing
        } else {
            raw.get(byte_skip as usize..)
        };
        match body {
            Some(b) if b.len() as u128 >= need => {
                scalar.decode_all_f32(&b[..need as usize], endian)
            }
            _ => {
                return Err(bad(format!(
                    "{} data for {dims:?} samples of {t} needs {need} bytes but {} are present",
                    if encoding == Encoding::Gzip {
                        "decompressed"
                    } else {
                        "raw"
                    },
                    if encoding == Encoding::Gzip {
                        raw.len()
                    } else {
                        raw.len().saturating_sub(byte_skip.max(0) as usize)
                    }
                )));
            }
        }
    };
    let mut vol = Volume {
        dims,
        origin,
        spacing,
        data: samples,
    };
    flip_negative_axes(&mut vol);
    Ok(vol)
}

/// Makes every spacing positive by reversing the axes whose spacing is negative (and moving
/// the origin to the new first sample), so the samples keep their world positions.
pub(crate) fn flip_negative_axes(v: &mut Volume) {
    let [nx, ny, nz] = v.dims;
    for a in 0..3 {
        if v.spacing[a] >= 0.0 {
            continue;
        }
        v.origin[a] += v.spacing[a] * (v.dims[a] - 1) as f32;
        v.spacing[a] = -v.spacing[a];
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let (mut ii, mut jj, mut kk) = (i, j, k);
                    let c = [&mut ii, &mut jj, &mut kk];
                    let mirrored = v.dims[a] - 1 - *c[a];
                    if mirrored <= *c[a] {
                        continue;
                    }
                    *c[a] = mirrored;
                    v.data.swap(i + nx * (j + ny * k), ii + nx * (jj + ny * kk));
                }
            }
        }
    }
}

pub(crate) fn write_nrrd(
    path: &Path,
    vol: &Volume,
    encoding: NrrdEncoding,
    meta: Option<&Lattice>,
) -> Result<(), IoError> {
    write_nrrd_with(path, vol, encoding, meta, &[])
}

/// Writes an NRRD file atomically as [`crate::write_nrrd`] does, with the key/value pairs
/// `pairs` (`key:=value` lines, in order) in its header. A key must be non-empty, must not
/// start with `#` (a comment) nor hold `:=` or `: ` (a field), and neither a key nor a value
/// may hold a line break: every pair reads back as written.
pub fn write_key_values(
    path: &Path,
    vol: &Volume,
    encoding: NrrdEncoding,
    pairs: &[(&str, &str)],
) -> Result<(), IoError> {
    for (k, v) in pairs {
        if k.is_empty()
            || k.starts_with('#')
            || k.contains(":=")
            || k.contains(": ")
            || [k, v].iter().any(|t| t.contains(['\n', '\r']))
        {
            return Err(IoError::invalid_input(
                path,
                format!(
                    "NRRD key/value {}:={} (a key is non-empty, not a comment, without ':=' or ': ', neither holds a line break)",
                    crate::shown_text(k),
                    crate::shown_text(v)
                ),
            ));
        }
    }
    write_nrrd_with(path, vol, encoding, None, pairs)
}

fn write_nrrd_with(
    path: &Path,
    vol: &Volume,
    encoding: NrrdEncoding,
    meta: Option<&Lattice>,
    pairs: &[(&str, &str)],
) -> Result<(), IoError> {
    vol.check()
        .map_err(|e| IoError::invalid_input(path, e.to_string()))?;
    let [nx, ny, nz] = vol.dims;
    let (s, o) = (vol.spacing, vol.origin);
    let (enc, level) = match encoding {
        NrrdEncoding::Raw => ("raw", None),
        NrrdEncoding::Gzip => ("gzip", Some(flate2::Compression::fast())),
        NrrdEncoding::GzipBest => ("gzip", Some(flate2::Compression::best())),
    };
    let mut header = format!(
        "NRRD0004\n# written by isokit\ntype: float\ndimension: 3\nspace dimension: 3\n\
         sizes: {nx} {ny} {nz}\nspace directions: ({},0,0) (0,{},0) (0,0,{})\n\
         kinds: domain domain domain\nendian: little\nencoding: {enc}\nspace origin: ({},{},{})\n",
        s.x, s.y, s.z, o.x, o.y, o.z
    );
    // The lattice's meaning as key/value pairs (NRRD0004 `key:=value`), under the names of
    // the NPY sidecar.
    if let Some(m) = meta {
        if let Some(b) = m.band {
            header.push_str(&format!("band:={b}\n"));
        }
        header.push_str(&format!("inside:={}\n", m.inside_name()));
        if let Some(sign) = &m.sign {
            header.push_str(&format!("sign:={sign}\n"));
        }
    }
    for (k, v) in pairs {
        header.push_str(&format!("{k}:={v}\n"));
    }
    header.push('\n');
    atomic_write(path, |w| {
        w.write_all(header.as_bytes())?;
        match level {
            None => write_le(w, &vol.data)?,
            Some(level) => {
                // One gzip member (pynrrd, for one, reads only the first).
                let mut gz = flate2::write::GzEncoder::new(w, level);
                write_le(&mut gz, &vol.data)?;
                gz.finish()?;
            }
        }
        Ok(())
    })
}

/// Writes samples as little-endian f32 in blocks (one `write_all` per 64 Ki samples).
fn write_le(w: &mut dyn Write, data: &[f32]) -> std::io::Result<()> {
    let mut buf = Vec::with_capacity(4 << 16);
    for chunk in data.chunks(1 << 16) {
        buf.clear();
        for v in chunk {
            buf.extend_from_slice(&v.to_le_bytes());
        }
        w.write_all(&buf)?;
    }
    Ok(())
}
