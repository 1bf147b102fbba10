extern crate std;
use super::*;

#[test]
fn derivative_of_a_ramp_is_its_slope() {
    let k = Kernel::<f32>::derivative(0.8);
    let input: [f32; 40] = core::array::from_fn(|i| 0.25 * i as f32);
    let mut out = [0.0; 40];
    k.apply(&input, &mut out);
    for &v in &out[k.radius()..40 - k.radius()] {
        assert!((v - 0.25).abs() < 1e-5, "{v}");
    }
}

#[test]
fn any_output_range_matches_the_full_correlation_bit_for_bit() {
    let k = Kernel::<f32>::gaussian(2.0);
    for n in [5usize, 13, 40, 100] {
        let input: std::vec::Vec<f32> = (0..n).map(|i| ((i * 37) % 11) as f32 * 0.3).collect();
        let mut full = std::vec![0.0f32; n];
        k.apply(&input, &mut full);
        for (a, b) in [(0, n), (0, 3), (2, 9), (n / 2, n), (n - 1, n), (7, 45)] {
            let mut part = std::vec![f32::NAN; n];
            k.apply_range(&input, &mut part, a..b);
            for t in 0..n {
                if (a..b.min(n)).contains(&t) {
                    assert_eq!(part[t].to_bits(), full[t].to_bits(), "n {n} {a}..{b} t {t}");
                } else {
                    assert!(part[t].is_nan(), "n {n} {a}..{b} wrote {t}");
                }
            }
        }
    }
}

#[test]
fn smoothing_sums_its_products_in_the_documented_order() {
    // Clamped edges tap by tap from the first; the interior the centre first, then
    // each mirrored pair, innermost first: the order every block form (fixed radii
    // 5 and 6 included) must keep, bit for bit.
    fn check<T: Scalar>(sigma: f32) -> usize {
        let k = Kernel::<T>::gaussian(sigma);
        let r = k.radius();
        for n in [3usize, 2 * r + 1, 2 * r + 33, 100, 513] {
            let input: std::vec::Vec<T> = (0..n)
                .map(|i| T::from_f32(((i * 37) % 11) as f32 * 0.3 + 0.01 * i as f32))
                .collect();
            let mut out = std::vec![T::MAX; n];
            k.apply(&input, &mut out);
            for t in 0..n {
                let expected = if t < r || t + r >= n {
                    let mut acc = T::ZERO;
                    for j in 0..2 * r + 1 {
                        acc += k.taps[j] * input[(t + j).saturating_sub(r).min(n - 1)];
                    }
                    acc
                } else {
                    let mut acc = k.taps[r] * input[t];
                    for j in 1..r + 1 {
                        acc += k.taps[r + j] * (input[t - j] + input[t + j]);
                    }
                    acc
                };
                assert!(out[t] == expected, "σ {sigma} n {n} t {t}");
                assert_eq!(
                    out[t].to_f32().to_bits(),
                    expected.to_f32().to_bits(),
                    "σ {sigma} n {n} t {t}"
                );
            }
        }
        r
    }
    let mut radii = std::vec::Vec::new();
    for sigma in [1.0f32, 1.5, 2.0, 2.5] {
        radii.push(check::<f32>(sigma));
        check::<crate::Q16>(sigma);
    }
    assert!(radii.contains(&5) && radii.contains(&6), "{radii:?}");
}

#[test]
fn the_even_outputs_match_the_full_correlation_bit_for_bit() {
    fn check<T: Scalar>(k: &Kernel<T>, what: &str) {
        for n in [0usize, 1, 2, 3, 5, 6, 12, 13, 14, 15, 24, 25, 40, 101, 512] {
            let input: std::vec::Vec<T> = (0..n)
                .map(|i| T::from_f32(((i * 37) % 11) as f32 * 0.3 + 0.01 * i as f32))
                .collect();
            let mut full = std::vec![T::ZERO; n];
            k.apply(&input, &mut full);
            let mut split = std::vec![T::ZERO; n];
            deinterleave(&input, &mut split);
            let mut even = std::vec![T::MAX; n.div_ceil(2) + 1];
            k.apply_even(&split, n, &mut even);
            for m in 0..n.div_ceil(2) {
                assert!(even[m] == full[2 * m], "{what} n {n} m {m}");
                assert_eq!(
                    even[m].to_f32().to_bits(),
                    full[2 * m].to_f32().to_bits(),
                    "{what} n {n} m {m}"
                );
            }
            assert!(
                even[n.div_ceil(2)] == T::MAX,
                "{what} n {n} wrote past ⌈n/2⌉"
            );
        }
    }
    for sigma in [0.0f32, 0.5, 1.0, 2.0, 2.5] {
        check(&Kernel::<f32>::gaussian(sigma), "gaussian");
        check(&Kernel::<crate::Q16>::gaussian(sigma), "gaussian q16");
    }
    check(&Kernel::<f32>::derivative(0.8), "derivative");
    check(&Kernel::<f32>::scharr_smoothing(0.5), "scharr");
}

#[test]
fn the_pair_pass_matches_two_correlations_bit_for_bit() {
    fn check<T: Scalar>(sigma: f32) -> usize {
        let odd = Kernel::<T>::derivative(sigma);
        let even = Kernel::<T>::scharr_smoothing(sigma);
        for n in [1usize, 7, 16, 23, 24, 40, 100, 513] {
            let input: std::vec::Vec<T> = (0..n)
                .map(|i| T::from_f32(((i * 37) % 11) as f32 * 0.3 + 0.01 * i as f32))
                .collect();
            let (mut d, mut s) = (std::vec![T::ZERO; n], std::vec![T::ZERO; n]);
            odd.apply(&input, &mut d);
            even.apply(&input, &mut s);
            let (mut pd, mut ps) = (std::vec![T::MAX; n], std::vec![T::MAX; n]);
            apply_pair(&odd, &even, &input, &mut pd, &mut ps);
            for t in 0..n {
                let bits = |v: T| v.to_f32().to_bits();
                assert!(pd[t] == d[t], "σ {sigma} n {n} derivative {t}");
                assert!(ps[t] == s[t], "σ {sigma} n {n} smoothing {t}");
                assert_eq!(bits(pd[t]), bits(d[t]), "σ {sigma} n {n} derivative {t}");
                assert_eq!(bits(ps[t]), bits(s[t]), "σ {sigma} n {n} smoothing {t}");
            }
        }
        odd.radius()
    }
    // Every radius `apply_pair` fixes at compile time (1, 2, 3) and a larger one.
    let mut radii = std::vec::Vec::new();
    for sigma in [0.0f32, 0.3, 0.5, 0.8, 1.1, 1.5] {
        radii.push(check::<f32>(sigma));
        assert_eq!(check::<crate::Q16>(sigma), radii[radii.len() - 1]);
    }
    for r in [1, 2, 3] {
        assert!(radii.contains(&r), "radius {r} not covered: {radii:?}");
    }
    assert!(radii.iter().any(|&r| r > 3), "no radius above 3: {radii:?}");
}

#[test]
fn prefilter_kernels_drop_negligible_outer_taps_and_keep_their_gain() {
    // σ = 0.5 (the default): the composed 7 taps lose their outer pair (3·10⁻⁴ / 10⁻⁴).
    assert_eq!(Kernel::<f32>::derivative(0.5).radius(), 2);
    assert_eq!(Kernel::<f32>::scharr_smoothing(0.5).radius(), 2);
    for sigma in [0.0f32, 0.3, 0.5, 0.8, 1.5, 3.0] {
        for (k, odd) in [
            (Kernel::<f32>::derivative(sigma), true),
            (Kernel::<f32>::scharr_smoothing(sigma), false),
        ] {
            let r = k.radius();
            let taps = &k.taps[..2 * r + 1];
            let largest = taps.iter().fold(0.0f32, |m, &v| m.max(v.abs()));
            assert!(
                taps[0].abs() >= PRUNE * largest * 0.5,
                "σ {sigma}: outer tap {} of {largest} kept",
                taps[0]
            );
            // Gain on a ramp (derivative: its slope) or a constant (smoothing).
            let gain: f32 = taps
                .iter()
                .enumerate()
                .map(|(i, &v)| if odd { v * (i as f32 - r as f32) } else { v })
                .sum();
            assert!(
                (gain - 1.0).abs() < 1e-5,
                "σ {sigma} odd {odd}: gain {gain}"
            );
        }
    }
}

#[test]
fn smoothing_preserves_constants_everywhere() {
    for k in [
        Kernel::<f32>::gaussian(1.5),
        Kernel::<f32>::scharr_smoothing(0.8),
    ] {
        let input = [2.0f32; 7];
        let mut out = [0.0; 7];
        k.apply(&input, &mut out);
        assert!(out.iter().all(|&v| (v - 2.0).abs() < 1e-5), "{out:?}");
        let input = [3.0f32; 50];
        let mut out = [0.0; 50];
        k.apply(&input, &mut out);
        assert!(out.iter().all(|&v| (v - 3.0).abs() < 1e-5), "{out:?}");
    }
}

#[test]
fn centre_weights_sum_to_one_and_fold_borders() {
    let mut w = [0.0f32; 9];
    centre_weights(1.5, 9, 4, &mut w);
    assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-5);
    assert!((w[0] - w[8]).abs() < 1e-6 && w[4] > w[3]);
    let mut w = [0.0f32; 3];
    centre_weights(1.5, 3, 1, &mut w);
    assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-5);
    assert!(w[0] > 0.2, "border mass folds onto the end rows: {w:?}");
}
