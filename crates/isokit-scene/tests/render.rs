//! Scenes through the ray caster: a lazily sampled band renders like the dense samples, and
//! the one `Renderer` renders scenes and volumes with the settings it is given.

use glam::Vec3;
use isokit_field::{Camera, Job, Projection};
use isokit_render::{BrickCache, Layout, RenderOptions, Volume, render};
use isokit_scene::{RenderSettings, RenderTarget, Renderer, SampleOptions, Scene, SceneFormat};

fn frame(v: &Volume, cam: &Camera, opts: &RenderOptions) -> isokit_render::Frame {
    let mut cache = BrickCache::for_volume(v);
    render(v, &mut cache, cam, opts).unwrap()
}

fn perspective(eye: Vec3, w: u32, h: u32) -> Camera {
    Camera::look_at(
        eye,
        Vec3::ZERO,
        Vec3::Y,
        Projection::Perspective {
            fov_y_degrees: 40.0,
        },
        w,
        h,
    )
    .unwrap()
}

/// A volume over a lazily sampled band renders exactly like one over the dense samples of
/// the same lattice: the band holds every sample a hit depends on, and keeps the sign.
#[test]
fn a_band_volume_renders_like_the_dense_one() {
    let text = r#"{"shape": {"difference": [
        {"sphere": {"radius": 0.8}},
        {"box": {"half": [0.4, 0.4, 0.9], "center": [0.5, 0.3, 0.0]}}
    ]}}"#;
    let scene = Scene::from_text(text, SceneFormat::Json, "t.json", ".".as_ref()).unwrap();
    let opts = SampleOptions {
        resolution: 48,
        apron: 1,
        ..SampleOptions::default()
    };
    let (band, stats) = scene.sample(&opts).unwrap();
    eprintln!("band: {:.3} of the dense samples", stats.dense_fraction);
    assert!(stats.dense_fraction < 0.9);
    let (dense, _) = scene.sample_dense(&opts).unwrap();
    let a = Volume::from_brick_grid(band, Layout::default()).unwrap();
    let b = Volume::from_grid(dense, Layout::default()).unwrap();
    let cam = perspective(Vec3::new(1.2, 1.0, 2.2), 48, 48);
    // The fixed-rate search samples where the ray is, whatever the values: bit for bit.
    let fixed = RenderOptions {
        search: isokit_render::Search::Fixed,
        ..RenderOptions::default()
    };
    let fa = frame(&a, &cam, &fixed);
    let fb = frame(&b, &cam, &fixed);
    assert!(fa.stats.hits > 400);
    assert_eq!(fa.gbuffer, fb.gbuffer);
    // Sphere tracing (the default) steps by the slope bounds measured per block, which the
    // band's clamped far samples lower: other samples, the same hits and surface.
    let sa = frame(&a, &cam, &RenderOptions::default());
    let sb = frame(&b, &cam, &RenderOptions::default());
    assert_eq!(sa.stats.hits, fa.stats.hits);
    let h = a.spacing();
    for (p, q) in sa.gbuffer.pixels().iter().zip(sb.gbuffer.pixels()) {
        assert_eq!(p.id, q.id);
        assert!(
            (p.depth - q.depth).abs() <= 1e-3 * h,
            "{} {}",
            p.depth,
            q.depth
        );
        assert!(p.normal.angle_between(q.normal) < 1e-3 || p.id == 0);
    }
}

/// The renderer frames a scene by its camera table, and the same scene through the library
/// calls by hand gives the same G-buffer: `Renderer::render` is sampling, `Volume`, camera,
/// `render`, `shade`, nothing else.
#[test]
fn the_renderer_is_the_pipeline_by_hand() {
    let text = r#"{"shape": {"smooth_union": {"radius": 0.2, "of": [
        {"sphere": {"radius": 0.6}}, {"torus": {"major": 0.7, "minor": 0.2}}]}},
        "camera": {"eye": [0.5, 1.5, 2.5], "fov": 40},
        "sampling": {"resolution": 48}}"#;
    let scene = Scene::from_text(text, SceneFormat::Json, "t.json", ".".as_ref()).unwrap();
    let settings = RenderSettings {
        width: 40,
        height: 32,
        ..RenderSettings::default()
    };
    let mut r = Renderer::cpu();
    let f = r
        .render(RenderTarget::Scene(&scene), &settings, &Job::default())
        .unwrap();
    assert_eq!((f.stats.width, f.stats.height), (40, 32));
    assert_eq!(f.stats.backend, "cpu");
    assert!(f.stats.hits > 200, "{:?}", f.stats);
    let s = f.stats.sampling.as_ref().unwrap();
    assert!(s.dense_fraction < 0.8);
    // By hand.
    let (band, _) = scene.sample(&SampleOptions::from_scene(&scene)).unwrap();
    let v = Volume::from_brick_grid(band, Layout::default()).unwrap();
    let cam = Camera::look_at(
        Vec3::new(0.5, 1.5, 2.5),
        Vec3::ZERO,
        Vec3::Y,
        Projection::Perspective {
            fov_y_degrees: 40.0,
        },
        40,
        32,
    )
    .unwrap();
    let g = frame(&v, &cam, &RenderOptions::default());
    assert_eq!(f.gbuffer, g.gbuffer);
    // A volume target with values away from 0 gets the middle of its range, with a note.
    let mut grid = isokit_field::Grid::new([24; 3], Vec3::splat(-1.0), 2.0 / 23.0).unwrap();
    isokit_field::sample_into(
        &isokit_field::primitives::Sphere::new(Vec3::ZERO, 0.6).unwrap(),
        &mut grid,
    );
    grid.data_mut().iter_mut().for_each(|v| *v = 10.0 - *v);
    let vol = Volume::from_grid(grid, Layout::default()).unwrap();
    let fv = r
        .render(RenderTarget::Volume(&vol), &settings, &Job::default())
        .unwrap();
    assert!(
        fv.notes.iter().any(|n| n.contains("using --iso")),
        "{:?}",
        fv.notes
    );
    assert!(fv.stats.iso > 9.0 && fv.stats.iso < 11.0);
}

/// A cancelled job stops the sampling with an error instead of a frame.
#[test]
fn a_cancelled_job_stops_the_rendering() {
    let scene = Scene::from_node(isokit_scene::Node::sphere(1.0, [0.0; 3])).unwrap();
    let job = Job::new();
    job.cancel();
    let e = Renderer::cpu()
        .render(
            RenderTarget::Scene(&scene),
            &RenderSettings::default(),
            &job,
        )
        .unwrap_err();
    assert!(e.to_string().contains("cancelled"), "{e}");
}

/// A multi-view target renders each of its views alone, the same as one `render_view` call
/// per view; a plain target has none.
#[test]
fn every_view_renders_alone() {
    let scene = Scene::from_node(isokit_scene::Node::sphere(0.6, [0.0; 3])).unwrap();
    let mut settings = RenderSettings {
        width: 24,
        height: 16,
        resolution: Some(24),
        ..RenderSettings::default()
    };
    let mut r = Renderer::cpu();
    let job = Job::default();
    let p = r
        .prepare(RenderTarget::Scene(&scene), &settings, &job)
        .unwrap();
    assert!(r.render_views(&p, "t").unwrap().is_empty());
    settings.multiview = Some(isokit_render::MultiView::new(3, 0.05));
    let p = r
        .prepare(RenderTarget::Scene(&scene), &settings, &job)
        .unwrap();
    let views = r.render_views(&p, "t").unwrap();
    assert_eq!(views.len(), 3);
    for (k, image) in views.iter().enumerate() {
        assert_eq!(*image, r.render_view(&p, k as u32, "t").unwrap().image);
    }
}

/// Frames that are shown, not kept, compute the principal curvatures only where the
/// shading reads them: the Phong image is the same pixel for pixel, its G-buffer holds no
/// curvature, and switching to a curvature mode brings the full G-buffer back.
#[test]
fn curvatures_can_follow_the_shading_mode() {
    let text = r#"{"shape": {"difference": [{"box": {"half": [0.6, 0.5, 0.4]}},
        {"sphere": {"radius": 0.6}}]}, "camera": {"eye": [1.5, 1.2, 2.5], "fov": 40},
        "sampling": {"resolution": 40}}"#;
    let scene = Scene::from_text(text, SceneFormat::Json, "t.json", ".".as_ref()).unwrap();
    let kept = RenderSettings {
        width: 48,
        height: 40,
        ..RenderSettings::default()
    };
    let shown = RenderSettings {
        curvature_follows_mode: true,
        ..kept.clone()
    };
    let mut r = Renderer::cpu();
    let job = Job::default();
    let full = r.render(RenderTarget::Scene(&scene), &kept, &job).unwrap();
    let mut p = r
        .prepare(RenderTarget::Scene(&scene), &shown, &job)
        .unwrap();
    assert!(!p.options().curvature);
    let lean = r.render_prepared(&p, "t.json").unwrap();
    assert!(full.stats.hits > 300, "{:?}", full.stats);
    assert_eq!(lean.image.pixels, full.image.pixels);
    let curved =
        |f: &isokit_scene::Frame| f.gbuffer.pixels().iter().filter(|s| s.k1 != 0.0).count();
    assert_eq!(curved(&lean), 0);
    assert!(curved(&full) > 300);
    for (a, b) in lean.gbuffer.pixels().iter().zip(full.gbuffer.pixels()) {
        assert_eq!(
            (a.position, a.depth, a.normal, a.id),
            (b.position, b.depth, b.normal, b.id)
        );
    }
    p.set_mode(isokit_render::ShadingMode::Curvature);
    assert!(p.options().curvature);
    let again = r.render_prepared(&p, "t.json").unwrap();
    assert_eq!(again.gbuffer, full.gbuffer);
    // Settings that keep the G-buffer keep the option as given.
    let p = r.prepare(RenderTarget::Scene(&scene), &kept, &job).unwrap();
    assert!(p.options().curvature);
}

#[test]
fn the_thin_feature_note_can_come_after_the_frame() {
    // A wall 0.04 thick sampled at 160 (the command's thin-wall test): curvature shading warns.
    let text = r#"{"shape": {"difference": [
        {"shell": {"thickness": 0.04, "of": {"rounded_box": {"half": [1.2, 0.2, 0.8], "radius": 0.05}}}},
        {"box": {"half": [0.8, 0.8, 0.8], "center": [0.8, 0.8, 0.8]}}]},
        "camera": {"eye": [2.5, 2.0, 3.0], "target": [0, 0, 0], "fov": 40},
        "shading": {"mode": "curvature"},
        "sampling": {"resolution": 160}}"#;
    let scene = Scene::from_text(text, SceneFormat::Json, "t.json", ".".as_ref()).unwrap();
    let thin = |notes: &[String]| {
        notes
            .iter()
            .any(|n| n.contains("crease of the distance field"))
    };
    let mut r = Renderer::cpu();
    let mut settings = RenderSettings {
        width: 96,
        height: 72,
        ..RenderSettings::default()
    };
    let p = r
        .prepare(RenderTarget::Scene(&scene), &settings, &Job::default())
        .unwrap();
    let now = r.render_prepared(&p, "t.json").unwrap();
    assert!(thin(&now.notes), "{:?}", now.notes);
    settings.defer_thin_note = true;
    let p = r
        .prepare(RenderTarget::Scene(&scene), &settings, &Job::default())
        .unwrap();
    let later = r.render_prepared(&p, "t.json").unwrap();
    assert!(!thin(&later.notes), "{:?}", later.notes);
    let note = r
        .thin_note(&p, &later)
        .expect("the note, asked for after the frame");
    assert_eq!(
        Some(&note),
        now.notes.iter().find(|n| thin(std::slice::from_ref(n)))
    );
}
