//! Volumes: NRRD, NPY and NIfTI reading and writing, grids, resampling, malformed input.

mod common;

use std::io::Write;

use common::*;
use glam::Vec3;
use isokit_field::Grid;
use isokit_io::*;

fn sample_volume() -> Volume {
    let dims = [5, 4, 3];
    let data = (0..60).map(|i| i as f32 * 0.5 - 3.0).collect();
    Volume {
        dims,
        origin: Vec3::new(-1.0, 2.0, 0.25),
        spacing: Vec3::new(0.5, 0.25, 2.0),
        data,
    }
}

#[test]
fn nrrd_round_trips_raw_and_gzip() {
    let dir = TempDir::new("nrrd-rt");
    let v = sample_volume();
    let p = dir.path("v.nrrd");
    write_volume(&p, &v).unwrap();
    let text = read_bytes(&p);
    assert!(text.starts_with(b"NRRD0004\n"));
    assert!(String::from_utf8_lossy(&text).contains("encoding: gzip"));
    assert_eq!(read_volume(&p).unwrap(), v);
    let p = dir.path("raw.NRRD");
    write_nrrd_raw(&p, &v).unwrap();
    assert_eq!(read_volume(&p).unwrap(), v);
}

#[test]
fn npy_round_trip_and_layout() {
    let dir = TempDir::new("npy-rt");
    let v = sample_volume();
    let p = dir.path("v.npy");
    write_volume(&p, &v).unwrap();
    let a = read_npy(&p).unwrap();
    assert_eq!(a.shape, vec![3, 4, 5], "(nz, ny, nx)");
    assert_eq!(a.data[1], v.data[1] as f64, "x fastest");
    let r = read_volume(&p).unwrap();
    assert_eq!(
        (r.dims, r.origin, r.spacing),
        ([5, 4, 3], Vec3::ZERO, Vec3::ONE)
    );
    assert_eq!(r.data, v.data);
    // The header is padded to 64 bytes.
    let b = read_bytes(&p);
    let hlen = u16::from_le_bytes([b[8], b[9]]) as usize;
    assert_eq!((10 + hlen) % 64, 0);
}

/// A .npy file built by hand.
fn npy(descr: &str, fortran: bool, shape: &str, body: &[u8]) -> Vec<u8> {
    let mut h = format!(
        "{{'descr': '{descr}', 'fortran_order': {}, 'shape': {shape}, }}",
        if fortran { "True" } else { "False" }
    );
    while (10 + h.len() + 1) % 64 != 0 {
        h.push(' ');
    }
    h.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(h.len() as u16).to_le_bytes());
    out.extend_from_slice(h.as_bytes());
    out.extend_from_slice(body);
    out
}

#[test]
fn npy_dtypes_and_query_points() {
    let pts = [1.5f64, -2.0, 3.25, 4.0, 5.0, 6.0];
    let le: Vec<u8> = pts.iter().flat_map(|x| x.to_le_bytes()).collect();
    let be: Vec<u8> = pts.iter().flat_map(|x| (*x as f32).to_be_bytes()).collect();
    for (descr, body) in [("<f8", &le), (">f4", &be)] {
        let a = read_npy_bytes(&npy(descr, false, "(2, 3)", body), "q.npy").unwrap();
        assert_eq!(a.shape, vec![2, 3]);
        assert_eq!(a.data, pts.to_vec(), "{descr}");
        assert_eq!(a.as_points().unwrap()[1], Vec3::new(4.0, 5.0, 6.0));
    }
    let ints: Vec<u8> = [-1i16, 2, 300]
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    let a = read_npy_bytes(&npy("<i2", false, "(3,)", &ints), "i.npy").unwrap();
    assert_eq!(a.data, vec![-1.0, 2.0, 300.0]);
    assert!(a.as_points().is_none());
    let a = read_npy_bytes(&npy("|u1", false, "(2, 1)", &[7, 255]), "u.npy").unwrap();
    assert_eq!(a.data, vec![7.0, 255.0]);
    let e = read_npy_bytes(&npy("<f8", true, "(2, 3)", &le), "f.npy").unwrap_err();
    assert!(e.to_string().contains("Fortran"), "{e}");
    let e = read_npy_bytes(&npy("<c16", false, "(1,)", &le), "c.npy").unwrap_err();
    assert!(matches!(e, IoError::Unsupported { .. }), "{e}");
    let e =
        read_npy_bytes(&npy("<f8", false, "(100000, 100000, 100000)", &le), "h.npy").unwrap_err();
    assert!(e.to_string().contains("needs"), "{e}");
    // A 2-D array is not a volume.
    let e = read_volume_bytes(
        &npy("<f8", false, "(2, 3)", &le),
        VolumeFormat::Npy,
        "2d.npy",
    )
    .unwrap_err();
    assert!(e.to_string().contains("3-D"), "{e}");
    let dir = TempDir::new("npy-w");
    let p = dir.path("q.npy");
    write_npy_f32(&p, &[2, 3], &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).unwrap();
    assert_eq!(read_npy(&p).unwrap().shape, vec![2, 3]);
    assert!(write_npy_f32(&p, &[2, 2], &[1.0]).is_err());
}

#[test]
fn nrrd_header_variants() {
    // ASCII encoding, big-endian ignored, comments, key/value pairs, spacings, axis mins.
    let text = "NRRD0005\n# comment\ntype: unsigned short\ndimension: 3\nsizes: 2 1 2\n\
        spacings: 0.5 1 2\naxis mins: 1 2 3\nencoding: ascii\nmy key:=some: value\n\n1 2\n3 4\n";
    let v = read_volume_bytes(text.as_bytes(), VolumeFormat::Nrrd, "a.nrrd").unwrap();
    assert_eq!(v.dims, [2, 1, 2]);
    assert_eq!(v.data, vec![1.0, 2.0, 3.0, 4.0]);
    assert_eq!(v.spacing, Vec3::new(0.5, 1.0, 2.0));
    assert_eq!(v.origin, Vec3::new(1.0, 2.0, 3.0));

    // Raw big-endian int16 with a negative space direction on x (flipped on read).
    let mut b = b"NRRD0004\ntype: short\ndimension: 3\nspace: left-posterior-superior\nsizes: 3 1 1\n\
        space directions: (-2,0,0) (0,1,0) (0,0,1)\nspace origin: (10,0,0)\nendian: big\nencoding: raw\n\n"
        .to_vec();
    for x in [1i16, 2, 3] {
        b.extend_from_slice(&x.to_be_bytes());
    }
    let v = read_volume_bytes(&b, VolumeFormat::Nrrd, "b.nrrd").unwrap();
    assert_eq!(v.data, vec![3.0, 2.0, 1.0]);
    assert_eq!(v.spacing.x, 2.0);
    assert_eq!(v.origin.x, 6.0);

    // Rotated grids are refused clearly.
    let rot = String::from_utf8_lossy(&b).replace("(-2,0,0) (0,1,0)", "(0,1,0) (-2,0,0)");
    let e = read_volume_bytes(rot.as_bytes(), VolumeFormat::Nrrd, "r.nrrd").unwrap_err();
    assert!(e.to_string().contains("axis-aligned"), "{e}");
    // Header promising a huge volume: refused before allocating.
    for sizes in ["100000 100000 100000", "2000 2000 2000"] {
        let h = format!(
            "NRRD0004\ntype: float\ndimension: 3\nsizes: {sizes}\nencoding: raw\n\n\0\0\0\0"
        );
        let e = read_volume_bytes(h.as_bytes(), VolumeFormat::Nrrd, "h.nrrd").unwrap_err();
        assert!(e.to_string().starts_with("h.nrrd: NRRD:"), "{e}");
    }
    let h = "NRRD0004\ntype: float\ndimension: 3\nsizes: 2000 2000 2000\nencoding: gzip\n\n";
    let mut gz = h.as_bytes().to_vec();
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    enc.write_all(&[0u8; 1000]).unwrap();
    gz.extend_from_slice(&enc.finish().unwrap());
    assert!(read_volume_bytes(&gz, VolumeFormat::Nrrd, "g.nrrd").is_err());
}

#[test]
fn nrrd_key_values_are_written_and_read_back_without_the_data() {
    let dir = TempDir::new("nrrd-kv");
    let p = dir.path("s.nrrd");
    let v = sample_volume();
    let pairs = [
        ("lattice", "spherical"),
        ("r-range", "1,1.3"),
        ("note", "a: b:=c"),
    ];
    write_nrrd_key_values(&p, &v, NrrdEncoding::Gzip, &pairs).unwrap();
    let got = read_nrrd_key_values(&p).unwrap();
    let want: Vec<(String, String)> = pairs
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    assert_eq!(got, want);
    assert_eq!(read_volume(&p).unwrap().data, v.data);
    // A field whose value holds ":=" is not a key/value pair; the header ends at the blank
    // line, so data that looks like a pair is not read.
    let q = dir.path("t.nrrd");
    std::fs::write(
        &q,
        "NRRD0004\ncontent: a:=b\nk:=v\n\nx:=not a header line\n",
    )
    .unwrap();
    assert_eq!(
        read_nrrd_key_values(&q).unwrap(),
        vec![("k".into(), "v".into())]
    );
    for bad in [
        ("", "x"),
        ("a:=b", "x"),
        ("k", "line\nbreak"),
        ("#k", "x"),
        ("a: b", "x"),
    ] {
        let e = write_nrrd_key_values(&p, &v, NrrdEncoding::Raw, &[bad]).unwrap_err();
        assert!(!e.to_string().contains('\n'), "{e}");
    }
    // The file is unchanged by the refused writes.
    assert_eq!(read_nrrd_key_values(&p).unwrap(), want);
    std::fs::write(&q, "P6\n").unwrap();
    assert!(read_nrrd_key_values(&q).is_err());
}

#[test]
fn nhdr_with_detached_data() {
    let dir = TempDir::new("nhdr");
    let v = sample_volume();
    let raw: Vec<u8> = v.data.iter().flat_map(|x| x.to_le_bytes()).collect();
    let mut with_skip = vec![9u8; 16];
    with_skip.extend_from_slice(&raw);
    std::fs::write(dir.path("v.raw"), &with_skip).unwrap();
    let h = "NRRD0004\ntype: float\ndimension: 3\nsizes: 5 4 3\nspacings: 0.5 0.25 2\n\
        space origin: (-1, 2, 0.25)\nendian: little\nencoding: raw\nbyte skip: 16\ndata file: v.raw\n";
    let p = dir.path("v.nhdr");
    std::fs::write(&p, h).unwrap();
    assert_eq!(read_volume(&p).unwrap(), v);
    let h2 = h.replace("byte skip: 16", "byte skip: -1");
    std::fs::write(&p, h2).unwrap();
    assert_eq!(read_volume(&p).unwrap(), v);
    std::fs::remove_file(dir.path("v.raw")).unwrap();
    let e = read_volume(&p).unwrap_err().to_string();
    assert!(e.contains("v.nhdr") && e.contains("v.raw"), "{e}");
}

/// A NIfTI-1 file built by hand: int16 samples with scl_slope, little or big endian,
/// pixdim (0.5, 0.25, 2) and an sform of the same diagonal translated to (−10, 20, 30).
fn nifti(big: bool, dims: [i16; 3], data: &[i16], slope: f32, inter: f32) -> Vec<u8> {
    let mut sform = [[0.0f32; 4]; 3];
    for (a, s) in [0.5, 0.25, 2.0].into_iter().enumerate() {
        sform[a][a] = s;
    }
    sform[0][3] = -10.0;
    sform[1][3] = 20.0;
    sform[2][3] = 30.0;
    nifti_with(big, dims, data, slope, inter, Some(sform))
}

/// [`nifti`] with a chosen sform (rows srow_x, srow_y, srow_z), or none (sform_code 0).
fn nifti_with(
    big: bool,
    dims: [i16; 3],
    data: &[i16],
    slope: f32,
    inter: f32,
    sform: Option<[[f32; 4]; 3]>,
) -> Vec<u8> {
    let mut h = vec![0u8; 352];
    let put_i32 = |h: &mut Vec<u8>, o: usize, v: i32| {
        h[o..o + 4].copy_from_slice(&if big {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        })
    };
    let put_i16 = |h: &mut Vec<u8>, o: usize, v: i16| {
        h[o..o + 2].copy_from_slice(&if big {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        })
    };
    let put_f32 = |h: &mut Vec<u8>, o: usize, v: f32| {
        h[o..o + 4].copy_from_slice(&if big {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        })
    };
    put_i32(&mut h, 0, 348);
    put_i16(&mut h, 40, 3);
    for (a, d) in dims.iter().enumerate() {
        put_i16(&mut h, 42 + 2 * a, *d);
    }
    put_i16(&mut h, 70, 4); // int16
    put_i16(&mut h, 72, 16);
    for (a, s) in [1.0f32, 0.5, 0.25, 2.0].iter().enumerate() {
        put_f32(&mut h, 76 + 4 * a, *s);
    }
    put_f32(&mut h, 108, 352.0);
    put_f32(&mut h, 112, slope);
    put_f32(&mut h, 116, inter);
    if let Some(rows) = sform {
        put_i16(&mut h, 254, 1); // sform_code
        for (r, row) in rows.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                put_f32(&mut h, 280 + 16 * r + 4 * c, *v);
            }
        }
    }
    h[344..348].copy_from_slice(b"n+1\0");
    for v in data {
        h.extend_from_slice(&if big {
            v.to_be_bytes()
        } else {
            v.to_le_bytes()
        });
    }
    h
}

#[test]
fn nifti_nii_and_nii_gz() {
    let dir = TempDir::new("nifti");
    let data: Vec<i16> = (0..24).map(|i| i * 3 - 10).collect();
    let want: Vec<f32> = data.iter().map(|&v| v as f32 * 2.0 + 1.0).collect();
    for big in [false, true] {
        let bytes = nifti(big, [4, 3, 2], &data, 2.0, 1.0);
        let p = dir.path("a.nii");
        std::fs::write(&p, &bytes).unwrap();
        let v = read_volume(&p).unwrap();
        assert_eq!(v.dims, [4, 3, 2]);
        assert_eq!(v.spacing, Vec3::new(0.5, 0.25, 2.0));
        assert_eq!(v.origin, Vec3::new(-10.0, 20.0, 30.0));
        assert_eq!(v.data, want);

        let p = dir.path("a.nii.gz");
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        enc.write_all(&bytes).unwrap();
        std::fs::write(&p, enc.finish().unwrap()).unwrap();
        assert_eq!(read_volume(&p).unwrap(), v);
        assert_eq!(VolumeFormat::from_path(&p).unwrap(), VolumeFormat::NiftiGz);
    }
    // Slope 0 means no scaling.
    let v = read_volume_bytes(
        &nifti(false, [4, 3, 2], &data, 0.0, 5.0),
        VolumeFormat::Nifti,
        "s.nii",
    )
    .unwrap();
    assert_eq!(v.data[0], -10.0);
    // Huge dims: refused before allocating (too large, or not present in the file).
    for dims in [[32767, 32767, 32767], [1000, 1000, 1000]] {
        let e = read_volume_bytes(
            &nifti(false, dims, &data, 1.0, 0.0),
            VolumeFormat::Nifti,
            "h.nii",
        )
        .unwrap_err();
        assert!(e.to_string().starts_with("h.nii: NIfTI:"), "{e}");
    }
    hammer(
        &nifti(true, [4, 3, 2], &data, 2.0, 1.0),
        |b| read_volume_bytes(b, VolumeFormat::Nifti, "f.nii"),
        check_volume,
    );
}

/// Sets bytes of a little-endian header.
fn put_le(h: &mut [u8], o: usize, v: &[u8]) {
    h[o..o + v.len()].copy_from_slice(v);
}

/// A mirrored x axis (sform diagonal (−2, 2, 2), common in radiological images): voxel i
/// lies at x = x0 − 2i. The reader flips x so the spacing is positive, the origin is the
/// minimum corner and every sample keeps its world position.
#[test]
fn nifti_negative_directions_are_flipped_not_dropped() {
    let dims = [4i16, 3, 2];
    let data: Vec<i16> = (0..24).collect();
    let x0 = 5.0f32;
    let sform = [
        [-2.0, 0.0, 0.0, x0],
        [0.0, 2.0, 0.0, -1.0],
        [0.0, 0.0, 2.0, 7.0],
    ];
    let v = read_volume_bytes(
        &nifti_with(false, dims, &data, 1.0, 0.0, Some(sform)),
        VolumeFormat::Nifti,
        "m.nii",
    )
    .unwrap();
    assert_eq!(v.spacing, Vec3::splat(2.0));
    assert_eq!(v.origin, Vec3::new(x0 - 2.0 * 3.0, -1.0, 7.0));
    for k in 0..2 {
        for j in 0..3 {
            for i in 0..4 {
                // File voxel (i, j, k) sits at x = x0 − 2i, i.e. at flipped index 3 − i.
                let want = data[i + 4 * (j + 3 * k)] as f32;
                let got = v.data[(3 - i) + 4 * (j + 3 * k)];
                assert_eq!(got, want, "voxel {i},{j},{k}");
                let world = x0 - 2.0 * i as f32;
                assert_eq!(v.origin.x + v.spacing.x * (3 - i) as f32, world);
            }
        }
    }

    // The same through the qform: a 180° turn about z (quaternion d = 1) flips x and y,
    // qfac = −1 flips z.
    let mut bytes = nifti_with(false, dims, &data, 1.0, 0.0, None);
    put_le(&mut bytes, 252, &1i16.to_le_bytes()); // qform_code
    put_le(&mut bytes, 264, &1.0f32.to_le_bytes()); // quatern_d
    put_le(&mut bytes, 76, &(-1.0f32).to_le_bytes()); // qfac
    for (o, x) in [(268, 1.0f32), (272, 2.0), (276, 3.0)] {
        put_le(&mut bytes, o, &x.to_le_bytes());
    }
    let q = read_volume_bytes(&bytes, VolumeFormat::Nifti, "q.nii").unwrap();
    assert_eq!(q.spacing, Vec3::new(0.5, 0.25, 2.0));
    assert_eq!(q.origin, Vec3::new(1.0 - 1.5, 2.0 - 0.5, 3.0 - 2.0));
    for k in 0..2 {
        for j in 0..3 {
            for i in 0..4 {
                let want = data[i + 4 * (j + 3 * k)] as f32;
                assert_eq!(q.data[(3 - i) + 4 * ((2 - j) + 3 * (1 - k))], want);
            }
        }
    }

    // Neither sform nor qform: pixdim only, origin 0.
    let p = read_volume_bytes(
        &nifti_with(false, dims, &data, 1.0, 0.0, None),
        VolumeFormat::Nifti,
        "p.nii",
    )
    .unwrap();
    assert_eq!(
        (p.origin, p.spacing),
        (Vec3::ZERO, Vec3::new(0.5, 0.25, 2.0))
    );
    assert_eq!(p.data, data.iter().map(|&x| x as f32).collect::<Vec<_>>());

    // A rotated grid is refused, clearly, rather than read mirrored or skewed.
    let rotated = [
        [0.0, -2.0, 0.0, 0.0],
        [2.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 2.0, 0.0],
    ];
    let e = read_volume_bytes(
        &nifti_with(false, dims, &data, 1.0, 0.0, Some(rotated)),
        VolumeFormat::Nifti,
        "r.nii",
    )
    .unwrap_err();
    assert!(matches!(e, IoError::Unsupported { .. }), "{e}");
    assert!(e.to_string().contains("not axis-aligned"), "{e}");
}

fn check_volume(v: &Volume) {
    assert_eq!(v.data.len(), v.dims.iter().product::<usize>());
}

#[test]
fn grids_and_resampling() {
    let g = Grid::from_data(
        [3, 2, 2],
        Vec3::new(1.0, 2.0, 3.0),
        0.5,
        (0..12).map(|i| i as f32).collect(),
    )
    .unwrap();
    let v = Volume::from_grid(&g);
    assert_eq!(v.clone().into_grid().unwrap(), g);
    // Anisotropic: a clear error naming the spacings.
    let e = sample_volume().into_grid().unwrap_err().to_string();
    assert!(
        e.contains("0.5") && e.contains("0.25") && e.contains("anisotropic"),
        "{e}"
    );
    // Nearly isotropic within 1e-4 is accepted.
    let mut w = v.clone();
    w.spacing.y *= 1.0 + 5e-5;
    assert!(w.into_grid().is_ok());
    // Resampling a linear field is exact (trilinear reproduces linear functions).
    let mut lin = sample_volume();
    let [nx, ny, _] = lin.dims;
    for (n, d) in lin.data.iter_mut().enumerate() {
        let p = lin.origin
            + lin.spacing
                * Vec3::new(
                    (n % nx) as f32,
                    ((n / nx) % ny) as f32,
                    (n / (nx * ny)) as f32,
                );
        *d = p.x - 2.0 * p.y + 0.5 * p.z;
    }
    let r = lin.resample_uniform(0.25).unwrap();
    assert_eq!(r.dims(), [9, 4, 17]);
    for ([i, j, k], val) in r.iter() {
        let p = r.position(i, j, k);
        assert!(
            (val - (p.x - 2.0 * p.y + 0.5 * p.z)).abs() < 1e-4,
            "{val} at {p}"
        );
    }
    assert!(lin.resample_uniform(0.0).is_err());
    assert!(lin.resample_uniform(f32::NAN).is_err());
    assert!(lin.resample_uniform(1e-9).is_err(), "too many samples");
    let mut broken = lin.clone();
    broken.data.pop();
    assert!(matches!(broken.into_grid(), Err(IoError::InvalidVolume(_))));
}

#[test]
fn writers_refuse_bad_volumes() {
    let dir = TempDir::new("vol-bad");
    let mut v = sample_volume();
    v.data.pop();
    for name in ["a.nrrd", "a.npy"] {
        assert!(matches!(
            write_volume(&dir.path(name), &v),
            Err(IoError::InvalidInput { .. })
        ));
    }
    assert!(matches!(
        write_volume(&dir.path("a.nii"), &sample_volume()),
        Err(IoError::UnknownFormat { .. })
    ));
    assert!(dir.entries().is_empty());
}

#[test]
fn malformed_volumes_never_panic() {
    let dir = TempDir::new("vol-fuzz");
    let v = sample_volume();
    let p = dir.path("g.nrrd");
    write_volume(&p, &v).unwrap();
    hammer(
        &read_bytes(&p),
        |b| read_volume_bytes(b, VolumeFormat::Nrrd, "g.nrrd"),
        check_volume,
    );
    write_nrrd_raw(&p, &v).unwrap();
    hammer(
        &read_bytes(&p),
        |b| read_volume_bytes(b, VolumeFormat::Nrrd, "r.nrrd"),
        check_volume,
    );
    let p = dir.path("v.npy");
    write_volume(&p, &v).unwrap();
    let valid = read_bytes(&p);
    hammer(
        &valid,
        |b| read_volume_bytes(b, VolumeFormat::Npy, "v.npy"),
        check_volume,
    );
    hammer(
        &valid,
        |b| read_npy_bytes(b, "v.npy"),
        |a| {
            assert_eq!(a.data.len(), a.shape.iter().product::<usize>());
        },
    );
    let data: Vec<i16> = (0..24).collect();
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    enc.write_all(&nifti(false, [4, 3, 2], &data, 1.0, 0.0))
        .unwrap();
    hammer(
        &enc.finish().unwrap(),
        |b| read_volume_bytes(b, VolumeFormat::NiftiGz, "z.nii.gz"),
        check_volume,
    );
}
