//! # isokit-molecule: molecules as isokit geometry
//!
//! Molecular structures for isokit's pipeline: atoms and bonds read from PDB and mmCIF
//! files, the per-element data geometry needs (covalent and van der Waals radii, CPK
//! colours), bond inference from distances, and molecules turned into quadric scenes for
//! `isokit-render`'s splatter (002 Sec. 7.3), with a camera that frames them.
//!
//! It is *not* a chemistry toolkit: only what geometry needs is read — no secondary
//! structure, no symmetry or unit cell, no biological assemblies, no anisotropic
//! B-factors, no charges, no bond orders — and nothing is written. Coordinates are kept
//! exactly as the file gives them (f32, Å). Nor does it render: a scene from
//! [`molecule_scene`] is an ordinary [`SplatScene`](isokit_render::splat::SplatScene) for
//! `isokit_render::splat` (CPU) or `isokit_render::gpu` (GPU).
//!
//! ## Choosing
//! - [`read_molecule`] reads a file, choosing the format by extension
//!   ([`MoleculeFormat::from_path`]: PDB `.pdb`/`.ent`, mmCIF `.cif`/`.mmcif`, each also
//!   gzip-compressed); [`read_molecule_bytes`] reads the same from memory. Errors are
//!   isokit-io's [`IoError`], naming the file, the line and the problem.
//! - A [`Molecule`] is its [`Atom`]s (element, position in Å, names and numbering as the
//!   file gives them) and its bonds as pairs of atom indices: from the file's `CONECT`
//!   records where a PDB file has them, otherwise inferred from distances
//!   ([`Molecule::infer_bonds`] with [`DEFAULT_BOND_TOLERANCE`]). Build one in code from
//!   [`Atom::new`].
//! - [`Element`] holds the radii and colours (Cordero covalent radii, Bondi / Mantina /
//!   Alvarez van der Waals radii, Jmol's CPK colours).
//! - [`molecule_scene`] turns a molecule into quadrics in a [`MoleculeStyle`] with the
//!   sizes of [`MoleculeOptions`]; [`framing_camera`] frames the result:
//!
//! | style | atoms | bonds |
//! | --- | --- | --- |
//! | [`MoleculeStyle::Balls`] | spheres of `ball_scale` × van der Waals radius | two cylinders of `bond_radius` per bond, each half in its atom's colour |
//! | [`MoleculeStyle::Spacefill`] | spheres of the van der Waals radius | none |
//!
//! ```no_run
//! use std::path::Path;
//! use isokit_molecule::{MoleculeOptions, framing_camera, molecule_scene, read_molecule};
//! use isokit_render::splat::{SplatOptions, splat};
//!
//! let m = read_molecule(Path::new("data/molecules/1a8o.pdb.gz"))?;
//! let (lo, hi) = m.bounds().expect("a molecule has atoms");
//! println!("{}: {} atoms, {} bonds, {lo} .. {hi}", m.name, m.atoms.len(), m.bonds.len());
//! let scene = molecule_scene(&m, &MoleculeOptions::default())?;
//! let camera = framing_camera(&scene, 640, 480)?;
//! let frame = splat(&scene, &camera, &SplatOptions::default())?;
//! println!("{} pixels show an atom or a bond", frame.gbuffer.hit_count());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![warn(missing_docs)]

mod bonds;
mod cif;
mod element;
mod pdb;
mod scene;
#[cfg(test)]
mod tests;

use std::collections::HashMap;
use std::path::Path;

use glam::Vec3;

use isokit_io::IoError;
use isokit_io::reader::{gunzip, read_file};

pub use bonds::{
    MAX_HH_BOND_DISTANCE, MAX_INFERRED_BONDS_PER_ATOM, MAX_TOLERANCE, MIN_BOND_DISTANCE,
};
pub use element::{Element, UNKNOWN_COVALENT_RADIUS, UNKNOWN_VDW_RADIUS};
pub use pdb::{element_from_atom_name, hybrid36_decode};
pub use scene::{MAX_COORDINATE, MoleculeOptions, MoleculeStyle, framing_camera, molecule_scene};

/// The readers refuse structures with more atoms than this (50 million), before the atom
/// list grows past it.
pub const MAX_ATOMS: usize = 50_000_000;

/// The readers refuse gzip-compressed input that inflates to more than this many bytes
/// (8 GiB), which is more than [`MAX_ATOMS`] atoms need in either format.
pub const MAX_TEXT_BYTES: u64 = 8 << 30;

/// The tolerance (Å) added to the sum of covalent radii when bonds are inferred, as in
/// Jmol and Open Babel: 0.45 Å.
pub const DEFAULT_BOND_TOLERANCE: f32 = 0.45;

/// One atom as a structure file gives it.
#[derive(Clone, Debug, PartialEq)]
pub struct Atom {
    /// Serial number (PDB columns 7–11, decoded from hybrid-36 when needed; mmCIF
    /// `_atom_site.id`). Not necessarily unique or contiguous.
    pub serial: i64,
    /// Atom name, stripped of padding (`"CA"`, `"HG11"`, `"O5'"`).
    pub name: String,
    /// Residue (component) name (`"ALA"`, `"HOH"`, `"ZN"`).
    pub residue: String,
    /// Chain identifier (PDB column 22; mmCIF `auth_asym_id`); may be empty.
    pub chain: String,
    /// Residue sequence number (PDB columns 23–26, hybrid-36 when needed; mmCIF
    /// `auth_seq_id`); 0 when absent.
    pub residue_seq: i64,
    /// The element (see [`read_molecule`] for how it is found).
    pub element: Element,
    /// Position in Å.
    pub position: Vec3,
    /// True for `HETATM` records (ligands, ions, water, modified residues).
    pub hetero: bool,
    /// Occupancy in 0..=1 (1 when the file gives none).
    pub occupancy: f32,
    /// Isotropic temperature factor (B) in Å² (0 when the file gives none).
    pub b_factor: f32,
}

impl Atom {
    /// An atom of `element` at `position` with empty names, serial and residue number 0,
    /// occupancy 1, B 0, not hetero: for building molecules in code.
    pub fn new(element: Element, position: Vec3) -> Atom {
        Atom {
            serial: 0,
            name: String::new(),
            residue: String::new(),
            chain: String::new(),
            residue_seq: 0,
            element,
            position,
            hetero: false,
            occupancy: 1.0,
            b_factor: 0.0,
        }
    }
}

/// Atoms and the bonds between them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Molecule {
    /// A name for messages and titles: the PDB ID from a PDB `HEADER` record or the
    /// mmCIF data block name (`data_1ABC`), else the file name without its extensions.
    pub name: String,
    /// The atoms, in file order.
    pub atoms: Vec<Atom>,
    /// Bonds as pairs of indices into [`Molecule::atoms`], each with `i < j`, sorted, no
    /// duplicates.
    pub bonds: Vec<[u32; 2]>,
}

impl Molecule {
    /// The smallest and largest coordinates over all atoms with finite positions (the
    /// readers only produce those); `None` when there is none.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let mut it = self
            .atoms
            .iter()
            .map(|a| a.position)
            .filter(|p| p.is_finite());
        let first = it.next()?;
        Some(it.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p))))
    }

    /// Number of atoms.
    pub fn len(&self) -> usize {
        self.atoms.len()
    }

    /// True when there are no atoms.
    pub fn is_empty(&self) -> bool {
        self.atoms.is_empty()
    }

    /// Replaces [`Molecule::bonds`] with bonds inferred from distances (see
    /// [`Molecule::inferred_bonds`] for the rule); `tolerance` is in Å,
    /// [`DEFAULT_BOND_TOLERANCE`] (0.45) being the usual choice.
    pub fn infer_bonds(&mut self, tolerance: f32) {
        self.bonds = self.inferred_bonds(tolerance);
    }

    /// Bonds inferred from distances, sorted, `i < j`, without changing the molecule.
    ///
    /// Atoms `i` and `j` are bonded when
    /// `MIN_BOND_DISTANCE (0.4 Å) < d < covalent_radius(i) + covalent_radius(j) + tolerance`
    /// ([`Element::covalent_radius`]), except that two hydrogens are bonded only when also
    /// `d < MAX_HH_BOND_DISTANCE` (0.8 Å). `tolerance` is clamped to
    /// `-MAX_TOLERANCE..=MAX_TOLERANCE` (±1 Å; NaN counts as 0). Atoms with non-finite
    /// positions get no bonds, and no atom gets more than
    /// [`MAX_INFERRED_BONDS_PER_ATOM`] (16); pairs past that are dropped in a fixed
    /// (spatial) order — a guard that only pathological input reaches.
    ///
    /// The readers keep one alternate location per residue, so every bond they infer is
    /// within one alternate-location choice.
    ///
    /// Cost: atoms are binned in a uniform hash grid whose cell is the longest possible
    /// bond, so only neighbouring cells are compared: O(n) for molecular densities (plus
    /// an O(n log n) sort of the cells), not O(n²).
    pub fn inferred_bonds(&self, tolerance: f32) -> Vec<[u32; 2]> {
        bonds::infer(&self.atoms, tolerance, |_, _| false)
    }

    /// The chain identifiers of the atoms, sorted, each once (an empty identifier
    /// included when some atom has none).
    pub fn chains(&self) -> Vec<&str> {
        let mut c: Vec<&str> = self.atoms.iter().map(|a| a.chain.as_str()).collect();
        c.sort_unstable();
        c.dedup();
        c
    }

    /// The molecule with only the atoms `keep` accepts and the bonds between them (indices
    /// renumbered, still sorted).
    pub fn filtered(&self, keep: impl Fn(&Atom) -> bool) -> Molecule {
        let mut index = vec![u32::MAX; self.atoms.len()];
        let mut atoms = Vec::new();
        for (i, a) in self.atoms.iter().enumerate() {
            if keep(a) {
                index[i] = atoms.len() as u32;
                atoms.push(a.clone());
            }
        }
        let bonds = self
            .bonds
            .iter()
            .filter_map(|&[i, j]| {
                let (a, b) = (index[i as usize], index[j as usize]);
                (a != u32::MAX && b != u32::MAX).then_some([a, b])
            })
            .collect();
        Molecule {
            name: self.name.clone(),
            atoms,
            bonds,
        }
    }

    /// [`Molecule::filtered`] by the usual selections: without water ([`Atom::is_water`])
    /// when `no_water`, and only the chains named in `chains` when it is not empty. A chain
    /// that no atom has is an error that lists the chains there are.
    pub fn select(&self, no_water: bool, chains: &[String]) -> Result<Molecule, String> {
        let present = self.chains();
        if let Some(c) = chains.iter().find(|c| !present.contains(&c.as_str())) {
            let names: Vec<String> = present.iter().map(|c| format!("{c:?}")).collect();
            return Err(format!(
                "{}: no chain {c:?} (the chains are {})",
                self.name,
                names.join(", ")
            ));
        }
        Ok(self.filtered(|a| {
            !(no_water && a.is_water()) && (chains.is_empty() || chains.contains(&a.chain))
        }))
    }
}

/// Residue names of water in PDB and mmCIF files (and those of common simulation tools).
pub const WATER_RESIDUES: [&str; 8] = ["HOH", "WAT", "H2O", "DOD", "TIP", "TIP3", "SOL", "D2O"];

impl Atom {
    /// True for an atom of a water residue ([`WATER_RESIDUES`], case-insensitive).
    pub fn is_water(&self) -> bool {
        WATER_RESIDUES
            .iter()
            .any(|w| self.residue.eq_ignore_ascii_case(w))
    }
}

/// The molecule file formats, chosen by extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MoleculeFormat {
    /// Protein Data Bank format (`.pdb`, `.ent`, `.pdb1`…), fixed columns.
    Pdb,
    /// PDBx/mmCIF (`.cif`, `.mmcif`).
    Mmcif,
}

impl MoleculeFormat {
    /// The extensions [`MoleculeFormat::from_path`] accepts, for messages.
    pub const EXTENSIONS: &'static str = ".pdb, .ent, .cif or .mmcif (each optionally .gz)";

    /// The format named by a path's extension (case-insensitive), looking through a final
    /// `.gz`: `x.pdb`, `x.ent`, `x.pdb1` (biological assemblies), `x.cif`, `x.mmcif`, and
    /// the same followed by `.gz`.
    pub fn from_path(path: &Path) -> Result<Self, IoError> {
        let name = path
            .file_name()
            .and_then(|n| n.to_str())
            .map(|n| n.to_ascii_lowercase())
            .unwrap_or_default();
        let name = name.strip_suffix(".gz").unwrap_or(&name);
        let ext = Path::new(name).extension().and_then(|e| e.to_str());
        match ext {
            Some("pdb" | "ent") => Ok(MoleculeFormat::Pdb),
            Some(e) if e.starts_with("pdb") && e[3..].bytes().all(|c| c.is_ascii_digit()) => {
                Ok(MoleculeFormat::Pdb)
            }
            Some("cif" | "mmcif") => Ok(MoleculeFormat::Mmcif),
            _ => Err(IoError::UnknownFormat {
                path: path.to_path_buf(),
                expected: Self::EXTENSIONS,
            }),
        }
    }
}

/// Reads a molecule by extension ([`MoleculeFormat::from_path`]): PDB (`.pdb`, `.ent`) or
/// mmCIF (`.cif`, `.mmcif`), each also gzip-compressed (`.gz`; recognised by its content,
/// so a `.gz` name is not required).
///
/// # PDB
/// - `ATOM`/`HETATM` by fixed columns: serial 7–11, name 13–16, altLoc 17, residue name
///   18–20 (21 too, for 4-letter names), chain 22, residue number 23–26, insertion code
///   27, x y z 31–38/39–46/47–54, occupancy 55–60 (default 1), B 61–66 (default 0),
///   element 77–78. Lines may be shorter than 80 columns (but must reach column 54), end
///   in CRLF or a lone CR, and carry trailing blanks or tabs.
/// - Serial and residue numbers may be hybrid-36 ([`hybrid36_decode`]) beyond 99,999 and
///   9,999; a serial of `*****` or blanks continues the numbering from the previous atom;
///   an `ATOM` serial spilling into columns 5–6 (as some programs write past 99,999) is
///   read as decimal.
/// - Element: columns 77–78 when they hold a known symbol, else inferred from the atom
///   name ([`element_from_atom_name`]); [`Element::Unknown`] when neither works.
/// - Models: only the first (`MODEL` … `ENDMDL`); reading stops at `END`.
/// - Alternate locations: within each residue (chain, number, insertion code), the first
///   altLoc letter met is kept (normally `A`) together with the blank one; atoms of the
///   other letters are dropped.
/// - Bonds: if the file has `CONECT` records, their bonds (serials that name no kept atom
///   are ignored, duplicates merged) *plus* bonds inferred with
///   [`DEFAULT_BOND_TOLERANCE`] for every pair of atoms *not both* named by a kept
///   `CONECT` bond — `CONECT` usually lists only HETATM groups and disulfides, so ligands
///   get exactly their listed bonds while the protein is still bonded by distance, and a
///   cysteine SG listed only for its S–S bond keeps its bond to CB. Without `CONECT`, all
///   bonds are inferred.
/// - Other records (`HEADER` apart, whose ID names the molecule) are skipped.
///
/// # mmCIF
/// The first `_atom_site` loop (or `_atom_site.item value` pairs for a single atom) of the
/// file; CIF 1.1 tokens: `'…'` and `"…"` quoting, `;` text fields, `#` comments, `.` and
/// `?` as missing values, numbers with standard uncertainties (`1.234(5)`). Items by name:
/// `group_PDB`, `id`, `type_symbol`, `label_atom_id` (else `auth_atom_id`),
/// `label_comp_id` (else `auth_comp_id`), `auth_asym_id` (else `label_asym_id`),
/// `auth_seq_id` (else `label_seq_id`), `Cartn_x/y/z` (required), `occupancy`,
/// `B_iso_or_equiv`, `label_alt_id` and `pdbx_PDB_ins_code` (alternate locations as for
/// PDB), `pdbx_PDB_model_num` (only rows of the first row's model are read). An element
/// missing from `type_symbol` is inferred from the atom name. `_struct_conn` and
/// `_chem_comp_bond` are ignored: bonds are always inferred ([`Molecule::infer_bonds`]
/// with [`DEFAULT_BOND_TOLERANCE`]).
///
/// # Errors
/// [`IoError::UnknownFormat`] for another extension, [`IoError::Io`] when the file cannot
/// be read, and [`IoError::Malformed`] — whose message names the file, the line and the
/// problem, e.g. `1crn.pdb: line 57: ATOM record: x coordinate "12.3a" is not a number` —
/// for: no atoms at all; missing, non-numeric or non-finite coordinates; unreadable
/// serial or residue numbers, occupancies or B-factors; binary data or non-UTF-8 text;
/// no `_atom_site` loop, no `Cartn_x/y/z` items, or a loop whose value count is not a
/// multiple of its columns; unclosed quotes or text fields; more than [`MAX_ATOMS`]
/// atoms; gzip data that is corrupt or inflates past [`MAX_TEXT_BYTES`].
pub fn read_molecule(path: &Path) -> Result<Molecule, IoError> {
    let format = MoleculeFormat::from_path(path)?;
    let bytes = read_file(path)?;
    read_molecule_from(&bytes, format, path)
}

/// Reads a molecule from bytes in memory (gzip-compressed or not); `name` is used in
/// messages and, without its extensions, as the molecule's name when the data carries
/// none. The rules are [`read_molecule`]'s.
///
/// ```
/// use isokit_molecule::{Element, MoleculeFormat, read_molecule_bytes};
///
/// let water = b"\
/// HETATM    1  O   HOH A   1       0.000   0.000   0.000  1.00  0.00           O
/// HETATM    2  H1  HOH A   1       0.757   0.586   0.000  1.00  0.00           H
/// HETATM    3  H2  HOH A   1      -0.757   0.586   0.000  1.00  0.00           H
/// END
/// ";
/// let m = read_molecule_bytes(water, "water.pdb", MoleculeFormat::Pdb)?;
/// assert_eq!(m.name, "water");
/// assert_eq!(m.atoms.len(), 3);
/// assert_eq!(m.atoms[0].element, Element::O);
/// assert_eq!(m.bonds, vec![[0, 1], [0, 2]]); // two O–H bonds, no H–H bond
///
/// let bad = b"ATOM      1  CA  ALA A   1       12.3a   0.000   0.000";
/// let err = read_molecule_bytes(bad, "bad.pdb", MoleculeFormat::Pdb).unwrap_err();
/// assert_eq!(
///     err.to_string(),
///     r#"bad.pdb: line 1: ATOM record: x coordinate "12.3a" is not a number"#
/// );
/// # Ok::<(), isokit_io::IoError>(())
/// ```
pub fn read_molecule_bytes(
    bytes: &[u8],
    name: &str,
    format: MoleculeFormat,
) -> Result<Molecule, IoError> {
    read_molecule_from(bytes, format, Path::new(name))
}

fn read_molecule_from(
    bytes: &[u8],
    format: MoleculeFormat,
    path: &Path,
) -> Result<Molecule, IoError> {
    read_with_limit(bytes, format, path, MAX_ATOMS)
}

/// [`read_molecule_bytes`] with an atom limit (tests use a small one).
pub(crate) fn read_with_limit(
    bytes: &[u8],
    format: MoleculeFormat,
    path: &Path,
    max_atoms: usize,
) -> Result<Molecule, IoError> {
    let inflated;
    let text: &[u8] = if bytes.starts_with(&[0x1f, 0x8b]) {
        let limit = usize::try_from(MAX_TEXT_BYTES).unwrap_or(usize::MAX - 1);
        let (out, _) = gunzip(bytes, 0, limit + 1, path)?;
        if out.len() > limit {
            return Err(IoError::malformed(
                path,
                format!("gzip data inflate to more than {MAX_TEXT_BYTES} bytes; refusing to read"),
            ));
        }
        inflated = out;
        &inflated
    } else {
        bytes
    };
    // A UTF-8 byte-order mark would hide the first record.
    let text = text.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(text);
    match format {
        MoleculeFormat::Pdb => pdb::read_pdb(text, path, max_atoms),
        MoleculeFormat::Mmcif => cif::read_mmcif(text, path, max_atoms),
    }
}

/// `path: line N: msg`, the shape of every parse error of this crate.
pub(crate) fn line_error(path: &Path, line: usize, msg: impl std::fmt::Display) -> IoError {
    IoError::malformed(path, format!("line {line}: {msg}"))
}

/// The file name without `.gz` and its format extension (`1abc.pdb.gz` → `1abc`).
pub(crate) fn stem(path: &Path) -> String {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let name = match name.len().checked_sub(3) {
        Some(k) if name.is_char_boundary(k) && name[k..].eq_ignore_ascii_case(".gz") => {
            name[..k].to_string()
        }
        _ => name,
    };
    match name.rfind('.') {
        Some(k) if k > 0 => name[..k].to_string(),
        _ => name,
    }
}

/// Keeps one alternate location per residue: the first non-blank altLoc met in a residue
/// (chain, number, insertion code) is that residue's choice.
#[derive(Default)]
pub(crate) struct AltLocFilter {
    chosen: HashMap<(String, i64, String), String>,
}

impl AltLocFilter {
    /// Whether an atom with the (non-blank) altLoc `alt` in this residue is kept.
    pub(crate) fn keep(&mut self, chain: &str, seq: i64, insertion: &str, alt: &str) -> bool {
        let key = (chain.to_string(), seq, insertion.trim().to_string());
        self.chosen.entry(key).or_insert_with(|| alt.to_string()) == alt
    }
}
