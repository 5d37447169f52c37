//! A tiny bitmap font of the ten digits, 3 by 5 pixels, for the frame numbers of a contact
//! sheet.

/// Each digit's 5 rows, top first; bit 2 of a row is its left pixel.
const GLYPHS: [[u8; 5]; 10] = [
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

/// A glyph's width and height in font pixels.
pub(super) const GLYPH: (u32, u32) = (3, 5);

/// The width in font pixels of `n` written out: 3 per digit and 1 between digits.
pub(super) fn text_width(n: u32) -> u32 {
    let digits = n.to_string().len() as u32;
    digits * (GLYPH.0 + 1) - 1
}

/// Whether the font pixel (x, y) of the number `n` written out is set.
pub(super) fn is_set(n: u32, x: u32, y: u32) -> bool {
    let digits = n.to_string();
    let (cell, col) = ((x / (GLYPH.0 + 1)) as usize, x % (GLYPH.0 + 1));
    if y >= GLYPH.1 || col >= GLYPH.0 {
        return false;
    }
    match digits.as_bytes().get(cell) {
        Some(&d) => GLYPHS[(d - b'0') as usize][y as usize] >> (GLYPH.0 - 1 - col) & 1 == 1,
        None => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pixels of a number as text, `#` for set.
    fn show(n: u32) -> Vec<String> {
        (0..GLYPH.1)
            .map(|y| {
                (0..text_width(n))
                    .map(|x| if is_set(n, x, y) { '#' } else { '.' })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn digits_are_drawn_left_to_right_with_a_gap() {
        assert_eq!(
            show(40),
            ["#.#.###", "#.#.#.#", "###.#.#", "..#.#.#", "..#.###"]
        );
        assert_eq!(text_width(7), 3);
        assert_eq!(text_width(12345), 19);
        assert!(!is_set(1, 0, 5) && !is_set(1, 3, 0));
    }

    #[test]
    fn every_digit_is_a_different_glyph() {
        for a in 0..10u32 {
            for b in a + 1..10 {
                assert_ne!(show(a), show(b), "{a} and {b}");
            }
        }
    }
}
