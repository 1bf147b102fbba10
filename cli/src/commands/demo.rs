//! `lfdepth demo`: renders a synthetic light field, estimates its disparity and scores
//! it against the exact ground truth — a self-contained tour of the pipeline.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;
use lfdepth::synth::{SceneKind, SynthSpec};
use lfdepth::{Grid, LightField};

use super::estimate::write_colour_png;
use super::params::{print_alignment, ParamArgs};
use super::synth::{check_spec, default_misalignment, parse_scene, render};
use super::{create_dir, CliError, LimitArgs, ScalarArg, Stage};
use crate::colormap;
use crate::engine::{self, EstimateOptions};
use crate::io::output::{check_folder_writable, check_writable};
use crate::io::pfm::{self, Pfm};
use crate::io::IoError;
use crate::progress::StageProgress;
use crate::report;

/// Arguments of `lfdepth demo`.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Output folder for disparity.pfm, disparity.png and ground_truth.png (created if
    /// needed). A folder holding other files is refused unless --force is given.
    #[arg(long, value_name = "DIR", default_value = "demo")]
    pub out: PathBuf,
    /// Write into a folder that holds other files too: demo replaces only its own three
    /// files and keeps every other one.
    #[arg(long)]
    pub force: bool,
    /// Synthetic scene: planes, slanted, spheres, occlusion, thin, low-texture or mixed.
    #[arg(long, value_name = "NAME", value_parser = parse_scene, default_value = "mixed")]
    pub scene: SceneKind,
    /// View width and height in pixels (9x9 views), 31 or more (the score ignores a
    /// 15-pixel border); at most 2574 within the default --max-pixels (81 views).
    #[arg(long, value_name = "N", default_value_t = 256)]
    pub size: usize,
    /// How far to run: `epi` or `full`.
    #[arg(long, value_enum, default_value_t = Stage::Full)]
    pub stage: Stage,
    /// Number type of every stage: `f32` or `q16` (Q16.16 fixed point).
    #[arg(long, value_enum, default_value_t = ScalarArg::F32)]
    pub scalar: ScalarArg,
    /// Worker threads, 1 to 256 (default: every core).
    #[arg(long, value_name = "N", value_parser = super::parse_threads)]
    pub threads: Option<u16>,
    /// Random seed of the scene's texture.
    #[arg(long, value_name = "N", default_value_t = 1)]
    pub seed: u64,
    /// Misalign the views by small random homographies (what `lfdepth synth --misalign`
    /// writes), to see the alignment at work.
    #[arg(long)]
    pub misalign: bool,
    /// Estimator parameters (as `estimate`'s).
    #[command(flatten)]
    pub params: ParamArgs,
    /// No progress bar.
    #[arg(short, long)]
    pub quiet: bool,
    /// Caps on the size of the light field.
    #[command(flatten)]
    pub limits: LimitArgs,
}

/// The files demo writes into its folder.
pub const DEMO_FILES: [&str; 3] = ["disparity.pfm", "disparity.png", "ground_truth.png"];

/// Makes sure `dir` can take demo's files: new, holding only demo's own files, or any
/// folder with `force`. Creates it and checks that it takes files.
fn prepare_folder(dir: &Path, force: bool) -> Result<PathBuf, CliError> {
    if dir.exists() && !dir.is_dir() {
        return Err(CliError::Usage(format!(
            "--out {} is not a folder: give a folder for {}",
            dir.display(),
            DEMO_FILES.join(", ")
        )));
    }
    if dir.is_dir() && !force {
        let list = |e| IoError::os(dir, "list", e);
        let mut others = Vec::new();
        for entry in std::fs::read_dir(dir).map_err(list)? {
            let name = entry
                .map_err(list)?
                .file_name()
                .to_string_lossy()
                .into_owned();
            if !DEMO_FILES.contains(&name.as_str()) {
                others.push(name);
            }
        }
        others.sort();
        if !others.is_empty() {
            return Err(CliError::Usage(format!(
                "--out {} holds files demo did not write ({}{}): give a new folder, or --force to write {} beside them",
                dir.display(),
                others.iter().take(4).cloned().collect::<Vec<_>>().join(", "),
                if others.len() > 4 { ", …" } else { "" },
                DEMO_FILES.join(", ")
            )));
        }
    }
    let dir = create_dir(dir)?;
    check_folder_writable(&dir, &dir)?;
    for name in DEMO_FILES {
        check_writable(&dir.join(name))?;
    }
    Ok(dir)
}

/// Runs `lfdepth demo`.
pub fn run(args: &DemoArgs) -> Result<(), CliError> {
    let mut spec = SynthSpec::new(args.scene, Grid::new(9, 9), args.size, args.size);
    spec.seed = args.seed;
    spec.misalign = args.misalign.then(default_misalignment);
    check_spec(&spec, &args.limits.limits(), "--size")?;
    let least = super::eval::MIN_SCORED_SIDE;
    if args.size < least {
        return Err(CliError::Usage(format!(
            "--size {}: the demo scores its estimate with the benchmark, which ignores a {}-pixel border, so views need at least {least} pixels a side: give --size {least} or more",
            args.size,
            lfdepth::metrics::BORDER
        )));
    }
    let dir = prepare_folder(&args.out, args.force)?;
    let start = Instant::now();
    let rendered = render(&spec)?;
    let render_time = start.elapsed();
    let layout = spec.layout();
    let lf = LightField::new(&rendered.views, layout)
        .map_err(|e| CliError::core("building the synthetic light field", e))?;
    let options = EstimateOptions {
        params: args.params.params(None)?,
        stage: args.stage.into(),
        threads: args.threads.map(usize::from),
    };
    let mut bar = StageProgress::new(args.quiet);
    let result = engine::estimate_with(&lf, &options, args.scalar.into(), &mut |s, d, t| {
        bar.update(s, d, t)
    });
    bar.finish();
    let estimate = result.map_err(|e| CliError::core("estimating the demo scene", e))?;
    print_alignment(estimate.align.as_ref());
    let (w, h) = (estimate.width, estimate.height);
    let est = Pfm::new(w, h, estimate.disparity.clone())?;
    let gt = Pfm::new(layout.width, layout.height, rendered.gt.clone())?;
    pfm::write(&dir.join("disparity.pfm"), &est)?;
    // Both pictures share the ground truth's range so their colours compare.
    let range = colormap::finite_range(&gt.data);
    write_colour_png(&dir.join("disparity.png"), w, h, &est.data, range)?;
    write_colour_png(
        &dir.join("ground_truth.png"),
        gt.width,
        gt.height,
        &gt.data,
        range,
    )?;
    let scores = super::eval::score(&est, &gt, None, &dir.join("disparity.pfm"), &dir)?;
    println!(
        "{} scene, 9x9 views of {}x{} (rendered in {:.2} s), written to {}",
        spec.scene.name(),
        w,
        h,
        render_time.as_secs_f64(),
        dir.display()
    );
    println!("\naccuracy against the exact ground truth:");
    print!("{}", report::scores_text(&scores));
    println!("\ntime per stage:");
    print!("{}", report::timings(&estimate.timings));
    Ok(())
}
