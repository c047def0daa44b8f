//! Mesh formats: round trips, glTF built by hand, validation, malformed input.

mod common;

use base64::Engine;
use common::*;
use glam::Vec3;
use isokit_io::*;

fn write_read(dir: &TempDir, name: &str, m: &TriMesh) -> TriMesh {
    let p = dir.path(name);
    write_mesh(&p, m).unwrap();
    read_mesh(&p).unwrap()
}

#[test]
fn round_trips_keep_indices_and_positions() {
    let dir = TempDir::new("mesh-rt");
    let m = icosphere(2);
    for name in ["a.ply", "a.off"] {
        let r = write_read(&dir, name, &m);
        assert_eq!(r, m, "{name}");
    }
    let p = dir.path("ascii.ply");
    write_ply_ascii(&p, &m).unwrap();
    assert_eq!(read_mesh(&p).unwrap(), m);
    // OBJ keeps the vertices in file order, so the mesh reads back as written.
    let r = write_read(&dir, "a.obj", &m);
    assert_eq!(r, m);
    assert!(r.validate().is_clean());
    // Extension case does not matter.
    let r = write_read(&dir, "UPPER.OFF", &m);
    assert_eq!(r, m);
    assert_eq!(
        dir.entries().iter().filter(|e| e.contains(".tmp")).count(),
        0
    );
}

#[test]
fn stl_round_trips_after_welding() {
    let dir = TempDir::new("stl-rt");
    let m = icosphere(2);
    for ascii in [false, true] {
        let p = dir.path(if ascii { "a_ascii.stl" } else { "a.stl" });
        if ascii {
            write_stl_ascii(&p, &m).unwrap();
        } else {
            write_mesh(&p, &m).unwrap();
        }
        let r = read_mesh(&p).unwrap();
        assert_eq!(
            r.positions.len(),
            m.positions.len(),
            "welded back to shared vertices"
        );
        assert_same_geometry(&r, &m);
        let rep = r.validate();
        assert!(rep.watertight && rep.consistently_oriented, "{rep}");
        assert_eq!(rep.euler_characteristic, 2);
    }
}

#[test]
fn binary_stl_starting_with_solid_is_read_as_binary() {
    let dir = TempDir::new("stl-solid");
    let p = dir.path("a.stl");
    write_mesh(&p, &cube()).unwrap();
    let mut b = read_bytes(&p);
    b[..12].copy_from_slice(b"solid cube  ");
    let r = read_mesh_bytes(&b, MeshFormat::Stl, "solid.stl").unwrap();
    assert_same_geometry(&r, &cube());
    // With trailing junk the length test fails, but the binary layout still fits.
    b.extend_from_slice(&[0u8; 7]);
    let r = read_mesh_bytes(&b, MeshFormat::Stl, "solid.stl").unwrap();
    assert_same_geometry(&r, &cube());
}

#[test]
fn writers_refuse_out_of_range_indices_and_leave_no_file() {
    let dir = TempDir::new("mesh-bad");
    let mut m = cube();
    m.triangles.push([0, 1, 99]);
    for name in ["a.obj", "a.ply", "a.stl", "a.off", "a.glb", "a.gltf"] {
        let e = write_mesh(&dir.path(name), &m).unwrap_err();
        assert!(matches!(e, IoError::InvalidInput { .. }), "{e}");
        assert!(e.to_string().contains(name), "{e}");
    }
    assert!(dir.entries().is_empty(), "{:?}", dir.entries());
    // glTF is written now (it was refused as unknown): an unknown extension still is.
    assert!(matches!(
        write_mesh(&dir.path("a.abc"), &cube()),
        Err(IoError::UnknownFormat { .. })
    ));
    assert!(matches!(
        read_mesh(&dir.path("a.xyz")),
        Err(IoError::UnknownFormat { .. })
    ));
}

#[test]
fn ply_variants_are_read() {
    // ASCII with extra properties, an extra element with a list, quads, uint8 counts,
    // double coordinates and a vertex_index name.
    let text = "ply\r\nformat ascii 1.0\r\ncomment hello\r\nobj_info x\r\n\
        element vertex 4\r\nproperty double x\r\nproperty double y\r\nproperty double z\r\n\
        property uchar red\r\nproperty list uchar float extra\r\n\
        element material 1\r\nproperty list int int stuff\r\nproperty float shininess\r\n\
        element face 1\r\nproperty uchar flags\r\nproperty list uint8 uint16 vertex_index\r\n\
        end_header\r\n\
        0 0 0 255 2 9 9\r\n1 0 0 0 0\r\n1 1 0 1 1 5\r\n0 1 0 2 0\r\n\
        3 1 2 3 0.5\r\n\
        7 4 0 1 2 3\r\n";
    let m = read_mesh_bytes(text.as_bytes(), MeshFormat::Ply, "q.ply").unwrap();
    assert_eq!(m.positions.len(), 4);
    assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);

    // The same, binary big-endian, built by hand.
    let mut b = b"ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\n\
        property float y\nproperty float z\nproperty list uchar int junk\n\
        element face 1\nproperty list int uint vertex_indices\nend_header\n"
        .to_vec();
    for (i, p) in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.]]
        .iter()
        .enumerate()
    {
        for x in p {
            b.extend_from_slice(&x.to_be_bytes());
        }
        b.push(i as u8);
        for k in 0..i {
            b.extend_from_slice(&(k as i32).to_be_bytes());
        }
    }
    b.extend_from_slice(&3i32.to_be_bytes());
    for i in [2u32, 1, 0] {
        b.extend_from_slice(&i.to_be_bytes());
    }
    let m = read_mesh_bytes(&b, MeshFormat::Ply, "be.ply").unwrap();
    assert_eq!(m.positions[1], Vec3::X);
    assert_eq!(m.triangles, vec![[2, 1, 0]]);
    // Its header has a face element with a count above zero: a mesh.
    assert!(detect_kind_bytes_ply(&b));
}

fn detect_kind_bytes_ply(b: &[u8]) -> bool {
    let dir = TempDir::new("kind");
    let p = dir.path("k.ply");
    std::fs::write(&p, b).unwrap();
    detect_kind(&p).unwrap() == FileKind::Mesh
}

#[test]
fn off_variants_are_read() {
    let text = "# comment\nCOFF 4 2 0\n\n0 0 0 255 0 0 255\n1 0 0 1 1 1 1\n1 1 0 1 1 1 1 # c\n0 1 0 1 1 1 1\n4 0 1 2 3 255 0 0\n3 0 2 1\n";
    let m = read_mesh_bytes(text.as_bytes(), MeshFormat::Off, "c.off").unwrap();
    assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 2, 1]]);
    let e = read_mesh_bytes(b"4OFF\n1 0 0\n0 0 0 0\n", MeshFormat::Off, "x.off").unwrap_err();
    assert!(matches!(e, IoError::Unsupported { .. }), "{e}");
}

#[test]
fn obj_features() {
    let text = "mtllib x.mtl\no a\nv 0 0 0\nv 1 0 0 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n\
        usemtl m\nf 1/1/1 2/1/1 3/1/1 4/1/1\nl 1 2\no b\nv 5 5 5\nv 6 5 5\nv 5 6 5\nf -3 -2 -1\n";
    let m = read_mesh_bytes(text.as_bytes(), MeshFormat::Obj, "f.obj").unwrap();
    assert_eq!(m.triangles.len(), 3);
    assert_eq!(m.positions.len(), 7);
    check_mesh(&m);
    let e = read_mesh_bytes(b"v 0 0 0\nf 1 2 3\n", MeshFormat::Obj, "bad.obj").unwrap_err();
    assert!(e.to_string().contains("bad.obj"), "{e}");
}

// ---------- glTF ----------

/// What the scene above should produce: the cube scaled by 2 and moved by +10 in x, and the
/// cube mirrored in z (orientation kept by the reader).
fn expected_scene() -> TriMesh {
    let c = cube();
    let mut a = c.clone();
    for p in &mut a.positions {
        *p = *p * 2.0 + Vec3::new(10.0, 0.0, 0.0);
    }
    let mut b = c.clone();
    for p in &mut b.positions {
        p.z = -p.z;
    }
    for t in &mut b.triangles {
        t.swap(1, 2);
    }
    a.append(&b);
    a
}

#[test]
fn glb_with_node_transforms() {
    let (bin, pl, il) = cube_buffer();
    let file = glb(&gltf_json(None, bin.len(), pl, il), &bin);
    let m = read_mesh_bytes(&file, MeshFormat::Glb, "scene.glb").unwrap();
    assert_same_geometry(&m, &expected_scene());
    let rep = m.validate();
    assert_eq!(rep.components, 2);
    assert!(rep.watertight && rep.consistently_oriented, "{rep}");
    hammer(
        &file,
        |b| read_mesh_bytes(b, MeshFormat::Glb, "h.glb"),
        check_mesh,
    );
}

#[test]
fn gltf_with_data_uri_and_external_buffer() {
    let (bin, pl, il) = cube_buffer();
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bin)
    );
    let json = gltf_json(Some(&uri), bin.len(), pl, il);
    let m = read_mesh_bytes(json.as_bytes(), MeshFormat::Gltf, "scene.gltf").unwrap();
    assert_same_geometry(&m, &expected_scene());

    let dir = TempDir::new("gltf-ext");
    std::fs::write(dir.path("cube data.bin"), &bin).unwrap();
    let p = dir.path("scene.GLTF");
    std::fs::write(&p, gltf_json(Some("cube%20data.bin"), bin.len(), pl, il)).unwrap();
    assert_same_geometry(&read_mesh(&p).unwrap(), &expected_scene());
    // A missing buffer file is a clear error naming the glTF file and the buffer.
    std::fs::remove_file(dir.path("cube data.bin")).unwrap();
    let e = read_mesh(&p).unwrap_err().to_string();
    assert!(
        e.contains("scene.GLTF") && e.contains("cube data.bin"),
        "{e}"
    );
    // A buffer name holding a newline (%0A) is shown escaped: the error stays one line.
    std::fs::write(&p, gltf_json(Some("cube%0Adata.bin"), bin.len(), pl, il)).unwrap();
    let e = read_mesh(&p).unwrap_err().to_string();
    assert!(e.contains(r"cube\ndata.bin") && !e.contains('\n'), "{e:?}");
    hammer(
        json.as_bytes(),
        |b| read_mesh_bytes(b, MeshFormat::Gltf, "h.gltf"),
        check_mesh,
    );
}

#[test]
fn gltf_errors() {
    let (bin, pl, il) = cube_buffer();
    // Out-of-range index.
    let mut bad = bin.clone();
    bad[pl..pl + 2].copy_from_slice(&100u16.to_le_bytes());
    let e = read_mesh_bytes(
        &glb(&gltf_json(None, bin.len(), pl, il), &bad),
        MeshFormat::Glb,
        "i.glb",
    )
    .unwrap_err();
    assert!(e.to_string().contains("out of range"), "{e}");
    // An accessor promising far more than the buffer holds.
    let json =
        gltf_json(None, bin.len(), pl, il).replace(r#""count": 8"#, r#""count": 4000000000"#);
    let e = read_mesh_bytes(&glb(&json, &bin), MeshFormat::Glb, "c.glb").unwrap_err();
    assert!(matches!(e, IoError::Malformed { .. }), "{e}");
    // A buffer declaring more than the binary chunk.
    let json = gltf_json(None, bin.len() + 1000, pl, il);
    assert!(read_mesh_bytes(&glb(&json, &bin), MeshFormat::Glb, "l.glb").is_err());
    // A sparse accessor is refused clearly.
    let json = gltf_json(None, bin.len(), pl, il).replace(
        r#""min": [-1,-1,-1]"#,
        r#""sparse": {"count": 1, "indices": {"bufferView": 1, "componentType": 5123}, "values": {"bufferView": 0}}, "min": [-1,-1,-1]"#,
    );
    let e = read_mesh_bytes(&glb(&json, &bin), MeshFormat::Glb, "s.glb").unwrap_err();
    assert!(e.to_string().contains("sparse"), "{e}");
    // A node cycle.
    let json = gltf_json(None, bin.len(), pl, il).replace(
        r#"{"mesh": 0, "scale": [2, 2, 2]}"#,
        r#"{"mesh": 0, "scale": [2, 2, 2], "children": [0]}"#,
    );
    assert!(read_mesh_bytes(&glb(&json, &bin), MeshFormat::Glb, "cy.glb").is_err());
    // GLB length field below the header size.
    let mut f = glb(&gltf_json(None, bin.len(), pl, il), &bin);
    f[8..12].copy_from_slice(&3u32.to_le_bytes());
    assert!(read_mesh_bytes(&f, MeshFormat::Glb, "len.glb").is_err());
}

#[test]
fn gltf_without_scene_reads_all_meshes() {
    let (bin, pl, il) = cube_buffer();
    let uri = format!(
        "data:;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(&bin)
    );
    let json = gltf_json(Some(&uri), bin.len(), pl, il)
        .replace(r#""scene": 0,"#, "")
        .replace(r#""scenes": [{"nodes": [0, 2]}],"#, "");
    let m = read_mesh_bytes(json.as_bytes(), MeshFormat::Gltf, "noscene.gltf").unwrap();
    assert_same_geometry(&m, &cube());
}

// ---------- malformed input, every mesh reader ----------

#[test]
fn malformed_meshes_never_panic() {
    let dir = TempDir::new("mesh-fuzz");
    let m = icosphere(1);
    type Writer<'a> = Box<dyn Fn(&std::path::Path) + 'a>;
    let cases: [(&str, MeshFormat, Writer); 6] = [
        (
            "a.obj",
            MeshFormat::Obj,
            Box::new(|p| write_mesh(p, &m).unwrap()),
        ),
        (
            "a.ply",
            MeshFormat::Ply,
            Box::new(|p| write_mesh(p, &m).unwrap()),
        ),
        (
            "b.ply",
            MeshFormat::Ply,
            Box::new(|p| write_ply_ascii(p, &m).unwrap()),
        ),
        (
            "a.stl",
            MeshFormat::Stl,
            Box::new(|p| write_mesh(p, &m).unwrap()),
        ),
        (
            "b.stl",
            MeshFormat::Stl,
            Box::new(|p| write_stl_ascii(p, &m).unwrap()),
        ),
        (
            "a.off",
            MeshFormat::Off,
            Box::new(|p| write_mesh(p, &m).unwrap()),
        ),
    ];
    for (name, format, write) in cases {
        let p = dir.path(name);
        write(&p);
        let valid = read_bytes(&p);
        hammer(&valid, |b| read_mesh_bytes(b, format, name), check_mesh);
    }
}

#[test]
fn headers_promising_huge_counts_fail_fast() {
    let t = std::time::Instant::now();
    let cases: [(&[u8], MeshFormat); 6] = [
        (
            b"ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n\0\0\0\0",
            MeshFormat::Ply,
        ),
        (
            b"ply\nformat ascii 1.0\nelement vertex 18446744073709551615\nproperty float x\nproperty float y\nproperty float z\nelement face 18446744073709551615\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n",
            MeshFormat::Ply,
        ),
        (
            b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n\0\0\0\0\0\0\0\0\0\0\0\0\xff\xff\xff\xff",
            MeshFormat::Ply,
        ),
        (b"OFF\n1000000000000 1000000000000 0\n0 0 0\n", MeshFormat::Off),
        (b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n", MeshFormat::Off),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3000000000\n", MeshFormat::Obj),
    ];
    for (bytes, format) in cases {
        assert!(
            read_mesh_bytes(bytes, format, "huge").is_err(),
            "{}",
            String::from_utf8_lossy(bytes)
        );
    }
    let mut stl = vec![0u8; 80];
    stl.extend_from_slice(&u32::MAX.to_le_bytes());
    stl.extend_from_slice(&[0u8; 100]);
    let e = read_mesh_bytes(&stl, MeshFormat::Stl, "huge.stl").unwrap_err();
    assert!(e.to_string().contains("promises"), "{e}");
    assert!(t.elapsed().as_secs_f32() < 5.0);
}

#[test]
fn out_of_range_face_indices_are_errors() {
    let cases: [(&[u8], MeshFormat); 4] = [
        (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", MeshFormat::Ply),
        (b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -1\n", MeshFormat::Ply),
        (b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", MeshFormat::Off),
        (b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", MeshFormat::Obj),
    ];
    for (bytes, format) in cases {
        let e = read_mesh_bytes(bytes, format, "idx.mesh").unwrap_err();
        assert!(e.to_string().starts_with("idx.mesh: "), "{e}");
    }
}

// ---------- validation ----------

#[test]
fn closed_cube_is_watertight_and_oriented() {
    let r = cube().validate();
    assert!(r.watertight && r.consistently_oriented, "{r}");
    assert_eq!((r.vertices, r.triangles, r.edges), (8, 12, 18));
    assert_eq!(r.euler_characteristic, 2);
    assert_eq!(r.genus(), Some(0));
    assert_eq!(r.components, 1);
    assert_eq!(
        (
            r.boundary_edges,
            r.non_manifold_edges,
            r.degenerate_triangles,
            r.duplicate_triangles
        ),
        (0, 0, 0, 0)
    );
    assert!(r.is_clean());
    let text = r.to_string();
    assert!(
        text.contains("watertight: yes") && text.contains("Euler characteristic: 2"),
        "{text}"
    );
    let s = icosphere(2).validate();
    assert!(s.is_clean() && s.euler_characteristic == 2, "{s}");
}

#[test]
fn open_flipped_degenerate_duplicate_and_non_manifold() {
    // One face (two triangles) missing: a square hole with 4 boundary edges.
    let mut m = cube();
    m.triangles.truncate(10);
    let r = m.validate();
    assert_eq!(r.boundary_edges, 4, "{r}");
    assert!(!r.watertight && r.consistently_oriented);
    assert_eq!(r.euler_characteristic, 1);

    // One flipped triangle.
    let mut m = cube();
    m.triangles[3].swap(0, 1);
    let r = m.validate();
    assert!(r.watertight && !r.consistently_oriented, "{r}");

    // A degenerate (collinear) triangle, one with a repeated index, and a duplicate.
    let mut m = cube();
    m.positions.push(Vec3::new(0.0, -1.0, -1.0)); // midpoint of edge 0-1
    m.triangles.push([0, 8, 1]);
    m.triangles.push([2, 2, 3]);
    m.triangles
        .push([m.triangles[0][1], m.triangles[0][2], m.triangles[0][0]]);
    let r = m.validate();
    assert_eq!(r.degenerate_triangles, 2, "{r}");
    assert_eq!(r.duplicate_triangles, 1, "{r}");

    // Three triangles on one edge.
    let m = TriMesh::new(
        vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, Vec3::NEG_Y],
        vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]],
    );
    let r = m.validate();
    assert_eq!(r.non_manifold_edges, 1, "{r}");
    assert!(!r.watertight);

    // Duplicate, unreferenced and non-finite vertices; out-of-range indices never panic.
    let m = TriMesh::new(
        vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Vec3::new(-0.0, 0.0, 0.0),
            Vec3::NAN,
        ],
        vec![[0, 1, 2], [0, 1, 77]],
    );
    let r = m.validate();
    assert_eq!(
        (
            r.duplicate_vertices,
            r.unreferenced_vertices,
            r.non_finite_vertices,
            r.invalid_triangles
        ),
        (1, 2, 1, 1),
        "{r}"
    );
    let r = TriMesh::default().validate();
    assert_eq!((r.components, r.euler_characteristic), (0, 0));
    assert!(r.bounds.is_empty());
    // No triangle, or only index-degenerate ones: nothing is closed or oriented.
    assert!(
        !r.watertight && !r.consistently_oriented && !r.is_clean(),
        "{r}"
    );
    let r = TriMesh::new(vec![Vec3::ZERO, Vec3::X], vec![[0, 0, 1]]).validate();
    assert!(
        !r.watertight && !r.consistently_oriented && !r.is_clean(),
        "{r}"
    );
    assert_eq!(
        (r.components, r.euler_characteristic, r.edges),
        (0, 0, 0),
        "{r}"
    );
}

/// Two closed tetrahedra touching in one vertex: every edge has two triangles (watertight by
/// edges), but the shared vertex has two fans; one tetrahedron alone has none.
#[test]
fn pinched_vertex_is_counted() {
    let tet = |o: Vec3, base: u32| {
        let p = vec![o, o + Vec3::X, o + Vec3::Y, o + Vec3::Z];
        let t = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]].map(|t| t.map(|i| i + base));
        (p, t)
    };
    let (p, t) = tet(Vec3::ZERO, 0);
    let one = TriMesh::new(p.clone(), t.to_vec());
    let r = one.validate();
    assert!(r.watertight && r.consistently_oriented, "{r}");
    assert_eq!(r.non_manifold_vertices, 0, "{r}");
    // The second tetrahedron mirrored through the origin, reusing vertex 0.
    let mut positions = p;
    positions.extend([-Vec3::X, -Vec3::Y, -Vec3::Z]);
    let mut triangles = t.to_vec();
    let map = |i: u32| if i == 0 { 0 } else { i + 3 };
    triangles.extend([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]].map(|t| t.map(map)));
    let r = TriMesh::new(positions, triangles).validate();
    assert!(r.watertight && r.consistently_oriented, "{r}");
    assert_eq!((r.non_manifold_vertices, r.components), (1, 1), "{r}");
    assert!(r.to_string().contains("non-manifold vertices: 1"), "{r}");
}

/// Index-degenerate triangles are out of the topology, vertices included: a lone
/// triangle plus a collapsed one elsewhere has χ = 3 − 3 + 1 = 1 and one component.
#[test]
fn euler_characteristic_ignores_index_degenerate_triangles() {
    let m = TriMesh::new(
        vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE],
        vec![[0, 1, 2], [3, 3, 4]],
    );
    let r = m.validate();
    assert_eq!(
        (
            r.edges,
            r.euler_characteristic,
            r.components,
            r.unreferenced_vertices,
            r.degenerate_triangles
        ),
        (3, 1, 1, 0, 1),
        "{r}"
    );
    // The collapsed triangle's vertices count only when a proper triangle uses them too.
    let m = TriMesh::new(
        vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        vec![[0, 1, 2], [2, 2, 0]],
    );
    let r = m.validate();
    assert_eq!(
        (r.edges, r.euler_characteristic, r.components),
        (3, 1, 1),
        "{r}"
    );
}

#[test]
fn ply_elements_without_properties_are_refused() {
    let t = std::time::Instant::now();
    for fmt in ["ascii", "binary_little_endian"] {
        let bytes = format!(
            "ply\nformat {fmt} 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nelement junk 18446744073709551615\nend_header\n"
        );
        let e = read_mesh_bytes(bytes.as_bytes(), MeshFormat::Ply, "z.ply").unwrap_err();
        assert!(
            e.to_string().contains("junk") && e.to_string().contains("no properties"),
            "{e}"
        );
        assert!(read_points_bytes(bytes.as_bytes(), PointFormat::Ply, "z.ply").is_err());
    }
    // An empty element without properties is harmless.
    let ok = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nelement nothing 0\nend_header\n1 2 3\n";
    assert_eq!(
        read_points_bytes(ok, PointFormat::Ply, "ok.ply")
            .unwrap()
            .points,
        [Vec3::new(1.0, 2.0, 3.0)]
    );
    assert!(t.elapsed().as_secs_f32() < 5.0);
}

// ---------- generated shapes ----------

/// Six times the signed volume: positive for outward-oriented closed meshes.
fn signed_volume6(m: &TriMesh) -> f64 {
    m.triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.positions[i as usize].as_dvec3());
            a.dot(b.cross(c))
        })
        .sum()
}

#[test]
fn generated_shapes_are_closed_and_outward() {
    use isokit_io::generate::*;
    let s = icosphere(Vec3::new(1.0, 2.0, 3.0), 2.0, 3);
    let r = s.validate();
    assert!(r.is_clean() && r.euler_characteristic == 2, "{r}");
    assert_eq!((r.vertices, r.triangles), (642, 1280));
    let v = signed_volume6(&s) / 6.0;
    assert!(
        (v - 4.0 / 3.0 * std::f64::consts::PI * 8.0).abs() < 1.0,
        "{v}"
    );

    let t = torus(1.0, 0.35, 48, 24);
    let r = t.validate();
    assert!(r.is_clean() && r.genus() == Some(1), "{r}");
    assert!(signed_volume6(&t) > 0.0);

    let k = tube(|u| trefoil(u, 0.5), 0.18, 192, 16);
    let r = k.validate();
    assert!(
        r.watertight && r.consistently_oriented && r.genus() == Some(1),
        "{r}"
    );
    assert!(signed_volume6(&k) > 0.0);
    // Every tube vertex lies at the tube radius from the curve (no collapsed rings).
    let c: Vec<Vec3> = (0..192).map(|i| trefoil(i as f32 / 192.0, 0.5)).collect();
    for (n, p) in k.positions.iter().enumerate() {
        assert!((p.distance(c[n / 16]) - 0.18).abs() < 1e-4);
    }

    let o = open_cube(0.5);
    let r = o.validate();
    assert_eq!((r.boundary_edges, r.euler_characteristic), (4, 1), "{r}");
    assert!(r.consistently_oriented);

    let r = degenerate_mesh().validate();
    assert_eq!(
        (
            r.degenerate_triangles,
            r.duplicate_triangles,
            r.duplicate_vertices,
            r.unreferenced_vertices
        ),
        (2, 1, 1, 1),
        "{r}"
    );
    // Topology of the five proper triangles (the zero-area [0, 1, 4] included, [3, 3, 2]
    // left out): V = 8 (0..=7), E = 10, F = 5, so χ = 3; components {0..4} and {5, 6, 7}.
    assert_eq!(
        (
            r.edges,
            r.euler_characteristic,
            r.components,
            r.boundary_edges,
            r.non_manifold_edges
        ),
        (10, 3, 2, 7, 2),
        "{r}"
    );

    let cloud = torus_cloud(1.0, 0.35, 1000, 2026);
    assert_eq!(cloud.points.len(), 1000);
    for (p, n) in cloud.points.iter().zip(cloud.normals.as_ref().unwrap()) {
        let ring = Vec3::new(p.x, p.y, 0.0).normalize() * 1.0;
        assert!(((*p - ring).length() - 0.35).abs() < 1e-4);
        assert!((n.length() - 1.0).abs() < 1e-5);
        assert!((*p - ring).normalize().dot(*n) > 0.999);
    }
    assert_eq!(torus_cloud(1.0, 0.35, 10, 7), torus_cloud(1.0, 0.35, 10, 7));
}
