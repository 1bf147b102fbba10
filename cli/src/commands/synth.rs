//! `lfdepth synth`: a synthetic light field with exact ground truth, written in the HCI
//! layout (`input_CamNNN.png`, `gt_disp_lowres.pfm`, `parameters.cfg`) plus, when the
//! views are misaligned, the true homographies in `homographies.txt`:
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
use lfdepth::synth::{self, Misalignment, SceneKind, SynthSpec};
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

/// Arguments of `lfdepth synth`.
#[derive(Debug, Args)]
pub struct SynthArgs {
    /// Scene: planes, slanted, spheres, occlusion, thin, low-texture or mixed.
    #[arg(long, value_name = "NAME", value_parser = parse_scene)]
    pub scene: SceneKind,
    /// Disparity range MIN..MAX in pixels between neighbouring views, within -4..4
    /// (default -1.5..1.5).
    #[arg(long, value_name = "A..B", value_parser = parse_range, allow_hyphen_values = true)]
    pub disparity_range: Option<Range>,
    /// Gaussian noise standard deviation in 8-bit grey levels.
    #[arg(long, value_name = "S", default_value_t = 0.0)]
    pub noise: f32,
    /// Per-view brightness/contrast change, relative (e.g. 0.05).
    #[arg(long, value_name = "P", default_value_t = 0.0)]
    pub photometric: f32,
    /// Misalign the views by small random homographies (written to homographies.txt).
    #[arg(long)]
    pub misalign: bool,
    /// View grid ROWSxCOLS.
    #[arg(long, value_name = "RxC", value_parser = parse_grid, default_value = "9x9")]
    pub grid: Grid,
    /// View size WIDTHxHEIGHT (or one number for square views).
    #[arg(long, value_name = "WxH", value_parser = parse_size, default_value = "256")]
    pub size: (usize, usize),
    /// Write gray (1-channel) views instead of RGB.
    #[arg(long)]
    pub gray: bool,
    /// Random seed (texture, noise, misalignment).
    #[arg(long, value_name = "N", default_value_t = 1)]
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
        let names: Vec<&str> = SceneKind::ALL.iter().map(|k| k.name()).collect();
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

/// The specification these arguments ask for.
pub fn spec(args: &SynthArgs) -> SynthSpec {
    let (width, height) = args.size;
    let mut spec = SynthSpec::new(args.scene, args.grid, width, height);
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
    SceneConfig {
        image_resolution_x_px: Some(spec.width),
        image_resolution_y_px: Some(spec.height),
        num_cams_x: Some(spec.grid.cols),
        num_cams_y: Some(spec.grid.rows),
        disp_min: Some(f64::from(spec.disparity_min)),
        disp_max: Some(f64::from(spec.disparity_max)),
        other: vec![
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
        ],
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
    let spec = spec(args);
    check_spec(&spec, &args.limits.limits(), "--size")?;
    let kept = prepare_folder(&args.out, args.force)?;
    let rendered = render(&spec)?;
    write_scene(&args.out, &spec, &rendered)?;
    if args.force {
        // Files of an earlier scene that this one did not replace (views beyond its
        // grid, homographies of a misaligned one) would make the folder inconsistent.
        for name in entry_names(&args.out)? {
            let view = name
                .strip_prefix("input_Cam")
                .and_then(|n| n.strip_suffix(".png"))
                .and_then(|d| d.parse::<usize>().ok());
            let stale = match view {
                Some(i) => i >= spec.grid.len(),
                None => name == HOMOGRAPHIES_FILE && spec.misalign.is_none(),
            };
            if stale && is_synth_file(&name) {
                let path = args.out.join(&name);
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
    let (min, max) = crate::colormap::finite_range(&rendered.gt).unwrap_or((0.0, 0.0));
    println!(
        "wrote {}: {} {}x{} views of {}x{}, disparity {min:.3}..{max:.3}{}",
        args.out.display(),
        spec.scene.name(),
        spec.grid.rows,
        spec.grid.cols,
        spec.width,
        spec.height,
        if spec.misalign.is_some() {
            ", misaligned (see homographies.txt)"
        } else {
            ""
        }
    );
    Ok(())
}
