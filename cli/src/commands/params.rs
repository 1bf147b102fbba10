//! Estimator parameters from the command line.

use clap::{Args, ValueEnum};
use lfdepth::align::{AlignMode, AlignReport, AlignedViews, Interpolation};
use lfdepth::epi::{ColorMode, DisparityRange};
use lfdepth::plan::Preset;
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

/// A preset by its name (`--preset`); the error lists every name.
pub fn parse_preset(text: &str) -> Result<Preset, String> {
    Preset::from_name(text).ok_or_else(|| {
        let names: Vec<&str> = Preset::ALL.iter().map(|p| p.name()).collect();
        format!("unknown preset `{text}`: use one of {}", names.join(", "))
    })
}

/// Colour handling of the EPI stage (`--epi-color`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum EpiColor {
    /// One structure tensor summed over the R, G, B channels.
    Tensor,
    /// The mean of the channels first: about a third of the tensor work.
    Gray,
}

impl From<EpiColor> for ColorMode {
    fn from(choice: EpiColor) -> Self {
        match choice {
            EpiColor::Tensor => ColorMode::Tensor,
            EpiColor::Gray => ColorMode::Gray,
        }
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

/// How aligned views are resampled (`--align-interp`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum AlignInterp {
    /// 2×2 taps: the fastest; blurs fine texture by a shift-dependent amount.
    Bilinear,
    /// Bilinear, then a 3-tap sharpening per axis that undoes its shift-dependent blur:
    /// Catmull–Rom's kernel for near-identity maps at about 1.7× the warp time of
    /// bilinear (the default).
    #[default]
    SharpenedBilinear,
    /// 4×4 Catmull–Rom cubic taps: keeps the texture's contrast (better disparity on
    /// finely textured scenes), about 2.3× the warp time of bilinear.
    CatmullRom,
}

impl From<AlignInterp> for Interpolation {
    fn from(choice: AlignInterp) -> Self {
        match choice {
            AlignInterp::Bilinear => Interpolation::Bilinear,
            AlignInterp::SharpenedBilinear => Interpolation::SharpenedBilinear,
            AlignInterp::CatmullRom => Interpolation::CatmullRom,
        }
    }
}

/// Which views get a homography (`--align-views`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, ValueEnum)]
pub enum AlignViewsChoice {
    /// The views the selected stages read: the centre row and column for the EPI stage
    /// and the default refinement, every view otherwise.
    #[default]
    Read,
    /// The centre row and column only (about a fifth of the work on a 9×9 grid).
    Cross,
    /// Every view: more views average out the random part of the misalignment, so the
    /// disparity offset no image can observe is smaller (slower to estimate).
    All,
}

impl From<AlignViewsChoice> for AlignedViews {
    fn from(choice: AlignViewsChoice) -> Self {
        match choice {
            AlignViewsChoice::Read => AlignedViews::Read,
            AlignViewsChoice::Cross => AlignedViews::Cross,
            AlignViewsChoice::All => AlignedViews::All,
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
    /// Start from a named set of parameters: `default` (the most accurate) or `fast`
    /// (docs/BENCHMARKS.md, "Presets"). Every other estimator flag overrides the
    /// preset's value, wherever it stands on the command line.
    #[arg(long, value_name = "NAME", default_value = "default", value_parser = parse_preset)]
    pub preset: Preset,
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
    /// EPI stage: distance between shear hypotheses in px, 0.1…2 (default from the core;
    /// larger = fewer hypotheses, faster, coarser).
    #[arg(long, value_name = "F")]
    pub epi_shear_step: Option<f32>,
    /// EPI stage: `tensor` (one structure tensor over R, G, B) or `gray` (the channels'
    /// mean first, a third of the tensor work) (default from the core).
    #[arg(long, value_enum, value_name = "MODE")]
    pub epi_color: Option<EpiColor>,
    /// Photometric refinement of the EPI disparity: 1 on, 0 off (default from the core).
    #[arg(long, value_name = "0|1")]
    pub refine: Option<u8>,
    /// Refinement: Gauss–Newton iterations, 1…16 (default from the core).
    #[arg(long, value_name = "N")]
    pub refine_iterations: Option<usize>,
    /// Refinement: rounds of propagation before the iterations, 0…4 (jumps of 8, 4, 2,
    /// 1 px, the last N of them; default from the core).
    #[arg(long, value_name = "N")]
    pub refine_propagation: Option<usize>,
    /// Refinement: radius of the aggregation window in px, 0…4 (default from the core).
    #[arg(long, value_name = "N")]
    pub refine_radius: Option<usize>,
    /// Refinement: sampling slack in px of image motion, 0…1: a view's residual counts
    /// only by how far it falls outside the centre view's values over ±F px
    /// (Birchfield–Tomasi; 0 = the plain residual). On warped views the pipeline uses
    /// 0.5 when this is 0 (default from the core).
    #[arg(long, value_name = "F")]
    pub refine_slack: Option<f32>,
    /// Refinement: settled windows in px, 0…1: after the first Gauss–Newton iteration,
    /// a pixel that kept its statistics and whose window's other pixels each moved by
    /// less than F px (at least the settle threshold) keeps its disparity and confidence
    /// instead of being updated again; 0 = update every pixel in every iteration (the
    /// maps of before, bit for bit; default from the core).
    #[arg(long, value_name = "F")]
    pub refine_skip_settled: Option<f32>,
    /// TV refinement: weight λ of the total variation against the EPI data term
    /// (larger = smoother; default from the core).
    #[arg(long, value_name = "F", allow_hyphen_values = true)]
    pub lambda: Option<f32>,
    /// TV refinement: most PPXA iterations per tile (default from the core).
    #[arg(long, value_name = "N")]
    pub tv_iterations: Option<usize>,
    /// TV refinement: stopping tolerance, the RMS change of the refined disparity over one
    /// iteration in pixels, 0 to run every iteration (default from the core; smaller =
    /// closer to the exact minimiser).
    #[arg(long, value_name = "F")]
    pub tv_tolerance: Option<f32>,
    /// TV refinement: side of a tile's core in pixels (default from the core).
    #[arg(long, value_name = "N")]
    pub tv_tile: Option<usize>,
    /// TV refinement: pixels of context around each tile (default from the core).
    #[arg(long, value_name = "N")]
    pub tv_halo: Option<usize>,
    /// TV refinement: outer sweeps, 0…8: solve every tile again from the previous pass's
    /// dual with the flows across its border held at the neighbours' values, so tiles
    /// agree where they meet (default from the core).
    #[arg(long, value_name = "N")]
    pub tv_sweeps: Option<usize>,
    /// Edge-snapping weighted median guided by the centre view (between the refinement
    /// and TV): window radius in pixels, 1…7, or 0 to switch it off (default from the
    /// core).
    #[arg(long, value_name = "R")]
    pub median: Option<usize>,
    /// Weighted median: colour scale σ of the weights (unit intensity; default from the
    /// core).
    #[arg(long, value_name = "F")]
    pub median_sigma: Option<f32>,
    /// Weighted median: passes (default from the core).
    #[arg(long, value_name = "N")]
    pub median_passes: Option<usize>,
    /// Weighted median: only pixels whose window holds a step between adjacent pixels
    /// larger than this (px) are filtered (default from the core).
    #[arg(long, value_name = "F")]
    pub median_gate: Option<f32>,
    /// Weighted median: a pixel takes the median only when it differs from it by more
    /// than this (px; default from the core).
    #[arg(long, value_name = "F")]
    pub median_snap: Option<f32>,
    /// Weighted median: neighbours vote with their own value instead of extrapolating
    /// along the local slope.
    #[arg(long)]
    pub median_flat: bool,
    /// Weighted median: run it after TV instead of between the refinement and TV.
    #[arg(long)]
    pub median_after_tv: bool,
    /// Geodesic refill of the band around depth steps (after the refinement, before the
    /// median): 1 on, 0 off (default from the core). Each pixel within --fill-band px of
    /// a disparity step takes the value of the outside pixel it reaches through the
    /// most uniform colour of the centre view, so a foreground fattened into a flat
    /// background returns to its colour edge.
    #[arg(long, value_name = "0|1")]
    pub fill: Option<u8>,
    /// Geodesic refill: width (px, city-block) of the band refilled around each step,
    /// 1…32 (default from the core).
    #[arg(long, value_name = "N")]
    pub fill_band: Option<usize>,
    /// Geodesic refill: a disparity difference between 4-neighbours larger than this
    /// (px) is a depth step (default from the core).
    #[arg(long, value_name = "F")]
    pub fill_step: Option<f32>,
    /// Geodesic refill: a depth step with a colour step (largest channel difference, unit
    /// intensity) of at least this within 2 px across it sits on its colour edge and is
    /// left alone (default from the core).
    #[arg(long, value_name = "F")]
    pub fill_edge: Option<f32>,
    /// Geodesic refill: a band pixel whose cheapest colour path to a pixel outside the
    /// band costs more than this (unit intensity) keeps its value (default from the
    /// core).
    #[arg(long, value_name = "F")]
    pub fill_max_cost: Option<f32>,
    /// Geodesic refill: path cost per pixel of length, in unit intensity, against the
    /// colour differences crossed (default from the core).
    #[arg(long, value_name = "F")]
    pub fill_spatial: Option<f32>,
    /// Geodesic refill: extrapolate the source pixel's value along its slope instead of
    /// copying it.
    #[arg(long)]
    pub fill_planar: bool,
    /// Align the views by per-view homographies first: `off`, `on`, or `auto` (only when
    /// the array is found not to be rectified).
    #[arg(long, value_enum, default_value_t = AlignChoice::Auto)]
    pub align: AlignChoice,
    /// Alignment: how the views are resampled into the rectified array,
    /// `sharpened-bilinear` (the default: as sharp as Catmull–Rom on alignment's maps),
    /// `bilinear` (fastest, blurs) or `catmull-rom` (about 1.4× the default's warp time).
    #[arg(long, value_enum, value_name = "KERNEL", default_value_t = AlignInterp::SharpenedBilinear)]
    pub align_interp: AlignInterp,
    /// Alignment: which views get a homography, `read` (those the stages read), `cross`
    /// (centre row and column) or `all` (every view: smaller unobservable disparity
    /// offset, slower).
    #[arg(long, value_enum, value_name = "VIEWS", default_value_t = AlignViewsChoice::Read)]
    pub align_views: AlignViewsChoice,
}

impl Default for ParamArgs {
    fn default() -> Self {
        ParamArgs {
            preset: Preset::Default,
            disparity_range: RangeChoice::Auto,
            no_shear: false,
            epi_shear_step: None,
            epi_color: None,
            refine: None,
            refine_iterations: None,
            refine_propagation: None,
            refine_radius: None,
            refine_slack: None,
            refine_skip_settled: None,
            lambda: None,
            tv_iterations: None,
            tv_tolerance: None,
            tv_tile: None,
            tv_halo: None,
            tv_sweeps: None,
            median: None,
            median_sigma: None,
            median_passes: None,
            median_gate: None,
            median_snap: None,
            median_flat: false,
            median_after_tv: false,
            fill: None,
            fill_band: None,
            fill_step: None,
            fill_spatial: None,
            fill_edge: None,
            fill_max_cost: None,
            fill_planar: false,
            align: AlignChoice::Auto,
            align_interp: AlignInterp::Bilinear,
            align_views: AlignViewsChoice::Read,
        }
    }
}

impl ParamArgs {
    /// The parameters these flags ask for; `config` is the scene's parameters.cfg.
    pub fn params(&self, config: Option<&SceneConfig>) -> Result<Params, CliError> {
        let mut params = Params::preset(self.preset);
        params.align.mode = self.align.into();
        params.align.interpolation = self.align_interp.into();
        params.align.views = self.align_views.into();
        if self.no_shear {
            params.epi = lfdepth::epi::EpiParams::paper();
        }
        if let Some(step) = self.epi_shear_step {
            params.epi.shear_step = step;
        }
        if let Some(color) = self.epi_color {
            params.epi.color = color.into();
        }
        match self.refine {
            Some(0) => params.refine.enabled = false,
            Some(1) => params.refine.enabled = true,
            Some(_) => return Err(CliError::Usage("--refine takes 0 (off) or 1 (on)".into())),
            None => {}
        }
        if let Some(n) = self.refine_iterations {
            params.refine.iterations = n;
        }
        if let Some(n) = self.refine_propagation {
            params.refine.propagation = n;
        }
        if let Some(r) = self.refine_radius {
            params.refine.radius = r;
        }
        if let Some(slack) = self.refine_slack {
            params.refine.sampling_slack = slack;
        }
        if let Some(moved) = self.refine_skip_settled {
            params.refine.skip_settled = moved;
        }
        if let Some(lambda) = self.lambda {
            params.tv.lambda = lambda;
        }
        if let Some(n) = self.tv_iterations {
            params.tv.max_iterations = n;
        }
        if let Some(t) = self.tv_tolerance {
            params.tv.tolerance = t;
        }
        if let Some(n) = self.tv_tile {
            params.tv.tile = n;
        }
        if let Some(n) = self.tv_halo {
            params.tv.halo = n;
        }
        if let Some(n) = self.tv_sweeps {
            params.tv.sweeps = n;
        }
        match self.median {
            Some(0) => params.median.enabled = false,
            Some(r) => params.median.radius = r,
            None => {}
        }
        if let Some(n) = self.median_passes {
            params.median.passes = n;
        }
        if self.median_after_tv {
            params.median.before_tv = false;
        }
        if self.median_flat {
            params.median.planar = false;
        }
        if let Some(t) = self.median_snap {
            params.median.snap = t;
        }
        if let Some(g) = self.median_gate {
            params.median.gate = g;
        }
        if let Some(sigma) = self.median_sigma {
            params.median.color_sigma = sigma;
        }
        match self.fill {
            Some(0) => params.geofill.enabled = false,
            Some(1) => params.geofill.enabled = true,
            Some(_) => return Err(CliError::Usage("--fill takes 0 (off) or 1 (on)".into())),
            None => {}
        }
        if let Some(n) = self.fill_band {
            params.geofill.band = n;
            params.geofill.reach = params.geofill.reach.max(2 * n);
        }
        if let Some(t) = self.fill_step {
            params.geofill.step = t;
        }
        if let Some(c) = self.fill_max_cost {
            params.geofill.max_cost = c;
        }
        if let Some(e) = self.fill_edge {
            params.geofill.edge = e;
        }
        if let Some(c) = self.fill_spatial {
            params.geofill.spatial = c;
        }
        if self.fill_planar {
            params.geofill.planar = true;
        }
        // Out-of-range values are reported here, before any view is decoded.
        params
            .refine
            .validate()
            .map_err(|e| CliError::core("checking the --refine flags", e))?;
        params
            .tv
            .validate()
            .map_err(|e| CliError::core("checking the TV flags", e))?;
        params
            .median
            .validate()
            .map_err(|e| CliError::core("checking the --median flags", e))?;
        params
            .geofill
            .validate()
            .map_err(|e| CliError::core("checking the --fill flags", e))?;
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
            .map_err(|e| CliError::core("checking --disparity-range and the --epi flags", e))?;
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

    #[test]
    fn preset_flags() {
        assert_eq!(parse_preset("fast"), Ok(Preset::Fast));
        let err = parse_preset("turbo").unwrap_err();
        assert!(
            err.contains("turbo") && err.contains("default, fast"),
            "{err}"
        );
        let fast = ParamArgs {
            preset: Preset::Fast,
            ..ParamArgs::default()
        };
        let expected = Params {
            align: fast.params(None).unwrap().align,
            ..Params::preset(Preset::Fast)
        };
        assert_eq!(fast.params(None).unwrap(), expected);
        let overridden = ParamArgs {
            refine_iterations: Some(5),
            refine_slack: Some(0.25),
            median_passes: Some(4),
            epi_color: Some(EpiColor::Gray),
            ..fast
        };
        let p = overridden.params(None).unwrap();
        assert_eq!((p.refine.iterations, p.median.passes), (5, 4));
        assert_eq!(p.refine.sampling_slack, 0.25);
        assert_eq!(p.epi.color, ColorMode::Gray);
        assert_eq!(p.refine.propagation, expected.refine.propagation);
        for bad in [
            ParamArgs {
                refine: Some(2),
                ..ParamArgs::default()
            },
            ParamArgs {
                refine_iterations: Some(0),
                ..ParamArgs::default()
            },
            ParamArgs {
                epi_shear_step: Some(5.0),
                ..ParamArgs::default()
            },
        ] {
            assert!(bad.params(None).is_err());
        }
    }

    #[test]
    fn fill_flags() {
        let on = ParamArgs {
            fill: Some(1),
            fill_band: Some(12),
            fill_max_cost: Some(0.3),
            fill_planar: true,
            ..ParamArgs::default()
        };
        let g = on.params(None).unwrap().geofill;
        assert!(g.enabled && g.planar);
        assert_eq!((g.band, g.reach, g.max_cost), (12, 24, 0.3));
        let off = ParamArgs {
            fill: Some(0),
            ..ParamArgs::default()
        };
        assert!(!off.params(None).unwrap().geofill.enabled);
        for bad in [
            ParamArgs {
                fill: Some(2),
                ..ParamArgs::default()
            },
            ParamArgs {
                fill_band: Some(0),
                ..ParamArgs::default()
            },
        ] {
            assert!(bad.params(None).is_err());
        }
    }
}
