//! Tests of the synthetic renderer against its contract (sign convention, ground truth,
//! sub-pixel agreement, options) — small scenes so they stay fast in debug builds.

extern crate std;

use super::rng::Rng;
use super::scene::Scene;
use super::surface::{Shape, Support, Surface};
use super::texture::Texture;
use super::*;
use std::vec;
use std::vec::Vec;

struct Rendered {
    views: Vec<u8>,
    gt: Vec<f32>,
    homographies: Vec<Homography>,
}

fn render_all(spec: &SynthSpec) -> Rendered {
    let mut views = vec![0u8; spec.layout().validate().unwrap()];
    let mut gt = vec![0.0f32; spec.width * spec.height];
    let mut homographies = vec![Homography::IDENTITY; spec.grid.len()];
    render(spec, &mut views, &mut gt, &mut homographies).unwrap();
    Rendered {
        views,
        gt,
        homographies,
    }
}

fn view<'a>(spec: &SynthSpec, views: &'a [u8], row: usize, col: usize) -> &'a [u8] {
    let len = spec.width * spec.height * spec.channels;
    let start = spec.grid.index(row, col) * len;
    &views[start..start + len]
}

/// Bilinear sample of channel `ch` at `(x, y)`, `None` outside the image.
pub(super) fn bilinear(img: &[u8], spec: &SynthSpec, ch: usize, x: f64, y: f64) -> Option<f64> {
    let (w, h) = (spec.width as f64, spec.height as f64);
    if !(x >= 0.0 && y >= 0.0 && x <= w - 1.0 && y <= h - 1.0) {
        return None;
    }
    let (x0, y0) = (x.floor().min(w - 2.0), y.floor().min(h - 2.0));
    let (fx, fy) = (x - x0, y - y0);
    let at = |xi: f64, yi: f64| {
        img[(yi as usize * spec.width + xi as usize) * spec.channels + ch] as f64
    };
    let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1.0, y0) * fx;
    let bottom = at(x0, y0 + 1.0) * (1.0 - fx) + at(x0 + 1.0, y0 + 1.0) * fx;
    Some(top * (1.0 - fy) + bottom * fy)
}

/// Mean |centre(x, y) − view(x − s·d·u, y − s·d·v)| over centre pixels whose 5×5 gt
/// neighbourhood is smooth (away from occlusion edges), for sign `s`.
fn warp_error(spec: &SynthSpec, r: &Rendered, row: usize, col: usize, sign: f64) -> f64 {
    let (r0, c0) = spec.grid.center();
    let (u, v) = (col as f64 - c0 as f64, row as f64 - r0 as f64);
    let centre = view(spec, &r.views, r0, c0);
    let other = view(spec, &r.views, row, col);
    let (mut sum, mut n) = (0.0, 0usize);
    for y in 2..spec.height - 2 {
        for x in 2..spec.width - 2 {
            let d = r.gt[y * spec.width + x];
            let flat = (0..25).all(|k| {
                let (xx, yy) = (x + k % 5 - 2, y + k / 5 - 2);
                (r.gt[yy * spec.width + xx] - d).abs() < 0.1
            });
            if !flat {
                continue;
            }
            let d = d as f64;
            for ch in 0..spec.channels {
                let (sx, sy) = (x as f64 - sign * d * u, y as f64 - sign * d * v);
                if let Some(value) = bilinear(other, spec, ch, sx, sy) {
                    sum += (value - centre[(y * spec.width + x) * spec.channels + ch] as f64).abs();
                    n += 1;
                }
            }
        }
    }
    assert!(n > 100, "too few comparable pixels: {n}");
    sum / n as f64
}

pub(super) fn small(scene: SceneKind) -> SynthSpec {
    SynthSpec::new(scene, Grid::new(9, 9), 64, 64)
}

#[test]
fn names_round_trip() {
    for kind in SceneKind::ALL {
        assert_eq!(SceneKind::from_name(kind.name()), Some(kind));
    }
    assert_eq!(
        SceneKind::from_name("Low_Texture"),
        Some(SceneKind::LowTexture)
    );
    assert_eq!(
        SceneKind::from_name("lowtexture"),
        Some(SceneKind::LowTexture)
    );
    assert_eq!(SceneKind::from_name("sphere"), None);
}

#[test]
fn ground_truth_stays_in_range_and_spans_it() {
    for kind in SceneKind::ALL {
        for (grid, min, max) in [
            (Grid::new(9, 9), -1.5f32, 1.5f32),
            (Grid::new(4, 6), -4.0, 4.0),
            (Grid::new(17, 3), 0.5, 0.75),
        ] {
            let mut spec = SynthSpec::new(kind, grid, 48, 40);
            spec.disparity_min = min;
            spec.disparity_max = max;
            spec.seed = 11;
            let mut gt = vec![0.0f32; 48 * 40];
            render_ground_truth(&spec, &mut gt).unwrap();
            let lo = gt.iter().cloned().fold(f32::INFINITY, f32::min);
            let hi = gt.iter().cloned().fold(f32::NEG_INFINITY, f32::max);
            assert!(lo >= min && hi <= max, "{kind:?} {lo} {hi}");
            // At least a third of the range is present in every scene.
            assert!(
                hi - lo >= (max - min) / 3.0,
                "{kind:?} spans only {lo}..{hi}"
            );
        }
    }
}

#[test]
fn same_seed_same_bytes_other_seed_other_bytes() {
    let mut spec = small(SceneKind::Mixed);
    spec.noise_sigma = 2.0;
    spec.photometric = 0.05;
    spec.grid = Grid::new(3, 3);
    let a = render_all(&spec);
    let b = render_all(&spec);
    assert_eq!(a.views, b.views);
    assert_eq!(a.gt, b.gt);
    spec.seed = 1;
    let c = render_all(&spec);
    assert_ne!(a.views, c.views);
    assert_ne!(a.gt, c.gt);
    // Streaming one view gives the bytes of the full render.
    let mut one = vec![0u8; 64 * 64 * 3];
    render_view(&spec, 2, 1, &mut one).unwrap();
    assert_eq!(&one[..], view(&spec, &c.views, 2, 1));
}

#[test]
fn views_follow_the_hci_sign_convention() {
    for kind in [SceneKind::Planes, SceneKind::Slanted, SceneKind::Spheres] {
        let spec = small(kind);
        let r = render_all(&spec);
        for (row, col) in [(4, 8), (0, 4), (1, 6)] {
            let right = warp_error(&spec, &r, row, col, 1.0);
            let wrong = warp_error(&spec, &r, row, col, -1.0);
            std::eprintln!(
                "{kind:?} view ({row},{col}) warped to the centre with the gt: mean |diff| \
                 {right:.2} levels (bilinear; occlusions included), opposite sign {wrong:.2}"
            );
            assert!(
                right < 6.0 && wrong > 5.0 * right,
                "{kind:?} ({row},{col}): {right} vs {wrong}"
            );
        }
    }
}

#[test]
fn even_and_odd_grids_render() {
    for grid in [Grid::new(4, 4), Grid::new(3, 8), Grid::new(6, 5)] {
        let mut spec = small(SceneKind::Planes);
        spec.grid = grid;
        spec.channels = 1;
        let r = render_all(&spec);
        assert_eq!(r.views.len(), grid.len() * 64 * 64);
        let right = warp_error(&spec, &r, grid.rows - 1, grid.cols - 1, 1.0);
        let wrong = warp_error(&spec, &r, grid.rows - 1, grid.cols - 1, -1.0);
        assert!(
            right < 6.0 && wrong > 5.0 * right,
            "{grid:?}: {right} vs {wrong}"
        );
        assert!(r.homographies.iter().all(|h| *h == Homography::IDENTITY));
    }
}

/// Agreement statistics of rendered pixels with the reference, in 8-bit levels.
#[derive(Debug, Default)]
struct Agreement {
    /// Pixels whose every reference sample sees the same surface.
    interior: (f64, f64, usize),
    /// Pixels straddling an occlusion edge.
    edge: (f64, f64, usize),
    /// Mean |gradient| of the reference over interior pixels, levels/px.
    gradient: f64,
}

impl Agreement {
    fn mean(part: (f64, f64, usize)) -> f64 {
        part.0 / part.2.max(1) as f64
    }
}

/// Renders views of `surfaces` through the production path and compares them with an
/// independent brute-force reference: per pixel, the mean over 12×12 sub-samples (mapped
/// to ideal coordinates for misaligned views) of the texture at the exact ray hit of the
/// nearest surface (no closed forms), before 8-bit rounding.
fn agreement(surfaces: &[Surface], spec: &SynthSpec, views: &[(usize, usize)]) -> Agreement {
    const K: usize = 12;
    let scene = Scene::from_surfaces(surfaces);
    let (w, h, ch) = (spec.width, spec.height, spec.channels);
    let (r0, c0) = spec.grid.center();
    let mut out = vec![0u8; w * h * ch];
    let mut result = Agreement::default();
    let mut gradient = (0.0f64, 0usize);
    for &(row, col) in views {
        let (u, v) = (col as f64 - c0 as f64, row as f64 - r0 as f64);
        super::raster::render_view(spec, &scene, row, col, &mut out);
        let prepared: Vec<_> = surfaces.iter().map(|s| s.prepare(u, v)).collect();
        let camera = super::camera::ViewCamera::new(spec, row, col);
        let mut reference = vec![0.0f64; w * h * ch];
        let mut interior = vec![true; w * h];
        for y in 0..h {
            for x in 0..w {
                let mut acc = [0.0; 3];
                let mut first = None;
                for sy in 0..K {
                    for sx in 0..K {
                        let (px, py) = camera.ideal_point(
                            x as f64 + (sx as f64 + 0.5) / K as f64 - 0.5,
                            y as f64 + (sy as f64 + 0.5) / K as f64 - 0.5,
                        );
                        let mut best = (usize::MAX, f64::NEG_INFINITY, 0.0, 0.0);
                        for (k, (s, p)) in surfaces.iter().zip(&prepared).enumerate() {
                            if let Some((d, tx, ty)) = s.hit(p, px, py, u, v) {
                                if d > best.1 {
                                    best = (k, d, tx, ty);
                                }
                            }
                        }
                        if *first.get_or_insert(best.0) != best.0 {
                            interior[y * w + x] = false;
                        }
                        let value = surfaces[best.0].texture.at(best.2, best.3);
                        for c in 0..3 {
                            acc[c] += value[c];
                        }
                    }
                }
                for c in 0..ch {
                    let expected = (acc[c] / (K * K) as f64).clamp(0.0, 1.0) * 255.0;
                    reference[(y * w + x) * ch + c] = expected;
                    let diff = (out[(y * w + x) * ch + c] as f64 - expected).abs();
                    let part = if interior[y * w + x] {
                        &mut result.interior
                    } else {
                        &mut result.edge
                    };
                    part.0 += diff;
                    part.1 = part.1.max(diff);
                    part.2 += 1;
                }
            }
        }
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                let flat = (0..9).all(|k| interior[(y + k / 3 - 1) * w + x + k % 3 - 1]);
                for c in 0..ch {
                    let at = |xx: usize, yy: usize| reference[(yy * w + xx) * ch + c];
                    let gx = (at(x + 1, y) - at(x - 1, y)) / 2.0;
                    let gy = (at(x, y + 1) - at(x, y - 1)) / 2.0;
                    if flat {
                        gradient.0 += (gx * gx + gy * gy).sqrt();
                        gradient.1 += 1;
                    }
                }
            }
        }
    }
    result.gradient = gradient.0 / gradient.1.max(1) as f64;
    result
}

fn textured(shape: Shape, seed: u64) -> Surface {
    let mut rng = Rng::stream(seed, 0, 0);
    Surface {
        shape,
        texture: Texture::random(&mut rng, 0.15, false),
    }
}

/// Sub-pixel agreement of rendered views with the exact shifted texture (documented in
/// the module docs): inside planes the only error left is the 8-bit rounding.
#[test]
fn subpixel_agreement_of_a_translating_plane() {
    let fronto = Shape::Plane {
        a: 0.37,
        b: 0.0,
        c: 0.0,
        support: Support::All,
    };
    let slanted = Shape::Plane {
        a: 0.2,
        b: 0.011,
        c: -0.007,
        support: Support::All,
    };
    let views = [(4, 5), (0, 0), (8, 3)];
    for (name, plane, supersample) in [("fronto d=0.37", fronto, 3), ("slanted", slanted, 1)] {
        let mut spec = small(SceneKind::Planes);
        spec.supersample = supersample;
        let a = agreement(&[textured(plane, 5)], &spec, &views);
        let (mean, max) = (Agreement::mean(a.interior), a.interior.1);
        std::eprintln!(
            "{name}, supersample {supersample}: mean |diff| {mean:.4} levels, max {max:.4}, \
             mean gradient {:.2} levels/px -> {:.5} px",
            a.gradient,
            mean / a.gradient
        );
        assert_eq!(a.edge.2, 0);
        assert!(mean < 0.27 && max < 0.52, "{name}: {mean} {max}");
    }
}

/// Caps (linearised per pixel) and occlusion edges (supersampled) against the reference.
#[test]
fn subpixel_agreement_of_caps_and_edges() {
    let background = Shape::Plane {
        a: -1.0,
        b: 0.0,
        c: 0.0,
        support: Support::All,
    };
    let cap = Shape::Cap {
        cx: 30.0,
        cy: 34.0,
        radius: 24.0,
        base: -0.5,
        height: 1.8,
    };
    let rect = Shape::Plane {
        a: 1.2,
        b: 0.0,
        c: 0.0,
        support: Support::Rect {
            cx: 40.0,
            cy: 20.0,
            cos: libm::cos(0.3),
            sin: libm::sin(0.3),
            half_length: 12.0,
            half_width: 1.0,
        },
    };
    let surfaces = [textured(background, 1), textured(cap, 2), textured(rect, 3)];
    let views = [(4, 4), (4, 7), (1, 2)];
    let mut previous_edge = f64::INFINITY;
    for supersample in [3, 6] {
        let mut spec = small(SceneKind::Mixed);
        spec.supersample = supersample;
        let a = agreement(&surfaces, &spec, &views);
        let (interior, edge) = (Agreement::mean(a.interior), Agreement::mean(a.edge));
        std::eprintln!(
            "cap + bar, supersample {supersample}: interior mean {interior:.4} max {:.4} \
             ({} px), edge mean {edge:.4} max {:.4} ({} px)",
            a.interior.1,
            a.interior.2,
            a.edge.1,
            a.edge.2
        );
        assert!(interior < 0.3 && a.interior.1 < 1.6, "{a:?}");
        // Edge pixels converge to the area-weighted mix as the sampling gets finer.
        assert!(edge < 3.0 && edge < previous_edge, "{a:?}");
        previous_edge = edge;
    }
}

/// Misaligned views: the box filter through the homography agrees with the reference.
#[test]
fn subpixel_agreement_of_misaligned_views() {
    let plane = Shape::Plane {
        a: 0.6,
        b: 0.008,
        c: 0.004,
        support: Support::All,
    };
    let mut spec = small(SceneKind::Planes);
    spec.misalign = Some(Misalignment {
        max_rotation_deg: 5.0,
        max_translation_px: 4.0,
        max_scale: 0.1,
        max_perspective: 0.05,
    });
    let a = agreement(&[textured(plane, 9)], &spec, &[(0, 1), (7, 8)]);
    let (mean, max) = (Agreement::mean(a.interior), a.interior.1);
    std::eprintln!("misaligned plane: mean |diff| {mean:.4} levels, max {max:.4}");
    assert!(mean < 0.27 && max < 0.52, "{a:?}");
}

#[test]
fn bad_specs_are_errors() {
    let ok = small(SceneKind::Planes);
    assert_eq!(ok.validate(), Ok(()));
    type Breaker = fn(&mut SynthSpec);
    let cases: [(Breaker, &str); 14] = [
        (|s| s.grid = Grid::new(2, 9), "grid"),
        (|s| s.grid = Grid::new(9, 18), "grid"),
        (|s| s.width = 15, "size"),
        (|s| s.channels = 4, "channels"),
        (|s| s.channels = 0, "channels"),
        (|s| s.disparity_min = f32::NAN, "nan"),
        (|s| s.disparity_max = f32::INFINITY, "inf"),
        (|s| s.disparity_min = -4.5, "range"),
        (|s| s.disparity_max = s.disparity_min, "order"),
        (|s| s.noise_sigma = -1.0, "noise"),
        (|s| s.photometric = 0.9, "photometric"),
        (|s| s.supersample = 0, "supersample"),
        (|s| s.supersample = MAX_SUPERSAMPLE + 1, "supersample"),
        (
            |s| {
                s.misalign = Some(Misalignment {
                    max_rotation_deg: 1.0,
                    max_translation_px: f32::NAN,
                    max_scale: 0.0,
                    max_perspective: 0.0,
                })
            },
            "misalign",
        ),
    ];
    for (break_it, what) in cases {
        let mut spec = ok;
        break_it(&mut spec);
        assert!(spec.validate().is_err(), "{what}");
        let mut gt = vec![0.0f32; 64 * 64];
        assert!(render_ground_truth(&spec, &mut gt).is_err(), "{what}");
    }
    let huge = SynthSpec::new(
        SceneKind::Planes,
        Grid::new(17, 17),
        usize::MAX / 4,
        1 << 40,
    );
    assert!(matches!(huge.validate(), Err(Error::SizeOverflow { .. })));
    // Output sizes.
    let mut views = vec![0u8; ok.layout().validate().unwrap()];
    let mut gt = vec![0.0f32; 64 * 64];
    let mut hs = vec![Homography::IDENTITY; 81];
    assert!(matches!(
        render(&ok, &mut views[1..], &mut gt, &mut hs),
        Err(Error::BufferTooSmall { .. })
    ));
    assert!(matches!(
        render(&ok, &mut views, &mut gt[1..], &mut hs),
        Err(Error::OutputSize { .. })
    ));
    assert!(matches!(
        render(&ok, &mut views, &mut gt, &mut hs[1..]),
        Err(Error::BufferTooSmall { .. })
    ));
    let mut one = vec![0u8; 64 * 64 * 3];
    assert!(matches!(
        render_view(&ok, 9, 0, &mut one),
        Err(Error::OutOfRange { .. })
    ));
    assert!(matches!(
        render_view(&ok, 0, 0, &mut one[1..]),
        Err(Error::BufferTooSmall { .. })
    ));
    assert!(view_homography(&ok, 0, 9).is_err());
}

#[test]
fn noise_has_the_requested_sigma() {
    let mut spec = small(SceneKind::LowTexture);
    spec.grid = Grid::new(3, 3);
    let clean = render_all(&spec);
    spec.noise_sigma = 4.0;
    let noisy = render_all(&spec);
    assert_eq!(clean.gt, noisy.gt);
    // Mid-gray low-texture scene: no clipping, so the difference is the noise (+ rounding).
    let diffs: Vec<f64> = clean
        .views
        .iter()
        .zip(&noisy.views)
        .map(|(&a, &b)| b as f64 - a as f64)
        .collect();
    let n = diffs.len() as f64;
    let mean = diffs.iter().sum::<f64>() / n;
    let std = (diffs.iter().map(|d| (d - mean) * (d - mean)).sum::<f64>() / n).sqrt();
    assert!(
        mean.abs() < 0.1 && (std - 4.0).abs() < 0.3,
        "mean {mean} std {std}"
    );
}

#[test]
fn photometric_changes_only_the_other_views() {
    let mut spec = small(SceneKind::Planes);
    spec.grid = Grid::new(3, 3);
    let clean = render_all(&spec);
    spec.photometric = 0.2;
    let changed = render_all(&spec);
    assert_eq!(
        view(&spec, &clean.views, 1, 1),
        view(&spec, &changed.views, 1, 1)
    );
    let mut differing = 0;
    for (row, col) in [(0, 0), (0, 2), (2, 1), (1, 0)] {
        let (a, b) = (
            view(&spec, &clean.views, row, col),
            view(&spec, &changed.views, row, col),
        );
        let mean = |v: &[u8]| v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64;
        let ratio = mean(b) / mean(a);
        assert!((0.75..=1.25).contains(&ratio), "{ratio}");
        if a != b {
            differing += 1;
        }
    }
    assert!(differing >= 3);
}

#[test]
fn misaligned_views_are_the_ideal_views_warped_by_the_returned_homographies() {
    let mut spec = small(SceneKind::Planes);
    spec.grid = Grid::new(3, 3);
    let ideal = render_all(&spec);
    spec.misalign = Some(Misalignment {
        max_rotation_deg: 2.0,
        max_translation_px: 3.0,
        max_scale: 0.02,
        max_perspective: 0.01,
    });
    let moved = render_all(&spec);
    assert_eq!(ideal.gt, moved.gt);
    assert_eq!(moved.homographies[4], Homography::IDENTITY);
    assert_eq!(
        view(&spec, &ideal.views, 1, 1),
        view(&spec, &moved.views, 1, 1)
    );
    for (row, col) in [(0, 0), (1, 2), (2, 1)] {
        let h = moved.homographies[spec.grid.index(row, col)];
        assert_ne!(h, Homography::IDENTITY);
        assert_eq!(h, view_homography(&spec, row, col).unwrap());
        let (a, b) = (
            view(&spec, &ideal.views, row, col),
            view(&spec, &moved.views, row, col),
        );
        // stored(H·p) = ideal(p): compare with H and, as a control, without it.
        let mut err = [0.0f64; 2];
        let mut n = 0;
        for y in 8..56 {
            for x in 8..56 {
                let (qx, qy) = h.apply(x as f32, y as f32).unwrap();
                let warped = bilinear(b, &spec, 1, qx as f64, qy as f64);
                let unwarped = bilinear(b, &spec, 1, x as f64, y as f64);
                if let (Some(w), Some(u)) = (warped, unwarped) {
                    let truth = a[(y * 64 + x) * 3 + 1] as f64;
                    err[0] += (w - truth).abs();
                    err[1] += (u - truth).abs();
                    n += 1;
                }
            }
        }
        let (with_h, without_h) = (err[0] / n as f64, err[1] / n as f64);
        std::eprintln!(
            "misaligned view ({row},{col}): |stored(H·p) − ideal(p)| {with_h:.2} levels \
             (bilinear), without H {without_h:.2}"
        );
        assert!(
            with_h < 4.0 && without_h > 3.0 * with_h,
            "{with_h} vs {without_h}"
        );
    }
}

#[test]
fn gray_views_are_gray() {
    let mut spec = small(SceneKind::Mixed);
    spec.channels = 1;
    spec.grid = Grid::new(3, 3);
    let r = render_all(&spec);
    assert_eq!(r.views.len(), 9 * 64 * 64);
    let max = *r.views.iter().max().unwrap();
    let min = *r.views.iter().min().unwrap();
    assert!(max - min > 150, "contrast {min}..{max}");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(48))]
    /// Any spec either renders (small ones only, to stay fast) or is rejected; never a
    /// panic, and the gt always lies in the requested range.
    #[test]
    fn random_specs_never_panic(
        kind in 0usize..7,
        rows in 0usize..20,
        cols in 0usize..20,
        width in 0usize..40,
        height in 0usize..40,
        channels in 0usize..5,
        dmin in -6.0f32..6.0,
        dmax in -6.0f32..6.0,
        noise in -1.0f32..70.0,
        photometric in -0.1f32..0.6,
        misalign in proptest::option::of((0.0f32..12.0, 0.0f32..70.0, 0.0f32..0.3, 0.0f32..0.06)),
        seed in proptest::prelude::any::<u64>(),
        supersample in 0usize..10,
    ) {
        let mut spec = SynthSpec::new(SceneKind::ALL[kind], Grid::new(rows, cols), width, height);
        spec.channels = channels;
        spec.disparity_min = dmin;
        spec.disparity_max = dmax;
        spec.noise_sigma = noise;
        spec.photometric = photometric;
        spec.misalign = misalign.map(|(r, t, s, p)| Misalignment {
            max_rotation_deg: r,
            max_translation_px: t,
            max_scale: s,
            max_perspective: p,
        });
        spec.seed = seed;
        spec.supersample = supersample;
        let mut gt = vec![0.0f32; width * height];
        match render_ground_truth(&spec, &mut gt) {
            Err(_) => proptest::prop_assert!(spec.validate().is_err()),
            Ok(()) => {
                proptest::prop_assert!(gt.iter().all(|&d| d >= dmin && d <= dmax));
                let mut out = vec![0u8; width * height * channels];
                render_view(&spec, rows - 1, 0, &mut out).unwrap();
            }
        }
    }
}
