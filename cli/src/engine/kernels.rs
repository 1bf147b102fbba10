//! Which machine code the stages run: the build's baseline, or the same core code
//! compiled a second time for AVX2 and chosen at run time when the CPU has it.
//!
//! The release build targets plain x86-64 (SSE2) so that the binary runs on any x86-64
//! CPU. Most of the stages' time is in vector loops over 16 lanes, which fill two AVX
//! registers instead of four SSE ones. [`Active::run`] calls a stage through a function
//! compiled with the AVX2 features; Rust compiles a function for a caller's features
//! only where it is inlined into it, so the core's stage modules mark their functions
//! `#[inline(always)]` (see `core/src/lib.rs`). Both paths run the same operations in
//! the same order with no fused multiply-add (Rust never contracts `a * b + c`), so the
//! maps are bit-identical (`tests/kernels.rs`).

use std::sync::OnceLock;

/// The kernels a caller asks for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Kernels {
    /// The fastest this CPU runs: AVX2 when it has it, else the baseline.
    #[default]
    Auto,
    /// The build's baseline instruction set only (for comparison).
    Baseline,
}

/// The kernels that actually run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Active {
    /// The build's baseline instruction set.
    Baseline,
    /// Compiled for AVX2 (x86-64 with AVX2, BMI1/2, LZCNT, POPCNT, FMA present).
    Avx2,
}

impl Kernels {
    /// What runs on this CPU for this choice.
    pub fn active(self) -> Active {
        match self {
            Kernels::Baseline => Active::Baseline,
            Kernels::Auto if avx2_available() => Active::Avx2,
            Kernels::Auto => Active::Baseline,
        }
    }
}

impl Active {
    /// A short name for reports (`avx2` or `baseline`).
    pub fn name(self) -> &'static str {
        match self {
            Active::Baseline => "baseline",
            Active::Avx2 => "avx2",
        }
    }

    /// Runs `stage` compiled for these kernels.
    #[inline(always)]
    pub fn run<R>(self, stage: impl FnOnce() -> R) -> R {
        #[cfg(target_arch = "x86_64")]
        if self == Active::Avx2 && avx2_available() {
            // SAFETY: `with_avx2` enables exactly the features `avx2_available` found
            // on this CPU, so its instructions exist here.
            #[allow(unsafe_code)]
            return unsafe { with_avx2(stage) };
        }
        stage()
    }
}

/// Whether the CPU runs the features [`with_avx2`] is compiled for (detected once).
pub fn avx2_available() -> bool {
    static AVAILABLE: OnceLock<bool> = OnceLock::new();
    *AVAILABLE.get_or_init(|| {
        #[cfg(target_arch = "x86_64")]
        {
            std::is_x86_feature_detected!("avx2")
                && std::is_x86_feature_detected!("bmi1")
                && std::is_x86_feature_detected!("bmi2")
                && std::is_x86_feature_detected!("lzcnt")
                && std::is_x86_feature_detected!("popcnt")
                && std::is_x86_feature_detected!("fma")
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            false
        }
    })
}

/// `stage()` compiled for x86-64-v3's features: everything `stage` inlines (the core's
/// stage modules inline their whole call tree) becomes AVX2 code.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,bmi1,bmi2,lzcnt,popcnt,fma")]
fn with_avx2<R>(stage: impl FnOnce() -> R) -> R {
    stage()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn baseline_is_always_baseline() {
        assert_eq!(Kernels::Baseline.active(), Active::Baseline);
        assert_eq!(Active::Baseline.run(|| 2 + 3), 5);
    }

    #[test]
    fn auto_follows_the_cpu() {
        let expected = if avx2_available() {
            Active::Avx2
        } else {
            Active::Baseline
        };
        assert_eq!(Kernels::Auto.active(), expected);
        assert_eq!(Kernels::Auto.active().run(|| 7 * 6), 42);
    }
}
