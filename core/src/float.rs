//! Square roots as the target's own instruction where the standard library is linked.
//!
//! `libm::sqrtf` / `libm::sqrt` compute the root on x86-64 with inline assembly of the
//! legacy SSE encoding (`sqrtss` / `sqrtsd`). In a build for a CPU with AVX (the native
//! build, `.cargo/config.toml`) the code around it uses the VEX encoding, and a legacy SSE
//! instruction after a 256-bit one pays the SSE/AVX transition: the TV stage's gradient
//! start ran 4–5× slower for it on an AVX2 host (docs/stages/tv.md). The
//! standard library's `sqrt` is the compiler's intrinsic instead: encoded for the target,
//! free to vectorise, and the same IEEE-754 correctly rounded root, so every result is bit
//! for bit libm's (tested below). Without the `std` feature (firmware, the wasm package)
//! libm's root stays: a hardware instruction on wasm32 and AArch64, software elsewhere.

/// The correctly rounded square root of `x` (NaN for negative `x`, as IEEE-754 says).
#[inline(always)]
pub fn sqrtf(x: f32) -> f32 {
    #[cfg(feature = "std")]
    {
        x.sqrt()
    }
    #[cfg(not(feature = "std"))]
    {
        libm::sqrtf(x)
    }
}

/// The correctly rounded square root of `x` in `f64`.
#[inline(always)]
pub fn sqrt(x: f64) -> f64 {
    #[cfg(feature = "std")]
    {
        x.sqrt()
    }
    #[cfg(not(feature = "std"))]
    {
        libm::sqrt(x)
    }
}

/// `x.clamp(lo, hi)` without `f32::clamp`'s panic on `lo > hi` or a NaN bound (equal to it
/// otherwise, NaN `x` included): keeps the panic out of the firmware image.
#[inline(always)]
pub(crate) fn clamp_f32(x: f32, lo: f32, hi: f32) -> f32 {
    if x < lo {
        lo
    } else if x > hi {
        hi
    } else {
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The same bits, or both NaN (payloads may differ).
    fn same(ours_bits: u64, theirs_bits: u64, both_nan: bool) -> bool {
        ours_bits == theirs_bits || both_nan
    }

    #[test]
    fn std_and_libm_roots_agree_bit_for_bit() {
        // Exact squares, rounding cases, subnormals, zero signs, infinities, NaN and a
        // spread of ordinary values (every 9973rd bit pattern of the positive floats).
        let singles = [
            0.0f32,
            -0.0,
            1.0,
            2.0,
            0.5,
            f32::MIN_POSITIVE / 3.0,
            f32::MAX,
        ]
        .into_iter()
        .chain([f32::INFINITY, -1.0, f32::NAN])
        .chain((0..0x7f80_0000u32).step_by(9973).map(f32::from_bits));
        for x in singles {
            let (ours, std_root, libm_root) = (sqrtf(x), x.sqrt(), libm::sqrtf(x));
            for (name, other) in [("std", std_root), ("libm", libm_root)] {
                assert!(
                    same(
                        ours.to_bits().into(),
                        other.to_bits().into(),
                        ours.is_nan() && other.is_nan()
                    ),
                    "sqrtf({x:e}) = {ours:e}, {name} {other:e}"
                );
            }
        }
        let doubles = [0.0f64, -0.0, 2.0, f64::INFINITY, -4.0, f64::NAN]
            .into_iter()
            .chain(
                (0..0x7ff0_0000_0000_0000u64)
                    .step_by(0x1234_5678_9abd)
                    .map(f64::from_bits),
            );
        for x in doubles {
            let (ours, std_root, libm_root) = (sqrt(x), x.sqrt(), libm::sqrt(x));
            for (name, other) in [("std", std_root), ("libm", libm_root)] {
                assert!(
                    same(
                        ours.to_bits(),
                        other.to_bits(),
                        ours.is_nan() && other.is_nan()
                    ),
                    "sqrt({x:e}) = {ours:e}, {name} {other:e}"
                );
            }
        }
    }
}
