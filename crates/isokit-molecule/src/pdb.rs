//! The PDB reader: fixed-column ATOM/HETATM, CONECT, MODEL/ENDMDL, END.

use std::collections::HashMap;
use std::path::Path;

use glam::Vec3;

use super::{AltLocFilter, Atom, Element, Molecule, bonds, line_error};
use isokit_io::IoError;
use isokit_io::reader::show;

/// Decodes a hybrid-36 number of `width` digits (5 for atom serial numbers, 4 for residue
/// sequence numbers), as written by the PDB format for values that do not fit in decimal:
/// decimal up to `10^width - 1`, then upper-case base 36 from `A000…` (= `10^width`),
/// then lower-case base 36 from `a000…`. Surrounding blanks are allowed around a decimal
/// value only. `None` for an empty field or anything that is not hybrid-36.
///
/// See <https://cci.lbl.gov/hybrid_36/> (R. W. Grosse-Kunstleve, cctbx).
///
/// ```
/// use isokit_molecule::hybrid36_decode;
/// assert_eq!(hybrid36_decode(5, "   42"), Some(42));
/// assert_eq!(hybrid36_decode(5, "A0000"), Some(100_000));
/// assert_eq!(hybrid36_decode(5, "a0000"), Some(43_770_016));
/// assert_eq!(hybrid36_decode(4, "A000"), Some(10_000));
/// assert_eq!(hybrid36_decode(5, "A00"), None);
/// ```
pub fn hybrid36_decode(width: usize, field: &str) -> Option<i64> {
    let b = field.as_bytes();
    let first = *b.first()?;
    if first == b' ' || first == b'-' || first == b'+' || first.is_ascii_digit() {
        let t = field.trim();
        let rest = t.as_bytes().get(1..).unwrap_or(&[]);
        if t.is_empty() || t.len() > width || !rest.iter().all(|c| c.is_ascii_digit()) {
            return None;
        }
        return t.parse().ok();
    }
    if b.len() != width || !(1..=6).contains(&width) {
        return None;
    }
    let upper = first.is_ascii_uppercase();
    if !upper && !first.is_ascii_lowercase() {
        return None;
    }
    let mut v: i64 = 0;
    for &c in b {
        let d = match c {
            b'0'..=b'9' => c - b'0',
            b'A'..=b'Z' if upper => c - b'A' + 10,
            b'a'..=b'z' if !upper => c - b'a' + 10,
            _ => return None,
        };
        v = v * 36 + i64::from(d);
    }
    let p36 = 36i64.pow(width as u32 - 1);
    let p10 = 10i64.pow(width as u32);
    Some(if upper {
        v - 10 * p36 + p10
    } else {
        v + 16 * p36 + p10
    })
}

/// The element of a PDB atom name (columns 13–16, padded to 4) when the element columns
/// are missing or unreadable, following the PDB convention that the element symbol is
/// right-justified in columns 13–14:
///
/// - a blank or a digit in column 13 (`" CA "`, `" N  "`, `"1HB "`): the one letter in
///   column 14 (carbon, nitrogen, hydrogen);
/// - a letter in column 13 starting a 3–4 character hydrogen name (`"HG11"`, `"HE21"`,
///   `"HD1 "`): hydrogen;
/// - a letter in column 13 and a two-letter symbol in columns 13–14 (`"CA  "`, `"FE  "`,
///   `"CL1 "`, `"FE2 "`): that element (calcium, iron, chlorine, iron) — except for the
///   protein and nucleic-acid names that merely look like one (`"CD1 "`, `"NE2 "`,
///   `"CE1 "`, `"ND1 "`, written one column too far left), which take the first letter;
/// - otherwise the letter in column 13 (`"C10 "`, `"O   "`).
///
/// A HETATM whose stripped name equals its residue name and is an element symbol (the
/// single-atom ions: `ZN`/`ZN`, `K`/`K`, ` FE`/`FE`) is that element whatever the columns.
pub fn element_from_atom_name(name: &str, residue: &str, hetero: bool) -> Element {
    let trimmed = name.trim();
    if hetero && !trimmed.is_empty() && trimmed.eq_ignore_ascii_case(residue.trim()) {
        let e = Element::from_symbol(trimmed);
        if e != Element::Unknown {
            return e;
        }
    }
    let mut n = [b' '; 4];
    for (d, s) in n.iter_mut().zip(name.bytes()) {
        *d = s;
    }
    let one = |c: u8| {
        if c.is_ascii_alphabetic() {
            Element::from_symbol(std::str::from_utf8(&[c]).unwrap_or(""))
        } else {
            Element::Unknown
        }
    };
    let [c13, c14, c15, c16] = n;
    if c13 == b' ' || c13.is_ascii_digit() {
        return one(c14);
    }
    if !c13.is_ascii_alphabetic() {
        return Element::Unknown;
    }
    let longer = c15 != b' ' || c16 != b' ';
    if c13.eq_ignore_ascii_case(&b'H') && longer {
        return Element::H;
    }
    if c14.is_ascii_alphabetic() {
        let pair = [c13.to_ascii_uppercase(), c14.to_ascii_uppercase()];
        let lookalike = longer && matches!(&pair, b"CD" | b"CE" | b"NE" | b"ND");
        if !lookalike {
            let e = Element::from_symbol(std::str::from_utf8(&pair).unwrap_or(""));
            if e != Element::Unknown {
                return e;
            }
        }
    }
    one(c13)
}

/// Bytes `from..=to` (1-based columns) of a line, clamped to its length.
fn col(line: &[u8], from: usize, to: usize) -> &str {
    let s = line.get(from - 1..to.min(line.len())).unwrap_or(&[]);
    // Records are checked to be ASCII before any column is read.
    std::str::from_utf8(s).unwrap_or("")
}

/// Where the reader is with respect to MODEL/ENDMDL.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Models {
    /// No MODEL record yet: atoms are read.
    Before,
    /// Inside the first MODEL: atoms are read.
    First,
    /// After the first model: atoms are skipped (CONECT is still read).
    Done,
}

/// Reads PDB text. See [`super::read_molecule`] for the rules.
pub(crate) fn read_pdb(text: &[u8], path: &Path, max_atoms: usize) -> Result<Molecule, IoError> {
    // Old Mac files end lines with a lone CR.
    let sep = if !text.contains(&b'\n') && text.contains(&b'\r') {
        b'\r'
    } else {
        b'\n'
    };
    let mut atoms: Vec<Atom> = Vec::new();
    let mut alt = AltLocFilter::default();
    let mut conect: Vec<(i64, i64)> = Vec::new();
    let mut models = Models::Before;
    let mut id_code = String::new();
    let mut prev_serial: i64 = 0;

    for (n, raw) in text.split(|&b| b == sep).enumerate() {
        let lineno = n + 1;
        let bad = |msg: String| line_error(path, lineno, msg);
        let mut line = raw;
        while let [rest @ .., last] = line {
            if last.is_ascii_whitespace() {
                line = rest;
            } else {
                break;
            }
        }
        if let Some(p) = line
            .iter()
            .position(|&b| (b < 0x20 && b != b'\t' && b != b'\r' && b != 0x0c) || b == 0x7f)
        {
            return Err(bad(format!(
                "binary data (byte 0x{:02x} at column {}); this is not a PDB text file",
                line[p],
                p + 1
            )));
        }
        let rec_bytes = line.get(..line.len().min(6)).unwrap_or(&[]);
        let rec_name = std::str::from_utf8(rec_bytes).unwrap_or("").trim_end();
        // "ATOM" with a 6- or 7-digit serial spilling into columns 5–6, as some programs write.
        let atom_wide = rec_bytes.starts_with(b"ATOM")
            && rec_bytes.len() == 6
            && rec_bytes[4..]
                .iter()
                .all(|c| *c == b' ' || c.is_ascii_digit())
            && rec_bytes[4..].iter().any(|c| c.is_ascii_digit());
        let kind = match rec_name {
            "ATOM" | "HETATM" | "CONECT" | "MODEL" | "ENDMDL" | "END" | "HEADER" => rec_name,
            _ if atom_wide => "ATOM",
            _ => continue,
        };
        if let Some(p) = line.iter().position(|b| !b.is_ascii()) {
            if kind == "HEADER" {
                continue; // only its ID is wanted; a stray byte in the title is no reason to fail
            }
            return Err(bad(format!(
                "{kind} record is not ASCII text (byte 0x{:02x} at column {}): not UTF-8, or not a PDB file",
                line[p],
                p + 1
            )));
        }
        match kind {
            "HEADER" => {
                if id_code.is_empty() {
                    // Only a plausible ID (letters and digits), not a shifted title.
                    let id = col(line, 63, 66).trim();
                    if id.bytes().all(|c| c.is_ascii_alphanumeric()) {
                        id_code = id.to_string();
                    }
                }
            }
            "MODEL" => {
                models = match models {
                    Models::Before => Models::First,
                    _ => Models::Done,
                }
            }
            "ENDMDL" => models = Models::Done,
            "END" => break,
            "CONECT" => {
                let serial_of = |from: usize, to: usize| -> Result<Option<i64>, IoError> {
                    let f = col(line, from, to);
                    if f.trim().is_empty() {
                        return Ok(None);
                    }
                    hybrid36_decode(5, f).map(Some).ok_or_else(|| {
                        bad(format!(
                            "CONECT record: serial number {:?} (columns {from}-{to}) is not a number",
                            f
                        ))
                    })
                };
                let Some(a) = serial_of(7, 11)? else {
                    continue; // no atom to bond from: nothing to read
                };
                for from in [12, 17, 22, 27] {
                    if let Some(b) = serial_of(from, from + 4)? {
                        conect.push((a, b));
                    }
                }
            }
            _ => {
                // ATOM or HETATM.
                if models == Models::Done {
                    continue;
                }
                let hetero = kind == "HETATM";
                if line.len() < 54 {
                    return Err(bad(format!(
                        "{kind} record is only {} characters long; the coordinates need columns 31-54",
                        line.len()
                    )));
                }
                let sfield = if atom_wide {
                    col(line, 5, 11)
                } else {
                    col(line, 7, 11)
                };
                let serial = if sfield.trim().is_empty() || sfield.trim().bytes().all(|c| c == b'*')
                {
                    // Blank, or "*****" as some programs write past 99,999: number on.
                    prev_serial.saturating_add(1)
                } else if atom_wide {
                    sfield.trim().parse::<i64>().ok().ok_or_else(|| {
                        bad(format!(
                            "{kind} record: serial number {sfield:?} is not a number"
                        ))
                    })?
                } else {
                    hybrid36_decode(5, sfield).ok_or_else(|| {
                        bad(format!(
                            "{kind} record: serial number {sfield:?} (columns 7-11) is neither decimal nor hybrid-36"
                        ))
                    })?
                };
                prev_serial = serial;
                let name4 = col(line, 13, 16);
                let alt_loc = line[16];
                let residue = col(line, 18, 21).trim();
                let chain = col(line, 22, 22).trim();
                let seq_field = col(line, 23, 26);
                let residue_seq = if seq_field.trim().is_empty() {
                    0
                } else {
                    hybrid36_decode(4, seq_field).ok_or_else(|| {
                        bad(format!(
                            "{kind} record: residue number {seq_field:?} (columns 23-26) is neither decimal nor hybrid-36"
                        ))
                    })?
                };
                let insertion = col(line, 27, 27);
                if alt_loc != b' ' && !alt.keep(chain, residue_seq, insertion, col(line, 17, 17)) {
                    continue;
                }
                let coord = |from: usize, axis: &str| -> Result<f32, IoError> {
                    let f = col(line, from, from + 7);
                    let t = f.trim();
                    if t.is_empty() {
                        return Err(bad(format!(
                            "{kind} record: {axis} coordinate (columns {from}-{}) is missing",
                            from + 7
                        )));
                    }
                    let v = t.parse::<f32>().map_err(|_| {
                        bad(format!(
                            "{kind} record: {axis} coordinate {:?} is not a number",
                            show(t.as_bytes())
                        ))
                    })?;
                    if !v.is_finite() {
                        return Err(bad(format!(
                            "{kind} record: {axis} coordinate {t:?} is not finite"
                        )));
                    }
                    Ok(v)
                };
                let position = Vec3::new(coord(31, "x")?, coord(39, "y")?, coord(47, "z")?);
                let optional = |from: usize, to: usize, what: &str, default: f32| {
                    let t = col(line, from, to).trim();
                    if t.is_empty() {
                        return Ok(default);
                    }
                    match t.parse::<f32>() {
                        Ok(v) if v.is_finite() => Ok(v),
                        _ => Err(bad(format!(
                            "{kind} record: {what} {:?} (columns {from}-{to}) is not a finite number",
                            show(t.as_bytes())
                        ))),
                    }
                };
                let occupancy = optional(55, 60, "occupancy", 1.0)?;
                let b_factor = optional(61, 66, "temperature factor", 0.0)?;
                let element = match Element::from_symbol(col(line, 77, 78)) {
                    Element::Unknown => element_from_atom_name(name4, residue, hetero),
                    e => e,
                };
                if atoms.len() >= max_atoms {
                    return Err(bad(format!(
                        "more than {max_atoms} atoms; refusing to read more"
                    )));
                }
                atoms.push(Atom {
                    serial,
                    name: name4.trim().to_string(),
                    residue: residue.to_string(),
                    chain: chain.to_string(),
                    residue_seq,
                    element,
                    position,
                    hetero,
                    occupancy,
                    b_factor,
                });
            }
        }
    }
    if atoms.is_empty() {
        return Err(IoError::malformed(
            path,
            "no ATOM or HETATM records: not a PDB coordinate file, or an empty one",
        ));
    }
    let name = if id_code.is_empty() {
        super::stem(path)
    } else {
        id_code
    };
    let mut molecule = Molecule {
        name,
        atoms,
        bonds: Vec::new(),
    };
    molecule.bonds = pdb_bonds(&molecule.atoms, &conect);
    Ok(molecule)
}

/// CONECT bonds united with inferred bonds for every pair of atoms that CONECT does not
/// both cover (see [`super::read_molecule`]).
fn pdb_bonds(atoms: &[Atom], conect: &[(i64, i64)]) -> Vec<[u32; 2]> {
    if conect.is_empty() {
        return bonds::infer(atoms, super::DEFAULT_BOND_TOLERANCE, |_, _| false);
    }
    let mut by_serial: HashMap<i64, u32> = HashMap::with_capacity(atoms.len());
    for (i, a) in atoms.iter().enumerate() {
        by_serial.entry(a.serial).or_insert(i as u32);
    }
    let mut covered = vec![false; atoms.len()];
    let mut out: Vec<[u32; 2]> = Vec::with_capacity(conect.len());
    for &(a, b) in conect {
        let (Some(&i), Some(&j)) = (by_serial.get(&a), by_serial.get(&b)) else {
            continue; // a serial not present (another model, a dropped altLoc, a typo)
        };
        if i == j {
            continue;
        }
        covered[i as usize] = true;
        covered[j as usize] = true;
        out.push([i.min(j), i.max(j)]);
    }
    out.extend(bonds::infer(
        atoms,
        super::DEFAULT_BOND_TOLERANCE,
        |i, j| covered[i as usize] && covered[j as usize],
    ));
    out.sort_unstable();
    out.dedup();
    out
}
