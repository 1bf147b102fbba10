//! The user-facing tunables of [`Params`], declared once.
//!
//! [`TUNABLES`] lists every parameter a user can set: its command-line flag (`--lambda`),
//! its key in the wasm package's option object (`lambda`), one line of documentation,
//! its type and range, and how it is read from and written into [`Params`]. The CLI
//! builds its estimator flags from this table, the wasm layer parses option keys
//! through it, and the TypeScript type of those options is generated from it, so the
//! three cannot disagree. Defaults are never written here: a tunable's default is its
//! getter applied to [`base`]`(Preset::Default)`, which is [`Params::default`] with
//! alignment on `auto`.
//!
//! Ranges are checked by the stages' own `validate` (the single source of the rules);
//! [`validate`] runs them and [`rename`] turns the internal name in an error
//! (`tv.lambda`) into the one the user typed (`--lambda` or `lambda`). The ranges shown
//! in [`Kind`] are what the help texts print; a test checks that they agree with the
//! stages' checks.

use core::fmt;

use crate::align::{AlignMode, AlignedViews, Interpolation};
use crate::epi::{ColorMode, DisparityRange, EpiParams, Fusion, MAX_DISPARITY};
use crate::error::{Error, Result};
use crate::plan::{Params, Preset};

/// The type and range of a tunable's values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// A finite number in `min..=max` (`min` itself excluded when `min_open`; no upper
    /// limit when `max` is infinite).
    Float { min: f32, max: f32, min_open: bool },
    /// A whole number in `min..=max`.
    Int { min: usize, max: usize },
    /// On or off.
    Bool,
    /// One of these names.
    Choice(&'static [&'static str]),
    /// A disparity range: automatic, or `min..=max` px between adjacent views within
    /// ±[`MAX_DISPARITY`].
    Range,
}

/// A value of a tunable.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    /// Of [`Kind::Float`].
    Float(f32),
    /// Of [`Kind::Int`].
    Int(usize),
    /// Of [`Kind::Bool`].
    Bool(bool),
    /// Of [`Kind::Choice`]: one of its names.
    Choice(&'static str),
    /// Of [`Kind::Range`].
    Range(DisparityRange),
}

/// How a tunable appears on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flag {
    /// `--NAME VALUE` (`name` includes the dashes).
    Value(&'static str),
    /// `--NAME` alone sets the tunable to `sets`; `doc` says what the switch does.
    Switch {
        name: &'static str,
        sets: bool,
        doc: &'static str,
    },
}

impl Flag {
    /// The flag as typed, dashes included.
    pub fn name(self) -> &'static str {
        match self {
            Flag::Value(name) | Flag::Switch { name, .. } => name,
        }
    }
}

/// Which front end an error message speaks to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Front {
    /// The command line: tunables are named by their flag (`--lambda`).
    Cli,
    /// The wasm package: tunables are named by their key (`lambda`).
    Js,
}

/// One user-facing parameter.
#[derive(Clone, Copy)]
pub struct Tunable {
    /// Its command-line flag, if it has one.
    pub flag: Option<Flag>,
    /// Its key in the wasm package's options, if it has one.
    pub key: Option<&'static str>,
    /// What it does, one line.
    pub doc: &'static str,
    /// Its type and range.
    pub kind: Kind,
    /// The name the stages' `validate` gives it in [`Error::InvalidParameter`] (for
    /// [`rename`]); unique in the table.
    pub path: &'static str,
    get: fn(&Params) -> Value,
    set: fn(&mut Params, Value) -> Option<()>,
}

impl fmt::Debug for Tunable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Tunable")
            .field("flag", &self.flag)
            .field("key", &self.key)
            .field("kind", &self.kind)
            .field("path", &self.path)
            .finish()
    }
}

impl Tunable {
    /// Its value in `params`.
    pub fn get(&self, params: &Params) -> Value {
        (self.get)(params)
    }

    /// Its default: its value in [`base`]`(Preset::Default)`.
    pub fn default_value(&self) -> Value {
        self.get(&base(Preset::Default))
    }

    /// The name the user knows it by in `front`, if it exists there.
    pub fn name(&self, front: Front) -> Option<&'static str> {
        match front {
            Front::Cli => self.flag.map(|f| f.name()),
            Front::Js => self.key,
        }
    }

    /// Writes `value` into `params`. Only the type is checked here (the range by
    /// [`validate`] once every value is in); a value of the wrong type, or a name its
    /// [`Kind::Choice`] does not list, is an [`Error::InvalidParameter`] naming
    /// [`Tunable::path`] (see [`rename`]).
    pub fn apply(&self, params: &mut Params, value: Value) -> Result<()> {
        let expected = match (self.kind, value) {
            (Kind::Float { .. }, Value::Float(_))
            | (Kind::Int { .. }, Value::Int(_))
            | (Kind::Bool, Value::Bool(_))
            | (Kind::Range, Value::Range(_)) => true,
            (Kind::Choice(names), Value::Choice(name)) => names.contains(&name),
            _ => false,
        };
        let invalid = Error::InvalidParameter {
            name: self.path,
            reason: self.kind.expects(),
        };
        if !expected {
            return Err(invalid);
        }
        (self.set)(params, value).ok_or(invalid)
    }

    /// Checks one value on its own: applied to [`base`]`(Preset::Default)`, does every
    /// stage accept it? The error names the tunable as `front` knows it.
    pub fn check(&self, value: Value, front: Front) -> Result<()> {
        let mut params = base(Preset::Default);
        self.apply(&mut params, value)
            .and_then(|()| validate(&params, front))
            .map_err(|e| rename(e, front))
    }

    /// Parses `text` as the command line writes a value: a number, `0`/`1` (also
    /// `false`/`true`) for [`Kind::Bool`], one of the names for [`Kind::Choice`], and
    /// `auto` or `MIN..MAX` for [`Kind::Range`]. The error is what the text should be.
    pub fn parse(&self, text: &str) -> core::result::Result<Value, &'static str> {
        let text = text.trim();
        match self.kind {
            Kind::Float { .. } => text
                .parse::<f32>()
                .ok()
                .filter(|v| v.is_finite())
                .map(Value::Float)
                .ok_or("must be a finite number"),
            Kind::Int { .. } => text
                .parse::<usize>()
                .map(Value::Int)
                .map_err(|_| "must be a whole number ≥ 0"),
            Kind::Bool => match text {
                "1" | "true" => Ok(Value::Bool(true)),
                "0" | "false" => Ok(Value::Bool(false)),
                _ => Err("use 0 (off) or 1 (on)"),
            },
            Kind::Choice(names) => names
                .iter()
                .find(|n| **n == text)
                .map(|n| Value::Choice(n))
                .ok_or("is not one of the names"),
            Kind::Range => {
                if text == "auto" {
                    return Ok(Value::Range(DisparityRange::Auto));
                }
                let (min, max) = text
                    .split_once("..")
                    .ok_or("use MIN..MAX (e.g. -2..2) or auto")?;
                let min = min.trim().parse::<f32>();
                let max = max.trim().parse::<f32>();
                match (min, max) {
                    (Ok(min), Ok(max)) => Ok(Value::Range(DisparityRange::Fixed { min, max })),
                    _ => Err("use MIN..MAX with two numbers (e.g. -2..2) or auto"),
                }
            }
        }
    }
}

impl Kind {
    /// What a value of this kind must be (the reason of a type error).
    fn expects(&self) -> &'static str {
        match self {
            Kind::Float { .. } => "must be a number",
            Kind::Int { .. } => "must be a whole number",
            Kind::Bool => "must be true or false (1 or 0)",
            Kind::Choice(_) => "must be one of its names",
            Kind::Range => "must be auto or a range [min, max]",
        }
    }
}

impl fmt::Display for Kind {
    /// The range as the help texts print it: `0…4`, `(0, 1000]`, `≥ 0`, `1…16`,
    /// `off|on|auto`, `auto or MIN..MAX within ±8`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Kind::Float {
                min,
                max,
                min_open: false,
            } if max.is_infinite() => write!(f, "≥ {min}"),
            Kind::Float {
                min,
                max,
                min_open: true,
            } if max.is_infinite() => write!(f, "> {min}"),
            Kind::Float {
                min,
                max,
                min_open: false,
            } => write!(f, "{min}…{max}"),
            Kind::Float {
                min,
                max,
                min_open: true,
            } => write!(f, "({min}, {max}]"),
            Kind::Int { min, max } => write!(f, "{min}…{max}"),
            Kind::Bool => f.write_str("on or off"),
            Kind::Choice(names) => {
                for (i, name) in names.iter().enumerate() {
                    if i > 0 {
                        f.write_str("|")?;
                    }
                    f.write_str(name)?;
                }
                Ok(())
            }
            Kind::Range => write!(f, "auto or MIN..MAX within ±{MAX_DISPARITY}"),
        }
    }
}

impl fmt::Display for Value {
    /// Numbers as Rust prints them, `true`/`false`, the name, `auto` or `MIN..MAX`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Value::Float(v) => write!(f, "{v}"),
            Value::Int(v) => write!(f, "{v}"),
            Value::Bool(v) => write!(f, "{v}"),
            Value::Choice(name) => f.write_str(name),
            Value::Range(DisparityRange::Auto) => f.write_str("auto"),
            Value::Range(DisparityRange::Fixed { min, max }) => write!(f, "{min}..{max}"),
        }
    }
}

/// The parameters every front end starts from for `preset`: [`Params::preset`] with the
/// alignment on [`AlignMode::Auto`] (a library caller of [`Params::default`] opts in to
/// alignment; a user of the CLI or the page gets it when the array needs it).
pub fn base(preset: Preset) -> Params {
    let mut params = Params::preset(preset);
    params.align.mode = AlignMode::Auto;
    params
}

/// Every stage's `validate` on `params`, with the failing tunable named as `front` knows
/// it ([`rename`]).
pub fn validate(params: &Params, front: Front) -> Result<()> {
    params
        .align
        .validate()
        .and_then(|()| params.epi.validate())
        .and_then(|()| params.refine.validate())
        .and_then(|()| params.tv.validate())
        .and_then(|()| params.median.validate())
        .and_then(|()| params.geofill.validate())
        .map_err(|e| rename(e, front))
}

/// `error` with an internal parameter name (`tv.lambda`) replaced by the name `front`
/// knows the tunable by (`--lambda`, `lambda`); other errors, and parameters without a
/// name in `front`, as they are.
pub fn rename(error: Error, front: Front) -> Error {
    match error {
        Error::InvalidParameter { name, reason } => {
            let name = TUNABLES
                .iter()
                .find(|t| t.path == name)
                .and_then(|t| t.name(front))
                .unwrap_or(name);
            Error::InvalidParameter { name, reason }
        }
        other => other,
    }
}

/// The tunable whose flag is `name` (dashes included).
pub fn by_flag(name: &str) -> Option<&'static Tunable> {
    TUNABLES
        .iter()
        .find(|t| t.flag.map(|f| f.name()) == Some(name))
}

/// The tunable whose wasm key is `key`.
pub fn by_key(key: &str) -> Option<&'static Tunable> {
    TUNABLES.iter().find(|t| t.key == Some(key))
}

/// One line about `preset`, for the CLI's help and the TypeScript type.
pub fn preset_doc(preset: Preset) -> &'static str {
    match preset {
        Preset::Default => "the most accurate settings",
        Preset::Fast => {
            "about 1.3× less CPU: one Gauss–Newton step, three median passes gated at 0.3 px, TV stopping earlier"
        }
    }
}

fn float(v: Value) -> Option<f32> {
    match v {
        Value::Float(x) => Some(x),
        _ => None,
    }
}

fn int(v: Value) -> Option<usize> {
    match v {
        Value::Int(x) => Some(x),
        _ => None,
    }
}

fn boolean(v: Value) -> Option<bool> {
    match v {
        Value::Bool(x) => Some(x),
        _ => None,
    }
}

fn choice(v: Value) -> Option<&'static str> {
    match v {
        Value::Choice(x) => Some(x),
        _ => None,
    }
}

const fn closed(min: f32, max: f32) -> Kind {
    Kind::Float {
        min,
        max,
        min_open: false,
    }
}

const fn ints(min: usize, max: usize) -> Kind {
    Kind::Int { min, max }
}

const ALIGN_MODES: &[&str] = &["off", "on", "auto"];
const INTERPOLATIONS: &[&str] = &["bilinear", "sharpened-bilinear", "catmull-rom"];
const ALIGNED_VIEWS: &[&str] = &["read", "cross", "all"];
const FUSIONS: &[&str] = &["coherence", "weighted"];
const COLORS: &[&str] = &["tensor", "gray"];

/// Every tunable, in the order the front ends apply them (a later one may build on an
/// earlier one: `--no-shear` replaces the whole EPI stage's settings, so it comes first
/// among them).
pub static TUNABLES: &[Tunable] = &[
    // Alignment.
    Tunable {
        flag: Some(Flag::Value("--align")),
        key: Some("align"),
        doc: "Align the views by per-view homographies first: off, on (fails on views that cannot be aligned), or auto (only when the array is found not to be rectified; warns and goes on unaligned when it cannot be aligned)",
        kind: Kind::Choice(ALIGN_MODES),
        path: "align.mode",
        get: |p| {
            Value::Choice(match p.align.mode {
                AlignMode::Off => "off",
                AlignMode::On => "on",
                AlignMode::Auto => "auto",
            })
        },
        set: |p, v| {
            p.align.mode = match choice(v)? {
                "off" => AlignMode::Off,
                "on" => AlignMode::On,
                "auto" => AlignMode::Auto,
                _ => return None,
            };
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--align-interp")),
        key: Some("alignInterp"),
        doc: "Alignment: how the views are resampled into the rectified array: bilinear (fastest, blurs fine texture), sharpened-bilinear (bilinear plus a 3-tap sharpening, as sharp as Catmull–Rom on alignment's maps) or catmull-rom (4×4 cubic taps, about 1.4× sharpened-bilinear's warp time)",
        kind: Kind::Choice(INTERPOLATIONS),
        path: "align.interpolation",
        get: |p| {
            Value::Choice(match p.align.interpolation {
                Interpolation::Bilinear => "bilinear",
                Interpolation::SharpenedBilinear => "sharpened-bilinear",
                Interpolation::CatmullRom => "catmull-rom",
            })
        },
        set: |p, v| {
            p.align.interpolation = match choice(v)? {
                "bilinear" => Interpolation::Bilinear,
                "sharpened-bilinear" => Interpolation::SharpenedBilinear,
                "catmull-rom" => Interpolation::CatmullRom,
                _ => return None,
            };
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--align-views")),
        key: Some("alignViews"),
        doc: "Alignment: which views get a homography: read (those the stages read), cross (the centre row and column) or all (every view: a smaller disparity offset no image can observe, slower)",
        kind: Kind::Choice(ALIGNED_VIEWS),
        path: "align.views",
        get: |p| {
            Value::Choice(match p.align.views {
                AlignedViews::Read => "read",
                AlignedViews::Cross => "cross",
                AlignedViews::All => "all",
            })
        },
        set: |p, v| {
            p.align.views = match choice(v)? {
                "read" => AlignedViews::Read,
                "cross" => AlignedViews::Cross,
                "all" => AlignedViews::All,
                _ => return None,
            };
            Some(())
        },
    },
    // EPI stage.
    Tunable {
        flag: Some(Flag::Switch {
            name: "--no-shear",
            sets: true,
            doc: "The paper's EPI variant: one unsheared EPI per direction (with its scales 0.8 and 1.5 and the widest fixed range) instead of shear hypotheses over the range",
        }),
        key: None,
        doc: "The paper's EPI variant instead of shear hypotheses (true replaces every EPI setting by the paper's; false restores the defaults when they were the paper's)",
        kind: Kind::Bool,
        path: "epi.paper",
        get: |p| Value::Bool(!p.epi.shear),
        set: |p, v| {
            if boolean(v)? {
                p.epi = EpiParams::paper();
            } else if !p.epi.shear {
                p.epi = EpiParams::default();
            }
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--epi-inner-sigma")),
        key: Some("innerSigma"),
        doc: "EPI stage: Gaussian pre-smoothing along the EPI line (px)",
        kind: closed(0.0, 4.0),
        path: "inner_sigma",
        get: |p| Value::Float(p.epi.inner_sigma),
        set: |p, v| {
            p.epi.inner_sigma = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--epi-outer-sigma")),
        key: Some("outerSigma"),
        doc: "EPI stage: Gaussian smoothing of the structure tensor along the line and across views (px)",
        kind: closed(0.0, 5.0),
        path: "outer_sigma",
        get: |p| Value::Float(p.epi.outer_sigma),
        set: |p, v| {
            p.epi.outer_sigma = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: None,
        key: Some("shear"),
        doc: "EPI stage: shear the EPIs over the range (false: one unsheared EPI per direction, the other settings kept)",
        kind: Kind::Bool,
        path: "shear",
        get: |p| Value::Bool(p.epi.shear),
        set: |p, v| {
            p.epi.shear = boolean(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--epi-shear-step")),
        key: Some("shearStep"),
        doc: "EPI stage: distance between shear hypotheses in px (larger: fewer hypotheses, faster, coarser)",
        kind: closed(0.1, 2.0),
        path: "shear_step",
        get: |p| Value::Float(p.epi.shear_step),
        set: |p, v| {
            p.epi.shear_step = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--epi-window")),
        key: Some("window"),
        doc: "EPI stage: largest residual slope a hypothesis accepts, in shear steps",
        kind: closed(0.5, 2.0),
        path: "window",
        get: |p| Value::Float(p.epi.window),
        set: |p, v| {
            p.epi.window = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--epi-interpolate")),
        key: Some("interpolate"),
        doc: "EPI stage: interpolate between adjacent shears at the zero crossing of the residual slope (off: the single most coherent hypothesis)",
        kind: Kind::Bool,
        path: "interpolate",
        get: |p| Value::Bool(p.epi.interpolate),
        set: |p, v| {
            p.epi.interpolate = boolean(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--epi-fusion")),
        key: Some("fusion"),
        doc: "EPI stage: how the horizontal and vertical estimates are combined: coherence (the more confident one) or weighted (their confidence-weighted mean where they agree within 0.1 px)",
        kind: Kind::Choice(FUSIONS),
        path: "fusion",
        get: |p| {
            Value::Choice(match p.epi.fusion {
                Fusion::Coherence => "coherence",
                Fusion::Weighted => "weighted",
            })
        },
        set: |p, v| {
            p.epi.fusion = match choice(v)? {
                "coherence" => Fusion::Coherence,
                "weighted" => Fusion::Weighted,
                _ => return None,
            };
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--epi-color")),
        key: Some("color"),
        doc: "EPI stage: tensor (one structure tensor over R, G, B) or gray (the channels' mean first, a third of the tensor work)",
        kind: Kind::Choice(COLORS),
        path: "color",
        get: |p| {
            Value::Choice(match p.epi.color {
                ColorMode::Tensor => "tensor",
                ColorMode::Gray => "gray",
            })
        },
        set: |p, v| {
            p.epi.color = match choice(v)? {
                "tensor" => ColorMode::Tensor,
                "gray" => ColorMode::Gray,
                _ => return None,
            };
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--disparity-range")),
        key: Some("range"),
        doc: "Disparity search range in px between adjacent views: auto (estimated from the views) or fixed from a minimum to a maximum",
        kind: Kind::Range,
        path: "disparity range",
        get: |p| Value::Range(p.epi.range),
        set: |p, v| match v {
            Value::Range(range) => {
                p.epi.range = range;
                Some(())
            }
            _ => None,
        },
    },
    // Photometric refinement.
    Tunable {
        flag: Some(Flag::Value("--refine")),
        key: Some("refine"),
        doc: "Photometric refinement of the EPI disparity over many views",
        kind: Kind::Bool,
        path: "refine.enabled",
        get: |p| Value::Bool(p.refine.enabled),
        set: |p, v| {
            p.refine.enabled = boolean(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--refine-iterations")),
        key: Some("refineIterations"),
        doc: "Refinement: Gauss–Newton iterations",
        kind: ints(1, 16),
        path: "refine.iterations",
        get: |p| Value::Int(p.refine.iterations),
        set: |p, v| {
            p.refine.iterations = int(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--refine-propagation")),
        key: Some("refinePropagation"),
        doc: "Refinement: rounds of propagation before the iterations (jumps of 8, 4, 2, 1 px, the last N of them)",
        kind: ints(0, 4),
        path: "refine.propagation",
        get: |p| Value::Int(p.refine.propagation),
        set: |p, v| {
            p.refine.propagation = int(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--refine-radius")),
        key: Some("refineRadius"),
        doc: "Refinement: radius of the aggregation window (px)",
        kind: ints(0, 4),
        path: "refine.radius",
        get: |p| Value::Int(p.refine.radius),
        set: |p, v| {
            p.refine.radius = int(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--refine-slack")),
        key: Some("refineSlack"),
        doc: "Refinement: sampling slack in px of image motion: a view's residual counts only by how far it falls outside the centre view's values over ±F px (0: the plain residual; on warped views the pipeline uses 0.5 when this is 0)",
        kind: closed(0.0, 1.0),
        path: "refine.sampling_slack",
        get: |p| Value::Float(p.refine.sampling_slack),
        set: |p, v| {
            p.refine.sampling_slack = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--refine-skip-settled")),
        key: Some("refineSkipSettled"),
        doc: "Refinement: after the first Gauss–Newton iteration, a pixel that kept its statistics and whose window's other pixels each moved by less than F px keeps its disparity and confidence (0: update every pixel in every iteration)",
        kind: closed(0.0, 1.0),
        path: "refine.skip_settled",
        get: |p| Value::Float(p.refine.skip_settled),
        set: |p, v| {
            p.refine.skip_settled = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--refine-band-rows")),
        key: Some("refineBandRows"),
        doc: "Refinement: image rows per band, the unit of parallel work (the page's refineBand)",
        kind: ints(1, 4096),
        path: "refine.band_rows",
        get: |p| Value::Int(p.refine.band_rows),
        set: |p, v| {
            p.refine.band_rows = int(v)?;
            Some(())
        },
    },
    // Geodesic refill.
    Tunable {
        flag: Some(Flag::Value("--fill")),
        key: Some("geofill"),
        doc: "Geodesic refill of the band around depth steps (after the refinement, before the median): each pixel near a step takes the value of the outside pixel it reaches through the most uniform colour, so a foreground fattened into a flat background returns to its colour edge",
        kind: Kind::Bool,
        path: "geofill.enabled",
        get: |p| Value::Bool(p.geofill.enabled),
        set: |p, v| {
            p.geofill.enabled = boolean(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--fill-band")),
        key: Some("fillBand"),
        doc: "Geodesic refill: width (px, city-block) of the band refilled around each step (the seeds' reach grows to twice it when needed)",
        kind: ints(1, 32),
        path: "geofill.band",
        get: |p| Value::Int(p.geofill.band),
        set: |p, v| {
            let band = int(v)?;
            p.geofill.band = band;
            p.geofill.reach = p.geofill.reach.max(band.saturating_mul(2));
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--fill-step")),
        key: Some("fillStep"),
        doc: "Geodesic refill: a disparity difference between 4-neighbours larger than this (px) is a depth step",
        kind: closed(0.01, 16.0),
        path: "geofill.step",
        get: |p| Value::Float(p.geofill.step),
        set: |p, v| {
            p.geofill.step = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--fill-edge")),
        key: Some("fillEdge"),
        doc: "Geodesic refill: a depth step with a colour step (largest channel difference, unit intensity) of at least this within 2 px across it sits on its colour edge and is left alone",
        kind: closed(0.001, 1.0),
        path: "geofill.edge",
        get: |p| Value::Float(p.geofill.edge),
        set: |p, v| {
            p.geofill.edge = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--fill-max-cost")),
        key: Some("fillMaxCost"),
        doc: "Geodesic refill: a band pixel whose cheapest colour path to a pixel outside the band costs more than this (unit intensity) keeps its value",
        kind: closed(0.001, 16.0),
        path: "geofill.max_cost",
        get: |p| Value::Float(p.geofill.max_cost),
        set: |p, v| {
            p.geofill.max_cost = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--fill-spatial")),
        key: Some("fillSpatial"),
        doc: "Geodesic refill: path cost per pixel of length, in unit intensity, against the colour differences crossed",
        kind: closed(0.0001, 1.0),
        path: "geofill.spatial",
        get: |p| Value::Float(p.geofill.spatial),
        set: |p, v| {
            p.geofill.spatial = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Switch {
            name: "--fill-planar",
            sets: true,
            doc: "Geodesic refill: extrapolate the source pixel's value along its slope instead of copying it",
        }),
        key: Some("fillPlanar"),
        doc: "Geodesic refill: extrapolate the source pixel's value along its slope instead of copying it",
        kind: Kind::Bool,
        path: "geofill.planar",
        get: |p| Value::Bool(p.geofill.planar),
        set: |p, v| {
            p.geofill.planar = boolean(v)?;
            Some(())
        },
    },
    // Weighted median.
    Tunable {
        flag: None,
        key: Some("median"),
        doc: "Edge-snapping weighted median guided by the centre view",
        kind: Kind::Bool,
        path: "median.enabled",
        get: |p| Value::Bool(p.median.enabled),
        set: |p, v| {
            p.median.enabled = boolean(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--median")),
        key: Some("medianRadius"),
        doc: "Edge-snapping weighted median guided by the centre view: window radius in px, or 0 to switch it off",
        kind: ints(0, 7),
        path: "median.radius",
        get: |p| Value::Int(if p.median.enabled { p.median.radius } else { 0 }),
        set: |p, v| {
            match int(v)? {
                0 => p.median.enabled = false,
                radius => p.median.radius = radius,
            }
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--median-sigma")),
        key: Some("medianSigma"),
        doc: "Weighted median: colour scale σ of the weights (unit intensity)",
        kind: closed(0.005, 0.5),
        path: "median.color_sigma",
        get: |p| Value::Float(p.median.color_sigma),
        set: |p, v| {
            p.median.color_sigma = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--median-passes")),
        key: Some("medianPasses"),
        doc: "Weighted median: passes (each moves a fattened band a window further back onto its colour edge)",
        kind: ints(1, 4),
        path: "median.passes",
        get: |p| Value::Int(p.median.passes),
        set: |p, v| {
            p.median.passes = int(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--median-gate")),
        key: Some("medianGate"),
        doc: "Weighted median: only pixels whose window holds a step between adjacent pixels larger than this (px) are filtered",
        kind: closed(0.0, 16.0),
        path: "median.gate",
        get: |p| Value::Float(p.median.gate),
        set: |p, v| {
            p.median.gate = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--median-snap")),
        key: Some("medianSnap"),
        doc: "Weighted median: a pixel takes the median only when it differs from it by more than this (px)",
        kind: closed(0.0, 16.0),
        path: "median.snap",
        get: |p| Value::Float(p.median.snap),
        set: |p, v| {
            p.median.snap = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Switch {
            name: "--median-flat",
            sets: true,
            doc: "Weighted median: neighbours vote with their own value instead of extrapolating along the local slope (best on scenes of flat surfaces)",
        }),
        key: Some("medianFlat"),
        doc: "Weighted median: neighbours vote with their own value instead of extrapolating along the local slope",
        kind: Kind::Bool,
        path: "median.flat",
        get: |p| Value::Bool(!p.median.planar),
        set: |p, v| {
            p.median.planar = !boolean(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Switch {
            name: "--median-after-tv",
            sets: false,
            doc: "Weighted median: run it after TV instead of between the refinement and TV",
        }),
        key: Some("medianBeforeTv"),
        doc: "Weighted median: run it between the refinement and TV (true) or after TV (false)",
        kind: Kind::Bool,
        path: "median.before_tv",
        get: |p| Value::Bool(p.median.before_tv),
        set: |p, v| {
            p.median.before_tv = boolean(v)?;
            Some(())
        },
    },
    // Total-variation refinement.
    Tunable {
        flag: Some(Flag::Value("--lambda")),
        key: Some("lambda"),
        doc: "TV refinement: weight λ of the total variation against the data term (larger: smoother)",
        kind: Kind::Float {
            min: 0.0,
            max: 1000.0,
            min_open: true,
        },
        path: "tv.lambda",
        get: |p| Value::Float(p.tv.lambda),
        set: |p, v| {
            p.tv.lambda = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--tv-iterations")),
        key: Some("iterations"),
        doc: "TV refinement: most PPXA iterations per tile",
        kind: ints(1, 100_000),
        path: "tv.max_iterations",
        get: |p| Value::Int(p.tv.max_iterations),
        set: |p, v| {
            p.tv.max_iterations = int(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--tv-tolerance")),
        key: Some("tvTolerance"),
        doc: "TV refinement: stopping tolerance, the RMS change of the refined disparity over one iteration in px (0: run every iteration; smaller: closer to the exact minimiser)",
        kind: closed(0.0, f32::INFINITY),
        path: "tv.tolerance",
        get: |p| Value::Float(p.tv.tolerance),
        set: |p, v| {
            p.tv.tolerance = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--tv-tile")),
        key: Some("tvTile"),
        doc: "TV refinement: side of a tile's core in px (the page's tvTile works on one)",
        kind: ints(8, 4096),
        path: "tv.tile",
        get: |p| Value::Int(p.tv.tile),
        set: |p, v| {
            p.tv.tile = int(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--tv-halo")),
        key: Some("tvHalo"),
        doc: "TV refinement: pixels of context around each tile",
        kind: ints(0, 256),
        path: "tv.halo",
        get: |p| Value::Int(p.tv.halo),
        set: |p, v| {
            p.tv.halo = int(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--tv-sweeps")),
        key: Some("tvSweeps"),
        doc: "TV refinement: outer sweeps: solve every tile again from the previous pass's dual with the flows across its border held at the neighbours' values, so tiles agree where they meet",
        kind: ints(0, 8),
        path: "tv.sweeps",
        get: |p| Value::Int(p.tv.sweeps),
        set: |p, v| {
            p.tv.sweeps = int(v)?;
            Some(())
        },
    },
];

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::string::ToString;
    use std::vec::Vec;

    /// Every tunable's default is its value in `Params::default()`, except alignment's
    /// mode, which the front ends turn to auto.
    #[test]
    fn defaults_are_params_default() {
        let params = Params::default();
        for t in TUNABLES {
            if t.path == "align.mode" {
                assert_eq!(t.get(&params), Value::Choice("off"));
                assert_eq!(t.default_value(), Value::Choice("auto"));
            } else {
                assert_eq!(t.default_value(), t.get(&params), "{t:?}");
            }
        }
        let mut expected = Params::default();
        expected.align.mode = AlignMode::Auto;
        assert_eq!(base(Preset::Default), expected);
        for preset in Preset::ALL {
            assert_eq!(base(preset).align.mode, AlignMode::Auto);
            validate(&base(preset), Front::Cli).unwrap();
        }
    }

    /// Names are unique; every value kind round-trips through `apply` and `get`.
    #[test]
    fn names_are_unique_and_values_round_trip() {
        let names = |f: &dyn Fn(&Tunable) -> Option<&'static str>| {
            let mut v: Vec<&str> = TUNABLES.iter().filter_map(f).collect();
            let n = v.len();
            v.sort_unstable();
            v.dedup();
            assert_eq!(v.len(), n, "duplicate names: {v:?}");
        };
        names(&|t| t.flag.map(|f| f.name()));
        names(&|t| t.key);
        names(&|t| Some(t.path));
        for t in TUNABLES {
            assert!(t.flag.is_some() || t.key.is_some(), "{t:?}");
            assert!(t.flag.is_none_or(|f| f.name().starts_with("--")));
            assert!(!t.doc.is_empty() && !t.doc.ends_with('.'), "{t:?}");
            assert_eq!(
                by_flag(t.flag.map_or("", |f| f.name())).map(|x| x.path),
                t.flag.map(|_| t.path)
            );
            assert_eq!(
                by_key(t.key.unwrap_or("")).map(|x| x.path),
                t.key.map(|_| t.path)
            );
            let values: Vec<Value> = match t.kind {
                Kind::Float { min, max, min_open } => {
                    let low = if min_open { min + 0.5 } else { min };
                    [low, max.min(100.0)].map(Value::Float).to_vec()
                }
                Kind::Int { min, max } => [min, max].map(Value::Int).to_vec(),
                Kind::Bool => [true, false].map(Value::Bool).to_vec(),
                Kind::Choice(names) => names.iter().map(|n| Value::Choice(n)).collect(),
                Kind::Range => [
                    DisparityRange::Auto,
                    DisparityRange::Fixed {
                        min: -2.0,
                        max: 1.5,
                    },
                ]
                .map(Value::Range)
                .to_vec(),
            };
            for value in values {
                let mut p = base(Preset::Default);
                t.apply(&mut p, value).unwrap();
                assert_eq!(t.get(&p), value, "{t:?}");
                t.check(value, Front::Cli).unwrap();
            }
            // A value of another kind is refused, naming the tunable.
            let other = match t.kind {
                Kind::Bool => Value::Int(1),
                _ => Value::Bool(true),
            };
            let err = t.check(other, Front::Js).unwrap_err();
            assert!(
                matches!(err, Error::InvalidParameter { name, .. } if Some(name) == t.key || name == t.path),
                "{err:?}"
            );
        }
    }

    /// The ranges the help texts print are those the stages accept: the ends pass,
    /// values just outside fail with the tunable's own name.
    #[test]
    fn printed_ranges_are_the_stages_ranges() {
        for t in TUNABLES {
            let outside: Vec<Value> = match t.kind {
                Kind::Float { min, max, min_open } => {
                    let mut v = Vec::from([Value::Float(f32::NAN)]);
                    v.push(Value::Float(if min_open { min } else { min - 1e-3 }));
                    if max.is_finite() {
                        v.push(Value::Float(max + max * 1e-3));
                    }
                    v
                }
                Kind::Int { min, max } => {
                    let mut v = Vec::from([Value::Int(max + 1)]);
                    if min > 0 {
                        v.push(Value::Int(min - 1));
                    }
                    v
                }
                Kind::Range => [
                    DisparityRange::Fixed {
                        min: 1.0,
                        max: -1.0,
                    },
                    DisparityRange::Fixed {
                        min: -MAX_DISPARITY - 1.0,
                        max: 0.0,
                    },
                ]
                .map(Value::Range)
                .to_vec(),
                Kind::Bool | Kind::Choice(_) => Vec::new(),
            };
            for value in outside {
                for front in [Front::Cli, Front::Js] {
                    let err = t.check(value, front).unwrap_err();
                    let Error::InvalidParameter { name, .. } = err else {
                        panic!("{err:?}");
                    };
                    assert_eq!(Some(name), t.name(front), "{t:?} {value:?}");
                }
            }
        }
    }

    #[test]
    fn errors_name_the_option_as_typed() {
        let lambda = by_flag("--lambda").unwrap();
        let err = lambda.check(Value::Float(-1.0), Front::Cli).unwrap_err();
        assert_eq!(err.to_string(), "parameter `--lambda` must be in (0, 1000]");
        let err = lambda.check(Value::Float(-1.0), Front::Js).unwrap_err();
        assert_eq!(err.to_string(), "parameter `lambda` must be in (0, 1000]");
        // A parameter no front end exposes keeps its internal name.
        let e = Error::InvalidParameter {
            name: "tv.tikhonov",
            reason: "r",
        };
        assert_eq!(rename(e, Front::Cli), e);
        // `medianRadius` exists only in wasm under that name; `--median` on the CLI.
        let radius = by_key("medianRadius").unwrap();
        assert_eq!(radius.name(Front::Cli), Some("--median"));
        assert_eq!(by_key("shear").unwrap().name(Front::Cli), None);
    }

    #[test]
    fn parse_reads_command_line_text() {
        let t = |flag| by_flag(flag).unwrap();
        assert_eq!(t("--lambda").parse("0.5"), Ok(Value::Float(0.5)));
        assert_eq!(t("--tv-tolerance").parse("2e-3"), Ok(Value::Float(2e-3)));
        assert!(t("--lambda").parse("inf").is_err());
        assert!(t("--lambda").parse("x").is_err());
        assert_eq!(t("--median").parse("3"), Ok(Value::Int(3)));
        assert!(t("--median").parse("-1").is_err());
        assert_eq!(t("--refine").parse("0"), Ok(Value::Bool(false)));
        assert_eq!(t("--refine").parse("1"), Ok(Value::Bool(true)));
        assert!(t("--refine").parse("2").is_err());
        assert_eq!(t("--align").parse("on"), Ok(Value::Choice("on")));
        assert!(t("--align").parse("sideways").is_err());
        assert_eq!(
            t("--disparity-range").parse("-1..2.5"),
            Ok(Value::Range(DisparityRange::Fixed {
                min: -1.0,
                max: 2.5
            }))
        );
        assert_eq!(
            t("--disparity-range").parse("auto"),
            Ok(Value::Range(DisparityRange::Auto))
        );
        assert!(t("--disparity-range").parse("1..x").is_err());
    }

    #[test]
    fn kinds_print_their_ranges() {
        let shown = |flag| by_flag(flag).unwrap().kind.to_string();
        assert_eq!(shown("--lambda"), "(0, 1000]");
        assert_eq!(shown("--tv-tolerance"), "≥ 0");
        assert_eq!(shown("--epi-inner-sigma"), "0…4");
        assert_eq!(shown("--refine-iterations"), "1…16");
        assert_eq!(shown("--align"), "off|on|auto");
        assert_eq!(Value::Float(7e-4).to_string(), "0.0007");
    }

    #[test]
    fn no_shear_is_the_papers_variant() {
        let t = by_flag("--no-shear").unwrap();
        let mut p = base(Preset::Fast);
        t.apply(&mut p, Value::Bool(true)).unwrap();
        assert_eq!(p.epi, EpiParams::paper());
        assert_eq!(p.refine, base(Preset::Fast).refine);
        t.apply(&mut p, Value::Bool(false)).unwrap();
        assert_eq!(p.epi, EpiParams::default());
    }
}
