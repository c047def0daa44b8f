//! PNG and EXR output, sRGB conversion, atomic writes.

mod common;

use common::*;
use isokit_io::*;

#[test]
fn png_round_trip() {
    let dir = TempDir::new("png");
    let (w, h) = (7u32, 5u32);
    let rgba: Vec<u8> = (0..w * h * 4).map(|i| (i * 37 % 256) as u8).collect();
    let p = dir.path("a.png");
    write_png(&p, w, h, &rgba).unwrap();
    assert_eq!(read_png(&p).unwrap(), (w, h, rgba.clone()));
    assert_eq!(detect_kind(&p).unwrap(), FileKind::Image);
    // Wrong length: an error naming the file, and nothing written.
    let e = write_png(&dir.path("b.png"), w, h, &rgba[1..]).unwrap_err();
    assert!(e.to_string().contains("b.png"), "{e}");
    assert!(!dir.path("b.png").exists());
}

#[test]
fn png_gray_and_rgb_become_rgba() {
    let dir = TempDir::new("png-gray");
    for (ct, px, want) in [
        (
            png::ColorType::Grayscale,
            vec![10u8, 200],
            vec![10u8, 10, 10, 255, 200, 200, 200, 255],
        ),
        (
            png::ColorType::Rgb,
            vec![1, 2, 3, 4, 5, 6],
            vec![1, 2, 3, 255, 4, 5, 6, 255],
        ),
        (
            png::ColorType::GrayscaleAlpha,
            vec![9, 8, 7, 6],
            vec![9, 9, 9, 8, 7, 7, 7, 6],
        ),
    ] {
        let mut buf = Vec::new();
        {
            let mut e = png::Encoder::new(&mut buf, 2, 1);
            e.set_color(ct);
            e.set_depth(png::BitDepth::Eight);
            e.write_header().unwrap().write_image_data(&px).unwrap();
        }
        let p = dir.path("g.png");
        std::fs::write(&p, &buf).unwrap();
        assert_eq!(read_png(&p).unwrap(), (2, 1, want));
    }
}

#[test]
fn malformed_png_never_panics() {
    let dir = TempDir::new("png-fuzz");
    let p = dir.path("a.png");
    let rgba: Vec<u8> = (0..16 * 16 * 4).map(|i| (i % 251) as u8).collect();
    write_png(&p, 16, 16, &rgba).unwrap();
    hammer(
        &read_bytes(&p),
        |b| read_png_bytes(b, "f.png"),
        |(w, h, d)| {
            assert_eq!(d.len(), *w as usize * *h as usize * 4);
        },
    );
}

#[test]
fn png_header_promising_huge_size_fails_fast() {
    let chunk = |ty: &[u8], data: &[u8]| {
        let mut c = (data.len() as u32).to_be_bytes().to_vec();
        c.extend_from_slice(ty);
        c.extend_from_slice(data);
        let mut crc = flate2::Crc::new();
        crc.update(ty);
        crc.update(data);
        c.extend_from_slice(&crc.sum().to_be_bytes());
        c
    };
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&100_000u32.to_be_bytes());
    ihdr.extend_from_slice(&100_000u32.to_be_bytes());
    ihdr.extend_from_slice(&[8, 6, 0, 0, 0]);
    let mut f = b"\x89PNG\r\n\x1a\n".to_vec();
    f.extend(chunk(b"IHDR", &ihdr));
    f.extend(chunk(
        b"IDAT",
        &[0x78, 0x9c, 0x03, 0x00, 0x00, 0x00, 0x00, 0x01],
    ));
    f.extend(chunk(b"IEND", &[]));
    let t = std::time::Instant::now();
    let e = read_png_bytes(&f, "huge.png").unwrap_err();
    assert!(e.to_string().contains("promises"), "{e}");
    assert!(t.elapsed().as_secs_f32() < 1.0);
}

#[test]
fn srgb_conversions() {
    assert_eq!(linear_to_srgb8(0.0), 0);
    assert_eq!(linear_to_srgb8(1.0), 255);
    assert_eq!(linear_to_srgb8(2.0), 255);
    assert_eq!(linear_to_srgb8(-1.0), 0);
    assert_eq!(linear_to_srgb8(f32::NAN), 0);
    assert_eq!(linear_to_srgb8(0.5), 188);
    for v in 0..=255u8 {
        assert_eq!(linear_to_srgb8(srgb8_to_linear(v)), v);
    }
}

/// The table-driven encoding is the formula's bit for bit: every float within 2¹³ ulps of
/// each code's start (where a non-monotone formula or a wrong threshold would show), and a
/// stride through all of `[0, 1]`.
#[test]
fn srgb_encoding_matches_the_formula() {
    let check = |bits: u32| {
        let v = f32::from_bits(bits);
        assert_eq!(
            linear_to_srgb8(v),
            linear_to_srgb8_formula(v),
            "v = {v:e} ({bits:#x})"
        );
    };
    // Where the code changes along a coarse walk (a search of the test's own), then every
    // float around there.
    let mut last = 0;
    for b in (0..=1f32.to_bits()).step_by(1 << 12) {
        let code = linear_to_srgb8_formula(f32::from_bits(b));
        if code != last {
            for b in b.saturating_sub(1 << 13)..=(b + (1 << 12)).min(1f32.to_bits()) {
                check(b);
            }
            last = code;
        }
    }
    for b in (0..=1f32.to_bits()).step_by(997) {
        check(b);
    }
    for v in [
        f32::MIN_POSITIVE,
        1e-30,
        0.003_130_8,
        0.04,
        0.5,
        0.999_999,
        1.0,
        f32::INFINITY,
    ] {
        check(v.to_bits());
    }
}

#[test]
fn exr_channels_read_back() {
    use exr::prelude::*;
    let dir = TempDir::new("exr");
    let (w, h) = (6usize, 4usize);
    let z: Vec<f32> = (0..w * h).map(|i| i as f32 * 0.25).collect();
    let nx: Vec<f32> = (0..w * h).map(|i| -(i as f32)).collect();
    let p = dir.path("g.exr");
    write_exr(&p, w, h, &[("Z", &z), ("N.X", &nx)]).unwrap();
    assert_eq!(detect_kind(&p).unwrap(), FileKind::Image);
    let img = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .non_parallel()
        .from_file(&p)
        .unwrap();
    let layer = &img.layer_data;
    assert_eq!(layer.size, Vec2(w, h));
    let mut names = Vec::new();
    for ch in &layer.channel_data.list {
        let name = ch.name.to_string();
        let vals: Vec<f32> = ch.sample_data.values_as_f32().collect();
        match name.as_str() {
            // Row 0 at the top: sample order is the same as ours.
            "Z" => assert_eq!(vals, z),
            "N.X" => assert_eq!(vals, nx),
            other => panic!("unexpected channel {other}"),
        }
        names.push(name);
    }
    names.sort();
    assert_eq!(names, ["N.X", "Z"]);

    for bad in [
        vec![("Z", &z[1..])],
        vec![("Z", &z[..]), ("Z", &z[..])],
        vec![("", &z[..])],
        vec![("Zé€", &z[..])],
    ] {
        let e = write_exr(&dir.path("bad.exr"), w, h, &bad).unwrap_err();
        assert!(matches!(e, IoError::InvalidInput { .. }), "{e}");
    }
    assert!(write_exr(&dir.path("bad.exr"), w, h, &[]).is_err());
    assert!(!dir.path("bad.exr").exists());
}

#[test]
fn exr_header_info() {
    let dir = TempDir::new("exr-info");
    let (w, h) = (7usize, 3usize);
    let z = vec![1.0f32; w * h];
    let p = dir.path("g.exr");
    write_exr(&p, w, h, &[("Z", &z), ("N.X", &z), ("N.Y", &z)]).unwrap();
    let info = read_exr_info(&p).unwrap();
    assert_eq!((info.width, info.height, info.layers), (w, h, 1));
    let mut names = info.channels.clone();
    names.sort();
    assert_eq!(names, ["N.X", "N.Y", "Z"]);
    let bytes = read_bytes(&p);
    assert_eq!(read_exr_info_bytes(&bytes, "g.exr").unwrap(), info);
    let e = read_exr_info(&dir.path("missing.exr")).unwrap_err();
    assert!(matches!(e, IoError::Io { .. }), "{e}");
    let e = read_exr_info_bytes(b"not an exr file", "x.exr").unwrap_err();
    assert!(e.to_string().starts_with("x.exr: "), "{e}");
    hammer(
        &bytes,
        |b| read_exr_info_bytes(b, "f.exr"),
        |i| assert!(i.layers >= 1),
    );
}

#[test]
fn atomic_write_keeps_existing_file_on_failure() {
    let dir = TempDir::new("atomic");
    let p = dir.path("keep.txt");
    std::fs::write(&p, b"precious").unwrap();
    let e = atomic_write(&p, |w| {
        w.write_all(b"half of the new cont")?;
        Err(std::io::Error::other("simulated failure"))
    })
    .unwrap_err();
    // The message names the file; the reason is the source, not repeated in the message
    // (so a chain printed as "message: source" says it once).
    assert!(e.to_string().ends_with("keep.txt"), "{e}");
    let source = std::error::Error::source(&e).expect("the OS error is the source");
    assert!(source.to_string().contains("simulated"), "{source}");
    assert!(!e.to_string().contains("simulated"), "{e}");
    assert_eq!(std::fs::read(&p).unwrap(), b"precious");
    assert_eq!(dir.entries(), ["keep.txt"], "temporary file left behind");
    atomic_write(&p, |w| w.write_all(b"new")).unwrap();
    assert_eq!(std::fs::read(&p).unwrap(), b"new");
    assert_eq!(dir.entries(), ["keep.txt"]);
    // A missing directory and a directory as target are errors naming the path.
    assert!(atomic_write(&dir.path("no/such/dir.txt"), |_| Ok(())).is_err());
    let e = atomic_write(&dir.0, |_| Ok(())).unwrap_err();
    assert!(e.to_string().contains(&*dir.0.to_string_lossy()), "{e}");
}

#[test]
fn detect_kind_by_extension() {
    let dir = TempDir::new("kind");
    // OBJ files are looked into: faces make a mesh, vertices alone a point cloud.
    std::fs::write(dir.path("a.OBJ"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    std::fs::write(dir.path("b.obj"), "v 0 0 0\nv 1 0 0\n").unwrap();
    assert_eq!(
        detect_kind(&dir.path("b.obj")).unwrap(),
        FileKind::PointCloud
    );
    for (name, kind) in [
        ("a.OBJ", FileKind::Mesh),
        ("a.glb", FileKind::Mesh),
        ("a.stl", FileKind::Mesh),
        ("a.xyz", FileKind::PointCloud),
        ("a.nii.gz", FileKind::Volume),
        ("a.inr", FileKind::Volume),
        ("a.INR.gz", FileKind::Volume),
        ("a.NRRD", FileKind::Volume),
        ("a.npy", FileKind::Volume),
        ("a.exr", FileKind::Image),
    ] {
        assert_eq!(detect_kind(&dir.path(name)).unwrap(), kind, "{name}");
    }
    assert!(matches!(
        detect_kind(&dir.path("a.txt")),
        Err(IoError::UnknownFormat { .. })
    ));
    assert!(matches!(
        detect_kind(&dir.path("missing.ply")),
        Err(IoError::Io { .. })
    ));
}
