//! The human-readable summary of `isokit octree`.

/// The human-readable form of the report `v` (the `--json` object).
pub fn print(v: &serde_json::Value) {
    let f = |k: &str| v[k].as_f64().unwrap_or(f64::NAN);
    let u = |k: &str| v[k].as_u64().unwrap_or(0);
    println!("{}", v["what"].as_str().unwrap_or(""));
    println!(
        "domain: cube of side {} at {}, levels {}..={}, finest cell {:.4e}",
        v["domain_side"],
        v["domain_origin"],
        v["min_level"],
        v["max_level"],
        f("finest_spacing")
    );
    println!(
        "{} cells ({} leaves, per level {}), {} nodes ({} hanging), {:.1} bytes per cell",
        u("cells"),
        u("leaves"),
        v["leaves_per_level"],
        u("nodes"),
        u("hanging_nodes"),
        f("bytes_per_cell")
    );
    println!(
        "built in {:.3} s ({} finalize passes), {} field evaluations = {:.4}% of the dense {}^3 grid",
        f("build_seconds"),
        u("finalize_passes"),
        u("evaluations"),
        100.0 * f("dense_fraction"),
        (1u64 << u("max_level")) + 1
    );
    println!(
        "error at {} random points within {:.3e} of the surface, against {}: max {:.3e}, rms {:.3e} (bound {:.3e})",
        u("test_points"),
        f("test_band"),
        v["reference"].as_str().unwrap_or(""),
        f("max_error"),
        f("rms_error"),
        f("error_bound")
    );
    if u("bound_missed_cells") > 0 {
        let at_max = u("bound_missed_cells_at_max_level");
        let level = match v["level_for_bound"].as_u64() {
            Some(l) => format!("; about --max-level {l} would meet it (error ~ h^2)"),
            None => String::new(),
        };
        println!(
            "bound missed: {} leaves hold a test point beyond the bound, {at_max} of them at --max-level {} (refinement stopped there){level}",
            u("bound_missed_cells"),
            v["max_level"]
        );
    }
    if let (Some(p), Some(d)) = (v["output"].as_str(), v["export_dims"].as_array()) {
        let d: Vec<String> = d.iter().map(|x| x.to_string()).collect();
        println!("-> {p} ({}, level {})", d.join(" x "), v["export_level"]);
    }
}
