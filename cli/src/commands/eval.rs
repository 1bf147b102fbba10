//! `lfdepth eval`: HCI benchmark metrics for one map, or estimate-and-score a dataset.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;
use lfdepth::metrics::{self, EvalOptions, Scores};

use super::estimate::estimate_scene;
use super::params::ParamArgs;
use super::{CliError, LimitArgs, ScalarArg, Stage, ViewArgs};
use crate::engine::{EstimateOptions, Runner};
use crate::io::pfm::{self, Pfm};
use crate::io::png::{self, Samples};
use crate::io::scene::{self, GROUND_TRUTH_FILE};
use crate::io::{needs, IoError};
use crate::progress::StageProgress;
use crate::report::{self, SceneRow};

/// Arguments of `lfdepth eval`.
#[derive(Debug, Args)]
pub struct EvalArgs {
    /// Estimated disparity (PFM) to score.
    #[arg(
        value_name = "EST.pfm",
        required_unless_present = "dataset",
        conflicts_with = "dataset"
    )]
    pub estimate: Option<PathBuf>,
    /// Ground-truth disparity (PFM), e.g. a scene's gt_disp_lowres.pfm.
    #[arg(
        long,
        value_name = "GT.pfm",
        required_unless_present = "dataset",
        conflicts_with = "dataset"
    )]
    pub gt: Option<PathBuf>,
    /// Only score pixels where this PNG (same size as GT) is non-zero.
    #[arg(long, value_name = "M.png", conflicts_with = "dataset")]
    pub mask: Option<PathBuf>,
    /// Estimate and score every scene under DIR (folders holding gt_disp_lowres.pfm and views).
    #[arg(long, value_name = "DIR")]
    pub dataset: Option<PathBuf>,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// With --dataset: how far to run the estimator.
    #[arg(long, value_enum, default_value_t = Stage::Full, requires = "dataset")]
    pub stage: Stage,
    /// With --dataset: number type of every stage, `f32` or `q16` (Q16.16 fixed point).
    #[arg(long, value_enum, default_value_t = ScalarArg::F32, requires = "dataset")]
    pub scalar: ScalarArg,
    /// With --dataset: worker threads, 1 to 256 (default: every core).
    #[arg(long, value_name = "N", requires = "dataset", value_parser = super::parse_threads)]
    pub threads: Option<u16>,
    /// With --dataset: how the views are named.
    #[command(flatten)]
    pub views: ViewArgs,
    /// With --dataset: estimator parameters.
    #[command(flatten)]
    pub params: ParamArgs,
    /// Caps on the size of the views (and the mask).
    #[command(flatten)]
    pub limits: LimitArgs,
}

/// Centre-embeds an estimate cropped symmetrically by `m ≤ BORDER` pixels per side
/// (e.g. EPINET's 490×490 of a 512×512 scene) in a NaN canvas of the ground truth's
/// size, as the reference evaluator does. Exact, because only pixels inside the
/// border are scored. Returns `None` when the sizes do not fit that rule.
pub fn embed_cropped(est: &Pfm, width: usize, height: usize) -> Option<Pfm> {
    if est.width == 0 || est.width.checked_mul(est.height) != Some(est.data.len()) {
        return None;
    }
    let dw = width.checked_sub(est.width)?;
    let dh = height.checked_sub(est.height)?;
    if !(dw == dh && dh > 0 && dh % 2 == 0 && dh / 2 <= metrics::BORDER) {
        return None;
    }
    let m = dh / 2;
    let mut data = vec![f32::NAN; width * height];
    for (y, row) in est.data.chunks_exact(est.width).enumerate() {
        let start = (y + m) * width + m;
        data[start..start + est.width].copy_from_slice(row);
    }
    Some(Pfm {
        width,
        height,
        data,
    })
}

/// Reads a mask PNG: a pixel is scored when any colour channel is non-zero.
pub fn read_mask(path: &Path, width: usize, height: usize) -> Result<Vec<u8>, IoError> {
    read_mask_limited(
        path,
        width,
        height,
        crate::io::limits::DEFAULT_MAX_VIEW_PIXELS,
    )
}

/// [`read_mask`] of a PNG whose header declares at most `max_pixels` pixels.
pub fn read_mask_limited(
    path: &Path,
    width: usize,
    height: usize,
    max_pixels: u64,
) -> Result<Vec<u8>, IoError> {
    let image = png::read_limited(path, max_pixels)?;
    if (image.width, image.height) != (width, height) {
        return Err(IoError::format(format!(
            "the mask is {}x{} pixels but the ground truth is {width}x{height}",
            image.width, image.height
        ))
        .in_file(path));
    }
    let colour = match image.channels {
        2 => 1,
        4 => 3,
        c => c,
    };
    let stride = image.channels;
    let nonzero: Vec<u8> = match &image.samples {
        Samples::Eight(s) => s
            .chunks_exact(stride)
            .map(|p| u8::from(p[..colour].iter().any(|&v| v != 0)))
            .collect(),
        Samples::Sixteen(s) => s
            .chunks_exact(stride)
            .map(|p| u8::from(p[..colour].iter().any(|&v| v != 0)))
            .collect(),
    };
    Ok(nonzero)
}

/// The smallest side of a map the benchmark can score: it ignores
/// [`metrics::BORDER`] pixels along every edge.
pub const MIN_SCORED_SIDE: usize = 2 * metrics::BORDER + 1;

/// Refuses a ground truth too small to keep any pixel inside the benchmark's border.
pub fn check_scorable(gt: &Pfm, gt_path: &Path) -> Result<(), CliError> {
    if gt.width >= MIN_SCORED_SIDE && gt.height >= MIN_SCORED_SIDE {
        return Ok(());
    }
    Err(IoError::format(format!(
        "is {}x{} pixels: the benchmark ignores a {}-pixel border, so scoring needs a map of at least {MIN_SCORED_SIDE}x{MIN_SCORED_SIDE} pixels",
        gt.width,
        gt.height,
        metrics::BORDER
    ))
    .in_file(gt_path)
    .into())
}

/// Scores `est` against `gt` (embedding a symmetric crop, see [`embed_cropped`]).
pub fn score(
    est: &Pfm,
    gt: &Pfm,
    mask: Option<&[u8]>,
    est_path: &Path,
    gt_path: &Path,
) -> Result<Scores, CliError> {
    let embedded;
    let est = if (est.width, est.height) == (gt.width, gt.height) {
        est
    } else if let Some(e) = embed_cropped(est, gt.width, gt.height) {
        embedded = e;
        &embedded
    } else {
        return Err(CliError::Usage(format!(
            "{} is {}x{} but {} is {}x{}: the estimate must have the ground truth's size (or be cropped by the same even margin of at most {} pixels on each side)",
            est_path.display(),
            est.width,
            est.height,
            gt_path.display(),
            gt.width,
            gt.height,
            metrics::BORDER
        )));
    };
    check_scorable(gt, gt_path)?;
    let mut scratch = vec![0f32; metrics::scratch_len(gt.width, gt.height)];
    let options = EvalOptions {
        border: metrics::BORDER,
        mask,
    };
    metrics::evaluate(
        &est.data,
        &gt.data,
        gt.width,
        gt.height,
        &options,
        &mut scratch,
    )
    .map_err(|e| {
        CliError::core(
            format!(
                "scoring {} against {}",
                est_path.display(),
                gt_path.display()
            ),
            e,
        )
    })
}

/// Runs `lfdepth eval`.
pub fn run(args: &EvalArgs) -> Result<(), CliError> {
    if let Some(dir) = &args.dataset {
        return run_dataset(args, dir);
    }
    let (Some(est_path), Some(gt_path)) = (&args.estimate, &args.gt) else {
        return Err(CliError::Usage(
            "give an estimate and --gt, or --dataset DIR".into(),
        ));
    };
    let est = pfm::read(est_path)?;
    let gt = pfm::read(gt_path)?;
    let mask = match &args.mask {
        Some(p) => Some(read_mask_limited(
            p,
            gt.width,
            gt.height,
            args.limits.max_view_pixels,
        )?),
        None => None,
    };
    let scores = score(&est, &gt, mask.as_deref(), est_path, gt_path)?;
    if let Some(warning) = report::invalid_warning(&scores) {
        eprintln!("warning: {}: {warning}", est_path.display());
    }
    if args.json {
        println!("{}", report::scores_json(&scores));
    } else {
        print!("{}", report::scores_text(&scores));
    }
    Ok(())
}

/// Scene folders under `root` (itself included) holding a ground truth and PNG views,
/// sorted. Symbolic links to folders are followed; a folder reached twice (a link cycle,
/// or two links to one scene) is visited once.
pub fn find_scenes(root: &Path) -> Result<Vec<PathBuf>, IoError> {
    let mut found = Vec::new();
    let mut seen = std::collections::HashSet::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        let real = std::fs::canonicalize(&dir).map_err(|e| IoError::os(&dir, "resolve", e))?;
        if !seen.insert(real) {
            continue;
        }
        let entries = std::fs::read_dir(&dir).map_err(|e| IoError::os(&dir, "list", e))?;
        for entry in entries {
            let entry = entry.map_err(|e| IoError::os(&dir, "list", e))?;
            let path = entry.path();
            // `is_dir` follows links; a broken link is no folder.
            if path.is_dir() {
                stack.push(path);
            }
        }
        if dir.join(GROUND_TRUTH_FILE).is_file() && has_png(&dir) {
            found.push(dir);
        }
    }
    found.sort();
    Ok(found)
}

fn has_png(dir: &Path) -> bool {
    std::fs::read_dir(dir)
        .map(|entries| {
            entries
                .flatten()
                .any(|e| e.file_name().to_string_lossy().ends_with(".png"))
        })
        .unwrap_or(false)
}

/// Loads, estimates and scores one scene of a dataset.
fn score_scene(args: &EvalArgs, dir: &Path, name: &str) -> Result<Scores, CliError> {
    let gt_path = dir.join(GROUND_TRUTH_FILE);
    let gt = pfm::read(&gt_path)?;
    check_scorable(&gt, &gt_path)?;
    let files = scene::locate(dir, &args.views.load_options())?;
    let params = args.params.params(files.config.as_ref())?;
    let wanted = needs::views_to_read(&files, &params, args.stage.into())?.wanted;
    // The views are decoded on the threads the stages run on.
    let runner = Runner::new(EstimateOptions {
        params,
        stage: args.stage.into(),
        threads: args.threads.map(usize::from),
    })
    .map_err(|e| CliError::core("starting the worker threads", e))?;
    let loaded = runner.install(|| scene::read_selected(files, &args.limits.limits(), &wanted))?;
    let mut bar = StageProgress::new(false);
    let result = estimate_scene(&loaded, &runner, args.scalar.into(), &mut |s, d, t| {
        bar.update(s, d, t)
    });
    bar.finish();
    let estimate = result?;
    if estimate.align.is_some() {
        eprint!("{name}: ");
        super::params::print_alignment(estimate.align.as_ref());
    }
    let est = Pfm::new(estimate.width, estimate.height, estimate.disparity)?;
    score(&est, &gt, None, dir, &gt_path)
}

/// Estimates and scores every scene under `root`. A scene that fails is reported in
/// the table (and on stderr) and the others are still evaluated; the command then
/// fails, after printing the table.
fn run_dataset(args: &EvalArgs, root: &Path) -> Result<(), CliError> {
    if !root.is_dir() {
        return Err(IoError::format(scene::not_a_folder(root, "scenes"))
            .in_file(root)
            .into());
    }
    let scenes = find_scenes(root)?;
    if scenes.is_empty() {
        return Err(IoError::format(format!(
            "holds no scene folder with {GROUND_TRUTH_FILE} and PNG views: give a folder of HCI scenes"
        ))
        .in_file(root)
        .into());
    }
    let mut rows = Vec::new();
    for dir in &scenes {
        let name = dir
            .strip_prefix(root)
            .ok()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(dir)
            .display()
            .to_string();
        let start = Instant::now();
        let result = score_scene(args, dir, &name);
        let seconds = start.elapsed().as_secs_f64();
        match &result {
            Ok(scores) => eprintln!(
                "{name}: BadPix0.07 {:.3}, {seconds:.2} s",
                scores.badpix_007
            ),
            Err(e) => eprintln!("{name}: error: {e}"),
        }
        rows.push(SceneRow {
            scene: name,
            result: result.map_err(|e| e.to_string()),
            seconds,
        });
    }
    if args.json {
        println!("{}", report::dataset_json(&rows));
    } else {
        print!("{}", report::dataset_markdown(&rows));
    }
    let failed = rows.iter().filter(|r| r.result.is_err()).count();
    if failed > 0 {
        return Err(CliError::Usage(format!(
            "{failed} of the {} scenes could not be scored (see the table); the others were",
            rows.len()
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn symmetric_crops_are_centred_in_nan() {
        let est = Pfm::new(2, 2, vec![1.0, 2.0, 3.0, 4.0]).unwrap();
        let e = embed_cropped(&est, 4, 4).unwrap();
        assert_eq!(e.data[5..7], [1.0, 2.0]);
        assert_eq!(e.data[9..11], [3.0, 4.0]);
        assert_eq!(e.data.iter().filter(|v| v.is_nan()).count(), 12);
        // Odd, uneven, too large or growing differences are not crops.
        assert!(embed_cropped(&est, 5, 5).is_none());
        assert!(embed_cropped(&est, 4, 6).is_none());
        assert!(embed_cropped(
            &est,
            2 + 2 * (metrics::BORDER + 1),
            2 + 2 * (metrics::BORDER + 1)
        )
        .is_none());
        assert!(embed_cropped(&Pfm::new(4, 4, vec![0.0; 16]).unwrap(), 2, 2).is_none());
    }
}
