//! A tiny 5×7 bitmap font for legend labels: digits, sign, point, `e`, and `NaN`.

use crate::rgb::Rgb;

/// Glyph width in pixels (before scaling).
pub const WIDTH: usize = 5;
/// Glyph height in pixels (before scaling).
pub const HEIGHT: usize = 7;
/// Blank columns between glyphs.
const SPACING: usize = 1;

/// Each glyph: 7 rows, `#` = ink.
const GLYPHS: [(char, [&str; HEIGHT]); 17] = [
    (
        '0',
        [
            ".###.", "#...#", "#..##", "#.#.#", "##..#", "#...#", ".###.",
        ],
    ),
    (
        '1',
        [
            "..#..", ".##..", "..#..", "..#..", "..#..", "..#..", ".###.",
        ],
    ),
    (
        '2',
        [
            ".###.", "#...#", "....#", "...#.", "..#..", ".#...", "#####",
        ],
    ),
    (
        '3',
        [
            "#####", "...#.", "..#..", "...#.", "....#", "#...#", ".###.",
        ],
    ),
    (
        '4',
        [
            "...#.", "..##.", ".#.#.", "#..#.", "#####", "...#.", "...#.",
        ],
    ),
    (
        '5',
        [
            "#####", "#....", "####.", "....#", "....#", "#...#", ".###.",
        ],
    ),
    (
        '6',
        [
            "..##.", ".#...", "#....", "####.", "#...#", "#...#", ".###.",
        ],
    ),
    (
        '7',
        [
            "#####", "....#", "...#.", "..#..", ".#...", ".#...", ".#...",
        ],
    ),
    (
        '8',
        [
            ".###.", "#...#", "#...#", ".###.", "#...#", "#...#", ".###.",
        ],
    ),
    (
        '9',
        [
            ".###.", "#...#", "#...#", ".####", "....#", "...#.", ".##..",
        ],
    ),
    (
        '-',
        [
            ".....", ".....", ".....", "#####", ".....", ".....", ".....",
        ],
    ),
    (
        '+',
        [
            ".....", "..#..", "..#..", "#####", "..#..", "..#..", ".....",
        ],
    ),
    (
        '.',
        [
            ".....", ".....", ".....", ".....", ".....", ".##..", ".##..",
        ],
    ),
    (
        'e',
        [
            ".....", ".....", ".###.", "#...#", "#####", "#....", ".###.",
        ],
    ),
    (
        'N',
        [
            "#...#", "##..#", "#.#.#", "#..##", "#...#", "#...#", "#...#",
        ],
    ),
    (
        'a',
        [
            ".....", ".....", ".###.", "....#", ".####", "#...#", ".####",
        ],
    ),
    (
        ' ',
        [
            ".....", ".....", ".....", ".....", ".....", ".....", ".....",
        ],
    ),
];

/// The rows of `c`'s glyph; unknown characters draw as a hollow box.
fn glyph(c: char) -> [&'static str; HEIGHT] {
    GLYPHS
        .iter()
        .find(|(g, _)| *g == c)
        .map(|(_, rows)| *rows)
        .unwrap_or([
            "#####", "#...#", "#...#", "#...#", "#...#", "#...#", "#####",
        ])
}

/// Width in pixels of `text` drawn at `scale`.
pub fn text_width(text: &str, scale: usize) -> usize {
    let n = text.chars().count();
    (n * (WIDTH + SPACING)).saturating_sub(SPACING) * scale
}

/// Draws `text` with its top-left corner at `(x, y)`, each font pixel a `scale`×`scale`
/// square. Pixels outside the picture are skipped.
pub fn draw(img: &mut Rgb, text: &str, x: usize, y: usize, scale: usize, colour: [u8; 3]) {
    for (i, c) in text.chars().enumerate() {
        let left = x + i * (WIDTH + SPACING) * scale;
        for (row, bits) in glyph(c).iter().enumerate() {
            for (col, bit) in bits.bytes().enumerate() {
                if bit != b'#' {
                    continue;
                }
                for dy in 0..scale {
                    for dx in 0..scale {
                        img.put(left + col * scale + dx, y + row * scale + dy, colour);
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
    fn glyphs_are_well_formed_and_distinct() {
        for (c, rows) in GLYPHS {
            assert!(rows.iter().all(|r| r.len() == WIDTH), "{c}");
        }
        for (i, (a, ra)) in GLYPHS.iter().enumerate() {
            for (b, rb) in &GLYPHS[i + 1..] {
                assert_ne!(ra, rb, "{a} and {b} look the same");
            }
        }
    }

    #[test]
    fn drawing_sets_exactly_the_ink() {
        let mut img = Rgb {
            width: 20,
            height: 10,
            pixels: vec![255; 600],
        };
        draw(&mut img, "1", 2, 1, 1, [0, 0, 0]);
        let ink = img.pixels.chunks(3).filter(|p| p[0] == 0).count();
        let expected: usize = glyph('1').iter().map(|r| r.matches('#').count()).sum();
        assert_eq!(ink, expected);
        assert_eq!(img.get(4, 1), Some([0, 0, 0]));
        assert_eq!(text_width("-1.25", 2), (5 * 6 - 1) * 2);
    }
}
