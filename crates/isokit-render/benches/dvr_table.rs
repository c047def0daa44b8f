//! Pre-integration tables built two ways: every entry integrated through the transfer
//! function's control points (`PreintegrationTable::new`, O(n²·pieces)) and incrementally
//! (`PreintegrationTable::incremental`, Lum, Wilson and Ma 2004, O(n²)). For each size: the
//! build time and the entries' error against segments integrated in f64 at 256 sub-steps per
//! piece (premultiplied RGB and opacity, mean and largest over all entries), for a smooth
//! transfer function and one with a spike a hundredth of the range wide.
//!
//! Run: `cargo bench -p isokit-render --bench dvr_table`. Knob: `ISOKIT_TABLE_RUNS` (best of,
//! default 3).

use glam::Vec4;
use isokit_render::dvr::{PreintegrationTable, TransferFunction};
use std::time::Instant;

fn best<T>(runs: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let (mut t_best, mut out) = (f64::INFINITY, None);
    for _ in 0..runs.max(1) {
        let t = Instant::now();
        let r = f();
        t_best = t_best.min(t.elapsed().as_secs_f64());
        out = Some(r);
    }
    (t_best, out.unwrap())
}

fn main() {
    let runs = std::env::var("ISOKIT_TABLE_RUNS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3);
    let smooth = TransferFunction::from_json(
        r#"{"points": [[0.1, 0, 0, 0, 0], [0.4, 0.2, 0.4, 1.0, 3], [0.8, 1.0, 0.6, 0.2, 12], [1.2, 1, 1, 1, 20]]}"#,
    )
    .unwrap();
    let spike = TransferFunction::from_json(
        r#"{"points": [[0.5, 0, 0, 0, 0], [0.505, 1, 0.8, 0.3, 60], [0.51, 0, 0, 0, 0]]}"#,
    )
    .unwrap();
    let (lo, hi, len) = (0.0f32, 1.2f32, 0.05f32);
    println!("values {lo}..{hi}, segments of length {len}; best of {runs}");
    println!("| transfer function | n | build | ms | mean error | max error |");
    println!("| --- | ---: | --- | ---: | ---: | ---: |");
    for (name, tf) in [("smooth", &smooth), ("spike", &spike)] {
        for n in [128usize, 256, 1024] {
            // The reference entries, f64 integration with 256 sub-steps per piece.
            let v = |i: usize| lo + (hi - lo) * i as f32 / (n - 1) as f32;
            let reference: Vec<Vec4> = (0..n * n)
                .map(|e| tf.segment(v(e % n), v(e / n), len, 256))
                .collect();
            for build in ["integrated", "incremental"] {
                let (t, table) = best(runs, || match build {
                    "integrated" => PreintegrationTable::new(tf, lo, hi, n, len).unwrap(),
                    _ => PreintegrationTable::incremental(tf, lo, hi, n, len).unwrap(),
                });
                let (mut sum, mut worst) = (0.0f64, 0.0f32);
                for (e, r) in reference.iter().enumerate() {
                    let got = table.lookup(v(e % n), v(e / n));
                    let d = (got - *r).abs().max_element();
                    sum += f64::from(d);
                    worst = worst.max(d);
                }
                println!(
                    "| {name} | {n} | {build} | {:.1} | {:.2e} | {worst:.2e} |",
                    1e3 * t,
                    sum / (n * n) as f64
                );
            }
        }
    }
}
