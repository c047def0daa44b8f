//! The panel: lines of text drawn over the frame (an 8x8 bitmap font), showing the
//! settings with the keys that change them and the live statistics, and the last error.

use font8x8::{BASIC_FONTS, UnicodeFonts};

/// Text colour of ordinary lines and of the error line (0RGB).
pub(crate) const TEXT: u32 = 0x00e8_e8e8;
pub(crate) const ERROR: u32 = 0x00ff_7060;

/// Draws `lines` (text, colour) from the top-left corner on a darkened box, at `scale`
/// pixels per font pixel. Characters outside the font draw as `?`; lines are cut at the
/// buffer's width.
pub(crate) fn draw(
    buf: &mut [u32],
    width: usize,
    height: usize,
    lines: &[(String, u32)],
    scale: usize,
) {
    let (cw, ch) = (8 * scale, 10 * scale);
    let cols = lines
        .iter()
        .map(|(l, _)| l.chars().count())
        .max()
        .unwrap_or(0);
    let (bw, bh) = (
        (cols * cw + 8).min(width),
        (lines.len() * ch + 6).min(height),
    );
    for y in 0..bh {
        for px in &mut buf[y * width..y * width + bw] {
            // Halve each channel: a translucent dark box under the text.
            *px = (*px >> 1) & 0x007f_7f7f;
        }
    }
    for (row, (line, colour)) in lines.iter().enumerate() {
        for (col, c) in line.chars().enumerate() {
            let glyph = BASIC_FONTS.get(c).or_else(|| BASIC_FONTS.get('?'));
            let Some(glyph) = glyph else { continue };
            let (x0, y0) = (4 + col * cw, 3 + row * ch);
            for (gy, bits) in glyph.iter().enumerate() {
                for gx in 0..8 {
                    if bits & (1 << gx) == 0 {
                        continue;
                    }
                    for sy in 0..scale {
                        for sx in 0..scale {
                            let (x, y) = (x0 + gx * scale + sx, y0 + gy * scale + sy);
                            if x < width && y < height {
                                buf[y * width + x] = *colour;
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
        draw(&mut buf, w, h, &[("A very long line".into(), TEXT)], 1);
        // Some text pixels, a darkened background, and nothing written out of bounds.
        assert!(buf.contains(&TEXT));
        assert!(buf.contains(&0x007f_7f7f));
        assert_eq!(buf.len(), w * h);
    }
}
