//! `cargo xtask types`: writes the TypeScript declaration of the wasm package's
//! `EstimateParams` (`wasm/src/estimate_params.d.ts`), generated from the core's tunable
//! table by the `estimate_params_ts` example of lfdepth-wasm. A test of lfdepth-wasm
//! fails while the committed file differs from what the table gives.

use std::path::{Path, PathBuf};

use crate::exec::Cmd;

/// The generated file, relative to the repository root.
pub const TYPES_FILE: &str = "wasm/src/estimate_params.d.ts";

/// The command that prints the declaration.
pub fn generator() -> Cmd {
    Cmd::cargo(&[
        "run",
        "--quiet",
        "-p",
        "lfdepth-wasm",
        "--example",
        "estimate_params_ts",
    ])
}

/// Regenerates [`TYPES_FILE`]; says whether it changed.
pub fn run(root: &Path) -> bool {
    let path: PathBuf = root.join(TYPES_FILE);
    println!("$ {} > {TYPES_FILE}", generator());
    let generated = match generator().output(root) {
        Ok(text) => text,
        Err(e) => {
            eprintln!("error: {e}");
            return false;
        }
    };
    let old = std::fs::read_to_string(&path).unwrap_or_default();
    if old == generated {
        println!("{TYPES_FILE} is current");
        return true;
    }
    match std::fs::write(&path, &generated) {
        Ok(()) => {
            println!("{TYPES_FILE} rewritten");
            true
        }
        Err(e) => {
            eprintln!("error: cannot write {}: {e}", path.display());
            false
        }
    }
}
