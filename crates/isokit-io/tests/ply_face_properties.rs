//! Named scalar face properties of PLY files (`region_front`, `region_back`): ASCII and
//! binary, before and after the index list, a polygon's value for each of its triangles,
//! and clear errors for what is missing or of the wrong kind.

use isokit_io::read_ply_face_properties;
use std::path::PathBuf;

fn write(name: &str, bytes: &[u8]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("isokit-ply-props-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

const NAMES: [&str; 2] = ["region_front", "region_back"];

#[test]
fn ascii_properties_after_the_list_repeat_for_a_polygons_triangles() {
    let text = "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n\
                property float z\nelement face 2\nproperty list uchar int vertex_indices\n\
                property int region_front\nproperty uchar region_back\nend_header\n\
                0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n4 0 1 2 3 7 2\n3 0 1 4 5 0\n";
    let (mesh, v) = read_ply_face_properties(&write("a.ply", text.as_bytes()), &NAMES).unwrap();
    assert_eq!(mesh.triangles.len(), 3);
    assert_eq!(v[0], [7.0, 7.0, 5.0]);
    assert_eq!(v[1], [2.0, 2.0, 0.0]);
}

#[test]
fn binary_properties_before_the_list() {
    let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
                  property float y\nproperty float z\nelement face 1\nproperty short region_back\n\
                  property list uchar int vertex_indices\nproperty int region_front\nend_header\n"
        .to_vec();
    for p in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for x in p {
            b.extend(x.to_le_bytes());
        }
    }
    b.extend(9i16.to_le_bytes());
    b.push(3);
    for i in [0i32, 1, 2] {
        b.extend(i.to_le_bytes());
    }
    b.extend(4i32.to_le_bytes());
    let (mesh, v) = read_ply_face_properties(&write("b.ply", &b), &NAMES).unwrap();
    assert_eq!(mesh.triangles, [[0, 1, 2]]);
    assert_eq!((v[0][0], v[1][0]), (4.0, 9.0));
}

#[test]
fn missing_list_typed_and_faceless_are_refused_by_name() {
    let head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                property float z\n";
    let pts = "0 0 0\n1 0 0\n0 1 0\n";
    let missing = format!(
        "{head}element face 1\nproperty list uchar int vertex_indices\nproperty int region_front\nend_header\n{pts}3 0 1 2 1\n"
    );
    let e = read_ply_face_properties(&write("m.ply", missing.as_bytes()), &NAMES).unwrap_err();
    assert!(
        e.to_string().contains("no scalar property region_back"),
        "{e}"
    );
    let list = format!(
        "{head}element face 1\nproperty list uchar int vertex_indices\nproperty int region_front\nproperty list uchar int region_back\nend_header\n{pts}3 0 1 2 1 1 0\n"
    );
    let e = read_ply_face_properties(&write("l.ply", list.as_bytes()), &NAMES).unwrap_err();
    assert!(e.to_string().contains("region_back"), "{e}");
    let faceless = format!("{head}end_header\n{pts}");
    let e = read_ply_face_properties(&write("f.ply", faceless.as_bytes()), &NAMES).unwrap_err();
    assert!(e.to_string().contains("no face element"), "{e}");
    let e = read_ply_face_properties(&write("x.obj", b"v 0 0 0\n"), &NAMES).unwrap_err();
    assert!(e.to_string().contains("PLY"), "{e}");
}
