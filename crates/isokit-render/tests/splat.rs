//! Quadric splatting against exact references, one conformance suite for both twins
//! ([`common::twin`]: each test body runs on the CPU twin and, where an adapter exists, on
//! the GPU twin): depths and normals against analytic ray–sphere, ray–cylinder and ray–cone
//! intersections, a far sphere's silhouette, caps end-on, intersecting spheres, a shared
//! depth test with the ray caster, the near plane's cut, soft shadows, outlines, refused
//! input. Bounds against a reference are the CPU's on the CPU and add the documented
//! GPU–CPU agreement ([`splat_tol`]) on the GPU; hit and owner decisions away from grazing
//! rays are exact on both.
//!
//! CPU-only: the screen boxes against dense f64 ray casting (host set-up in f64, shared by
//! both twins), the four-fetch Sobel and the shadow sample pattern (CPU twin functions; the
//! GPU's are compared in `gpu_splat.rs`), the CPU's occlusion culling (the GPU evaluates
//! every fragment) and the CPU's binning limit (the GPU does not bin).

mod common;

use common::twin::{raycast_tol, splat_tol, twins};
use glam::{DMat3, DVec3, Vec3};
use isokit_field::rng::SplitMix64;
use isokit_field::{Camera, Projection};
use isokit_render::quadric::{Quadric, QuadricKind, View};
use isokit_render::splat::{
    self, NO_OBJECT, OutlineOptions, ShadowOptions, SplatOptions, SplatScene, SplatShading,
    camera_uniforms, shadow_sample, sobel4,
};

fn camera(eye: Vec3, target: Vec3, w: u32, h: u32, fov: f32) -> Camera {
    Camera::look_at(
        eye,
        target,
        Vec3::Y,
        Projection::Perspective { fov_y_degrees: fov },
        w,
        h,
    )
    .unwrap()
}

/// The f64 ray of continuous pixel coordinates `(x, y)` (as `Camera::ray`).
fn ray64(v: &View, x: f64, y: f64) -> (DVec3, DVec3) {
    let aspect = f64::from(v.width) / f64::from(v.height);
    let sx = (2.0 * x / f64::from(v.width) - 1.0) * v.half_height * aspect;
    let sy = (1.0 - 2.0 * y / f64::from(v.height)) * v.half_height;
    if v.ortho {
        (v.eye + sx * v.right + sy * v.up, v.forward)
    } else {
        (v.eye, (v.forward + sx * v.right + sy * v.up).normalize())
    }
}

/// Independent f64 reference: the interval of the ray inside the clipped solid, by
/// bisection-free sampling refined with the quadric's own sign (robust, slow): returns the
/// entry parameter of the visible part (t where N ≥ near), if any.
fn visible_entry64(q: &Quadric, v: &View, o: DVec3, d: DVec3) -> Option<f64> {
    let t_near = if v.ortho {
        v.near
    } else {
        v.near / d.dot(v.forward)
    };
    // Solve in parameter space exactly: x(t) = a + t b.
    let ti = q.variance_matrix().inverse();
    let a = ti * o.extend(1.0);
    let b = ti * d.extend(0.0);
    let dg = q.kind().diag();
    let f = |x: glam::DVec4, y: glam::DVec4| {
        dg[0] * x.x * y.x + dg[1] * x.y * y.y + dg[2] * x.z * y.z + dg[3] * x.w * y.w
    };
    let (qa, qb, qc) = (f(b, b), f(a, b), f(a, a));
    let (zlo, zhi) = q.slab();
    let inside = |t: f64| {
        let x = a + b * t;
        (qa * t + 2.0 * qb) * t + qc <= 0.0 && x.z >= zlo && x.z <= zhi
    };
    // Candidate boundaries: quadric roots, slab planes, t_near.
    let mut cands = vec![t_near];
    let disc = qb * qb - qa * qc;
    if qa.abs() > 1e-300 && disc >= 0.0 {
        cands.push((-qb - disc.sqrt()) / qa);
        cands.push((-qb + disc.sqrt()) / qa);
    } else if qa.abs() <= 1e-300 && qb != 0.0 {
        cands.push(-qc / (2.0 * qb));
    }
    if b.z != 0.0 && zlo.is_finite() {
        cands.push((zlo - a.z) / b.z);
        cands.push((zhi - a.z) / b.z);
    }
    cands.retain(|t| t.is_finite() && *t >= t_near);
    cands.sort_by(f64::total_cmp);
    // The solid along the ray is an interval: the first candidate at which (or just after
    // which) the ray is inside.
    for (i, &t) in cands.iter().enumerate() {
        let next = cands.get(i + 1).copied().unwrap_or(t + 1e3);
        let mid = 0.5 * (t + next);
        if inside(t) || inside(mid) {
            return Some(t);
        }
    }
    None
}

fn random_quadric(rng: &mut SplitMix64, centre: DVec3, size: f64) -> Quadric {
    let mut r = || rng.next_f64();
    let c = centre + DVec3::new(r() - 0.5, r() - 0.5, r() - 0.5) * size;
    let dir = DVec3::new(r() - 0.5, r() - 0.5, r() - 0.5).normalize_or(DVec3::X);
    let len = size * (0.2 + 0.5 * r());
    match (r() * 4.0) as u32 {
        0 => Quadric::sphere(c, size * (0.1 + 0.3 * r())).unwrap(),
        1 => {
            let rot = DMat3::from_axis_angle(dir, r() * 6.0);
            let radii = DVec3::new(0.1 + 0.3 * r(), 0.1 + 0.3 * r(), 0.1 + 0.3 * r()) * size;
            Quadric::ellipsoid(c, radii, rot).unwrap()
        }
        2 => Quadric::cylinder(c - dir * len, c + dir * len, size * (0.05 + 0.2 * r())).unwrap(),
        _ => {
            let r0 = if r() < 0.5 { 0.0 } else { size * 0.1 * r() };
            Quadric::cone(c - dir * len, r0, c + dir * len, size * (0.1 + 0.2 * r())).unwrap()
        }
    }
}

/// Checks one quadric's box against the exact coverage: dense samples over the box (grown by
/// 2 pixels) and the image (grown by 4), limited to 60 pixels beyond the image, all lie in
/// the box; and the solid reaches within one pixel of each side of the box.
fn check_box(q: &Quadric, view: &View, label: &str) -> bool {
    let b = q.screen_box(view);
    let (w, h) = (f64::from(view.width), f64::from(view.height));
    let lim = 60.0;
    let mut win = [-4.0, -4.0, w + 4.0, h + 4.0];
    if let Some(b) = b {
        win = [
            win[0].min(b[0] - 2.0).max(-lim),
            win[1].min(b[1] - 2.0).max(-lim),
            win[2].max(b[2] + 2.0).min(w + lim),
            win[3].max(b[3] + 2.0).min(h + lim),
        ];
    }
    let sub = 3.0;
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    let nx = ((win[2] - win[0]) * sub) as i64;
    let ny = ((win[3] - win[1]) * sub) as i64;
    for j in 0..=ny {
        for i in 0..=nx {
            let (x, y) = (win[0] + i as f64 / sub, win[1] + j as f64 / sub);
            let (o, d) = ray64(view, x, y);
            if visible_entry64(q, view, o, d).is_some() {
                lo = [lo[0].min(x), lo[1].min(y)];
                hi = [hi[0].max(x), hi[1].max(y)];
                let b = b.unwrap_or_else(|| panic!("{label}: covered at ({x}, {y}) but culled"));
                assert!(
                    x >= b[0] - 1e-3 && x <= b[2] + 1e-3 && y >= b[1] - 1e-3 && y <= b[3] + 1e-3,
                    "{label}: covered sample ({x}, {y}) outside box {b:?}"
                );
            }
        }
    }
    let Some(b) = b else {
        return false;
    };
    if lo[0] > hi[0] {
        // Nothing covered in the window: the box must be thinner than a sample step or lie
        // outside the window.
        let outside = b[2] < win[0] || b[0] > win[2] || b[3] < win[1] || b[1] > win[3];
        let thin = b[2] - b[0] < 1.0 / sub || b[3] - b[1] < 1.0 / sub;
        assert!(
            outside || thin,
            "{label}: box {b:?} but nothing covered in {win:?}"
        );
        return false;
    }
    // Tightness: one pixel inward from each side (the middle line when the box is thinner
    // than two pixels), a fine scan across the box's whole extent must meet the solid.
    for k in 0..4 {
        let horizontal = k % 2 == 0; // sides 0 and 2 bound x
        let (lo_s, hi_s) = if horizontal {
            (b[0], b[2])
        } else {
            (b[1], b[3])
        };
        let line = if hi_s - lo_s < 2.0 {
            0.5 * (lo_s + hi_s)
        } else if k < 2 {
            lo_s + 1.0
        } else {
            hi_s - 1.0
        };
        let (a0, a1) = if horizontal {
            (b[1], b[3])
        } else {
            (b[0], b[2])
        };
        let (a0, a1) = (a0.max(-2000.0), a1.min(2000.0));
        let steps = (((a1 - a0) * 64.0) as i64).clamp(64, 40_000);
        let met = (0..=steps).any(|i| {
            let a = a0 + (a1 - a0) * i as f64 / steps as f64;
            let (x, y) = if horizontal { (line, a) } else { (a, line) };
            let (o, d) = ray64(view, x, y);
            visible_entry64(q, view, o, d).is_some()
        });
        assert!(
            met,
            "{label}: box {b:?} side {k}: nothing within one pixel of it"
        );
    }
    true
}

/// Boxes of random quadrics hold every covered pixel and are tight. CPU-only: host set-up.
#[test]
fn boxes_hold_every_covered_pixel_and_are_tight() {
    let mut rng = SplitMix64::new(7);
    let mut seen = 0;
    for case in 0..40 {
        let q = random_quadric(&mut rng, DVec3::ZERO, 2.0);
        let eye = Vec3::new(0.3, 0.8, 4.0 + 3.0 * rng.next_f64() as f32);
        let cam = camera(eye, Vec3::ZERO, 40, 30, 50.0);
        let u = camera_uniforms(&cam).unwrap();
        let view = View::from_uniforms(&u, 0.05);
        seen += usize::from(check_box(&q, &view, &format!("case {case} {:?}", q.kind())));
    }
    assert!(seen >= 30, "only {seen} quadrics were visible");
}

/// Boxes are tight across the near plane and behind the eye. CPU-only: host set-up.
#[test]
fn boxes_are_tight_across_the_near_plane_and_behind_the_eye() {
    let mut rng = SplitMix64::new(11);
    let mut crossing = 0;
    for case in 0..40 {
        // Quadrics around the eye: partly behind it, cut by the near plane.
        let eye = Vec3::new(0.0, 0.0, 0.0);
        let cam = camera(eye, Vec3::new(0.2, 0.1, -1.0), 32, 24, 60.0);
        let u = camera_uniforms(&cam).unwrap();
        let near = 0.3;
        let view = View::from_uniforms(&u, near);
        let q = random_quadric(&mut rng, DVec3::new(0.0, 0.0, -0.4), 1.6);
        // Does the near plane cut the solid? (sample its bounds' corners' depth range)
        let (lo, hi) = q.bounds();
        let f = view.forward;
        let depths = [lo.x, hi.x]
            .iter()
            .flat_map(|&x| [lo.y, hi.y].map(move |y| (x, y)))
            .flat_map(|(x, y)| [lo.z, hi.z].map(move |z| DVec3::new(x, y, z)))
            .map(|p| (p - view.eye).dot(f))
            .collect::<Vec<_>>();
        if depths.iter().any(|&d| d < near) && depths.iter().any(|&d| d > near) {
            crossing += 1;
        }
        check_box(&q, &view, &format!("near case {case} {:?}", q.kind()));
    }
    assert!(
        crossing >= 20,
        "only {crossing} cases straddle the near plane"
    );
}

/// Orthographic boxes are tight. CPU-only: host set-up.
#[test]
fn orthographic_boxes_are_tight() {
    let mut rng = SplitMix64::new(5);
    for case in 0..15 {
        let q = random_quadric(&mut rng, DVec3::ZERO, 2.0);
        let cam = Camera::look_at(
            Vec3::new(1.0, 2.0, 5.0),
            Vec3::ZERO,
            Vec3::Y,
            Projection::Orthographic { height: 4.0 },
            40,
            30,
        )
        .unwrap();
        let u = camera_uniforms(&cam).unwrap();
        check_box(&q, &View::from_uniforms(&u, 0.0), &format!("ortho {case}"));
    }
}

/// Analytic first hit of a ray with a sphere.
fn ray_sphere(o: Vec3, d: Vec3, c: Vec3, r: f32) -> Option<f32> {
    let oc = (o - c).as_dvec3();
    let d = d.as_dvec3();
    let b = oc.dot(d);
    let perp = oc - b * d;
    let disc = f64::from(r).powi(2) - perp.length_squared();
    (disc >= 0.0).then(|| (-b - disc.sqrt()) as f32)
}

/// A sphere's depths, normals and curvatures against the analytic ray–sphere intersection,
/// on both twins; every pixel off the silhouette (by 1e-4) hits or misses as the analytic
/// ray does and sees object 0 or none (exact on both: the GPU's masks differ from the CPU's
/// only on grazing rays). Bounds (the CPU's; on the GPU plus the documented agreement of
/// [`splat_tol`]): `Z` within 2e-5·t (+ `DEPTH_REL`·t), normals within 2e-3 rad
/// (+ `NORMAL_RAD`), `k1`, `k2` within 1e-4 of 1/r (+ `K_REL`/r: f32 curvature on the GPU).
#[test]
fn sphere_depths_normals_and_curvatures_are_exact() {
    use splat_tol::{DEPTH_REL, K_REL, NORMAL_RAD};
    let c = Vec3::new(0.2, -0.1, 0.0);
    let r = 0.8;
    let mut scene = SplatScene::default();
    scene.push(
        Quadric::sphere(c.as_dvec3(), f64::from(r)).unwrap(),
        Vec3::ONE,
    );
    let cam = camera(Vec3::new(0.5, 0.8, 4.0), Vec3::ZERO, 64, 48, 40.0);
    for t in twins("sphere_depths_normals_and_curvatures_are_exact") {
        let tol_z = t.tol(2e-5, 2e-5 + DEPTH_REL);
        let tol_n = t.tol(2e-3, 2e-3 + NORMAL_RAD);
        let tol_k = t.tol(1e-4, 1e-4 + K_REL / r);
        let frame = t.splat(&scene, &cam, &SplatOptions::default()).unwrap();
        let mut hits = 0;
        for py in 0..48 {
            for px in 0..64 {
                let ray = cam.ray(px as f32 + 0.5, py as f32 + 0.5);
                let g = frame.gbuffer.get(px, py);
                match ray_sphere(ray.origin, ray.dir, c, r) {
                    Some(tt) => {
                        // Grazing pixels may flip within rounding.
                        let perp =
                            ((ray.origin - c) - (ray.origin - c).dot(ray.dir) * ray.dir).length();
                        if (perp - r).abs() < 1e-4 {
                            continue;
                        }
                        hits += 1;
                        assert!(g.is_hit(), "{t}: pixel ({px}, {py}) missed");
                        assert!(
                            (g.depth - tt).abs() < tol_z * tt,
                            "{t}: depth {} vs {tt}",
                            g.depth
                        );
                        let n = (ray.origin + tt * ray.dir - c) / r;
                        assert!(
                            g.normal.angle_between(n) < tol_n,
                            "{t}: normal {} vs {n}",
                            g.normal
                        );
                        assert!(
                            (g.k1 - 1.0 / r).abs() < tol_k && (g.k2 - 1.0 / r).abs() < tol_k,
                            "{t}: k {} {}",
                            g.k1,
                            g.k2
                        );
                        assert_eq!(frame.objects[(px + 64 * py) as usize], 0, "{t}");
                    }
                    None => {
                        assert!(
                            !g.is_hit(),
                            "{t}: pixel ({px}, {py}) hit outside the sphere"
                        );
                        assert_eq!(frame.objects[(px + 64 * py) as usize], NO_OBJECT, "{t}");
                    }
                }
            }
        }
        assert!(hits > 400, "{t}: {hits}");
    }
}

/// A sphere 1000 radii away keeps its silhouette (the shifted quadratic keeps the
/// discriminant accurate in f32), on both twins: every ray more than 2e-3 off the
/// silhouette hits or misses as the analytic one (exact on both).
#[test]
fn a_far_sphere_keeps_its_silhouette() {
    let r = 1.0f32;
    let mut scene = SplatScene::default();
    scene.push(
        Quadric::sphere(DVec3::ZERO, f64::from(r)).unwrap(),
        Vec3::ONE,
    );
    let cam = camera(Vec3::new(0.0, 0.0, 1000.0), Vec3::ZERO, 64, 64, 0.2);
    for t in twins("a_far_sphere_keeps_its_silhouette") {
        let frame = t.splat(&scene, &cam, &SplatOptions::default()).unwrap();
        let mut wrong = 0;
        for py in 0..64 {
            for px in 0..64 {
                let ray = cam.ray(px as f32 + 0.5, py as f32 + 0.5);
                let exact = ray_sphere(ray.origin, ray.dir, Vec3::ZERO, r);
                let perp = (ray.origin - ray.origin.dot(ray.dir) * ray.dir).length();
                if (perp - r).abs() > 2e-3 && exact.is_some() != frame.gbuffer.get(px, py).is_hit()
                {
                    wrong += 1;
                }
            }
        }
        assert_eq!(wrong, 0, "{t}");
    }
}

/// A cylinder's and a cone's sides against the analytic intersection, on both twins: every
/// pixel off the silhouette and the rims hits; `Z` within 3e-5·t, normals within 2e-3 rad,
/// the cylinder's `k1` = 1/r and `k2` = 0 within 1e-3 (the CPU's bounds; on the GPU plus
/// the documented [`splat_tol`] agreement: `DEPTH_REL`·t, `NORMAL_RAD`, `K_REL`·|k1|).
#[test]
fn cylinder_and_cone_depths_and_normals_are_exact() {
    use splat_tol::{DEPTH_REL, K_REL, NORMAL_RAD};
    // Axis along x; the camera looks from +z so the side is seen.
    let cyl =
        Quadric::cylinder(DVec3::new(-1.0, 0.0, 0.0), DVec3::new(1.0, 0.0, 0.0), 0.4).unwrap();
    let cone = Quadric::cone(
        DVec3::new(-1.0, 0.0, 0.0),
        0.0,
        DVec3::new(1.0, 0.0, 0.0),
        0.5,
    )
    .unwrap();
    for t in twins("cylinder_and_cone_depths_and_normals_are_exact") {
        let tol_z = f64::from(t.tol(3e-5, 3e-5 + DEPTH_REL));
        let tol_n = t.tol(2e-3, 2e-3 + NORMAL_RAD);
        let tol_k = t.tol(1e-3, 1e-3 + K_REL * 2.5);
        for (q, name) in [(cyl, "cylinder"), (cone, "cone")] {
            let mut scene = SplatScene::default();
            scene.push(q, Vec3::ONE);
            let cam = camera(Vec3::new(0.0, 0.3, 4.0), Vec3::ZERO, 80, 40, 40.0);
            let frame = t.splat(&scene, &cam, &SplatOptions::default()).unwrap();
            let mut checked = 0;
            for py in 0..40 {
                for px in 0..80 {
                    let ray = cam.ray(px as f32 + 0.5, py as f32 + 0.5);
                    let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
                    // Analytic: radius(x) = a + b x along the x axis, side only (|x| < 1).
                    let (ra, rb) = if name == "cylinder" {
                        (0.4, 0.0)
                    } else {
                        (0.25, 0.25)
                    };
                    // (oy + t dy)² + (oz + t dz)² = (ra + rb (ox + t dx))².
                    let qa = d.y * d.y + d.z * d.z - rb * rb * d.x * d.x;
                    let qb = o.y * d.y + o.z * d.z - rb * d.x * (ra + rb * o.x);
                    let qc = o.y * o.y + o.z * o.z - (ra + rb * o.x).powi(2);
                    let disc = qb * qb - qa * qc;
                    let g = frame.gbuffer.get(px, py);
                    if disc < 1e-6 {
                        continue;
                    }
                    let tt = (-qb - disc.sqrt()) / qa;
                    let p = o + tt * d;
                    if p.x.abs() > 0.98 || (ra + rb * p.x) < 0.02 {
                        continue;
                    }
                    assert!(g.is_hit(), "{t}, {name}: ({px}, {py}) missed");
                    assert!(
                        (f64::from(g.depth) - tt).abs() < tol_z * tt,
                        "{t}, {name}: depth {} vs {tt}",
                        g.depth
                    );
                    // Normal ∝ (−rb (ra + rb x), y, z).
                    let n = DVec3::new(-rb * (ra + rb * p.x), p.y, p.z)
                        .normalize()
                        .as_vec3();
                    assert!(
                        g.normal.angle_between(n) < tol_n,
                        "{t}, {name}: normal {} vs {n}",
                        g.normal
                    );
                    if name == "cylinder" {
                        assert!(
                            (g.k1 - 2.5).abs() < tol_k && g.k2.abs() < tol_k,
                            "{t}: k {} {}",
                            g.k1,
                            g.k2
                        );
                    }
                    checked += 1;
                }
            }
            assert!(checked > 150, "{t}, {name}: {checked}");
        }
    }
}

/// Looking down a cylinder's axis, on both twins: the cap is a disc facing the eye, even for
/// the centre ray that is parallel to the axis (no roots of the side's quadratic); its depth
/// within 1e-5 of 4 and its normal within 1e-5 of +z (on the GPU plus `DEPTH_REL`·4 and
/// `NORMAL_RAD`, [`splat_tol`]), its id the cap's (exact on both).
#[test]
fn cylinder_caps_are_hit_end_on() {
    use splat_tol::{DEPTH_REL, NORMAL_RAD};
    let mut scene = SplatScene::default();
    scene.push(
        Quadric::cylinder(DVec3::new(0.0, 0.0, -1.0), DVec3::new(0.0, 0.0, 1.0), 0.5).unwrap(),
        Vec3::ONE,
    );
    let cam = camera(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 33, 33, 30.0);
    for t in twins("cylinder_caps_are_hit_end_on") {
        let frame = t.splat(&scene, &cam, &SplatOptions::default()).unwrap();
        let g = frame.gbuffer.get(16, 16);
        assert!(g.is_hit(), "{t}");
        let tol_z = t.tol(1e-5, 1e-5 + DEPTH_REL * 4.0);
        assert!((g.depth - 4.0).abs() < tol_z, "{t}: {}", g.depth);
        let tol_n = t.tol(1e-5, 1e-5 + NORMAL_RAD);
        assert!((g.normal - Vec3::Z).length() < tol_n, "{t}: {}", g.normal);
        assert_eq!(g.id, isokit_render::kernel::ID_CAP, "{t}");
    }
}

/// Two intersecting spheres meet on their intersection curve, on both twins: where the two
/// analytic depths differ by more than 1e-4 relative, the nearer sphere owns the pixel
/// (exact on both: 10 times the GPU's documented depth agreement) and the depth is the
/// nearer one within 1e-4 (on the GPU plus `DEPTH_REL`·t, [`splat_tol`]).
#[test]
fn intersecting_spheres_meet_on_their_intersection_curve() {
    let (c0, r0) = (Vec3::new(-0.4, 0.0, 0.0), 0.7);
    let (c1, r1) = (Vec3::new(0.45, 0.1, 0.2), 0.6);
    let mut scene = SplatScene::default();
    scene.push(
        Quadric::sphere(c0.as_dvec3(), f64::from(r0)).unwrap(),
        Vec3::X,
    );
    scene.push(
        Quadric::sphere(c1.as_dvec3(), f64::from(r1)).unwrap(),
        Vec3::Y,
    );
    let cam = camera(Vec3::new(0.3, 1.0, 4.0), Vec3::ZERO, 96, 64, 40.0);
    for t in twins("intersecting_spheres_meet_on_their_intersection_curve") {
        let rel = t.tol(0.0, splat_tol::DEPTH_REL);
        let frame = t.splat(&scene, &cam, &SplatOptions::default()).unwrap();
        let mut both = 0;
        for py in 0..64 {
            for px in 0..96 {
                let ray = cam.ray(px as f32 + 0.5, py as f32 + 0.5);
                let t0 = ray_sphere(ray.origin, ray.dir, c0, r0);
                let t1 = ray_sphere(ray.origin, ray.dir, c1, r1);
                let obj = frame.objects[(px + 96 * py) as usize];
                if let (Some(a), Some(b)) = (t0, t1) {
                    if (a - b).abs() > 1e-4 * a {
                        both += 1;
                        assert_eq!(obj, u32::from(b < a), "{t}: pixel ({px}, {py}): {a} vs {b}");
                        let z = a.min(b);
                        assert!(
                            (frame.gbuffer.get(px, py).depth - z).abs() < 1e-4 + rel * z,
                            "{t}: ({px}, {py})"
                        );
                    }
                }
            }
        }
        assert!(both > 100, "{t}: {both}");
    }
}

/// A splatted sphere and a ray-cast isosurface (a sphere sampled on a 64³ grid) share one
/// depth test, on both twins (each ray casts and splats; the merge is host code): each
/// pixel shows the nearer surface (exact on both, away from the intersection curve by three
/// voxels of depth), and the depth is the analytic one: within 0.05 voxel for the
/// isosurface and 1e-5 relative for the quadric (on the GPU plus the documented
/// [`raycast_tol::Z_VOXEL`] and [`splat_tol::DEPTH_REL`]).
#[test]
fn quadrics_and_ray_cast_isosurfaces_share_the_depth_buffer() {
    use isokit_render::RenderOptions;
    let (ca, ra) = (Vec3::new(-0.3, 0.0, 0.0), 0.55f32);
    let (cb, rb) = (Vec3::new(0.3, 0.05, 0.1), 0.5f32);
    let n = 64;
    let h = 2.0 / (n - 1) as f32;
    let g = common::grid_of(n, |p| (p - ca).length() - ra);
    let volume = common::volume(g);
    let cam = camera(Vec3::new(0.4, 1.2, 3.5), Vec3::ZERO, 96, 72, 40.0);
    let mut scene = SplatScene::default();
    scene.push(
        Quadric::sphere(cb.as_dvec3(), f64::from(rb)).unwrap(),
        Vec3::X,
    );
    for mut t in twins("quadrics_and_ray_cast_isosurfaces_share_the_depth_buffer") {
        let tol_a = t.tol(0.05, 0.05 + raycast_tol::Z_VOXEL) * h;
        let tol_b = t.tol(1e-5, 1e-5 + splat_tol::DEPTH_REL);
        let cast = t.render(&volume, &cam, &RenderOptions::default()).unwrap();
        let mut frame = t.splat(&scene, &cam, &SplatOptions::default()).unwrap();
        let taken = frame.merge_nearest(&cast.gbuffer).unwrap();
        assert!(taken > 100, "{t}: {taken}");
        let mut compared = 0;
        for py in 0..72 {
            for px in 0..96 {
                let ray = cam.ray(px as f32 + 0.5, py as f32 + 0.5);
                let (ta, tb) = (
                    ray_sphere(ray.origin, ray.dir, ca, ra),
                    ray_sphere(ray.origin, ray.dir, cb, rb),
                );
                let (Some(ta), Some(tb)) = (ta, tb) else {
                    continue;
                };
                // Away from the intersection curve (a few voxels of depth difference) the
                // nearer surface must win, and the depth must be the analytic one.
                if (ta - tb).abs() < 3.0 * h {
                    continue;
                }
                compared += 1;
                let g = frame.gbuffer.get(px, py);
                let obj = frame.objects[(px + 96 * py) as usize];
                if ta < tb {
                    assert_eq!(
                        obj, NO_OBJECT,
                        "{t}: ({px}, {py}): the isosurface is nearer"
                    );
                    assert!((g.depth - ta).abs() < tol_a, "{t}: {} vs {ta}", g.depth);
                } else {
                    assert_eq!(obj, 0, "{t}: ({px}, {py}): the quadric is nearer");
                    assert!(
                        (g.depth - tb).abs() < tol_b * tb,
                        "{t}: {} vs {tb}",
                        g.depth
                    );
                }
            }
        }
        assert!(compared > 100, "{t}: {compared}");
        let mut small = t
            .splat(
                &scene,
                &camera(Vec3::Z * 3.0, Vec3::ZERO, 8, 8, 40.0),
                &SplatOptions::default(),
            )
            .unwrap();
        assert!(small.merge_nearest(&cast.gbuffer).is_err(), "{t}");
    }
}

/// The eye inside a big sphere, on both twins: every pixel sees the near plane's cut, a cap
/// at the near plane (within 1e-5, on the GPU plus `DEPTH_REL`: positions are `o + Z d`
/// with `|P|` and `Z` below 1 here) facing the eye (normal within 1e-6 of +z, on the GPU
/// plus `NORMAL_RAD`, [`splat_tol`]). A sphere wholly behind the eye is culled (exact).
#[test]
fn the_near_plane_cuts_a_solid_with_a_flat_cap() {
    use splat_tol::{DEPTH_REL, NORMAL_RAD};
    let mut scene = SplatScene::default();
    scene.push(Quadric::sphere(DVec3::ZERO, 3.0).unwrap(), Vec3::ONE);
    let cam = camera(Vec3::new(0.0, 0.0, 1.0), Vec3::ZERO, 16, 16, 60.0);
    let mut behind = SplatScene::default();
    behind.push(
        Quadric::sphere(DVec3::new(0.0, 0.0, 3.0), 1.0).unwrap(),
        Vec3::ONE,
    );
    for t in twins("the_near_plane_cuts_a_solid_with_a_flat_cap") {
        let tol_p = t.tol(1e-5, 1e-5 + DEPTH_REL);
        let tol_n = t.tol(1e-6, 1e-6 + NORMAL_RAD);
        let frame = t
            .splat(
                &scene,
                &cam,
                &SplatOptions {
                    near: Some(0.5),
                    ..Default::default()
                },
            )
            .unwrap();
        for p in frame.gbuffer.pixels() {
            assert_eq!(p.id, isokit_render::kernel::ID_CAP, "{t}");
            assert!((p.position.z - 0.5).abs() < tol_p, "{t}: {}", p.position);
            assert!((p.normal - Vec3::Z).length() < tol_n, "{t}: {}", p.normal);
        }
        let frame = t.splat(&behind, &cam, &SplatOptions::default()).unwrap();
        assert_eq!(frame.stats.drawn, 0, "{t}");
        assert_eq!(frame.gbuffer.hit_count(), 0, "{t}");
    }
}

/// The four-fetch Sobel equals the full 3x3 masks. CPU-only: `sobel4`, the CPU twin's
/// filter (the GPU's fetches are compared with it in `gpu_splat.rs`).
#[test]
fn sobel_with_four_fetches_equals_the_full_masks() {
    let (w, h) = (9u32, 7u32);
    let mut rng = SplitMix64::new(3);
    let img: Vec<[f32; 1]> = (0..w * h).map(|_| [rng.next_f64() as f32]).collect();
    let at = |x: i64, y: i64| img[(x.clamp(0, 8) + 9 * y.clamp(0, 6)) as usize][0];
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let gx = (at(x + 1, y - 1) + 2.0 * at(x + 1, y) + at(x + 1, y + 1))
                - (at(x - 1, y - 1) + 2.0 * at(x - 1, y) + at(x - 1, y + 1));
            let gy = (at(x - 1, y + 1) + 2.0 * at(x, y + 1) + at(x + 1, y + 1))
                - (at(x - 1, y - 1) + 2.0 * at(x, y - 1) + at(x + 1, y - 1));
            let (fx, fy) = sobel4(&img, w, h, x as u32, y as u32);
            assert!(
                (fx[0] - gx).abs() < 1e-5 && (fy[0] - gy).abs() < 1e-5,
                "({x}, {y})"
            );
        }
    }
}

/// The shadow samples fill the disc, outer ring first, jittered per pixel with period 4.
/// CPU-only: `shadow_sample` (the GPU takes the same samples, compared in `gpu_splat.rs`).
#[test]
fn shadow_samples_fill_the_disc_outer_ring_first() {
    for px in 0..4 {
        for py in 0..4 {
            for k in 0..64 {
                let [x, y] = shadow_sample(k, px, py);
                let r = (x * x + y * y).sqrt();
                assert!(r <= 1.0 + 1e-6);
                if k < 8 {
                    assert!(r >= (7.0f32 / 8.0).sqrt() - 1e-6, "sample {k} r {r}");
                }
            }
            // Jitter differs between pixels of the tile, repeats with period 4.
            assert_eq!(shadow_sample(5, px, py), shadow_sample(5, px + 4, py + 8));
        }
    }
    assert_ne!(shadow_sample(5, 0, 0), shadow_sample(5, 1, 0));
}

fn ground_and_ball() -> SplatScene {
    let mut scene = SplatScene::default();
    // A flat wide ellipsoid as the ground and a ball above it.
    scene.push(
        Quadric::ellipsoid(
            DVec3::new(0.0, -1.0, 0.0),
            DVec3::new(3.0, 0.05, 3.0),
            DMat3::IDENTITY,
        )
        .unwrap(),
        Vec3::splat(0.8),
    );
    scene.push(
        Quadric::sphere(DVec3::new(0.0, 0.0, 0.0), 0.5).unwrap(),
        Vec3::new(0.8, 0.1, 0.1),
    );
    scene
}

/// A ball casts a soft shadow on the ground, on both twins (each renders the shadow map and
/// shades its own frame; the shadow factors at chosen points are the CPU's
/// `shadow_factor` read on each twin's map): below the ball in shadow, far away and on the
/// ball's top lit; some pixels need all 64 samples, most stop after 8; the shadowed ground
/// darker than the lit ground. The thresholds are the same on both twins: they are coarse
/// (1%, a half, 70%) against the documented agreement (shadow maps within `DEPTH_REL`,
/// shaded channels within `IMAGE_MAX` on all but `IMAGE_PX` pixels, [`splat_tol`]).
#[test]
fn a_ball_casts_a_soft_shadow_on_the_ground() {
    let scene = ground_and_ball();
    let cam = camera(
        Vec3::new(0.0, 2.0, 5.0),
        Vec3::new(0.0, -0.5, 0.0),
        96,
        72,
        45.0,
    );
    let light = Vec3::new(0.0, 6.0, 0.0);
    let shadows = ShadowOptions {
        resolution: 512,
        softness: 3.0,
        light: Some(light),
    };
    for t in twins("a_ball_casts_a_soft_shadow_on_the_ground") {
        let frame = t.splat(&scene, &cam, &SplatOptions::default()).unwrap();
        let map = t.shadow_map(&scene, light, &shadows).unwrap();
        // Ground points right below the ball are in shadow, far ones lit.
        let below = Vec3::new(0.0, -0.95, 0.0);
        let far = Vec3::new(2.0, -0.95, 0.0);
        let (f_below, _) = splat::shadow_factor(&map.params, &map.depth, below, Vec3::Y, 0, 0);
        let (f_far, n_far) = splat::shadow_factor(&map.params, &map.depth, far, Vec3::Y, 0, 0);
        assert!(f_below < 0.01, "{t}: {f_below}");
        assert!(f_far > 0.99 && n_far == 8, "{t}: {f_far} {n_far}");
        // The ball's top is lit (no self-shadowing acne).
        let (f_top, _) = splat::shadow_factor(
            &map.params,
            &map.depth,
            Vec3::new(0.0, 0.5, 0.0),
            Vec3::Y,
            0,
            0,
        );
        assert!(f_top > 0.99, "{t}: {f_top}");
        // Shading: some pixels need the full 64 samples (penumbra), most stop after 8.
        let opts = SplatShading {
            shadows: Some(shadows),
            outlines: Some(OutlineOptions::default()),
            ..Default::default()
        };
        let (img, stats) = t.shade_splat(&frame, &scene, &opts).unwrap();
        assert_eq!(img.pixels.len(), 96 * 72);
        assert!(stats.penumbra_pixels > 0, "{t}: {stats:?}");
        let hits = frame.gbuffer.hit_count() as u64;
        assert!(
            stats.shadow_samples < 64 * hits / 2,
            "{t}: {stats:?} for {hits} hits"
        );
        // The shadowed ground is darker than the lit ground.
        let lum = |x: u32, y: u32| {
            let p = img.pixels[(x + 96 * y) as usize];
            p[0] + p[1] + p[2]
        };
        let project = |p: Vec3| cam.project(p).unwrap().0;
        let (a, b) = (
            project(Vec3::new(0.0, -0.95, 0.25)),
            project(Vec3::new(2.0, -0.95, 0.25)),
        );
        let (la, lb) = (lum(a.x as u32, a.y as u32), lum(b.x as u32, b.y as u32));
        let ga = frame.gbuffer.get(a.x as u32, a.y as u32);
        assert!(
            la < 0.7 * lb,
            "{t}: shadowed {la} lit {lb} at {a} {b}: {ga:?}"
        );
    }
}

/// Outlines trace a sphere's silhouette, on both twins (the GPU's corner fetches bilinear
/// where the device has `FLOAT32_FILTERABLE`, as on lavapipe): the centre is not outlined,
/// the first outlined pixel of the middle row is within one pixel of the first hit. The same
/// on both twins: an outline pixel is dark by far more than the fetches' ~8 bits of weight
/// precision move it.
#[test]
fn outlines_trace_the_silhouette() {
    let mut scene = SplatScene::default();
    scene.push(Quadric::sphere(DVec3::ZERO, 1.0).unwrap(), Vec3::ONE);
    let cam = camera(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 64, 64, 40.0);
    let opts = SplatShading {
        outlines: Some(OutlineOptions::default()),
        ..Default::default()
    };
    for t in twins("outlines_trace_the_silhouette") {
        let frame = t.splat(&scene, &cam, &SplatOptions::default()).unwrap();
        let (img, _) = t.shade_splat(&frame, &scene, &opts).unwrap();
        let dark = |x: u32, y: u32| img.pixels[(x + 64 * y) as usize][0] < 0.1;
        // The centre is not outlined, the rim along the middle row is.
        assert!(!dark(32, 32), "{t}");
        let row: Vec<bool> = (0..64).map(|x| dark(x, 32)).collect();
        let first = row.iter().position(|&d| d).unwrap();
        let ray_hits = |x: u32| frame.gbuffer.get(x, 32).is_hit();
        let edge = (0..64).find(|&x| ray_hits(x)).unwrap();
        assert!(
            (first as i64 - edge as i64).abs() <= 1,
            "{t}: outline at {first}, edge at {edge}"
        );
    }
}

/// Bad scenes and frames are refused by both twins, never indexed past: colours that do not
/// match the quadrics, a negative near plane, a frame whose parts disagree (in shading, and
/// in the host's merge); an empty scene splats to no hit. The cone's normalized form is
/// checked once (no twin is involved).
#[test]
fn scenes_are_checked() {
    let mut scene = SplatScene::default();
    scene.push(Quadric::sphere(DVec3::ZERO, 1.0).unwrap(), Vec3::ONE);
    let cam = camera(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 8, 8, 40.0);
    for t in twins("scenes_are_checked") {
        let mut scene = scene.clone();
        scene.colors.push(Vec3::ONE);
        assert!(
            t.splat(&scene, &cam, &SplatOptions::default()).is_err(),
            "{t}"
        );
        scene.colors.pop();
        assert!(
            t.splat(
                &scene,
                &cam,
                &SplatOptions {
                    near: Some(-1.0),
                    ..Default::default()
                }
            )
            .is_err(),
            "{t}"
        );
        let empty = SplatScene::default();
        let frame = t.splat(&empty, &cam, &SplatOptions::default()).unwrap();
        assert_eq!(frame.gbuffer.hit_count(), 0, "{t}");
        // A frame assembled by hand with parts that disagree is refused, not indexed past.
        let mut broken = frame.clone();
        broken.objects.pop();
        assert!(
            t.shade_splat(&broken, &scene, &SplatShading::default())
                .is_err(),
            "{t}"
        );
        assert!(broken.merge_nearest(&frame.gbuffer).is_err());
    }
    assert_eq!(
        QuadricKind::Cone.diag(),
        [1.0, 1.0, -1.0, 0.0],
        "the cone's normalized form"
    );
}

/// The CPU's occlusion culling changes no pixel and evaluates fewer fragments. CPU-only: the
/// GPU has no occlusion culling (it evaluates every fragment; `gpu_splat.rs` compares it
/// with the exhaustive CPU frame).
#[test]
fn occlusion_culling_changes_no_pixel() {
    // Dense overlapping spheres, with exact duplicates (ties go to the lower index), and a
    // few cylinders: culling must give the exhaustive G-buffer bit for bit.
    let mut rng = SplitMix64::new(21);
    let mut scene = SplatScene::default();
    for i in 0..600 {
        let q = random_quadric(&mut rng, DVec3::ZERO, 1.5);
        scene.push(q, Vec3::splat(i as f32 / 600.0));
        if i % 50 == 0 {
            scene.push(q, Vec3::X);
        }
    }
    let cam = camera(Vec3::new(0.5, 1.0, 4.0), Vec3::ZERO, 96, 80, 45.0);
    let culled = splat::splat(&scene, &cam, &SplatOptions::default()).unwrap();
    let all = splat::splat(
        &scene,
        &cam,
        &SplatOptions {
            exhaustive: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(culled.gbuffer, all.gbuffer);
    assert_eq!(culled.objects, all.objects);
    assert_eq!(culled.stats.fragments, all.stats.fragments);
    assert_eq!(all.stats.evaluated, all.stats.fragments);
    assert!(
        culled.stats.evaluated * 2 < all.stats.evaluated,
        "{:?} vs {:?}",
        culled.stats,
        all.stats
    );
}

/// Too many overlapping boxes are refused before binning. CPU-only: the limit is the CPU
/// splatter's tile binning (the GPU draws one quad per set-up).
#[test]
fn too_many_overlapping_boxes_are_refused_before_binning() {
    // 20,000 spheres filling a 4096² image: 1.3e9 (tile, quadric) pairs.
    let mut scene = SplatScene::default();
    for _ in 0..20_000 {
        scene.push(Quadric::sphere(DVec3::ZERO, 1.0).unwrap(), Vec3::ONE);
    }
    let cam = camera(Vec3::new(0.0, 0.0, 1.5), Vec3::ZERO, 4096, 4096, 60.0);
    let e = splat::splat(&scene, &cam, &SplatOptions::default()).unwrap_err();
    assert!(e.to_string().contains("binning limit"), "{e}");
}
