//! Caps on the size of what is decoded or rendered, checked from image headers (or the
//! requested size) before anything of that size is allocated.
//!
//! The defaults hold every light field we know of with room to spare — the HCI scenes
//! are 81 views of 512×512 (21 M pixels), Lytro Illum decodes 15×15 views of 625×434
//! (61 M), the Stanford gantry 17×17 views of up to 1536×1152 (511 M) — and bound a
//! run's memory to a few GiB: loading holds each sample twice, decoded and packed, so
//! about 6 bytes per pixel for 8-bit RGB and 18 for 16-bit RGB (3 and 9 GiB at the
//! light-field default). A header declaring more is refused before decoding, naming the
//! flag that raises the cap.

use std::fmt;

/// Default cap on one view: 8192 × 8192 pixels.
pub const DEFAULT_MAX_VIEW_PIXELS: u64 = 1 << 26;
/// Default cap on all views together: 512 Mi pixels.
pub const DEFAULT_MAX_PIXELS: u64 = 1 << 29;

/// The caps in force (`--max-view-pixels`, `--max-pixels`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// Most pixels one view (or a mask) may have.
    pub max_view_pixels: u64,
    /// Most pixels all views of a light field may have together.
    pub max_pixels: u64,
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            max_view_pixels: DEFAULT_MAX_VIEW_PIXELS,
            max_pixels: DEFAULT_MAX_PIXELS,
        }
    }
}

/// Why a size was refused; the message names the flag that raises the cap.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TooLarge(String);

impl fmt::Display for TooLarge {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl TooLarge {
    /// The message.
    pub fn message(&self) -> &str {
        &self.0
    }
}

fn product(values: &[usize]) -> Option<u64> {
    values
        .iter()
        .try_fold(1u64, |acc, &v| acc.checked_mul(u64::try_from(v).ok()?))
}

fn shown(n: Option<u64>) -> String {
    n.map_or_else(|| "more than 2^64".to_string(), |n| n.to_string())
}

impl Limits {
    /// Checks one view (or image) of `width`×`height` pixels.
    pub fn check_view(&self, width: usize, height: usize) -> Result<(), TooLarge> {
        let pixels = product(&[width, height]);
        if pixels.is_some_and(|p| p <= self.max_view_pixels) {
            return Ok(());
        }
        Err(TooLarge(format!(
            "{width}x{height} pixels ({}): more than the {} one view may have; if the size is genuine, raise --max-view-pixels",
            shown(pixels),
            self.max_view_pixels
        )))
    }

    /// Checks a light field of `views` views of `width`×`height` pixels each.
    pub fn check_light_field(
        &self,
        views: usize,
        width: usize,
        height: usize,
    ) -> Result<(), TooLarge> {
        self.check_view(width, height)?;
        let pixels = product(&[views, width, height]);
        if pixels.is_some_and(|p| p <= self.max_pixels) {
            return Ok(());
        }
        Err(TooLarge(format!(
            "{views} views of {width}x{height} pixels ({} in all): more than the {} a light field may have; if you have the memory (about 6 bytes per pixel for 8-bit RGB views), raise --max-pixels",
            shown(pixels),
            self.max_pixels
        )))
    }
}

/// `N`, or `N` with a suffix `K`, `M`, `G` (powers of 1000) or `Ki`, `Mi`, `Gi` (powers
/// of 1024) → a positive count.
pub fn parse_count(text: &str) -> Result<u64, String> {
    let bad = || format!("`{text}` is not a positive count such as 100000000, 64Mi or 2G");
    let t = text.trim();
    let (digits, scale) = [
        ("Ki", 1u64 << 10),
        ("Mi", 1 << 20),
        ("Gi", 1 << 30),
        ("K", 1_000),
        ("k", 1_000),
        ("M", 1_000_000),
        ("G", 1_000_000_000),
    ]
    .iter()
    .find_map(|&(suffix, scale)| t.strip_suffix(suffix).map(|d| (d, scale)))
    .unwrap_or((t, 1));
    let n: u64 = digits.trim().parse().map_err(|_| bad())?;
    match n.checked_mul(scale) {
        Some(v) if v > 0 => Ok(v),
        _ => Err(bad()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn caps_and_messages() {
        let l = Limits::default();
        assert!(l.check_view(8192, 8192).is_ok());
        let e = l.check_view(60000, 60000).unwrap_err();
        assert!(e.message().contains("--max-view-pixels"), "{e}");
        assert!(l.check_view(usize::MAX, 3).is_err());
        assert!(l.check_light_field(81, 512, 512).is_ok());
        assert!(l.check_light_field(289, 1536, 1152).is_ok());
        let e = l.check_light_field(289, 2048, 2048).unwrap_err();
        assert!(e.message().contains("--max-pixels"), "{e}");
        assert!(l.check_light_field(usize::MAX, 16, 16).is_err());
    }

    #[test]
    fn counts() {
        assert_eq!(parse_count("1000"), Ok(1000));
        assert_eq!(parse_count("64Mi"), Ok(1 << 26));
        assert_eq!(parse_count("2G"), Ok(2_000_000_000));
        assert!(parse_count("0").is_err());
        assert!(parse_count("-5").is_err());
        assert!(parse_count("99999999999Gi").is_err());
        assert!(parse_count("lots").is_err());
    }
}
