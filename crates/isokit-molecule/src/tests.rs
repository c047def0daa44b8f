//! Tests of the molecule readers, the element table and bond inference.

use std::io::Read;
use std::path::{Path, PathBuf};

use glam::Vec3;
use isokit_field::rng::SplitMix64;

use super::*;

/// A PDB ATOM/HETATM line: `head` is columns 1–26 as a file has them (record name, serial,
/// atom name, altLoc, residue name, chain, residue number), then come the coordinates,
/// occupancy 1, B 0 and the element in columns 77–78.
fn line(head: &str, p: [f32; 3], element: &str) -> String {
    assert_eq!(head.len(), 26, "{head:?}");
    let s = format!(
        "{head}    {:>8.3}{:>8.3}{:>8.3}{:>6.2}{:>6.2}          {element:>2}",
        p[0], p[1], p[2], 1.0, 0.0
    );
    assert_eq!(s.len(), 78, "{s}");
    s
}

fn pdb(text: &str) -> Result<Molecule, IoError> {
    read_molecule_bytes(text.as_bytes(), "t.pdb", MoleculeFormat::Pdb)
}

fn cif(text: &str) -> Result<Molecule, IoError> {
    read_molecule_bytes(text.as_bytes(), "t.cif", MoleculeFormat::Mmcif)
}

fn err_pdb(text: &[u8]) -> String {
    read_molecule_bytes(text, "bad.pdb", MoleculeFormat::Pdb)
        .expect_err("malformed input must fail")
        .to_string()
}

fn err_cif(text: &[u8]) -> String {
    read_molecule_bytes(text, "bad.cif", MoleculeFormat::Mmcif)
        .expect_err("malformed input must fail")
        .to_string()
}

// ---------------------------------------------------------------------------------------
// Elements

#[test]
fn molecule_elements_have_positive_radii_and_round_trip() {
    assert!(Element::all().len() >= 91);
    for &e in Element::all().iter().chain([Element::Unknown].iter()) {
        assert!(
            e.covalent_radius() > 0.0 && e.covalent_radius() < 3.0,
            "{e:?}"
        );
        assert!(e.vdw_radius() > 1.0 && e.vdw_radius() < 3.6, "{e:?}");
        for c in e.cpk_color() {
            assert!((0.0..=1.0).contains(&c), "{e:?}");
        }
        assert_eq!(Element::from_atomic_number(e.atomic_number()), e);
        if e != Element::Unknown {
            assert_eq!(Element::from_symbol(e.symbol()), e);
            assert_eq!(Element::from_symbol(&e.symbol().to_ascii_uppercase()), e);
            assert_eq!(Element::from_symbol(&e.symbol().to_ascii_lowercase()), e);
            assert_eq!(e.to_string(), e.symbol());
        }
    }
    // Atomic numbers are in order, 1..=92 without promethium.
    let z: Vec<u8> = Element::all().iter().map(|e| e.atomic_number()).collect();
    let want: Vec<u8> = (1..=92).filter(|&z| z != 61).collect();
    assert_eq!(z, want);
}

#[test]
fn molecule_element_values_spot_checks() {
    // Cordero 2008.
    assert_eq!(Element::H.covalent_radius(), 0.31);
    assert_eq!(Element::C.covalent_radius(), 0.76);
    assert_eq!(Element::N.covalent_radius(), 0.71);
    assert_eq!(Element::O.covalent_radius(), 0.66);
    assert_eq!(Element::S.covalent_radius(), 1.05);
    assert_eq!(Element::Fe.covalent_radius(), 1.32);
    assert_eq!(Element::Zn.covalent_radius(), 1.22);
    assert_eq!(Element::Se.covalent_radius(), 1.20);
    // Bondi 1964, Mantina 2009, Alvarez 2013.
    assert_eq!(Element::H.vdw_radius(), 1.20);
    assert_eq!(Element::C.vdw_radius(), 1.70);
    assert_eq!(Element::N.vdw_radius(), 1.55);
    assert_eq!(Element::O.vdw_radius(), 1.52);
    assert_eq!(Element::S.vdw_radius(), 1.80);
    assert_eq!(Element::Ca.vdw_radius(), 2.31);
    assert_eq!(Element::Fe.vdw_radius(), 2.44);
    // Jmol.
    assert_eq!(Element::C.cpk_color_srgb8(), [0x90, 0x90, 0x90]);
    assert_eq!(Element::O.cpk_color_srgb8(), [0xFF, 0x0D, 0x0D]);
    assert_eq!(Element::N.cpk_color_srgb8(), [0x30, 0x50, 0xF8]);
    assert_eq!(Element::Fe.cpk_color_srgb8(), [0xE0, 0x66, 0x33]);
    assert_eq!(Element::H.cpk_color(), [1.0, 1.0, 1.0]);
    let c = Element::C.cpk_color();
    assert!((c[0] - 0.2789).abs() < 1e-3, "{c:?}");
    // Unknown.
    assert_eq!(Element::Unknown.covalent_radius(), 1.5);
    assert_eq!(Element::Unknown.vdw_radius(), 1.8);
    assert_eq!(Element::Unknown.cpk_color_srgb8(), [0xFF, 0x14, 0x93]);
    assert_eq!(Element::Unknown.symbol(), "X");
    // Symbols.
    for (s, e) in [
        ("FE", Element::Fe),
        ("Fe", Element::Fe),
        ("fe", Element::Fe),
        (" Fe ", Element::Fe),
        ("D", Element::H),
        ("T", Element::H),
        ("", Element::Unknown),
        ("X", Element::Unknown),
        ("Pm", Element::Unknown),
        ("C1", Element::Unknown),
        ("CAL", Element::Unknown),
        ("é", Element::Unknown),
    ] {
        assert_eq!(Element::from_symbol(s), e, "{s:?}");
    }
}

#[test]
fn molecule_element_from_atom_names() {
    let cases: &[(&str, &str, bool, Element)] = &[
        (" CA ", "ALA", false, Element::C),
        ("CA  ", "CA", true, Element::Ca),
        ("CA  ", "XYZ", true, Element::Ca),
        (" N  ", "ALA", false, Element::N),
        (" OXT", "ALA", false, Element::O),
        ("1HB ", "ALA", false, Element::H),
        ("2HG1", "VAL", false, Element::H),
        ("HG11", "VAL", false, Element::H),
        ("HE21", "GLN", false, Element::H),
        ("HD1 ", "HIS", false, Element::H),
        (" HG ", "SER", false, Element::H),
        ("HG  ", "HG", true, Element::Hg),
        ("HG  ", "MMC", true, Element::Hg),
        ("FE  ", "HEM", true, Element::Fe),
        ("FE1 ", "SF4", true, Element::Fe),
        ("CL1 ", "LIG", true, Element::Cl),
        ("BR  ", "BR", true, Element::Br),
        ("SE  ", "MSE", true, Element::Se),
        ("CD1 ", "LEU", false, Element::C),
        ("NE2 ", "GLN", false, Element::N),
        ("CE1 ", "PHE", false, Element::C),
        ("ND1 ", "HIS", false, Element::N),
        ("CD  ", "CD", true, Element::Cd),
        ("C10 ", "LIG", true, Element::C),
        ("O   ", "HOH", true, Element::O),
        (" FE ", "FE", true, Element::Fe),
        ("  K ", "K", true, Element::K),
        (" ZN ", "ZN", true, Element::Zn),
        ("    ", "UNK", false, Element::Unknown),
        (" X1 ", "UNK", false, Element::Unknown),
        ("*1  ", "UNK", false, Element::Unknown),
    ];
    for &(name, res, het, want) in cases {
        assert_eq!(
            pdb::element_from_atom_name(name, res, het),
            want,
            "{name:?} in {res}"
        );
    }
}

// ---------------------------------------------------------------------------------------
// Hybrid-36

/// Reference encoder (the inverse of the decoder, written independently from the spec).
fn hy36_encode(width: u32, v: i64) -> String {
    let p10 = 10i64.pow(width);
    let p36 = 36i64.pow(width - 1);
    if v < p10 {
        return format!("{v:>w$}", w = width as usize);
    }
    let (mut n, digits) = if v < p10 + 26 * p36 {
        (v - p10 + 10 * p36, b"0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZ")
    } else {
        (v - p10 - 16 * p36, b"0123456789abcdefghijklmnopqrstuvwxyz")
    };
    let mut out = vec![b'0'; width as usize];
    for k in (0..width as usize).rev() {
        out[k] = digits[(n % 36) as usize];
        n /= 36;
    }
    String::from_utf8(out).unwrap()
}

#[test]
fn molecule_hybrid36_decoding() {
    assert_eq!(hybrid36_decode(5, "A0000"), Some(100_000));
    assert_eq!(hybrid36_decode(5, "A0001"), Some(100_001));
    assert_eq!(hybrid36_decode(5, "ZZZZZ"), Some(43_770_015));
    assert_eq!(hybrid36_decode(5, "a0000"), Some(43_770_016));
    assert_eq!(hybrid36_decode(5, "zzzzz"), Some(87_440_031));
    assert_eq!(hybrid36_decode(5, "99999"), Some(99_999));
    assert_eq!(hybrid36_decode(5, "    1"), Some(1));
    assert_eq!(hybrid36_decode(5, "-9999"), Some(-9999));
    assert_eq!(hybrid36_decode(4, "A000"), Some(10_000));
    assert_eq!(hybrid36_decode(4, "a000"), Some(10_000 + 26 * 36i64.pow(3)));
    assert_eq!(hybrid36_decode(4, "-999"), Some(-999));
    for bad in [
        "", "     ", "A00", "Aa000", "A00!0", "1 2", "!0000", "123456", "--1", "  é", " -é", "Aé00",
    ] {
        assert_eq!(hybrid36_decode(5, bad), None, "{bad:?}");
    }
    for width in [4u32, 5] {
        let max = 10i64.pow(width) + 52 * 36i64.pow(width - 1) - 1;
        let mut rng = SplitMix64::new(36);
        let mut values: Vec<i64> = vec![0, 1, 9999, 10i64.pow(width) - 1, 10i64.pow(width), max];
        values.extend((0..2000).map(|_| (rng.next_u64() % (max as u64 + 1)) as i64));
        for v in values {
            let s = hy36_encode(width, v);
            assert_eq!(hybrid36_decode(width as usize, &s), Some(v), "{s:?}");
        }
    }
}

// ---------------------------------------------------------------------------------------
// PDB

#[test]
fn molecule_pdb_columns() {
    let text = "HEADER    TEST PROTEIN                            01-JAN-00   9XYZ              \n\
                ATOM     17  CB BSER Q -12A     -1.250  22.500-103.125  0.35 87.65      SEG  C  \n\
                HETATM   18 ZN    ZN Q 501      10.000  10.000  10.000  1.00  5.00          ZN2+\n";
    let m = pdb(text).unwrap();
    assert_eq!(m.name, "9XYZ");
    assert_eq!(m.atoms.len(), 2);
    let a = &m.atoms[0];
    assert_eq!(a.serial, 17);
    assert_eq!(a.name, "CB");
    assert_eq!(a.residue, "SER");
    assert_eq!(a.chain, "Q");
    assert_eq!(a.residue_seq, -12);
    assert_eq!(a.element, Element::C);
    assert_eq!(a.position, Vec3::new(-1.25, 22.5, -103.125));
    assert!(!a.hetero);
    assert_eq!(a.occupancy, 0.35);
    assert_eq!(a.b_factor, 87.65);
    let z = &m.atoms[1];
    assert!(z.hetero);
    assert_eq!((z.name.as_str(), z.residue.as_str()), ("ZN", "ZN"));
    assert_eq!(z.element, Element::Zn);
    assert_eq!(z.residue_seq, 501);
    assert!(m.bonds.is_empty());
}

#[test]
fn molecule_pdb_element_column_and_inference() {
    let text = [
        line("ATOM      1  CA  ALA A   1", [0.0, 0.0, 0.0], ""),
        line("HETATM    2 CA    CA A   2", [9.0, 0.0, 0.0], ""),
        line("ATOM      3 HG11 VAL A   3", [0.0, 9.0, 0.0], ""),
        line("ATOM      4 1HB  ALA A   4", [0.0, 0.0, 9.0], ""),
        line("HETATM    5 FE   HEM A   5", [9.0, 9.0, 0.0], "fe"),
        line("ATOM      6  D   ALA A   6", [9.0, 0.0, 9.0], " D"),
        line("HETATM    7 XX   UNL A   7", [0.0, 9.0, 9.0], "Qq"),
    ]
    .join("\n");
    let m = pdb(&text).unwrap();
    let e: Vec<Element> = m.atoms.iter().map(|a| a.element).collect();
    use Element as E;
    assert_eq!(
        e,
        [E::C, E::Ca, E::H, E::H, E::Fe, E::H, E::Unknown],
        "{text}"
    );
}

#[test]
fn molecule_pdb_short_lines_crlf_tabs_and_cr_only() {
    // Lines end right after z (no occupancy, B or element), with CRLF and trailing tabs.
    let text = "ATOM      1  N   GLY A   1       0.000   0.000   0.000\t \r\n\
                ATOM      2  CA  GLY A   1       1.450   0.000   0.000\r\n\
                ATOM      3  C   GLY A   1       2.000   1.400   0.000  1.00\r\n\
                END\r\n";
    let m = pdb(text).unwrap();
    assert_eq!(m.atoms.len(), 3);
    assert_eq!(m.atoms[0].occupancy, 1.0);
    assert_eq!(m.atoms[0].b_factor, 0.0);
    assert_eq!(
        m.atoms.iter().map(|a| a.element).collect::<Vec<_>>(),
        [Element::N, Element::C, Element::C]
    );
    assert_eq!(m.bonds, vec![[0, 1], [1, 2]]);
    assert_eq!(m.name, "t");
    // Classic Mac line endings.
    let cr = text.replace("\r\n", "\r");
    assert_eq!(pdb(&cr).unwrap().atoms, m.atoms);
    // Unix line endings, no final newline.
    let lf = text.replace("\r\n", "\n");
    assert_eq!(pdb(lf.trim_end()).unwrap(), m);
    // A byte-order mark.
    assert_eq!(pdb(&format!("\u{feff}{lf}")).unwrap(), m);
}

#[test]
fn molecule_pdb_altloc_keeps_the_first_per_residue() {
    let text = [
        line("ATOM      1  N   SER A   1", [0.0, 0.0, 0.0], "N"),
        line("ATOM      2  CA ASER A   1", [1.45, 0.0, 0.0], "C"),
        line("ATOM      3  CA BSER A   1", [1.45, 0.2, 0.0], "C"),
        line("ATOM      4  OG ASER A   1", [2.0, 1.3, 0.0], "O"),
        line("ATOM      5  OG BSER A   1", [2.0, -1.3, 0.0], "O"),
        // A residue whose alternates are B and C only: B is its choice.
        line("ATOM      6  N  BTHR A   2", [5.0, 0.0, 0.0], "N"),
        line("ATOM      7  N  CTHR A   2", [5.0, 0.3, 0.0], "N"),
        // Same number, other chain: independent.
        line("ATOM      8  N  CTHR B   2", [9.0, 0.3, 0.0], "N"),
    ]
    .join("\n");
    let m = pdb(&text).unwrap();
    let serials: Vec<i64> = m.atoms.iter().map(|a| a.serial).collect();
    assert_eq!(serials, [1, 2, 4, 6, 8]);
    // Bonds are within the kept choice only: N–CA, CA–OG(A).
    assert_eq!(m.bonds, vec![[0, 1], [1, 2]]);
}

#[test]
fn molecule_pdb_hybrid36_serials_and_conect() {
    let text = [
        line("HETATM99999  C1  LIG A9999", [0.0, 0.0, 0.0], "C"),
        line("HETATMA0000  C2  LIG AA000", [1.5, 0.0, 0.0], "C"),
        line("HETATMA0001  O3  LIG AA000", [2.2, 1.2, 0.0], "O"),
        "CONECT99999A0000".to_string(),
        "CONECTA0000A0001".to_string(),
    ]
    .join("\n");
    let m = pdb(&text).unwrap();
    assert_eq!(
        m.atoms.iter().map(|a| a.serial).collect::<Vec<_>>(),
        [99_999, 100_000, 100_001]
    );
    assert_eq!(m.atoms[1].residue_seq, 10_000);
    assert_eq!(m.bonds, vec![[0, 1], [1, 2]]);
}

#[test]
fn molecule_pdb_wide_and_starred_serials() {
    let a = line("ATOM      1  N   GLY A   1", [0.0, 0.0, 0.0], "N");
    let mut wide = line("ATOM         CA  GLY A   1", [1.5, 0.0, 0.0], "C");
    wide.replace_range(4..11, "1234567");
    let starred = line("ATOM  *****  C   GLY A   1", [2.0, 1.4, 0.0], "C");
    let m = pdb(&[a, wide, starred].join("\n")).unwrap();
    assert_eq!(
        m.atoms.iter().map(|a| a.serial).collect::<Vec<_>>(),
        [1, 1_234_567, 1_234_568]
    );
}

#[test]
fn molecule_pdb_first_model_only_and_end() {
    let model = |dx: f32| {
        [
            line("ATOM      1  N   GLY A   1", [dx, 0.0, 0.0], "N"),
            line("ATOM      2  CA  GLY A   1", [dx + 1.45, 0.0, 0.0], "C"),
        ]
        .join("\n")
    };
    let text = format!(
        "MODEL        1\n{}\nENDMDL\nMODEL        2\n{}\nENDMDL\nCONECT    1    2\nEND\n{}\n",
        model(0.0),
        model(50.0),
        line("ATOM      9  O   HOH A   9", [0.0, 0.0, 0.0], "O")
    );
    let m = pdb(&text).unwrap();
    assert_eq!(m.atoms.len(), 2);
    assert_eq!(m.atoms[1].position.x, 1.45);
    assert_eq!(m.bonds, vec![[0, 1]]);
    // A second MODEL without ENDMDL also ends the first model.
    let text = format!("MODEL 1\n{}\nMODEL 2\n{}\n", model(0.0), model(50.0));
    assert_eq!(pdb(&text).unwrap().atoms.len(), 2);
}

#[test]
fn molecule_pdb_conect_rules() {
    // A ligand of three atoms listed by CONECT (C1–C2 only), a protein SG listed only for
    // an S–S bond with another SG, its CB not listed, and a CONECT naming absent serials,
    // repeating a bond, and bonding an atom to itself.
    let text = [
        line("ATOM      1  CB  CYS A   1", [0.0, 0.0, 0.0], "C"),
        line("ATOM      2  SG  CYS A   1", [1.8, 0.0, 0.0], "S"),
        line("ATOM      3  SG  CYS A   9", [3.85, 0.0, 0.0], "S"),
        line("ATOM      4  CB  CYS A   9", [5.65, 0.0, 0.0], "C"),
        line("HETATM    5  C1  LIG B   1", [20.0, 0.0, 0.0], "C"),
        line("HETATM    6  C2  LIG B   1", [21.5, 0.0, 0.0], "C"),
        // Close to C2 (1.5 Å) and listed by CONECT, but not bonded to it there.
        line("HETATM    7  C3  LIG B   1", [21.5, 1.5, 0.0], "C"),
        "CONECT    2    3".to_string(),
        "CONECT    3    2".to_string(),
        "CONECT    5    6    6 9999".to_string(),
        "CONECT    7    7".to_string(),
        "CONECT 8888    1".to_string(),
    ]
    .join("\n");
    let m = pdb(&text).unwrap();
    // CB–SG inferred (CB is not named by CONECT), SG–SG and C1–C2 from CONECT, C2–C3
    // inferred: C3's only CONECT is a self-bond, which is dropped, so C3 is not covered.
    assert_eq!(m.bonds, vec![[0, 1], [1, 2], [2, 3], [4, 5], [5, 6]]);

    // Once CONECT bonds C3 to C1, C2 and C3 are both covered: C2–C3 is not inferred,
    // although they are 1.5 Å apart, while C1–C3 (2.1 Å) is kept from CONECT.
    let text2 = format!("{text}\nCONECT    7    5");
    let m = pdb(&text2).unwrap();
    assert_eq!(m.bonds, vec![[0, 1], [1, 2], [2, 3], [4, 5], [4, 6]]);
}

#[test]
fn molecule_water_has_two_oh_bonds_and_no_hh() {
    let text = [
        line("HETATM    1  O   HOH A   1", [0.0, 0.0, 0.0], "O"),
        line("HETATM    2  H1  HOH A   1", [0.757, 0.586, 0.0], "H"),
        line("HETATM    3  H2  HOH A   1", [-0.757, 0.586, 0.0], "H"),
    ]
    .join("\n");
    let m = pdb(&text).unwrap();
    assert_eq!(m.bonds, vec![[0, 1], [0, 2]]);
    // H₂ at 0.74 Å is bonded; two hydrogens 0.9 Å apart are not; nor atoms 0.3 Å apart.
    let mut h2 = Molecule::default();
    h2.atoms.push(Atom::new(Element::H, Vec3::ZERO));
    h2.atoms
        .push(Atom::new(Element::H, Vec3::new(0.74, 0.0, 0.0)));
    h2.atoms
        .push(Atom::new(Element::H, Vec3::new(10.0, 0.0, 0.0)));
    h2.atoms
        .push(Atom::new(Element::H, Vec3::new(10.9, 0.0, 0.0)));
    h2.atoms
        .push(Atom::new(Element::C, Vec3::new(20.0, 0.0, 0.0)));
    h2.atoms
        .push(Atom::new(Element::C, Vec3::new(20.3, 0.0, 0.0)));
    h2.infer_bonds(DEFAULT_BOND_TOLERANCE);
    assert_eq!(h2.bonds, vec![[0, 1]]);
}

// ---------------------------------------------------------------------------------------
// Bond inference against brute force

fn brute_force(atoms: &[Atom], tolerance: f32) -> Vec<[u32; 2]> {
    let tol = if tolerance.is_nan() {
        0.0
    } else {
        tolerance.clamp(-1.0, 1.0)
    };
    let mut out = Vec::new();
    for i in 0..atoms.len() {
        for j in i + 1..atoms.len() {
            let (a, b) = (&atoms[i], &atoms[j]);
            let d = a.position.distance(b.position);
            if !d.is_finite() || d <= 0.4 {
                continue;
            }
            let cut = a.element.covalent_radius() + b.element.covalent_radius() + tol;
            let hh = a.element == Element::H && b.element == Element::H;
            if d < cut && (!hh || d < 0.8) {
                out.push([i as u32, j as u32]);
            }
        }
    }
    out
}

#[test]
fn molecule_bond_inference_matches_brute_force() {
    use Element as E;
    let pool = [
        E::C,
        E::C,
        E::C,
        E::H,
        E::H,
        E::H,
        E::N,
        E::O,
        E::S,
        E::Fe,
        E::Unknown,
    ];
    for seed in 0..6u64 {
        let mut rng = SplitMix64::new(1000 + seed);
        let n = 150 + 40 * seed as usize;
        let side = (n as f32 / 0.06).cbrt();
        let mut atoms: Vec<Atom> = (0..n)
            .map(|_| {
                let e = pool[rng.below(pool.len())];
                Atom::new(e, rng.point_in(Vec3::ZERO, Vec3::splat(side)))
            })
            .collect();
        // A duplicate point, a near-duplicate, a non-finite one.
        let p = atoms[0].position;
        atoms.push(Atom::new(E::C, p));
        atoms.push(Atom::new(E::C, p + Vec3::new(0.3, 0.0, 0.0)));
        atoms.push(Atom::new(E::C, Vec3::new(f32::NAN, 0.0, 0.0)));
        let dense = Molecule {
            name: String::new(),
            atoms: atoms.clone(),
            bonds: Vec::new(),
        };
        // A far-away bonded pair makes the grid sparse (the hash-map path).
        atoms.push(Atom::new(E::C, Vec3::splat(1.0e6)));
        atoms.push(Atom::new(
            E::O,
            Vec3::splat(1.0e6) + Vec3::new(0.0, 1.2, 0.0),
        ));
        let sparse = Molecule {
            name: String::new(),
            atoms,
            bonds: Vec::new(),
        };
        for (m, tol) in [&dense, &sparse]
            .into_iter()
            .flat_map(|m| [DEFAULT_BOND_TOLERANCE, 0.0, -0.3, 0.8, 5.0, f32::NAN].map(|t| (m, t)))
        {
            let want = brute_force(&m.atoms, tol);
            let mut degree = vec![0usize; m.atoms.len()];
            for b in &want {
                degree[b[0] as usize] += 1;
                degree[b[1] as usize] += 1;
            }
            assert!(
                degree.iter().all(|&d| d < MAX_INFERRED_BONDS_PER_ATOM),
                "test density too high for the comparison"
            );
            assert_eq!(
                m.inferred_bonds(tol),
                want,
                "seed {seed} tolerance {tol}, {} atoms",
                m.atoms.len()
            );
        }
        assert!(!brute_force(&dense.atoms, DEFAULT_BOND_TOLERANCE).is_empty());
        let far = sparse.atoms.len() as u32 - 2;
        assert!(
            sparse
                .inferred_bonds(DEFAULT_BOND_TOLERANCE)
                .contains(&[far, far + 1])
        );
    }
}

#[test]
fn molecule_bond_inference_scales_linearly() {
    // A simple cubic lattice of carbons 1.5 Å apart: each bonds to its 6 axis neighbours
    // (1.5 < 0.76 + 0.76 + 0.45 = 1.97 < 1.5·√2). 216,000 atoms would take ~2·10¹⁰ pair
    // tests by brute force; the grid does it in well under a second.
    let k = 60usize;
    let mut m = Molecule::default();
    for x in 0..k {
        for y in 0..k {
            for z in 0..k {
                let p = Vec3::new(x as f32, y as f32, z as f32) * 1.5 + Vec3::splat(-40.0);
                m.atoms.push(Atom::new(Element::C, p));
            }
        }
    }
    m.infer_bonds(DEFAULT_BOND_TOLERANCE);
    assert_eq!(m.bonds.len(), 3 * k * k * (k - 1));
    assert!(m.bonds.windows(2).all(|w| w[0] < w[1]));
    assert!(m.bonds.iter().all(|b| b[0] < b[1]));
}

#[test]
fn molecule_bond_inference_degree_cap() {
    // 1000 atoms within 1 Å: bonds are capped per atom instead of growing quadratically.
    let mut rng = SplitMix64::new(7);
    let mut m = Molecule::default();
    for _ in 0..1000 {
        let p = rng.point_in(Vec3::ZERO, Vec3::splat(1.2));
        m.atoms.push(Atom::new(Element::C, p));
    }
    m.infer_bonds(DEFAULT_BOND_TOLERANCE);
    assert!(m.bonds.len() <= 1000 * MAX_INFERRED_BONDS_PER_ATOM / 2);
    let mut degree = vec![0usize; 1000];
    for b in &m.bonds {
        degree[b[0] as usize] += 1;
        degree[b[1] as usize] += 1;
    }
    assert!(degree.iter().all(|&d| d <= MAX_INFERRED_BONDS_PER_ATOM));
}

#[test]
fn molecule_bounds() {
    let mut m = Molecule::default();
    assert_eq!(m.bounds(), None);
    m.atoms
        .push(Atom::new(Element::C, Vec3::new(1.0, -2.0, 3.0)));
    m.atoms
        .push(Atom::new(Element::C, Vec3::new(f32::NAN, 0.0, 0.0)));
    m.atoms
        .push(Atom::new(Element::C, Vec3::new(-1.0, 5.0, 0.0)));
    assert_eq!(
        m.bounds(),
        Some((Vec3::new(-1.0, -2.0, 0.0), Vec3::new(1.0, 5.0, 3.0)))
    );
}

// ---------------------------------------------------------------------------------------
// PDB errors

#[test]
fn molecule_pdb_errors_name_the_line() {
    let good = line("ATOM      1  N   GLY A   1", [0.0, 0.0, 0.0], "N");
    let with = |bad: &str| format!("REMARK 1\n{good}\n{bad}\n");

    let mut x = good.clone();
    x.replace_range(30..38, "   12.3a");
    assert_eq!(
        err_pdb(with(&x).as_bytes()),
        r#"bad.pdb: line 3: ATOM record: x coordinate "12.3a" is not a number"#
    );
    let mut y = good.replace("ATOM  ", "HETATM");
    y.replace_range(38..46, "     nan");
    assert_eq!(
        err_pdb(with(&y).as_bytes()),
        r#"bad.pdb: line 3: HETATM record: y coordinate "nan" is not finite"#
    );
    let mut z = good.clone();
    z.replace_range(46..54, "        ");
    assert_eq!(
        err_pdb(with(&z).as_bytes()),
        "bad.pdb: line 3: ATOM record: z coordinate (columns 47-54) is missing"
    );
    assert_eq!(
        err_pdb(with(&good[..50]).as_bytes()),
        "bad.pdb: line 3: ATOM record is only 50 characters long; the coordinates need columns 31-54"
    );
    let mut o = good.clone();
    o.replace_range(54..60, "  x.00");
    assert!(err_pdb(with(&o).as_bytes()).starts_with("bad.pdb: line 3: ATOM record: occupancy"));
    let mut s = good.clone();
    s.replace_range(6..11, "1!000");
    assert!(
        err_pdb(with(&s).as_bytes())
            .starts_with("bad.pdb: line 3: ATOM record: serial number \"1!000\""),
    );
    let mut r = good.clone();
    r.replace_range(22..26, "1x 2");
    assert!(
        err_pdb(with(&r).as_bytes()).starts_with("bad.pdb: line 3: ATOM record: residue number")
    );
    assert_eq!(
        err_pdb(with("CONECT    1   xx").as_bytes()),
        r#"bad.pdb: line 3: CONECT record: serial number "   xx" (columns 12-16) is not a number"#
    );

    // Non-UTF-8 in an ATOM record.
    let mut bytes = with(&good).into_bytes();
    let at = bytes.len() - 10;
    bytes[at] = 0xff;
    let msg = err_pdb(&bytes);
    assert!(
        msg.starts_with("bad.pdb: line 3: ATOM record is not ASCII text (byte 0xff at column 70)"),
        "{msg}"
    );
    // Binary garbage.
    let msg = err_pdb(b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR");
    assert!(
        msg.starts_with("bad.pdb: line 2: binary data (byte 0x1a"),
        "{msg}"
    );
    let msg = err_pdb(b"HEADER\nREMARK \0\x01\x02");
    assert!(
        msg.starts_with("bad.pdb: line 2: binary data (byte 0x00 at column 8)"),
        "{msg}"
    );
    // Latin-1 in a REMARK or a HEADER title is tolerated.
    let mut latin = b"HEADER    PROT\xe9INE\nREMARK   3 AUTHOR M\xfcLLER\n".to_vec();
    latin.extend_from_slice(good.as_bytes());
    assert_eq!(
        read_molecule_bytes(&latin, "x.pdb", MoleculeFormat::Pdb)
            .unwrap()
            .atoms
            .len(),
        1
    );

    // No atoms.
    for empty in [&b""[..], b"HEADER    NOTHING\nEND\n", b"hello world"] {
        assert_eq!(
            err_pdb(empty),
            "bad.pdb: no ATOM or HETATM records: not a PDB coordinate file, or an empty one"
        );
    }
    // Too many atoms.
    let three = [good.as_str(), good.as_str(), good.as_str()].join("\n");
    let e = read_with_limit(
        three.as_bytes(),
        MoleculeFormat::Pdb,
        Path::new("big.pdb"),
        2,
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "big.pdb: line 3: more than 2 atoms; refusing to read more"
    );
    // Corrupt gzip.
    let msg = err_pdb(&[0x1f, 0x8b, 8, 0, 0, 0, 0, 0, 0, 3, 1, 2, 3]);
    assert!(
        msg.starts_with("bad.pdb: gzip data cannot be decompressed"),
        "{msg}"
    );
}

#[test]
fn molecule_pdb_never_panics_on_mangled_input() {
    // Every truncation and many byte flips of a real file give Ok or Err, never a panic.
    let text = decompress(&std::fs::read(data_dir().join("1a8o.pdb.gz")).unwrap());
    let start = text.windows(6).position(|w| w == b"ATOM  ").unwrap();
    let chunk = &text[start..start + 4000];
    for cut in (0..chunk.len()).step_by(7) {
        let _ = read_molecule_bytes(&chunk[..cut], "cut.pdb", MoleculeFormat::Pdb);
        let _ = read_molecule_bytes(&chunk[..cut], "cut.cif", MoleculeFormat::Mmcif);
    }
    let mut rng = SplitMix64::new(99);
    for _ in 0..300 {
        let mut v = chunk.to_vec();
        for _ in 0..4 {
            let i = rng.below(v.len());
            v[i] = rng.next_u64() as u8;
        }
        let _ = read_molecule_bytes(&v, "flip.pdb", MoleculeFormat::Pdb);
        let _ = read_molecule_bytes(&v, "flip.cif", MoleculeFormat::Mmcif);
    }
}

// ---------------------------------------------------------------------------------------
// mmCIF

const CIF: &str = "data_TEST
# a comment line
_entry.id   TEST
_struct.title
;A text field with 'quotes', data_ and loop_
spanning two lines
;
loop_
_atom_site.group_PDB
_atom_site.id
_atom_site.type_symbol
_atom_site.label_atom_id
_atom_site.label_alt_id
_atom_site.label_comp_id
_atom_site.label_asym_id
_atom_site.label_seq_id
_atom_site.pdbx_PDB_ins_code
_atom_site.Cartn_x
_atom_site.Cartn_y
_atom_site.Cartn_z
_atom_site.occupancy
_atom_site.B_iso_or_equiv
_atom_site.auth_seq_id
_atom_site.auth_asym_id
_atom_site.pdbx_PDB_model_num
ATOM   1 N  N     . ALA A 1 ? 0.000 0.000 0.000 1.00 10.0 5 B 1
ATOM   2 C  CA    . ALA A 1 ? 1.458 0.000 0.000 ?    11.0 5 B 1
ATOM   3 C  \"C'\"  A ALA A 1 ? 2.009 1.420(3) 0.000 0.5 . 5 B 1
ATOM   4 C  \"C'\"  B ALA A 1 ? 2.1 1.5 0.1 0.5 . 5 B 1
HETATM 5 ZN ZN    . ZN  B . ? 10.0 10.0 10.0 1 20 101 C 1
HETATM 6 O  'O 1' . 'my lig' C . ? 20.0 20.0 20.0 1 20 ? C 1 # trailing comment
HETATM 7 C  C1    . LIG C .
? 21.5 20.0 20.0 1 20 201 C 1
ATOM   8 N  N     . ALA A 1 ? 5.000 5.000 5.000 1.00 10.0 5 B 2
#
loop_
_other.a
_other.b
1 2
";

#[test]
fn molecule_mmcif_snippet() {
    let m = cif(CIF).unwrap();
    assert_eq!(m.name, "TEST");
    let ids: Vec<i64> = m.atoms.iter().map(|a| a.serial).collect();
    assert_eq!(ids, [1, 2, 3, 5, 6, 7]);
    let a = &m.atoms[2];
    assert_eq!(a.name, "C'");
    assert_eq!(a.position, Vec3::new(2.009, 1.42, 0.0));
    assert_eq!((a.occupancy, a.b_factor), (0.5, 0.0));
    assert_eq!((a.chain.as_str(), a.residue_seq), ("B", 5));
    assert_eq!(m.atoms[1].occupancy, 1.0);
    assert_eq!(m.atoms[1].b_factor, 11.0);
    let zn = &m.atoms[3];
    assert_eq!(
        (zn.element, zn.hetero, zn.residue_seq),
        (Element::Zn, true, 101)
    );
    let o = &m.atoms[4];
    assert_eq!((o.name.as_str(), o.residue.as_str()), ("O 1", "my lig"));
    assert_eq!((o.chain.as_str(), o.residue_seq), ("C", 0));
    assert_eq!(m.atoms[5].residue_seq, 201);
    assert!(!m.atoms[0].hetero);
    assert_eq!(m.bonds, vec![[0, 1], [1, 2], [4, 5]]);
    // The same with CRLF line endings.
    assert_eq!(cif(&CIF.replace('\n', "\r\n")).unwrap(), m);
}

#[test]
fn molecule_mmcif_single_atom_and_missing_type_symbol() {
    let one = "data_ONE\n_atom_site.id 1\n_atom_site.label_atom_id CA\n_atom_site.label_comp_id CA\n\
               _atom_site.group_PDB HETATM\n_atom_site.Cartn_x 1\n_atom_site.Cartn_y 2\n_atom_site.Cartn_z 3\n";
    let m = cif(one).unwrap();
    assert_eq!(m.atoms.len(), 1);
    assert_eq!(m.atoms[0].element, Element::Ca);
    assert_eq!(m.atoms[0].position, Vec3::new(1.0, 2.0, 3.0));
    // Without type_symbol, a protein CA is carbon.
    let two = "data_\nloop_\n_atom_site.label_atom_id\n_atom_site.label_comp_id\n_atom_site.Cartn_x\n\
               _atom_site.Cartn_y\n_atom_site.Cartn_z\nCA ALA 0 0 0\nHG11 VAL 5 5 5\n";
    let m = cif(two).unwrap();
    assert_eq!(m.name, "t");
    assert_eq!(m.atoms[0].element, Element::C);
    assert_eq!(m.atoms[1].element, Element::H);
    assert_eq!(m.atoms[1].serial, 2);
    // Ligand atoms named after two-letter elements: iron in a haem, selenium in MSE,
    // chlorine; a ligand's CA stays carbon.
    let het = "data_\nloop_\n_atom_site.group_PDB\n_atom_site.label_atom_id\n_atom_site.label_comp_id\n\
               _atom_site.Cartn_x\n_atom_site.Cartn_y\n_atom_site.Cartn_z\n\
               HETATM FE HEM 0 0 0\nHETATM SE MSE 3 0 0\nHETATM CL1 LIG 6 0 0\nHETATM CA MSE 9 0 0\n";
    let m = cif(het).unwrap();
    let e: Vec<Element> = m.atoms.iter().map(|a| a.element).collect();
    assert_eq!(e, [Element::Fe, Element::Se, Element::Cl, Element::C]);
}

#[test]
fn molecule_mmcif_errors_name_the_line() {
    let head = "data_X\nloop_\n_atom_site.id\n_atom_site.Cartn_x\n_atom_site.Cartn_y\n_atom_site.Cartn_z\n";
    assert_eq!(
        err_cif(format!("{head}1 0 0 0\n2 12.3a 0 0\n").as_bytes()),
        r#"bad.cif: line 8: _atom_site.Cartn_x "12.3a" is not a number"#
    );
    assert_eq!(
        err_cif(format!("{head}1 0 0 0\n2 0 0 ?\n").as_bytes()),
        r#"bad.cif: line 8: _atom_site.Cartn_z is missing ("?"); every atom needs coordinates"#
    );
    assert_eq!(
        err_cif(format!("{head}1 0 0 0\n2 0 0 1e40\n").as_bytes()),
        r#"bad.cif: line 8: _atom_site.Cartn_z "1e40" is not finite"#
    );
    assert_eq!(
        err_cif(format!("{head}1 0 0 0\n2 0 0\n").as_bytes()),
        "bad.cif: line 8: the _atom_site loop (from line 2) has 7 values, not a multiple of its 4 columns: its last row has only 3 values"
    );
    // A missing value mid-loop shifts the rows: the message says so.
    let named = "data_X\nloop_\n_atom_site.label_atom_id\n_atom_site.Cartn_x\n_atom_site.Cartn_y\n_atom_site.Cartn_z\n";
    let msg = err_cif(format!("{named}N 0 0\nCA 0 0 0\nC 0 0 0\n").as_bytes());
    assert!(msg.contains("wrong number of values"), "{msg}");
    assert_eq!(
        err_cif(b"data_X\nloop_\n_atom_site.id\n_atom_site.Cartn_x\n_atom_site.Cartn_y\n1 2 3\n"),
        "bad.cif: line 2: the _atom_site category has no _atom_site.Cartn_z item (Cartesian coordinates are required)"
    );
    assert_eq!(
        err_cif(b"data_X\n_entry.id X\nloop_\n_a.b\n1\n"),
        "bad.cif: no _atom_site loop: not an mmCIF coordinate file (or one without atoms)"
    );
    assert_eq!(
        err_cif(format!("{head}#nothing\n").as_bytes()),
        "bad.cif: line 2: the _atom_site loop has no rows"
    );
    assert_eq!(
        err_cif(format!("{head}1 'abc 0 0\n").as_bytes()),
        r#"bad.cif: line 7: quoted value 'abc 0 0 is not closed on its line"#
    );
    assert_eq!(
        err_cif(b"data_X\n_x.y\n;never\nclosed\n"),
        "bad.cif: line 3: text field starting with ';' is never closed (no later line starts with ';')"
    );
    let mut bytes = format!("{head}1 0 0 0\n2 0 0 0\n").into_bytes();
    let n = bytes.len();
    bytes[n - 4] = 0xc3;
    assert_eq!(
        err_cif(&bytes),
        "bad.cif: line 8: not UTF-8 text (byte 0xc3 at column 5); this is not an mmCIF text file"
    );
    assert_eq!(
        err_cif(b"data_X\n\x00\x01"),
        "bad.cif: line 2: binary data (byte 0x00 at column 1); this is not an mmCIF text file"
    );
    let e = read_with_limit(
        format!("{head}1 0 0 0\n2 0 0 0\n3 0 0 0\n").as_bytes(),
        MoleculeFormat::Mmcif,
        Path::new("big.cif"),
        2,
    )
    .unwrap_err();
    assert_eq!(
        e.to_string(),
        "big.cif: line 9: more than 2 atoms; refusing to read more"
    );
}

// ---------------------------------------------------------------------------------------
// Formats, names, files

#[test]
fn molecule_format_from_path_and_stem() {
    use MoleculeFormat as F;
    for (p, f) in [
        ("a.pdb", F::Pdb),
        ("A.PDB", F::Pdb),
        ("pdb1abc.ent.gz", F::Pdb),
        ("1abc.pdb1", F::Pdb),
        ("x.pdb.GZ", F::Pdb),
        ("1abc.cif", F::Mmcif),
        ("1abc.mmcif.gz", F::Mmcif),
    ] {
        assert_eq!(F::from_path(Path::new(p)).unwrap(), f, "{p}");
    }
    for p in ["a.gz", "a.xyz", "pdb", "a.pdbx", "a.cif.zip"] {
        let e = F::from_path(Path::new(p)).unwrap_err();
        assert!(matches!(e, IoError::UnknownFormat { .. }), "{p}");
    }
    assert_eq!(stem(Path::new("dir/1abc.pdb.gz")), "1abc");
    assert_eq!(stem(Path::new("1abc.cif")), "1abc");
    assert_eq!(stem(Path::new("noext")), "noext");
    assert_eq!(stem(Path::new(".gz")), "");
}

#[test]
fn molecule_read_errors_for_files() {
    let e = read_molecule(Path::new("/nonexistent/x.pdb")).unwrap_err();
    assert!(matches!(e, IoError::Io { .. }));
    let e = read_molecule(Path::new("x.mol2")).unwrap_err();
    assert!(matches!(e, IoError::UnknownFormat { .. }));
}

fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/molecules")
}

fn decompress(bytes: &[u8]) -> Vec<u8> {
    if bytes.starts_with(&[0x1f, 0x8b]) {
        let mut out = Vec::new();
        flate2::read::MultiGzDecoder::new(bytes)
            .read_to_end(&mut out)
            .unwrap();
        out
    } else {
        bytes.to_vec()
    }
}

/// ATOM/HETATM lines of a PDB file's first model whose altLoc is blank or `A`, counted
/// the way `grep` would.
fn count_pdb(text: &str) -> usize {
    let mut n = 0;
    for l in text.lines() {
        if l.starts_with("ENDMDL") || l.starts_with("END ") || l == "END" {
            break;
        }
        if (l.starts_with("ATOM  ") || l.starts_with("HETATM"))
            && matches!(l.as_bytes().get(16), Some(b' ' | b'A'))
        {
            n += 1;
        }
    }
    n
}

/// `_atom_site` rows of an mmCIF file's first model whose alt id is `.` or `A`, split on
/// whitespace (the bundled files have no quoted values with blanks).
fn count_cif(text: &str) -> usize {
    let tags: Vec<&str> = text
        .lines()
        .filter_map(|l| l.trim().strip_prefix("_atom_site."))
        .collect();
    let model = tags
        .iter()
        .position(|t| *t == "pdbx_PDB_model_num")
        .unwrap();
    let alt = tags.iter().position(|t| *t == "label_alt_id").unwrap();
    let rows: Vec<Vec<&str>> = text
        .lines()
        .filter(|l| l.starts_with("ATOM ") || l.starts_with("HETATM "))
        .map(|l| l.split_whitespace().collect())
        .collect();
    let first = rows[0][model];
    rows.iter()
        .filter(|r| r[model] == first && matches!(r[alt], "." | "A"))
        .count()
}

#[test]
fn molecule_bundled_files() {
    // File, atoms in the first model and first altLoc (also counted from the file).
    let files = [
        ("1a8o.pdb.gz", 644),
        ("1a8o.cif.gz", 644),
        ("7ddo.pdb.gz", 6461),
        ("2beg.cif.gz", 1855),
    ];
    for (file, want) in files {
        let path = data_dir().join(file);
        let m = read_molecule(&path).unwrap_or_else(|e| panic!("{e}"));
        let text = String::from_utf8(decompress(&std::fs::read(&path).unwrap())).unwrap();
        let counted = if file.contains(".pdb") {
            count_pdb(&text)
        } else {
            count_cif(&text)
        };
        assert_eq!(counted, want, "{file}");
        assert_eq!(m.atoms.len(), counted, "{file}");
        assert!(!m.bonds.is_empty(), "{file}");
        assert!(m.bonds.windows(2).all(|w| w[0] < w[1]), "{file}");
        assert!(
            m.bonds
                .iter()
                .all(|b| b[0] < b[1] && (b[1] as usize) < m.atoms.len())
        );
        let (lo, hi) = m.bounds().unwrap();
        assert!(
            lo.is_finite() && hi.is_finite() && lo.cmple(hi).all(),
            "{file}"
        );
        for a in &m.atoms {
            assert_ne!(a.element, Element::Unknown, "{file}: {a:?}");
            assert!(a.element.covalent_radius() > 0.0 && a.element.vdw_radius() > 0.0);
        }
        // Covalent geometry: bonds are between 0.4 and 2.5 Å, and on average each heavy
        // atom of a protein has between 1.5 and 2.5 bonds.
        for b in &m.bonds {
            let d = m.atoms[b[0] as usize]
                .position
                .distance(m.atoms[b[1] as usize].position);
            assert!(d > 0.4 && d < 2.5, "{file}: bond {b:?} of {d} Å");
        }
        let heavy = m.atoms.iter().filter(|a| a.element != Element::H).count();
        let per_atom = 2.0 * m.bonds.len() as f32 / m.atoms.len() as f32;
        assert!(
            (1.5..2.5).contains(&per_atom),
            "{file}: {per_atom} bonds per atom ({heavy} heavy)"
        );
    }
}

#[test]
fn molecule_bundled_pdb_and_mmcif_agree() {
    let p = read_molecule(&data_dir().join("1a8o.pdb.gz")).unwrap();
    let c = read_molecule(&data_dir().join("1a8o.cif.gz")).unwrap();
    assert_eq!((p.name.as_str(), c.name.as_str()), ("1A8O", "1A8O"));
    assert_eq!(p.atoms.len(), c.atoms.len());
    // The two files come from different eras of the archive: the PDB file numbers atoms
    // from 10 and calls MSE a HETATM, the remediated mmCIF numbers from 1 and calls it an
    // ATOM. Everything else agrees exactly.
    for (a, b) in p.atoms.iter().zip(&c.atoms) {
        let strip = |x: &Atom| Atom {
            serial: 0,
            hetero: false,
            ..x.clone()
        };
        assert_eq!(strip(a), strip(b));
    }
    // Selenomethionine: selenium from the element column / type_symbol.
    assert_eq!(
        p.atoms.iter().filter(|a| a.element == Element::Se).count(),
        4
    );
    // 1A8O's CONECT records cover the MSE residues; every Se keeps its two C neighbours.
    for (i, a) in p.atoms.iter().enumerate() {
        if a.element == Element::Se {
            let n = p.bonds.iter().filter(|b| b.contains(&(i as u32))).count();
            assert_eq!(n, 2, "{a:?}");
        }
    }
    // On this file, CONECT united with inference gives the bonds that inference alone
    // gives from the mmCIF.
    assert_eq!(p.bonds, c.bonds);
}

#[test]
fn molecule_bundled_multimodel_keeps_the_first() {
    let m = read_molecule(&data_dir().join("2beg.cif.gz")).unwrap();
    assert_eq!(m.name, "2BEG");
    let h = m.atoms.iter().filter(|a| a.element == Element::H).count();
    assert!(h > 800, "{h} hydrogens");
    // The first atom of model 1, as the file gives it.
    assert_eq!(m.atoms[0].position, Vec3::new(-16.074, -6.064, -3.588));
    assert_eq!(
        (m.atoms[0].name.as_str(), m.atoms[0].residue_seq),
        ("N", 17)
    );
}

#[test]
fn molecule_a_pile_of_coincident_atoms_does_not_make_inference_quadratic() {
    // 200,000 atoms at one point (a broken file) next to a water molecule: without the cap
    // on candidates per cell this tests 2e10 pairs; with it, about 5e7.
    let mut m = Molecule::default();
    for _ in 0..200_000 {
        m.atoms
            .push(Atom::new(Element::C, Vec3::new(50.0, 50.0, 50.0)));
    }
    m.atoms.push(Atom::new(Element::O, Vec3::ZERO));
    m.atoms
        .push(Atom::new(Element::H, Vec3::new(0.757, 0.586, 0.0)));
    m.atoms
        .push(Atom::new(Element::H, Vec3::new(-0.757, 0.586, 0.0)));
    m.infer_bonds(DEFAULT_BOND_TOLERANCE);
    // Coincident atoms never bond; the water's two O–H bonds are found.
    assert_eq!(m.bonds, vec![[200_000, 200_001], [200_000, 200_002]]);
}
