//! The panel: lines of text drawn over the frame (an 8x8 bitmap font) with the settings, their
//! buttons and the isovalue's slider, the live statistics and the last error; and where a
//! click on it lands.

use font8x8::{BASIC_FONTS, UnicodeFonts};

/// Text colour of ordinary lines and of the error line (0RGB).
pub(crate) const TEXT: u32 = 0x00e8_e8e8;
pub(crate) const ERROR: u32 = 0x00ff_7060;
/// Background of buttons, and the slider's track and its filled part (0RGB).
const BUTTON: u32 = 0x0046_5260;
const TRACK: u32 = 0x0030_3438;
const FILL: u32 = 0x0070_a0d0;

/// What a click on a widget asks for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Action {
    /// The next (+1) or previous (−1) shading mode.
    Mode(isize),
    /// The isovalue one step up (+1) or down (−1).
    Iso(f32),
    /// The isovalue at this fraction of the slider's range (set from where it was clicked).
    IsoAt,
    /// Twice (true) or half (false) the sampling resolution.
    Resolution(bool),
    /// Twice (true) or half (false) the sampled band.
    Band(bool),
    /// The input's own camera.
    Reset,
    /// Hide the panel.
    Hide,
    /// Close the window.
    Quit,
}

/// A clickable run of columns of a line.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Widget {
    pub col: usize,
    pub len: usize,
    pub action: Action,
    /// For a slider: the filled fraction drawn.
    pub slider: Option<f32>,
}

/// One line of the panel.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Line {
    pub text: String,
    pub colour: u32,
    pub widgets: Vec<Widget>,
}

impl Line {
    pub fn new(text: impl Into<String>, colour: u32) -> Self {
        Self {
            text: text.into(),
            colour,
            widgets: Vec::new(),
        }
    }

    /// Appends a button labelled `label` (after a space).
    pub fn button(mut self, label: &str, action: Action) -> Self {
        self.text.push(' ');
        let col = self.text.chars().count();
        self.text.push_str(label);
        self.widgets.push(Widget {
            col,
            len: label.chars().count(),
            action,
            slider: None,
        });
        self
    }

    /// Appends plain text.
    pub fn text(mut self, s: &str) -> Self {
        self.text.push_str(s);
        self
    }

    /// Appends a slider `cols` characters wide, filled to `fraction` (after a space).
    pub fn slider(mut self, cols: usize, fraction: f32, action: Action) -> Self {
        self.text.push(' ');
        let col = self.text.chars().count();
        self.text.extend(std::iter::repeat_n(' ', cols));
        self.widgets.push(Widget {
            col,
            len: cols,
            action,
            slider: Some(fraction.clamp(0.0, 1.0)),
        });
        self
    }
}

/// The panel's geometry at `scale` pixels per font pixel: character cell and text origin.
fn cell(scale: usize) -> (usize, usize) {
    (8 * scale, 10 * scale)
}
const LEFT: usize = 4;
const TOP: usize = 3;

/// The widget at pixel (`x`, `y`), with the fraction of its width left of `x` (for sliders).
pub(crate) fn hit(lines: &[Line], scale: usize, x: f64, y: f64) -> Option<(Action, f32)> {
    let (cw, ch) = cell(scale);
    if x < LEFT as f64 || y < TOP as f64 {
        return None;
    }
    let row = ((y - TOP as f64) / ch as f64) as usize;
    let col_f = (x - LEFT as f64) / cw as f64;
    let line = lines.get(row)?;
    line.widgets.iter().find_map(|w| {
        let rel = col_f - w.col as f64;
        (0.0..w.len as f64)
            .contains(&rel)
            .then(|| (w.action, (rel / w.len as f64) as f32))
    })
}

/// Where along the first slider of `lines` the pixel column `x` lies (0 at its left end,
/// 1 at its right, clamped): a drag that started on the slider follows the cursor anywhere.
pub(crate) fn slider_fraction(lines: &[Line], scale: usize, x: f64) -> Option<f32> {
    let (cw, _) = cell(scale);
    let w = lines
        .iter()
        .flat_map(|l| &l.widgets)
        .find(|w| w.slider.is_some())?;
    let x0 = (LEFT + w.col * cw) as f64;
    Some((((x - x0) / (w.len * cw) as f64) as f32).clamp(0.0, 1.0))
}

/// Draws `lines` from the top-left corner on a darkened box, at `scale` pixels per font
/// pixel, with their widgets. Characters outside the font draw as `?`; lines are cut at the
/// buffer's width.
pub(crate) fn draw(buf: &mut [u32], width: usize, height: usize, lines: &[Line], scale: usize) {
    let (cw, ch) = cell(scale);
    let cols = lines
        .iter()
        .map(|l| l.text.chars().count())
        .max()
        .unwrap_or(0);
    let (bw, bh) = (
        (cols * cw + 2 * LEFT).min(width),
        (lines.len() * ch + 2 * TOP).min(height),
    );
    for y in 0..bh {
        for px in &mut buf[y * width..y * width + bw] {
            // Halve each channel: a translucent dark box under the text.
            *px = (*px >> 1) & 0x007f_7f7f;
        }
    }
    let mut rect = |x0: usize, y0: usize, w: usize, h: usize, colour: u32| {
        for y in y0..(y0 + h).min(height) {
            for x in x0..(x0 + w).min(width) {
                buf[y * width + x] = colour;
            }
        }
    };
    for (row, line) in lines.iter().enumerate() {
        let y0 = TOP + row * ch;
        for w in &line.widgets {
            let x0 = LEFT + w.col * cw;
            match w.slider {
                None => rect(
                    x0 - scale,
                    y0 - scale,
                    w.len * cw + scale,
                    ch - scale,
                    BUTTON,
                ),
                Some(f) => {
                    let full = w.len * cw;
                    let filled = (f * full as f32).round() as usize;
                    let (ty, th) = (y0 + 2 * scale, 4 * scale);
                    rect(x0, ty, full, th, TRACK);
                    rect(x0, ty, filled, th, FILL);
                    // The knob.
                    rect(
                        x0 + filled.saturating_sub(scale),
                        y0,
                        2 * scale,
                        8 * scale,
                        TEXT,
                    );
                }
            }
        }
    }
    for (row, line) in lines.iter().enumerate() {
        for (col, c) in line.text.chars().enumerate() {
            if c == ' ' {
                continue;
            }
            let glyph = BASIC_FONTS.get(c).or_else(|| BASIC_FONTS.get('?'));
            let Some(glyph) = glyph else { continue };
            let (x0, y0) = (LEFT + col * cw, TOP + row * ch);
            for (gy, bits) in glyph.iter().enumerate() {
                for gx in 0..8 {
                    if bits & (1 << gx) == 0 {
                        continue;
                    }
                    for sy in 0..scale {
                        for sx in 0..scale {
                            let (x, y) = (x0 + gx * scale + sx, y0 + gy * scale + sy);
                            if x < width && y < height {
                                buf[y * width + x] = line.colour;
                            }
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_drawn_and_clipped() {
        let (w, h) = (40, 12);
        let mut buf = vec![0x00ff_ffff; w * h];
        draw(&mut buf, w, h, &[Line::new("A very long line", TEXT)], 1);
        // Some text pixels, a darkened background, and nothing written out of bounds.
        assert!(buf.contains(&TEXT));
        assert!(buf.contains(&0x007f_7f7f));
        assert_eq!(buf.len(), w * h);
    }

    fn lines() -> Vec<Line> {
        vec![
            Line::new("file.json", TEXT).button("[hide]", Action::Hide),
            Line::new("shading  phong", TEXT)
                .button("[<]", Action::Mode(-1))
                .button("[>]", Action::Mode(1)),
            Line::new("iso", TEXT).slider(20, 0.25, Action::IsoAt),
        ]
    }

    /// The centre of a widget's `k`-th column, in pixels.
    fn at(l: &[Line], row: usize, w: usize, k: usize, scale: usize) -> (f64, f64) {
        let (cw, ch) = cell(scale);
        let col = l[row].widgets[w].col + k;
        (
            (LEFT + col * cw + cw / 2) as f64,
            (TOP + row * ch + ch / 2) as f64,
        )
    }

    #[test]
    fn clicks_land_on_the_widget_drawn_there() {
        let l = lines();
        for scale in [1, 2] {
            let (x, y) = at(&l, 1, 1, 1, scale);
            assert_eq!(hit(&l, scale, x, y).map(|h| h.0), Some(Action::Mode(1)));
            let (x, y) = at(&l, 1, 0, 0, scale);
            assert_eq!(hit(&l, scale, x, y).map(|h| h.0), Some(Action::Mode(-1)));
            let (x, y) = at(&l, 0, 0, 3, scale);
            assert_eq!(hit(&l, scale, x, y).map(|h| h.0), Some(Action::Hide));
            // The slider reports where along it the click fell.
            let (x, y) = at(&l, 2, 0, 15, scale);
            let (a, f) = hit(&l, scale, x, y).unwrap();
            assert_eq!(a, Action::IsoAt);
            assert!((f - 15.5 / 20.0).abs() < 0.01, "{f}");
            // Dragged from it: the same fraction on any row, clamped beyond its ends.
            assert_eq!(slider_fraction(&l, scale, x), Some(f));
            assert_eq!(slider_fraction(&l, scale, 0.0), Some(0.0));
            assert_eq!(slider_fraction(&l, scale, 1e4), Some(1.0));
            // Text, the gap between buttons, and below the panel: nothing.
            let (cw, _) = cell(scale);
            let (x, y) = at(&l, 1, 0, 0, scale);
            assert_eq!(hit(&l, scale, x - 2.0 * cw as f64, y), None);
            assert_eq!(hit(&l, scale, x + 3.0 * cw as f64, y), None);
            assert_eq!(hit(&l, scale, x, y + 10.0 * cell(scale).1 as f64), None);
        }
        assert_eq!(hit(&l, 1, -5.0, 1.0), None);
    }

    #[test]
    fn buttons_and_the_slider_are_drawn_under_their_columns() {
        let l = lines();
        let (w, h) = (300, 40);
        let mut buf = vec![0; w * h];
        draw(&mut buf, w, h, &l, 1);
        let (x, y) = at(&l, 1, 1, 0, 1);
        // A button's background in its cell (around the glyph's pixels).
        let near = |x: f64, y: f64, c: u32| {
            (-4..=4).any(|dy: i64| {
                (-4..=4).any(|dx: i64| {
                    let (px, py) = ((x as i64 + dx) as usize, (y as i64 + dy) as usize);
                    buf[py * w + px] == c
                })
            })
        };
        assert!(near(x, y, BUTTON));
        // The slider: filled left of a quarter, track right of it.
        let (x, y) = at(&l, 2, 0, 2, 1);
        assert!(near(x, y, FILL));
        let (x, y) = at(&l, 2, 0, 15, 1);
        assert!(near(x, y, TRACK) && !near(x, y, FILL));
    }
}
