//! Rasterisation of one view and of the centre-view ground truth.
//!
//! Each stored pixel is the box filter of the scene's linear radiance over the pixel
//! area, then saturated to `[0, 1]` (the camera's tone curve), photometrically changed,
//! noised and quantised to 8 bits.
//!
//! * Pixels that see a single plane over their whole area (decided from `n × n` visibility
//!   samples, or from bounds alone when only the background can be there) are integrated
//!   in closed form: a plane maps pixels affinely to the surface, and the integral of
//!   `cos(g·p + ψ)` over a unit square is `cos(g·p₀ + ψ)·sinc(gx/2)·sinc(gy/2)`. For
//!   misaligned views the footprint uses the homography's Jacobian at the image centre.
//! * Other pixels (occlusion edges, spherical caps) average the `n × n` point samples
//!   (`n` = `supersample`) on a regular grid.

use super::camera::{ViewCamera, NOISE_STREAM};
use super::rng::Rng;
use super::scene::{Scene, MAX_SURFACES};
use super::surface::ViewSurface;
use super::texture::WAVES;
use super::SynthSpec;

/// Largest `supersample` (so per-pixel sample arrays have a fixed size).
pub const MAX_SUPERSAMPLE: usize = 8;

/// A wave of a plane's texture as seen by one view: phase `gx·x' + gy·y' + psi` in ideal
/// view coordinates, amplitude already multiplied by the pixel box filter's response.
#[derive(Clone, Copy, Debug, Default)]
struct ViewWave {
    gx: f64,
    gy: f64,
    psi: f64,
    amplitude: [f64; 3],
}

/// Everything about one surface that depends on the view.
#[derive(Clone, Copy, Debug)]
struct Prepared {
    geometry: ViewSurface,
    base: [f64; 3],
    waves: [ViewWave; WAVES],
}

/// `sin(t)/t`, continuous at 0.
fn sinc(t: f64) -> f64 {
    if libm::fabs(t) < 1e-8 {
        1.0
    } else {
        libm::sin(t) / t
    }
}

/// Renders view `(row, col)` of a validated spec into `out` (`width · height · channels`).
pub(crate) fn render_view(spec: &SynthSpec, scene: &Scene, row: usize, col: usize, out: &mut [u8]) {
    let (r0, c0) = spec.grid.center();
    let u = col as f64 - c0 as f64;
    let v = row as f64 - r0 as f64;
    let camera = ViewCamera::new(spec, row, col);
    let surfaces = scene.surfaces();

    let mut prepared = [Prepared {
        geometry: ViewSurface {
            alpha: 0.0,
            beta: 0.0,
            gamma: 0.0,
            bounds: [0.0; 4],
        },
        base: [0.0; 3],
        waves: [ViewWave::default(); WAVES],
    }; MAX_SURFACES];
    for (p, s) in prepared.iter_mut().zip(surfaces) {
        p.geometry = s.prepare(u, v);
        p.base = s.texture.base;
        if !s.is_plane() {
            continue;
        }
        let ViewSurface {
            alpha, beta, gamma, ..
        } = p.geometry;
        let j = camera.jacobian;
        for (w, t) in p.waves.iter_mut().zip(&s.texture.waves) {
            // Surface point p = p' + d(p')·(u, v) with d = alpha + beta·x' + gamma·y'.
            let gx = t.fx * (1.0 + u * beta) + t.fy * v * beta;
            let gy = t.fx * u * gamma + t.fy * (1.0 + v * gamma);
            let psi = t.phase + alpha * (t.fx * u + t.fy * v);
            // Frequencies per stored pixel: through the footprint Jacobian.
            let hx = gx * j[0] + gy * j[2];
            let hy = gx * j[1] + gy * j[3];
            let response = sinc(hx / 2.0) * sinc(hy / 2.0);
            *w = ViewWave {
                gx,
                gy,
                psi,
                amplitude: t.amplitude.map(|a| a * response),
            };
        }
    }
    let prepared = prepared.get(..surfaces.len()).unwrap_or(&[]);

    let n = spec.supersample.clamp(1, MAX_SUPERSAMPLE);
    let mut offsets = [0.0f64; MAX_SUPERSAMPLE];
    for (k, o) in offsets.iter_mut().enumerate().take(n) {
        *o = (k as f64 + 0.5) / n as f64 - 0.5;
    }
    let offsets = offsets.get(..n).unwrap_or(&[]);

    let channels = spec.channels;
    let sigma = spec.noise_sigma as f64;
    let mut noise = Rng::stream(spec.seed, NOISE_STREAM, spec.grid.index(row, col) as u64);
    let width = spec.width;
    for (index, pixel) in out.chunks_exact_mut(channels).enumerate() {
        let (i, j) = ((index % width) as f64, (index / width) as f64);
        let radiance = pixel_radiance(&camera, surfaces, prepared, offsets, i, j, u, v);
        for (value, linear) in pixel.iter_mut().zip(radiance) {
            let stored = camera.photometric(linear.clamp(0.0, 1.0)) * 255.0;
            let noisy = if sigma > 0.0 {
                stored + sigma * noise.normal()
            } else {
                stored
            };
            *value = libm::round(noisy.clamp(0.0, 255.0)) as u8;
        }
    }
}

/// Linear radiance of stored pixel `(i, j)`, box-filtered over the pixel.
#[allow(clippy::too_many_arguments)]
fn pixel_radiance(
    camera: &ViewCamera,
    surfaces: &[super::surface::Surface],
    prepared: &[Prepared],
    offsets: &[f64],
    i: f64,
    j: f64,
    u: f64,
    v: f64,
) -> [f64; 3] {
    // Footprint of the pixel in ideal coordinates.
    let footprint = if camera.misaligned {
        let mut b = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        for (dx, dy) in [(-0.5, -0.5), (0.5, -0.5), (-0.5, 0.5), (0.5, 0.5)] {
            let (x, y) = camera.ideal_point(i + dx, j + dy);
            b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
        }
        b
    } else {
        [i - 0.5, j - 0.5, i + 0.5, j + 0.5]
    };
    let mut candidates = [0u8; MAX_SURFACES];
    let mut count = 0;
    for (k, p) in prepared.iter().enumerate() {
        let b = p.geometry.bounds;
        if b[0] <= footprint[2]
            && b[2] >= footprint[0]
            && b[1] <= footprint[3]
            && b[3] >= footprint[1]
        {
            if let Some(c) = candidates.get_mut(count) {
                *c = k as u8;
                count += 1;
            }
        }
    }
    let candidates = candidates.get(..count).unwrap_or(&[]);
    let (ci, cj) = camera.ideal_point(i, j);
    if let [only] = candidates {
        let k = *only as usize;
        if surfaces.get(k).is_some_and(|s| s.is_plane()) {
            return analytic(prepared, k, ci, cj);
        }
    }

    // Visibility per sample: the hit with the largest disparity (nearest) wins.
    const MAX_SAMPLES: usize = MAX_SUPERSAMPLE * MAX_SUPERSAMPLE;
    let mut hits = [(u8::MAX, 0.0f64, 0.0f64); MAX_SAMPLES];
    let mut samples = 0;
    let mut single = true;
    for &oy in offsets {
        for &ox in offsets {
            let (x, y) = camera.ideal_point(i + ox, j + oy);
            let mut best = (u8::MAX, f64::NEG_INFINITY, 0.0, 0.0);
            for &k in candidates {
                let (Some(s), Some(p)) = (surfaces.get(k as usize), prepared.get(k as usize))
                else {
                    continue;
                };
                if let Some((d, sx, sy)) = s.hit(&p.geometry, x, y, u, v) {
                    if d > best.1 {
                        best = (k, d, sx, sy);
                    }
                }
            }
            if let Some(h) = hits.get_mut(samples) {
                *h = (best.0, best.2, best.3);
            }
            if samples > 0 && hits.first().map(|h| h.0) != Some(best.0) {
                single = false;
            }
            samples += 1;
        }
    }
    let hits = hits.get(..samples).unwrap_or(&[]);
    if single {
        if let Some(&(k, _, _)) = hits.first() {
            if surfaces.get(k as usize).is_some_and(|s| s.is_plane()) {
                return analytic(prepared, k as usize, ci, cj);
            }
        }
    }
    let mut sum = [0.0f64; 3];
    for &(k, sx, sy) in hits {
        if let Some(s) = surfaces.get(k as usize) {
            let value = s.texture.at(sx, sy);
            for (a, b) in sum.iter_mut().zip(value) {
                *a += b;
            }
        }
    }
    let inv = 1.0 / samples.max(1) as f64;
    sum.map(|a| a * inv)
}

/// Exact box-filtered radiance of plane `k` for the pixel centred at ideal point `(x, y)`.
#[inline]
fn analytic(prepared: &[Prepared], k: usize, x: f64, y: f64) -> [f64; 3] {
    let Some(p) = prepared.get(k) else {
        return [0.0; 3];
    };
    let mut value = p.base;
    for w in &p.waves {
        let c = libm::cos(w.gx * x + w.gy * y + w.psi);
        for (a, b) in value.iter_mut().zip(w.amplitude) {
            *a += b * c;
        }
    }
    value
}

/// The centre-view ground truth: disparity of the surface seen at each pixel centre.
pub(crate) fn ground_truth(spec: &SynthSpec, scene: &Scene, gt: &mut [f32]) {
    let surfaces = scene.surfaces();
    let mut prepared = [ViewSurface {
        alpha: 0.0,
        beta: 0.0,
        gamma: 0.0,
        bounds: [0.0; 4],
    }; MAX_SURFACES];
    for (p, s) in prepared.iter_mut().zip(surfaces) {
        *p = s.prepare(0.0, 0.0);
    }
    let width = spec.width;
    for (index, value) in gt.iter_mut().enumerate() {
        let (x, y) = ((index % width) as f64, (index / width) as f64);
        let mut best = f64::NEG_INFINITY;
        for (s, p) in surfaces.iter().zip(&prepared) {
            if let Some((d, _, _)) = s.hit(p, x, y, 0.0, 0.0) {
                best = best.max(d);
            }
        }
        *value = best as f32;
    }
}
