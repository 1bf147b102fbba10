//! Estimator parameters from the command line.

use clap::{Args, ValueEnum};
use lfdepth::align::{AlignMode, AlignReport};
use lfdepth::epi::DisparityRange;
use lfdepth::Params;

use super::{parse_range, CliError, Range};
use crate::io::cfg::SceneConfig;

/// Where the disparity search range comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RangeChoice {
    /// Estimated from the views.
    Auto,
    /// `disp_min..disp_max` of the scene's parameters.cfg.
    Config,
    /// Given explicitly.
    Fixed(Range),
}

/// `auto`, `cfg` or `A..B`.
pub fn parse_range_choice(text: &str) -> Result<RangeChoice, String> {
    match text {
        "auto" => Ok(RangeChoice::Auto),
        "cfg" => Ok(RangeChoice::Config),
        _ => parse_range(text)
            .map(RangeChoice::Fixed)
            .map_err(|e| format!("{e}, or `auto`, or `cfg`")),
    }
}

/// Whether to align the views before estimating (`--align`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum AlignChoice {
    /// Use the views as they are (the array is rectified).
    Off,
    /// Always estimate per-view homographies and warp the views into a rectified array;
    /// fails when a view cannot be aligned (textureless or too different).
    On,
    /// Check cheaply whether the array is rectified and align only if it is not; when
    /// alignment fails, warn and use the views as they are.
    #[default]
    Auto,
}

impl From<AlignChoice> for AlignMode {
    fn from(choice: AlignChoice) -> Self {
        match choice {
            AlignChoice::Off => AlignMode::Off,
            AlignChoice::On => AlignMode::On,
            AlignChoice::Auto => AlignMode::Auto,
        }
    }
}

/// Prints what the alignment did on stderr: auto mode's fallback as a warning, otherwise
/// one line (nothing when alignment was off).
pub fn print_alignment(report: Option<&AlignReport>) {
    let Some(report) = report else {
        return;
    };
    if let Some(warning) = &report.warning {
        eprintln!("warning: the views were not aligned (--align auto): {warning}");
    } else if report.skipped {
        eprintln!(
            "alignment: skipped, the array is rectified (residual {:.3} px with identity homographies)",
            report.identity_rms
        );
    } else {
        // Views outside the stages' reach keep the identity and no tracks.
        let aligned = report.views.iter().filter(|v| v.inliers > 0).count();
        eprintln!(
            "alignment: {aligned} views aligned, reprojection RMS {:.3} px ({:.3} px before)",
            report.rms, report.identity_rms
        );
    }
}

/// Estimator flags shared by `estimate` and `eval --dataset`.
#[derive(Clone, Debug, Args)]
pub struct ParamArgs {
    /// Disparity search range: MIN..MAX in pixels between neighbouring views (e.g.
    /// -2..2), `auto` (estimated from the views) or `cfg` (disp_min..disp_max from the
    /// scene's parameters.cfg).
    #[arg(long, value_name = "A..B|auto|cfg", default_value = "auto",
          value_parser = parse_range_choice, allow_hyphen_values = true)]
    pub disparity_range: RangeChoice,
    /// The paper's EPI variant: one unsheared EPI per direction instead of shear
    /// hypotheses over the range.
    #[arg(long)]
    pub no_shear: bool,
    /// TV refinement: weight λ of the total variation against the EPI data term
    /// (larger = smoother; default from the core).
    #[arg(long, value_name = "F", allow_hyphen_values = true)]
    pub lambda: Option<f32>,
    /// TV refinement: most PPXA iterations per tile (default from the core).
    #[arg(long, value_name = "N")]
    pub tv_iterations: Option<usize>,
    /// Align the views by per-view homographies first: `off`, `on`, or `auto` (only when
    /// the array is found not to be rectified).
    #[arg(long, value_enum, default_value_t = AlignChoice::Auto)]
    pub align: AlignChoice,
}

impl Default for ParamArgs {
    fn default() -> Self {
        ParamArgs {
            disparity_range: RangeChoice::Auto,
            no_shear: false,
            lambda: None,
            tv_iterations: None,
            align: AlignChoice::Auto,
        }
    }
}

impl ParamArgs {
    /// The parameters these flags ask for; `config` is the scene's parameters.cfg.
    pub fn params(&self, config: Option<&SceneConfig>) -> Result<Params, CliError> {
        let mut params = Params::default();
        params.align.mode = self.align.into();
        if self.no_shear {
            params.epi = lfdepth::epi::EpiParams::paper();
        }
        if let Some(lambda) = self.lambda {
            params.tv.lambda = lambda;
        }
        if let Some(n) = self.tv_iterations {
            params.tv.max_iterations = n;
        }
        // Out-of-range values are reported here, before any view is decoded.
        params
            .tv
            .validate()
            .map_err(|e| CliError::core("checking the TV flags", e))?;
        params.epi.range = match self.disparity_range {
            RangeChoice::Auto if self.no_shear => params.epi.range,
            RangeChoice::Auto => DisparityRange::Auto,
            RangeChoice::Fixed(r) => DisparityRange::Fixed {
                min: r.min,
                max: r.max,
            },
            RangeChoice::Config => {
                let (min, max) = config.and_then(SceneConfig::disparity_range).ok_or_else(|| {
                    CliError::Usage(
                        "--disparity-range cfg needs disp_min and disp_max in the scene's parameters.cfg: give MIN..MAX or auto instead".into(),
                    )
                })?;
                DisparityRange::Fixed {
                    min: min as f32,
                    max: max as f32,
                }
            }
        };
        params
            .epi
            .validate()
            .map_err(|e| CliError::core("checking --disparity-range", e))?;
        Ok(params)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn range_choices() {
        assert_eq!(parse_range_choice("auto"), Ok(RangeChoice::Auto));
        assert_eq!(parse_range_choice("cfg"), Ok(RangeChoice::Config));
        assert_eq!(
            parse_range_choice("-1..2"),
            Ok(RangeChoice::Fixed(Range {
                min: -1.0,
                max: 2.0
            }))
        );
        assert!(parse_range_choice("wide").is_err());
        let args = ParamArgs {
            disparity_range: RangeChoice::Config,
            ..ParamArgs::default()
        };
        assert!(args.params(None).is_err());
        let cfg = SceneConfig {
            disp_min: Some(-1.5),
            disp_max: Some(0.5),
            ..SceneConfig::default()
        };
        assert_eq!(
            args.params(Some(&cfg)).unwrap().epi.range,
            DisparityRange::Fixed {
                min: -1.5,
                max: 0.5
            }
        );
    }
}
