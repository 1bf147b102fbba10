//! Matching a centre-view corner in another view: pyramidal Lucas–Kanade on a square
//! template (inverse compositional, translation plus brightness offset).
//!
//! The template around the corner is the corner's descriptor; matching is aligning it,
//! coarse to fine, which gives the sub-pixel positions a 0.1-pixel homography needs
//! (descriptor matching alone is pixel-accurate at best).

use super::pyramid::{Image, Pyramid};

/// Template half-size: 9 × 9 samples.
const RADIUS: i32 = 4;
const SIDE: usize = (2 * RADIUS + 1) as usize;
const AREA: usize = SIDE * SIDE;
/// Smallest zero-mean normalised correlation of an accepted match.
const MIN_NCC: f32 = 0.8;
/// Gauss–Newton rounds per level.
const ROUNDS: usize = 12;

/// The shape of a first-pass match: no rotation or scale expected.
pub const IDENTITY: [f32; 4] = [1.0, 0.0, 0.0, 1.0];

/// Both pyramids a match reads.
#[derive(Clone, Copy)]
pub struct Pair<'d> {
    pub pyramid: &'d Pyramid,
    pub center: &'d [f32],
    pub view: &'d [f32],
}

/// Full-resolution pixel coordinate → coordinate at `level` (box-filtered pyramid).
#[inline(always)]
fn to_level(v: f32, level: usize) -> f32 {
    let s = (1u32 << level) as f32;
    (v + 0.5) / s - 0.5
}

#[inline(always)]
fn from_level(v: f32, level: usize) -> f32 {
    let s = (1u32 << level) as f32;
    (v + 0.5) * s - 0.5
}

/// Template samples with a one-sample rim for gradients; `None` near the border.
fn template(
    img: &Image<'_>,
    x: f32,
    y: f32,
    out: &mut [f32; (SIDE + 2) * (SIDE + 2)],
) -> Option<()> {
    let r = (RADIUS + 1) as f32;
    sample_grid(img, x - r, y - r, SIDE + 2, out).then_some(())
}

/// Sub-pixel position in the view of the corner at `p` of the centre view, starting from
/// `guess`. `shape` (row-major 2 × 2) is the expected local linear map from the centre
/// view to this view — identity on a first pass, the current homographies' Jacobian on
/// the second, so that rotation and scale between the views do not bias the match.
/// `None` when the match leaves the image, is ill-conditioned or does not look like the
/// template.
///
/// `coarsest` caps the pyramid level the search starts from: a guess known to within a
/// pixel or two needs only the full-resolution level.
pub fn track(
    pair: &Pair<'_>,
    p: (f32, f32),
    guess: (f32, f32),
    shape: [f32; 4],
    coarsest: usize,
) -> Option<(f32, f32)> {
    let a = shape;
    let mut q = guess;
    let mut last_ncc = None;
    for level in (0..pair.pyramid.levels.min(coarsest.saturating_add(1))).rev() {
        // Coarse levels only need to bring the next level into its basin.
        let converged = if level == 0 { 1e-4 } else { 4e-4 };
        let t_img = pair.pyramid.level(pair.center, level);
        let v_img = pair.pyramid.level(pair.view, level);
        let (px, py) = (to_level(p.0, level), to_level(p.1, level));
        let mut qx = to_level(q.0, level);
        let mut qy = to_level(q.1, level);
        let mut rim = [0.0f32; (SIDE + 2) * (SIDE + 2)];
        if template(&t_img, px, py, &mut rim).is_none() {
            if level == 0 {
                return None;
            }
            continue; // too close to the border at this scale: refine at finer ones
        }
        // Template, its gradients and the Gauss–Newton matrix.
        let mut t = [0.0f32; AREA];
        let mut gx = [0.0f32; AREA];
        let mut gy = [0.0f32; AREA];
        let (mut hxx, mut hxy, mut hyy, mut t_mean) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
        let row = SIDE + 2;
        for j in 0..SIDE {
            for i in 0..SIDE {
                let c = (j + 1) * row + i + 1;
                let k = j * SIDE + i;
                t[k] = rim[c];
                gx[k] = 0.5 * (rim[c + 1] - rim[c - 1]);
                gy[k] = 0.5 * (rim[c + row] - rim[c - row]);
                hxx += gx[k] * gx[k];
                hxy += gx[k] * gy[k];
                hyy += gy[k] * gy[k];
                t_mean += t[k];
            }
        }
        t_mean /= AREA as f32;
        let det = hxx * hyy - hxy * hxy;
        if !(det > 1e-12 && det.is_finite()) {
            return None;
        }
        let mut patch = [0.0f32; AREA];
        let mut ok = false;
        for _ in 0..ROUNDS {
            ok = false;
            let inside = sample_patch(&v_img, qx, qy, a, &mut patch);
            let mean = patch.iter().sum::<f32>() / AREA as f32;
            if !inside {
                break;
            }
            ok = true;
            let (mut bx, mut by) = (0.0f32, 0.0f32);
            for k in 0..AREA {
                let e = (patch[k] - mean) - (t[k] - t_mean);
                bx += gx[k] * e;
                by += gy[k] * e;
            }
            let dx = (hyy * bx - hxy * by) / det;
            let dy = (hxx * by - hxy * bx) / det;
            if !(dx.is_finite() && dy.is_finite()) {
                return None;
            }
            // Inverse compositional: the template moved by (dx, dy) ⇒ the view point by −A·(dx, dy).
            qx -= a[0] * dx + a[1] * dy;
            qy -= a[2] * dx + a[3] * dy;
            if dx * dx + dy * dy < converged {
                break;
            }
        }
        if !ok {
            if level == 0 {
                return None;
            }
            continue;
        }
        if level == 0 {
            last_ncc = ncc(&v_img, qx, qy, a, &t, t_mean, &mut patch);
        }
        q = (from_level(qx, level), from_level(qy, level));
    }
    match last_ncc {
        Some(c) if c >= MIN_NCC => Some(q),
        _ => None,
    }
}

/// Samples the `side` × `side` grid with top-left corner `(x0, y0)` and unit steps into
/// `out`; every sample shares the same bilinear weights. False when it leaves the image.
fn sample_grid(img: &Image<'_>, x0: f32, y0: f32, side: usize, out: &mut [f32]) -> bool {
    if !(x0 >= 0.0 && y0 >= 0.0) {
        return false;
    }
    let (ix, iy) = (x0 as usize, y0 as usize);
    if ix + side >= img.width || iy + side >= img.height || out.len() < side * side {
        return false;
    }
    let (fx, fy) = (x0 - ix as f32, y0 - iy as f32);
    let (w00, w01) = ((1.0 - fx) * (1.0 - fy), fx * (1.0 - fy));
    let (w10, w11) = ((1.0 - fx) * fy, fx * fy);
    let w = img.width;
    for (j, row) in out.chunks_exact_mut(side).take(side).enumerate() {
        let start = (iy + j) * w + ix;
        let (Some(top), Some(bottom)) = (
            img.data.get(start..start + side + 1),
            img.data.get(start + w..start + w + side + 1),
        ) else {
            return false;
        };
        let (top_next, bottom_next) = (top.iter().skip(1), bottom.iter().skip(1));
        let pixels = top.iter().zip(top_next).zip(bottom.iter().zip(bottom_next));
        for (o, ((t0, t1), (b0, b1))) in row.iter_mut().zip(pixels) {
            *o = w00 * t0 + w01 * t1 + w10 * b0 + w11 * b1;
        }
    }
    true
}

/// Samples the 9 × 9 patch `q + A·(dx, dy)` of `img`; false when it leaves the image.
fn sample_patch(img: &Image<'_>, qx: f32, qy: f32, a: [f32; 4], out: &mut [f32; AREA]) -> bool {
    let r = RADIUS as f32;
    if a == IDENTITY {
        return sample_grid(img, qx - r, qy - r, SIDE, out);
    }
    let mut slots = out.iter_mut();
    for dy in -RADIUS..=RADIUS {
        for dx in -RADIUS..=RADIUS {
            let (ox, oy) = (dx as f32, dy as f32);
            // SIDE × SIDE = AREA slots: `next` never runs out.
            let (Some(v), Some(slot)) = (
                img.sample(qx + a[0] * ox + a[1] * oy, qy + a[2] * ox + a[3] * oy),
                slots.next(),
            ) else {
                return false;
            };
            *slot = v;
        }
    }
    true
}

/// Zero-mean normalised correlation of the template with the view patch at `(x, y)`.
fn ncc(
    img: &Image<'_>,
    x: f32,
    y: f32,
    a: [f32; 4],
    t: &[f32; AREA],
    t_mean: f32,
    buf: &mut [f32; AREA],
) -> Option<f32> {
    let mut slots = buf.iter_mut();
    let mut mean = 0.0f32;
    for dy in -RADIUS..=RADIUS {
        for dx in -RADIUS..=RADIUS {
            let (ox, oy) = (dx as f32, dy as f32);
            // SIDE × SIDE = AREA slots: `next` never runs out.
            let slot = slots.next()?;
            *slot = img.sample(x + a[0] * ox + a[1] * oy, y + a[2] * ox + a[3] * oy)?;
            mean += *slot;
        }
    }
    mean /= AREA as f32;
    let (mut st, mut sv, mut stv) = (0.0f32, 0.0f32, 0.0f32);
    for k in 0..AREA {
        let (a, b) = (t[k] - t_mean, buf[k] - mean);
        st += a * a;
        sv += b * b;
        stv += a * b;
    }
    let den = crate::float::sqrtf(st * sv);
    (den > 1e-12).then(|| stv / den)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texture(x: f32, y: f32) -> f32 {
        0.5 + 0.2 * libm::sinf(0.31 * x + 0.17 * y)
            + 0.15 * libm::cosf(0.23 * y - 0.11 * x)
            + 0.1 * libm::sinf(0.07 * x * 1.3 + 0.05 * y * y * 0.02)
    }

    #[test]
    fn recovers_a_sub_pixel_shift() {
        let (w, h) = (96usize, 96usize);
        let pyramid = Pyramid::new(w, h).unwrap();
        let mut center = std::vec![0.0f32; pyramid.len];
        let mut view = std::vec![0.0f32; pyramid.len];
        let (sx, sy) = (5.3f32, -3.7f32);
        for y in 0..h {
            for x in 0..w {
                center[y * w + x] = texture(x as f32, y as f32);
                view[y * w + x] = texture(x as f32 - sx, y as f32 - sy) + 0.05;
            }
        }
        pyramid.reduce(&mut center);
        pyramid.reduce(&mut view);
        let pair = Pair {
            pyramid: &pyramid,
            center: &center,
            view: &view,
        };
        let q = track(&pair, (40.0, 50.0), (40.0, 50.0), IDENTITY, 3).unwrap();
        // Bilinear resampling biases LK by a few hundredths of a pixel on fine texture.
        assert!(
            (q.0 - 45.3).abs() < 0.05 && (q.1 - 46.3).abs() < 0.05,
            "{q:?}"
        );
        // A different image is rejected.
        for v in view.iter_mut().take(w * h) {
            *v = 0.5;
        }
        view[50 * w + 45] = 0.9;
        pyramid.reduce(&mut view);
        let pair = Pair {
            pyramid: &pyramid,
            center: &center,
            view: &view,
        };
        assert!(track(&pair, (40.0, 50.0), (40.0, 50.0), IDENTITY, 3).is_none());
    }
}
