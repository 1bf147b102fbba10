//! Any UTF-8 text given to the HCI `parameters.cfg` parser: a scene configuration or an
//! `IoError`, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = core::str::from_utf8(data) {
        let _ = lfdepth_cli::io::cfg::parse(text);
    }
});
