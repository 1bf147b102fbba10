//! A [`Plan`]: dimensions and parameters validated once, from which every buffer size
//! follows. Each stage takes its own part of it, a [`Setup`] of the layout and that
//! stage's parameters (`plan.epi()`, `plan.tv()`, …), and reports its own scratch needs
//! (`epi::scratch_len(plan.epi())`, `tv::scratch_len(plan.tv())`).

use crate::align::{AlignMode, AlignParams};
use crate::epi::EpiParams;
use crate::error::{checked_product, Result};
use crate::geofill::GeoFillParams;
use crate::lightfield::Layout;
use crate::median::MedianParams;
use crate::planesweep::{PlaneSweepParams, SweepColor};
use crate::refine::RefineParams;
use crate::setup::Setup;
use crate::tv::TvParams;

/// Parameters of every stage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    /// Alignment of an imperfect array before the other stages (used by
    /// `pipeline::run_aligned`; `pipeline::run` takes the array as rectified). The
    /// default here is [`AlignMode::Off`]: a library caller opts in (the CLI and the page
    /// default to [`AlignMode::Auto`]).
    pub align: AlignParams,
    /// Initial disparity from EPIs.
    pub epi: EpiParams,
    /// Initial disparity from a plane sweep instead of the EPI stage (on by default, off
    /// in [`Params::paper`] and in the firmware's stream; the EPI stage's automatic range
    /// still sets its hypotheses).
    pub sweep: PlaneSweepParams,
    /// Start from both the EPI stage and the plane sweep (whatever `sweep.enabled` says),
    /// refine each and keep per pixel the one the views agree with better (off by
    /// default; needs the refinement; docs/stages/fused.md).
    pub fused: bool,
    /// Photometric refinement of the EPI disparity over many views.
    pub refine: RefineParams,
    /// Total-variation refinement.
    pub tv: TvParams,
    /// Edge-snapping weighted median guided by the centre view (before TV by default).
    pub median: MedianParams,
    /// Geodesic refill of the band around depth steps (after the refinement, before the
    /// median).
    pub geofill: GeoFillParams,
}

impl Default for Params {
    /// Every stage's default, alignment off (see [`Params::align`]), and TV's λ = 0.25
    /// instead of the paper's 0.5 ([`TvParams::default`]): with the refinement and the
    /// median in front, λ 0.1…0.5 all meet the same goals and 0.25 has the smallest sum
    /// of ratios to SPO's scores; smaller λ flattens curved surfaces less
    /// (docs/stages/median.md has the λ table).
    fn default() -> Self {
        Params {
            align: AlignParams {
                mode: AlignMode::Off,
                ..AlignParams::default()
            },
            epi: EpiParams::default(),
            sweep: PlaneSweepParams {
                enabled: true,
                ..PlaneSweepParams::default()
            },
            fused: false,
            refine: RefineParams::default(),
            tv: TvParams {
                lambda: 0.25,
                ..TvParams::default()
            },
            median: MedianParams::default(),
            geofill: GeoFillParams::default(),
        }
    }
}

impl Params {
    /// The paper's pipeline: its EPI variant, no refinement, no median, TV with λ = 0.5.
    pub fn paper() -> Self {
        Params {
            align: Params::default().align,
            epi: EpiParams::paper(),
            sweep: PlaneSweepParams::off(),
            fused: false,
            refine: RefineParams::off(),
            tv: TvParams::default(),
            median: MedianParams::off(),
            geofill: GeoFillParams::off(),
        }
    }

    /// The parameters of a named preset (alignment off, as [`Params::default`]).
    pub fn preset(preset: Preset) -> Self {
        let default = Params::default();
        match preset {
            Preset::Default => default,
            // Each knob is one the CLI exposes; docs/BENCHMARKS.md ("Presets") has
            // what each costs and saves, measured on the HCI scenes, both sizes of the
            // realistic suite and the demo scenes.
            Preset::Fast => Params {
                sweep: PlaneSweepParams {
                    color: SweepColor::Gray,
                    ..default.sweep
                },
                refine: RefineParams {
                    iterations: 1,
                    ..default.refine
                },
                median: MedianParams {
                    passes: 3,
                    ..default.median
                },
                ..default
            },
        }
    }
}

/// A named set of [`Params`] on the speed/accuracy frontier (docs/BENCHMARKS.md,
/// "Presets"). The names are what the CLI's and the page's `--preset` accept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preset {
    /// [`Params::default`]: the most accurate settings.
    Default,
    /// Less CPU than [`Preset::Default`] (about 27 % fewer instructions on cotton) for a
    /// lower accuracy on the HCI scenes that still beats SPO on both: the plane sweep on
    /// luminance, one Gauss–Newton iteration, three median passes.
    Fast,
}

impl Preset {
    /// Every preset, in the order the CLI lists them.
    pub const ALL: [Preset; 2] = [Preset::Default, Preset::Fast];

    /// The preset's name (lower case, as the CLI spells it).
    pub fn name(self) -> &'static str {
        match self {
            Preset::Default => "default",
            Preset::Fast => "fast",
        }
    }

    /// The preset called `name` (exact, lower case), if any.
    pub fn from_name(name: &str) -> Option<Preset> {
        Preset::ALL.into_iter().find(|p| p.name() == name)
    }
}

/// The plane sweep replaces the EPI stage, so it cannot start from the half-resolution
/// EPI's upsampling; the fused start runs the sweep at full resolution beside the EPI
/// stage and chooses by the refinement's residual, so it needs the refinement and the
/// full-resolution EPI.
pub(crate) fn check_initial(params: &Params) -> Result<()> {
    if params.fused && !params.refine.enabled {
        return Err(crate::error::Error::InvalidParameter {
            name: "initial",
            reason: "fused chooses between the starts by the refinement's cost: enable the refinement with it",
        });
    }
    if params.fused && params.epi.half_resolution {
        return Err(crate::error::Error::InvalidParameter {
            name: "initial",
            reason: "fused runs the plane sweep at full resolution beside the EPI stage: switch the half-resolution EPI off with it",
        });
    }
    if params.sweep.enabled && params.epi.half_resolution {
        return Err(crate::error::Error::InvalidParameter {
            name: "initial",
            reason: "is sweep, which replaces the EPI stage: the half-resolution EPI needs the EPI start (epi); choose it or switch the half-resolution EPI off",
        });
    }
    Ok(())
}

/// Validated dimensions and parameters of one estimation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plan {
    layout: Layout,
    params: Params,
    pixels: usize,
}

impl Plan {
    /// Validates the layout and every stage's parameters.
    pub fn new(layout: Layout, params: Params) -> Result<Self> {
        layout.validate()?;
        params.align.validate()?;
        params.epi.validate()?;
        params.refine.validate()?;
        params.tv.validate()?;
        params.median.validate()?;
        params.geofill.validate()?;
        params.sweep.validate()?;
        check_initial(&params)?;
        let pixels = checked_product(&[layout.width, layout.height], "the disparity map")?;
        Ok(Plan {
            layout,
            params,
            pixels,
        })
    }
    /// The light-field layout.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }
    /// Stage parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }
    /// Pixels of the centre view: the length of every per-pixel output.
    pub fn pixels(&self) -> usize {
        self.pixels
    }
    /// What the EPI stage needs: the layout and [`Params::epi`].
    pub fn epi(&self) -> Setup<'_, EpiParams> {
        Setup::validated(&self.layout, &self.params.epi, self.pixels)
    }
    /// What the plane sweep needs: the layout and [`Params::sweep`].
    pub fn sweep(&self) -> Setup<'_, PlaneSweepParams> {
        Setup::validated(&self.layout, &self.params.sweep, self.pixels)
    }
    /// What the refinement needs: the layout and [`Params::refine`].
    pub fn refine(&self) -> Setup<'_, RefineParams> {
        Setup::validated(&self.layout, &self.params.refine, self.pixels)
    }
    /// What the refill needs: the layout and [`Params::geofill`].
    pub fn geofill(&self) -> Setup<'_, GeoFillParams> {
        Setup::validated(&self.layout, &self.params.geofill, self.pixels)
    }
    /// What the median needs: the layout and [`Params::median`].
    pub fn median(&self) -> Setup<'_, MedianParams> {
        Setup::validated(&self.layout, &self.params.median, self.pixels)
    }
    /// What TV needs: the layout and [`Params::tv`].
    pub fn tv(&self) -> Setup<'_, TvParams> {
        Setup::validated(&self.layout, &self.params.tv, self.pixels)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lightfield::Grid;
    use crate::Error;

    #[test]
    fn presets_are_valid_and_named() {
        assert_eq!(Params::preset(Preset::Default), Params::default());
        assert_ne!(Params::preset(Preset::Fast), Params::default());
        let layout = Layout::packed(Grid::new(9, 9), 64, 48, 3);
        for preset in Preset::ALL {
            Plan::new(layout, Params::preset(preset)).unwrap();
            assert_eq!(Preset::from_name(preset.name()), Some(preset));
        }
        assert_eq!(Preset::from_name("Fast"), None);
        assert_eq!(Preset::from_name(""), None);
    }

    #[test]
    fn plan_validates_layout() {
        let layout = Layout::packed(Grid::new(9, 9), 64, 48, 3);
        let plan = Plan::new(layout, Params::default()).unwrap();
        assert_eq!(plan.pixels(), 64 * 48);
        let bad = Layout::packed(Grid::new(2, 9), 64, 48, 3);
        assert!(matches!(
            Plan::new(bad, Params::default()),
            Err(Error::GridSize { .. })
        ));
    }
}
