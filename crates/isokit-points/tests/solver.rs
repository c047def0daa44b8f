//! The sparse system of the PolyGauss partition of unity: measured iterations and residuals
//! of both solvers, on random and on quasi-regular (Fibonacci) samplings of the sphere.

mod common;

use glam::Vec3;
use isokit_points::{PointSdf, PointSdfOptions, Solver};

fn fibonacci_sphere(n: usize) -> Vec<Vec3> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..n)
        .map(|i| {
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let t = golden * i as f64;
            Vec3::new((r * t.cos()) as f32, (r * t.sin()) as f32, z as f32)
        })
        .collect()
}

#[test]
fn solver_figures() {
    let random = common::cloud(&common::sphere(), 6000, 5).0;
    let fib = fibonacci_sphere(6000);
    for (name, p) in [("random", &random), ("fibonacci", &fib)] {
        let n: Vec<Vec3> = p.iter().map(|q| q.normalize()).collect();
        let h = common::spacing(p);
        for solver in [Solver::Gmres, Solver::Bicgstab] {
            for k in [8, 16, 24] {
                for max_iter in [25, 100, 400] {
                    let opts = PointSdfOptions {
                        k,
                        solver,
                        max_iter,
                        ..PointSdfOptions::default()
                    };
                    let sdf = PointSdf::new(p, &n, &opts).unwrap();
                    let st = sdf.stats().solve.unwrap();
                    println!(
                        "{name} sphere, {solver:?}, k {k}, cap {max_iter}: {} iterations, relative residual {:.2e}, max |f(p_i)| {:.2e} h, {:.3} s",
                        st.iterations,
                        st.relative_residual,
                        st.max_sample_value / h,
                        st.seconds
                    );
                    if solver == Solver::Gmres && k == 16 {
                        assert!(st.max_sample_value < 0.05 * h);
                    }
                }
            }
        }
    }
}
