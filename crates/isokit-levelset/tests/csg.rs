//! CSG, offset and morph: operators against ERRATA 1, the CSG laws, exactness claims
//! against brute-force distances, Lipschitz constants, bounds, and grid operations.

use glam::Vec3;
use isokit_field::primitives::{Capsule, Cuboid, Sphere, Torus};
use isokit_field::rng::{DEFAULT_SEED, SplitMix64};
use isokit_field::{Aabb, BrickGrid, Field, Grid, sample_into};
use isokit_levelset::csg::{
    self, Complement, CsgError, Difference, DifferenceN, Intersection, IntersectionN, Offset,
    SmoothDifference, SmoothIntersection, SmoothUnion, Union, UnionN, complement_grid,
    difference_brick_grids, difference_grids, intersection_grids, offset_grid,
    smooth_difference_grids, smooth_intersection_grids, smooth_union_grids, union_brick_grids,
    union_grids,
};
use isokit_levelset::morph::{LinearMorph, MorphError, morph_grids};

fn sphere(c: [f32; 3], r: f32) -> Sphere {
    Sphere::new(Vec3::from_array(c), r).unwrap()
}

fn random_points(n: usize, half: f32, seed: u64) -> Vec<Vec3> {
    let mut rng = SplitMix64::new(seed);
    (0..n)
        .map(|_| rng.point_in(Vec3::splat(-half), Vec3::splat(half)))
        .collect()
}

/// `n` nearly uniform points on the sphere (Fibonacci lattice).
fn fibonacci_sphere(c: Vec3, r: f32, n: usize) -> impl Iterator<Item = Vec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n).map(move |i| {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let s = (1.0 - z * z).sqrt();
        let phi = golden * i as f64;
        c + r * Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, z as f32)
    })
}

/// Brute-force signed distance to a union or an intersection of balls: the distance to the
/// nearest of many samples of the result's boundary (the parts of each sphere outside every
/// other ball for a union, inside every other ball for an intersection), signed by
/// membership. Accurate to about the sample spacing.
struct BruteBalls {
    balls: Vec<(Vec3, f32)>,
    union: bool,
    samples: Vec<Vec3>,
}

impl BruteBalls {
    fn new(balls: &[(Vec3, f32)], union: bool, per_sphere: usize) -> Self {
        let mut samples = Vec::new();
        for (i, &(c, r)) in balls.iter().enumerate() {
            for s in fibonacci_sphere(c, r, per_sphere) {
                let others = balls
                    .iter()
                    .enumerate()
                    .filter(|&(j, _)| j != i)
                    .map(|(_, &(cj, rj))| (s - cj).length() < rj);
                let keep = if union {
                    others.into_iter().all(|inside| !inside)
                } else {
                    others.into_iter().all(|inside| inside)
                };
                if keep {
                    samples.push(s);
                }
            }
        }
        Self {
            balls: balls.to_vec(),
            union,
            samples,
        }
    }

    fn signed_distance(&self, p: Vec3) -> f32 {
        let d = self
            .samples
            .iter()
            .map(|s| (p - *s).length_squared())
            .fold(f32::INFINITY, f32::min)
            .sqrt();
        let mut inside = self.balls.iter().map(|&(c, r)| (p - c).length() < r);
        let is_in = if self.union {
            inside.any(|x| x)
        } else {
            inside.all(|x| x)
        };
        if is_in { -d } else { d }
    }
}

// ---------------------------------------------------------------- ERRATA 1

/// 002 Table 2.1 as printed (positive-interior rules).
fn printed_union(a: f32, b: f32) -> f32 {
    a.max(b)
}
fn printed_intersection(a: f32, b: f32) -> f32 {
    a.min(b)
}

#[test]
fn errata1_operators_follow_negative_inside() {
    let a = sphere([-3.0, 0.0, 0.0], 1.0);
    let b = sphere([3.0, 0.0, 0.0], 1.0);
    let pa = Vec3::new(-3.0, 0.0, 0.0);
    let (fa, fb) = (a.value(pa), b.value(pa));
    // A point inside one of two disjoint spheres is inside their union.
    assert!(csg::union(fa, fb) < 0.0);
    assert!(Union::new(a, b).value(pa) < 0.0);
    assert!(UnionN::new(vec![a, b]).unwrap().value(pa) < 0.0);
    // ... which the printed operator gets wrong (this is what the test guards against).
    assert!(printed_union(fa, fb) > 0.0);

    // A point inside only one of two overlapping spheres is outside their intersection.
    let c = sphere([0.5, 0.0, 0.0], 1.0);
    let d = sphere([-0.5, 0.0, 0.0], 1.0);
    let only_c = Vec3::new(1.2, 0.0, 0.0);
    let both = Vec3::ZERO;
    assert!(Intersection::new(c, d).value(only_c) > 0.0);
    assert!(Intersection::new(c, d).value(both) < 0.0);
    assert!(printed_intersection(c.value(only_c), d.value(only_c)) < 0.0);

    // A − B: inside A and outside B is inside; inside both is outside.
    assert!(Difference::new(c, d).value(only_c) < 0.0);
    assert!(Difference::new(c, d).value(both) > 0.0);
    // Complement swaps sides.
    assert!(Complement::new(c).value(both) > 0.0);
    assert!(Complement::new(c).value(Vec3::splat(5.0)) < 0.0);
}

// ---------------------------------------------------------------- CSG laws

#[test]
fn csg_laws_hold_exactly_on_random_points() {
    let a = sphere([0.3, -0.2, 0.1], 1.1);
    let b = Cuboid::new(Vec3::new(-0.4, 0.5, 0.0), Vec3::new(0.9, 0.6, 1.2)).unwrap();
    let c = Torus::new(Vec3::new(0.0, 0.0, 0.4), 1.0, 0.35).unwrap();
    let d = Capsule::new(Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, 1.2, 0.5), 0.4).unwrap();
    let pts = random_points(2000, 2.5, DEFAULT_SEED);
    for &p in &pts {
        let v = |f: &dyn Field| f.value(p);
        // Commutativity.
        assert_eq!(v(&Union::new(a, b)), v(&Union::new(b, a)));
        assert_eq!(v(&Intersection::new(a, c)), v(&Intersection::new(c, a)));
        assert_eq!(
            v(&SmoothUnion::new(a, b, 0.5).unwrap()),
            v(&SmoothUnion::new(b, a, 0.5).unwrap())
        );
        assert_eq!(
            v(&SmoothIntersection::new(a, b, 0.5).unwrap()),
            v(&SmoothIntersection::new(b, a, 0.5).unwrap())
        );
        // Associativity.
        assert_eq!(
            v(&Union::new(Union::new(a, b), c)),
            v(&Union::new(a, Union::new(b, c)))
        );
        assert_eq!(
            v(&Intersection::new(Intersection::new(a, b), c)),
            v(&Intersection::new(a, Intersection::new(b, c)))
        );
        // Idempotence.
        assert_eq!(v(&Union::new(a, a)), v(&a));
        assert_eq!(v(&Intersection::new(c, c)), v(&c));
        // De Morgan with the complement.
        assert_eq!(
            v(&Complement::new(Union::new(a, b))),
            v(&Intersection::new(Complement::new(a), Complement::new(b)))
        );
        assert_eq!(
            v(&Complement::new(Intersection::new(a, b))),
            v(&Union::new(Complement::new(a), Complement::new(b)))
        );
        assert_eq!(
            v(&Complement::new(SmoothUnion::new(a, b, 0.4).unwrap())),
            v(&SmoothIntersection::new(Complement::new(a), Complement::new(b), 0.4).unwrap())
        );
        // Difference is intersection with the complement; double complement is identity.
        assert_eq!(
            v(&Difference::new(a, b)),
            v(&Intersection::new(a, Complement::new(b)))
        );
        assert_eq!(
            v(&SmoothDifference::new(a, b, 0.3).unwrap()),
            v(&SmoothIntersection::new(a, Complement::new(b), 0.3).unwrap())
        );
        assert_eq!(v(&Complement::new(Complement::new(d))), v(&d));
        // Absorption: A ∪ (A ∩ B) = A.
        assert_eq!(v(&Union::new(a, Intersection::new(a, b))), v(&a));
        // n-ary forms equal the binary folds.
        let children: Vec<Box<dyn Field>> =
            vec![Box::new(a), Box::new(b), Box::new(c), Box::new(d)];
        assert_eq!(
            v(&UnionN::new(children).unwrap()),
            v(&Union::new(Union::new(Union::new(a, b), c), d))
        );
        assert_eq!(
            v(&IntersectionN::new(vec![a, sphere([0.0; 3], 1.5)]).unwrap()),
            v(&Intersection::new(a, sphere([0.0; 3], 1.5)))
        );
        let dn: DifferenceN<Sphere, Box<dyn Field>> =
            DifferenceN::new(a, vec![Box::new(b), Box::new(c)]);
        assert_eq!(v(&dn), v(&Difference::new(Difference::new(a, b), c)));
        assert_eq!(v(&DifferenceN::<_, Sphere>::new(a, vec![])), v(&a));
        // Smooth operations with k = 0 are the sharp ones.
        assert_eq!(
            v(&SmoothUnion::new(a, c, 0.0).unwrap()),
            v(&Union::new(a, c))
        );
        assert_eq!(
            v(&SmoothDifference::new(a, c, 0.0).unwrap()),
            v(&Difference::new(a, c))
        );
    }
}

#[test]
fn batch_values_equal_pointwise_values() {
    let a = sphere([0.3, -0.2, 0.1], 1.1);
    let b = Cuboid::new(Vec3::new(-0.4, 0.5, 0.0), Vec3::new(0.9, 0.6, 1.2)).unwrap();
    let fields: Vec<Box<dyn Field>> = vec![
        Box::new(Union::new(a, b)),
        Box::new(Intersection::new(a, b)),
        Box::new(Difference::new(a, b)),
        Box::new(Complement::new(a)),
        Box::new(Offset::new(a, 0.3).unwrap()),
        Box::new(SmoothUnion::new(a, b, 0.5).unwrap()),
        Box::new(SmoothIntersection::new(a, b, 0.5).unwrap()),
        Box::new(SmoothDifference::new(a, b, 0.5).unwrap()),
        Box::new(UnionN::new(vec![a, sphere([1.0; 3], 0.5)]).unwrap()),
        Box::new(IntersectionN::new(vec![a, sphere([1.0; 3], 0.5)]).unwrap()),
        Box::new(DifferenceN::new(a, vec![b])),
        Box::new(LinearMorph::new(a, b, 0.4).unwrap()),
    ];
    let pts = random_points(300, 2.5, 5);
    for f in &fields {
        let mut out = vec![f32::NAN; pts.len() + 1];
        f.values(&pts, &mut out);
        for (p, o) in pts.iter().zip(&out) {
            assert_eq!(*o, f.value(*p));
        }
        assert!(out[pts.len()].is_nan(), "extra entries are left alone");
    }
}

// ---------------------------------------------------------------- exactness

#[test]
fn union_is_exact_outside_and_a_bound_inside() {
    let (ca, cb) = (Vec3::new(-0.6, 0.0, 0.0), Vec3::new(0.6, 0.1, 0.0));
    let u = Union::new(Sphere::new(ca, 1.0).unwrap(), Sphere::new(cb, 0.8).unwrap());
    let brute = BruteBalls::new(&[(ca, 1.0), (cb, 0.8)], true, 40_000);
    let tol = 0.02;
    let (mut outside, mut inside) = (0, 0);
    for p in random_points(600, 2.2, 21) {
        let (v, t) = (u.value(p), brute.signed_distance(p));
        assert_eq!(v > 0.0, t > 0.0, "sign at {p}: {v} vs {t}");
        if v > 0.0 {
            // Outside: the exact distance, up to the brute force's sampling.
            assert!((v - t).abs() < tol, "outside at {p}: {v} vs {t}");
            outside += 1;
        } else {
            // Inside: never more than the true depth.
            assert!(-v <= -t + tol, "inside at {p}: {v} vs {t}");
            inside += 1;
        }
    }
    assert!(outside > 100 && inside > 30, "{outside} {inside}");
    // In the overlap it is strictly a bound: at the origin min(a, b) = −0.4... but the
    // nearest boundary point is on the circle where the spheres meet.
    let p = Vec3::new(0.0, 0.0, 0.0);
    let (v, t) = (u.value(p), brute.signed_distance(p));
    assert!(-v < -t - 0.2, "{v} vs {t}");
    assert!(!u.is_exact());
}

#[test]
fn intersection_is_exact_inside_and_a_bound_outside() {
    let (ca, cb) = (Vec3::new(-0.6, 0.0, 0.0), Vec3::new(0.6, 0.0, 0.1));
    let x = Intersection::new(Sphere::new(ca, 1.0).unwrap(), Sphere::new(cb, 1.0).unwrap());
    let brute = BruteBalls::new(&[(ca, 1.0), (cb, 1.0)], false, 40_000);
    let tol = 0.02;
    let mut inside = 0;
    for p in random_points(800, 1.1, 22) {
        let (v, t) = (x.value(p), brute.signed_distance(p));
        assert_eq!(v > 0.0, t > 0.0, "sign at {p}: {v} vs {t}");
        if v <= 0.0 {
            assert!((v - t).abs() < tol, "inside at {p}: {v} vs {t}");
            inside += 1;
        } else {
            assert!(v <= t + tol, "outside at {p}: {v} vs {t}");
        }
    }
    assert!(inside > 20, "{inside}");
    // Beside the lens's rim the value underestimates the distance to it.
    let p = Vec3::new(0.0, 1.2, 0.05);
    assert!(x.value(p) < brute.signed_distance(p) - 0.03);
}

#[test]
fn complement_and_offset_exactness_flags() {
    let s = sphere([0.0; 3], 1.0);
    assert!(Complement::new(s).is_exact());
    assert!(Offset::new(s, 0.0).unwrap().is_exact());
    assert!(!Offset::new(s, 0.2).unwrap().is_exact());
    assert!(!Offset::new(s, -0.2).unwrap().is_exact());
    assert!(!Complement::new(Union::new(s, s)).is_exact());
    assert!(!SmoothUnion::new(s, s, 0.1).unwrap().is_exact());
    assert!(!Intersection::new(s, s).is_exact());
    assert!(!Difference::new(s, s).is_exact());
    assert!(
        LinearMorph::new(s, Union::new(s, s), 0.0)
            .unwrap()
            .is_exact()
    );
    assert!(!LinearMorph::new(s, s, 0.5).unwrap().is_exact());
}

#[test]
fn dilation_is_exact_outside_and_a_bound_inside() {
    // Two small balls dilated by 0.75: the union of two balls of radius 1.25, whose waist
    // the dilation's inside values do not see.
    let (ca, cb) = (Vec3::new(-1.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0));
    let two = Union::new(Sphere::new(ca, 0.5).unwrap(), Sphere::new(cb, 0.5).unwrap());
    let dil = Offset::new(two, 0.75).unwrap();
    let brute = BruteBalls::new(&[(ca, 1.25), (cb, 1.25)], true, 40_000);
    for p in random_points(300, 2.8, 23) {
        let v = dil.value(p);
        let exact_outside = ((p - ca).length().min((p - cb).length())) - 1.25;
        assert_eq!(v > 0.0, exact_outside > 0.0);
        if v > 0.0 {
            assert!((v - exact_outside).abs() < 1e-5, "{v} vs {exact_outside}");
        } else {
            assert!(-v <= -brute.signed_distance(p) + 0.02);
        }
    }
    // At the waist: value −0.25, true depth 0.75 (the circle where the balls meet).
    let v = dil.value(Vec3::ZERO);
    assert!((v + 0.25).abs() < 1e-6);
    assert!((brute.signed_distance(Vec3::ZERO) + 0.75).abs() < 0.02);
}

#[test]
fn erosion_is_exact_inside_and_a_bound_outside() {
    let cube = Cuboid::new(Vec3::ZERO, Vec3::ONE).unwrap();
    let ero = Offset::new(cube, -0.3).unwrap();
    // The eroded cube is the cube of half extent 0.7 (sharp corners).
    let truth = Cuboid::new(Vec3::ZERO, Vec3::splat(0.7)).unwrap();
    for p in random_points(2000, 2.0, 24) {
        let (v, t) = (ero.value(p), truth.value(p));
        assert_eq!(v > 0.0, t > 0.0, "{p}");
        if v <= 0.0 {
            assert!((v - t).abs() < 1e-5, "{v} vs {t}");
        } else {
            assert!(v <= t + 1e-5, "{v} vs {t}");
        }
    }
    // Diagonally off a corner the offset value is √3 · 1 + 0.3, the true distance √3 · 1.3.
    let p = Vec3::splat(2.0);
    assert!(ero.value(p) < truth.value(p) - 0.2);
    assert_eq!(ero.bounds(), Aabb::new(Vec3::splat(-0.7), Vec3::splat(0.7)));
}

// ---------------------------------------------------------------- smooth operations

#[test]
fn smooth_union_is_union_away_from_the_blend_and_within_k_over_4() {
    let a = sphere([-0.7, 0.0, 0.0], 1.0);
    let b = Cuboid::new(Vec3::new(0.8, 0.2, 0.0), Vec3::new(0.6, 0.9, 0.5)).unwrap();
    for k in [0.1, 0.5, 1.5] {
        let s = SmoothUnion::new(a, b, k).unwrap();
        let (mut sharp, mut blend) = (0, 0);
        for p in random_points(1500, 2.5, 31) {
            let (fa, fb) = (a.value(p), b.value(p));
            let (v, m) = (s.value(p), fa.min(fb));
            assert_eq!(v, csg::smooth_union(fa, fb, k));
            if (fa - fb).abs() >= k {
                assert_eq!(v, m, "at {p}");
                sharp += 1;
            } else {
                blend += 1;
            }
            assert!(v <= m && m - v <= 0.25 * k * (1.0 + 1e-5), "{v} vs {m}");
            // The smooth intersection and difference mirror it.
            let si = SmoothIntersection::new(a, b, k).unwrap().value(p);
            assert!(si >= fa.max(fb) && si - fa.max(fb) <= 0.25 * k * (1.0 + 1e-5));
            let sd = SmoothDifference::new(a, b, k).unwrap().value(p);
            assert!(sd >= fa.max(-fb) && sd - fa.max(-fb) <= 0.25 * k * (1.0 + 1e-5));
        }
        assert!(sharp > 30 && blend > 20, "{sharp} {blend}");
    }
    // Where the two are equal the blend is exactly k/4 below.
    let twin = SmoothUnion::new(
        sphere([-1.0, 0.0, 0.0], 1.0),
        sphere([1.0, 0.0, 0.0], 1.0),
        0.8,
    )
    .unwrap();
    let p = Vec3::new(0.0, 0.3, 0.0);
    let m = sphere([1.0, 0.0, 0.0], 1.0).value(p);
    assert!((m - twin.value(p) - 0.2).abs() < 1e-6);
}

// ---------------------------------------------------------------- Lipschitz and gradients

#[test]
fn lipschitz_constants_hold_on_random_pairs() {
    let a = sphere([-0.5, 0.0, 0.0], 1.0);
    let b = sphere([0.7, 0.3, 0.0], 0.6);
    let c = Cuboid::new(Vec3::new(0.0, 0.5, 0.2), Vec3::new(0.5, 0.9, 0.4)).unwrap();
    let fields: Vec<(&str, Box<dyn Field>)> = vec![
        ("union", Box::new(Union::new(a, c))),
        ("intersection", Box::new(Intersection::new(a, c))),
        ("difference", Box::new(Difference::new(a, b))),
        ("complement", Box::new(Complement::new(c))),
        ("offset", Box::new(Offset::new(c, -0.2).unwrap())),
        (
            "smooth union",
            Box::new(SmoothUnion::new(a, c, 1.0).unwrap()),
        ),
        (
            "smooth union k=3",
            Box::new(SmoothUnion::new(a, b, 3.0).unwrap()),
        ),
        (
            "smooth intersection",
            Box::new(SmoothIntersection::new(a, b, 1.0).unwrap()),
        ),
        (
            "smooth difference",
            Box::new(SmoothDifference::new(a, b, 1.0).unwrap()),
        ),
        ("union n", Box::new(UnionN::new(vec![a, b]).unwrap())),
        ("morph", Box::new(LinearMorph::new(a, c, 0.3).unwrap())),
        ("morph t=2", Box::new(LinearMorph::new(a, b, 2.0).unwrap())),
        (
            "morph t=-1",
            Box::new(LinearMorph::new(a, c, -1.0).unwrap()),
        ),
    ];
    let mut rng = SplitMix64::new(41);
    for (name, f) in &fields {
        let l = f.lipschitz();
        let mut worst = 0.0f32;
        for _ in 0..3000 {
            let p = rng.point_in(Vec3::splat(-2.0), Vec3::splat(2.0));
            let q = p + rng.unit_vector() * rng.range(1e-3, 1.0);
            let ratio = (f.value(p) - f.value(q)).abs() / (p - q).length();
            worst = worst.max(ratio);
            assert!(ratio <= l * (1.0 + 1e-3) + 1e-3, "{name}: {ratio} > {l}");
        }
        // The stated constants are not wildly loose either.
        assert!(worst > 0.5 * l, "{name}: worst {worst}, L {l}");
    }
    // The extrapolated morph's constant |1 − t| + |t| = 3 is attained where the gradients
    // oppose: on the axis between the centres, inside both balls.
    let (ca, cb) = (Vec3::new(-0.5, 0.0, 0.0), Vec3::new(0.7, 0.3, 0.0));
    let (p, q) = (ca.lerp(cb, 0.7), ca.lerp(cb, 0.72));
    let m = &fields[11].1;
    let ratio = (m.value(p) - m.value(q)).abs() / (p - q).length();
    assert!((ratio - 3.0).abs() < 1e-3, "{ratio}");
    assert_eq!(fields[11].1.lipschitz(), 3.0);
    assert_eq!(fields[12].1.lipschitz(), 3.0);
}

#[test]
fn analytic_gradients_match_finite_differences() {
    let a = sphere([-0.5, 0.0, 0.0], 1.0);
    let b = sphere([0.7, 0.3, 0.0], 0.6);
    let c = Cuboid::new(Vec3::new(0.0, 0.5, 0.2), Vec3::new(0.5, 0.9, 0.4)).unwrap();
    let fields: Vec<(&str, Box<dyn Field>)> = vec![
        ("union", Box::new(Union::new(a, b))),
        ("intersection", Box::new(Intersection::new(a, b))),
        ("difference", Box::new(Difference::new(a, b))),
        ("complement", Box::new(Complement::new(b))),
        ("offset", Box::new(Offset::new(a, 0.3).unwrap())),
        (
            "smooth union",
            Box::new(SmoothUnion::new(a, b, 0.8).unwrap()),
        ),
        (
            "smooth intersection",
            Box::new(SmoothIntersection::new(a, b, 0.8).unwrap()),
        ),
        (
            "smooth difference",
            Box::new(SmoothDifference::new(a, b, 0.8).unwrap()),
        ),
        ("union n", Box::new(UnionN::new(vec![a, b]).unwrap())),
        (
            "intersection n",
            Box::new(IntersectionN::new(vec![a, b]).unwrap()),
        ),
        ("difference n", Box::new(DifferenceN::new(a, vec![b]))),
        ("morph", Box::new(LinearMorph::new(a, b, 0.4).unwrap())),
    ];
    let mut rng = SplitMix64::new(43);
    let mut checked = 0;
    while checked < 300 {
        let p = rng.point_in(Vec3::splat(-2.0), Vec3::splat(2.0));
        let (fa, fb) = (a.value(p), b.value(p));
        // Away from ties (kinks of the sharp operations) and the sphere centres.
        if (fa - fb).abs() < 0.05 || (fa + fb).abs() < 0.05 || fa < -0.9 || fb < -0.5 {
            continue;
        }
        checked += 1;
        for (name, f) in &fields {
            let h = 1e-3;
            let fd = Vec3::new(
                f.value(p + h * Vec3::X) - f.value(p - h * Vec3::X),
                f.value(p + h * Vec3::Y) - f.value(p - h * Vec3::Y),
                f.value(p + h * Vec3::Z) - f.value(p - h * Vec3::Z),
            ) / (2.0 * h);
            let g = f.gradient(p);
            assert!((g - fd).length() < 5e-3, "{name} at {p}: {g} vs {fd}");
        }
    }
    // The Hessian of a sharp operation is the active operand's.
    let p = Vec3::new(-1.2, 0.4, 0.3);
    assert_eq!(Union::new(a, c).hessian(p), a.hessian(p));
    assert_eq!(Complement::new(a).hessian(p), -a.hessian(p));
}

// ---------------------------------------------------------------- bounds

/// Every sampled point where the field is ≤ 0 lies in its bounds; returns how many were.
fn assert_bounds_hold(name: &str, f: &dyn Field, pts: &[Vec3]) -> usize {
    let b = f.bounds();
    let mut n = 0;
    for &p in pts {
        if f.value(p) <= 0.0 {
            assert!(
                b.contains(p),
                "{name}: {p} with value {} outside {b:?}",
                f.value(p)
            );
            n += 1;
        }
    }
    n
}

#[test]
fn bounds_contain_every_nonpositive_sample() {
    let a = sphere([-1.5, 0.0, 0.0], 1.0);
    let b = sphere([1.5, 0.0, 0.0], 1.0);
    let c = Cuboid::new(Vec3::new(-0.6, 0.8, 0.0), Vec3::new(0.5, 0.3, 2.0)).unwrap();
    // The blend of a smooth union with a large radius bulges beyond both spheres' boxes.
    let wide = SmoothUnion::new(a, b, 4.0).unwrap();
    let bulge = Vec3::new(0.6, 1.05, 0.0);
    assert!(wide.value(bulge) < 0.0);
    assert!(!a.bounds().union(&b.bounds()).contains(bulge));
    assert!(wide.bounds().contains(bulge));

    let fields: Vec<(&str, Box<dyn Field>)> = vec![
        ("union", Box::new(Union::new(a, c))),
        ("intersection", Box::new(Intersection::new(a, c))),
        ("difference", Box::new(Difference::new(c, a))),
        ("smooth union k=4", Box::new(wide.clone())),
        (
            "smooth union k=1",
            Box::new(SmoothUnion::new(a, c, 1.0).unwrap()),
        ),
        (
            "smooth intersection",
            Box::new(SmoothIntersection::new(a, c, 0.2).unwrap()),
        ),
        (
            "smooth difference",
            Box::new(SmoothDifference::new(c, a, 1.0).unwrap()),
        ),
        ("dilation", Box::new(Offset::new(a, 0.7).unwrap())),
        ("erosion", Box::new(Offset::new(c, -0.25).unwrap())),
        // Nesting relies on property (P): a dilated blend, a blend of blends, and a
        // dilated intersection of disjoint balls (an inverted box that the dilation
        // turns non-empty).
        (
            "dilated blend",
            Box::new(Offset::new(wide.clone(), 0.5).unwrap()),
        ),
        (
            "blend of blends",
            Box::new(SmoothUnion::new(wide.clone(), c, 2.0).unwrap()),
        ),
        (
            "dilated empty intersection",
            Box::new(Offset::new(Intersection::new(a, b), 0.8).unwrap()),
        ),
        ("union n", Box::new(UnionN::new(vec![a, b]).unwrap())),
        (
            "intersection n",
            Box::new(IntersectionN::new(vec![a, b]).unwrap()),
        ),
        ("difference n", Box::new(DifferenceN::new(c, vec![a, b]))),
        ("morph", Box::new(LinearMorph::new(a, c, 0.5).unwrap())),
        (
            "morph t=2",
            Box::new(LinearMorph::new(a, sphere([-1.0, 0.3, 0.0], 1.6), 2.0).unwrap()),
        ),
        (
            "morph t=-1.5",
            Box::new(LinearMorph::new(sphere([0.0; 3], 1.2), c, -1.5).unwrap()),
        ),
    ];
    let pts = random_points(30_000, 5.0, 51);
    for (name, f) in &fields {
        let n = assert_bounds_hold(name, f.as_ref(), &pts);
        if *name != "intersection n" {
            assert!(n > 0, "{name}: no inside sample");
        }
    }
    // The dilated empty intersection is non-empty, and its box is where it should be.
    let di = Offset::new(Intersection::new(a, b), 0.8).unwrap();
    assert!(di.value(Vec3::ZERO) < 0.0);
    assert!(di.bounds().max.x < 0.31);
    // Complement is unbounded.
    assert_eq!(Complement::new(a).bounds(), Aabb::INFINITE);
}

// ---------------------------------------------------------------- morph

#[test]
fn morph_endpoints_and_concentric_spheres() {
    let s1 = sphere([0.0; 3], 1.0);
    let s2 = sphere([0.0; 3], 2.0);
    let c = Cuboid::new(Vec3::new(0.3, 0.0, 0.0), Vec3::new(0.5, 1.0, 0.7)).unwrap();
    let pts = random_points(1000, 3.0, 61);
    let m0 = LinearMorph::new(s1, c, 0.0).unwrap();
    let m1 = LinearMorph::new(s1, c, 1.0).unwrap();
    for &p in &pts {
        assert_eq!(m0.value(p), s1.value(p));
        assert_eq!(m1.value(p), c.value(p));
        assert_eq!(m0.gradient(p), s1.gradient(p));
    }
    assert_eq!(m0.bounds(), s1.bounds());
    assert_eq!(m1.bounds(), c.bounds());
    for t in [0.25f32, 0.5, 0.9, 1.5, -0.5] {
        let m = LinearMorph::new(s1, s2, t).unwrap();
        let r = 1.0 + t;
        for &p in &pts {
            let want = p.length() - r;
            assert!(
                (m.value(p) - want).abs() < 1e-5,
                "t={t}: {} vs {want}",
                m.value(p)
            );
        }
        // The zero crossing along a ray is at the interpolated radius.
        let dir = Vec3::new(0.6, -0.48, 0.64);
        assert!(m.value(dir * r).abs() < 1e-5);
        assert!(m.bounds().contains(dir * r));
    }
    let mut m = LinearMorph::new(s1, s2, 0.5).unwrap();
    assert!(matches!(
        m.set_t(f32::INFINITY),
        Err(MorphError::NonFiniteT(_))
    ));
    m.set_t(0.75).unwrap();
    assert!(m.value(Vec3::new(1.75, 0.0, 0.0)).abs() < 1e-6);
}

// ---------------------------------------------------------------- grids

fn lattice() -> Grid {
    Grid::covering(Aabb::new(Vec3::splat(-2.5), Vec3::splat(2.5)), 21, 0.0).unwrap()
}

fn sampled(f: &dyn Field) -> Grid {
    let mut g = lattice();
    sample_into(f, &mut g);
    g
}

#[test]
fn grid_operations_equal_sampled_field_operations() {
    let a = sphere([-0.5, 0.2, 0.0], 1.2);
    let b = Cuboid::new(Vec3::new(0.6, 0.0, 0.1), Vec3::new(0.7, 1.1, 0.6)).unwrap();
    let (ga, gb) = (sampled(&a), sampled(&b));
    let pairs: Vec<(&str, Grid, Box<dyn Field>)> = vec![
        (
            "union",
            union_grids(&ga, &gb).unwrap(),
            Box::new(Union::new(a, b)),
        ),
        (
            "intersection",
            intersection_grids(&ga, &gb).unwrap(),
            Box::new(Intersection::new(a, b)),
        ),
        (
            "difference",
            difference_grids(&ga, &gb).unwrap(),
            Box::new(Difference::new(a, b)),
        ),
        (
            "smooth union",
            smooth_union_grids(&ga, &gb, 0.6).unwrap(),
            Box::new(SmoothUnion::new(a, b, 0.6).unwrap()),
        ),
        (
            "smooth intersection",
            smooth_intersection_grids(&ga, &gb, 0.6).unwrap(),
            Box::new(SmoothIntersection::new(a, b, 0.6).unwrap()),
        ),
        (
            "smooth difference",
            smooth_difference_grids(&ga, &gb, 0.6).unwrap(),
            Box::new(SmoothDifference::new(a, b, 0.6).unwrap()),
        ),
        (
            "complement",
            complement_grid(&ga),
            Box::new(Complement::new(a)),
        ),
        (
            "offset",
            offset_grid(&gb, -0.2).unwrap(),
            Box::new(Offset::new(b, -0.2).unwrap()),
        ),
        (
            "morph",
            morph_grids(&ga, &gb, 0.35).unwrap(),
            Box::new(LinearMorph::new(a, b, 0.35).unwrap()),
        ),
    ];
    for (name, g, f) in &pairs {
        let want = sampled(f.as_ref());
        assert_eq!(g.dims(), want.dims());
        assert_eq!(g.origin(), want.origin());
        for (x, y) in g.data().iter().zip(want.data()) {
            assert_eq!(x, y, "{name}");
        }
    }
}

#[test]
fn mismatched_grids_are_errors() {
    let g = lattice();
    let other_dims = Grid::new([21, 21, 20], g.origin(), g.spacing()).unwrap();
    let other_origin = Grid::new(g.dims(), g.origin() + Vec3::X * 1e-3, g.spacing()).unwrap();
    let other_spacing = Grid::new(g.dims(), g.origin(), g.spacing() * 1.001).unwrap();
    for h in [&other_dims, &other_origin, &other_spacing] {
        for r in [
            union_grids(&g, h),
            intersection_grids(&g, h),
            difference_grids(&g, h),
            smooth_union_grids(&g, h, 0.1),
        ] {
            assert!(matches!(r, Err(CsgError::GeometryMismatch { .. })));
        }
        assert!(matches!(
            morph_grids(&g, h, 0.5),
            Err(MorphError::Csg(CsgError::GeometryMismatch { .. }))
        ));
    }
    let a = BrickGrid::from_grid(&g, 4, 1, f32::INFINITY, 1.0).unwrap();
    let b = BrickGrid::from_grid(&other_origin, 4, 1, f32::INFINITY, 1.0).unwrap();
    assert!(matches!(
        union_brick_grids(&a, &b, 0.5),
        Err(CsgError::GeometryMismatch { .. })
    ));
    // Same geometry is fine.
    assert!(union_grids(&g, &g.clone()).is_ok());
}

#[test]
fn brick_grid_operations_match_dense_near_the_surface() {
    let a = sphere([-0.6, 0.0, 0.0], 1.0);
    let b = sphere([0.7, 0.2, 0.0], 0.9);
    let (ga, gb) = (sampled(&a), sampled(&b));
    let band = 0.6;
    let ba = BrickGrid::from_grid(&ga, 4, 1, band, band).unwrap();
    let bb = BrickGrid::from_grid(&gb, 4, 1, band, band).unwrap();
    let cases = [
        (
            "union",
            union_brick_grids(&ba, &bb, band).unwrap(),
            union_grids(&ga, &gb).unwrap(),
        ),
        (
            "difference",
            difference_brick_grids(&ba, &bb, band).unwrap(),
            difference_grids(&ga, &gb).unwrap(),
        ),
    ];
    for (name, got, want) in &cases {
        assert!(got.brick_count() > 0);
        assert_eq!(got.brick_size(), 4);
        let mut near = 0;
        for ([i, j, k], w) in want.iter() {
            if w.abs() < 0.5 * band {
                assert_eq!(got.get(i, j, k), w, "{name} at {i} {j} {k}");
                near += 1;
            }
        }
        assert!(near > 50, "{name}: {near}");
    }
    assert_eq!(cases[0].1.background(), band);
    let off = csg::offset_brick_grid(&ba, 0.1, band).unwrap();
    assert_eq!(off.background(), band - 0.1);
    for ([i, j, k], w) in ga.iter() {
        if (w - 0.1).abs() < 0.25 {
            assert_eq!(off.get(i, j, k), w - 0.1);
        }
    }
}
