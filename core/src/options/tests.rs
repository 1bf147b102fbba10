//! The table against `Params::default()`, the stages' checks and its own names.

extern crate std;
use super::*;
use crate::align::AlignMode;
use crate::epi::EpiParams;
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
