//! `lfdepth synth`: a synthetic light field with exact ground truth, written in the HCI
//! layout (`input_CamNNN.png`, `gt_disp_lowres.pfm`, `parameters.cfg`) plus, for the
//! realistic scenes, region masks (`mask_floor.png`, …, see [`REGION_MASKS`]) and, when
//! the views are misaligned, the true homographies in `homographies.txt`:
//!
//! ```text
//! # lfdepth synth: per view, the homography mapping rectified (ideal) view pixel
//! # coordinates (x, y, 1) to the misaligned view's pixel coordinates, row-major.
//! # row col h00 h01 h02 h10 h11 h12 h20 h21 h22
//! 0 0 1.0001 …
//! ```

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use clap::Args;
use lfdepth::synth::{self, region, Misalignment, SceneKind, SynthSpec, REALISTIC_SUITE};
use lfdepth::{Grid, Homography};
use rayon::prelude::*;

use super::{create_dir, parse_grid, parse_range, parse_size, CliError, LimitArgs, Range};
use crate::io::cfg::{self, SceneConfig};
use crate::io::limits::Limits;
use crate::io::output::check_folder_writable;
use crate::io::pfm::{self, Pfm};
use crate::io::png::{self, Image, Samples};
use crate::io::scene::{CONFIG_FILE, GROUND_TRUTH_FILE};
use crate::io::write_bytes;

/// The file holding the true homographies of a misaligned synthetic light field.
pub const HOMOGRAPHIES_FILE: &str = "homographies.txt";

/// The masks written beside a realistic scene, and the region each marks: pixels whose
/// visible surface has the region flag (`slope`: where the ground truth's gradient
/// exceeds [`STEEP_SLOPE`] away from depth steps).
pub const REGION_MASKS: [(&str, Option<u8>); 5] = [
    ("mask_floor.png", Some(region::FLOOR)),
    ("mask_dim.png", Some(region::DIM)),
    ("mask_relief.png", Some(region::RELIEF)),
    ("mask_thin.png", Some(region::THIN)),
    ("mask_slope.png", None),
];

/// |∇d| (px per px) above which a pixel counts as steeply slanted.
pub const STEEP_SLOPE: f32 = 0.02;
/// A difference between 4-neighbours above this (px) is a depth step, not a slope.
pub const DEPTH_STEP: f32 = 0.25;

/// The named scene suites of `--suite`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Suite {
    /// Rooms with receding floors, dim walls, fine relief and thin structures, up to
    /// ±4 px, through a noisy vignetting sensor (hall, corridor, tabletop, dusk, relief).
    Realistic,
}

/// Arguments of `lfdepth synth`.
#[derive(Debug, Args)]
pub struct SynthArgs {
    /// Scene: planes, slanted, spheres, occlusion, thin, low-texture, mixed, or one of the
    /// realistic scenes hall, corridor, tabletop, dusk, relief (with an ideal sensor and
    /// the default range; `--suite realistic` renders them as the suite defines them).
    #[arg(
        long,
        value_name = "NAME",
        value_parser = parse_scene,
        required_unless_present = "suite",
        conflicts_with = "suite"
    )]
    pub scene: Option<SceneKind>,
    /// Write every scene of a suite into its own folder under --out (`realistic`: 512x512
    /// views unless --size, each with its own disparity range, seed and sensor noise).
    #[arg(long, value_enum, value_name = "NAME")]
    pub suite: Option<Suite>,
    /// Disparity range MIN..MAX in pixels between neighbouring views, within -4..4
    /// (default -1.5..1.5).
    #[arg(long, value_name = "A..B", value_parser = parse_range, allow_hyphen_values = true, conflicts_with = "suite")]
    pub disparity_range: Option<Range>,
    /// Gaussian noise standard deviation in 8-bit grey levels.
    #[arg(
        long,
        value_name = "S",
        default_value_t = 0.0,
        conflicts_with = "suite"
    )]
    pub noise: f32,
    /// Per-view brightness/contrast change, relative (e.g. 0.05).
    #[arg(
        long,
        value_name = "P",
        default_value_t = 0.0,
        conflicts_with = "suite"
    )]
    pub photometric: f32,
    /// Misalign the views by small random homographies (written to homographies.txt).
    #[arg(long, conflicts_with = "suite")]
    pub misalign: bool,
    /// View grid ROWSxCOLS.
    #[arg(long, value_name = "RxC", value_parser = parse_grid, default_value = "9x9", conflicts_with = "suite")]
    pub grid: Grid,
    /// View size WIDTHxHEIGHT (or one number for square views; default 256, 512 for
    /// --suite).
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    pub size: Option<(usize, usize)>,
    /// Write gray (1-channel) views instead of RGB.
    #[arg(long, conflicts_with = "suite")]
    pub gray: bool,
    /// Random seed (texture, noise, misalignment).
    #[arg(long, value_name = "N", default_value_t = 1, conflicts_with = "suite")]
    pub seed: u64,
    /// Output folder (created if needed). It must be empty unless --force is given.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Write into a folder that is not empty: the files synth writes
    /// (input_CamNNN.png, gt_disp_lowres.pfm, parameters.cfg, homographies.txt) are
    /// replaced and those of an earlier, larger scene removed; every other file is kept.
    #[arg(long)]
    pub force: bool,
    /// Caps on the size of the light field (9x9 views of 256x256 are 5308416 pixels).
    #[command(flatten)]
    pub limits: LimitArgs,
}

/// Scene name → kind, listing the names on error.
pub fn parse_scene(name: &str) -> Result<SceneKind, String> {
    SceneKind::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = SceneKind::ALL
            .iter()
            .chain(&SceneKind::REALISTIC)
            .map(|k| k.name())
            .collect();
        format!("unknown scene `{name}`: use one of {}", names.join(", "))
    })
}

/// The misalignment `--misalign` applies: what a hand-held or loosely calibrated rig
/// shows after nominal rectification.
pub fn default_misalignment() -> Misalignment {
    Misalignment {
        max_rotation_deg: 0.5,
        max_translation_px: 2.0,
        max_scale: 0.01,
        max_perspective: 0.002,
    }
}

/// The specification these arguments ask for with `--scene` (`kind`).
pub fn spec(args: &SynthArgs, kind: SceneKind) -> SynthSpec {
    let (width, height) = args.size.unwrap_or((256, 256));
    let mut spec = SynthSpec::new(kind, args.grid, width, height);
    if let Some(r) = args.disparity_range {
        spec.disparity_min = r.min;
        spec.disparity_max = r.max;
    }
    spec.channels = if args.gray { 1 } else { 3 };
    spec.noise_sigma = args.noise;
    spec.photometric = args.photometric;
    spec.misalign = args.misalign.then(default_misalignment);
    spec.seed = args.seed;
    spec
}

/// A rendered light field held in memory.
pub struct Rendered {
    /// Packed u8 views (`spec.layout()`).
    pub views: Vec<u8>,
    /// Exact centre-view disparity, row-major.
    pub gt: Vec<f32>,
    /// Per view, rectified → misaligned pixel coordinates.
    pub homographies: Vec<Homography>,
}

/// Renders a specification, one view per task in parallel (the same bytes as the
/// serial `synth::render`).
pub fn render(spec: &SynthSpec) -> Result<Rendered, CliError> {
    let fail = |e| CliError::core("rendering the synthetic light field", e);
    spec.validate().map_err(fail)?;
    let layout = spec.layout();
    let total = layout.validate().map_err(fail)?;
    let mut views = vec![0u8; total];
    let mut gt = vec![0f32; layout.pixels()];
    let cols = layout.grid.cols;
    views
        .par_chunks_mut(layout.view_stride)
        .enumerate()
        .try_for_each(|(i, view)| synth::render_view(spec, i / cols, i % cols, view))
        .map_err(fail)?;
    synth::render_ground_truth(spec, &mut gt).map_err(fail)?;
    let homographies = (0..layout.grid.len())
        .map(|i| synth::view_homography(spec, i / cols, i % cols))
        .collect::<Result<Vec<_>, _>>()
        .map_err(fail)?;
    Ok(Rendered {
        views,
        gt,
        homographies,
    })
}

/// The `parameters.cfg` of a synthetic light field.
pub fn config(spec: &SynthSpec) -> SceneConfig {
    let meta = |k: &str, v: String| ("meta".to_string(), k.to_string(), v);
    let mut other = vec![
        meta("scene", spec.scene.name().to_string()),
        meta("category", "synthetic".into()),
        meta(
            "generator",
            format!("lfdepth synth {}", env!("CARGO_PKG_VERSION")),
        ),
        meta("seed", spec.seed.to_string()),
        meta("noise_sigma", spec.noise_sigma.to_string()),
        meta("photometric", spec.photometric.to_string()),
        meta("misaligned", spec.misalign.is_some().to_string()),
    ];
    if let Some(s) = spec.sensor {
        other.push(meta(
            "sensor",
            format!(
                "read noise {} levels, shot noise {} levels^2/level, vignetting {}",
                s.read_noise, s.shot_noise, s.vignetting
            ),
        ));
    }
    SceneConfig {
        image_resolution_x_px: Some(spec.width),
        image_resolution_y_px: Some(spec.height),
        num_cams_x: Some(spec.grid.cols),
        num_cams_y: Some(spec.grid.rows),
        disp_min: Some(f64::from(spec.disparity_min)),
        disp_max: Some(f64::from(spec.disparity_max)),
        other,
        ..SceneConfig::default()
    }
}

/// The text of `homographies.txt` (format in the module docs).
pub fn homographies_text(grid: Grid, homographies: &[Homography]) -> String {
    let mut out = String::from(
        "# lfdepth synth: per view, the homography mapping rectified (ideal) view pixel\n\
         # coordinates (x, y, 1) to the misaligned view's pixel coordinates, row-major.\n\
         # row col h00 h01 h02 h10 h11 h12 h20 h21 h22\n",
    );
    for (i, h) in homographies.iter().enumerate() {
        let _ = write!(out, "{} {}", i / grid.cols.max(1), i % grid.cols.max(1));
        for v in h.m {
            let _ = write!(out, " {v:e}");
        }
        out.push('\n');
    }
    out
}

/// Writes a rendered light field to `dir` in the HCI layout.
pub fn write_scene(dir: &Path, spec: &SynthSpec, rendered: &Rendered) -> Result<(), CliError> {
    create_dir(dir)?;
    let layout = spec.layout();
    rendered
        .views
        .par_chunks(layout.view_stride)
        .enumerate()
        .try_for_each(|(i, view)| {
            let image = Image {
                width: layout.width,
                height: layout.height,
                channels: layout.channels,
                samples: Samples::Eight(view.to_vec()),
            };
            png::write(&dir.join(format!("input_Cam{i:03}.png")), &image)
        })?;
    pfm::write(
        &dir.join(GROUND_TRUTH_FILE),
        &Pfm::new(layout.width, layout.height, rendered.gt.clone())?,
    )?;
    cfg::save(&dir.join(CONFIG_FILE), &config(spec))?;
    if SceneKind::REALISTIC.contains(&spec.scene) {
        let fail = |e| CliError::core("rendering the region map", e);
        let mut regions = vec![0u8; layout.pixels()];
        synth::render_regions(spec, &mut regions).map_err(fail)?;
        let steep = steep_pixels(&rendered.gt, layout.width, layout.height);
        for (name, flag) in REGION_MASKS {
            let samples = match flag {
                Some(f) => regions
                    .iter()
                    .map(|&r| if r & f != 0 { 255 } else { 0 })
                    .collect(),
                None => steep.iter().map(|&s| if s { 255 } else { 0 }).collect(),
            };
            let image = Image {
                width: layout.width,
                height: layout.height,
                channels: 1,
                samples: Samples::Eight(samples),
            };
            png::write(&dir.join(name), &image)?;
        }
    }
    if spec.misalign.is_some() {
        let path = dir.join(HOMOGRAPHIES_FILE);
        write_bytes(
            &path,
            homographies_text(layout.grid, &rendered.homographies).as_bytes(),
        )?;
    }
    Ok(())
}

/// Checks a specification, and its size against `limits`, before anything of that size
/// is allocated; `flag` is the option that set the size.
pub fn check_spec(spec: &SynthSpec, limits: &Limits, flag: &str) -> Result<(), CliError> {
    spec.validate()
        .map_err(|e| CliError::core("rendering the synthetic light field", e))?;
    limits
        .check_light_field(spec.grid.len(), spec.width, spec.height)
        .map_err(|e| CliError::Usage(format!("{flag}: {e}")))
}

/// Whether `name` is a file `synth` writes: a view `input_CamNNN.png`, the ground
/// truth, the camera parameters or the homographies.
pub fn is_synth_file(name: &str) -> bool {
    let view = name
        .strip_prefix("input_Cam")
        .and_then(|n| n.strip_suffix(".png"))
        .is_some_and(|d| d.len() == 3 && d.bytes().all(|b| b.is_ascii_digit()));
    view || [GROUND_TRUTH_FILE, CONFIG_FILE, HOMOGRAPHIES_FILE].contains(&name)
        || REGION_MASKS.iter().any(|(mask, _)| *mask == name)
}

/// Upper bounds (px per px) of the slope classes [`slope_histogram`] counts; the last
/// class is everything steeper that is not a depth step.
pub const SLOPE_BINS: [f32; 3] = [0.005, STEEP_SLOPE, 0.05];

/// |∇d| of the ground truth at each pixel by central differences, `None` on the border
/// and next to a depth step (a 4-neighbour more than [`DEPTH_STEP`] away).
fn slopes(gt: &[f32], width: usize, height: usize) -> Vec<Option<f32>> {
    let at = |x: usize, y: usize| gt[y * width + x];
    let mut out = vec![None; gt.len()];
    for y in 1..height.saturating_sub(1) {
        for x in 1..width.saturating_sub(1) {
            let d = at(x, y);
            let neighbours = [at(x - 1, y), at(x + 1, y), at(x, y - 1), at(x, y + 1)];
            if neighbours.iter().any(|n| (n - d).abs() > DEPTH_STEP) {
                continue;
            }
            let gx = (neighbours[1] - neighbours[0]) / 2.0;
            let gy = (neighbours[3] - neighbours[2]) / 2.0;
            out[y * width + x] = Some((gx * gx + gy * gy).sqrt());
        }
    }
    out
}

/// Pixels whose ground-truth slope exceeds [`STEEP_SLOPE`] away from depth steps.
pub fn steep_pixels(gt: &[f32], width: usize, height: usize) -> Vec<bool> {
    slopes(gt, width, height)
        .into_iter()
        .map(|s| s.is_some_and(|s| s > STEEP_SLOPE))
        .collect()
}

/// Shares (percent of the pixels inside a 1-pixel border) of the ground truth's slope
/// classes: below each bound of [`SLOPE_BINS`], above the last, and depth steps.
pub fn slope_histogram(gt: &[f32], width: usize, height: usize) -> [f64; 5] {
    let mut counts = [0usize; 5];
    let mut total = 0usize;
    let slopes = slopes(gt, width, height);
    for y in 1..height.saturating_sub(1) {
        for x in 1..width.saturating_sub(1) {
            total += 1;
            let class = match slopes[y * width + x] {
                None => 4,
                Some(s) => SLOPE_BINS.iter().position(|&b| s < b).unwrap_or(3),
            };
            counts[class] += 1;
        }
    }
    counts.map(|c| 100.0 * c as f64 / total.max(1) as f64)
}

/// One line of ground-truth statistics: range and slope histogram.
pub fn gt_statistics(gt: &[f32], width: usize, height: usize) -> String {
    let (min, max) = crate::colormap::finite_range(gt).unwrap_or((0.0, 0.0));
    let h = slope_histogram(gt, width, height);
    format!(
        "disparity {min:.3}..{max:.3}; |grad d| (px/px) <0.005 {:.1} %, 0.005-0.02 {:.1} %, 0.02-0.05 {:.1} %, >=0.05 {:.1} %, depth steps {:.1} %",
        h[0], h[1], h[2], h[3], h[4]
    )
}

/// Names of the entries of `dir`, sorted.
fn entry_names(dir: &Path) -> Result<Vec<String>, CliError> {
    let list = |e| crate::io::IoError::os(dir, "list", e);
    let mut names = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(list)? {
        names.push(
            entry
                .map_err(list)?
                .file_name()
                .to_string_lossy()
                .into_owned(),
        );
    }
    names.sort();
    Ok(names)
}

/// A few names for a message.
fn some_names(names: &[String]) -> String {
    let mut s = names.iter().take(4).cloned().collect::<Vec<_>>().join(", ");
    if names.len() > 4 {
        s.push_str(&format!(" and {} more", names.len() - 4));
    }
    s
}

/// Makes sure `dir` can take a new light field: a new or empty folder, or with
/// `force` any folder. Creates it, checks that it takes files, and returns the names of
/// the files in it that synth does not write (they are kept).
fn prepare_folder(dir: &Path, force: bool) -> Result<Vec<String>, CliError> {
    if dir.exists() && !dir.is_dir() {
        return Err(CliError::Usage(format!(
            "--out {} is not a folder: give a new or empty folder",
            dir.display()
        )));
    }
    let names = if dir.is_dir() {
        entry_names(dir)?
    } else {
        Vec::new()
    };
    if !names.is_empty() && !force {
        return Err(CliError::Usage(format!(
            "--out {} is not empty ({}): give a new or empty folder, or --force to replace the files synth writes there and keep the others",
            dir.display(),
            some_names(&names)
        )));
    }
    create_dir(dir)?;
    check_folder_writable(dir, dir)?;
    Ok(names.into_iter().filter(|n| !is_synth_file(n)).collect())
}

/// Runs `lfdepth synth`.
pub fn run(args: &SynthArgs) -> Result<(), CliError> {
    match (args.scene, args.suite) {
        (_, Some(Suite::Realistic)) => run_suite(args),
        (Some(kind), None) => {
            let spec = spec(args, kind);
            write_one(&spec, &args.out, args, "--size")?;
            Ok(())
        }
        (None, None) => Err(CliError::Usage(
            "give --scene NAME or --suite realistic".into(),
        )),
    }
}

/// Writes every scene of the realistic suite into its own folder under `--out`, and
/// prints a table of their ground-truth statistics.
fn run_suite(args: &SynthArgs) -> Result<(), CliError> {
    let (width, height) = args.size.unwrap_or((512, 512));
    let specs: Vec<SynthSpec> = REALISTIC_SUITE
        .iter()
        .map(|s| s.spec(width, height))
        .collect();
    for spec in &specs {
        check_spec(spec, &args.limits.limits(), "--size")?;
    }
    prepare_folder(&args.out, args.force)?;
    let mut table = String::from(
        "| scene | disparity | <0.005 | 0.005-0.02 | 0.02-0.05 | >=0.05 | depth steps | floor | dim |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    for spec in &specs {
        let dir = args.out.join(spec.scene.name());
        let rendered = write_one(spec, &dir, args, "--size")?;
        let (min, max) = crate::colormap::finite_range(&rendered.gt).unwrap_or((0.0, 0.0));
        let h = slope_histogram(&rendered.gt, width, height);
        let mut regions = vec![0u8; width * height];
        synth::render_regions(spec, &mut regions)
            .map_err(|e| CliError::core("rendering the region map", e))?;
        let share = |flag: u8| {
            100.0 * regions.iter().filter(|&&r| r & flag != 0).count() as f64
                / regions.len().max(1) as f64
        };
        let _ = writeln!(
            table,
            "| {} | {min:.2}..{max:.2} | {:.1} % | {:.1} % | {:.1} % | {:.1} % | {:.1} % | {:.1} % | {:.1} % |",
            spec.scene.name(),
            h[0],
            h[1],
            h[2],
            h[3],
            h[4],
            share(region::FLOOR),
            share(region::DIM)
        );
    }
    println!("ground truth: share of pixels by |grad d| (px/px), floor and dim regions\n{table}");
    Ok(())
}

/// Renders `spec` into the folder `dir` (new or empty unless `--force`) and prints what
/// it wrote.
fn write_one(
    spec: &SynthSpec,
    dir: &Path,
    args: &SynthArgs,
    flag: &str,
) -> Result<Rendered, CliError> {
    check_spec(spec, &args.limits.limits(), flag)?;
    let kept = prepare_folder(dir, args.force)?;
    let rendered = render(spec)?;
    write_scene(dir, spec, &rendered)?;
    if args.force {
        // Files of an earlier scene that this one did not replace (views beyond its
        // grid, homographies of a misaligned one, masks of a realistic one) would make
        // the folder inconsistent.
        let realistic = SceneKind::REALISTIC.contains(&spec.scene);
        for name in entry_names(dir)? {
            let view = name
                .strip_prefix("input_Cam")
                .and_then(|n| n.strip_suffix(".png"))
                .and_then(|d| d.parse::<usize>().ok());
            let stale = match view {
                Some(i) => i >= spec.grid.len(),
                None => {
                    (name == HOMOGRAPHIES_FILE && spec.misalign.is_none())
                        || (!realistic && REGION_MASKS.iter().any(|(m, _)| *m == name))
                }
            };
            if stale && is_synth_file(&name) {
                let path = dir.join(&name);
                std::fs::remove_file(&path)
                    .map_err(|e| crate::io::IoError::os(&path, "remove", e))?;
            }
        }
        if !kept.is_empty() {
            eprintln!(
                "kept {} file(s) synth does not write: {}",
                kept.len(),
                some_names(&kept)
            );
        }
    }
    println!(
        "wrote {}: {} {}x{} views of {}x{}, {}{}",
        dir.display(),
        spec.scene.name(),
        spec.grid.rows,
        spec.grid.cols,
        spec.width,
        spec.height,
        gt_statistics(&rendered.gt, spec.width, spec.height),
        if spec.misalign.is_some() {
            ", misaligned (see homographies.txt)"
        } else {
            ""
        }
    );
    Ok(rendered)
}
