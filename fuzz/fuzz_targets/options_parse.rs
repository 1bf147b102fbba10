//! The options table every front end parses through (`lfdepth::options`: the wasm
//! package's `params` object goes through `Tunable::parse`-equivalent typing,
//! `Tunable::apply` and `options::validate`, the CLI's flags through the same table):
//! arbitrary tunables given arbitrary text, in any order, on either preset. Parsing gives
//! a value or a reason; a parsed value prints as text that parses back to it; applying and
//! validating give `Ok` or an error whose parameter name is the one the front end's
//! user typed (a flag for the CLI, a key for the page), never an internal path; a plan
//! from accepted parameters is made or refused, never a panic.
#![no_main]

use lfdepth::options::{self, Front, TUNABLES};
use lfdepth::{Error, Grid, Layout, Plan, Preset};
use libfuzzer_sys::arbitrary::{self, Arbitrary};
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug)]
struct Setting {
    tunable: u8,
    text: String,
}

#[derive(Arbitrary, Debug)]
struct Input {
    fast: bool,
    js: bool,
    settings: Vec<Setting>,
    grid: (u8, u8),
    size: (u8, u8),
}

/// Whether `name` is how `front` knows some tunable, or a name no tunable stands for
/// (an error about something other than a tunable, e.g. the layout).
fn user_name(name: &str, front: Front) -> bool {
    match TUNABLES.iter().find(|t| t.path == name) {
        // An internal path: fine only when it is also the front's name for the tunable
        // (the page's key `window`), or the front has no name for it.
        Some(t) => t.name(front).is_none_or(|n| n == name),
        None => true,
    }
}

fn check_error(e: &Error, front: Front) {
    if let Error::InvalidParameter { name, .. } = e {
        assert!(user_name(name, front), "{e} names an internal path");
    }
}

fuzz_target!(|input: Input| {
    let front = if input.js { Front::Js } else { Front::Cli };
    let preset = if input.fast {
        Preset::Fast
    } else {
        Preset::Default
    };
    let mut params = options::base(preset);
    for setting in &input.settings {
        let t = &TUNABLES[usize::from(setting.tunable) % TUNABLES.len()];
        let value = match t.parse(&setting.text) {
            Ok(v) => v,
            Err(reason) => {
                assert!(!reason.is_empty());
                continue;
            }
        };
        // Printing a value and parsing it back gives the same value.
        let shown = value.to_string();
        let again = t.parse(&shown).expect("a printed value parses");
        assert_eq!(again.to_string(), shown);
        // One value on its own.
        if let Err(e) = t.check(value, front) {
            check_error(&e, front);
        }
        if let Err(e) = t.apply(&mut params, value) {
            check_error(&options::rename(e, front), front);
        }
    }
    match options::validate(&params, front) {
        Ok(()) => {
            let layout = Layout::packed(
                Grid::new(
                    usize::from(input.grid.0 % 12),
                    usize::from(input.grid.1 % 12),
                ),
                usize::from(input.size.0),
                usize::from(input.size.1),
                3,
            );
            if let Err(e) = Plan::new(layout, params) {
                check_error(&options::rename(e, front), front);
            }
        }
        Err(e) => check_error(&e, front),
    }
});
