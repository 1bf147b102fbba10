//! Any bytes given to the view decoder under the caps the CLI loads views with
//! (`lfdepth_cli::io::limits::Limits::default()`), through
//! `lfdepth_cli::io::formats::decode_limited`, which tells PNG, JPEG and TIFF apart by
//! their first bytes as the loader does: an image within the caps whose sample count
//! matches its size, or an `IoError` with a message, never a panic, a hang or an
//! allocation sized by an unchecked header.
//!
//! The first byte picks a container ([`Format`]) whose signature is put before the
//! other bytes unless they already start with it (so random bytes reach every
//! decoder, and real files stay what they are); `Format::AsIs` leaves them alone.
#![no_main]

use lfdepth_cli::io::formats;
use lfdepth_cli::io::limits::Limits;
use lfdepth_cli::io::png::Samples;
use libfuzzer_sys::fuzz_target;

/// The containers the view loader reads, by the signature the input is given.
#[derive(Clone, Copy, Debug)]
enum Format {
    AsIs,
    Png,
    Jpeg,
    Tiff,
}

const FORMATS: [Format; 4] = [Format::AsIs, Format::Png, Format::Jpeg, Format::Tiff];

impl Format {
    fn signature(self) -> &'static [u8] {
        match self {
            Format::AsIs => b"",
            Format::Png => b"\x89PNG\r\n\x1a\n",
            Format::Jpeg => b"\xFF\xD8\xFF",
            Format::Tiff => b"II*\0",
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&pick, bytes)) = data.split_first() else {
        return;
    };
    let signature = FORMATS[usize::from(pick) % FORMATS.len()].signature();
    let mut file = Vec::with_capacity(signature.len() + bytes.len());
    if !bytes.starts_with(signature) {
        file.extend_from_slice(signature);
    }
    file.extend_from_slice(bytes);
    let limits = Limits::default();
    match formats::decode_limited(&file, limits.max_view_pixels) {
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
