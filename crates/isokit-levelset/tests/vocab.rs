//! The modeling vocabulary against brute-force references: extrusions and revolutions of
//! profiles (exact, against dense samples of their surfaces and the primitives they equal),
//! repetitions (exact unions, against the minimum over every copy), deformations (bounds:
//! never above the distance to dense samples of the deformed surface, same sign), chamfer
//! and stairs blends (bounds against a fine mesh of their surface), at unit, 1e-6 and 1e6
//! scale, points on the surface and far away included.

use glam::{DVec2, DVec3, Vec2, Vec3};
use isokit_field::primitives::{CappedCylinder, Cuboid, Sphere, Torus};
use isokit_field::profile::{Circle, Polygon, Rectangle};
use isokit_field::rng::SplitMix64;
use isokit_field::{Field, Grid, sample_into};
use isokit_levelset::csg::{Blend, SmoothKind, SmoothN};
use isokit_levelset::deform::{Bend, Elongate, Taper, Twist};
use isokit_levelset::meshing::{MeshOptions, mesh_grid};
use isokit_levelset::profile::{Extrude, Revolve};
use isokit_levelset::repeat::{CircularArray, Repeat};

fn min_dist(samples: &[DVec3], p: Vec3) -> f64 {
    let p = p.as_dvec3();
    samples
        .iter()
        .map(|&s| (s - p).length())
        .fold(f64::INFINITY, f64::min)
}

/// Points on a closed polyline, about `h` apart, and the largest gap.
fn polyline(points: &[DVec2], h: f64) -> Vec<DVec2> {
    let n = points.len();
    let mut out = vec![];
    for i in 0..n {
        let (a, b) = (points[i], points[(i + 1) % n]);
        let k = ((b - a).length() / h).ceil().max(1.0) as usize;
        out.extend((0..k).map(|j| a + (b - a) * (j as f64 / k as f64)));
    }
    out
}

/// A gear-like star of `n` teeth (a non-convex polygon).
fn star(r: f64, depth: f64, n: usize, s: f64) -> Vec<DVec2> {
    (0..4 * n)
        .map(|k| {
            let a = std::f64::consts::TAU * k as f64 / (4 * n) as f64;
            let rr = if (k / 2) % 2 == 0 { r + depth } else { r };
            s * rr * DVec2::new(a.cos(), a.sin())
        })
        .collect()
}

/// Samples of the six faces of the box `c ± half`, about `h` apart.
fn box_surface(c: DVec3, half: DVec3, h: f64) -> Vec<DVec3> {
    let mut out = vec![];
    for axis in 0..3 {
        let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
        let (nu, nv) = (
            (2.0 * half[u] / h).ceil() as usize + 1,
            (2.0 * half[v] / h).ceil() as usize + 1,
        );
        for side in [-1.0, 1.0] {
            for i in 0..nu {
                for j in 0..nv {
                    let mut p = c;
                    p[axis] += side * half[axis];
                    p[u] += half[u] * (2.0 * i as f64 / (nu - 1) as f64 - 1.0);
                    p[v] += half[v] * (2.0 * j as f64 / (nv - 1) as f64 - 1.0);
                    out.push(p);
                }
            }
        }
    }
    out
}

fn random_in(rng: &mut SplitMix64, lo: Vec3, hi: Vec3) -> Vec3 {
    rng.point_in(lo, hi)
}

/// An extruded star and an extruded rectangle are exact: against the distance to dense
/// samples of their walls and caps, with the right sign, at three scales; a rounded
/// extrusion of a circle equals the rounded cylinder (an offset of a smaller cylinder).
#[test]
fn extrusions_are_exact() {
    let mut rng = SplitMix64::new(1);
    for s in [1.0f64, 1e-6, 1e6] {
        let h = 0.02 * s;
        let height = 0.8 * s;
        for (name, pts) in [
            ("star", star(0.5, 0.15, 6, s)),
            (
                "rectangle",
                vec![
                    DVec2::new(-0.6, -0.3) * s,
                    DVec2::new(0.6, -0.3) * s,
                    DVec2::new(0.6, 0.3) * s,
                    DVec2::new(-0.6, 0.3) * s,
                ],
            ),
        ] {
            let f32pts: Vec<Vec2> = pts.iter().map(|p| p.as_vec2()).collect();
            let poly = Polygon::new(&f32pts).unwrap();
            let exact_pts = poly.points().to_vec();
            let e = Extrude::new(poly.clone(), height as f32, 0.0).unwrap();
            assert!(e.is_exact());
            let mut surface = vec![];
            let wall = polyline(&exact_pts, h);
            let nz = (height / h).ceil() as usize;
            for k in 0..=nz {
                let z = -0.5 * height + height * k as f64 / nz as f64;
                surface.extend(wall.iter().map(|w| DVec3::new(w.x, w.y, z)));
            }
            let b = e.bounds();
            let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
            let n = ((hi - lo) / h).ceil();
            for i in 0..=n.x as usize {
                for j in 0..=n.y as usize {
                    let q = lo + DVec3::new(i as f64 * h, j as f64 * h, 0.0);
                    if poly.value(q.as_vec3()) <= 0.0 {
                        surface.push(DVec3::new(q.x, q.y, 0.5 * height));
                        surface.push(DVec3::new(q.x, q.y, -0.5 * height));
                    }
                }
            }
            let gap = 1.5 * h;
            let span = b.size();
            let mut pts3: Vec<Vec3> = (0..300)
                .map(|_| random_in(&mut rng, b.min - 0.4 * span, b.max + 0.4 * span))
                .collect();
            pts3.extend(
                (0..10).map(|k| b.center() + 50.0 * span * rng.unit_vector() * (k as f32 + 1.0)),
            );
            for _ in 0..20 {
                let q = surface[rng.below(surface.len())];
                pts3.push(q.as_vec3());
            }
            for p in pts3 {
                let v = e.value(p) as f64;
                let d = min_dist(&surface, p);
                let tol = 2e-6 * s.max(p.abs().max_element() as f64);
                assert!(
                    v.abs() <= d + tol && v.abs() >= d - gap - tol,
                    "{name} at scale {s}: |{v}| vs {d} at {p}"
                );
                if d > gap {
                    let inside = poly.value(Vec3::new(p.x, p.y, 0.0)) < 0.0
                        && (p.z as f64).abs() < 0.5 * height;
                    assert_eq!(v < 0.0, inside, "{name} at scale {s}: sign at {p}");
                }
                assert!(
                    e.lower_bound(p) <= e.value(p) + 1e-6 * e.value(p).abs(),
                    "{name}: lower bound {} > {} at {p}",
                    e.lower_bound(p),
                    e.value(p)
                );
            }
        }
        // Rounded cap edges of a convex profile: an offset of a smaller cylinder.
        let (rad, r) = (0.5 * s, 0.1 * s);
        let circle = Circle::new(Vec2::ZERO, rad as f32).unwrap();
        let rounded = Extrude::new(circle, height as f32, r as f32).unwrap();
        let inner = CappedCylinder::new(
            Vec3::new(0.0, 0.0, -(0.5 * height - r) as f32),
            Vec3::new(0.0, 0.0, (0.5 * height - r) as f32),
            (rad - r) as f32,
        )
        .unwrap();
        for _ in 0..500 {
            let p = random_in(&mut rng, Vec3::splat(-s as f32), Vec3::splat(s as f32));
            let want = inner.value(p) as f64 - r;
            let v = rounded.value(p) as f64;
            assert!(
                (v - want).abs() <= 2e-6 * s,
                "rounded at scale {s}: {v} vs {want} at {p}"
            );
        }
    }
}

/// A revolved circle is the torus; a revolved rectangle is a tube, exact against dense
/// samples of its surface; a profile across the axis gives a bound with the right sign.
#[test]
fn revolutions_are_exact_on_the_positive_side() {
    let mut rng = SplitMix64::new(2);
    for s in [1.0f64, 1e-6, 1e6] {
        let circle =
            Circle::new(Vec2::new(0.1 * s as f32, 0.2 * s as f32), (0.25 * s) as f32).unwrap();
        let rev = Revolve::new(circle, (0.5 * s) as f32).unwrap();
        assert!(rev.is_exact());
        let torus = Torus::new(
            Vec3::new(0.0, 0.0, (0.2 * s) as f32),
            (0.6 * s) as f32,
            (0.25 * s) as f32,
        )
        .unwrap();
        for _ in 0..1000 {
            let p = random_in(
                &mut rng,
                Vec3::splat(-1.2 * s as f32),
                Vec3::splat(1.2 * s as f32),
            );
            let (v, t) = (rev.value(p), torus.value(p));
            assert!(
                ((v - t) as f64).abs() <= 2e-6 * s,
                "scale {s}: {v} vs {t} at {p}"
            );
        }
    }
    // A tube: the rectangle [0.3, 0.5] × [−0.4, 0.4] revolved.
    let rect = Rectangle::new(Vec2::new(0.4, 0.0), Vec2::new(0.1, 0.4)).unwrap();
    let tube = Revolve::new(rect, 0.0).unwrap();
    let h = 0.01;
    let meridian = polyline(
        &[
            DVec2::new(0.3, -0.4),
            DVec2::new(0.5, -0.4),
            DVec2::new(0.5, 0.4),
            DVec2::new(0.3, 0.4),
        ],
        h,
    );
    let surface: Vec<DVec3> = meridian
        .iter()
        .flat_map(|m| {
            let n = (std::f64::consts::TAU * m.x / h).ceil() as usize;
            (0..n).map(move |k| {
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                DVec3::new(m.x * a.cos(), m.x * a.sin(), m.y)
            })
        })
        .collect();
    for _ in 0..300 {
        let p = random_in(&mut rng, Vec3::splat(-0.8), Vec3::splat(0.8));
        let (v, d) = (tube.value(p) as f64, min_dist(&surface, p));
        assert!(
            v.abs() <= d + 1e-6 && v.abs() >= d - 1.5 * h,
            "tube: {v} vs {d} at {p}"
        );
    }
    // Across the axis: the disk centred on the axis revolved is the ball (exact there, even
    // though the profile crosses), and a disk past the axis gives a bound.
    let across = Revolve::new(Circle::new(Vec2::new(-0.1, 0.0), 0.5).unwrap(), 0.0).unwrap();
    assert!(!across.is_exact());
    let cut: Vec<DVec3> = (0..400)
        .flat_map(|i| {
            let t = std::f64::consts::TAU * i as f64 / 400.0;
            let m = DVec2::new(-0.1 + 0.5 * t.cos(), 0.5 * t.sin());
            (0..200).filter(move |_| m.x >= 0.0).map(move |k| {
                let a = std::f64::consts::TAU * k as f64 / 200.0;
                DVec3::new(m.x * a.cos(), m.x * a.sin(), m.y)
            })
        })
        .collect();
    for _ in 0..300 {
        let p = random_in(&mut rng, Vec3::splat(-0.8), Vec3::splat(0.8));
        let (v, d) = (across.value(p) as f64, min_dist(&cut, p));
        assert!(v.abs() <= d + 1e-6, "across: |{v}| > {d} at {p}");
        let rho = (p.x as f64).hypot(p.y as f64);
        let inside = DVec2::new(rho + 0.1, p.z as f64).length() < 0.5;
        if d > 0.02 {
            assert_eq!(v < 0.0, inside, "across: sign at {p}");
        }
    }
}

/// Repetitions equal the minimum over every copy (the union), exactly, whether the shape is
/// smaller than its cell (then also exact distances) or larger; at 1e6 scale too.
#[test]
fn repetitions_equal_the_union_of_their_copies() {
    let mut rng = SplitMix64::new(3);
    for s in [1.0f32, 1e-6, 1e6] {
        for (name, half) in [
            ("small", Vec3::new(0.2, 0.15, 0.1)),
            ("large", Vec3::new(0.9, 0.3, 0.2)),
        ] {
            let child = Cuboid::new(Vec3::new(0.15, 0.05, 0.0) * s, half * s).unwrap();
            let spacing = Vec3::new(0.7, 0.5, 0.0) * s;
            let arr = Repeat::array(child, [4, 3, 1], spacing).unwrap();
            assert_eq!(arr.is_exact(), name == "small", "{name}");
            let inf = Repeat::infinite(child, Vec3::new(0.7, 0.5, 0.0) * s).unwrap();
            for _ in 0..400 {
                let p = random_in(
                    &mut rng,
                    Vec3::new(-1.5, -1.5, -0.5) * s,
                    Vec3::new(3.5, 2.5, 0.5) * s,
                );
                let mut brute = f32::INFINITY;
                for i in 0..4 {
                    for j in 0..3 {
                        let off = Vec3::new(i as f32, j as f32, 0.0) * spacing;
                        brute = brute.min(child.value(p - off));
                    }
                }
                let tol = 1e-6 * s.max(p.abs().max_element());
                assert!(
                    (arr.value(p) - brute).abs() <= tol,
                    "{name} array at {s}: {} vs {brute}",
                    arr.value(p)
                );
                let mut brute_inf = f32::INFINITY;
                for i in -12..12 {
                    for j in -12..12 {
                        let off = Vec3::new(i as f32 * 0.7, j as f32 * 0.5, 0.0) * s;
                        brute_inf = brute_inf.min(child.value(p - off));
                    }
                }
                assert!(
                    (inf.value(p) - brute_inf).abs() <= tol,
                    "{name} repeat at {s}: {} vs {brute_inf}",
                    inf.value(p)
                );
                for cap in [0.05 * s, 0.3 * s] {
                    let c = isokit_field::value_clamped(&arr, p, cap);
                    assert!((c - brute.clamp(-cap, cap)).abs() <= tol);
                }
                assert!(
                    arr.lower_bound(p) <= arr.value(p) + tol
                        && inf.lower_bound(p) <= inf.value(p) + tol
                );
            }
            // Far from a finite array: still the union.
            let far = Vec3::new(40.0, -30.0, 5.0) * s;
            let mut brute = f32::INFINITY;
            for i in 0..4 {
                for j in 0..3 {
                    brute =
                        brute.min(child.value(far - Vec3::new(i as f32, j as f32, 0.0) * spacing));
                }
            }
            assert!((arr.value(far) - brute).abs() <= 1e-6 * far.length());
        }
    }
}

/// A circular array equals the union of its rotated copies; exact when each copy fits its
/// sector; with the axis along any direction.
#[test]
fn circular_arrays_equal_the_union_of_their_copies() {
    let mut rng = SplitMix64::new(4);
    for (axis, count, half, exact) in [
        (Vec3::Z, 8u32, Vec3::new(0.1, 0.1, 0.2), true),
        (Vec3::new(1.0, 1.0, 0.5), 5, Vec3::new(0.15, 0.1, 0.1), true),
        (Vec3::Z, 12, Vec3::new(0.4, 0.3, 0.2), false),
        (Vec3::Z, 3, Vec3::new(0.8, 0.2, 0.1), false),
    ] {
        let hole = Sphere::new(Vec3::new(0.6, 0.0, 0.0), half.x).unwrap();
        let blockish = Cuboid::new(Vec3::new(0.6, 0.0, 0.0), half).unwrap();
        let ring = CircularArray::new(blockish, count, axis).unwrap();
        let balls = CircularArray::new(hole, count, axis).unwrap();
        assert_eq!(ring.is_exact(), exact, "{axis} {count} {half}");
        let a = axis.as_dvec3().normalize();
        for _ in 0..500 {
            let p = random_in(&mut rng, Vec3::splat(-1.5), Vec3::splat(1.5));
            for (f, child) in [
                (&ring as &dyn Field, &blockish as &dyn Field),
                (&balls, &hole),
            ] {
                let brute = (0..count)
                    .map(|j| {
                        let ang = -std::f64::consts::TAU * j as f64 / count as f64;
                        let q = glam::DQuat::from_axis_angle(a, ang) * p.as_dvec3();
                        child.value(q.as_vec3())
                    })
                    .fold(f32::INFINITY, f32::min);
                assert!(
                    (f.value(p) - brute).abs() < 2e-6,
                    "{count} about {axis}: {} vs {brute} at {p}",
                    f.value(p)
                );
                assert!(f.lower_bound(p) <= f.value(p) + 1e-6);
                let c = isokit_field::value_clamped(f, p, 0.1);
                assert!((c - brute.clamp(-0.1, 0.1)).abs() < 2e-6);
            }
        }
    }
}

/// A ring of 2D profiles about z (a gear's teeth): bounded in x and y though the profile
/// is z-invariant, exact while each tooth stays inside its sector, and equal to the minimum
/// over the copies.
#[test]
fn circular_arrays_of_profiles_are_bounded_in_the_plane() {
    let tooth = Polygon::new(&[
        Vec2::new(0.75, -0.09),
        Vec2::new(0.98, -0.05),
        Vec2::new(0.98, 0.05),
        Vec2::new(0.75, 0.09),
    ])
    .unwrap();
    let ring = CircularArray::new(tooth.clone(), 12, Vec3::Z).unwrap();
    let b = ring.bounds();
    assert!(
        b.min.x >= -1.0 && b.max.x <= 1.0 && b.min.y >= -1.0 && b.max.y <= 1.0,
        "{b:?}"
    );
    assert!(b.min.x < -0.9 && b.max.y > 0.9, "{b:?}");
    assert!(
        b.min.z == f32::NEG_INFINITY && b.max.z == f32::INFINITY,
        "{b:?}"
    );
    assert!(ring.is_exact());
    let mut rng = SplitMix64::new(12);
    for _ in 0..2000 {
        let p = random_in(&mut rng, Vec3::splat(-1.5), Vec3::splat(1.5));
        let brute = (0..12)
            .map(|j| {
                let ang = -std::f64::consts::TAU * j as f64 / 12.0;
                let q = glam::DQuat::from_rotation_z(ang) * p.as_dvec3();
                tooth.value(q.as_vec3())
            })
            .fold(f32::INFINITY, f32::min);
        assert!((ring.value(p) - brute).abs() < 2e-6, "{p}");
        assert!(ring.lower_bound(p) <= ring.value(p) + 1e-6);
    }
    // Extruded, the ring is a bounded solid.
    let gear = Extrude::new(ring, 0.3, 0.0).unwrap();
    assert!(gear.bounds().is_finite());
}

/// A point map (a deformation's forward or inverse map).
type Map = Box<dyn Fn(DVec3) -> DVec3>;

/// The forward maps of the deformations, written independently of the library.
fn twist_fwd(k: f64) -> impl Fn(DVec3) -> DVec3 {
    move |q| {
        let (s, c) = (k * q.z).sin_cos();
        DVec3::new(c * q.x - s * q.y, s * q.x + c * q.y, q.z)
    }
}

fn bend_fwd(k: f64) -> impl Fn(DVec3) -> DVec3 {
    move |q| {
        let (phi, rho) = (k * q.x, 1.0 / k - q.y);
        DVec3::new(rho * phi.sin(), 1.0 / k - rho * phi.cos(), q.z)
    }
}

fn taper_fwd(t: f64) -> impl Fn(DVec3) -> DVec3 {
    move |q| {
        let s = 1.0 + t * q.z;
        DVec3::new(q.x * s, q.y * s, q.z)
    }
}

/// Twist, bend and taper of a box: never above the distance to dense samples of the
/// deformed surface, with the right sign (by the independent inverse maps), at unit, 1e-6
/// and 1e6 scale; elongation of a sphere is the capsule.
#[test]
fn deformations_are_bounds_with_the_right_sign() {
    let mut rng = SplitMix64::new(5);
    for s in [1.0f64, 1e-6, 1e6] {
        let (c, half) = (
            DVec3::new(0.05, 0.0, 0.0) * s,
            DVec3::new(0.3, 0.2, 0.6) * s,
        );
        let child = Cuboid::new(c.as_vec3(), half.as_vec3()).unwrap();
        let surface = box_surface(c, half, 0.015 * s);
        let inside_child = |q: DVec3| ((q - c).abs() - half).max_element() < 0.0;
        let twist_k = 2.5 / s;
        let bend_k = 1.2 / s;
        let taper_t = 0.8 / s;
        let cases: Vec<(&str, Box<dyn Field>, Map, Map)> = vec![
            (
                "twist",
                Box::new(Twist::new(child, twist_k as f32, Vec3::Z).unwrap()),
                Box::new(twist_fwd(twist_k)),
                Box::new(move |p: DVec3| twist_fwd(-twist_k)(p)),
            ),
            (
                "bend",
                Box::new(Bend::new(child, bend_k as f32).unwrap()),
                Box::new(bend_fwd(bend_k)),
                Box::new(move |p: DVec3| {
                    let v = DVec2::new(p.x, 1.0 / bend_k - p.y);
                    DVec3::new(v.x.atan2(v.y) / bend_k, 1.0 / bend_k - v.length(), p.z)
                }),
            ),
            (
                "taper",
                Box::new(Taper::new(child, taper_t as f32, Vec3::Z).unwrap()),
                Box::new(taper_fwd(taper_t)),
                Box::new(move |p: DVec3| {
                    let s = 1.0 + taper_t * p.z;
                    DVec3::new(p.x / s, p.y / s, p.z)
                }),
            ),
        ];
        for (name, f, fwd, inv) in &cases {
            let deformed: Vec<DVec3> = surface.iter().map(|&q| fwd(q)).collect();
            let b = f.bounds();
            let span = b.size();
            let gap = 0.05 * s;
            let mut checked_inside = 0;
            let mut pts: Vec<Vec3> = (0..400)
                .map(|_| random_in(&mut rng, b.min - 0.3 * span, b.max + 0.3 * span))
                .collect();
            pts.extend((0..20).map(|_| deformed[rng.below(deformed.len())].as_vec3()));
            pts.push((b.center() + 1e3 * span).as_dvec3().as_vec3());
            for p in pts {
                let v = f.value(p) as f64;
                let d = min_dist(&deformed, p);
                let tol = 1e-5 * s;
                assert!(
                    v.abs() <= d + tol,
                    "{name} at scale {s}: |{v}| > {d} at {p}"
                );
                assert!(f.lower_bound(p) as f64 <= v + tol, "{name}: lower bound");
                if d > gap {
                    let inside = b.contains(p) && inside_child(inv(p.as_dvec3()));
                    assert_eq!(v < 0.0, inside, "{name} at scale {s}: sign at {p} (d {d})");
                    checked_inside += inside as usize;
                }
                // The bound is not vacuous: within a factor of the true distance.
                if d > 2.0 * gap {
                    assert!(
                        v.abs() >= d / 8.0 - tol,
                        "{name} at scale {s}: {v} far below {d} at {p}"
                    );
                }
            }
            assert!(
                checked_inside > 5,
                "{name}: only {checked_inside} inside points"
            );
        }
        // Elongating a sphere along x gives the capsule.
        let ball = Sphere::new(Vec3::ZERO, (0.3 * s) as f32).unwrap();
        let el = Elongate::new(ball, Vec3::new((0.8 * s) as f32, 0.0, 0.0)).unwrap();
        let cap = isokit_field::primitives::Capsule::new(
            Vec3::new(-(0.4 * s) as f32, 0.0, 0.0),
            Vec3::new((0.4 * s) as f32, 0.0, 0.0),
            (0.3 * s) as f32,
        )
        .unwrap();
        for _ in 0..500 {
            let p = random_in(&mut rng, Vec3::splat(-s as f32), Vec3::splat(s as f32));
            assert!(
                ((el.value(p) - cap.value(p)) as f64).abs() <= 2e-6 * s,
                "elongate at {s}"
            );
        }
    }
}

/// Impossible deformations are refused: a bend through its centre or by 180° or more, a
/// taper to nothing, an unbounded operand.
#[test]
fn impossible_deformations_are_refused() {
    let bar = Cuboid::new(Vec3::ZERO, Vec3::new(1.0, 0.2, 0.2)).unwrap();
    assert!(Bend::new(bar, 10.0).is_err(), "through the centre");
    assert!(Bend::new(bar, 1.6).is_err(), "more than 180°");
    assert!(Bend::new(bar, 1.5).is_ok());
    assert!(Bend::new(bar, 0.0).is_err());
    let tall = Cuboid::new(Vec3::ZERO, Vec3::new(0.2, 0.2, 1.0)).unwrap();
    assert!(Taper::new(tall, 1.0, Vec3::Z).is_err());
    assert!(Taper::new(tall, 0.9, Vec3::Z).is_ok());
    let plane = isokit_field::primitives::Plane::new(Vec3::Z, 0.0).unwrap();
    assert!(Twist::new(plane, 1.0, Vec3::Z).is_err());
    assert!(Twist::new(bar, 1.0, Vec3::ZERO).is_err());
    assert!(Repeat::infinite(plane, Vec3::new(0.0, 0.0, 1.0)).is_err());
    assert!(Repeat::array(bar, [0, 1, 1], Vec3::ONE).is_err());
    assert!(CircularArray::new(bar, 0, Vec3::Z).is_err());
}

/// Chamfer and stairs blends: the sharp operation where the operands differ by the size or
/// more, within half the size of it otherwise, never above the distance to a fine mesh of
/// their surface (plus its resolution), with the sign of their defining formula.
#[test]
fn chamfer_and_stairs_blends_are_bounds() {
    use isokit_levelset::csg::{chamfer_union, stairs_union};
    let mut rng = SplitMix64::new(6);
    for _ in 0..10_000 {
        let (a, b, r) = (
            rng.range(-1.0, 1.0),
            rng.range(-1.0, 1.0),
            rng.range(0.01, 0.5),
        );
        for v in [chamfer_union(a, b, r), stairs_union(a, b, r, 4)] {
            assert!(v <= a.min(b) && v >= a.min(b) - 0.5 * r - 1e-6);
            if (a - b).abs() >= r {
                assert_eq!(v, a.min(b));
            }
        }
    }
    let a = Cuboid::new(Vec3::new(-0.3, 0.0, 0.0), Vec3::new(0.4, 0.4, 0.4)).unwrap();
    let b = Sphere::new(Vec3::new(0.15, 0.1, 0.1), 0.4).unwrap();
    for (kind, blend) in [
        (SmoothKind::Union, Blend::Chamfer),
        (SmoothKind::Union, Blend::Stairs(3)),
        (SmoothKind::Difference, Blend::Chamfer),
        (SmoothKind::Intersection, Blend::Stairs(4)),
    ] {
        let kids: Vec<Box<dyn Field>> = vec![Box::new(a), Box::new(b)];
        let f = SmoothN::with_blend(kind, blend, 0.2, kids).unwrap();
        let n = 121;
        let h = 2.0 / (n - 1) as f32;
        let mut g = Grid::new([n; 3], Vec3::splat(-1.0), h).unwrap();
        sample_into(&f, &mut g);
        let mesh = mesh_grid(&g, &MeshOptions::default()).unwrap();
        let verts: Vec<DVec3> = mesh.positions.iter().map(|p| p.as_dvec3()).collect();
        assert!(
            verts.len() > 1000,
            "{kind:?} {blend:?}: {} vertices",
            verts.len()
        );
        for _ in 0..300 {
            let p = random_in(&mut rng, Vec3::splat(-0.9), Vec3::splat(0.9));
            let v = f.value(p) as f64;
            let d = min_dist(&verts, p);
            assert!(
                v.abs() <= d + 2.0 * h as f64,
                "{kind:?} {blend:?}: |{v}| > {d} at {p}"
            );
        }
        assert_eq!(f.lipschitz(), 1.0);
    }
}
