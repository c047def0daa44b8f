//! The mmCIF reader: a CIF 1.1 tokenizer and the `_atom_site` category.

use std::path::Path;

use glam::Vec3;

use super::pdb::element_from_atom_name;
use super::{AltLocFilter, Atom, Element, Molecule, bonds, line_error};
use isokit_io::IoError;
use isokit_io::reader::show;

/// One CIF token: its text (without quotes or `;` delimiters), whether it was quoted or a
/// text field (so that `'?'` is a value while `?` is "unknown"), and its line.
#[derive(Clone, Copy, Debug)]
struct Tok<'a> {
    text: &'a str,
    quoted: bool,
    line: usize,
}

impl<'a> Tok<'a> {
    /// The value, or `None` for the CIF "inapplicable" `.` and "unknown" `?`.
    fn value(self) -> Option<&'a str> {
        if !self.quoted && (self.text == "." || self.text == "?") {
            None
        } else {
            Some(self.text)
        }
    }

    /// True for a tag (`_category.item`) or a reserved word: what ends a loop's values.
    fn ends_values(self) -> bool {
        !self.quoted && (self.text.starts_with('_') || is_reserved(self.text))
    }
}

fn starts_with_ci(s: &str, prefix: &str) -> bool {
    s.len() >= prefix.len() && s.as_bytes()[..prefix.len()].eq_ignore_ascii_case(prefix.as_bytes())
}

fn is_reserved(t: &str) -> bool {
    starts_with_ci(t, "data_")
        || starts_with_ci(t, "save_")
        || t.eq_ignore_ascii_case("loop_")
        || t.eq_ignore_ascii_case("global_")
        || t.eq_ignore_ascii_case("stop_")
}

/// CIF 1.1 tokenizer over checked UTF-8 text: whitespace-separated tokens, `#` comments,
/// `'…'` and `"…"` quoted values (closed by the quote followed by whitespace, so `O5'` and
/// `'N1' '` work), and `;` text fields (from a `;` at the start of a line to the next line
/// starting with `;`).
struct Lexer<'a> {
    s: &'a str,
    pos: usize,
    line: usize,
    path: &'a Path,
    back: Option<Tok<'a>>,
}

impl<'a> Lexer<'a> {
    fn new(s: &'a str, path: &'a Path) -> Self {
        Self {
            s,
            pos: 0,
            line: 1,
            path,
            back: None,
        }
    }

    fn push_back(&mut self, t: Tok<'a>) {
        self.back = Some(t);
    }

    fn slice(&self, a: usize, b: usize) -> &'a str {
        // Boundaries are always at ASCII delimiters, hence char boundaries.
        self.s.get(a..b).unwrap_or("")
    }

    fn next(&mut self) -> Result<Option<Tok<'a>>, IoError> {
        if let Some(t) = self.back.take() {
            return Ok(Some(t));
        }
        let b = self.s.as_bytes();
        loop {
            while self.pos < b.len() && b[self.pos].is_ascii_whitespace() {
                if b[self.pos] == b'\n' {
                    self.line += 1;
                }
                self.pos += 1;
            }
            if self.pos >= b.len() {
                return Ok(None);
            }
            let start = self.pos;
            let at_line_start = start == 0 || b[start - 1] == b'\n';
            match b[start] {
                b'#' => {
                    while self.pos < b.len() && b[self.pos] != b'\n' {
                        self.pos += 1;
                    }
                }
                b';' if at_line_start => {
                    let line = self.line;
                    let mut i = start + 1;
                    let end = loop {
                        match b[i..].iter().position(|&c| c == b'\n') {
                            Some(k) if b.get(i + k + 1) == Some(&b';') => break i + k,
                            Some(k) => i += k + 1,
                            None => {
                                return Err(line_error(
                                    self.path,
                                    line,
                                    "text field starting with ';' is never closed (no later line starts with ';')",
                                ));
                            }
                        }
                    };
                    self.line += b[start..=end].iter().filter(|&&c| c == b'\n').count();
                    self.pos = end + 2;
                    let mut text = self.slice(start + 1, end);
                    text = text.strip_suffix('\r').unwrap_or(text);
                    return Ok(Some(Tok {
                        text,
                        quoted: true,
                        line,
                    }));
                }
                q @ (b'\'' | b'"') => {
                    let mut i = start + 1;
                    loop {
                        if i >= b.len() || b[i] == b'\n' {
                            return Err(line_error(
                                self.path,
                                self.line,
                                format!(
                                    "quoted value {} is not closed on its line",
                                    show(self.slice(start, i).as_bytes())
                                ),
                            ));
                        }
                        if b[i] == q && b.get(i + 1).is_none_or(|c| c.is_ascii_whitespace()) {
                            break;
                        }
                        i += 1;
                    }
                    self.pos = i + 1;
                    return Ok(Some(Tok {
                        text: self.slice(start + 1, i),
                        quoted: true,
                        line: self.line,
                    }));
                }
                _ => {
                    let mut i = start;
                    while i < b.len() && !b[i].is_ascii_whitespace() {
                        i += 1;
                    }
                    self.pos = i;
                    return Ok(Some(Tok {
                        text: self.slice(start, i),
                        quoted: false,
                        line: self.line,
                    }));
                }
            }
        }
    }
}

/// Checks that the text is UTF-8 without binary control bytes, naming the first bad line.
fn check_text<'a>(text: &'a [u8], path: &Path) -> Result<&'a str, IoError> {
    let at = |p: usize| {
        let line = text[..p].iter().filter(|&&c| c == b'\n').count() + 1;
        let column = p - text[..p]
            .iter()
            .rposition(|&c| c == b'\n')
            .map_or(0, |k| k + 1)
            + 1;
        (line, column)
    };
    if let Some(p) = text
        .iter()
        .position(|&b| (b < 0x20 && !matches!(b, b'\t' | b'\n' | b'\r' | 0x0c)) || b == 0x7f)
    {
        let (line, column) = at(p);
        return Err(line_error(
            path,
            line,
            format!(
                "binary data (byte 0x{:02x} at column {column}); this is not an mmCIF text file",
                text[p]
            ),
        ));
    }
    std::str::from_utf8(text).map_err(|e| {
        let p = e.valid_up_to();
        let (line, column) = at(p);
        line_error(
            path,
            line,
            format!(
                "not UTF-8 text (byte 0x{:02x} at column {column}); this is not an mmCIF text file",
                text[p]
            ),
        )
    })
}

/// Column indices of the `_atom_site` items this reader uses.
struct Columns {
    names: Vec<String>,
    group: Option<usize>,
    id: Option<usize>,
    type_symbol: Option<usize>,
    atom: [Option<usize>; 2],
    comp: [Option<usize>; 2],
    asym: [Option<usize>; 2],
    seq: [Option<usize>; 2],
    xyz: [usize; 3],
    occupancy: Option<usize>,
    b_factor: Option<usize>,
    alt: Option<usize>,
    ins: Option<usize>,
    model: Option<usize>,
}

impl Columns {
    /// `tags` are the items after `_atom_site.`, as written.
    fn new(tags: Vec<String>, path: &Path, line: usize) -> Result<Self, IoError> {
        let find = |n: &str| tags.iter().position(|t| t.eq_ignore_ascii_case(n));
        let mut xyz = [0; 3];
        for (k, n) in ["Cartn_x", "Cartn_y", "Cartn_z"].iter().enumerate() {
            xyz[k] = find(n).ok_or_else(|| {
                line_error(
                    path,
                    line,
                    format!("the _atom_site category has no _atom_site.{n} item (Cartesian coordinates are required)"),
                )
            })?;
        }
        Ok(Self {
            group: find("group_PDB"),
            id: find("id"),
            type_symbol: find("type_symbol"),
            atom: [find("label_atom_id"), find("auth_atom_id")],
            comp: [find("label_comp_id"), find("auth_comp_id")],
            asym: [find("auth_asym_id"), find("label_asym_id")],
            seq: [find("auth_seq_id"), find("label_seq_id")],
            xyz,
            occupancy: find("occupancy"),
            b_factor: find("B_iso_or_equiv"),
            alt: find("label_alt_id"),
            ins: find("pdbx_PDB_ins_code"),
            model: find("pdbx_PDB_model_num"),
            names: tags,
        })
    }
}

/// Turns `_atom_site` rows into atoms.
struct Rows<'p> {
    cols: Columns,
    path: &'p Path,
    max_atoms: usize,
    atoms: Vec<Atom>,
    alt: AltLocFilter,
    first_model: Option<String>,
    rows: usize,
    prev_last_line: usize,
    /// Rows of a loop (not one atom given as `_atom_site.item value` pairs).
    in_loop: bool,
}

impl Rows<'_> {
    fn push(&mut self, row: &[Tok]) -> Result<(), IoError> {
        self.rows += 1;
        let first_line = row.first().map_or(0, |t| t.line);
        let last_line = row.last().map_or(0, |t| t.line);
        let shifted =
            self.in_loop && (first_line == self.prev_last_line || first_line != last_line);
        self.prev_last_line = last_line;
        let get = |i: Option<usize>| i.and_then(|i| row.get(i)).and_then(|t| t.value());
        let either = |ii: [Option<usize>; 2]| get(ii[0]).or_else(|| get(ii[1]));
        let path = self.path;
        let names = &self.cols.names;
        let hint = if shifted {
            " (a row of the _atom_site loop may have the wrong number of values)"
        } else {
            ""
        };
        let number = |i: usize| -> Result<Option<f32>, IoError> {
            let t = row[i];
            let Some(v) = t.value() else {
                return Ok(None);
            };
            // Drop a standard uncertainty in parentheses: "12.345(3)".
            let digits = match v.find('(') {
                Some(k) if v.ends_with(')') => &v[..k],
                _ => v,
            };
            // Parsed straight to f32 (as the PDB reader does), so both formats give the
            // same bits for the same decimal text.
            match digits.parse::<f32>() {
                Ok(x) if x.is_finite() => Ok(Some(x)),
                Ok(_) => Err(line_error(
                    path,
                    t.line,
                    format!("_atom_site.{} {v:?} is not finite{hint}", names[i]),
                )),
                Err(_) => Err(line_error(
                    path,
                    t.line,
                    format!(
                        "_atom_site.{} {:?} is not a number{hint}",
                        names[i],
                        show(v.as_bytes())
                    ),
                )),
            }
        };

        if let Some(m) = self.cols.model.and_then(|i| row.get(i)).map(|t| t.text) {
            match &self.first_model {
                None => self.first_model = Some(m.to_string()),
                Some(first) if first != m => return Ok(()),
                Some(_) => {}
            }
        }
        let chain = either(self.cols.asym).unwrap_or("");
        let residue_seq = match self.cols.seq.iter().flatten().find_map(|&i| {
            let t = row[i];
            t.value().map(|v| (t, v))
        }) {
            None => 0,
            Some((t, v)) => v.parse::<i64>().map_err(|_| {
                line_error(
                    path,
                    t.line,
                    format!(
                        "_atom_site residue number {:?} is not an integer{hint}",
                        show(v.as_bytes())
                    ),
                )
            })?,
        };
        if let Some(a) = get(self.cols.alt) {
            let ins = get(self.cols.ins).unwrap_or("");
            if !self.alt.keep(chain, residue_seq, ins, a) {
                return Ok(());
            }
        }
        let mut p = [0f32; 3];
        for (k, &i) in self.cols.xyz.iter().enumerate() {
            p[k] = number(i)?.ok_or_else(|| {
                line_error(
                    path,
                    row[i].line,
                    format!(
                        "_atom_site.{} is missing ({:?}); every atom needs coordinates{hint}",
                        names[i], row[i].text
                    ),
                )
            })?;
        }
        let occupancy = match self.cols.occupancy {
            Some(i) => number(i)?.unwrap_or(1.0),
            None => 1.0,
        };
        let b_factor = match self.cols.b_factor {
            Some(i) => number(i)?.unwrap_or(0.0),
            None => 0.0,
        };
        let hetero = get(self.cols.group).is_some_and(|g| g.eq_ignore_ascii_case("HETATM"));
        let name = either(self.cols.atom).unwrap_or("");
        let residue = either(self.cols.comp).unwrap_or("");
        let element = match get(self.cols.type_symbol).map(Element::from_symbol) {
            Some(e) if e != Element::Unknown => e,
            _ => {
                // No usable type_symbol: place the name as PDB would and infer. mmCIF
                // names carry no column alignment, so in ligands (HETATM) a name starting
                // with a two-letter metal, halogen or selenium (`FE` in HEM, `SE` in MSE,
                // `CL1`) is taken as that element; elsewhere the PDB rule applies.
                let two = name.get(..2).map(str::to_ascii_uppercase);
                const TWO: [&str; 15] = [
                    "FE", "ZN", "MG", "MN", "CU", "CO", "NI", "CL", "BR", "SE", "NA", "CD", "HG",
                    "PT", "AU",
                ];
                match two {
                    Some(t) if hetero && TWO.contains(&t.as_str()) => Element::from_symbol(&t),
                    _ => {
                        let padded = if name.len() >= 4 {
                            name.to_string()
                        } else {
                            format!(" {name}")
                        };
                        element_from_atom_name(&padded, residue, hetero)
                    }
                }
            }
        };
        let serial = get(self.cols.id)
            .and_then(|v| v.parse::<i64>().ok())
            .unwrap_or(self.rows as i64);
        if self.atoms.len() >= self.max_atoms {
            return Err(line_error(
                path,
                row[0].line,
                format!("more than {} atoms; refusing to read more", self.max_atoms),
            ));
        }
        self.atoms.push(Atom {
            serial,
            name: name.to_string(),
            residue: residue.to_string(),
            chain: chain.to_string(),
            residue_seq,
            element,
            position: Vec3::from_array(p),
            hetero,
            occupancy,
            b_factor,
        });
        Ok(())
    }
}

/// Reads mmCIF text. See [`super::read_molecule`] for the rules.
pub(crate) fn read_mmcif(text: &[u8], path: &Path, max_atoms: usize) -> Result<Molecule, IoError> {
    let s = check_text(text, path)?;
    let mut lx = Lexer::new(s, path);
    let mut block = String::new();
    // `_atom_site.item value` pairs outside a loop (a structure with one atom).
    let mut singles: Vec<(String, Tok)> = Vec::new();
    let mut singles_line = 0;
    let mut atoms: Option<(Vec<Atom>, usize)> = None;

    while let Some(t) = lx.next()? {
        if t.quoted {
            continue;
        }
        if starts_with_ci(t.text, "data_") {
            if !singles.is_empty() {
                break;
            }
            block = t.text[5..].to_string();
            continue;
        }
        if t.text.eq_ignore_ascii_case("loop_") {
            let loop_line = t.line;
            let mut tags: Vec<&str> = Vec::new();
            while let Some(tag) = lx.next()? {
                if tag.quoted || !tag.text.starts_with('_') {
                    lx.push_back(tag);
                    break;
                }
                tags.push(tag.text);
            }
            if tags
                .first()
                .is_some_and(|t| starts_with_ci(t, "_atom_site."))
            {
                let items = tags
                    .iter()
                    .map(|t| t.split_once('.').map_or("", |(_, item)| item).to_string())
                    .collect();
                let cols = Columns::new(items, path, loop_line)?;
                let ncols = tags.len();
                let mut rows = Rows {
                    cols,
                    path,
                    max_atoms,
                    atoms: Vec::new(),
                    alt: AltLocFilter::default(),
                    first_model: None,
                    rows: 0,
                    prev_last_line: 0,
                    in_loop: true,
                };
                let mut row: Vec<Tok> = Vec::with_capacity(ncols);
                let mut total: u64 = 0;
                while let Some(v) = lx.next()? {
                    if v.ends_values() {
                        break;
                    }
                    total += 1;
                    row.push(v);
                    if row.len() == ncols {
                        rows.push(&row)?;
                        row.clear();
                    }
                }
                if let Some(last) = row.last() {
                    return Err(line_error(
                        path,
                        last.line,
                        format!(
                            "the _atom_site loop (from line {loop_line}) has {total} values, not a multiple of its {ncols} columns: its last row has only {} values",
                            row.len()
                        ),
                    ));
                }
                atoms = Some((rows.atoms, loop_line));
                break;
            }
            // Another category's loop: skip its values.
            while let Some(v) = lx.next()? {
                if v.ends_values() {
                    lx.push_back(v);
                    break;
                }
            }
            continue;
        }
        if t.text.starts_with('_') {
            let Some(v) = lx.next()? else { break };
            if v.ends_values() {
                lx.push_back(v); // a tag without a value: tolerated
                continue;
            }
            if starts_with_ci(t.text, "_atom_site.") {
                if singles.is_empty() {
                    singles_line = t.line;
                }
                singles.push((t.text["_atom_site.".len()..].to_string(), v));
            }
        }
    }

    let (atoms, first_line) = match atoms {
        Some(a) => a,
        None if !singles.is_empty() => {
            let (items, row): (Vec<String>, Vec<Tok>) = singles.into_iter().unzip();
            let cols = Columns::new(items, path, singles_line)?;
            let mut rows = Rows {
                cols,
                path,
                max_atoms,
                atoms: Vec::new(),
                alt: AltLocFilter::default(),
                first_model: None,
                rows: 0,
                prev_last_line: 0,
                in_loop: false,
            };
            rows.push(&row)?;
            (rows.atoms, singles_line)
        }
        None => {
            return Err(IoError::malformed(
                path,
                "no _atom_site loop: not an mmCIF coordinate file (or one without atoms)",
            ));
        }
    };
    if atoms.is_empty() {
        return Err(line_error(
            path,
            first_line,
            "the _atom_site loop has no rows",
        ));
    }
    let name = if block.is_empty() {
        super::stem(path)
    } else {
        block
    };
    let bonds = bonds::infer(&atoms, super::DEFAULT_BOND_TOLERANCE, |_, _| false);
    Ok(Molecule { name, atoms, bonds })
}
