//! Any bytes given to the PFM decoder: an image or an `IoError`, never a panic (nor an
//! allocation sized by an unchecked header).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = lfdepth_cli::io::pfm::decode(data);
});
