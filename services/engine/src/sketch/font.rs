//! A built-in 3 × 5 bitmap font for the digits 0–9, used to number lines on overlays.
//!
//! Part of the overlay picture ([`super::overlay`]); no font file, no dependency. Each glyph
//! is five rows of three bits, most significant bit on the left.

/// Glyph width, pixels (before scaling).
pub const GLYPH_WIDTH_PX: u32 = 3;
/// Glyph height, pixels (before scaling).
pub const GLYPH_HEIGHT_PX: u32 = 5;

const DIGITS: [[u8; 5]; 10] = [
    [0b111, 0b101, 0b101, 0b101, 0b111], // 0
    [0b010, 0b110, 0b010, 0b010, 0b111], // 1
    [0b111, 0b001, 0b111, 0b100, 0b111], // 2
    [0b111, 0b001, 0b111, 0b001, 0b111], // 3
    [0b101, 0b101, 0b111, 0b001, 0b001], // 4
    [0b111, 0b100, 0b111, 0b001, 0b111], // 5
    [0b111, 0b100, 0b111, 0b101, 0b111], // 6
    [0b111, 0b001, 0b010, 0b010, 0b010], // 7
    [0b111, 0b101, 0b111, 0b101, 0b111], // 8
    [0b111, 0b101, 0b111, 0b001, 0b111], // 9
];

/// True when pixel `(col, row)` of digit `digit`'s glyph is ink. Out-of-range arguments
/// are blank.
pub fn glyph_pixel(digit: u8, col: u32, row: u32) -> bool {
    if digit > 9 || col >= GLYPH_WIDTH_PX || row >= GLYPH_HEIGHT_PX {
        return false;
    }
    DIGITS[digit as usize][row as usize] & (0b100 >> col) != 0
}

/// Size `(width, height)` in pixels of `text` written at `scale` with one blank column
/// between glyphs.
pub fn text_size_px(text: &str, scale: u32) -> (u32, u32) {
    let n = text.chars().count() as u32;
    if n == 0 {
        return (0, 0);
    }
    (
        (n * (GLYPH_WIDTH_PX + 1) - 1) * scale,
        GLYPH_HEIGHT_PX * scale,
    )
}

/// Calls `put(x, y)` for every ink pixel of `text` (digits only; other characters leave a
/// blank cell) drawn with its top-left corner at `(x0, y0)`, each glyph pixel `scale × scale`.
pub fn draw_text(text: &str, x0: i64, y0: i64, scale: u32, mut put: impl FnMut(i64, i64)) {
    let scale = scale.max(1) as i64;
    for (k, ch) in text.chars().enumerate() {
        let Some(d) = ch.to_digit(10) else { continue };
        let gx = x0 + k as i64 * (GLYPH_WIDTH_PX as i64 + 1) * scale;
        for row in 0..GLYPH_HEIGHT_PX {
            for col in 0..GLYPH_WIDTH_PX {
                if glyph_pixel(d as u8, col, row) {
                    for sy in 0..scale {
                        for sx in 0..scale {
                            put(gx + col as i64 * scale + sx, y0 + row as i64 * scale + sy);
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
    fn digits_have_distinct_glyphs() {
        for a in 0..10u8 {
            for b in (a + 1)..10 {
                assert_ne!(DIGITS[a as usize], DIGITS[b as usize]);
            }
        }
        assert!(glyph_pixel(1, 1, 0) && !glyph_pixel(1, 0, 0) && !glyph_pixel(11, 0, 0));
    }

    #[test]
    fn text_is_measured_and_drawn() {
        assert_eq!(text_size_px("12", 2), (14, 10));
        let mut n = 0;
        draw_text("8", 0, 0, 1, |_, _| n += 1);
        assert_eq!(n, 13);
    }
}
