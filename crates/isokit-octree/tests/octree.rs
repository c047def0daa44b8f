//! The octrees against exact fields and brute force: continuity across level changes, the
//! error bound at independent points, point location, deep trees, and hashed against
//! linked.

use glam::{DVec3, IVec3, UVec3, Vec3};
use isokit_field::primitives::{Sphere, Torus};
use isokit_field::rng::SplitMix64;
use isokit_field::{Aabb, Field};
use isokit_io::generate;
use isokit_kdtree::{MeshOptions, MeshSdf};
use isokit_octree::{
    BuildOptions, Cell, Construction, Cull, Domain, HashedOctree, LinkedOctree, NodeStatus, Octree,
    OctreeError, trilerp,
};

fn sphere() -> Sphere {
    Sphere::new(Vec3::new(0.05, -0.03, 0.02), 1.0).unwrap()
}

fn torus() -> Torus {
    Torus::new(Vec3::ZERO, 0.75, 0.25).unwrap()
}

fn knot() -> MeshSdf {
    let mesh = generate::tube(|u| generate::trefoil(u, 0.5), 0.18, 96, 10);
    MeshSdf::new(&mesh, MeshOptions::default()).unwrap()
}

fn opts(max_level: u32, error: f32) -> BuildOptions {
    BuildOptions {
        min_level: 2,
        error,
        ..BuildOptions::new(max_level)
    }
}

/// A random point on `cell`'s face towards `dir` (one nonzero component), in world space.
fn point_on_face(t: &dyn Octree, cell: Cell, dir: IVec3, r: &mut SplitMix64) -> Vec3 {
    let d = t.domain();
    let s = cell.size(d.max_level()) as f64;
    let mut g = cell.pos.as_dvec3();
    for a in 0..3 {
        g[a] += if dir[a] > 0 {
            s
        } else if dir[a] < 0 {
            0.0
        } else {
            s * r.next_f64()
        };
    }
    (d.origin().as_dvec3() + g * d.finest_spacing()).as_vec3()
}

/// Largest jump across faces between leaves of different levels, sampled from both sides;
/// also the largest jump the same faces would show with the field's own values at the fine
/// side's corners (what hanging nodes would give without interpolation).
fn face_jumps(t: &dyn Octree, field: &dyn Field, samples: usize) -> (f32, f32, usize) {
    let l = t.domain().max_level();
    let mut r = SplitMix64::new(77);
    let (mut jump, mut raw_jump, mut faces) = (0.0f32, 0.0f32, 0usize);
    for fine in t.leaves() {
        for dir in [
            IVec3::X,
            IVec3::NEG_X,
            IVec3::Y,
            IVec3::NEG_Y,
            IVec3::Z,
            IVec3::NEG_Z,
        ] {
            let Some(coarse) = t.neighbor(fine, dir) else {
                continue;
            };
            if coarse.level >= fine.level || !t.is_leaf(coarse) {
                continue;
            }
            faces += 1;
            let raw: [f32; 8] =
                std::array::from_fn(|n| field.value(t.domain().position(fine.corner(n, l))));
            for _ in 0..samples {
                let p = point_on_face(t, fine, dir, &mut r);
                let a = t.cell_value(fine, p).unwrap();
                let b = t.cell_value(coarse, p).unwrap();
                jump = jump.max((a - b).abs());
                let g = t.domain().to_grid(p);
                let tt = ((g - fine.pos.as_dvec3()) / fine.size(l) as f64)
                    .clamp(DVec3::ZERO, DVec3::ONE)
                    .as_vec3();
                raw_jump = raw_jump.max((trilerp(&raw, tt) - b).abs());
            }
        }
    }
    (jump, raw_jump, faces)
}

#[test]
fn continuous_across_faces_between_levels() {
    let fields: Vec<(&str, Box<dyn Field>, BuildOptions)> = vec![
        ("sphere", Box::new(sphere()), opts(7, 2e-3)),
        ("torus", Box::new(torus()), opts(7, 1e-3)),
        ("knot", Box::new(knot()), opts(6, 2e-3)),
        (
            "sphere, thesis construction",
            Box::new(sphere()),
            BuildOptions {
                refine_hanging: false,
                ..opts(6, 0.0)
            },
        ),
    ];
    for (name, f, o) in fields {
        let t = HashedOctree::build(&*f, f.bounds().expanded(0.2), &o).unwrap();
        let (jump, raw, faces) = face_jumps(&t, &*f, 8);
        assert!(faces > 100, "{name}: only {faces} faces between levels");
        assert!(jump <= 1e-6, "{name}: jump {jump} across {faces} faces");
        // Without the interpolated hanging values the same faces would jump: the test can
        // see a discontinuity.
        assert!(raw > 1e-5, "{name}: raw jump only {raw}");
        assert!(t.stats().hanging_nodes > 0, "{name}");
    }
}

/// Random points within `band` of the surface of an exact field: random points projected to
/// the surface along the gradient, then moved by up to `band`.
fn near_surface(f: &dyn Field, domain: Aabb, band: f32, n: usize, seed: u64) -> Vec<Vec3> {
    let mut r = SplitMix64::new(seed);
    let mut out = Vec::new();
    while out.len() < n {
        let p = r.point_in(domain.min, domain.max);
        let on = p - f.value(p) * f.gradient(p);
        let q = on + r.unit_vector() * band * r.next_f32();
        if domain.contains(q) && f.value(q).abs() <= band {
            out.push(q);
        }
    }
    out
}

#[test]
fn error_bound_holds_at_independent_points() {
    for construction in [Construction::TopDown, Construction::BottomUp] {
        let cases: Vec<(&str, Box<dyn Field>, u32, f32)> = match construction {
            Construction::TopDown => vec![
                ("sphere", Box::new(sphere()), 8, 1e-3),
                ("torus", Box::new(torus()), 8, 1e-3),
                ("sphere, loose", Box::new(sphere()), 7, 1e-2),
            ],
            Construction::BottomUp => vec![
                ("sphere", Box::new(sphere()), 7, 2e-3),
                ("torus", Box::new(torus()), 7, 4e-3),
            ],
        };
        for (name, f, l, error) in cases {
            let bounds = f.bounds().expanded(0.2);
            let mut o = opts(l, error);
            o.construction = construction;
            let h = Domain::cube_around(bounds, l).unwrap().finest_spacing() as f32;
            o.band = 2.0 * h;
            let t = HashedOctree::build(&*f, bounds, &o).unwrap();
            let per_level = &t.stats().leaves_per_level;
            // The bound, not the maximum level, stopped the subdivision.
            assert_eq!(
                per_level[l as usize], 0,
                "{name} {construction:?}: {per_level:?}"
            );
            let pts = near_surface(&*f, t.domain().bounds(), 2.0 * h, 20_000, 9);
            let worst = pts
                .iter()
                .map(|&p| (t.value(p) - f.value(p)).abs())
                .fold(0.0f32, f32::max);
            assert!(worst <= error, "{name} {construction:?}: {worst} > {error}");
            // ...and it is not trivially loose: the worst error is a fair share of it.
            assert!(worst > 0.1 * error, "{name} {construction:?}: {worst}");
        }
    }
}

#[test]
fn a_looser_bound_samples_less() {
    let f = torus();
    let b = f.bounds().expanded(0.2);
    let tight = HashedOctree::build(&f, b, &opts(8, 1e-3)).unwrap();
    let loose = HashedOctree::build(&f, b, &opts(8, 1e-2)).unwrap();
    assert!(loose.cell_count() * 2 < tight.cell_count());
    assert!(loose.stats().evaluations * 2 < tight.stats().evaluations);
    assert!(
        tight.stats().dense_fraction < 0.2,
        "{}",
        tight.stats().dense_fraction
    );
}

fn brute_locate(leaves: &[Cell], t: &dyn Octree, p: Vec3) -> Cell {
    let d = t.domain();
    let f = d.finest_cell(d.to_grid(p));
    let l = d.max_level();
    let hits: Vec<Cell> = leaves
        .iter()
        .copied()
        .filter(|c| {
            let s = c.size(l);
            (0..3).all(|a| c.pos[a] <= f[a] && f[a] < c.pos[a] + s)
        })
        .collect();
    assert_eq!(hits.len(), 1, "{p}: {hits:?}");
    hits[0]
}

/// Random points, points on leaf faces, edges and corners, the domain's corners, and points
/// outside.
fn probe_points(t: &dyn Octree, n: usize, seed: u64) -> Vec<Vec3> {
    let mut r = SplitMix64::new(seed);
    let d = t.domain();
    let b = d.bounds();
    let mut pts: Vec<Vec3> = (0..n).map(|_| r.point_in(b.min, b.max)).collect();
    pts.extend(b.corners());
    pts.extend(b.corners().map(|c| c + (c - b.center()) * 0.5));
    let leaves = t.leaves();
    for _ in 0..n {
        let c = leaves[r.below(leaves.len())];
        let k = r.below(8);
        pts.push(d.position(c.corner(k, d.max_level())));
        let dir = IVec3::new(
            r.below(3) as i32 - 1,
            r.below(3) as i32 - 1,
            r.below(3) as i32 - 1,
        );
        pts.push(point_on_face(t, c, dir, &mut r));
    }
    pts
}

#[test]
fn point_location_agrees_with_a_brute_force_scan() {
    let f = knot();
    let h = HashedOctree::build(&f, f.bounds().expanded(0.1), &opts(6, 1e-3)).unwrap();
    let k = LinkedOctree::from_hashed(&h);
    let leaves = h.leaves();
    assert_eq!(leaves, k.leaves());
    assert!(leaves.iter().map(|c| c.level).min() < leaves.iter().map(|c| c.level).max());
    for p in probe_points(&h, 3000, 4) {
        let want = brute_locate(&leaves, &h, p);
        assert_eq!(h.locate(p), want, "{p}");
        assert_eq!(h.locate_binary(p), want, "{p}");
        assert_eq!(h.accessor().locate(p), want, "{p}");
        assert_eq!(k.locate(p), want, "{p}");
    }
}

#[test]
fn hashed_and_linked_give_identical_values() {
    let cases: Vec<(&str, Box<dyn Field>, BuildOptions)> = vec![
        ("sphere", Box::new(sphere()), opts(7, 1e-3)),
        ("knot", Box::new(knot()), opts(6, 0.0)),
        (
            "torus bottom-up",
            Box::new(torus()),
            BuildOptions {
                construction: Construction::BottomUp,
                ..opts(6, 1e-3)
            },
        ),
    ];
    for (name, f, o) in cases {
        let h = HashedOctree::build(&*f, f.bounds().expanded(0.2), &o).unwrap();
        let k = LinkedOctree::build(&*f, f.bounds().expanded(0.2), &o).unwrap();
        assert_eq!(h.cell_count(), k.cell_count(), "{name}");
        assert_eq!(h.node_count(), k.node_count(), "{name}");
        let mut a = h.accessor();
        for p in probe_points(&h, 4000, 12) {
            let (vh, vk) = (h.value(p), k.value(p));
            assert_eq!(vh.to_bits(), vk.to_bits(), "{name} {p}: {vh} vs {vk}");
            assert_eq!(a.value(p).to_bits(), vh.to_bits(), "{name} {p}");
            assert_eq!(h.gradient(p), k.gradient(p), "{name} {p}");
            assert_eq!(a.gradient(p), h.gradient(p), "{name} {p}");
        }
        for c in h.leaves().iter().step_by(7) {
            assert_eq!(h.corner_values(*c), k.corner_values(*c));
            for dir in [
                IVec3::X,
                IVec3::NEG_Y,
                IVec3::new(1, -1, 1),
                IVec3::new(0, 1, -1),
            ] {
                assert_eq!(
                    h.neighbor(*c, dir),
                    k.neighbor(*c, dir),
                    "{name} {c:?} {dir}"
                );
            }
        }
        assert!(a.node_stats().hits > 0);
    }
}

#[test]
fn neighbours_are_adjacent_and_as_large_or_larger() {
    let f = torus();
    let t = HashedOctree::build(&f, f.bounds().expanded(0.2), &opts(6, 1e-3)).unwrap();
    let l = t.domain().max_level();
    for c in t.leaves() {
        for dir in [
            IVec3::X,
            IVec3::NEG_Z,
            IVec3::new(1, 1, 0),
            IVec3::new(-1, -1, -1),
        ] {
            let Some(n) = t.neighbor(c, dir) else {
                continue;
            };
            assert!(t.contains(n) && n.level <= c.level);
            // n covers the place next to c.
            let target = (c.pos.as_ivec3() + dir * c.size(l) as i32).as_uvec3();
            let s = n.size(l);
            assert!((0..3).all(|a| n.pos[a] <= target[a] && target[a] < n.pos[a] + s));
        }
    }
    assert_eq!(t.neighbor(Cell::ROOT, IVec3::X), None);
}

#[test]
fn node_access_by_the_sibling_rule_matches_the_node_map() {
    let f = sphere();
    let t = HashedOctree::build(&f, f.bounds().expanded(0.2), &opts(6, 1e-3)).unwrap();
    let l = t.domain().max_level();
    let mut a = t.accessor();
    let (mut regular, mut hanging) = (0, 0);
    for c in t.leaves() {
        for n in 0..8 {
            let q = c.corner(n, l);
            let st = t.node_status(q);
            assert_eq!(a.node_status(q), st);
            let v = t.node_value(q).expect("every leaf corner is a node");
            match st {
                NodeStatus::Absent => panic!("{q} is a corner of {c:?}"),
                NodeStatus::Regular => {
                    regular += 1;
                    assert_eq!(v, f.value(t.domain().position(q)), "{q}");
                }
                NodeStatus::Hanging { leaf } => {
                    hanging += 1;
                    assert!(t.is_leaf(leaf) && leaf.level < c.level && !leaf.has_corner(q, l));
                    let corners = t.corner_values(leaf).unwrap();
                    let tt = (q - leaf.pos).as_vec3() / leaf.size(l) as f32;
                    assert_eq!(v, trilerp(&corners, tt));
                }
            }
        }
    }
    assert!(regular > 0 && hanging > 0);
    // Points that are not nodes are absent, whichever way they are asked.
    let mut r = SplitMix64::new(3);
    let mut absent = 0;
    for _ in 0..20_000 {
        let q = UVec3::new(r.below(65) as u32, r.below(65) as u32, r.below(65) as u32);
        let st = t.node_status(q);
        assert_eq!(st == NodeStatus::Absent, t.node_value(q).is_none(), "{q}");
        absent += (st == NodeStatus::Absent) as usize;
    }
    assert!(absent > 0);
    assert_eq!(t.node_status(UVec3::splat(65)), NodeStatus::Absent);
}

/// A tiny sphere (radius ~10 finest cells) in a deep tree.
fn deep(max_level: u32, center: Vec3) -> (Sphere, HashedOctree) {
    let h = 2.0 / (1u64 << max_level) as f32;
    let s = Sphere::new(center, 10.0 * h).unwrap();
    let b = Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0));
    let t = HashedOctree::build(&s, b, &BuildOptions::new(max_level)).unwrap();
    (s, t)
}

#[test]
fn deep_trees_at_levels_20_and_21() {
    for (l, c) in [
        (20u32, Vec3::new(0.3, -0.2, 0.1)),
        // Against the upper corner: cells with the largest keys (u64::MAX at level 21).
        (21, Vec3::splat(1.0 - 6.0 * 2.0 / (1u64 << 21) as f32)),
    ] {
        let (s, t) = deep(l, c);
        let k = LinkedOctree::from_hashed(&t);
        let per = &t.stats().leaves_per_level;
        assert!(per[l as usize] > 500, "level {l}: {per:?}");
        assert!(t.stats().dense_fraction < 1e-12);
        if l == 21 {
            let last = Cell {
                level: 21,
                pos: UVec3::splat((1 << 21) - 1),
            };
            assert!(t.is_leaf(last));
            assert_eq!(last.key(21), u64::MAX);
        }
        let leaves = t.leaves();
        let h = t.domain().finest_spacing() as f32;
        // Near the surface, on cell faces, edges and corners of the finest leaves.
        let mut r = SplitMix64::new(21);
        let fine: Vec<Cell> = leaves.iter().copied().filter(|c| c.level == l).collect();
        let mut checked = 0;
        for _ in 0..3000 {
            let cell = fine[r.below(fine.len())];
            let dir = IVec3::new(
                r.below(3) as i32 - 1,
                r.below(3) as i32 - 1,
                r.below(3) as i32 - 1,
            );
            let p = point_on_face(&t, cell, dir, &mut r);
            assert_eq!(t.locate(p), brute_locate(&leaves, &t, p), "level {l} {p}");
            assert_eq!(t.value(p).to_bits(), k.value(p).to_bits());
            // The reconstruction error at this scale is far below a finest cell (f32 positions
            // resolve about 1/64 of one here, which bounds the precision).
            // Checked where the point's leaf is a finest band leaf (one the surface may pass:
            // a culled leaf promises nothing about its error).
            let leaf = t.locate(p);
            let band =
                (0..8).any(|n| s.value(t.domain().position(leaf.corner(n, l))).abs() <= 0.87 * h);
            if leaf.level == l && band {
                let e = (t.value(p) - s.value(p)).abs();
                assert!(e < 0.15 * h, "level {l} {p}: {e} vs h {h}");
                checked += 1;
            }
        }
        assert!(checked > 1000, "{checked}");
        // The domain's corners hold the exact distance.
        for q in t.domain().bounds().corners() {
            assert_eq!(t.value(q), s.value(q), "{q}");
            assert_eq!(t.locate(q), brute_locate(&leaves, &t, q));
        }
        let (jump, _, faces) = face_jumps(&t, &s, 2);
        assert!(faces > 0 && jump <= 1e-6, "level {l}: {jump}");
    }
}

/// A ball whose values are not marked exact, so only sign changes reveal it.
struct Blob(Sphere);
impl Field for Blob {
    fn value(&self, p: Vec3) -> f32 {
        self.0.value(p)
    }
    fn bounds(&self) -> Aabb {
        Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0))
    }
}

#[test]
fn look_ahead_finds_small_features_of_general_fields() {
    let f = Blob(Sphere::new(Vec3::new(0.37, -0.41, 0.13), 0.05).unwrap());
    let b = f.bounds();
    let centre = Vec3::new(0.37, -0.41, 0.13);
    let mut o = opts(7, 1e-3);
    o.cull = Cull::SignChange;
    let blind = HashedOctree::build(&f, b, &o).unwrap();
    assert!(
        blind.value(centre) > 0.0,
        "the coarse test points miss the ball"
    );
    assert_eq!(blind.cell_count(), 73, "nothing near: min level 2 only");
    o.lookahead = 3;
    let seeing = HashedOctree::build(&f, b, &o).unwrap();
    assert!(seeing.value(centre) < -0.03, "{}", seeing.value(centre));
    assert!(seeing.stats().evaluations > blind.stats().evaluations);
    // Auto culling treats the non-exact field by sign changes too.
    o.cull = Cull::Auto;
    let auto = HashedOctree::build(&f, b, &o).unwrap();
    assert_eq!(auto.cell_count(), seeing.cell_count());
}

#[test]
fn bottom_up_samples_the_dense_grid_and_matches_the_bound() {
    let f = sphere();
    let mut o = opts(7, 2e-3);
    o.construction = Construction::BottomUp;
    let t = HashedOctree::build(&f, f.bounds().expanded(0.2), &o).unwrap();
    assert_eq!(t.stats().dense_fraction, 1.0);
    assert!(t.cell_count() < 129usize.pow(3) / 8);
    let td = HashedOctree::build(&f, f.bounds().expanded(0.2), &opts(7, 2e-3)).unwrap();
    assert!(
        td.stats().evaluations < t.stats().evaluations / 4,
        "{} vs {}",
        td.stats().evaluations,
        t.stats().evaluations
    );
}

#[test]
fn memory_per_cell_hashed_below_linked() {
    let f = sphere();
    let h = HashedOctree::build(&f, f.bounds().expanded(0.1), &opts(7, 0.0)).unwrap();
    let k = LinkedOctree::from_hashed(&h);
    let (hb, kb) = (h.bytes_per_cell(), k.bytes_per_cell());
    assert!(hb > 5.0 && kb > 40.0, "{hb} {kb}");
    assert!(hb < 0.8 * kb, "hashed {hb} vs linked {kb} bytes per cell");
    let (cells, nodes) = h.memory_split();
    assert!(cells < nodes);
}

#[test]
fn exports_match_the_tree() {
    let f = torus();
    let t = HashedOctree::build(&f, f.bounds().expanded(0.2), &opts(7, 1e-3)).unwrap();
    let k = LinkedOctree::from_hashed(&t);
    let g = t.to_grid(6).unwrap();
    assert_eq!(g.dims(), [65, 65, 65]);
    assert_eq!(g, k.to_grid(6).unwrap());
    let l = t.domain().max_level();
    for ([i, j, k], v) in g.iter().step_by(97) {
        let q = UVec3::new(i as u32, j as u32, k as u32) << (l - 6);
        assert_eq!(v, t.value_at_grid(q.as_dvec3()));
    }
    let band = t.to_brick_grid(6, 8, 1, 0.1).unwrap();
    assert!(band.brick_count() < 512);
    for ([i, j, k], v) in g.iter() {
        if v.abs() < 0.05 {
            assert!((band.get(i, j, k) - v).abs() < 1e-6, "{i} {j} {k}");
        }
    }
    assert!(matches!(
        t.to_grid(8),
        Err(OctreeError::BadParameter { .. })
    ));
}

struct Nan;
impl Field for Nan {
    fn value(&self, p: Vec3) -> f32 {
        if p.x > 0.5 {
            f32::NAN
        } else {
            p.length() - 0.3
        }
    }
    fn bounds(&self) -> Aabb {
        Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0))
    }
}

#[test]
fn bad_input_gives_errors_not_panics() {
    let f = sphere();
    let b = f.bounds();
    let bad = |o: BuildOptions| HashedOctree::build(&f, b, &o).unwrap_err();
    assert!(matches!(
        bad(BuildOptions::new(22)),
        OctreeError::BadParameter {
            name: "max level",
            ..
        }
    ));
    assert!(matches!(
        bad(BuildOptions {
            min_level: 5,
            ..BuildOptions::new(4)
        }),
        OctreeError::BadParameter {
            name: "min level",
            ..
        }
    ));
    for e in [f32::NAN, -1.0, f32::INFINITY] {
        assert!(matches!(
            bad(BuildOptions {
                error: e,
                ..BuildOptions::new(4)
            }),
            OctreeError::BadParameter { .. }
        ));
    }
    assert!(matches!(
        bad(BuildOptions {
            lookahead: 5,
            ..BuildOptions::new(4)
        }),
        OctreeError::BadParameter { .. }
    ));
    assert!(matches!(
        bad(BuildOptions {
            cull: Cull::Lipschitz(0.0),
            ..BuildOptions::new(4)
        }),
        OctreeError::BadParameter { .. }
    ));
    assert!(matches!(
        HashedOctree::build(&f, Aabb::EMPTY, &BuildOptions::new(4)),
        Err(OctreeError::BadDomain(_))
    ));
    assert!(matches!(
        HashedOctree::build(&Nan, Nan.bounds(), &BuildOptions::new(4)),
        Err(OctreeError::NonFinite { .. })
    ));
    // A tree beyond its cell budget stops with an error.
    assert_eq!(
        bad(BuildOptions {
            max_cells: 1000,
            ..BuildOptions::new(10)
        }),
        OctreeError::TooManyCells { limit: 1000 }
    );
    // The dense grid of 21 levels is refused before allocating, for bottom-up and export.
    let o = BuildOptions {
        construction: Construction::BottomUp,
        ..BuildOptions::new(21)
    };
    assert!(matches!(bad(o), OctreeError::Field(_)));
    let (_, t) = deep(21, Vec3::ZERO);
    assert!(matches!(t.to_grid(21), Err(OctreeError::Field(_))));
    // NaN points give NaN, far points the clamped value.
    assert!(t.value(Vec3::NAN).is_nan());
    assert_eq!(t.value(Vec3::splat(1e30)), t.value(Vec3::ONE));
}
