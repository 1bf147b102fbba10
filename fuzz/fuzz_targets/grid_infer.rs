//! The folder and grid inference over a list of file names: any names, an optional
//! `--pattern`, `--grid` and `parameters.cfg` grid → `scene::locate_names` gives a
//! supported grid with one file per view (each present view's name among the names
//! given), or an error in words (no Rust debug structure where no name given and no
//! pattern holds braces the message could quote); never a panic or a hang.
//!
//! Input: UTF-8 text, one name per line. A first line starting with `?` holds the
//! options, `;`-separated: `grid=RxC`, `pattern=P`, `cfg=RxC` (`parameters.cfg`'s
//! `num_cams_y` × `num_cams_x`). `cli/tests/fuzz_regressions.rs` decodes its corpus
//! the same way.
#![no_main]

use std::path::Path;

use lfdepth::Grid;
use lfdepth_cli::io::cfg::SceneConfig;
use lfdepth_cli::io::scene::{self, LoadOptions};
use libfuzzer_sys::fuzz_target;

fn grid(text: &str) -> Option<(usize, usize)> {
    let (r, c) = text.split_once('x')?;
    Some((r.parse().ok()?, c.parse().ok()?))
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = core::str::from_utf8(data) else {
        return;
    };
    let mut lines = text.lines().peekable();
    let mut options = LoadOptions::default();
    let mut config = None;
    if let Some(first) = lines.next_if(|l| l.starts_with('?')) {
        for option in first[1..].split(';') {
            match option.split_once('=') {
                Some(("grid", g)) => options.grid = grid(g).map(|(r, c)| Grid::new(r, c)),
                Some(("pattern", p)) => options.pattern = Some(p.to_string()),
                Some(("cfg", g)) => {
                    config = grid(g).map(|(r, c)| SceneConfig {
                        num_cams_y: Some(r),
                        num_cams_x: Some(c),
                        ..SceneConfig::default()
                    })
                }
                _ => {}
            }
        }
    }
    let mut names: Vec<String> = lines.map(String::from).collect();
    names.sort();
    match scene::locate_names(Path::new("scene"), names.clone(), config, &options) {
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
            // Names and patterns are quoted as they are, braces included; without
            // them, braces in a message would be a Rust debug structure.
            let braces = |n: &String| n.contains(['{', '}']);
            if options.pattern.is_none() && !names.iter().any(braces) {
                assert!(!message.contains(" { "), "{message}");
            }
        }
    }
});
