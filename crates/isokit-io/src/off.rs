//! Object File Format (OFF) reader and writer.

use std::path::Path;

use glam::Vec3;

use crate::mesh::fan;
use crate::util::parse_f64;
use crate::{IoError, TriMesh, atomic_write};

/// Lines without comments, with their 1-based line numbers, skipping blank ones.
fn content_lines(text: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    text.split(|&b| b == b'\n')
        .enumerate()
        .filter_map(|(n, l)| {
            let l = match l.iter().position(|&b| b == b'#') {
                Some(c) => &l[..c],
                None => l,
            };
            let l = l.trim_ascii();
            (!l.is_empty()).then_some((n + 1, l))
        })
}

fn words(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|b| b.is_ascii_whitespace())
        .filter(|w| !w.is_empty())
}

fn count(tok: Option<&[u8]>, what: &str, line: usize, path: &Path) -> Result<usize, IoError> {
    tok.and_then(|t| std::str::from_utf8(t).ok()?.parse::<usize>().ok())
        .ok_or_else(|| {
            IoError::malformed(
                path,
                format!("OFF line {line}: expected the number of {what} as a non-negative integer"),
            )
        })
}

pub(crate) fn read_off(bytes: &[u8], path: &Path) -> Result<TriMesh, IoError> {
    let mut lines = content_lines(bytes);
    let Some((ln, header)) = lines.next() else {
        return Err(IoError::malformed(path, "OFF file is empty"));
    };
    let mut head = words(header);
    let kw = head.next().unwrap_or_default();
    let kw_str = String::from_utf8_lossy(kw).into_owned();
    let Some(prefix) = kw_str.strip_suffix("OFF") else {
        return Err(IoError::malformed(
            path,
            format!("OFF line {ln}: expected a header like OFF, COFF or NOFF, found {kw_str:?}"),
        ));
    };
    if prefix.contains('4') || prefix.contains('n') {
        return Err(IoError::unsupported(
            path,
            format!("{kw_str} (only 3-D OFF files are read)"),
        ));
    }
    if !prefix.chars().all(|c| matches!(c, 'S' | 'T' | 'C' | 'N')) {
        return Err(IoError::malformed(
            path,
            format!("OFF line {ln}: unknown header {kw_str:?}"),
        ));
    }
    // Counts may follow the keyword on the same line.
    let mut rest: Vec<&[u8]> = head.collect();
    if rest.first() == Some(&&b"BINARY"[..]) {
        return Err(IoError::unsupported(path, "binary OFF"));
    }
    let counts_line = if rest.is_empty() {
        let Some((ln, l)) = lines.next() else {
            return Err(IoError::malformed(
                path,
                "OFF file ends before the counts line",
            ));
        };
        rest = words(l).collect();
        ln
    } else {
        ln
    };
    let mut it = rest.into_iter();
    let nv = count(it.next(), "vertices", counts_line, path)?;
    let nf = count(it.next(), "faces", counts_line, path)?;
    // Each vertex and face needs a line of at least two bytes: cap preallocation by that.
    let cap = bytes.len() / 2;
    if nv > cap || nf > cap {
        return Err(IoError::malformed(
            path,
            format!(
                "OFF header promises {nv} vertices and {nf} faces but the file has only {} bytes",
                bytes.len()
            ),
        ));
    }
    if nv > u32::MAX as usize {
        return Err(IoError::unsupported(
            path,
            format!("{nv} vertices (limit 2^32)"),
        ));
    }
    let mut mesh = TriMesh {
        positions: Vec::with_capacity(nv),
        triangles: Vec::with_capacity(nf),
    };
    for v in 0..nv {
        let Some((ln, l)) = lines.next() else {
            return Err(IoError::malformed(
                path,
                format!("OFF file ends after {v} of {nv} vertices"),
            ));
        };
        let mut c = [0f32; 3];
        let mut w = words(l);
        for x in &mut c {
            *x = w.next().and_then(parse_f64).ok_or_else(|| {
                IoError::malformed(path, format!("OFF line {ln}: expected three coordinates"))
            })? as f32;
        }
        mesh.positions.push(Vec3::from_array(c));
    }
    let mut poly: Vec<u32> = Vec::new();
    for fi in 0..nf {
        let Some((ln, l)) = lines.next() else {
            return Err(IoError::malformed(
                path,
                format!("OFF file ends after {fi} of {nf} faces"),
            ));
        };
        let mut w = words(l);
        let k = count(w.next(), "face corners", ln, path)?;
        poly.clear();
        for _ in 0..k {
            let idx = w
                .next()
                .and_then(|t| std::str::from_utf8(t).ok()?.parse::<u64>().ok())
                .ok_or_else(|| {
                    IoError::malformed(
                        path,
                        format!("OFF line {ln}: face promises {k} vertex indices"),
                    )
                })?;
            if idx >= nv as u64 {
                return Err(IoError::malformed(
                    path,
                    format!("OFF line {ln}: vertex index {idx} out of range ({nv} vertices)"),
                ));
            }
            poly.push(idx as u32);
        }
        fan(&poly, &mut mesh.triangles);
    }
    Ok(mesh)
}

pub(crate) fn write_off(path: &Path, mesh: &TriMesh) -> Result<(), IoError> {
    crate::mesh::check_indices(mesh, path)?;
    atomic_write(path, |w| {
        writeln!(w, "OFF")?;
        writeln!(w, "{} {} 0", mesh.positions.len(), mesh.triangles.len())?;
        for p in &mesh.positions {
            writeln!(w, "{} {} {}", p.x, p.y, p.z)?;
        }
        for t in &mesh.triangles {
            writeln!(w, "3 {} {} {}", t[0], t[1], t[2])?;
        }
        Ok(())
    })
}
