//! Native single-threaded timing of the same work the wasm `Estimator.estimate()` does,
//! for `docs/stages/web.md` (run by `tests/bench/wasm-vs-native.mjs`, which times the wasm
//! side on the same scene):
//!
//! ```text
//! cargo run --release -p lfdepth-wasm --example native_timing -- planes 512 9 3 epi
//! ```
//! Arguments: scene, size (px), grid (views per side), repetitions, stages ("epi": the
//! start alone, the plane sweep by default, as `{ stage: "epi" }`; "full": the start →
//! refine → refill → median → TV, as `{ align: "off" }`). Prints one JSON line.

use std::ops::ControlFlow;
use std::time::Instant;

use lfdepth::pipeline::{self, Stages};
use lfdepth::synth::{self, SceneKind, SynthSpec};
use lfdepth::{Grid, Homography, LightField, Params, Plan};

fn main() -> Result<(), String> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: &str| args.get(i).cloned().unwrap_or_else(|| default.into());
    let scene = SceneKind::from_name(&arg(0, "planes")).ok_or("unknown scene")?;
    let size: usize = arg(1, "512").parse().map_err(|_| "size must be a number")?;
    let grid: usize = arg(2, "9").parse().map_err(|_| "grid must be a number")?;
    let repetitions: usize = arg(3, "3")
        .parse()
        .map_err(|_| "repetitions must be a number")?;
    let stages = match arg(4, "epi").as_str() {
        "epi" => Stages::Epi,
        "full" => Stages::Full,
        _ => return Err("stages must be \"epi\" or \"full\"".into()),
    };

    let mut spec = SynthSpec::new(scene, Grid::new(grid, grid), size, size);
    spec.seed = 1;
    let layout = spec.layout();
    let mut views = vec![0u8; layout.validate().map_err(|e| e.to_string())?];
    let mut gt = vec![0.0f32; size * size];
    let mut homographies = vec![Homography::default(); grid * grid];
    synth::render(&spec, &mut views, &mut gt, &mut homographies).map_err(|e| e.to_string())?;

    let lf = LightField::new(&views, layout).map_err(|e| e.to_string())?;
    let plan = Plan::new(layout, Params::default()).map_err(|e| e.to_string())?;
    let mut best = f64::INFINITY;
    let mut disparity = vec![0.0f32; plan.pixels()];
    for _ in 0..repetitions.max(1) {
        // Allocations inside the timing, as the wasm Estimator.estimate() does.
        let start = Instant::now();
        let mut d = vec![0.0f32; plan.pixels()];
        let mut c = vec![0.0f32; plan.pixels()];
        let mut scratch = vec![0.0f32; pipeline::stage_scratch_len(&plan, stages)];
        let (mut maps, mut history) = match stages {
            Stages::Epi => (Vec::new(), Vec::new()),
            Stages::Full => (
                vec![0.0f32; pipeline::map_scratch_len(&plan)],
                vec![0.0f32; plan.params().tv.max_iterations],
            ),
        };
        pipeline::run(
            &plan,
            &lf,
            stages,
            pipeline::RunOutput {
                disparity: &mut d,
                confidence: &mut c,
                history: &mut history,
            },
            pipeline::RunScratch {
                kernel: &mut scratch,
                maps: &mut maps,
            },
            &mut |_| ControlFlow::Continue(()),
        )
        .map_err(|e| e.to_string())?;
        best = best.min(start.elapsed().as_secs_f64() * 1e3);
        disparity = d;
    }
    let checksum: f64 = disparity.iter().map(|&d| d as f64).sum();
    println!(
        "{{\"scene\":\"{}\",\"size\":{size},\"grid\":{grid},\"best_ms\":{best:.1},\"checksum\":{checksum}}}",
        scene.name()
    );
    Ok(())
}
