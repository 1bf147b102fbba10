//! Rasterisation of one view and of the centre-view ground truth.
//!
//! Each stored pixel is the box filter of the scene's linear radiance over the pixel
//! area, then saturated to `[0, 1]` (the camera's tone curve), photometrically changed,
//! noised and quantised to 8 bits.
//!
//! * Pixels that see a single plane over their whole area (decided geometrically: the
//!   plane's hit region covers the pixel and nothing nearer can reach it; or, failing
//!   that, all `n × n` visibility samples agree) are integrated in closed form: a plane
//!   maps pixels affinely to the surface, and the integral of `cos(g·p + ψ)` over a unit
//!   square is `cos(g·p₀ + ψ)·sinc(gx/2)·sinc(gy/2)`. For misaligned views the footprint
//!   is the homography linearised at the pixel centre.
//! * Pixels wholly on a spherical cap use the same formula with the cap's local affine
//!   map at the pixel centre, where its second-order term stays below 1e-3 px.
//! * Other pixels (occlusion edges, cap rims) average `n × n` point samples
//!   (`n` = `supersample`) on a regular grid.

use super::camera::{ViewCamera, NOISE_STREAM};
use super::light::Lighting;
use super::rng::Rng;
use super::scene::{region, Scene, MAX_SURFACES};
use super::surface::{Quad, Surface, ViewSurface};
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
    /// Amplitude times the box filter's response for a rectified pixel.
    amplitude: [f64; 3],
    /// The texture's amplitude (misaligned pixels apply their own response).
    raw: [f64; 3],
}

/// Everything about one surface that depends on the view.
#[derive(Clone, Copy, Debug)]
struct Prepared {
    geometry: ViewSurface,
    base: [f64; 3],
    waves: [ViewWave; WAVES],
    /// `(cos gx, sin gx)` per wave: the phase step from one pixel to the next in a row.
    steps: [(f64, f64); WAVES],
}

/// Pixels after which a running phasor is recomputed exactly (bounds rounding drift to
/// ~1e-14).
const PHASOR_RUN: u32 = 64;

/// `(cos θ, sin θ)` of every wave of one plane at the pixel `next`, advanced along a row
/// by complex multiplication: one exact evaluation per run instead of one per pixel.
#[derive(Clone, Copy, Debug)]
struct Phasors {
    next: usize,
    run: u32,
    waves: [(f64, f64); WAVES],
}

/// What a pixel sees.
enum Footprint {
    /// Only plane `k`, over the whole pixel: integrate in closed form.
    Plane(usize),
    /// Several surfaces or a cap: the mean of the samples' radiance.
    Mixed([f64; 3]),
}

/// `sin(t)/t`, continuous at 0. Texture frequencies keep |t| ≲ 1 for pixel box filters,
/// where the Taylor series to t¹⁴ is exact to 1e-12.
#[inline]
fn sinc(t: f64) -> f64 {
    if libm::fabs(t) > 1.5 {
        return super::trig::sincos(t).1 / t;
    }
    let t2 = t * t;
    let p = -1.0 / 1_307_674_368_000.0;
    let p = 1.0 / 6_227_020_800.0 + t2 * p;
    let p = -1.0 / 39_916_800.0 + t2 * p;
    let p = 1.0 / 362_880.0 + t2 * p;
    let p = -1.0 / 5_040.0 + t2 * p;
    let p = 1.0 / 120.0 + t2 * p;
    let p = -1.0 / 6.0 + t2 * p;
    1.0 + t2 * p
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
            outline: None,
        },
        base: [0.0; 3],
        waves: [ViewWave::default(); WAVES],
        steps: [(1.0, 0.0); WAVES],
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
        for (w, t) in p.waves.iter_mut().zip(&s.texture.waves) {
            // Surface point p = p' + d(p')·(u, v) with d = alpha + beta·x' + gamma·y'.
            let gx = t.fx * (1.0 + u * beta) + t.fy * v * beta;
            let gy = t.fx * u * gamma + t.fy * (1.0 + v * gamma);
            let psi = t.phase + alpha * (t.fx * u + t.fy * v);
            let response = sinc(gx / 2.0) * sinc(gy / 2.0);
            *w = ViewWave {
                gx,
                gy,
                psi,
                amplitude: t.amplitude.map(|a| a * response),
                raw: t.amplitude,
            };
        }
        for (step, w) in p.steps.iter_mut().zip(&p.waves) {
            *step = super::trig::sincos(w.gx);
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
    // Along a row the phase is linear in x only for rectified views.
    let mut phasors = [Phasors {
        next: usize::MAX,
        run: 0,
        waves: [(1.0, 0.0); WAVES],
    }; MAX_SURFACES];
    let lighting = scene.lighting.as_ref();
    let view = ViewScene {
        camera: &camera,
        u,
        v,
        surfaces,
        prepared,
        lighting,
        offsets,
    };
    for (index, pixel) in out.chunks_exact_mut(channels).enumerate() {
        let (i, j) = ((index % width) as f64, (index / width) as f64);
        let footprint = pixel_radiance(&view, i, j);
        let radiance = match footprint {
            Footprint::Mixed(value) => value,
            Footprint::Plane(k) => {
                let (Some(p), Some(phasor)) = (prepared.get(k), phasors.get_mut(k)) else {
                    continue;
                };
                let (x, y) = camera.ideal_point(i, j);
                let value = if camera.misaligned {
                    analytic_footprint(p, x, y, camera.jacobian_at(i, j))
                } else {
                    running_analytic(p, phasor, index, i, j)
                };
                match lighting {
                    // The gain at the surface point of the pixel centre.
                    Some(light) => {
                        let g = &p.geometry;
                        let d = g.alpha + g.beta * x + g.gamma * y;
                        let gain = light.gain(x + d * u, y + d * v);
                        value.map(|c| c * gain)
                    }
                    None => value,
                }
            }
        };
        let vignette = spec
            .sensor
            .map(|s| s.vignette(i, j, spec.width, spec.height));
        for (value, linear) in pixel.iter_mut().zip(radiance) {
            let stored = camera.photometric(linear.clamp(0.0, 1.0)) * 255.0;
            let noisy = if let (Some(sensor), Some(vignette)) = (spec.sensor, vignette) {
                let signal = stored * vignette;
                let sigma = crate::float::sqrt(sigma * sigma + sensor.variance(signal));
                signal + sigma * noise.normal()
            } else if sigma > 0.0 {
                stored + sigma * noise.normal()
            } else {
                stored
            };
            // Round half up (values are non-negative).
            *value = (noisy.clamp(0.0, 255.0) + 0.5) as u8;
        }
    }
}

/// The scene as one view sees it: its camera, its position `(u, v)` in the grid
/// relative to the centre view, the surfaces and their preparation for the view, the
/// lighting, and the supersampling offsets within a pixel.
struct ViewScene<'a> {
    camera: &'a ViewCamera,
    u: f64,
    v: f64,
    surfaces: &'a [super::surface::Surface],
    prepared: &'a [Prepared],
    lighting: Option<&'a Lighting>,
    offsets: &'a [f64],
}

/// Linear radiance of stored pixel `(i, j)` of `view`, box-filtered over the pixel.
fn pixel_radiance(view: &ViewScene<'_>, i: f64, j: f64) -> Footprint {
    let ViewScene {
        camera,
        u,
        v,
        surfaces,
        prepared,
        lighting,
        offsets,
    } = *view;
    // Footprint of the pixel in ideal coordinates.
    let corners = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)];
    let quad: Quad = corners.map(|(dx, dy)| camera.ideal_point(i + dx, j + dy));
    let mut footprint = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for &(x, y) in &quad {
        footprint = [
            footprint[0].min(x),
            footprint[1].min(y),
            footprint[2].max(x),
            footprint[3].max(y),
        ];
    }
    // Surfaces that may be seen in the pixel, with their disparity range there.
    let mut candidates = [0u8; MAX_SURFACES];
    let mut ranges = [(0.0f64, 0.0f64); MAX_SURFACES];
    let mut count = 0;
    for (k, (s, p)) in surfaces.iter().zip(prepared).enumerate() {
        let b = p.geometry.bounds;
        let overlaps = b[0] <= footprint[2]
            && b[2] >= footprint[0]
            && b[1] <= footprint[3]
            && b[3] >= footprint[1];
        if !overlaps || s.misses(&p.geometry, &quad, u, v) {
            continue;
        }
        if let (Some(c), Some(r)) = (candidates.get_mut(count), ranges.get_mut(count)) {
            *c = k as u8;
            *r = s.disparity_range(&p.geometry, &quad);
            count += 1;
        }
    }
    let candidates = candidates.get(..count).unwrap_or(&[]);
    let ranges = ranges.get(..count).unwrap_or(&[]);
    // A plane covering the pixel and nearer than anything else there is all it shows.
    for (n, (&k, &(lo, _))) in candidates.iter().zip(ranges).enumerate() {
        let Some((s, p)) = surfaces.get(k as usize).zip(prepared.get(k as usize)) else {
            continue;
        };
        let in_front = ranges
            .iter()
            .enumerate()
            .all(|(m, &(_, hi))| m == n || hi < lo);
        if in_front && s.covers(&p.geometry, &quad, u, v) {
            if s.is_plane() {
                return Footprint::Plane(k as usize);
            }
            if let Some(value) = curved_analytic(view, s, &p.geometry, i, j) {
                return Footprint::Mixed(value);
            }
            break;
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
            let (Some(s), Some(p)) = (surfaces.get(k as usize), prepared.get(k as usize)) else {
                return Footprint::Mixed([0.0; 3]);
            };
            if s.is_plane() {
                return Footprint::Plane(k as usize);
            }
            if let Some(value) = curved_analytic(view, s, &p.geometry, i, j) {
                return Footprint::Mixed(value);
            }
        }
    }
    let mut sum = [0.0f64; 3];
    for &(k, sx, sy) in hits {
        if let Some(s) = surfaces.get(k as usize) {
            let gain = lighting.map_or(1.0, |l| l.gain(sx, sy));
            let value = s.texture.at(sx, sy);
            for (a, b) in sum.iter_mut().zip(value) {
                *a += if lighting.is_some() { b * gain } else { b };
            }
        }
    }
    let inv = 1.0 / samples.max(1) as f64;
    Footprint::Mixed(sum.map(|a| a * inv))
}

/// Box-filtered radiance of a plane for a misaligned pixel centred at ideal point
/// `(x, y)` whose footprint has Jacobian `jacobian` (stored → ideal; the homography is
/// linearised over the pixel, a ~1e-5 px approximation for the allowed perspective).
#[inline]
fn analytic_footprint(p: &Prepared, x: f64, y: f64, jacobian: [f64; 4]) -> [f64; 3] {
    let mut value = p.base;
    for w in &p.waves {
        let hx = w.gx * jacobian[0] + w.gy * jacobian[2];
        let hy = w.gx * jacobian[1] + w.gy * jacobian[3];
        let response = sinc(hx / 2.0) * sinc(hy / 2.0);
        let c = super::trig::cos(w.gx * x + w.gy * y + w.psi) * response;
        for (a, b) in value.iter_mut().zip(w.raw) {
            *a += b * c;
        }
    }
    value
}

/// Largest deviation of a curved surface's local view → surface Jacobian from the
/// identity for which a pixel is integrated through its linearisation; steeper parts
/// (near the rim of a cap) are supersampled instead.
const MAX_CURVED_SHEAR: f64 = 0.5;
/// Largest second-order term (surface pixels) of the linearisation over a pixel.
const MAX_CURVED_ERROR: f64 = 1e-3;

/// Box-filtered radiance of a curved surface (a cap) seen over the whole pixel `(i, j)`
/// of `view`, through the local affine approximation of the view → surface map at the
/// pixel centre. `None` (supersample instead) where the neglected second-order term,
/// measured by second differences, could exceed [`MAX_CURVED_ERROR`] over the pixel, or
/// near the rim.
fn curved_analytic(
    view: &ViewScene<'_>,
    surface: &super::surface::Surface,
    geometry: &ViewSurface,
    i: f64,
    j: f64,
) -> Option<[f64; 3]> {
    let ViewScene {
        camera,
        u,
        v,
        lighting,
        ..
    } = *view;
    const STEP: f64 = 0.25;
    let (x, y) = camera.ideal_point(i, j);
    let hit = |dx: f64, dy: f64| surface.hit(geometry, x + dx, y + dy, u, v);
    let (_, cx, cy) = hit(0.0, 0.0)?;
    let (_, rx, ry) = hit(STEP, 0.0)?;
    let (_, lx, ly) = hit(-STEP, 0.0)?;
    let (_, dx, dy) = hit(0.0, STEP)?;
    let (_, ux, uy) = hit(0.0, -STEP)?;
    let map = [
        (rx - lx) / (2.0 * STEP),
        (dx - ux) / (2.0 * STEP),
        (ry - ly) / (2.0 * STEP),
        (dy - uy) / (2.0 * STEP),
    ];
    let shear = libm::fabs(map[0] - 1.0)
        .max(libm::fabs(map[1]))
        .max(libm::fabs(map[2]))
        .max(libm::fabs(map[3] - 1.0));
    // |p''|·(½)²/2 along each axis, from second differences.
    let second = |a: f64, b: f64, centre: f64| libm::fabs(a + b - 2.0 * centre) / (STEP * STEP);
    let curvature = second(rx, lx, cx)
        .max(second(ry, ly, cy))
        .max(second(dx, ux, cx))
        .max(second(dy, uy, cy));
    if shear > MAX_CURVED_SHEAR || curvature * 0.125 > MAX_CURVED_ERROR {
        return None;
    }
    // Stored pixel → surface: the camera footprint, then the surface map.
    let c = camera.jacobian_at(i, j);
    let total = [
        map[0] * c[0] + map[1] * c[2],
        map[0] * c[1] + map[1] * c[3],
        map[2] * c[0] + map[3] * c[2],
        map[2] * c[1] + map[3] * c[3],
    ];
    let mut value = surface.texture.base;
    for w in &surface.texture.waves {
        let gx = w.fx * total[0] + w.fy * total[2];
        let gy = w.fx * total[1] + w.fy * total[3];
        let response = sinc(gx / 2.0) * sinc(gy / 2.0);
        let phase = super::trig::cos(w.fx * cx + w.fy * cy + w.phase);
        for (a, b) in value.iter_mut().zip(w.amplitude) {
            *a += b * response * phase;
        }
    }
    match lighting {
        Some(light) => {
            let gain = light.gain(cx, cy);
            Some(value.map(|c| c * gain))
        }
        None => Some(value),
    }
}

/// Exact box-filtered radiance of a plane at rectified pixel `(i, j)` (linear `index`):
/// `base + Σ amplitude·cos(gx·i + gy·j + ψ)`, continuing the plane's
/// running phasors when the previous pixel of the row used them.
#[inline]
fn running_analytic(p: &Prepared, phasor: &mut Phasors, index: usize, i: f64, j: f64) -> [f64; 3] {
    if phasor.next != index || phasor.run >= PHASOR_RUN || i == 0.0 {
        for (state, w) in phasor.waves.iter_mut().zip(&p.waves) {
            *state = super::trig::sincos(w.gx * i + w.gy * j + w.psi);
        }
        phasor.run = 0;
    }
    let mut value = p.base;
    for ((state, w), step) in phasor.waves.iter_mut().zip(&p.waves).zip(&p.steps) {
        let (c, s) = *state;
        for (a, b) in value.iter_mut().zip(w.amplitude) {
            *a += b * c;
        }
        *state = (c * step.0 - s * step.1, s * step.0 + c * step.1);
    }
    phasor.next = index + 1;
    phasor.run += 1;
    value
}

/// Every surface prepared for the centre view (`u = v = 0`).
fn centre_surfaces(surfaces: &[Surface]) -> [ViewSurface; MAX_SURFACES] {
    let mut prepared = [ViewSurface {
        alpha: 0.0,
        beta: 0.0,
        gamma: 0.0,
        bounds: [0.0; 4],
        outline: None,
    }; MAX_SURFACES];
    for (p, s) in prepared.iter_mut().zip(surfaces) {
        *p = s.prepare(0.0, 0.0);
    }
    prepared
}

/// The disparity and index of the nearest surface (largest disparity; the first of
/// equals) hit at centre-view point `(x, y)`, `None` where no surface is.
fn front_surface(
    surfaces: &[Surface],
    prepared: &[ViewSurface],
    x: f64,
    y: f64,
) -> Option<(f64, usize)> {
    let mut best: Option<(f64, usize)> = None;
    for (k, (s, p)) in surfaces.iter().zip(prepared).enumerate() {
        if let Some((d, _, _)) = s.hit(p, x, y, 0.0, 0.0) {
            if d > best.map_or(f64::NEG_INFINITY, |(b, _)| b) {
                best = Some((d, k));
            }
        }
    }
    best
}

/// The centre-view ground truth: disparity of the surface seen at each pixel centre.
pub(crate) fn ground_truth(spec: &SynthSpec, scene: &Scene, gt: &mut [f32]) {
    let surfaces = scene.surfaces();
    let prepared = centre_surfaces(surfaces);
    let width = spec.width;
    for (index, value) in gt.iter_mut().enumerate() {
        let (x, y) = ((index % width) as f64, (index / width) as f64);
        let best = front_surface(surfaces, &prepared, x, y).map_or(f64::NEG_INFINITY, |(d, _)| d);
        *value = best as f32;
    }
}

/// Radiance below which a lit surface counts as dim (a fifth of full scale).
const DIM_RADIANCE: f64 = 0.2;

/// The region flags of the surface seen at each centre-view pixel centre, plus
/// `region::DIM` where its mean lit base radiance is below [`DIM_RADIANCE`].
pub(crate) fn regions(spec: &SynthSpec, scene: &Scene, out: &mut [u8]) {
    let surfaces = scene.surfaces();
    let prepared = centre_surfaces(surfaces);
    let width = spec.width;
    for (index, value) in out.iter_mut().enumerate() {
        let (x, y) = ((index % width) as f64, (index / width) as f64);
        let front = front_surface(surfaces, &prepared, x, y);
        *value = match front.and_then(|(_, k)| surfaces.get(k).map(|s| (k, s))) {
            Some((k, s)) => {
                let base = s.texture.base;
                let gain = scene.lighting.map_or(1.0, |l| l.gain(x, y));
                let lit = gain * (base[0] + base[1] + base[2]) / 3.0;
                scene.region(k) | if lit < DIM_RADIANCE { region::DIM } else { 0 }
            }
            None => 0,
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sinc_is_accurate_everywhere() {
        let mut t = -6.0;
        while t < 6.0 {
            let exact = if t == 0.0 { 1.0 } else { libm::sin(t) / t };
            assert!((sinc(t) - exact).abs() < 1e-11, "{t}");
            t += 0.001;
        }
        assert_eq!(sinc(0.0), 1.0);
    }
}
