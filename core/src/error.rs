//! The one error type of the core: every bad input is reported, never a panic.

use core::fmt;

/// Everything that can go wrong in the core. Each message says what to change.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Error {
    /// The view grid is outside the supported 3×3 … 17×17 and is no linear array of
    /// 1×3 … 1×17 or 3×1 … 17×1 views.
    GridSize { rows: usize, cols: usize },
    /// Views are smaller than 16×16 pixels.
    ViewTooSmall { width: usize, height: usize },
    /// Only 1 (gray), 3 (RGB) and 4 (RGBA) channels are supported.
    Channels { channels: usize },
    /// A stride is too small for the data it has to step over.
    Stride {
        which: &'static str,
        stride: usize,
        needed: usize,
    },
    /// Sizes whose product does not fit in `usize`.
    SizeOverflow { what: &'static str },
    /// An input buffer is shorter than its layout requires.
    BufferTooSmall {
        what: &'static str,
        needed: usize,
        got: usize,
    },
    /// An output buffer does not have the size the plan requires.
    OutputSize {
        what: &'static str,
        needed: usize,
        got: usize,
    },
    /// Caller-provided scratch is too short (`needed` elements of the scratch type).
    ScratchTooSmall { needed: usize, got: usize },
    /// A parameter is out of its valid range.
    InvalidParameter {
        name: &'static str,
        reason: &'static str,
    },
    /// An index (view, row, column, pixel) outside the light field.
    OutOfRange {
        what: &'static str,
        index: usize,
        len: usize,
    },
    /// Input contains NaN or infinity where finite values are required.
    NonFinite { what: &'static str },
    /// Alignment could not be estimated for a view.
    Alignment { view: usize, reason: &'static str },
    /// The progress callback asked to stop.
    Cancelled,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::GridSize { rows, cols } => write!(
                f,
                "a {rows}x{cols} view grid is not supported: use between 3x3 and 17x17 views, or one row or column of 3 to 17 views (1x3 to 1x17, 3x1 to 17x1)"
            ),
            Error::ViewTooSmall { width, height } => write!(
                f,
                "views of {width}x{height} pixels are too small: each view needs at least 16x16 pixels"
            ),
            Error::Channels { channels } => write!(
                f,
                "{channels} channels per pixel are not supported: use 1 (gray), 3 (RGB) or 4 (RGBA)"
            ),
            Error::Stride { which, stride, needed } => write!(
                f,
                "{which} of {stride} elements is too small: it must be at least {needed}"
            ),
            Error::SizeOverflow { what } => write!(
                f,
                "{what} is too large to address in memory: reduce the image or grid size"
            ),
            Error::BufferTooSmall { what, needed, got } => write!(
                f,
                "{what} holds {got} elements but its layout needs {needed}: check the width, height, channels and strides"
            ),
            Error::OutputSize { what, needed, got } => write!(
                f,
                "{what} has {got} elements but must have exactly {needed} (one per pixel of the centre view)"
            ),
            Error::ScratchTooSmall { needed, got } => write!(
                f,
                "scratch holds {got} elements but {needed} are needed: size it with scratch_len()"
            ),
            Error::InvalidParameter { name, reason } => write!(f, "parameter `{name}` {reason}"),
            Error::OutOfRange { what, index, len } => {
                write!(f, "{what} {index} is out of range: there are {len}")
            }
            Error::NonFinite { what } => {
                write!(f, "{what} contains NaN or infinity: only finite values are accepted")
            }
            Error::Alignment { view, reason } => {
                write!(f, "alignment of view {view} failed: {reason}")
            }
            Error::Cancelled => write!(f, "cancelled by the caller"),
        }
    }
}

impl core::error::Error for Error {}

/// Result type of the core.
pub type Result<T> = core::result::Result<T, Error>;

/// Multiplies sizes, reporting overflow as [`Error::SizeOverflow`] about `what`.
pub(crate) fn checked_product(factors: &[usize], what: &'static str) -> Result<usize> {
    factors.iter().try_fold(1usize, |acc, &f| {
        acc.checked_mul(f).ok_or(Error::SizeOverflow { what })
    })
}

/// [`Error::ScratchTooSmall`] unless `got` scratch elements cover the `needed` ones: the
/// check every stage makes before it touches its scratch.
pub(crate) fn check_scratch(needed: usize, got: usize) -> Result<()> {
    if got < needed {
        return Err(Error::ScratchTooSmall { needed, got });
    }
    Ok(())
}

/// [`Error::OutputSize`] for the first of `maps` (name, length) whose length is not
/// `needed`: the maps a stage reads and writes all hold one value per pixel.
pub(crate) fn check_map_lengths(needed: usize, maps: &[(&'static str, usize)]) -> Result<()> {
    for &(what, got) in maps {
        if got != needed {
            return Err(Error::OutputSize { what, needed, got });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::string::ToString;

    #[test]
    fn size_checks_name_the_first_bad_buffer() {
        assert_eq!(check_scratch(4, 4), Ok(()));
        assert_eq!(
            check_scratch(5, 4),
            Err(Error::ScratchTooSmall { needed: 5, got: 4 })
        );
        assert_eq!(check_map_lengths(3, &[("a", 3), ("b", 3)]), Ok(()));
        assert_eq!(
            check_map_lengths(3, &[("a", 3), ("b", 2), ("c", 1)]),
            Err(Error::OutputSize {
                what: "b",
                needed: 3,
                got: 2
            })
        );
    }

    #[test]
    fn messages_say_what_to_change() {
        let msg = Error::ScratchTooSmall { needed: 10, got: 3 }.to_string();
        assert!(msg.contains("scratch_len"), "{msg}");
        let msg = Error::GridSize { rows: 1, cols: 2 }.to_string();
        assert!(
            msg.contains("1x2") && msg.contains("3x3") && msg.contains("1x3"),
            "{msg}"
        );
    }

    #[test]
    fn checked_product_reports_overflow() {
        assert_eq!(checked_product(&[3, 4, 5], "x"), Ok(60));
        assert_eq!(
            checked_product(&[usize::MAX, 2], "frame"),
            Err(Error::SizeOverflow { what: "frame" })
        );
    }
}
