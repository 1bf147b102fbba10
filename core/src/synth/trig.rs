//! A fast cosine for texture phases (the renderer's hot spot): Cody–Waite reduction by
//! π/2 and Taylor polynomials on [−π/4, π/4]. Only IEEE arithmetic, so results are the
//! same on every platform; absolute error below 1e-14 for |x| < 2^20 (phases here stay
//! far below), falling back to `libm::cos` beyond.

const FRAC_2_PI: f64 = core::f64::consts::FRAC_2_PI;
/// π/2 split so that `k · PIO2_HI` is exact for |k| < 2^20.
const PIO2_HI: f64 = 1.570_796_326_734_125_6;
const PIO2_LO: f64 = 6.077_100_506_506_192e-11;
const LIMIT: f64 = 1_048_576.0;

/// cos(x).
#[inline]
pub(crate) fn cos(x: f64) -> f64 {
    sincos(x).0
}

/// (cos(x), sin(x)).
#[inline]
pub(crate) fn sincos(x: f64) -> (f64, f64) {
    if !(x > -LIMIT && x < LIMIT) {
        return (libm::cos(x), libm::sin(x));
    }
    let t = x * FRAC_2_PI;
    let k = (if t >= 0.0 { t + 0.5 } else { t - 0.5 }) as i64;
    let kf = k as f64;
    let r = (x - kf * PIO2_HI) - kf * PIO2_LO;
    // Both polynomials and selects instead of a branch: quadrants are unpredictable.
    let (c, s) = (cos_poly(r), sin_poly(r));
    let (cos_magnitude, sin_magnitude) = if k & 1 == 0 { (c, s) } else { (s, c) };
    // cos is negative in quadrants 1 and 2, sin in quadrants 2 and 3.
    let cos = if (k + 1) & 2 == 0 {
        cos_magnitude
    } else {
        -cos_magnitude
    };
    let sin = if k & 2 == 0 {
        sin_magnitude
    } else {
        -sin_magnitude
    };
    (cos, sin)
}

#[inline]
fn sin_poly(r: f64) -> f64 {
    let r2 = r * r;
    let p = -1.0 / 1_307_674_368_000.0;
    let p = 1.0 / 6_227_020_800.0 + r2 * p;
    let p = -1.0 / 39_916_800.0 + r2 * p;
    let p = 1.0 / 362_880.0 + r2 * p;
    let p = -1.0 / 5_040.0 + r2 * p;
    let p = 1.0 / 120.0 + r2 * p;
    let p = -1.0 / 6.0 + r2 * p;
    r + r * r2 * p
}

#[inline]
fn cos_poly(r: f64) -> f64 {
    let r2 = r * r;
    let p = 1.0 / 20_922_789_888_000.0;
    let p = -1.0 / 87_178_291_200.0 + r2 * p;
    let p = 1.0 / 479_001_600.0 + r2 * p;
    let p = -1.0 / 3_628_800.0 + r2 * p;
    let p = 1.0 / 40_320.0 + r2 * p;
    let p = -1.0 / 720.0 + r2 * p;
    let p = 1.0 / 24.0 + r2 * p;
    let p = -0.5 + r2 * p;
    1.0 + r2 * p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_libm() {
        let mut worst = 0.0f64;
        let mut x = -20_000.0;
        while x < 20_000.0 {
            worst = worst.max((cos(x) - libm::cos(x)).abs());
            worst = worst.max((sincos(x).1 - libm::sin(x)).abs());
            x += 0.0137;
        }
        for x in [0.0, 1e-300, core::f64::consts::FRAC_PI_4, 1e6, -3e6, 1e300] {
            worst = worst.max((cos(x) - libm::cos(x)).abs());
        }
        assert!(worst < 1e-14, "{worst}");
        assert!(cos(f64::NAN).is_nan());
    }
}
