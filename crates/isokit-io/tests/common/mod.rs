//! Shared helpers for the integration tests: generated meshes, temporary directories,
//! geometric comparison and the malformed-input harness.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use glam::Vec3;
use isokit_field::rng::{DEFAULT_SEED, SplitMix64};
use isokit_io::{IoError, TriMesh};

/// A fresh temporary directory, removed on drop.
pub struct TempDir(pub PathBuf);

impl TempDir {
    pub fn new(tag: &str) -> Self {
        static N: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = N.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let p = std::env::temp_dir().join(format!("isokit-io-{tag}-{}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        TempDir(p)
    }
    pub fn path(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
    /// Names of all entries (to check that no temporary file is left behind).
    pub fn entries(&self) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(&self.0)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The closed, outward-oriented unit cube [-1, 1]^3 (8 vertices, 12 triangles).
pub fn cube() -> TriMesh {
    let positions = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 != 0 { 1.0 } else { -1.0 },
                if i & 2 != 0 { 1.0 } else { -1.0 },
                if i & 4 != 0 { 1.0 } else { -1.0 },
            )
        })
        .collect();
    // Quads counter-clockwise seen from outside.
    let quads = [
        [0, 2, 3, 1], // -z
        [4, 5, 7, 6], // +z
        [0, 1, 5, 4], // -y
        [2, 6, 7, 3], // +y
        [0, 4, 6, 2], // -x
        [1, 3, 7, 5], // +x
    ];
    let mut triangles = Vec::new();
    for q in quads {
        triangles.push([q[0], q[1], q[2]]);
        triangles.push([q[0], q[2], q[3]]);
    }
    TriMesh::new(positions, triangles)
}

/// An icosphere of radius 1 with `level` subdivisions (level 2: 162 vertices, 320 triangles).
pub fn icosphere(level: usize) -> TriMesh {
    isokit_io::generate::icosphere(Vec3::ZERO, 1.0, level)
}

/// Triangles as position triples, each rotated (keeping orientation) to start at its
/// smallest corner, sorted: equal for meshes that differ only by vertex numbering.
pub fn soup(m: &TriMesh) -> Vec<[[u32; 3]; 3]> {
    let key = |p: Vec3| [p.x + 0.0, p.y + 0.0, p.z + 0.0].map(f32::to_bits);
    let mut v: Vec<[[u32; 3]; 3]> = m
        .triangles
        .iter()
        .map(|t| {
            let k = t.map(|i| key(m.positions[i as usize]));
            let r = (0..3).min_by_key(|&r| k[r]).unwrap();
            [k[r], k[(r + 1) % 3], k[(r + 2) % 3]]
        })
        .collect();
    v.sort();
    v
}

pub fn assert_same_geometry(a: &TriMesh, b: &TriMesh) {
    assert_eq!(
        a.triangles.len(),
        b.triangles.len(),
        "triangle counts differ"
    );
    assert!(soup(a) == soup(b), "triangles differ");
}

/// Runs a reader over broken versions of a valid file: it must return (Ok or Err) and never
/// panic; `check` validates any Ok result.
pub fn hammer<T>(valid: &[u8], read: impl Fn(&[u8]) -> Result<T, IoError>, check: impl Fn(&T)) {
    hammer_with(valid, &read, &check, DEFAULT_SEED, 300);
}

/// [`hammer`] with a chosen seed and number of random mutations.
pub fn hammer_with<T>(
    valid: &[u8],
    read: &dyn Fn(&[u8]) -> Result<T, IoError>,
    check: &dyn Fn(&T),
    seed: u64,
    mutations: usize,
) {
    assert!(read(&[]).is_err(), "an empty file must be an error");
    // Every prefix (or a spread of ~600 of them for big files).
    let step = (valid.len() / 600).max(1);
    for n in (0..valid.len())
        .step_by(step)
        .chain(valid.len().saturating_sub(64)..valid.len())
    {
        if let Ok(v) = read(&valid[..n]) {
            check(&v);
        }
    }
    let mut rng = SplitMix64::new(seed);
    // Random garbage, alone and after the valid file's first bytes (to pass magic checks).
    for len in [1usize, 3, 12, 50, 84, 100, 348, 400, 1000, 4096] {
        let junk: Vec<u8> = (0..len).map(|_| rng.next_u64() as u8).collect();
        if let Ok(v) = read(&junk) {
            check(&v);
        }
        for keep in [4usize, 16, 64, 200] {
            let mut b = valid[..keep.min(valid.len())].to_vec();
            b.extend_from_slice(&junk);
            if let Ok(v) = read(&b) {
                check(&v);
            }
        }
    }
    // Random byte mutations of the valid file.
    for _ in 0..mutations {
        let mut b = valid.to_vec();
        for _ in 0..1 + rng.below(4) {
            let i = rng.below(b.len());
            b[i] = match rng.below(4) {
                0 => rng.next_u64() as u8,
                1 => b[i] ^ (1 << rng.below(8)),
                2 => 0xff,
                _ => b"0123456789-.e "[rng.below(14)],
            };
        }
        if let Ok(v) = read(&b) {
            check(&v);
        }
    }
}

/// A mesh returned by a reader must have every index in range.
pub fn check_mesh(m: &TriMesh) {
    let n = m.positions.len();
    assert!(m.triangles.iter().flatten().all(|&i| (i as usize) < n));
}

pub fn read_bytes(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap()
}

// ---------- glTF built by hand ----------

pub fn le_f32(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// A buffer holding the cube's positions (f32) then u16 indices.
pub fn cube_buffer() -> (Vec<u8>, usize, usize) {
    let c = cube();
    let mut b = le_f32(
        &c.positions
            .iter()
            .flat_map(|p| p.to_array())
            .collect::<Vec<_>>(),
    );
    let pos_len = b.len();
    for t in &c.triangles {
        for &i in t {
            b.extend_from_slice(&(i as u16).to_le_bytes());
        }
    }
    let idx_len = b.len() - pos_len;
    (b, pos_len, idx_len)
}

pub fn gltf_json(uri: Option<&str>, buf_len: usize, pos_len: usize, idx_len: usize) -> String {
    let uri = uri.map(|u| format!(r#""uri": "{u}","#)).unwrap_or_default();
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0, 2]}}],
  "nodes": [
    {{"translation": [10, 0, 0], "children": [1]}},
    {{"mesh": 0, "scale": [2, 2, 2]}},
    {{"mesh": 0, "matrix": [1,0,0,0, 0,1,0,0, 0,0,-1,0, 0,0,0,1]}},
    {{"mesh": 0, "translation": [99, 0, 0]}}
  ],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}},
                             {{"attributes": {{"POSITION": 0}}, "mode": 1}}]}}],
  "buffers": [{{{uri} "byteLength": {buf_len}}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": {pos_len}}},
    {{"buffer": 0, "byteOffset": {pos_len}, "byteLength": {idx_len}}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
      "min": [-1,-1,-1], "max": [1,1,1]}},
    {{"bufferView": 1, "componentType": 5123, "count": 36, "type": "SCALAR"}}
  ]
}}"#
    )
}

pub fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    out.extend_from_slice(&(b.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&b);
    out
}
