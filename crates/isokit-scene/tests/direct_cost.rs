//! What evaluating a scene's tree per ray sample would cost, against the sampled band the
//! ray caster reads (fidget and Curv trace analytic trees directly; this project samples the
//! tree into bricks and caches them). Prints nanoseconds per point; the ray caster's own
//! cost per sample is printed by `isokit render examples/scenes/demo.json --backend cpu
//! --width 512 --height 512 --stats` (trace seconds over samples).

use isokit_scene::{Scene, SceneFormat};
use std::path::Path;
use std::time::Instant;

fn demo(text: &str) -> Scene {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/scenes");
    Scene::from_text(text, SceneFormat::Json, "demo.json", &dir).unwrap()
}

/// Nanoseconds per point of `f` over `points` (the best of three runs), and a checksum.
fn cost(points: &[glam::Vec3], f: impl Fn(glam::Vec3) -> f32) -> (f64, f32) {
    let mut best = f64::INFINITY;
    let mut sum = 0.0;
    for _ in 0..3 {
        let t = Instant::now();
        sum = points.iter().map(|&p| f(p)).sum::<f32>();
        best = best.min(t.elapsed().as_secs_f64());
    }
    (1e9 * best / points.len() as f64, sum)
}

#[test]
#[ignore = "measurement: cargo test --release -p isokit-scene --test direct_cost -- --ignored --nocapture"]
fn per_sample_cost_of_the_demo_scene_s_tree() {
    let full = demo(
        &std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/scenes/demo.json"),
        )
        .unwrap(),
    );
    let sphere = demo(r#"{"shape": {"sphere": {"radius": 0.42}}}"#);
    let blend = demo(
        r#"{"shape": {"smooth_union": {"radius": 0.12, "of": [
            {"torus": {"major": 0.8, "minor": 0.25}}, {"sphere": {"radius": 0.42}}]}}}"#,
    );
    let d = full.domain();
    // Uniform points in the domain, and those within 0.1 (about 4 voxels at the demo's
    // resolution) of the surface: where a sphere-tracing ray takes most of its steps.
    let mut s = 0x2545_f491_4f6c_dd1du64;
    let mut rnd = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    let uniform: Vec<glam::Vec3> = (0..400_000)
        .map(|_| d.min + (d.max - d.min) * glam::Vec3::new(rnd(), rnd(), rnd()))
        .collect();
    let near: Vec<glam::Vec3> = uniform
        .iter()
        .copied()
        .filter(|&p| full.value_clamped(p, 0.1).abs() < 0.1)
        .collect();
    assert!(near.len() > 1000);
    println!(
        "{} uniform points, {} near the surface",
        uniform.len(),
        near.len()
    );
    for (name, scene) in [
        ("demo (trefoil mesh + sphere)", &full),
        ("sphere", &sphere),
        ("torus + sphere blend", &blend),
    ] {
        let (v, a) = cost(&near, |p| scene.field().value(p));
        let (c, b) = cost(&near, |p| scene.value_clamped(p, 0.1));
        let (g, e) = cost(&near, |p| scene.field().gradient(p).x);
        let (h, k) = cost(&near, |p| scene.field().hessian(p).x_axis.x);
        let (u, _) = cost(&uniform, |p| scene.field().value(p));
        assert!(a.is_finite() && b.is_finite() && e.is_finite() && k.is_finite());
        println!(
            "{name}: near the surface value {v:.0} ns, clamped to 0.1 {c:.0} ns, gradient {g:.0} ns, \
             Hessian {h:.0} ns; anywhere value {u:.0} ns"
        );
    }
}
