//! Point clouds: PLY and XYZ round trips, detection, malformed input.

mod common;

use common::*;
use glam::Vec3;
use isokit_field::rng::SplitMix64;
use isokit_io::*;

fn cloud(n: usize, normals: bool) -> PointCloud {
    let mut rng = SplitMix64::new(7);
    let points: Vec<Vec3> = (0..n)
        .map(|_| rng.point_in(Vec3::splat(-1e3), Vec3::splat(1e3)) * 1e-3)
        .collect();
    let normals = normals.then(|| points.iter().map(|p| p.normalize_or_zero()).collect());
    PointCloud { points, normals }
}

#[test]
fn round_trips_with_and_without_normals() {
    let dir = TempDir::new("pts-rt");
    for normals in [false, true] {
        let c = cloud(500, normals);
        for name in ["c.ply", "c.xyz", "C.XYZ"] {
            let p = dir.path(name);
            write_points(&p, &c).unwrap();
            let r = read_points(&p).unwrap();
            assert_eq!(r, c, "{name} normals={normals}");
            let kind = detect_kind(&p).unwrap();
            assert_eq!(kind, FileKind::PointCloud);
        }
    }
    let c = PointCloud::default();
    write_points(&dir.path("e.ply"), &c).unwrap();
    assert_eq!(read_points(&dir.path("e.ply")).unwrap(), c);
}

#[test]
fn mesh_ply_reads_as_points_and_is_detected_as_mesh() {
    let dir = TempDir::new("pts-mesh");
    let p = dir.path("m.ply");
    let m = icosphere(1);
    write_mesh(&p, &m).unwrap();
    assert_eq!(detect_kind(&p).unwrap(), FileKind::Mesh);
    let c = read_points(&p).unwrap();
    assert_eq!(c.points, m.positions);
    // A mesh's PLY carries its vertex normals (it had none before they were written).
    assert_eq!(c.normals, Some(isokit_io::vertex_normals(&m)));
}

#[test]
fn xyz_details() {
    let text = "# header\n1 2 3\n\n4,5,6 # trailing\n 7 8 9\n";
    let c = read_points_bytes(text.as_bytes(), PointFormat::Xyz, "a.xyz").unwrap();
    assert_eq!(c.points.len(), 3);
    assert_eq!(c.points[1], Vec3::new(4.0, 5.0, 6.0));
    for bad in [
        "1 2 3\n1 2 3 4 5 6\n",
        "1 2\n",
        "1 2 3 4 5 6 7\n",
        "1 2 x\n",
    ] {
        let e = read_points_bytes(bad.as_bytes(), PointFormat::Xyz, "bad.xyz").unwrap_err();
        assert!(e.to_string().starts_with("bad.xyz: XYZ line"), "{e}");
    }
}

#[test]
fn writers_check_normal_count() {
    let dir = TempDir::new("pts-bad");
    let mut c = cloud(10, true);
    c.normals.as_mut().unwrap().pop();
    for name in ["a.ply", "a.xyz"] {
        assert!(matches!(
            write_points(&dir.path(name), &c),
            Err(IoError::InvalidInput { .. })
        ));
    }
    assert!(dir.entries().is_empty());
}

#[test]
fn malformed_clouds_never_panic() {
    let dir = TempDir::new("pts-fuzz");
    let c = cloud(200, true);
    for (name, f) in [("a.ply", PointFormat::Ply), ("a.xyz", PointFormat::Xyz)] {
        let p = dir.path(name);
        write_points(&p, &c).unwrap();
        let valid = read_bytes(&p);
        hammer(
            &valid,
            |b| read_points_bytes(b, f, name),
            |r| {
                if let Some(n) = &r.normals {
                    assert_eq!(n.len(), r.points.len());
                }
            },
        );
    }
    let huge = b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty double x\nproperty double y\nproperty double z\nend_header\n";
    assert!(read_points_bytes(huge, PointFormat::Ply, "h.ply").is_err());
}
