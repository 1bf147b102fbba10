//! An 8-bit RGB picture: what the colour maps and the font draw into.

/// An 8-bit RGB picture.
#[derive(Clone, Debug, PartialEq)]
pub struct Rgb {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `width * height * 3` bytes, top row first.
    pub pixels: Vec<u8>,
}

impl Rgb {
    /// A picture of `width × height` pixels of colour `fill`.
    pub fn new(width: usize, height: usize, fill: [u8; 3]) -> Self {
        Rgb {
            width,
            height,
            pixels: fill.repeat(width * height),
        }
    }

    /// Sets one pixel; outside the picture nothing happens.
    pub fn put(&mut self, x: usize, y: usize, colour: [u8; 3]) {
        if x < self.width && y < self.height {
            let i = (y * self.width + x) * 3;
            self.pixels[i..i + 3].copy_from_slice(&colour);
        }
    }

    /// One pixel, or `None` outside.
    pub fn get(&self, x: usize, y: usize) -> Option<[u8; 3]> {
        if x >= self.width || y >= self.height {
            return None;
        }
        let i = (y * self.width + x) * 3;
        Some([self.pixels[i], self.pixels[i + 1], self.pixels[i + 2]])
    }
}
