//! Volumes on spherical lattices (Westermann and Ertl 1998, Sec. 2.2), rendered without
//! resampling: a shell field's isosurface against the analytic sphere, a uniform medium's
//! opacity against the analytic chord through the domain (a whole shell, and a wedge cut by
//! polar cones and azimuthal half-planes, against an f64 fine-step integral), no crack at the
//! azimuth seam (the same function on lattices whose seams lie on opposite sides renders the
//! same) or at the poles, and the GPU twins against the CPU twins (on lavapipe in CI;
//! skipped with a printed reason where no adapter exists, failing when
//! `ISOKIT_REQUIRE_GPU=1`).

mod common;

use glam::{DVec3, Vec3, Vec4};
use isokit_field::{Camera, Grid, Projection};
use isokit_render::Inside;
use isokit_render::dvr::{Classification, DvrOptions, TransferFunction, render_dvr_spherical};
use isokit_render::kernel::{ID_CAP, ID_SURFACE};
use isokit_render::spherical::{IsoOptions, SphericalLattice, SphericalVolume, render_iso};

/// Samples of `f(r, θ, φ)` (degrees) on a lattice.
fn sampled(
    dims: [usize; 3],
    lattice: SphericalLattice,
    f: impl Fn(f32, f32, f32) -> f32,
) -> SphericalVolume {
    let [nr, nt, np] = dims;
    let at = |a: [f32; 2], n: usize, i: usize| a[0] + (a[1] - a[0]) * i as f32 / (n - 1) as f32;
    let mut data = Vec::with_capacity(nr * nt * np);
    for k in 0..np {
        for j in 0..nt {
            for i in 0..nr {
                data.push(f(
                    at(lattice.r, nr, i),
                    at(lattice.theta, nt, j),
                    at(lattice.phi, np, k),
                ));
            }
        }
    }
    let grid = Grid::from_data(dims, Vec3::ZERO, 1.0, data).unwrap();
    SphericalVolume::new(grid, lattice).unwrap()
}

/// The whole sphere, 36 azimuths 10° apart with the last cell wrapping to the first,
/// starting at `phi0`.
fn whole(phi0: f32) -> SphericalLattice {
    SphericalLattice {
        r: [0.3, 1.0],
        theta: [0.0, 180.0],
        phi: [phi0, phi0 + 350.0],
    }
}

fn camera(eye: Vec3, size: u32) -> Camera {
    let up = if eye.normalize().z.abs() > 0.99 {
        Vec3::Y
    } else {
        Vec3::Z
    };
    let fov = Projection::Perspective {
        fov_y_degrees: 40.0,
    };
    Camera::look_at(eye, Vec3::ZERO, up, fov, size, size).unwrap()
}

/// Eyes on the +x axis (facing the seam at azimuth 0), above the north pole, below the
/// south pole, and oblique.
fn eyes() -> [Vec3; 4] {
    [
        Vec3::new(3.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 3.0),
        Vec3::new(0.0, 0.0, -3.0),
        Vec3::new(-1.5, 2.0, 1.4),
    ]
}

/// Where a ray meets the sphere of radius `r` (f64), entering and leaving.
fn chord(o: DVec3, d: DVec3, r: f64) -> Option<(f64, f64)> {
    let b = o.dot(d);
    let disc = b * b - (o.length_squared() - r * r);
    (disc > 0.0).then(|| (-b - disc.sqrt(), -b + disc.sqrt()))
}

#[test]
fn a_shell_fields_isosurface_is_the_analytic_sphere_through_the_seam_and_the_poles() {
    // f = r − 0.65 is linear in r: its interpolant is exact, so the surface is the sphere.
    let vol = sampled([15, 19, 36], whole(0.0), |r, _, _| r - 0.65);
    assert!(vol.periodic() && !vol.wedge());
    let n = 64;
    for eye in eyes() {
        let cam = camera(eye, n);
        let gb = render_iso(&vol, &cam, &IsoOptions::default()).unwrap();
        let (mut hits, mut worst_r, mut worst_n) = (0, 0.0f32, 0.0f32);
        for (pix, s) in gb.pixels().iter().enumerate() {
            let ray = cam.ray((pix as u32 % n) as f32 + 0.5, (pix as u32 / n) as f32 + 0.5);
            let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
            // Rays that pass a hundredth of a radius inside or outside the sphere.
            let inside = chord(o, d, 0.65 * 0.99).is_some();
            let outside = chord(o, d, 0.65 * 1.01).is_none();
            if inside {
                assert!(s.is_hit(), "{eye}: pixel {pix} misses the sphere");
            }
            if outside {
                assert!(!s.is_hit(), "{eye}: pixel {pix} hits beside the sphere");
            }
            if s.is_hit() {
                hits += 1;
                assert_eq!(s.id, ID_SURFACE);
                worst_r = worst_r.max((s.position.length() - 0.65).abs());
                let angle = s.normal.dot(s.position.normalize()).clamp(-1.0, 1.0).acos();
                worst_n = worst_n.max(angle.to_degrees());
                let t = chord(o, d, 0.65).unwrap().0;
                assert!((f64::from(s.depth) - t).abs() < 1e-4, "{} {t}", s.depth);
            }
        }
        eprintln!(
            "eye {eye}: {hits} hits, radius error {worst_r:.1e}, normal error {worst_n:.2} degrees"
        );
        assert!(hits > 1000);
        assert!(worst_r < 1e-4, "{worst_r}");
        // Central differences across cells of a lattice whose cells are 10° wide: the
        // normal's error stays within a degree.
        assert!(worst_n < 1.0, "{worst_n}");
    }
}

#[test]
fn the_azimuth_seam_leaves_no_crack() {
    // A bumpy surface that varies with the azimuth and the polar angle. Sampled on two
    // lattices that hold the same azimuths (10° apart), one with its seam at 0° and one at
    // 180°: the interpolants are the same function, so the images must be the same — a
    // crack or a mismatched cell at either seam shows as a difference.
    let f = |r: f32, t: f32, p: f32| {
        let (t, p) = (t.to_radians(), p.to_radians());
        r - 0.55 - 0.12 * t.sin() * p.cos() - 0.05 * (3.0 * p).sin() * t.sin()
    };
    let a = sampled([15, 19, 36], whole(0.0), f);
    let b = sampled([15, 19, 36], whole(180.0), f);
    for eye in [Vec3::new(3.0, 0.0, 0.4), Vec3::new(-3.0, 0.0, -0.4)] {
        let cam = camera(eye, 64);
        let ga = render_iso(&a, &cam, &IsoOptions::default()).unwrap();
        let gb = render_iso(&b, &cam, &IsoOptions::default()).unwrap();
        let mut worst = 0.0f32;
        for (p, q) in ga.pixels().iter().zip(gb.pixels()) {
            assert_eq!(p.is_hit(), q.is_hit(), "{eye}");
            if p.is_hit() {
                worst = worst.max((p.depth - q.depth).abs());
            }
        }
        eprintln!("isosurface, eye {eye}: depths of the two seams differ by {worst:.1e}");
        assert!(worst < 1e-4, "{worst}");
        assert!(ga.hit_count() > 500);
        let tf = TransferFunction::from_json(
            r#"{"points": [[-0.3, 1, 0.6, 0.2, 6], [0, 0.2, 0.4, 1, 1], [0.2, 0, 0, 0, 0]]}"#,
        )
        .unwrap();
        for c in [Classification::Post, Classification::Preintegrated] {
            let o = DvrOptions {
                classification: c,
                step: Some(0.01),
                ..DvrOptions::default()
            };
            let da = render_dvr_spherical(&a, &cam, &tf, &o).unwrap();
            let db = render_dvr_spherical(&b, &cam, &tf, &o).unwrap();
            let d = max_diff(&da.rgba, &db.rgba);
            eprintln!("dvr {c:?}, eye {eye}: the two seams differ by {d:.1e}");
            assert!(d < 1e-4, "{d}");
        }
    }
}

#[test]
fn the_poles_take_one_value() {
    // A pole row that varies with the azimuth (as data rounded on a lattice may): the
    // interpolant is continuous through the pole, whichever way a point approaches it.
    let lat = whole(0.0);
    let vol = sampled([4, 7, 36], lat, |_, t, p| {
        t / 180.0 + (p.to_radians()).cos() * if t == 0.0 { 1.0 } else { 0.0 }
    });
    let near = |phi: f32, eps: f32| {
        let (t, p) = (eps.to_radians(), phi.to_radians());
        vol.value(0.6 * Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos()))
    };
    let at_pole = vol.value(Vec3::new(0.0, 0.0, 0.6));
    for phi in [0.0, 45.0, 90.0, 200.0, 355.0] {
        let v = near(phi, 1e-3);
        assert!(
            (v - at_pole).abs() < 1e-4,
            "azimuth {phi}: {v} against {at_pole}"
        );
    }
    // The same for the centre of a lattice from r0 = 0 whose first radius differs by
    // direction, and for a last azimuth column that repeats the first (φ1 − φ0 = 360°)
    // with other values: one value at the centre, none jumping across the seam.
    let lat = SphericalLattice {
        r: [0.0, 1.0],
        theta: [0.0, 180.0],
        phi: [0.0, 360.0],
    };
    let vol = sampled([5, 7, 13], lat, |r, t, p| {
        let wobble = if r == 0.0 { t / 90.0 + p / 360.0 } else { 0.0 };
        r + 0.3 * (t.to_radians()).sin() + if p == 360.0 { 0.5 } else { 0.0 } + wobble
    });
    assert!(!vol.periodic() && !vol.wedge());
    let centre = vol.value(Vec3::ZERO);
    for d in [Vec3::X, Vec3::NEG_Y, Vec3::new(0.3, 0.4, -0.8).normalize()] {
        let v = vol.value(d * 1e-5);
        assert!(
            (v - centre).abs() < 1e-3,
            "towards {d}: {v} against {centre}"
        );
    }
    let (above, below) = (
        vol.value(Vec3::new(0.5, 1e-5, 0.2)),
        vol.value(Vec3::new(0.5, -1e-5, 0.2)),
    );
    assert!(
        (above - below).abs() < 1e-3,
        "across the seam: {above} {below}"
    );
}

#[test]
fn an_eye_inside_the_inner_sphere_sees_its_wall() {
    // The search starts inside the hole (r < r0), passes over it and brackets the wall,
    // where the solid r < 0.65 begins for this field: a cap at r0 = 0.3 facing the centre.
    let vol = sampled([15, 19, 36], whole(0.0), |r, _, _| r - 0.65);
    let fov = Projection::Perspective {
        fov_y_degrees: 60.0,
    };
    let cam = Camera::look_at(Vec3::new(0.0, 0.05, 0.02), Vec3::X, Vec3::Z, fov, 16, 16).unwrap();
    let gb = render_iso(&vol, &cam, &IsoOptions::default()).unwrap();
    for s in gb.pixels() {
        assert_eq!(s.id, ID_CAP, "{s:?}");
        assert!((s.position.length() - 0.3).abs() < 1e-4, "{s:?}");
        assert!(s.normal.dot(s.position.normalize()) < -0.99, "{s:?}");
    }
}

fn max_diff(a: &[Vec4], b: &[Vec4]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (*x - *y).abs().max_element())
        .fold(0.0, f32::max)
}

/// Whether a point lies in the lattice's domain (f64).
fn in_domain(x: DVec3, l: &SphericalLattice) -> bool {
    let r = x.length();
    let theta = (x.z / r).clamp(-1.0, 1.0).acos().to_degrees();
    let phi = (x.y.atan2(x.x).to_degrees() - f64::from(l.phi[0])).rem_euclid(360.0);
    (f64::from(l.r[0])..=f64::from(l.r[1])).contains(&r)
        && (f64::from(l.theta[0])..=f64::from(l.theta[1])).contains(&theta)
        && phi <= f64::from(l.phi[1] - l.phi[0])
}

/// The length of `[0, end]` where `inside` holds: crossings found on steps of 1/1000 and
/// bisected to 1e-12.
fn length_in(inside: impl Fn(f64) -> bool, end: f64) -> f64 {
    let h = 1e-3;
    let n = (end / h) as usize;
    let crossing = |mut a: f64, mut b: f64| {
        let at_a = inside(a);
        while b - a > 1e-12 {
            let m = 0.5 * (a + b);
            if inside(m) == at_a {
                a = m;
            } else {
                b = m;
            }
        }
        0.5 * (a + b)
    };
    let (mut len, mut from) = (0.0, inside(0.0).then_some(0.0));
    for k in 1..=n {
        let (a, b) = ((k - 1) as f64 * h, k as f64 * h);
        match (from, inside(b)) {
            (None, true) => from = Some(crossing(a, b)),
            (Some(f), false) => {
                len += crossing(a, b) - f;
                from = None;
            }
            _ => {}
        }
    }
    len + from.map_or(0.0, |f| n as f64 * h - f)
}

#[test]
fn a_uniform_medium_shows_the_length_of_the_domain_along_each_ray() {
    let sigma = 1.5f64;
    let tf =
        TransferFunction::from_json(&format!(r#"{{"points": [[0, 1, 1, 1, {sigma}]]}}"#)).unwrap();
    let shell = whole(0.0);
    let wedge = SphericalLattice {
        r: [0.3, 1.0],
        theta: [30.0, 150.0],
        phi: [-20.0, 100.0],
    };
    for (name, lat, dims) in [("shell", shell, [8, 19, 36]), ("wedge", wedge, [8, 13, 13])] {
        let vol = sampled(dims, lat, |_, _, _| 1.0);
        assert_eq!(vol.wedge(), name == "wedge");
        let n = 32;
        let cam = camera(Vec3::new(1.6, 2.2, 1.3), n);
        for c in [Classification::Post, Classification::Preintegrated] {
            let o = DvrOptions {
                classification: c,
                step: Some(0.02),
                termination: 1.0,
                ..DvrOptions::default()
            };
            let img = render_dvr_spherical(&vol, &cam, &tf, &o).unwrap();
            let (mut worst, mut sum) = (0.0f64, 0.0f64);
            for (pix, got) in img.rgba.iter().enumerate() {
                let ray = cam.ray((pix as u32 % n) as f32 + 0.5, (pix as u32 / n) as f32 + 0.5);
                let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
                // The length of the ray in the domain: analytic for the shell; for the
                // wedge, in f64, its crossings found on steps of 1/1000 and bisected.
                let len = if name == "shell" {
                    let outer = chord(o, d, 1.0).map_or(0.0, |(a, b)| b - a);
                    let inner = chord(o, d, 0.3).map_or(0.0, |(a, b)| b - a);
                    outer - inner
                } else {
                    length_in(|t| in_domain(o + d * t, &lat), 6.0)
                };
                let want = 1.0 - (-sigma * len).exp();
                let e = (f64::from(got.w) - want).abs();
                worst = worst.max(e);
                sum += e;
            }
            let mean = sum / f64::from(n * n);
            eprintln!("{name}, {c:?}: opacity error mean {mean:.1e}, worst {worst:.1e}");
            // The domain's boundary is taken linear across each step of 0.02, and a step
            // whose ends both lie outside is left out: a ray that cuts a corner of the
            // domain shorter than a step loses it (the wedge's worst pixel: 0.019 in the
            // domain). So: at most one step's opacity per pixel, and little on average.
            let one_step = 1.0 - (-sigma * 0.02).exp();
            assert!(worst < one_step, "{name} {c:?}: {worst}");
            assert!(mean < 5e-4, "{name} {c:?}: {mean}");
            if name == "shell" {
                assert!(worst < 1e-3, "{c:?}: {worst}");
            }
            assert!(img.rgba.iter().any(|p| p.w > 0.5) && img.rgba.iter().any(|p| p.w == 0.0));
        }
    }
}

#[test]
fn the_domains_boundary_closes_a_solid_that_reaches_it() {
    // A density above 0.5 everywhere in a wedge: the isosurface is the wedge's boundary,
    // shown as caps with the boundary's outward normals.
    let lat = SphericalLattice {
        r: [0.3, 1.0],
        theta: [30.0, 150.0],
        phi: [0.0, 90.0],
    };
    let vol = sampled([8, 13, 10], lat, |_, _, _| 1.0);
    let opts = IsoOptions {
        iso: 0.5,
        inside: Inside::Above,
        step: None,
    };
    let cam = camera(Vec3::new(2.0, 2.0, 0.3), 48);
    let gb = render_iso(&vol, &cam, &opts).unwrap();
    let caps: Vec<_> = gb.pixels().iter().filter(|s| s.is_hit()).collect();
    assert!(caps.len() > 300, "{}", caps.len());
    for s in caps {
        assert_eq!(s.id, ID_CAP);
        // On the outer sphere, away from its edges, the normal is radial (normals are
        // central differences half a spacing apart, which round the domain's edges).
        let theta = (s.position.z / s.position.length()).acos().to_degrees();
        let phi = s.position.y.atan2(s.position.x).to_degrees();
        let away = (35.0..145.0).contains(&theta) && (5.0..85.0).contains(&phi);
        if (s.position.length() - 1.0).abs() < 1e-4 && away {
            assert!(s.normal.dot(s.position) > 0.999, "{s:?}");
        }
    }
}

#[test]
fn bad_lattices_and_samples_are_refused() {
    let grid = |dims: [usize; 3]| Grid::filled(dims, Vec3::ZERO, 1.0, 0.0).unwrap();
    let ok = whole(0.0);
    for (lat, want) in [
        (
            SphericalLattice {
                r: [1.0, 0.5],
                ..ok
            },
            "radii",
        ),
        (
            SphericalLattice {
                theta: [0.0, 190.0],
                ..ok
            },
            "polar",
        ),
        (
            SphericalLattice {
                phi: [0.0, 400.0],
                ..ok
            },
            "azimuths",
        ),
        (
            SphericalLattice {
                r: [0.0, f32::NAN],
                ..ok
            },
            "finite",
        ),
    ] {
        let e = SphericalVolume::new(grid([4, 4, 4]), lat)
            .unwrap_err()
            .to_string();
        assert!(e.contains(want), "{want}: {e}");
    }
    let e = SphericalVolume::new(grid([4, 1, 4]), ok)
        .unwrap_err()
        .to_string();
    assert!(e.contains("at least 2"), "{e}");
    let mut g = grid([4, 4, 4]);
    g.set(1, 1, 1, f32::NAN);
    assert!(SphericalVolume::new(g, ok).is_err());
    let vol = SphericalVolume::new(grid([4, 4, 4]), ok).unwrap();
    let bad_step = IsoOptions {
        step: Some(0.0),
        ..IsoOptions::default()
    };
    assert!(render_iso(&vol, &camera(Vec3::X * 3.0, 4), &bad_step).is_err());
}

#[test]
fn the_gpu_twins_render_spherical_volumes_as_the_cpu_twins_do() {
    let Some(r) = common::twin::gpu_renderer(
        "spherical::the_gpu_twins_render_spherical_volumes_as_the_cpu_twins_do",
    ) else {
        return;
    };
    let f = |r: f32, t: f32, p: f32| {
        let (t, p) = (t.to_radians(), p.to_radians());
        r - 0.55 - 0.12 * t.sin() * p.cos()
    };
    let wedge = SphericalLattice {
        r: [0.2, 1.0],
        theta: [20.0, 160.0],
        phi: [30.0, 300.0],
    };
    let tf = TransferFunction::from_json(
        r#"{"points": [[-0.3, 1, 0.6, 0.2, 6], [0, 0.2, 0.4, 1, 1], [0.2, 0, 0, 0, 0]]}"#,
    )
    .unwrap();
    for (name, lat) in [("whole", whole(0.0)), ("wedge", wedge)] {
        let vol = sampled([12, 15, 28], lat, f);
        for eye in [Vec3::new(3.0, 0.2, 0.4), Vec3::new(0.1, 0.2, 3.0)] {
            let cam = camera(eye, 40);
            let cpu = render_iso(&vol, &cam, &IsoOptions::default()).unwrap();
            let gpu = r
                .render_spherical_iso(&vol, &cam, &IsoOptions::default())
                .unwrap();
            let mask = cpu
                .pixels()
                .iter()
                .zip(gpu.pixels())
                .filter(|(a, b)| a.is_hit() != b.is_hit() || a.id != b.id)
                .count();
            let (mut dz, mut dn) = (0.0f32, 0.0f32);
            for (a, b) in cpu.pixels().iter().zip(gpu.pixels()) {
                if a.is_hit() && b.is_hit() {
                    dz = dz.max((a.depth - b.depth).abs());
                    dn = dn.max((a.normal - b.normal).length());
                }
            }
            eprintln!(
                "{name}, eye {eye}: isosurface {} hits, {mask} differ, depth {dz:.1e}, normal {dn:.1e}",
                cpu.hit_count()
            );
            assert!(cpu.hit_count() > 150);
            // WGSL lets acos and atan2 be far less exact than the CPU's (atan2 within
            // 4096 ulp): the lattice coordinates, so the values and the surface, move by
            // ~1e-4 (measured 4.5e-5 to 1.3e-4 on lavapipe).
            assert!(mask <= 2 && dz < 5e-4 && dn < 2e-3, "{mask} {dz} {dn}");
            for c in [Classification::Post, Classification::Preintegrated] {
                let o = DvrOptions {
                    classification: c,
                    shade: true,
                    ..DvrOptions::default()
                };
                let a = render_dvr_spherical(&vol, &cam, &tf, &o).unwrap();
                let b = r.render_dvr_spherical(&vol, &cam, &tf, &o).unwrap();
                let d = max_diff(&a.rgba, &b.rgba);
                eprintln!(
                    "{name}, eye {eye}, dvr {c:?}: max difference {d:.1e}, samples {} / {}",
                    a.samples, b.samples
                );
                assert!(d < 1e-3, "{d}");
                assert!(a.rgba.iter().any(|p| p.w > 0.5));
            }
        }
    }
}
