//! Pruned evaluation of the combinators: on random trees of every n-ary operation, offsets,
//! shells, complements, morphs and transforms, and of the modeling vocabulary (profiles
//! extruded and revolved, affine maps and mirrors, repetitions and circular arrays,
//! twists, bends, tapers, elongations, chamfer and stairs blends) over exact primitives,
//! the value clamped to `±cap` equals the full value clamped (bit for bit), lower bounds
//! and distance boxes never exceed the value, measured slopes over random segments never
//! exceed the declared Lipschitz bound, the lazy band equals the dense one, and a union of
//! many children (searched through its bounding-volume hierarchy) equals the brute-force
//! minimum.

use glam::{DMat3, Vec2, Vec3};
use isokit_field::primitives::{Capsule, Cuboid, Primitive, Sphere, Torus};
use isokit_field::profile::{Circle, Ellipse, Polygon, Profile, Rectangle, Slot};
use isokit_field::rng::SplitMix64;
use isokit_field::transform::{Affine, Transformed};
use isokit_field::{BrickGrid, Field, Grid, sample_into, value_clamped};
use isokit_levelset::csg::{
    Blend, Complement, DifferenceN, IntersectionN, Offset, Shell, SmoothKind, SmoothN, UnionN,
};
use isokit_levelset::deform::{Bend, Elongate, Taper, Twist};
use isokit_levelset::morph::LinearMorph;
use isokit_levelset::profile::{Extrude, Revolve};
use isokit_levelset::repeat::{CircularArray, Repeat};
use std::sync::atomic::{AtomicUsize, Ordering};

fn leaf(rng: &mut SplitMix64) -> Box<dyn Field> {
    let c = rng.point_in(Vec3::splat(-0.8), Vec3::splat(0.8));
    let r = rng.range(0.1, 0.5);
    let p: Primitive = match rng.next_u64() % 4 {
        0 => Sphere::new(c, r).unwrap().into(),
        1 => Cuboid::new(c, Vec3::new(r, 0.7 * r, 1.2 * r))
            .unwrap()
            .into(),
        2 => Torus::new(c, r, 0.3 * r).unwrap().into(),
        _ => Capsule::new(c, c + Vec3::new(r, -r, 0.5 * r), 0.4 * r)
            .unwrap()
            .into(),
    };
    Box::new(p)
}

/// A random profile (a 2D shape) centred in `[-0.6, 0.6]²`.
fn profile_leaf(rng: &mut SplitMix64) -> Box<dyn Field> {
    let c = Vec2::new(rng.range(-0.5, 0.5), rng.range(-0.5, 0.5));
    let r = rng.range(0.1, 0.4);
    let p: Profile = match rng.next_u64() % 5 {
        0 => Circle::new(c, r).unwrap().into(),
        1 => Rectangle::new(c, Vec2::new(r, 0.6 * r)).unwrap().into(),
        2 => Ellipse::new(c, Vec2::new(r, 0.5 * r)).unwrap().into(),
        3 => Slot::new(c, c + Vec2::new(r, -0.5 * r), 0.3 * r)
            .unwrap()
            .into(),
        _ => Polygon::regular(c, r, 3 + (rng.next_u64() % 6) as u32, rng.range(0.0, 90.0))
            .unwrap()
            .into(),
    };
    Box::new(p)
}

/// A random tree of profiles (2D CSG, blends and offsets).
fn profile_tree(rng: &mut SplitMix64, depth: usize) -> Box<dyn Field> {
    if depth == 0 || rng.next_u64().is_multiple_of(3) {
        return profile_leaf(rng);
    }
    let kids: Vec<Box<dyn Field>> = (0..2).map(|_| profile_tree(rng, depth - 1)).collect();
    match rng.next_u64() % 4 {
        0 => Box::new(UnionN::new(kids).unwrap()),
        1 => {
            let mut kids = kids;
            let base = kids.remove(0);
            Box::new(DifferenceN::new(base, kids))
        }
        2 => Box::new(
            SmoothN::with_blend(SmoothKind::Union, Blend::Chamfer, rng.range(0.0, 0.2), kids)
                .unwrap(),
        ),
        _ => Box::new(Offset::new(profile_tree(rng, depth - 1), rng.range(-0.05, 0.1)).unwrap()),
    }
}

/// A node of the modeling vocabulary over random children (falling back to a leaf where a
/// random parameter is refused, e.g. a bend through its centre).
fn vocab(rng: &mut SplitMix64, depth: usize) -> Box<dyn Field> {
    let child = |rng: &mut SplitMix64| tree(rng, depth - 1);
    let fallback = |rng: &mut SplitMix64| leaf(rng);
    match rng.next_u64() % 12 {
        0 => {
            let round = rng.range(0.0, 0.1);
            Box::new(Extrude::new(profile_tree(rng, 2), rng.range(0.3, 1.2), round).unwrap())
        }
        1 => Box::new(
            Revolve::new(profile_tree(rng, 2), rng.range(-0.2, 0.8)).unwrap_or_else(|_| {
                let disk: Box<dyn Field> = Box::new(Circle::new(Vec2::new(0.5, 0.0), 0.2).unwrap());
                Revolve::new(disk, 0.0).unwrap()
            }),
        ),
        2 => {
            let cols = [0, 1, 2].map(|_| (rng.unit_vector() * rng.range(0.4, 1.6)).as_dvec3());
            let m = DMat3::from_cols(cols[0], cols[1], cols[2]);
            let t = rng.point_in(Vec3::splat(-0.3), Vec3::splat(0.3)).as_dvec3();
            match Affine::new(child(rng), m, t) {
                Ok(a) => Box::new(a),
                Err(_) => fallback(rng),
            }
        }
        3 => Box::new(Affine::mirror(child(rng), rng.unit_vector(), rng.range(-0.3, 0.3)).unwrap()),
        4 => {
            let count = [1 + rng.below(3) as u32, 1 + rng.below(3) as u32, 1];
            let spacing = rng.point_in(Vec3::splat(-0.8), Vec3::splat(0.8));
            Box::new(Repeat::array(child(rng), count, spacing).unwrap())
        }
        5 => match Repeat::infinite(
            leaf(rng),
            Vec3::new(rng.range(0.5, 1.5), 0.0, rng.range(0.0, 1.0)),
        ) {
            Ok(r) => Box::new(r),
            Err(_) => fallback(rng),
        },
        6 => Box::new(
            CircularArray::new(child(rng), 1 + rng.below(9) as u32, rng.unit_vector()).unwrap(),
        ),
        7 => match Twist::new(child(rng), rng.range(-4.0, 4.0), rng.unit_vector()) {
            Ok(t) => Box::new(t),
            Err(_) => fallback(rng),
        },
        8 => match Bend::new(child(rng), rng.range(-1.0, 1.0)) {
            Ok(b) => Box::new(b),
            Err(_) => fallback(rng),
        },
        9 => match Taper::new(child(rng), rng.range(-0.5, 0.5), rng.unit_vector()) {
            Ok(t) => Box::new(t),
            Err(_) => fallback(rng),
        },
        10 => {
            Box::new(Elongate::new(child(rng), rng.point_in(Vec3::ZERO, Vec3::splat(0.5))).unwrap())
        }
        _ => {
            let kind = [
                SmoothKind::Union,
                SmoothKind::Intersection,
                SmoothKind::Difference,
            ][(rng.next_u64() % 3) as usize];
            let blend = if rng.next_u64().is_multiple_of(2) {
                Blend::Chamfer
            } else {
                Blend::Stairs(1 + rng.below(5) as u32)
            };
            let kids = (0..2 + rng.below(2)).map(|_| child(rng)).collect();
            Box::new(SmoothN::with_blend(kind, blend, rng.range(0.0, 0.3), kids).unwrap())
        }
    }
}

fn tree(rng: &mut SplitMix64, depth: usize) -> Box<dyn Field> {
    tree_with(rng, depth, VOCAB.with(|v| v.get()))
}

thread_local! {
    /// Whether random trees draw from the modeling vocabulary too.
    static VOCAB: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

fn vocab_trees<T>(f: impl FnOnce() -> T) -> T {
    VOCAB.with(|v| v.set(true));
    let out = f();
    VOCAB.with(|v| v.set(false));
    out
}

fn tree_with(rng: &mut SplitMix64, depth: usize, with_vocab: bool) -> Box<dyn Field> {
    if depth == 0 || rng.next_u64().is_multiple_of(5) {
        return leaf(rng);
    }
    if with_vocab && rng.next_u64().is_multiple_of(2) {
        return vocab(rng, depth);
    }
    let n = 1 + (rng.next_u64() % 4) as usize;
    let kids = |rng: &mut SplitMix64, n: usize| -> Vec<Box<dyn Field>> {
        (0..n).map(|_| tree(rng, depth - 1)).collect()
    };
    match rng.next_u64() % 11 {
        0 => Box::new(UnionN::new(kids(rng, n)).unwrap()),
        1 => Box::new(IntersectionN::new(kids(rng, n)).unwrap()),
        2 => {
            let base = tree(rng, depth - 1);
            Box::new(DifferenceN::new(base, kids(rng, n)))
        }
        3..=5 => {
            let kind = [
                SmoothKind::Union,
                SmoothKind::Intersection,
                SmoothKind::Difference,
            ][(rng.next_u64() % 3) as usize];
            let k = rng.range(0.0, 0.4);
            Box::new(SmoothN::new(kind, k, kids(rng, n.max(2))).unwrap())
        }
        6 => Box::new(Offset::new(tree(rng, depth - 1), rng.range(-0.2, 0.2)).unwrap()),
        7 => Box::new(Shell::new(tree(rng, depth - 1), rng.range(0.02, 0.3)).unwrap()),
        8 => Box::new(Complement::new(tree(rng, depth - 1))),
        9 => {
            let t = [0.0, 1.0, 0.3, -0.5, 1.7][(rng.next_u64() % 5) as usize];
            Box::new(LinearMorph::new(tree(rng, depth - 1), tree(rng, depth - 1), t).unwrap())
        }
        _ => Box::new(
            Transformed::new(tree(rng, depth - 1))
                .rotate_axis_degrees(rng.unit_vector(), rng.range(-180.0, 180.0))
                .unwrap()
                .scale(rng.range(0.5, 2.0))
                .unwrap()
                .translate(rng.point_in(Vec3::splat(-0.5), Vec3::splat(0.5)))
                .unwrap(),
        ),
    }
}

#[test]
fn clamped_values_equal_clamped_full_values_on_random_trees() {
    check_clamped(41);
}

/// The same on trees that draw from the modeling vocabulary half of the time.
#[test]
fn clamped_values_equal_clamped_full_values_on_random_vocabulary_trees() {
    vocab_trees(|| check_clamped(42));
}

fn check_clamped(seed: u64) {
    let mut rng = SplitMix64::new(seed);
    let mut pruned_tests = 0;
    for t in 0..60 {
        let f = tree(&mut rng, 4);
        for _ in 0..400 {
            let p = rng.point_in(Vec3::splat(-2.0), Vec3::splat(2.0));
            let full = f.value(p);
            let lb = f.lower_bound(p);
            assert!(!lb.is_nan(), "tree {t}: NaN lower bound at {p}");
            assert!(
                lb <= full + 1e-5,
                "tree {t}: lower bound {lb} > value {full} at {p}"
            );
            if let Some(d) = f.distance_box() {
                let db = d.lower_bound(p);
                assert!(
                    db <= full + 1e-5,
                    "tree {t}: distance box {db} > {full} at {p}"
                );
            }
            for cap in [0.05f32, 0.2, 1.0, f32::INFINITY] {
                let c = value_clamped(&*f, p, cap);
                let want = full.clamp(-cap, cap);
                if lb >= cap {
                    pruned_tests += 1;
                }
                assert!(
                    c == want || (c - want).abs() <= 2e-6 * (1.0 + full.abs()),
                    "tree {t}, cap {cap}: clamped {c} vs {want} (full {full}) at {p}"
                );
            }
        }
    }
    assert!(
        pruned_tests > 1000,
        "the bounds pruned only {pruned_tests} evaluations"
    );
}

#[test]
fn a_large_union_equals_the_brute_force_minimum_and_visits_few_children() {
    let mut rng = SplitMix64::new(7);
    let spheres: Vec<Sphere> = (0..5000)
        .map(|_| {
            Sphere::new(
                rng.point_in(Vec3::splat(-10.0), Vec3::splat(10.0)),
                rng.range(0.05, 0.3),
            )
            .unwrap()
        })
        .collect();
    let u = UnionN::new(spheres.clone()).unwrap();
    assert_eq!(u.children().len(), 5000);
    // Count what the hierarchy evaluates.
    let counted = UnionN::new(
        spheres
            .iter()
            .map(|s| Counted {
                s: *s,
                n: &EVALUATED,
            })
            .collect(),
    )
    .unwrap();
    let pts: Vec<Vec3> = (0..200)
        .map(|_| rng.point_in(Vec3::splat(-10.0), Vec3::splat(10.0)))
        .collect();
    EVALUATED.store(0, Ordering::Relaxed);
    for &p in &pts {
        counted.value(p);
    }
    let per_point = EVALUATED.load(Ordering::Relaxed) as f64 / pts.len() as f64;
    println!("union of 5000 spheres: {per_point:.1} children evaluated per point");
    assert!(per_point < 50.0, "{per_point} children per point");
    for _ in 0..500 {
        let p = rng.point_in(Vec3::splat(-11.0), Vec3::splat(11.0));
        let brute = spheres
            .iter()
            .map(|s| s.value(p))
            .fold(f32::INFINITY, f32::min);
        assert_eq!(u.value(p), brute, "at {p}");
        assert_eq!(value_clamped(&u, p, 0.1), brute.clamp(-0.1, 0.1));
        assert!(u.lower_bound(p) <= brute);
    }
    let b = u.bounds();
    assert!(b.min.cmple(Vec3::splat(-9.5)).all() && b.max.cmpge(Vec3::splat(9.5)).all());
}

static EVALUATED: AtomicUsize = AtomicUsize::new(0);

/// A sphere that counts its evaluations.
struct Counted {
    s: Sphere,
    n: &'static AtomicUsize,
}

impl Field for Counted {
    fn value(&self, p: Vec3) -> f32 {
        self.n.fetch_add(1, Ordering::Relaxed);
        self.s.value(p)
    }
    fn bounds(&self) -> isokit_field::Aabb {
        self.s.bounds()
    }
    fn distance_box(&self) -> Option<isokit_field::DistanceBox> {
        self.s.distance_box()
    }
}

/// A union of children without distance boxes (complements) is still exact.
#[test]
fn unions_of_unboxed_children_visit_them_all() {
    let mut rng = SplitMix64::new(3);
    let kids: Vec<Box<dyn Field>> = (0..20)
        .map(|i: u32| -> Box<dyn Field> {
            let s = Sphere::new(rng.point_in(Vec3::splat(-1.0), Vec3::splat(1.0)), 0.3).unwrap();
            if i.is_multiple_of(3) {
                Box::new(Complement::new(s))
            } else {
                Box::new(s)
            }
        })
        .collect();
    let u = UnionN::new(kids).unwrap();
    for _ in 0..200 {
        let p = rng.point_in(Vec3::splat(-2.0), Vec3::splat(2.0));
        let want = u
            .children()
            .iter()
            .map(|c| c.value(p))
            .fold(f32::INFINITY, f32::min);
        assert_eq!(u.value(p), want);
        assert_eq!(u.lower_bound(p), f32::NEG_INFINITY);
    }
}

/// Measured slopes `|f(p) − f(q)| / |p − q|` over random segments (lengths from 1e-2 to 2)
/// never exceed the declared Lipschitz bound, on random vocabulary trees (up to the f32
/// rounding of the two values).
#[test]
fn measured_slopes_never_exceed_the_declared_bound() {
    vocab_trees(|| {
        let mut rng = SplitMix64::new(43);
        let mut worst = 0.0f32;
        for t in 0..80 {
            let f = tree(&mut rng, 4);
            let l = f.lipschitz();
            assert!(l.is_finite() && l >= 1.0, "tree {t}: Lipschitz {l}");
            for _ in 0..400 {
                let p = rng.point_in(Vec3::splat(-2.0), Vec3::splat(2.0));
                let len = 10f32.powf(rng.range(-2.0, 0.3));
                let q = p + rng.unit_vector() * len;
                let (a, b) = (f.value(p), f.value(q));
                let d = (p - q).length();
                let slope = (a - b).abs() / d;
                let rounding = 4e-7 * (a.abs() + b.abs() + 1.0) / d;
                worst = worst.max(slope / l);
                assert!(
                    slope <= l * (1.0 + 1e-4) + rounding,
                    "tree {t}: slope {slope} > {l} between {p} and {q} ({a}, {b})"
                );
            }
        }
        println!("worst measured slope over the declared bound: {worst:.4}");
    });
}

/// The lazy band (one evaluation per brick decides, with the Lipschitz bound) equals the
/// dense one on random vocabulary trees: every sample clamped to the band agrees.
#[test]
fn lazy_bands_equal_dense_bands_on_random_vocabulary_trees() {
    vocab_trees(|| {
        let mut rng = SplitMix64::new(44);
        let (n, band) = (40usize, 0.08f32);
        let h = 4.0 / (n - 1) as f32;
        let origin = Vec3::splat(-2.0);
        let mut kept = 0usize;
        for t in 0..40 {
            let f = tree(&mut rng, 3);
            let lazy = BrickGrid::sample_field(&*f, [n; 3], origin, h, 4, 0, band, band)
                .unwrap()
                .to_grid()
                .unwrap();
            let mut dense = Grid::new([n; 3], origin, h).unwrap();
            sample_into(&*f, &mut dense);
            for (i, (a, b)) in lazy.data().iter().zip(dense.data()).enumerate() {
                let (a, b) = (a.clamp(-band, band), b.clamp(-band, band));
                assert!(a == b, "tree {t}: sample {i}: lazy {a} vs dense {b}");
                kept += (b.abs() < band) as usize;
            }
        }
        assert!(kept > 10_000, "only {kept} samples in the band");
    });
}

/// A sphere whose value at the origin is `v` (its centre 10 away along `x`).
fn valued(v: f32) -> Sphere {
    Sphere::new(Vec3::new(10.0, 0.0, 0.0), 10.0 - v).unwrap()
}

/// The configurations random trees rarely meet: in a fold of three or more operands, a
/// clamped operand after one a window above the cap and before one just below it shifts
/// the running value, and a later operand near it carries the shift into the result.
/// Swept over the operands' values at one point for every blend and kind.
#[test]
fn a_clamped_middle_operand_of_a_long_blend_does_not_shift_the_result() {
    let grid = |lo: f32, hi: f32, n: usize| -> Vec<f32> {
        (0..n)
            .map(|i| lo + (hi - lo) * i as f32 / (n - 1) as f32)
            .collect()
    };
    let (k, cap) = (1.0f32, 1.0f32);
    for blend in [Blend::Round, Blend::Chamfer, Blend::Stairs(3)] {
        for kind in [
            SmoothKind::Union,
            SmoothKind::Intersection,
            SmoothKind::Difference,
        ] {
            for &a in &grid(0.5, 3.5, 31) {
                for &b in &grid(1.0, 8.0, 29) {
                    for &c in &grid(0.5, 1.5, 21) {
                        // Intersections and differences meet the clamp from below: the
                        // operands mirrored (the difference negates all but the first).
                        let vals = match kind {
                            SmoothKind::Union => [a, b, c, c + 0.01],
                            SmoothKind::Intersection => [-a, -b, -c, -c - 0.01],
                            SmoothKind::Difference => [-a, b, c, c + 0.01],
                        };
                        let f = SmoothN::with_blend(
                            kind,
                            blend,
                            k,
                            vals.iter().map(|&v| valued(v)).collect(),
                        )
                        .unwrap();
                        let p = Vec3::ZERO;
                        let want = f.value(p).clamp(-cap, cap);
                        let got = value_clamped(&f, p, cap);
                        assert!(
                            (got - want).abs() <= 2e-6,
                            "{kind:?} {blend:?} of {vals:?}: clamped {got}, full {want}"
                        );
                    }
                }
            }
        }
    }
}
