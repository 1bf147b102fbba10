//! Estimator parameters from the command line: `--preset` and one flag per tunable of
//! the core's table (`lfdepth::options::TUNABLES`), built with clap's builder API and
//! read back through the same table, so the flags, their help and their checks are the
//! core's.

use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::{Arg, ArgAction, ArgMatches, Args, Command, FromArgMatches};
use lfdepth::align::AlignReport;
use lfdepth::epi::DisparityRange;
use lfdepth::options::{self, Flag, Front, Kind, Tunable, Value, TUNABLES};
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

/// A flag the user gave.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Given {
    /// A tunable's value.
    Value(Value),
    /// `--disparity-range`, which may also name the scene's parameters.cfg.
    Range(RangeChoice),
}

/// Estimator flags shared by `estimate`, `eval --dataset` and `demo`: `--preset`, then one
/// flag per tunable of the core's table, applied over the preset in the table's order
/// wherever they stand on the command line.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamArgs {
    /// The preset the other flags override.
    pub preset: Preset,
    /// The tunables given (index into `TUNABLES`), in the table's order.
    given: Vec<(usize, Given)>,
}

impl Default for ParamArgs {
    /// The parameters of no flag: the default preset.
    fn default() -> Self {
        ParamArgs {
            preset: Preset::Default,
            given: Vec::new(),
        }
    }
}

/// The clap id (and long name) of a flag: its name without the dashes.
fn id(flag: Flag) -> &'static str {
    flag.name().trim_start_matches('-')
}

/// A tunable's default as the command line writes it.
fn default_text(t: &Tunable) -> String {
    match t.default_value() {
        Value::Bool(on) => u8::from(on).to_string(),
        other => other.to_string(),
    }
}

/// The help line of `--preset`, listing every preset.
fn preset_help() -> String {
    let presets: Vec<String> = Preset::ALL
        .iter()
        .map(|&p| format!("{} ({})", p.name(), options::preset_doc(p)))
        .collect();
    format!(
        "Start from a named set of estimator parameters: {}. Every other estimator flag overrides the preset's value, wherever it stands on the command line.",
        presets.join(", or ")
    )
}

/// The clap argument of a tunable (`None` when it has no flag).
fn flag_arg(t: &'static Tunable) -> Option<Arg> {
    let flag = t.flag?;
    let arg = Arg::new(id(flag)).long(id(flag));
    let help = |range: String| format!("{} ({range}default {}).", t.doc, default_text(t));
    Some(match (flag, t.kind) {
        (Flag::Switch { doc, .. }, _) => arg.action(ArgAction::SetTrue).help(format!("{doc}.")),
        (Flag::Value(_), Kind::Range) => arg
            .value_name("A..B|auto|cfg")
            .allow_hyphen_values(true)
            .value_parser(parse_range_choice)
            .help(format!(
                "{}: MIN..MAX (e.g. -2..2), or cfg (disp_min..disp_max of the scene's parameters.cfg); within ±{} (default {}).",
                t.doc,
                lfdepth::epi::MAX_DISPARITY,
                default_text(t)
            )),
        (Flag::Value(_), Kind::Choice(names)) => arg
            .value_name("NAME")
            .value_parser(PossibleValuesParser::new(names).map(move |name: String| {
                // The parser admits only these names.
                let name = names.iter().find(|n| **n == name).copied().unwrap_or(names[0]);
                Value::Choice(name)
            }))
            .help(help(String::new())),
        (Flag::Value(_), Kind::Bool) => arg
            .value_name("0|1")
            .value_parser(move |text: &str| t.parse(text))
            .help(help("1 on, 0 off; ".into())),
        (Flag::Value(_), kind) => arg
            .value_name(if matches!(kind, Kind::Int { .. }) { "N" } else { "F" })
            .allow_negative_numbers(true)
            .value_parser(move |text: &str| t.parse(text))
            .help(help(format!("{kind}; "))),
    })
}

impl Args for ParamArgs {
    fn augment_args(cmd: Command) -> Command {
        cmd.arg(
            Arg::new("preset")
                .long("preset")
                .value_name("NAME")
                .default_value("default")
                .value_parser(parse_preset)
                .help(preset_help()),
        )
        .args(TUNABLES.iter().filter_map(flag_arg))
    }

    fn augment_args_for_update(cmd: Command) -> Command {
        Self::augment_args(cmd)
    }
}

impl FromArgMatches for ParamArgs {
    fn from_arg_matches(matches: &ArgMatches) -> Result<Self, clap::Error> {
        let preset = matches
            .try_get_one::<Preset>("preset")
            .ok()
            .flatten()
            .copied()
            .unwrap_or(Preset::Default);
        let mut given = Vec::new();
        for (index, t) in TUNABLES.iter().enumerate() {
            let Some(flag) = t.flag else { continue };
            let value = match (flag, t.kind) {
                (Flag::Switch { sets, .. }, _) => matches
                    .try_get_one::<bool>(id(flag))
                    .ok()
                    .flatten()
                    .filter(|on| **on)
                    .map(|_| Given::Value(Value::Bool(sets))),
                (Flag::Value(_), Kind::Range) => matches
                    .try_get_one::<RangeChoice>(id(flag))
                    .ok()
                    .flatten()
                    .map(|r| Given::Range(*r)),
                (Flag::Value(_), _) => matches
                    .try_get_one::<Value>(id(flag))
                    .ok()
                    .flatten()
                    .map(|v| Given::Value(*v)),
            };
            given.extend(value.map(|v| (index, v)));
        }
        Ok(ParamArgs { preset, given })
    }

    fn update_from_arg_matches(&mut self, matches: &ArgMatches) -> Result<(), clap::Error> {
        *self = Self::from_arg_matches(matches)?;
        Ok(())
    }
}

/// The scene's `disp_min`/`disp_max` as `--disparity-range cfg` uses them: finite,
/// `disp_min <= disp_max`, both within ±[`lfdepth::epi::MAX_DISPARITY`]. The error names the file's
/// keys, not the flag.
fn check_config_range(min: f64, max: f64) -> Result<(), CliError> {
    let limit = f64::from(lfdepth::epi::MAX_DISPARITY);
    if min.is_finite() && max.is_finite() && min <= max && min >= -limit && max <= limit {
        return Ok(());
    }
    Err(CliError::Usage(format!(
        "the scene's parameters.cfg gives disp_min = {min} and disp_max = {max}, which --disparity-range cfg cannot use: they must be finite with disp_min <= disp_max, both within -{limit}..{limit} px; fix the file or give --disparity-range MIN..MAX or auto"
    )))
}

impl ParamArgs {
    /// The parameters these flags ask for; `config` is the scene's parameters.cfg.
    /// Out-of-range values are reported here, before any view is decoded, naming the
    /// flag.
    pub fn params(&self, config: Option<&SceneConfig>) -> Result<Params, CliError> {
        let mut params = options::base(self.preset);
        let no_shear = self
            .given
            .iter()
            .any(|&(i, _)| TUNABLES[i].flag.map(Flag::name) == Some("--no-shear"));
        for &(index, given) in &self.given {
            let value = match given {
                Given::Value(v) => v,
                // The paper's variant keeps its own fixed range unless one is given.
                Given::Range(RangeChoice::Auto) if no_shear => continue,
                Given::Range(RangeChoice::Auto) => Value::Range(DisparityRange::Auto),
                Given::Range(RangeChoice::Fixed(r)) => Value::Range(DisparityRange::Fixed {
                    min: r.min,
                    max: r.max,
                }),
                Given::Range(RangeChoice::Config) => {
                    let (min, max) = config.and_then(SceneConfig::disparity_range).ok_or_else(|| {
                        CliError::Usage(
                            "--disparity-range cfg needs disp_min and disp_max in the scene's parameters.cfg: give MIN..MAX or auto instead".into(),
                        )
                    })?;
                    check_config_range(min, max)?;
                    Value::Range(DisparityRange::Fixed {
                        min: min as f32,
                        max: max as f32,
                    })
                }
            };
            TUNABLES[index].apply(&mut params, value).map_err(|e| {
                CliError::core(
                    "reading the estimator flags",
                    options::rename(e, Front::Cli),
                )
            })?;
        }
        options::validate(&params, Front::Cli)
            .map_err(|e| CliError::core("checking the estimator flags", e))?;
        Ok(params)
    }
}
#[cfg(test)]
mod tests {
    use super::*;
    use crate::commands::Cli;
    use clap::{CommandFactory, Parser};

    /// `ParamArgs` alone, as a command line parses it.
    #[derive(Debug, Parser)]
    struct Flags {
        #[command(flatten)]
        params: ParamArgs,
    }

    fn parse(args: &[&str]) -> Result<ParamArgs, clap::Error> {
        Flags::try_parse_from(std::iter::once("flags").chain(args.iter().copied()))
            .map(|f| f.params)
    }

    fn params(args: &[&str]) -> Params {
        parse(args).unwrap().params(None).unwrap()
    }

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
        let args = parse(&["--disparity-range", "cfg"]).unwrap();
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
        assert_eq!(
            params(&["--disparity-range", "-1..2"]).epi.range,
            DisparityRange::Fixed {
                min: -1.0,
                max: 2.0
            }
        );
        // The paper's variant keeps its fixed range under an explicit `auto`.
        let paper = lfdepth::epi::EpiParams::paper();
        assert_eq!(params(&["--no-shear"]).epi, paper);
        assert_eq!(
            params(&["--no-shear", "--disparity-range", "auto"]).epi,
            paper
        );
    }

    /// No flag: `Params::default()` with alignment on auto, and what `estimate` parses
    /// without flags is exactly that.
    #[test]
    fn defaults_are_the_cores() {
        let mut expected = Params::default();
        expected.align.mode = lfdepth::align::AlignMode::Auto;
        assert_eq!(params(&[]), expected);
        assert_eq!(ParamArgs::default().params(None).unwrap(), expected);
        assert_eq!(
            expected.align.interpolation,
            lfdepth::align::Interpolation::SharpenedBilinear
        );
        for command in [
            &["lfdepth", "estimate", "in", "-o", "x.pfm"][..],
            &["lfdepth", "eval", "--dataset", "d"][..],
            &["lfdepth", "demo"][..],
        ] {
            let cli = Cli::try_parse_from(command).unwrap();
            let args = match &cli.command {
                crate::commands::Command::Estimate(a) => &a.params,
                crate::commands::Command::Eval(a) => &a.params,
                crate::commands::Command::Demo(a) => &a.params,
                crate::commands::Command::Synth(_) => unreachable!(),
            };
            assert_eq!(args.params(None).unwrap(), expected, "{command:?}");
        }
    }

    /// Each subcommand that estimates lists every flag of the table in its help, with its
    /// default.
    #[test]
    fn help_lists_every_table_flag() {
        let mut cli = Cli::command();
        for name in ["estimate", "eval", "demo"] {
            let help = cli
                .find_subcommand_mut(name)
                .unwrap()
                .render_long_help()
                .to_string();
            for t in TUNABLES {
                let Some(flag) = t.flag else { continue };
                assert!(help.contains(flag.name()), "{name}: {}", flag.name());
                if let Flag::Value(_) = flag {
                    let default = format!("default {}", default_text(t));
                    assert!(help.contains(&default), "{name}: {} {default}", flag.name());
                }
            }
            assert!(
                help.contains("--preset") && help.contains("fast ("),
                "{name}"
            );
        }
    }

    #[test]
    fn every_flag_sets_its_tunable() {
        for t in TUNABLES {
            let Some(flag) = t.flag else { continue };
            let (args, expected): (Vec<String>, Value) = match (flag, t.kind) {
                (Flag::Switch { sets, .. }, _) => (vec![flag.name().into()], Value::Bool(sets)),
                (_, Kind::Float { min, max, .. }) => {
                    let v = (min + max.min(16.0)) / 2.0;
                    (vec![flag.name().into(), v.to_string()], Value::Float(v))
                }
                // The largest value: every whole-number tunable accepts it (the sweep's
                // candidate window takes odd sides only, so a midpoint may be refused).
                (_, Kind::Int { max, .. }) => {
                    let v = max;
                    (vec![flag.name().into(), v.to_string()], Value::Int(v))
                }
                (_, Kind::Bool) => {
                    let v = !matches!(t.default_value(), Value::Bool(true));
                    (
                        vec![flag.name().into(), u8::from(v).to_string()],
                        Value::Bool(v),
                    )
                }
                (_, Kind::Choice(names)) => {
                    let v = names[names.len() - 1];
                    (vec![flag.name().into(), v.into()], Value::Choice(v))
                }
                (_, Kind::Range) => (
                    vec![flag.name().into(), "-1.5..0.5".into()],
                    Value::Range(DisparityRange::Fixed {
                        min: -1.5,
                        max: 0.5,
                    }),
                ),
            };
            let mut args: Vec<&str> = args.iter().map(String::as_str).collect();
            // The half-resolution EPI needs the EPI start, which the plane sweep replaces.
            if t.path == "half_resolution" {
                args.extend(["--initial", "epi"]);
            }
            assert_eq!(t.get(&params(&args)), expected, "{args:?}");
        }
    }

    #[test]
    fn preset_flags() {
        assert_eq!(parse_preset("fast"), Ok(Preset::Fast));
        let err = parse_preset("turbo").unwrap_err();
        assert!(
            err.contains("turbo") && err.contains("default, fast"),
            "{err}"
        );
        assert_eq!(params(&["--preset", "fast"]), options::base(Preset::Fast));
        // Explicit flags win over the preset, wherever they stand.
        let p = params(&[
            "--refine-iterations",
            "5",
            "--preset",
            "fast",
            "--refine-slack",
            "0.25",
            "--median-passes",
            "4",
            "--epi-color",
            "gray",
        ]);
        assert_eq!((p.refine.iterations, p.median.passes), (5, 4));
        assert_eq!(p.refine.sampling_slack, 0.25);
        assert_eq!(p.epi.color, lfdepth::epi::ColorMode::Gray);
        assert_eq!(
            p.refine.propagation,
            options::base(Preset::Fast).refine.propagation
        );
    }

    /// Bad values fail, naming the flag as typed.
    #[test]
    fn bad_values_name_the_flag() {
        for (args, flag) in [
            (&["--refine", "2"][..], "--refine"),
            (&["--align", "sideways"][..], "--align"),
            (&["--lambda", "x"][..], "--lambda"),
            (&["--median", "-1"][..], "--median"),
        ] {
            let err = parse(args).unwrap_err().to_string();
            assert!(err.contains(flag), "{args:?}: {err}");
        }
        for (args, flag) in [
            (&["--refine-iterations", "0"][..], "`--refine-iterations`"),
            (&["--epi-shear-step", "5"][..], "`--epi-shear-step`"),
            (&["--fill-band", "0"][..], "`--fill-band`"),
            (&["--lambda", "-1"][..], "`--lambda`"),
            (&["--disparity-range", "-20..20"][..], "`--disparity-range`"),
        ] {
            let err = parse(args).unwrap().params(None).unwrap_err().to_string();
            assert!(err.contains(flag), "{args:?}: {err}");
        }
    }

    #[test]
    fn fill_flags() {
        let g = params(&[
            "--fill",
            "1",
            "--fill-band",
            "12",
            "--fill-max-cost",
            "0.3",
            "--fill-planar",
        ])
        .geofill;
        assert!(g.enabled && g.planar);
        assert_eq!((g.band, g.reach, g.max_cost), (12, 24, 0.3));
        assert!(!params(&["--fill", "0"]).geofill.enabled);
    }

    #[test]
    fn median_flags() {
        let m = params(&["--median", "3", "--median-flat", "--median-after-tv"]).median;
        assert!(m.enabled && !m.planar && !m.before_tv);
        assert_eq!(m.radius, 3);
        let off = params(&["--median", "0"]).median;
        assert!(!off.enabled);
        assert_eq!(off.radius, Params::default().median.radius);
    }
}
