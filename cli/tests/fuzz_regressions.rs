//! Replays the regression corpus of the byte-level fuzz targets
//! (`fuzz/regressions/<target>/`): every input that once crashed a target, or gave an
//! unclear answer, goes through the same call the target makes and must give a value or
//! an error in words, never a panic. `grid_infer`'s inputs are name listings, decoded
//! and located by the target's own code (`fuzz/fuzz_targets/grid_infer_input.rs`,
//! included here). The structured targets (`options_parse`, `stages`, `align`) keep
//! theirs in `fuzz/regressions/` too, for `cargo fuzz run`; each crash they found is
//! also a unit test in the crate it concerns (see docs/FUZZING.md).

use std::path::PathBuf;

use lfdepth_cli::io::limits::Limits;
use lfdepth_cli::io::{cfg, formats, pfm};

#[path = "../../fuzz/fuzz_targets/grid_infer_input.rs"]
mod grid_infer_input;

use grid_infer_input::Listing;

fn corpus(target: &str) -> Vec<(PathBuf, Vec<u8>)> {
    let dir =
        PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../fuzz/regressions")).join(target);
    let mut files: Vec<(PathBuf, Vec<u8>)> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| {
            let path = e.unwrap().path();
            let bytes = std::fs::read(&path).unwrap();
            (path, bytes)
        })
        .collect();
    files.sort();
    assert!(!files.is_empty(), "{} is empty", dir.display());
    files
}

/// An error message in words: not empty, no Rust debug structure.
fn in_words(message: &str, path: &std::path::Path) {
    assert!(!message.is_empty(), "{}", path.display());
    assert!(
        !message.contains(" { ") && !message.contains("ChunkType"),
        "{}: {message}",
        path.display()
    );
}

#[test]
fn view_decode_regressions() {
    for (path, bytes) in corpus("view_decode") {
        // As the target: the first byte picks a signature (none, PNG, JPEG, TIFF) put
        // before the other bytes unless they start with it.
        let Some((&pick, data)) = bytes.split_first() else {
            continue;
        };
        let signature: &[u8] = match pick % 4 {
            0 => b"",
            1 => b"\x89PNG\r\n\x1a\n",
            2 => b"\xFF\xD8\xFF",
            _ => b"II*\0",
        };
        let mut file = Vec::new();
        if !data.starts_with(signature) {
            file.extend_from_slice(signature);
        }
        file.extend_from_slice(data);
        match formats::decode_limited(&file, Limits::default().max_view_pixels) {
            Ok(image) => assert!(image.width > 0 && image.height > 0),
            Err(e) => in_words(&e.to_string(), &path),
        }
    }
}

#[test]
fn pfm_decode_regressions() {
    for (path, bytes) in corpus("pfm_decode") {
        if let Err(e) = pfm::decode(&bytes) {
            in_words(&e.to_string(), &path);
        }
    }
}

#[test]
fn cfg_parse_regressions() {
    for (path, bytes) in corpus("cfg_parse") {
        if let Ok(text) = std::str::from_utf8(&bytes) {
            if let Err(e) = cfg::parse(text) {
                in_words(&e.to_string(), &path);
            }
        }
    }
}

#[test]
fn grid_infer_regressions() {
    for (path, bytes) in corpus("grid_infer") {
        // The target ignores input that is not UTF-8: no such input can be a regression.
        let Some(listing) = Listing::decode(&bytes) else {
            panic!("{}: not UTF-8, which grid_infer ignores", path.display());
        };
        match listing.locate() {
            Ok(files) => {
                assert!(files.grid.is_supported(), "{}", path.display());
                assert_eq!(files.paths.len(), files.grid.len(), "{}", path.display());
                assert_eq!(files.present.len(), files.grid.len(), "{}", path.display());
                for (p, &present) in files.paths.iter().zip(&files.present) {
                    let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
                    assert!(
                        !present || listing.names.iter().any(|n| n == name),
                        "{name}"
                    );
                }
            }
            Err(e) if listing.quotes_braces() => {
                assert!(!e.to_string().is_empty(), "{}", path.display());
            }
            Err(e) => in_words(&e.to_string(), &path),
        }
    }
}
