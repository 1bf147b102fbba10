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

use crate::align::AlignMode;
use crate::epi::{DisparityRange, MAX_DISPARITY};
use crate::error::{Error, Result};
use crate::plan::{Params, Preset};

mod table;
#[cfg(test)]
mod tests;

pub use table::TUNABLES;

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
    /// stage accept it? Combinations with other tunables (the half-resolution EPI needs
    /// the EPI start) are [`validate`]'s. The error names the tunable as `front` knows it.
    pub fn check(&self, value: Value, front: Front) -> Result<()> {
        let mut params = base(Preset::Default);
        self.apply(&mut params, value)
            .and_then(|()| validate_stages(&params))
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
    validate_stages(params)
        .and_then(|()| crate::plan::check_initial(params))
        .map_err(|e| rename(e, front))
}

/// Every stage's `validate` on its own parameters.
fn validate_stages(params: &Params) -> Result<()> {
    params
        .align
        .validate()
        .and_then(|()| params.epi.validate())
        .and_then(|()| params.refine.validate())
        .and_then(|()| params.tv.validate())
        .and_then(|()| params.median.validate())
        .and_then(|()| params.geofill.validate())
        .and_then(|()| params.sweep.validate())
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
            "less CPU: the plane sweep on luminance, one Gauss–Newton step, three median passes"
        }
    }
}
