//! The folder and grid inference over a list of file names: any names, an optional
//! `--pattern`, `--grid` and `parameters.cfg` grid → `scene::locate_names` gives a
//! supported grid with one file per view (each present view's name among the names
//! given), or an error in words (no Rust debug structure where no name given and no
//! pattern holds braces the message could quote); never a panic or a hang.
//!
//! Input: a name listing with the options, decoded by [`grid_infer_input`] (shared
//! with `cli/tests/fuzz_regressions.rs`, which replays this target's corpus).
#![no_main]

use libfuzzer_sys::fuzz_target;

mod grid_infer_input;

use grid_infer_input::Listing;

fuzz_target!(|data: &[u8]| {
    let Some(listing) = Listing::decode(data) else {
        return;
    };
    let names = &listing.names;
    match listing.locate() {
        Ok(files) => {
            assert!(files.grid.is_supported(), "{:?}", files.grid);
            assert_eq!(files.paths.len(), files.grid.len());
            assert_eq!(files.present.len(), files.grid.len());
            for (path, &present) in files.paths.iter().zip(&files.present) {
                let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
                assert!(!present || names.iter().any(|n| n == name), "{name}");
            }
        }
        Err(e) => {
            let message = e.to_string();
            assert!(!message.is_empty());
            if !listing.quotes_braces() {
                assert!(!message.contains(" { "), "{message}");
            }
        }
    }
});
