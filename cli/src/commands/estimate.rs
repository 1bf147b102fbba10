//! `lfdepth estimate`: disparity of a light field's centre view from a folder of views.

use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;
use lfdepth::LightField;

use super::outputs::Outputs;
use super::params::ParamArgs;
use super::{CliError, LimitArgs, ScalarArg, Stage, ViewArgs};
use crate::colormap;
use crate::engine::{Estimate, EstimateOptions, Precision, Runner};
use crate::io::scene::{self, Scene, Views};
use crate::io::{formats, needs, pfm, png};
use crate::progress::StageProgress;
use crate::report;

/// Arguments of `lfdepth estimate`.
#[derive(Debug, Args)]
pub struct EstimateArgs {
    /// Folder holding the views: an HCI scene folder or NAME_RR_CC.png files (PNG, JPEG
    /// or TIFF). Only the views the chosen stages read must exist: the centre row and
    /// column of the grid (and the refinement's views when they reach further).
    #[arg(value_name = "INPUT")]
    pub input: PathBuf,
    /// Disparity map to write, in the container its extension names: .pfm (one channel,
    /// rows bottom-to-top; also a name without extension), .tif/.tiff (32-bit float
    /// TIFF) or .exr (OpenEXR, one 32-bit float channel Y); another extension is refused.
    #[arg(short, long, value_name = "OUT.pfm")]
    pub output: PathBuf,
    /// Also write the disparity as a colour PNG with a legend bar.
    #[arg(long, value_name = "OUT.png")]
    pub png: Option<PathBuf>,
    /// Disparity range MIN..MAX of the colour PNG and the 16-bit PNG (default: the
    /// map's own finite range), e.g. to compare several maps.
    #[arg(long, value_name = "A..B", value_parser = super::parse_range, allow_hyphen_values = true)]
    pub png_range: Option<super::Range>,
    /// Also write the disparity as 16-bit gray PNG (MIN..MAX → 0..65535, MIN..MAX
    /// from --png-range or the map; the range is stored in its text chunks).
    #[arg(long, value_name = "OUT.png")]
    pub png16: Option<PathBuf>,
    /// Also write depth in metres (PFM; float TIFF for .tif, OpenEXR for .exr) from parameters.cfg with the HCI formula
    /// z = b·f·D / (d·D + b·f); NaN where the disparity lies at or beyond infinity.
    #[arg(long, value_name = "DEPTH.pfm")]
    pub depth: Option<PathBuf>,
    /// Also write the per-pixel confidence in [0, 1] (PFM; float TIFF for .tif, OpenEXR for .exr).
    #[arg(long, value_name = "CONF.pfm")]
    pub confidence: Option<PathBuf>,
    /// How far to run: `epi` (the initial disparity, from the start `--initial` chooses)
    /// or `full` (through every later stage down to TV).
    #[arg(long, value_enum, default_value_t = Stage::Full)]
    pub stage: Stage,
    /// Number type of every stage: `f32` or `q16` (Q16.16 fixed point).
    #[arg(long, value_enum, default_value_t = ScalarArg::F32)]
    pub scalar: ScalarArg,
    /// Worker threads, 1 to 256 (default: every core).
    #[arg(long, value_name = "N", value_parser = super::parse_threads)]
    pub threads: Option<u16>,
    /// Where and how the views are named.
    #[command(flatten)]
    pub views: ViewArgs,
    /// Caps on the size of the views.
    #[command(flatten)]
    pub limits: LimitArgs,
    /// Estimator parameters.
    #[command(flatten)]
    pub params: ParamArgs,
    /// No progress bar.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Runs the engine on a loaded scene, whatever its sample type, computing in `precision`
/// on `runner`'s threads.
pub fn estimate_scene(
    scene: &Scene,
    runner: &Runner,
    precision: Precision,
    progress: &mut dyn FnMut(&str, u64, u64),
) -> Result<Estimate, CliError> {
    let context = || format!("estimating {}", scene.dir().display());
    let present = &scene.decoded;
    let result = match &scene.views {
        Views::U8(data) => LightField::new(data, scene.layout)
            .and_then(|lf| runner.estimate(&lf, precision, present, progress)),
        Views::F32(data) => LightField::new(data, scene.layout)
            .and_then(|lf| runner.estimate(&lf, precision, present, progress)),
    };
    result.map_err(|e| CliError::core(context(), e))
}

/// Writes a colour PNG with legend over the finite range of `values`.
pub fn write_colour_png(
    path: &Path,
    width: usize,
    height: usize,
    values: &[f32],
    range: Option<(f32, f32)>,
) -> Result<(), CliError> {
    let (min, max) = range
        .or_else(|| colormap::finite_range(values))
        .unwrap_or((0.0, 1.0));
    let img = colormap::with_legend(width, height, values, min, max);
    png::write_rgb8(path, img.width, img.height, &img.pixels)?;
    Ok(())
}

/// Compares the image resolution `parameters.cfg` states with the views' size. Metric
/// depth takes its focal length in pixels from the cfg's resolution, so with `--depth`
/// a mismatch is refused (the depth would be off by the ratio); without it the
/// disparity is unaffected and a warning is printed.
fn check_config_resolution(
    config: &crate::io::cfg::SceneConfig,
    input: &Path,
    width: usize,
    height: usize,
    depth: bool,
) -> Result<(), CliError> {
    let (Some(x), Some(y)) = (config.image_resolution_x_px, config.image_resolution_y_px) else {
        return Ok(());
    };
    if (x, y) == (width, height) {
        return Ok(());
    }
    let cfg = input.join(scene::CONFIG_FILE);
    let what = format!(
        "{}: image_resolution_x_px/y_px say {x}x{y} pixels but the views are {width}x{height}",
        cfg.display()
    );
    if depth {
        return Err(CliError::Usage(format!(
            "{what}: --depth would scale the focal length by the wrong resolution (depth off by up to {:.1} %); correct the file's resolution (and focal length, if the views were resized) or leave out --depth",
            100.0 * ((x.max(y) as f64) / (width.max(height) as f64) - 1.0).abs()
        )));
    }
    eprintln!("warning: {what}; the disparity does not depend on it, but metric depth from this file would be wrong");
    Ok(())
}

/// Runs `lfdepth estimate`. Everything that can be checked without the views' pixels
/// (outputs, parameters) is checked before they are decoded.
pub fn run(args: &EstimateArgs) -> Result<(), CliError> {
    let start = Instant::now();
    let outputs = Outputs::new(&[
        ("-o", Some(args.output.as_path())),
        ("--png", args.png.as_deref()),
        ("--png16", args.png16.as_deref()),
        ("--depth", args.depth.as_deref()),
        ("--confidence", args.confidence.as_deref()),
    ])?;
    let files = scene::locate(&args.input, &args.views.load_options())?;
    outputs.refuse_inputs(&files)?;
    outputs.check_writable()?;
    for (flag, path) in [
        ("-o", Some(&args.output)),
        ("--confidence", args.confidence.as_ref()),
        ("--depth", args.depth.as_ref()),
    ] {
        if let Some(path) = path {
            formats::map_format(path).map_err(|e| CliError::Usage(format!("{flag}: {e}")))?;
        }
    }
    let config = files.config.as_ref();
    if args.depth.is_some() && config.and_then(|c| c.depth_m(0.0)).is_none() {
        return Err(CliError::Usage(format!(
            "--depth needs {} with focal_length_mm, sensor_size_mm, image_resolution_x_px/y_px, baseline_mm and focus_distance_m",
            args.input.join(scene::CONFIG_FILE).display()
        )));
    }
    let params = args.params.params(config)?;
    if let Some(note) = &files.grid_note {
        eprintln!("note: {note}");
    }
    if let Some(note) = scene::linear_note(files.grid) {
        eprintln!("note: {note}");
    }
    let needs = needs::views_to_read(&files, &params, args.stage.into())?;
    let summary = needs.summary(&files);
    // One pool for the whole run: the views are decoded on the threads the stages run on.
    let runner = Runner::new(EstimateOptions {
        params,
        stage: args.stage.into(),
        threads: args.threads.map(usize::from),
    })
    .map_err(|e| CliError::core("starting the worker threads", e))?;
    let scene =
        runner.install(|| scene::read_selected(files, &args.limits.limits(), &needs.wanted))?;
    let load_time = start.elapsed();
    let l = scene.layout;
    eprintln!(
        "{}: {}x{} views of {}x{} pixels ({})",
        args.input.display(),
        l.grid.rows,
        l.grid.cols,
        l.width,
        l.height,
        match scene.views {
            Views::U8(_) => "8-bit",
            Views::F32(_) => "16-bit",
        }
    );
    eprintln!("{summary}");
    let config = scene.files.config.as_ref();
    if let Some(config) = config {
        check_config_resolution(config, &args.input, l.width, l.height, args.depth.is_some())?;
    }
    let mut bar = StageProgress::new(args.quiet);
    let result = estimate_scene(&scene, &runner, args.scalar.into(), &mut |s, d, t| {
        bar.update(s, d, t)
    });
    bar.finish();
    let estimate = result?;
    super::params::print_alignment(estimate.align.as_ref());
    let (w, h) = (estimate.width, estimate.height);
    formats::write_map(
        &args.output,
        &pfm::Pfm::new(w, h, estimate.disparity.clone())?,
    )?;
    if let Some(path) = &args.confidence {
        formats::write_map(path, &pfm::Pfm::new(w, h, estimate.confidence.clone())?)?;
    }
    if let (Some(path), Some(config)) = (&args.depth, config) {
        let depth = estimate
            .disparity
            .iter()
            .map(|&d| config.depth_m(f64::from(d)).map_or(f32::NAN, |z| z as f32))
            .collect();
        formats::write_map(path, &pfm::Pfm::new(w, h, depth)?)?;
    }
    if let Some(path) = &args.png {
        let range = args.png_range.map(|r| (r.min, r.max));
        write_colour_png(path, w, h, &estimate.disparity, range)?;
    }
    if let Some(path) = &args.png16 {
        let (min, max) = args
            .png_range
            .map(|r| (r.min, r.max))
            .or_else(|| colormap::finite_range(&estimate.disparity))
            .unwrap_or((0.0, 1.0));
        png::write_disparity16(path, w, h, &estimate.disparity, min, max)?;
    }
    let mut stages = vec![("load", load_time)];
    stages.extend(estimate.timings.iter().copied());
    print!("{}", report::timings(&stages));
    Ok(())
}
