//! Pruned evaluation of the combinators: on random trees of every n-ary operation, offsets,
//! shells, complements, morphs and transforms over exact primitives, the value clamped to
//! `±cap` equals the full value clamped (bit for bit), lower bounds and distance boxes never
//! exceed the value, and a union of many children (searched through its bounding-volume
//! hierarchy) equals the brute-force minimum.

use glam::Vec3;
use isokit_field::primitives::{Capsule, Cuboid, Primitive, Sphere, Torus};
use isokit_field::rng::SplitMix64;
use isokit_field::transform::Transformed;
use isokit_field::{Field, value_clamped};
use isokit_levelset::csg::{
    Complement, DifferenceN, IntersectionN, Offset, Shell, SmoothKind, SmoothN, UnionN,
};
use isokit_levelset::morph::LinearMorph;
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

fn tree(rng: &mut SplitMix64, depth: usize) -> Box<dyn Field> {
    if depth == 0 || rng.next_u64().is_multiple_of(5) {
        return leaf(rng);
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
    let mut rng = SplitMix64::new(41);
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
