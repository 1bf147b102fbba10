//! The `lfdepth` command line: argument definitions (clap derive) and dispatch.

pub mod demo;
pub mod estimate;
pub mod eval;
pub mod outputs;
pub mod params;
pub mod synth;

use std::fmt;
use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};
use lfdepth::Grid;

use crate::engine::{Precision, Stages};
use crate::io::limits::{self, Limits};
use crate::io::IoError;

/// Dense disparity (depth) from light fields: EPI structure tensor + weighted
/// total-variation refinement.
#[derive(Debug, Parser)]
#[command(name = "lfdepth", version, propagate_version = true)]
#[command(after_help = "Run `lfdepth demo` for a self-contained example.")]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands. Each takes negative numbers as values (`--tv-tolerance -1`), so the
/// option's own range check answers them instead of clap's "unexpected argument".
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a synthetic light field, estimate its disparity and score it against the
    /// exact ground truth.
    #[command(allow_negative_numbers = true)]
    Demo(demo::DemoArgs),
    /// Estimate the disparity of a light field's centre view from a folder of views.
    #[command(allow_negative_numbers = true)]
    Estimate(estimate::EstimateArgs),
    /// Score disparity maps with the HCI benchmark metrics (one map, or a whole dataset).
    #[command(allow_negative_numbers = true)]
    Eval(eval::EvalArgs),
    /// Write a synthetic light field with exact ground truth in the HCI layout.
    #[command(allow_negative_numbers = true)]
    Synth(synth::SynthArgs),
}

/// How views are found in an input folder.
#[derive(Clone, Debug, Default, Args)]
pub struct ViewArgs {
    /// View file names, e.g. `2067_{row:02}_{col:02}.png` or `input_Cam{index:03}.png`
    /// ({row}/{col} or {index}, 0- or 1-based; `:0N` = exactly N digits). Detected when
    /// left out (input_CamNNN.png or NAME_RR_CC.png).
    #[arg(long, value_name = "PATTERN")]
    pub pattern: Option<String>,
    /// View grid as ROWSxCOLS (e.g. 9x9); default from parameters.cfg or the file names
    /// (the largest row and column, or for views numbered by index the smallest square
    /// holding the highest index). Views no chosen stage reads may be absent. A single
    /// row or column of cameras (1xN, Nx1) is refused: the estimator needs at least 3x3.
    #[arg(long, value_name = "RxC", value_parser = parse_grid)]
    pub grid: Option<Grid>,
}

impl ViewArgs {
    /// The scene-loading options these flags ask for.
    pub fn load_options(&self) -> crate::io::scene::LoadOptions {
        crate::io::scene::LoadOptions {
            pattern: self.pattern.clone(),
            grid: self.grid,
        }
    }
}

/// Caps on what is decoded or rendered (defaults and reasons in [`crate::io::limits`]).
#[derive(Clone, Copy, Debug, Args)]
pub struct LimitArgs {
    /// Most pixels one view may have; the default 64Mi is 8192x8192 (counts take the
    /// suffixes K, M, G or Ki, Mi, Gi). A larger view is refused before any of its pixels
    /// is decoded (from the PNG header) or rendered.
    #[arg(long, value_name = "N", default_value = "64Mi", value_parser = limits::parse_count)]
    pub max_view_pixels: u64,
    /// Most pixels of all views together; the default 512Mi holds e.g. 17x17 views of
    /// 1536x1152. Loading needs about 6 bytes per pixel for 8-bit RGB views, 18 for
    /// 16-bit.
    #[arg(long, value_name = "N", default_value = "512Mi", value_parser = limits::parse_count)]
    pub max_pixels: u64,
}

impl LimitArgs {
    /// The caps these flags set.
    pub fn limits(&self) -> Limits {
        Limits {
            max_view_pixels: self.max_view_pixels,
            max_pixels: self.max_pixels,
        }
    }
}

/// Most worker threads `--threads` takes: far more than any machine's cores, so the
/// cap only stops a mistyped count from spending minutes starting threads.
pub const MAX_THREADS: usize = 256;

/// `--threads N` → `N` in `1..=MAX_THREADS`.
pub fn parse_threads(text: &str) -> Result<u16, String> {
    match text.trim().parse::<i64>() {
        Ok(n) if (1..=MAX_THREADS as i64).contains(&n) => Ok(n as u16),
        Ok(n) => Err(format!(
            "{n} worker threads: give 1 to {MAX_THREADS} (results are identical for any count)"
        )),
        Err(_) => Err(format!(
            "`{text}` is not a number of worker threads: give 1 to {MAX_THREADS}"
        )),
    }
}

/// How far the pipeline runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum Stage {
    /// The initial disparity only (the plane sweep, or the EPI stage with `--initial epi`).
    Epi,
    /// The initial disparity refined through every later stage down to TV.
    #[default]
    Full,
}

impl From<Stage> for Stages {
    fn from(s: Stage) -> Self {
        match s {
            Stage::Epi => Stages::Epi,
            Stage::Full => Stages::Full,
        }
    }
}

/// The number type every stage computes in (`--scalar`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum ScalarArg {
    /// IEEE single precision.
    #[default]
    F32,
    /// Q16.16 fixed point, as firmware without an FPU runs it.
    Q16,
}

impl From<ScalarArg> for Precision {
    fn from(s: ScalarArg) -> Self {
        match s {
            ScalarArg::F32 => Precision::F32,
            ScalarArg::Q16 => Precision::Q16,
        }
    }
}

/// `RxC` → grid.
pub fn parse_grid(text: &str) -> Result<Grid, String> {
    let (r, c) = text
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("`{text}` is not ROWSxCOLS (e.g. 9x9)"))?;
    let parse = |s: &str| {
        s.trim()
            .parse::<usize>()
            .map_err(|_| format!("`{text}` is not ROWSxCOLS (e.g. 9x9)"))
    };
    Ok(Grid::new(parse(r)?, parse(c)?))
}

/// `WxH` or `N` (square) → (width, height).
pub fn parse_size(text: &str) -> Result<(usize, usize), String> {
    let bad = || format!("`{text}` is not WIDTHxHEIGHT or a single size (e.g. 256x192 or 256)");
    let parse = |s: &str| s.trim().parse::<usize>().map_err(|_| bad());
    match text.split_once(['x', 'X']) {
        Some((w, h)) => Ok((parse(w)?, parse(h)?)),
        None => {
            let n = parse(text)?;
            Ok((n, n))
        }
    }
}

/// A disparity range `A..B` (pixels between neighbouring views).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    /// Smallest disparity.
    pub min: f32,
    /// Largest disparity.
    pub max: f32,
}

/// `A..B` → range with `A < B`, both finite.
pub fn parse_range(text: &str) -> Result<Range, String> {
    let bad = || format!("`{text}` is not a range MIN..MAX (e.g. -2..2)");
    let (a, b) = text.split_once("..").ok_or_else(bad)?;
    let min: f32 = a.trim().parse().map_err(|_| bad())?;
    let max: f32 = b.trim().parse().map_err(|_| bad())?;
    if !(min.is_finite() && max.is_finite() && min < max) {
        return Err(format!("range `{text}` needs finite MIN < MAX"));
    }
    Ok(Range { min, max })
}

/// Everything a command can fail with; the message says what to change.
#[derive(Debug)]
pub enum CliError {
    /// Reading or writing a file.
    Io(IoError),
    /// The core refused; `context` says doing what.
    Core {
        /// What was being done.
        context: String,
        /// Why it failed.
        source: lfdepth::Error,
    },
    /// Inconsistent arguments.
    Usage(String),
}

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CliError::Io(e) => write!(f, "{e}"),
            CliError::Core { context, source } => write!(f, "{context}: {source}"),
            CliError::Usage(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for CliError {}

impl From<IoError> for CliError {
    fn from(e: IoError) -> Self {
        CliError::Io(e)
    }
}

impl CliError {
    /// A core error while doing `context`.
    pub fn core(context: impl Into<String>, source: lfdepth::Error) -> Self {
        CliError::Core {
            context: context.into(),
            source,
        }
    }
}

/// Runs one command.
pub fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Demo(args) => demo::run(&args),
        Command::Estimate(args) => estimate::run(&args),
        Command::Eval(args) => eval::run(&args),
        Command::Synth(args) => synth::run(&args),
    }
}

/// Creates an output folder (and its parents).
pub fn create_dir(dir: &std::path::Path) -> Result<PathBuf, CliError> {
    std::fs::create_dir_all(dir).map_err(|e| IoError::os(dir, "create", e))?;
    Ok(dir.to_path_buf())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    #[test]
    fn arguments_are_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn value_parsers() {
        assert_eq!(parse_grid("9x7"), Ok(Grid::new(9, 7)));
        assert!(parse_grid("9").is_err());
        assert_eq!(parse_size("256"), Ok((256, 256)));
        assert_eq!(parse_size("320x200"), Ok((320, 200)));
        assert_eq!(
            parse_range("-1.5..2"),
            Ok(Range {
                min: -1.5,
                max: 2.0
            })
        );
        assert!(parse_range("2..-1").is_err());
        assert!(parse_range("nan..1").is_err());
        assert_eq!(parse_threads("256"), Ok(256));
        assert!(parse_threads("0").is_err());
        assert!(parse_threads("-1").is_err());
        assert!(parse_threads("10000").is_err());
    }
}
