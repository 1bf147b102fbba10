//! The automatic disparity range (`--disparity-range auto`, `lfdepth::epi::estimate_range`)
//! of each scene folder given, with default parameters. Where the folder holds a ground
//! truth (`gt_disp_lowres.pfm`), also its range and the share of its pixels below and above
//! the automatic range: those pixels lie outside every hypothesis the estimator tries.
//! Folders load as `lfdepth estimate` loads them (HCI names, `NAME_RR_CC`, a
//! `parameters.cfg` grid), so real captures without ground truth report their range too.
//!
//! ```text
//! cargo run --release -p lfdepth-cli --example range_report -- DIR…
//! ```
//!
//! One line per folder, e.g.
//! `/tmp/thin: auto [-2.00, 1.40] truth [-1.50, 1.50] outside 0.000 % below, 0.536 % above`.

use std::path::Path;
use std::process::ExitCode;

use lfdepth::{epi, LightField, Params, Plan, Sample};
use lfdepth_cli::io::{pfm, scene};

fn main() -> ExitCode {
    let dirs: Vec<String> = std::env::args().skip(1).collect();
    if dirs.is_empty() {
        eprintln!("usage: range_report DIR…");
        return ExitCode::FAILURE;
    }
    let mut status = ExitCode::SUCCESS;
    for dir in &dirs {
        match report(Path::new(dir)) {
            Ok(line) => println!("{dir}: {line}"),
            Err(e) => {
                eprintln!("{dir}: error: {e}");
                status = ExitCode::FAILURE;
            }
        }
    }
    status
}

/// The report line of one folder.
fn report(dir: &Path) -> Result<String, Box<dyn std::error::Error>> {
    let loaded = scene::load(dir, &scene::LoadOptions::default())?;
    let (lo, hi) = match &loaded.views {
        scene::Views::U8(data) => auto_range(data, loaded.layout)?,
        scene::Views::F32(data) => auto_range(data, loaded.layout)?,
    };
    let mut line = format!("auto [{lo:.2}, {hi:.2}]");
    if let Some(path) = loaded.ground_truth_path() {
        let gt = pfm::read(&path)?.data;
        let finite = || gt.iter().copied().filter(|g| g.is_finite());
        let gmin = finite().fold(f32::INFINITY, f32::min);
        let gmax = finite().fold(f32::NEG_INFINITY, f32::max);
        let share = |n: usize| 100.0 * n as f64 / finite().count().max(1) as f64;
        let below = share(finite().filter(|&g| g < lo).count());
        let above = share(finite().filter(|&g| g > hi).count());
        line += &format!(
            " truth [{gmin:.2}, {gmax:.2}] outside {below:.3} % below, {above:.3} % above"
        );
    }
    Ok(line)
}

/// `estimate_range` on the views with default parameters.
fn auto_range<S: Sample>(
    views: &[S],
    layout: lfdepth::Layout,
) -> Result<(f32, f32), Box<dyn std::error::Error>> {
    let plan = Plan::new(layout, Params::default())?;
    let lf = LightField::new(views, layout)?;
    let mut scratch = vec![0.0f32; epi::scratch_len(plan.epi())];
    Ok(epi::estimate_range(plan.epi(), &lf, &mut scratch)?)
}
