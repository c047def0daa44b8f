//! What `isokit render` prints about a frame: one line on stderr, and with `--stats` the
//! frame's counters as one JSON object on stdout.

use super::Args;
use anyhow::Result;
use isokit_scene::{Frame, RenderSettings};

/// Prints the line about `frame` (`what`: the input, as the command describes it) and, with
/// `--stats`, the JSON object (the frame's stats less the scene sampling, plus the output
/// and, with `--clip`, `clip_caps`: the pixels showing the clip's cut faces).
pub fn print(
    a: &Args,
    s: &RenderSettings,
    frame: &Frame,
    what: &str,
    clip_caps: Option<usize>,
) -> Result<()> {
    let st = &frame.stats;
    eprintln!(
        "{what}; {}: {}x{}{} {} image{}: {} surface + {} cap pixels{}, {:.1} samples/ray, {}/{} blocks and {}/{} bricks active, {} pass(es), {} bricks loaded; prepare {:.2} s, trace {:.3} s, shade {:.3} s -> {}{}",
        st.device,
        if s.samples > 1 {
            st.width
        } else {
            frame.uniforms.width
        },
        st.height,
        s.multiview
            .map_or(String::new(), |m| format!(" {}-view", m.views)),
        st.mode,
        if s.samples > 1 {
            format!(" ({} rays per pixel; the counts are rays)", s.samples)
        } else {
            String::new()
        },
        st.hits,
        st.caps,
        clip_caps.map_or(String::new(), |n| format!(
            " ({n} surface pixels on the clip's cut faces)"
        )),
        st.samples_per_ray,
        st.blocks_active,
        st.blocks_total,
        st.bricks_active,
        st.bricks_total,
        st.passes,
        st.bricks_loaded,
        st.prepare_seconds,
        st.trace_seconds,
        st.shade_seconds,
        a.output.display(),
        a.gbuffer
            .as_ref()
            .map_or(String::new(), |g| format!(", {}", g.display()))
    );
    if a.stats {
        let mut j = serde_json::to_value(st)?;
        if let Some(o) = j.as_object_mut() {
            o.remove("sampling");
            o.insert("output".into(), a.output.display().to_string().into());
            if let Some(n) = clip_caps {
                o.insert("clip_caps".into(), n.into());
            }
        }
        println!("{j}");
    }
    Ok(())
}
