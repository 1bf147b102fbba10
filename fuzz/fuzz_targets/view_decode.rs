//! Any bytes given to the view decoder under the caps the CLI loads views with
//! (`lfdepth_cli::io::limits::Limits::default()`): an image within the caps whose sample
//! count matches its size, or an `IoError` with a message, never a panic, a hang or an
//! allocation sized by an unchecked header.
//!
//! The first byte picks the container; each format the loader decodes is one arm of
//! [`Format`] (PNG today).
#![no_main]

use lfdepth_cli::io::limits::Limits;
use lfdepth_cli::io::png::{self, Samples};
use libfuzzer_sys::fuzz_target;

/// The containers the view loader reads.
#[derive(Clone, Copy, Debug)]
enum Format {
    Png,
}

const FORMATS: [Format; 1] = [Format::Png];

fuzz_target!(|data: &[u8]| {
    let Some((&pick, bytes)) = data.split_first() else {
        return;
    };
    let format = FORMATS[usize::from(pick) % FORMATS.len()];
    let limits = Limits::default();
    let decoded = match format {
        Format::Png => png::decode_limited(bytes, limits.max_view_pixels),
    };
    match decoded {
        Ok(image) => {
            assert!(image.width > 0 && image.height > 0);
            assert!(limits.check_view(image.width, image.height).is_ok());
            assert!((1..=4).contains(&image.channels));
            let len = match &image.samples {
                Samples::Eight(s) => s.len(),
                Samples::Sixteen(s) => s.len(),
            };
            assert_eq!(len, image.width * image.height * image.channels);
        }
        Err(e) => {
            let message = e.to_string();
            assert!(!message.is_empty());
            // A human sentence, not a Rust debug structure.
            assert!(!message.contains(" { "), "debug text in {message:?}");
        }
    }
});
