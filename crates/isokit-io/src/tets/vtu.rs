//! VTK XML unstructured grids (`<VTKFile type="UnstructuredGrid">`, one `Piece`).
//!
//! Data arrays are `ascii` (numbers in the element's text), `binary` (base64 in the text) or
//! `appended` (at an offset into `<AppendedData>`, raw or base64). Binary data starts with a
//! header of `header_type` words (UInt32 by default): uncompressed, the byte count; with
//! `compressor="vtkZLibDataCompressor"`, the block count, the block size, the last block's
//! size and each block's compressed size, then the zlib blocks. In base64 the header of
//! uncompressed data is encoded apart from the data or together with it (VTK and meshio
//! write both); both are read. Compressed data is read with its header encoded apart, as
//! both write it.

use std::io::Read;

use rayon::prelude::*;
use std::path::Path;

use base64::Engine;
use base64::engine::general_purpose::STANDARD;

use super::{Num, Parts, check_budget, decode};
use crate::IoError;
use crate::util::show;

/// An element of the XML part: its name, attributes and text.
#[derive(Debug)]
struct Element {
    name: String,
    attrs: Vec<(String, String)>,
    text: String,
    parent: Option<usize>,
}

impl Element {
    fn attr(&self, key: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
}

/// The XML before the appended data, as a flat list of elements (a small parser for what
/// VTK writes: tags, attributes, text; declarations and comments skipped).
fn parse_xml(text: &str, path: &Path) -> Result<Vec<Element>, IoError> {
    let bad = |m: String| IoError::malformed(path, format!("XML: {m}"));
    let mut out: Vec<Element> = Vec::new();
    let mut open: Vec<usize> = Vec::new();
    let mut rest = text;
    while let Some(lt) = rest.find('<') {
        if let Some(&top) = open.last() {
            out[top].text.push_str(&rest[..lt]);
        }
        rest = &rest[lt..];
        if let Some(r) = rest.strip_prefix("<!--") {
            rest = r.find("-->").map_or("", |i| &r[i + 3..]);
            continue;
        }
        if rest.starts_with("<?") || rest.starts_with("<!") {
            rest = rest.find('>').map_or("", |i| &rest[i + 1..]);
            continue;
        }
        let end = rest
            .find('>')
            .ok_or_else(|| bad("a tag is not closed".into()))?;
        let tag = &rest[1..end];
        rest = &rest[end + 1..];
        if let Some(name) = tag.strip_prefix('/') {
            let name = name.trim();
            match open.pop() {
                Some(i) if out[i].name == name => {}
                _ => {
                    return Err(bad(format!(
                        "</{}> closes nothing open",
                        show(name.as_bytes())
                    )));
                }
            }
            continue;
        }
        let (tag, closed) = match tag.strip_suffix('/') {
            Some(t) => (t, true),
            None => (tag, false),
        };
        let name_end = tag
            .find(|c: char| c.is_ascii_whitespace())
            .unwrap_or(tag.len());
        let mut e = Element {
            name: tag[..name_end].to_string(),
            attrs: Vec::new(),
            text: String::new(),
            parent: open.last().copied(),
        };
        let mut a = tag[name_end..].trim_start();
        while !a.is_empty() {
            let eq = a
                .find('=')
                .ok_or_else(|| bad(format!("attribute without a value in <{}>", e.name)))?;
            let key = a[..eq].trim().to_string();
            let v = a[eq + 1..].trim_start();
            let q = v
                .chars()
                .next()
                .filter(|c| *c == '"' || *c == '\'')
                .ok_or_else(|| bad(format!("attribute {key} is not quoted")))?;
            let close = v[1..]
                .find(q)
                .ok_or_else(|| bad(format!("attribute {key} is not closed")))?;
            e.attrs.push((key, unescape(&v[1..1 + close])));
            a = v[close + 2..].trim_start();
        }
        out.push(e);
        if !closed {
            open.push(out.len() - 1);
        }
    }
    Ok(out)
}

fn unescape(s: &str) -> String {
    s.replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&")
}

/// How the file stores binary data.
struct Layout<'a> {
    big: bool,
    header: Num,
    zlib: bool,
    /// The appended data after its `_` marker, and whether it is base64.
    appended: Option<(&'a [u8], bool)>,
    path: &'a Path,
}

impl Layout<'_> {
    fn bad(&self, m: String) -> IoError {
        IoError::malformed(self.path, m)
    }

    fn words(&self, bytes: &[u8]) -> Vec<f64> {
        decode(self.header, bytes, self.big)
    }

    /// The values of a `DataArray` of `count` numbers.
    fn array(&self, e: &Element, count: u128) -> Result<Vec<f64>, IoError> {
        let name = e.attr("Name").unwrap_or("(unnamed)");
        let ty = match e.attr("type").unwrap_or("") {
            "Int8" => Num::I8,
            "UInt8" => Num::U8,
            "Int16" => Num::I16,
            "UInt16" => Num::U16,
            "Int32" => Num::I32,
            "UInt32" => Num::U32,
            "Int64" => Num::I64,
            "UInt64" => Num::U64,
            "Float32" => Num::F32,
            "Float64" => Num::F64,
            other => {
                return Err(self.bad(format!(
                    "DataArray {name}: type {:?} is not read (Int8 … Float64)",
                    show(other.as_bytes())
                )));
            }
        };
        check_budget(count, ty.size(), &format!("DataArray {name}"), self.path)?;
        let want = count * ty.size() as u128;
        let bytes = match e.attr("format").unwrap_or("ascii") {
            "ascii" => {
                let mut out = Vec::new();
                for t in e.text.split_ascii_whitespace() {
                    if out.len() as u128 == count {
                        break;
                    }
                    out.push(t.parse::<f64>().map_err(|_| {
                        self.bad(format!(
                            "DataArray {name}: {:?} is not a number",
                            show(t.as_bytes())
                        ))
                    })?);
                }
                if (out.len() as u128) < count {
                    return Err(self.bad(format!(
                        "DataArray {name}: {} values, {count} needed",
                        out.len()
                    )));
                }
                return Ok(out);
            }
            "binary" => {
                let text: Vec<u8> = e
                    .text
                    .bytes()
                    .filter(|b| !b.is_ascii_whitespace())
                    .collect();
                self.base64_data(&text, name)?
            }
            "appended" => {
                let (data, base64) = self.appended.ok_or_else(|| {
                    self.bad(format!(
                        "DataArray {name} is appended but the file has no AppendedData"
                    ))
                })?;
                let offset: usize = e
                    .attr("offset")
                    .and_then(|o| o.trim().parse().ok())
                    .ok_or_else(|| self.bad(format!("DataArray {name}: no offset")))?;
                let at = data.get(offset..).ok_or_else(|| {
                    self.bad(format!(
                        "DataArray {name}: offset {offset} is past the appended data"
                    ))
                })?;
                if base64 {
                    self.base64_data(at, name)?
                } else {
                    self.raw_data(at, name)?
                }
            }
            other => {
                return Err(self.bad(format!(
                    "DataArray {name}: format {:?} is not ascii, binary or appended",
                    show(other.as_bytes())
                )));
            }
        };
        if (bytes.len() as u128) < want {
            return Err(self.bad(format!(
                "DataArray {name}: {} bytes of data, {count} values of {} bytes need {want}",
                bytes.len(),
                ty.size()
            )));
        }
        Ok(decode(ty, &bytes[..want as usize], self.big))
    }

    /// Raw appended data: the header words, then the data.
    fn raw_data(&self, at: &[u8], name: &str) -> Result<Vec<u8>, IoError> {
        let hs = self.header.size();
        let short = || {
            self.bad(format!(
                "DataArray {name}: the appended data ends in its header"
            ))
        };
        if !self.zlib {
            let n = *self
                .words(at.get(..hs).ok_or_else(short)?)
                .first()
                .unwrap_or(&0.0);
            let body = at.get(hs..).unwrap_or(&[]);
            if n > body.len() as f64 {
                return Err(self.bad(format!(
                    "DataArray {name}: {n} bytes claimed, {} present",
                    body.len()
                )));
            }
            return Ok(body[..n as usize].to_vec());
        }
        let first = self.words(at.get(..3 * hs).ok_or_else(short)?);
        let blocks = first[0];
        if blocks > (at.len() / hs) as f64 {
            return Err(short());
        }
        let head = at.get(..(3 + blocks as usize) * hs).ok_or_else(short)?;
        let words = self.words(head);
        self.inflate(&words, &at[head.len()..], name)
    }

    /// Base64 data (inline, or appended from its offset): the header encoded apart or with
    /// the data.
    fn base64_data(&self, text: &[u8], name: &str) -> Result<Vec<u8>, IoError> {
        let hs = self.header.size();
        let bad64 = |e: base64::DecodeError| {
            self.bad(format!(
                "DataArray {name}: base64 data cannot be decoded: {e}"
            ))
        };
        let chars = |bytes: usize| bytes.div_ceil(3) * 4;
        let take = |n: usize| -> Result<&[u8], IoError> {
            text.get(..n).ok_or_else(|| {
                self.bad(format!(
                    "DataArray {name}: the base64 data ends in its header"
                ))
            })
        };
        if !self.zlib {
            let head = take(chars(hs))?;
            let decoded = STANDARD.decode(head).map_err(bad64)?;
            let n = *self
                .words(decoded.get(..hs).unwrap_or(&[]))
                .first()
                .unwrap_or(&0.0);
            if head.ends_with(b"=") && decoded.len() == hs {
                // The header apart, then the data.
                let rest = &text[head.len()..];
                let len = chars(n.min(rest.len() as f64) as usize).min(rest.len());
                let data = STANDARD.decode(&rest[..len]).map_err(bad64)?;
                return Ok(data.into_iter().take(n as usize).collect());
            }
            // Together: one stream of the header and the data.
            let total = chars(hs + n.min(text.len() as f64) as usize).min(text.len());
            let all = STANDARD.decode(&text[..total]).map_err(bad64)?;
            return Ok(all.into_iter().skip(hs).take(n as usize).collect());
        }
        let first = STANDARD.decode(take(chars(3 * hs))?).map_err(bad64)?;
        let blocks = *self.words(&first).first().unwrap_or(&0.0);
        if blocks > text.len() as f64 {
            return Err(self.bad(format!("DataArray {name}: {blocks} blocks claimed")));
        }
        let head_len = chars((3 + blocks as usize) * hs);
        let words = self.words(&STANDARD.decode(take(head_len)?).map_err(bad64)?);
        let compressed: f64 = words.iter().skip(3).sum();
        let rest = &text[head_len..];
        let len = chars(compressed.min(rest.len() as f64) as usize).min(rest.len());
        let data = STANDARD.decode(&rest[..len]).map_err(bad64)?;
        self.inflate(&words, &data, name)
    }

    /// zlib blocks after their header words `[count, size, last size, compressed sizes…]`.
    fn inflate(&self, words: &[f64], data: &[u8], name: &str) -> Result<Vec<u8>, IoError> {
        let blocks = words.first().map_or(0, |&b| b as usize);
        if words.len() < 3 || words.len() - 3 < blocks {
            return Err(self.bad(format!(
                "DataArray {name}: the compression header is cut short ({} words for {blocks} blocks)",
                words.len()
            )));
        }
        let (size, last) = (words[1], words[2]);
        let total = if blocks == 0 {
            0.0
        } else {
            size * (blocks - 1) as f64 + if last == 0.0 { size } else { last }
        };
        check_budget(total as u128, 1, &format!("DataArray {name}"), self.path)?;
        // Each block's compressed bytes and its piece of the output, then the blocks
        // inflated in parallel (VTK writes blocks of 32 KiB).
        let mut out = vec![0u8; total as usize];
        let mut jobs = Vec::with_capacity(blocks);
        let (mut at, mut rest) = (0usize, out.as_mut_slice());
        for b in 0..blocks {
            let c = words[3 + b] as usize;
            let block = data.get(at..at.saturating_add(c)).ok_or_else(|| {
                self.bad(format!(
                    "DataArray {name}: compressed block {b} is cut short"
                ))
            })?;
            at += c;
            let want = if b + 1 == blocks && last != 0.0 {
                last
            } else {
                size
            } as usize;
            let n = want.min(rest.len());
            let (piece, tail) = std::mem::take(&mut rest).split_at_mut(n);
            rest = tail;
            jobs.push((b, block, piece));
        }
        jobs.into_par_iter().try_for_each(|(b, block, piece)| {
            let mut z = flate2::read::ZlibDecoder::new(block);
            z.read_exact(piece).map_err(|e| {
                self.bad(format!(
                    "DataArray {name}: block {b} does not inflate to its {} bytes: {e}",
                    piece.len()
                ))
            })
        })?;
        Ok(out)
    }
}

pub(super) fn read(bytes: &[u8], path: &Path) -> Result<Parts, IoError> {
    let bad = |m: String| IoError::malformed(path, m);
    // Raw appended data is binary: the XML ends at its marker.
    let marker = find(bytes, b"<AppendedData");
    let xml_end = marker.unwrap_or(bytes.len());
    let xml = String::from_utf8_lossy(&bytes[..xml_end]);
    let mut elems = parse_xml(&xml, path)?;
    let mut appended = None;
    if let Some(m) = marker {
        let close = find(&bytes[m..], b">")
            .ok_or_else(|| bad("XML: <AppendedData is not closed".into()))?;
        let tag = String::from_utf8_lossy(&bytes[m..m + close + 1]).into_owned();
        let parsed = parse_xml(&tag, path)?;
        let encoding = parsed
            .first()
            .and_then(|e| e.attr("encoding"))
            .unwrap_or("raw")
            .to_string();
        let after = &bytes[m + close + 1..];
        let us = after
            .iter()
            .position(|&b| b == b'_')
            .ok_or_else(|| bad("AppendedData has no '_' marker".into()))?;
        let base64 = match encoding.as_str() {
            "raw" => false,
            "base64" => true,
            other => {
                return Err(bad(format!(
                    "AppendedData encoding {other:?} is not raw or base64"
                )));
            }
        };
        appended = Some((&after[us + 1..], base64));
        elems.extend(parsed);
    }
    let file = elems
        .iter()
        .find(|e| e.name == "VTKFile")
        .ok_or_else(|| bad("not a VTK XML file: no <VTKFile> element".into()))?;
    if file.attr("type") != Some("UnstructuredGrid") {
        return Err(IoError::Unsupported {
            path: path.to_path_buf(),
            what: format!(
                "VTK XML type {:?}: a tetrahedral grid is an UnstructuredGrid",
                file.attr("type").unwrap_or("")
            ),
        });
    }
    let zlib = match file.attr("compressor") {
        None | Some("") => false,
        Some("vtkZLibDataCompressor") => true,
        Some(other) => {
            return Err(IoError::Unsupported {
                path: path.to_path_buf(),
                what: format!("compressor {other} (only vtkZLibDataCompressor is read)"),
            });
        }
    };
    let layout = Layout {
        big: file.attr("byte_order") == Some("BigEndian"),
        header: match file.attr("header_type") {
            Some("UInt64") => Num::U64,
            None | Some("UInt32") => Num::U32,
            Some(other) => {
                return Err(bad(format!(
                    "header_type {other:?} is not UInt32 or UInt64"
                )));
            }
        },
        zlib,
        appended,
        path,
    };
    let pieces: Vec<usize> = (0..elems.len())
        .filter(|&i| elems[i].name == "Piece")
        .collect();
    let &[piece] = pieces.as_slice() else {
        return Err(IoError::Unsupported {
            path: path.to_path_buf(),
            what: format!("{} pieces (one is read)", pieces.len()),
        });
    };
    let count = |key: &str| -> Result<u128, IoError> {
        elems[piece]
            .attr(key)
            .and_then(|v| v.trim().parse().ok())
            .ok_or_else(|| bad(format!("Piece has no {key}")))
    };
    let (n, cells) = (count("NumberOfPoints")?, count("NumberOfCells")?);
    // The data arrays under `section` of the piece.
    let under = |section: &str| -> Vec<&Element> {
        elems
            .iter()
            .filter(|e| {
                e.name == "DataArray"
                    && e.parent
                        .is_some_and(|p| elems[p].name == section && elems[p].parent == Some(piece))
            })
            .collect()
    };
    let mut parts = Parts::default();
    let points = under("Points");
    let p = points
        .first()
        .ok_or_else(|| bad("the Piece has no Points DataArray".into()))?;
    parts.points = layout.array(p, n.saturating_mul(3))?;
    let cell_arrays = under("Cells");
    let named = |name: &str| {
        cell_arrays
            .iter()
            .find(|e| e.attr("Name") == Some(name))
            .ok_or_else(|| bad(format!("the Cells have no {name} DataArray")))
    };
    let mut offsets = layout.array(named("offsets")?, cells)?;
    offsets.insert(0, 0.0);
    parts.offsets = offsets;
    let conn_len = parts.offsets.last().copied().unwrap_or(0.0);
    if !(conn_len >= 0.0 && conn_len <= cells.saturating_mul(4) as f64) {
        return Err(bad(format!(
            "the offsets end at {conn_len}; {cells} tetrahedra use {} indices",
            cells * 4
        )));
    }
    parts.connectivity = layout.array(named("connectivity")?, conn_len as u128)?;
    parts.types = layout.array(named("types")?, cells)?;
    for e in under("PointData") {
        let comps: u128 = e
            .attr("NumberOfComponents")
            .and_then(|c| c.trim().parse().ok())
            .unwrap_or(1);
        if comps == 1 {
            let v = layout.array(e, n)?;
            parts
                .arrays
                .push((e.attr("Name").unwrap_or("scalars").to_string(), v));
        }
    }
    Ok(parts)
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}
