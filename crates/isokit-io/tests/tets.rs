//! Tetrahedral grids from VTK files: one grid written in every encoding the readers accept
//! (legacy ASCII and binary, old and version 5.1 cells, extra attributes; VTK XML ASCII,
//! inline base64 with the header apart or together, appended raw and base64, zlib in
//! several blocks, 32- and 64-bit headers, both byte orders) reads back the same, and broken
//! files (cut at every length, wrong counts, indices out of range, other cell types) give
//! errors, never a panic.

use std::io::Write;

use base64::Engine;
use base64::engine::general_purpose::STANDARD;
use glam::Vec3;
use isokit_field::{Grid, TetGrid, TetSplit};
use isokit_io::{IoError, TetFormat, read_tets_bytes};

fn grid() -> TetGrid {
    let mut g = Grid::new([3, 3, 4], Vec3::new(-0.5, 0.25, 1.0), 0.5).unwrap();
    for (i, v) in g.data_mut().iter_mut().enumerate() {
        *v = (i as f32 * 0.37).sin();
    }
    TetGrid::from_grid(&g, TetSplit::Five).unwrap()
}

fn legacy_ascii(t: &TetGrid) -> Vec<u8> {
    let mut s = String::from(
        "# vtk DataFile Version 4.2\nwritten by a test\nASCII\nDATASET UNSTRUCTURED_GRID\n",
    );
    s += &format!("POINTS {} float\n", t.points().len());
    for p in t.points() {
        s += &format!("{} {} {}\n", p.x, p.y, p.z);
    }
    s += &format!("CELLS {} {}\n", t.tets().len(), 5 * t.tets().len());
    for c in t.tets() {
        s += &format!("4 {} {} {} {}\n", c[0], c[1], c[2], c[3]);
    }
    s += &format!("CELL_TYPES {}\n", t.tets().len());
    s += &"10\n".repeat(t.tets().len());
    s += &format!(
        "CELL_DATA {}\nSCALARS id int 1\nLOOKUP_TABLE default\n",
        t.tets().len()
    );
    s += &(0..t.tets().len())
        .map(|i| format!("{i}\n"))
        .collect::<String>();
    s += &format!("POINT_DATA {}\nVECTORS v float\n", t.points().len());
    s += &"1 2 3\n".repeat(t.points().len());
    s += "SCALARS f float\nLOOKUP_TABLE default\n";
    for v in t.values() {
        s += &format!("{v}\n");
    }
    s.into_bytes()
}

fn legacy_binary(t: &TetGrid) -> Vec<u8> {
    let mut b: Vec<u8> =
        b"# vtk DataFile Version 5.1\nbinary test\nBINARY\nDATASET UNSTRUCTURED_GRID\n".to_vec();
    b.extend(format!("POINTS {} double\n", t.points().len()).bytes());
    for p in t.points() {
        for c in p.to_array() {
            b.extend(f64::from(c).to_be_bytes());
        }
    }
    b.extend(
        format!(
            "\nMETADATA\nINFORMATION 0\n\nCELLS {} {}\nOFFSETS vtktypeint64\n",
            t.tets().len() + 1,
            4 * t.tets().len()
        )
        .bytes(),
    );
    for i in 0..=t.tets().len() {
        b.extend((4 * i as i64).to_be_bytes());
    }
    b.extend(b"\nCONNECTIVITY vtktypeint64\n");
    for c in t.tets() {
        for i in c {
            b.extend(i64::from(*i).to_be_bytes());
        }
    }
    b.extend(format!("\nCELL_TYPES {}\n", t.tets().len()).bytes());
    for _ in t.tets() {
        b.extend(10i32.to_be_bytes());
    }
    b.extend(
        format!(
            "\nPOINT_DATA {}\nFIELD FieldData 2\nvec 3 {} float\n",
            t.points().len(),
            t.points().len()
        )
        .bytes(),
    );
    for _ in 0..3 * t.points().len() {
        b.extend(1.5f32.to_be_bytes());
    }
    b.extend(format!("\nf 1 {} float\n", t.points().len()).bytes());
    for v in t.values() {
        b.extend(v.to_be_bytes());
    }
    b.extend(b"\nMETADATA\nINFORMATION 0\n\n");
    b
}

#[derive(Clone, Copy, Debug)]
enum Enc {
    Ascii,
    /// Inline base64: 64-bit header, header encoded together with the data, zlib.
    Inline {
        wide: bool,
        together: bool,
        zlib: bool,
    },
    /// Appended: base64 or raw, zlib.
    Appended {
        base64: bool,
        zlib: bool,
        wide: bool,
        big: bool,
    },
}

/// The arrays of a `.vtu` as (section, name, type, components, little-endian bytes).
fn arrays(t: &TetGrid) -> Vec<(&'static str, &'static str, &'static str, usize, Vec<u8>)> {
    let f32s =
        |v: &mut dyn Iterator<Item = f32>| v.flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
    vec![
        (
            "PointData",
            "other",
            "Float32",
            3,
            f32s(&mut t.points().iter().flat_map(|p| p.to_array())),
        ),
        (
            "PointData",
            "f",
            "Float32",
            1,
            f32s(&mut t.values().iter().copied()),
        ),
        (
            "Points",
            "Points",
            "Float32",
            3,
            f32s(&mut t.points().iter().flat_map(|p| p.to_array())),
        ),
        (
            "Cells",
            "connectivity",
            "Int64",
            1,
            t.tets()
                .iter()
                .flatten()
                .flat_map(|&i| i64::from(i).to_le_bytes())
                .collect(),
        ),
        (
            "Cells",
            "offsets",
            "Int64",
            1,
            (1..=t.tets().len())
                .flat_map(|i| (4 * i as i64).to_le_bytes())
                .collect(),
        ),
        ("Cells", "types", "UInt8", 1, vec![10u8; t.tets().len()]),
    ]
}

fn swap(bytes: &[u8], size: usize) -> Vec<u8> {
    bytes
        .chunks(size)
        .flat_map(|c| c.iter().rev().copied())
        .collect()
}

fn word(n: usize, wide: bool, big: bool) -> Vec<u8> {
    match (wide, big) {
        (true, false) => (n as u64).to_le_bytes().to_vec(),
        (true, true) => (n as u64).to_be_bytes().to_vec(),
        (false, false) => (n as u32).to_le_bytes().to_vec(),
        (false, true) => (n as u32).to_be_bytes().to_vec(),
    }
}

/// zlib in blocks of 64 bytes: (header, compressed data).
fn zlib(data: &[u8], wide: bool, big: bool) -> (Vec<u8>, Vec<u8>) {
    let blocks: Vec<Vec<u8>> = data
        .chunks(64)
        .map(|c| {
            let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
            e.write_all(c).unwrap();
            e.finish().unwrap()
        })
        .collect();
    let mut h = word(blocks.len(), wide, big);
    h.extend(word(64, wide, big));
    h.extend(word(data.len() % 64, wide, big));
    for b in &blocks {
        h.extend(word(b.len(), wide, big));
    }
    (h, blocks.concat())
}

fn vtu(t: &TetGrid, enc: Enc) -> Vec<u8> {
    let (wide, zl, big) = match enc {
        Enc::Ascii => (false, false, false),
        Enc::Inline { wide, zlib, .. } => (wide, zlib, false),
        Enc::Appended {
            zlib, wide, big, ..
        } => (wide, zlib, big),
    };
    let mut head = format!(
        "<?xml version=\"1.0\"?>\n<!-- a comment -->\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"{}\" header_type=\"{}\"{}>\n<UnstructuredGrid>\n<Piece NumberOfPoints=\"{}\" NumberOfCells=\"{}\">\n",
        if big { "BigEndian" } else { "LittleEndian" },
        if wide { "UInt64" } else { "UInt32" },
        if zl {
            " compressor=\"vtkZLibDataCompressor\""
        } else {
            ""
        },
        t.points().len(),
        t.tets().len()
    );
    let mut appended: Vec<u8> = Vec::new();
    let mut section = "";
    for (sec, name, ty, comps, le) in arrays(t) {
        if sec != section {
            if !section.is_empty() {
                head += &format!("</{section}>\n");
            }
            head += &format!("<{sec}>\n");
            section = sec;
        }
        let size = if ty == "UInt8" {
            1
        } else if ty == "Int64" {
            8
        } else {
            4
        };
        let data = if big { swap(&le, size) } else { le.clone() };
        let attrs = format!("type=\"{ty}\" Name=\"{name}\" NumberOfComponents=\"{comps}\"");
        match enc {
            Enc::Ascii => {
                let text: Vec<String> = le
                    .chunks(size)
                    .map(|c| match ty {
                        "Float32" => f32::from_le_bytes(c.try_into().unwrap()).to_string(),
                        "Int64" => i64::from_le_bytes(c.try_into().unwrap()).to_string(),
                        _ => c[0].to_string(),
                    })
                    .collect();
                head += &format!(
                    "<DataArray {attrs} format=\"ascii\">\n{}\n</DataArray>\n",
                    text.join(" ")
                );
            }
            Enc::Inline { together, .. } => {
                let text = if zl {
                    let (h, d) = zlib(&data, wide, big);
                    STANDARD.encode(h) + &STANDARD.encode(d)
                } else if together {
                    let mut all = word(data.len(), wide, big);
                    all.extend(&data);
                    STANDARD.encode(all)
                } else {
                    STANDARD.encode(word(data.len(), wide, big)) + &STANDARD.encode(&data)
                };
                head += &format!("<DataArray {attrs} format=\"binary\">\n  {text}\n</DataArray>\n");
            }
            Enc::Appended { base64, .. } => {
                head += &format!(
                    "<DataArray {attrs} format=\"appended\" offset=\"{}\"/>\n",
                    appended.len()
                );
                let (h, d) = if zl {
                    zlib(&data, wide, big)
                } else {
                    (word(data.len(), wide, big), data)
                };
                if base64 {
                    appended.extend(STANDARD.encode(h).bytes());
                    appended.extend(STANDARD.encode(d).bytes());
                } else {
                    appended.extend(h);
                    appended.extend(d);
                }
            }
        }
    }
    head += &format!("</{section}>\n</Piece>\n</UnstructuredGrid>\n");
    let mut out = head.into_bytes();
    if let Enc::Appended { base64, .. } = enc {
        out.extend(
            format!(
                "<AppendedData encoding=\"{}\">\n   _",
                if base64 { "base64" } else { "raw" }
            )
            .bytes(),
        );
        out.extend(appended);
        out.extend(b"\n</AppendedData>\n");
    }
    out.extend(b"</VTKFile>\n");
    out
}

fn read(bytes: &[u8], format: TetFormat) -> Result<TetGrid, IoError> {
    read_tets_bytes(bytes, format, None, "test")
}

fn encodings() -> Vec<Enc> {
    let mut v = vec![Enc::Ascii];
    for wide in [false, true] {
        for (together, zlib) in [(false, false), (true, false), (false, true)] {
            v.push(Enc::Inline {
                wide,
                together,
                zlib,
            });
        }
        for base64 in [false, true] {
            for zlib in [false, true] {
                for big in [false, true] {
                    v.push(Enc::Appended {
                        base64,
                        zlib,
                        wide,
                        big,
                    });
                }
            }
        }
    }
    v
}

#[test]
fn every_encoding_reads_back_the_same_grid() {
    let t = grid();
    let expect = |got: TetGrid, what: &str| {
        assert_eq!(got.points(), t.points(), "{what}");
        assert_eq!(got.tets(), t.tets(), "{what}");
        assert_eq!(got.values(), t.values(), "{what}");
        assert_eq!(got.array(), "f", "{what}");
    };
    expect(
        read(&legacy_ascii(&t), TetFormat::Legacy).unwrap(),
        "legacy ascii",
    );
    expect(
        read(&legacy_binary(&t), TetFormat::Legacy).unwrap(),
        "legacy binary 5.1",
    );
    for enc in encodings() {
        let got = read_tets_bytes(&vtu(&t, enc), TetFormat::Vtu, Some("f"), "t.vtu")
            .unwrap_or_else(|e| panic!("{enc:?}: {e}"));
        expect(got, &format!("{enc:?}"));
    }
}

#[test]
fn the_first_one_component_array_is_the_default_and_a_missing_name_lists_the_others() {
    let t = grid();
    // The .vtu's first point array has three components: "f" is the first scalar.
    assert_eq!(
        read(&vtu(&t, Enc::Ascii), TetFormat::Vtu).unwrap().array(),
        "f"
    );
    let e = read_tets_bytes(&legacy_ascii(&t), TetFormat::Legacy, Some("g"), "t.vtk").unwrap_err();
    assert!(
        e.to_string().contains("\"g\"") && e.to_string().contains("f"),
        "{e}"
    );
}

#[test]
fn files_cut_anywhere_give_errors() {
    // About 300 cut points per file, spread over its whole length.
    let t = grid();
    let mut files = vec![
        (legacy_ascii(&t), TetFormat::Legacy),
        (legacy_binary(&t), TetFormat::Legacy),
    ];
    for enc in encodings() {
        files.push((vtu(&t, enc), TetFormat::Vtu));
    }
    for (bytes, format) in &files {
        let step = (bytes.len() / 300).max(1);
        for n in (0..bytes.len()).step_by(step) {
            // Cut anywhere: an error, or where only trailing text went, the same grid (in
            // ASCII a cut in the last number still reads as a shorter number).
            if let Ok(g) = read(&bytes[..n], *format) {
                let k = t.values().len() - 1;
                assert_eq!(g.tets(), t.tets(), "{format:?} cut at {n}");
                assert_eq!(g.values()[..k], t.values()[..k], "{format:?} cut at {n}");
            }
        }
    }
}

#[test]
fn wrong_counts_indices_and_cell_types_are_refused_with_their_reason() {
    let t = grid();
    let text = String::from_utf8(legacy_ascii(&t)).unwrap();
    let err = |s: &str, format: TetFormat| read(s.as_bytes(), format).unwrap_err().to_string();
    // An index past the points.
    let n = t.points().len();
    let bad = text.replacen(&format!("4 {} ", t.tets()[0][0]), &format!("4 {n} "), 1);
    assert!(
        err(&bad, TetFormat::Legacy).contains("not one of the"),
        "{}",
        err(&bad, TetFormat::Legacy)
    );
    // A hexahedron among the cells.
    let hex = text.replacen("\n10\n", "\n12\n", 1);
    let e = err(&hex, TetFormat::Legacy);
    assert!(
        e.contains("hexahedron") && e.contains("only tetrahedra"),
        "{e}"
    );
    // Claimed counts beyond the file.
    let big = text.replacen(&format!("POINTS {n} float"), "POINTS 99999999999 float", 1);
    assert!(
        err(&big, TetFormat::Legacy).contains("cannot fit"),
        "{}",
        err(&big, TetFormat::Legacy)
    );
    // A claim of 4e12 points over raw appended data: refused by the budget, not attempted.
    let raw = vtu(
        &t,
        Enc::Appended {
            base64: false,
            zlib: false,
            wide: false,
            big: false,
        },
    );
    let from = format!("NumberOfPoints=\"{n}\"");
    let at = raw
        .windows(from.len())
        .position(|w| w == from.as_bytes())
        .unwrap();
    let mut claim = raw[..at].to_vec();
    claim.extend(b"NumberOfPoints=\"4000000000000\"");
    claim.extend(&raw[at + from.len()..]);
    let e = read_tets_bytes(&claim, TetFormat::Vtu, None, "t.vtu")
        .unwrap_err()
        .to_string();
    assert!(e.contains("budget"), "{e}");
    // Not a grid at all.
    assert!(err("hello", TetFormat::Legacy).contains("not a VTK legacy file"));
    assert!(err("<a></a>", TetFormat::Vtu).contains("no <VTKFile>"));
    let image = "# vtk DataFile Version 3.0\nx\nASCII\nDATASET STRUCTURED_POINTS\n";
    assert!(err(image, TetFormat::Legacy).contains("UNSTRUCTURED_GRID"));
}

/// A one-cell VTU with ASCII arrays except the cell types, given as `types` (an element's
/// attributes and text), and the file's `compressor` attribute.
fn one_cell_vtu(types: &str, compressor: &str) -> String {
    format!(
        r#"<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian" header_type="UInt32"{compressor}>
<UnstructuredGrid><Piece NumberOfPoints="4" NumberOfCells="1">
<PointData><DataArray type="Float32" Name="v" format="ascii">0 1 2 3</DataArray></PointData>
<Points><DataArray type="Float32" NumberOfComponents="3" format="ascii">0 0 0 1 0 0 0 1 0 0 0 1</DataArray></Points>
<Cells>
<DataArray type="Int32" Name="connectivity" format="ascii">0 1 2 3</DataArray>
<DataArray type="Int32" Name="offsets" format="ascii">4</DataArray>
<DataArray {types}</DataArray>
</Cells></Piece></UnstructuredGrid></VTKFile>"#
    )
}

#[test]
fn one_byte_arrays_and_short_compression_headers_are_read_or_refused() {
    // One byte of data with its header encoded together: 5 bytes, 8 characters ending in
    // padding, as a header encoded apart would.
    let together = one_cell_vtu(r#"type="UInt8" Name="types" format="binary">AQAAAAo="#, "");
    let g = read(together.as_bytes(), TetFormat::Vtu).unwrap();
    assert_eq!(g.tets(), &[[0, 1, 2, 3]]);
    assert_eq!(g.values(), &[0.0, 1.0, 2.0, 3.0]);
    // A compressed array whose header decodes short of its words (padding in the header's
    // characters): an error, not a read past the header.
    for text in [
        "AAAAAAAAAAAAAA==",
        "AwAAAAAAAAAAAAAA",
        "AQAAAAAAAAAAAAAAAAAAAA==",
    ] {
        let short = one_cell_vtu(
            &format!(r#"type="UInt8" Name="types" format="binary">{text}"#),
            r#" compressor="vtkZLibDataCompressor""#,
        );
        let e = read(short.as_bytes(), TetFormat::Vtu)
            .unwrap_err()
            .to_string();
        assert!(e.contains("DataArray types"), "{text}: {e}");
        assert!(!e.contains('\n'), "{e}");
    }
}
