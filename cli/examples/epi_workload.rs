//! Fixed EPI-stage workloads for comparing kernel changes on a busy machine, where CPU
//! time and instruction counts are steadier than wall time.
//!
//! `cpu`: estimates of the `epi` bench's scene (`mixed`, 9×9×512² RGB, automatic range)
//! through the engine, each printed with its wall and process CPU time, then the minimum,
//! median and mean (the minimum CPU time is the steadiest figure on a shared machine):
//!
//! ```text
//! cargo run --release -p lfdepth-cli --example epi_workload -- cpu [--reps N] [--threads N] [--exhaustive]
//! ```
//!
//! (defaults: 5 estimates, 1 thread, the default coarse-to-fine search). `callgrind`: one
//! 1-thread estimate of a cheap hashed-texture scene with 7 hypotheses (fixed range
//! −1.5…1.5 px), a repeatable instruction count:
//!
//! ```text
//! cargo build --release -p lfdepth-cli --example epi_workload
//! valgrind --tool=callgrind --toggle-collect='lfdepth_cli::engine::estimate*' \
//!     target/release/examples/epi_workload callgrind
//! ```

use lfdepth::epi::{DisparityRange, EpiParams, Search};
use lfdepth::{Grid, LightField, Params};
use lfdepth_cli::engine::{estimate, EstimateOptions, Stages};

const USAGE: &str =
    "usage: epi_workload cpu [--reps N] [--threads N] [--exhaustive] | epi_workload callgrind";

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("callgrind") if args.len() == 1 => callgrind_workload(),
        Some("cpu") => {
            let (mut reps, mut threads, mut epi) = (5usize, 1usize, EpiParams::default());
            let mut rest = args[1..].iter();
            while let Some(flag) = rest.next() {
                let mut count = |what: &str| -> usize {
                    match rest.next().and_then(|v| v.parse().ok()) {
                        Some(n) if n >= 1 => n,
                        _ => fail(&format!("{flag} takes a positive number of {what}")),
                    }
                };
                match flag.as_str() {
                    "--reps" => reps = count("estimates"),
                    "--threads" => threads = count("threads"),
                    "--exhaustive" => epi.search = Search::Exhaustive,
                    other => fail(&format!("unknown option `{other}`")),
                }
            }
            cpu_workload(reps, threads, epi);
        }
        _ => fail("no workload named"),
    }
}

fn fail(why: &str) -> ! {
    eprintln!("error: {why}\n{USAGE}");
    std::process::exit(2);
}

fn options(threads: usize, epi: EpiParams) -> EstimateOptions {
    EstimateOptions {
        params: Params {
            epi,
            sweep: lfdepth::planesweep::PlaneSweepParams::off(),
            ..Params::default()
        },
        stage: Stages::Epi,
        threads: Some(threads),
    }
}

/// CPU seconds used by this process so far, exited threads included (the engine's
/// workers end with each estimate): Linux `/proc/self/stat`, 10 ms ticks.
fn process_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let fields: Vec<&str> = stat.rsplit(')').next()?.split_whitespace().collect();
    let ticks: f64 = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// `reps` estimates of the `epi` bench's scene with `threads` threads and `epi`.
fn cpu_workload(reps: usize, threads: usize, epi: EpiParams) {
    use lfdepth::synth::{render, SceneKind, SynthSpec};
    use lfdepth::Homography;
    // The scene of `cargo bench --bench epi`: `Mixed`, −1.5…1.5 px, 9×9×512×512 RGB.
    let spec = SynthSpec::new(SceneKind::Mixed, Grid::new(9, 9), 512, 512);
    let mut data = vec![0u8; spec.layout().validate().unwrap()];
    let mut gt = vec![0.0f32; 512 * 512];
    let mut h = vec![Homography::IDENTITY; 81];
    render(&spec, &mut data, &mut gt, &mut h).unwrap();
    let lf = LightField::new(&data, spec.layout()).unwrap();
    let mut cpu_times = Vec::new();
    let mut wall_times = Vec::new();
    for _ in 0..reps {
        let (wall, cpu) = (std::time::Instant::now(), process_cpu_seconds());
        estimate(&lf, &options(threads, epi), &mut |_, _, _| {}).unwrap();
        wall_times.push(wall.elapsed().as_secs_f64());
        let cpu = process_cpu_seconds().zip(cpu).map(|(b, a)| b - a);
        eprintln!(
            "{threads}-thread estimate of 9x9x512x512 RGB: wall {:?}, process CPU {:?} s",
            wall.elapsed(),
            cpu
        );
        cpu_times.extend(cpu);
    }
    cpu_times.sort_by(f64::total_cmp);
    if let (Some(min), Some(median)) = (cpu_times.first(), cpu_times.get(cpu_times.len() / 2)) {
        let mean = cpu_times.iter().sum::<f64>() / cpu_times.len() as f64;
        eprintln!(
            "CPU per estimate over {reps}: min {:.0} ms, median {:.0} ms, mean {:.0} ms",
            min * 1e3,
            median * 1e3,
            mean * 1e3
        );
    }
    wall_times.sort_by(f64::total_cmp);
    if let (Some(min), Some(median)) = (wall_times.first(), wall_times.get(wall_times.len() / 2)) {
        eprintln!(
            "wall per estimate over {reps}: min {:.0} ms, median {:.0} ms",
            min * 1e3,
            median * 1e3
        );
    }
}

/// One 1-thread estimate of a cheap hashed-texture scene (7 hypotheses).
fn callgrind_workload() {
    let grid = Grid::new(9, 9);
    let (w, h) = (512usize, 512usize);
    let layout = lfdepth::Layout::packed(grid, w, h, 3);
    let (r0, c0) = grid.center();
    // A hashed texture, shifted by one pixel per view (disparity 1).
    let texture = |x: isize, y: isize, ch: usize| -> u8 {
        let mut v = (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
            ^ ch as u64;
        v ^= v >> 29;
        v = v.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        (v >> 56) as u8
    };
    let mut data = Vec::with_capacity(layout.validate().unwrap());
    for r in 0..grid.rows {
        for c in 0..grid.cols {
            let (dr, dc) = (r as isize - r0 as isize, c as isize - c0 as isize);
            for y in 0..h as isize {
                for x in 0..w as isize {
                    for ch in 0..3 {
                        data.push(texture((x + dc) / 2, (y + dr) / 2, ch));
                    }
                }
            }
        }
    }
    let lf = LightField::new(&data, layout).unwrap();
    let epi = EpiParams {
        range: DisparityRange::Fixed {
            min: -1.5,
            max: 1.5,
        },
        ..EpiParams::default()
    };
    let e = estimate(&lf, &options(1, epi), &mut |_, _, _| {}).unwrap();
    assert_eq!(e.disparity.len(), w * h);
}
