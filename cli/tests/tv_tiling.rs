//! Tiles: bit-identical results for any thread count, agreement with an untiled solve,
//! fixed point against f32, on synthetic scenes (fast) and the HCI scenes (release).

#[path = "tv_support.rs"]
mod tv_support;

use lfdepth::synth::{self, SceneKind, SynthSpec};
use lfdepth::tv::{self, Guide, Maps, SolveOutput, TvParams};
use lfdepth::{Grid, Params, Plan, Scalar, Q16};
use rayon::prelude::*;
use tv_support::*;

/// A synthetic scene: centre view (RGB), ground truth, and an EPI-like input — the ground
/// truth with noise and a few outliers, whose confidence is low.
struct Scene {
    w: usize,
    h: usize,
    image: Vec<u8>,
    gt: Vec<f32>,
    input: Vec<f32>,
    confidence: Vec<f32>,
}

fn scene(kind: SceneKind, w: usize, h: usize, seed: u64) -> Scene {
    let spec = SynthSpec {
        seed,
        ..SynthSpec::new(kind, Grid::new(3, 3), w, h)
    };
    let (r, c) = spec.grid.center();
    let mut image = vec![0u8; w * h * 3];
    synth::render_view(&spec, r, c, &mut image).unwrap();
    let mut gt = vec![0.0f32; w * h];
    synth::render_ground_truth(&spec, &mut gt).unwrap();
    let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut input = Vec::with_capacity(w * h);
    let mut confidence = Vec::with_capacity(w * h);
    for &g in &gt {
        let outlier = next() < 0.03;
        let noise = (next() - 0.5) * 0.1;
        if outlier {
            input.push(g + (next() - 0.5) * 2.0);
            confidence.push(0.2 * next());
        } else {
            input.push(g + noise);
            confidence.push(0.7 + 0.3 * next());
        }
    }
    Scene {
        w,
        h,
        image,
        gt,
        input,
        confidence,
    }
}

fn plan_for(s: &Scene, tv: TvParams) -> (Vec<u8>, Plan) {
    guide_light_field(
        s.w,
        s.h,
        &s.image,
        Params {
            tv,
            ..Params::default()
        },
    )
}

fn refine_serial<S: Scalar>(s: &Scene, tv_params: TvParams) -> (Vec<f32>, Vec<f32>) {
    let (data, plan) = plan_for(s, tv_params);
    let lf = light_field(&data, &plan);
    let maps = Maps::new(s.w, s.h, &s.input, &s.confidence).unwrap();
    let guide = Guide::View(lf.center_view());
    let mut out = vec![0.0f32; s.w * s.h];
    let mut history = vec![0.0f32; tv_params.max_iterations];
    let mut scratch = vec![S::ZERO; tv::scratch_len(plan.tv())];
    tv::refine(
        plan.tv(),
        &maps,
        &guide,
        &mut out,
        &mut history,
        tv::TvScratch {
            kernel: &mut scratch,
            duals: &mut vec![0.0; tv::dual_len(plan.tv())],
        },
    )
    .unwrap();
    (out, history)
}

/// Tiles in parallel on `threads` threads, each into its own buffers, stitched and the
/// histories summed in tile order — the way a parallel caller uses the tile API.
fn refine_parallel(s: &Scene, tv_params: TvParams, threads: usize) -> (Vec<f32>, Vec<f32>) {
    let (data, plan) = plan_for(s, tv_params);
    let lf = light_field(&data, &plan);
    let maps = Maps::new(s.w, s.h, &s.input, &s.confidence).unwrap();
    let guide = Guide::View(lf.center_view());
    let (cols, rows) = tv::tile_count(plan.tv());
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let tiles: Vec<(Vec<f32>, Vec<f32>)> = pool.install(|| {
        (0..cols * rows)
            .into_par_iter()
            .map(|index| {
                let (core, _) = tv::tile_rects(plan.tv(), index).unwrap();
                let mut out = vec![0.0f32; core.width * core.height];
                let mut history = vec![0.0f32; tv_params.max_iterations];
                let mut scratch = vec![0.0f32; tv::scratch_len(plan.tv())];
                tv::refine_tile(
                    plan.tv(),
                    &maps,
                    &guide,
                    index,
                    SolveOutput {
                        disparity: &mut out,
                        stride: core.width,
                        history: &mut history,
                        dual: None,
                    },
                    &mut scratch,
                )
                .unwrap();
                (out, history)
            })
            .collect()
    });
    let mut out = vec![0.0f32; s.w * s.h];
    let mut history = vec![0.0f32; tv_params.max_iterations];
    for (index, (core_out, tile_history)) in tiles.iter().enumerate() {
        let (core, _) = tv::tile_rects(plan.tv(), index).unwrap();
        for y in 0..core.height {
            let dst = (core.y + y) * s.w + core.x;
            out[dst..dst + core.width]
                .copy_from_slice(&core_out[y * core.width..(y + 1) * core.width]);
        }
        for (h, t) in history.iter_mut().zip(tile_history) {
            *h += t;
        }
    }
    tv::normalise_history(plan.tv(), &mut history);
    (out, history)
}

fn small_tiles() -> TvParams {
    TvParams {
        tile: 32,
        halo: 8,
        max_iterations: 80,
        ..TvParams::default()
    }
}

#[test]
fn tiles_are_bit_identical_for_any_thread_count() {
    let s = scene(SceneKind::Mixed, 100, 70, 3);
    let params = small_tiles();
    let (serial, serial_history) = refine_serial::<f32>(&s, params);
    for threads in [1, 2, 3] {
        let (parallel, history) = refine_parallel(&s, params, threads);
        let same = serial
            .iter()
            .zip(&parallel)
            .all(|(a, b)| a.to_bits() == b.to_bits());
        assert!(
            same,
            "{threads} threads: refined map differs from the serial one"
        );
        assert_eq!(
            history, serial_history,
            "{threads} threads: history differs"
        );
    }
    // The history is a real residual curve: it starts high and falls.
    assert!(serial_history[0] > 0.0 && serial_history[60] < 0.1 * serial_history[0]);
}

#[test]
fn tv_reduces_the_error_of_a_noisy_synthetic_input() {
    for kind in [SceneKind::Planes, SceneKind::Occlusion, SceneKind::Slanted] {
        let s = scene(kind, 96, 96, 5);
        let (out, _) = refine_serial::<f32>(&s, TvParams::default());
        let before = scores(&s.input, &s.gt, s.w, s.h);
        let after = scores(&out, &s.gt, s.w, s.h);
        eprintln!(
            "{}: BadPix0.07 {:.2} → {:.2} %, MSE×100 {:.3} → {:.3}",
            kind.name(),
            before.0,
            after.0,
            before.1,
            after.1
        );
        assert!(
            after.1 < 0.5 * before.1,
            "{}: MSE×100 {:.3} → {:.3}",
            kind.name(),
            before.1,
            after.1
        );
    }
}

#[test]
fn fixed_point_stays_within_a_hundredth_of_a_pixel_of_f32() {
    for (kind, seed) in [
        (SceneKind::Planes, 1),
        (SceneKind::Spheres, 2),
        (SceneKind::Mixed, 3),
    ] {
        let s = scene(kind, 80, 72, seed);
        let params = TvParams {
            tile: 48,
            halo: 8,
            ..TvParams::default()
        };
        let (f, _) = refine_serial::<f32>(&s, params);
        let (q, _) = refine_serial::<Q16>(&s, params);
        let mut diffs: Vec<f32> = f.iter().zip(&q).map(|(a, b)| (a - b).abs()).collect();
        diffs.sort_by(f32::total_cmp);
        let max = diffs[diffs.len() - 1];
        let p999 = diffs[diffs.len() * 999 / 1000];
        eprintln!(
            "{}: |Q16.16 − f32| max {max:.5} px, 99.9 % {p999:.5} px",
            kind.name()
        );
        assert!(max < 0.01, "{}: max |Q16.16 − f32| = {max} px", kind.name());
    }
}

/// The engine's EPI stage on an HCI scene: (width, height, disparity, confidence, image).
fn hci_inputs(dir: &std::path::Path) -> Scene {
    use lfdepth_cli::engine::{estimate, EstimateOptions, Stages};
    let (views, layout) = load_hci(dir);
    let lf = lfdepth::LightField::new(&views, layout).unwrap();
    let options = EstimateOptions {
        params: Params {
            sweep: lfdepth::planesweep::PlaneSweepParams::off(),
            ..Params::default()
        },
        stage: Stages::Epi,
        threads: None,
    };
    let e = estimate(&lf, &options, &mut |_, _, _| {}).unwrap();
    let (_, _, image) = read_rgb_png(&dir.join("input_Cam040.png"));
    let (_, _, gt) = read_pfm(&dir.join("gt_disp_lowres.pfm"));
    Scene {
        w: e.width,
        h: e.height,
        image,
        gt,
        input: e.disparity,
        confidence: e.confidence,
    }
}

/// RMS and largest absolute difference of two maps.
fn differences(a: &[f32], b: &[f32]) -> (f64, f32) {
    let rms = (a
        .iter()
        .zip(b)
        .map(|(x, y)| ((x - y) as f64).powi(2))
        .sum::<f64>()
        / a.len() as f64)
        .sqrt();
    let max = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max);
    (rms, max)
}

#[test]
#[cfg_attr(debug_assertions, ignore)]
fn tiled_and_untiled_agree_on_the_hci_scenes() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: the HCI tiling test runs only with --release");
        return;
    }
    let Some(data) = shared_data("the HCI tiling test") else {
        return;
    };
    for scene in ["stratified/backgammon", "training/cotton"] {
        let s = hci_inputs(&data.join("hci").join(scene));
        let untiled = |params: TvParams| TvParams {
            tile: s.w.max(s.h),
            halo: 0,
            sweeps: 0,
            ..params
        };
        // Default parameters: both stop at the default tolerance (primal change per
        // iteration), so they differ by their convergence error as much as by the tiling.
        let tiled_params = TvParams::default();
        let (tiled, _) = refine_serial::<f32>(&s, tiled_params);
        let (whole, _) = refine_serial::<f32>(&s, untiled(tiled_params));
        let (rms, max) = differences(&tiled, &whole);
        eprintln!(
            "{scene}: default tiled ({}+{}) vs untiled: RMS {rms:.5} px, max {max:.5} px",
            tiled_params.tile, tiled_params.halo
        );
        assert!(rms <= 0.005, "{scene}: RMS tiled vs untiled {rms} px");
        // Run close to convergence, what is left is the tiling: the outer sweeps, which
        // hold each tile's border flows at its neighbours' values, bring it within
        // 0.005 px everywhere.
        let converged = TvParams {
            tolerance: 5e-7,
            max_iterations: 6000,
            ..TvParams::default()
        };
        let (whole, _) = refine_serial::<f32>(&s, untiled(converged));
        let (tiled, _) = refine_serial::<f32>(&s, converged);
        let (rms, max) = differences(&tiled, &whole);
        eprintln!("{scene}: converged tiled vs untiled: RMS {rms:.5} px, max {max:.5} px");
        let swept = TvParams {
            sweeps: 2,
            ..converged
        };
        let (tiled, _) = refine_serial::<f32>(&s, swept);
        let (rms, max) = differences(&tiled, &whole);
        eprintln!(
            "{scene}: converged tiled with 2 outer sweeps vs untiled: RMS {rms:.5} px, max {max:.5} px"
        );
        assert!(
            max <= 0.005,
            "{scene}: max tiled (swept) vs untiled {max} px"
        );
    }
}
