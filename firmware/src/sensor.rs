//! A synthetic sensor: rows of the views of a 9×9 array looking at a textured square
//! (disparity `NEAR`) in front of a textured background (`FAR`), computed on demand so the
//! firmware holds no frame.

/// Disparity of the square and of the background (px between adjacent views).
pub const NEAR: f32 = 1.0;
pub const FAR: f32 = -0.5;

/// The square, in centre-view pixels: `[LOW, HIGH)²` scaled by the frame side.
const LOW: f32 = 0.3;
const HIGH: f32 = 0.7;

fn texture(x: f32, y: f32, seed: f32) -> f32 {
    128.0
        + 50.0 * libm::sinf(0.71 * x + seed) * libm::cosf(0.53 * y - seed)
        + 30.0 * libm::sinf(0.23 * x + 0.37 * y + 2.0 * seed)
}

fn in_square(x: f32, y: f32, width: usize, height: usize) -> bool {
    let (u, v) = (x / width as f32, y / height as f32);
    (LOW..HIGH).contains(&u) && (LOW..HIGH).contains(&v)
}

/// Fills `out` (one gray row of `width` pixels) with row `y` of the view `(du, dv)` views
/// from the centre.
pub fn row(du: f32, dv: f32, y: usize, width: usize, height: usize, out: &mut [u8]) {
    for (x, o) in out.iter_mut().enumerate().take(width) {
        let (px, py) = (x as f32, y as f32);
        // The ray of this pixel meets the square at (px + NEAR·du, py + NEAR·dv).
        let (nx, ny) = (px + NEAR * du, py + NEAR * dv);
        let value = if in_square(nx, ny, width, height) {
            texture(nx, ny, 1.3)
        } else {
            texture(px + FAR * du, py + FAR * dv, 0.0)
        };
        *o = value.clamp(0.0, 255.0) as u8;
    }
}

/// The true centre-view disparity at pixel `(x, y)`.
#[cfg_attr(target_os = "none", allow(dead_code))]
pub fn disparity(x: usize, y: usize, width: usize, height: usize) -> f32 {
    if in_square(x as f32, y as f32, width, height) {
        NEAR
    } else {
        FAR
    }
}
