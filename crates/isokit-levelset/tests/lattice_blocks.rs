//! Meshing a lattice block by block (what a distributed meshing does): the pieces welded by
//! key equal marching cubes of the whole lattice, the same vertices in the same order and
//! the same triangles, for blocks of any size, with and without closing the boundary, for a
//! surface cut by the lattice's faces and isovalues at sample values.

use glam::Vec3;
use isokit_field::Grid;
use isokit_levelset::meshing::{
    MeshOptions, MeshPiece, MeshingError, mesh_grid, mesh_lattice_block, weld_pieces,
};

/// A lattice holding `f`, `dims` samples from `(-1, -1, -1)` with spacing `h`.
fn lattice(dims: [usize; 3], h: f32, f: impl Fn(Vec3) -> f32) -> Grid {
    let mut g = Grid::new(dims, Vec3::splat(-1.0), h).unwrap();
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = g.position(i, j, k);
                g.set(i, j, k, f(p));
            }
        }
    }
    g
}

/// The pieces of blocks of `side` samples tiling `g`.
fn pieces(g: &Grid, side: [usize; 3], opts: &MeshOptions) -> Vec<MeshPiece> {
    let d = g.dims();
    let mut out = Vec::new();
    for z in (0..d[2]).step_by(side[2]) {
        for y in (0..d[1]).step_by(side[1]) {
            for x in (0..d[0]).step_by(side[0]) {
                let first = [x, y, z];
                let owned: [usize; 3] = std::array::from_fn(|a| side[a].min(d[a] - first[a]));
                let vd: [usize; 3] =
                    std::array::from_fn(|a| (first[a] + owned[a] + 1).min(d[a]) - first[a]);
                let mut values = Vec::new();
                for k in 0..vd[2] {
                    for j in 0..vd[1] {
                        for i in 0..vd[0] {
                            values.push(g.get(first[0] + i, first[1] + j, first[2] + k));
                        }
                    }
                }
                let p = mesh_lattice_block(d, g.origin(), g.spacing(), first, owned, &values, opts)
                    .unwrap();
                out.push(p);
            }
        }
    }
    out
}

fn sorted(mut t: Vec<[u32; 3]>) -> Vec<[u32; 3]> {
    t.sort_unstable();
    t
}

#[test]
fn blocks_welded_by_key_equal_the_whole_lattice() {
    // A torus cut by the lattice's +x face, and a sphere whose isovalue hits samples.
    let torus = lattice([41, 37, 23], 0.05, |p| {
        let q = glam::Vec2::new(glam::Vec2::new(p.x - 0.3, p.y).length() - 0.6, p.z);
        q.length() - 0.25
    });
    let ball = lattice([30, 30, 30], 2.0 / 29.0, |p| {
        ((p * 8.0).round() / 8.0).length() - 0.5
    });
    // A ball cut by the three faces through the lattice's first corner.
    let corner = lattice([26, 21, 19], 0.06, |p| {
        (p + Vec3::splat(0.9)).length() - 0.5
    });
    for (name, g) in [("torus", &torus), ("ball", &ball), ("corner", &corner)] {
        for close_boundary in [true, false] {
            let opts = MeshOptions {
                iso: 0.0,
                close_boundary,
            };
            let whole = mesh_grid(g, &opts).unwrap();
            assert!(!whole.triangles.is_empty());
            for side in [[16, 16, 16], [7, 13, 5], [41, 1, 40], [1, 1, 1]] {
                let welded = weld_pieces(pieces(g, side, &opts)).unwrap();
                assert!(
                    welded.positions == whole.positions,
                    "{name}, close {close_boundary}, blocks {side:?}: vertices differ ({} against {})",
                    welded.positions.len(),
                    whole.positions.len()
                );
                assert!(
                    sorted(welded.triangles.clone()) == sorted(whole.triangles.clone()),
                    "{name}, close {close_boundary}, blocks {side:?}: triangles differ ({} against {})",
                    welded.triangles.len(),
                    whole.triangles.len()
                );
            }
        }
    }
}

#[test]
fn a_block_outside_the_lattice_or_with_the_wrong_samples_is_refused() {
    let opts = MeshOptions::default();
    let o = Vec3::ZERO;
    for (first, owned, n) in [
        ([0, 0, 0], [0, 4, 4], 0),
        ([8, 0, 0], [4, 4, 4], 125),
        ([0, 0, 0], [4, 4, 4], 7),
        ([usize::MAX, 0, 0], [4, 4, 4], 125),
    ] {
        let e = mesh_lattice_block([10, 10, 10], o, 0.1, first, owned, &vec![0.0; n], &opts);
        assert!(
            matches!(e, Err(MeshingError::BadBlock { .. })),
            "{first:?} {owned:?}"
        );
    }
}

#[test]
fn a_bad_lattice_or_piece_is_refused() {
    let opts = MeshOptions::default();
    let v = vec![0.0; 8];
    for (dims, o, h) in [
        ([usize::MAX, 2, 2], Vec3::ZERO, 0.1),
        ([1 << 20, 1 << 20, 1 << 20], Vec3::ZERO, 0.1),
        ([4, 4, 4], Vec3::NAN, 0.1),
        ([4, 4, 4], Vec3::ZERO, 0.0),
    ] {
        let e = mesh_lattice_block(dims, o, h, [0, 0, 0], [1, 1, 1], &v, &opts);
        assert!(matches!(e, Err(MeshingError::BadBlock { .. })), "{dims:?}");
    }
    let bad = MeshPiece {
        keys: vec![1, 2],
        positions: vec![Vec3::ZERO; 2],
        triangles: vec![[0, 1, 2]],
    };
    assert!(matches!(
        weld_pieces(vec![bad]),
        Err(MeshingError::BadPiece(_))
    ));
    let bad = MeshPiece {
        keys: vec![1, 2, 3],
        positions: vec![Vec3::ZERO; 2],
        triangles: vec![],
    };
    assert!(matches!(
        weld_pieces(vec![bad]),
        Err(MeshingError::BadPiece(_))
    ));
}
