//! Equality, bit for bit, with the reference on random maps and guides, over bands and
//! passes.

use super::reference::{reference_pass, reference_passes, same};
use super::*;

/// A small xorshift generator: the tests are reproducible without a dependency.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
}

const MAX_SIDE: usize = 40;

/// A random side from the smallest a stage takes to `MAX_SIDE`.
fn side(rng: &mut Rng) -> usize {
    let min = crate::lightfield::VIEW_MIN;
    min + rng.below(MAX_SIDE - min + 1)
}

/// A disparity map of slanted regions split by a few straight depth edges, fattened or
/// not against the guide's colour edges, with noise, quantised ties and non-finite
/// values; and a guide whose colour edges follow the true depth edges.
struct Scene {
    map: [f32; MAX_SIDE * MAX_SIDE],
    colours: [u8; 4 * MAX_SIDE * MAX_SIDE],
}

fn scene(rng: &mut Rng, width: usize, height: usize, channels: usize) -> Scene {
    let mut map = [0.0f32; MAX_SIDE * MAX_SIDE];
    let mut colours = [0u8; 4 * MAX_SIDE * MAX_SIDE];
    // Up to three edges a·x + b·y = c; each region (side pattern) gets a plane and a colour.
    let edges = 1 + rng.below(3);
    let mut lines = [(0.0f32, 0.0f32, 0.0f32); 3];
    for line in lines.iter_mut().take(edges) {
        let angle = rng.unit() * core::f32::consts::PI;
        let (a, b) = (libm::cosf(angle), libm::sinf(angle));
        let c = a * rng.unit() * width as f32 + b * rng.unit() * height as f32;
        *line = (a, b, c);
    }
    let fatten = rng.below(4) as f32;
    let noise = [0.0, 0.002, 0.05][rng.below(3)];
    let colour_noise = rng.below(12) as i32;
    let quantum = [0.0, 0.25, 0.01][rng.below(3)];
    let mut planes = [(0.0f32, 0.0f32, 0.0f32); 8];
    let mut tints = [[0u8; 4]; 8];
    for (plane, tint) in planes.iter_mut().zip(tints.iter_mut()) {
        let slant = [0.0, 0.02, 0.3][rng.below(3)];
        *plane = (
            rng.unit() * 3.0 - 1.5,
            (rng.unit() - 0.5) * slant,
            (rng.unit() - 0.5) * slant,
        );
        for t in tint.iter_mut() {
            *t = rng.below(256) as u8;
        }
    }
    let region = |x: f32, y: f32, shift: f32| {
        let mut index = 0;
        for (k, (a, b, c)) in lines.iter().take(edges).enumerate() {
            if a * x + b * y > c + shift {
                index |= 1 << k;
            }
        }
        index
    };
    for y in 0..height {
        for x in 0..width {
            let (fx, fy) = (x as f32, y as f32);
            // The map's edges sit `fatten` pixels off the colour edges.
            let (d0, dx, dy) = planes[region(fx, fy, -fatten)];
            let mut d = d0 + dx * fx + dy * fy + (rng.unit() - 0.5) * noise;
            if quantum > 0.0 {
                d = libm::roundf(d / quantum) * quantum;
            }
            d = match rng.below(200) {
                0 => f32::NAN,
                1 => f32::INFINITY,
                2 => f32::NEG_INFINITY,
                3 => -0.0,
                _ => d,
            };
            map[y * width + x] = d;
            let tint = tints[region(fx, fy, 0.0)];
            for k in 0..channels {
                let jitter = rng.below(2 * colour_noise as usize + 1) as i32 - colour_noise;
                colours[(y * width + x) * channels + k] =
                    (i32::from(tint[k]) + jitter).clamp(0, 255) as u8;
            }
        }
    }
    Scene { map, colours }
}

fn random_params(rng: &mut Rng) -> MedianParams {
    MedianParams {
        radius: 1 + rng.below(MAX_RADIUS),
        color_sigma: [0.005, 0.02, 0.04, 0.1, 0.5][rng.below(5)],
        gate: [0.0, 0.05, 0.2, 1.0][rng.below(4)],
        snap: [0.0, 0.05, 0.2, 1.0][rng.below(4)],
        planar: rng.below(3) != 0,
        thin: [0.0, 1.0, 2.5, 4.0, 16.0][rng.below(5)],
        ..MedianParams::default()
    }
}

/// One random case: its sides and a [`scene`] whose guide has `channels` channels.
struct Case {
    w: usize,
    h: usize,
    channels: usize,
    scene: Scene,
}

/// Draws a [`Case`]: the sides, the guide's channels (`channels`), then the scene.
fn case_with(rng: &mut Rng, channels: impl FnOnce(&mut Rng) -> usize) -> Case {
    let (w, h) = (side(rng), side(rng));
    let channels = channels(rng);
    Case {
        w,
        h,
        channels,
        scene: scene(rng, w, h, channels),
    }
}

/// A [`Case`] whose guide has 1, 3 or 4 channels.
fn random_case(rng: &mut Rng) -> Case {
    case_with(rng, |rng| [1, 3, 4][rng.below(3)])
}

impl Case {
    fn pixels(&self) -> usize {
        self.w * self.h
    }

    /// The scene's disparity map.
    fn map(&self) -> &[f32] {
        &self.scene.map[..self.pixels()]
    }

    /// The scene's colours as the guide.
    fn guide(&self) -> View<'_, u8> {
        let (w, h, channels) = (self.w, self.h, self.channels);
        View::new(
            &self.scene.colours[..w * h * channels],
            w,
            h,
            channels,
            w * channels,
        )
        .unwrap()
    }

    /// The median stage with `params` on a map of the case's sides.
    fn stage(&self, params: MedianParams) -> TestSetup<MedianParams> {
        stage_for(self.w, self.h, params)
    }
}

/// `filter_rows` over the whole map and in random bands, checked bit for bit against
/// the reference (a median of zero of either sign: [`same`]); returns how many pixels
/// the median moved.
fn check_against_reference<S: Sample>(
    rng: &mut Rng,
    stage: Setup<'_, MedianParams>,
    guide: &View<'_, S>,
    map: &[f32],
    trial: usize,
) -> usize {
    let (w, h) = (stage.layout().width, stage.layout().height);
    let pixels = w * h;
    let mut scratch = vec![0.0f32; scratch_len(stage)];
    let scratch = &mut scratch[..];
    let expected = reference_pass(stage.params(), guide, map);
    let mut got = [0.0f32; MAX_SIDE * MAX_SIDE];
    filter(stage, guide, map, &mut got[..pixels], scratch).unwrap();
    let mut banded = [0.0f32; MAX_SIDE * MAX_SIDE];
    let mut start = 0;
    while start < h {
        let end = (start + 1 + rng.below(h)).min(h);
        // Scratch left over from another call must not matter.
        scratch.fill(f32::NAN);
        filter_rows(
            stage,
            guide,
            map,
            start..end,
            &mut banded[start * w..end * w],
            scratch,
        )
        .unwrap();
        start = end;
    }
    for i in 0..pixels {
        let (x, y) = (i % w, i / w);
        assert!(
            same(got[i], expected[i]),
            "trial {trial}, ({x}, {y}): {} vs reference {}",
            got[i],
            expected[i]
        );
        assert!(
            same(banded[i], expected[i]),
            "trial {trial}, banded ({x}, {y}): {} vs reference {}",
            banded[i],
            expected[i]
        );
    }
    (0..pixels)
        .filter(|&i| expected[i].to_bits() != map[i].to_bits())
        .count()
}

#[test]
fn equals_the_reference_bit_for_bit_on_random_scenes() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let mut moved = 0;
    for trial in 0..60 {
        let case = random_case(&mut rng);
        let stage = case.stage(random_params(&mut rng));
        moved += check_against_reference(&mut rng, stage.setup(), &case.guide(), case.map(), trial);
    }
    // The comparison means something only if the selection ran and moved pixels.
    assert!(moved > 200, "only {moved} pixels moved");
}

#[test]
fn equals_the_reference_with_a_float_guide() {
    let mut rng = Rng(0x0123_4567_89AB_CDEF);
    let mut moved = 0;
    for trial in 0..20 {
        let case = case_with(&mut rng, |_| 3);
        let (w, h) = (case.w, case.h);
        let mut colours = [0.0f32; 3 * MAX_SIDE * MAX_SIDE];
        for (c, &level) in colours.iter_mut().zip(&case.scene.colours[..3 * w * h]) {
            // Levels beyond [0, 1] and NaN clamp to the ends.
            *c = match rng.below(100) {
                0 => f32::NAN,
                1 => 1.5,
                2 => -0.5,
                _ => f32::from(level) / 255.0 + (rng.unit() - 0.5) / 255.0,
            };
        }
        let stage = case.stage(random_params(&mut rng));
        let guide = View::new(&colours[..3 * w * h], w, h, 3, 3 * w).unwrap();
        moved += check_against_reference(&mut rng, stage.setup(), &guide, case.map(), trial);
    }
    assert!(moved > 50, "only {moved} pixels moved");
}

/// Every pass of [`filter_band`] over random bands, with and without the settled
/// bytes, equals the reference's passes one after the other over the whole map.
#[test]
fn every_pass_of_a_band_equals_the_reference_passes() {
    let mut rng = Rng(0x6A09_E667_F3BC_C908);
    let mut moved = 0;
    for trial in 0..24 {
        let case = random_case(&mut rng);
        let params = MedianParams {
            passes: 1 + rng.below(MAX_PASSES),
            ..random_params(&mut rng)
        };
        let stage = case.stage(params);
        let (guide, map) = (case.guide(), case.map());
        let (w, h, pixels) = (case.w, case.h, case.pixels());
        let expected = reference_passes(stage.setup().params(), &guide, map);
        moved += (0..pixels)
            .filter(|&i| expected[i].to_bits() != map[i].to_bits())
            .count();
        let mut maps = vec![f32::NAN; band_scratch_len(stage.setup())];
        for remember in [false, true] {
            let mut settled = vec![7u8; if remember { pixels } else { 0 }];
            let mut got = vec![0.0f32; pixels];
            let mut start = 0;
            while start < h {
                let end = (start + 1 + rng.below(h)).min(h);
                filter_band(
                    stage.setup(),
                    &guide,
                    map,
                    start..end,
                    &mut got[start * w..end * w],
                    &mut maps,
                    &mut settled,
                )
                .unwrap();
                start = end;
            }
            for i in 0..pixels {
                assert!(
                    same(got[i], expected[i]),
                    "trial {trial} ({} passes, settled bytes {remember}), ({}, {}): {} vs reference {}",
                    params.passes,
                    i % w,
                    i / w,
                    got[i],
                    expected[i]
                );
            }
        }
    }
    assert!(moved > 100, "only {moved} pixels moved");
}

#[test]
fn later_passes_skip_unchanged_windows_with_the_same_result() {
    let mut rng = Rng(0x5DEE_CE66_D1CE_4E5B);
    let mut skipped_some = 0;
    for trial in 0..30 {
        let case = random_case(&mut rng);
        let stage = case.stage(random_params(&mut rng));
        let guide = case.guide();
        let (w, h, pixels) = (case.w, case.h, case.pixels());
        let mut scratch = vec![0.0f32; scratch_len(stage.setup())];
        let mut previous = case.map().to_vec();
        let mut input = vec![0.0f32; pixels];
        filter(stage.setup(), &guide, &previous, &mut input, &mut scratch).unwrap();
        for pass in 1..4 {
            let mut expected = vec![0.0f32; pixels];
            filter(stage.setup(), &guide, &input, &mut expected, &mut scratch).unwrap();
            let mut got = vec![0.0f32; pixels];
            let mut start = 0;
            while start < h {
                let end = (start + 1 + rng.below(h)).min(h);
                scratch.fill(f32::NAN);
                filter_rows_again(
                    stage.setup(),
                    &guide,
                    &input,
                    &previous,
                    start..end,
                    &mut got[start * w..end * w],
                    &mut scratch,
                )
                .unwrap();
                start = end;
            }
            for i in 0..pixels {
                assert_eq!(
                    got[i].to_bits(),
                    expected[i].to_bits(),
                    "trial {trial}, pass {pass}, ({}, {})",
                    i % w,
                    i / w
                );
            }
            if input != previous {
                skipped_some += 1;
            }
            previous = core::mem::replace(&mut input, expected);
        }
    }
    assert!(
        skipped_some > 10,
        "too few passes where something moved: {skipped_some}"
    );
    let stage = stage_for(16, 16, MedianParams::default());
    let views = [0u8; 256];
    let guide = View::new(&views, 16, 16, 1, 16).unwrap();
    let mut out = [0.0f32; 256];
    assert!(matches!(
        filter_rows_again(
            stage.setup(),
            &guide,
            &[0.0; 256],
            &[0.0; 255],
            0..16,
            &mut out,
            &mut vec![0.0; scratch_len(stage.setup())]
        ),
        Err(Error::OutputSize { .. })
    ));
}

/// [`filter_pass`] over four passes in random bands (a new banding each pass, scratch
/// and the first pass's `settled` bytes garbage) equals full passes of [`filter`] bit
/// for bit, while pixels settled by their quarter rows are kept without a decision.
#[test]
fn passes_that_remember_settled_pixels_equal_full_passes() {
    let mut rng = Rng(0x2545_F491_4F6C_DD1D);
    let (mut settled_pixels, mut moved) = (0, 0);
    for trial in 0..30 {
        let case = random_case(&mut rng);
        let stage = case.stage(random_params(&mut rng));
        let guide = case.guide();
        let (w, h, pixels) = (case.w, case.h, case.pixels());
        let mut scratch = vec![0.0f32; scratch_len(stage.setup())];
        let mut expected = case.map().to_vec();
        let mut input = expected.clone();
        let mut previous: Option<Vec<f32>> = None;
        let mut settled = vec![7u8; pixels];
        for pass in 0..4 {
            let mut next = vec![0.0f32; pixels];
            filter(stage.setup(), &guide, &expected, &mut next, &mut scratch).unwrap();
            moved += (0..pixels)
                .filter(|&i| next[i].to_bits() != expected[i].to_bits())
                .count();
            expected = next;
            let mut got = vec![0.0f32; pixels];
            let mut start = 0;
            while start < h {
                let end = (start + 1 + rng.below(h)).min(h);
                scratch.fill(f32::NAN);
                filter_pass(
                    stage.setup(),
                    PassInput {
                        guide: &guide,
                        input: &input,
                        previous: previous.as_deref(),
                    },
                    start..end,
                    &mut got[start * w..end * w],
                    &mut settled[start * w..end * w],
                    &mut scratch,
                )
                .unwrap();
                start = end;
            }
            for i in 0..pixels {
                assert_eq!(
                    got[i].to_bits(),
                    expected[i].to_bits(),
                    "trial {trial}, pass {pass}, ({}, {})",
                    i % w,
                    i / w
                );
                assert!(
                    settled[i] <= 1,
                    "trial {trial}, pass {pass}: byte not written"
                );
            }
            settled_pixels += settled.iter().filter(|&&b| b == 1).count();
            previous = Some(core::mem::replace(&mut input, got));
        }
    }
    // Both the median and the settled shortcut must have had work to do.
    assert!(moved > 100, "only {moved} pixels moved");
    assert!(
        settled_pixels > 1000,
        "only {settled_pixels} settled pixels"
    );
    let stage = stage_for(16, 16, MedianParams::default());
    let views = [0u8; 256];
    let guide = View::new(&views, 16, 16, 1, 16).unwrap();
    let mut out = [0.0f32; 256];
    let mut scratch = vec![0.0; scratch_len(stage.setup())];
    let map = [0.0f32; 256];
    assert!(matches!(
        filter_pass(
            stage.setup(),
            PassInput {
                guide: &guide,
                input: &map,
                previous: None
            },
            0..16,
            &mut out,
            &mut [0; 255],
            &mut scratch
        ),
        Err(Error::OutputSize { .. })
    ));
    assert!(matches!(
        filter_pass(
            stage.setup(),
            PassInput {
                guide: &guide,
                input: &map,
                previous: Some(&[0.0; 255])
            },
            0..16,
            &mut out,
            &mut [0; 256],
            &mut scratch
        ),
        Err(Error::OutputSize { .. })
    ));
}
