//! Weighted selection: the smallest value whose weight of values at or below it reaches
//! half the total.

/// The smallest value `v` whose weight of values `≤ v` reaches `half` (weighted
/// quickselect with three-way partitions; `values` and `weights` are reordered).
/// `half` must be at most the total weight and the slices non-empty and equally long.
pub(super) fn weighted_median(values: &mut [f32], weights: &mut [u32], half: u64) -> f32 {
    let n = values.len().min(weights.len());
    let (values, weights) = (&mut values[..n], &mut weights[..n]);
    // The indices below stay within [0, n) (`lo ≤ lt ≤ i < gt ≤ hi ≤ n`); the
    // optimiser cannot follow that through the loops, so each access is a checked one
    // whose miss ends the selection (it never misses).
    let (mut lo, mut hi) = (0usize, n);
    let mut below = 0u64;
    while hi > lo {
        let slice = lo..hi;
        let (Some(&first), Some(&middle), Some(&last)) = (
            values.get(slice.start),
            values.get(slice.start + slice.len() / 2),
            values.get(slice.end - 1),
        ) else {
            break;
        };
        let pivot = median_of_three(first, middle, last);
        // Dutch-flag partition of [lo, hi): < pivot | == pivot | > pivot.
        let (mut lt, mut i, mut gt) = (lo, lo, hi);
        while i < gt {
            let Some(&v) = values.get(i) else { break };
            if v < pivot {
                if lt >= n {
                    break;
                }
                values.swap(i, lt);
                weights.swap(i, lt);
                lt += 1;
                i += 1;
            } else if v > pivot {
                gt -= 1;
                if gt >= n {
                    break;
                }
                values.swap(i, gt);
                weights.swap(i, gt);
            } else {
                i += 1;
            }
        }
        let sum = |range: core::ops::Range<usize>| -> u64 {
            let part = weights.get(range).unwrap_or_default();
            part.iter().map(|&w| u64::from(w)).sum()
        };
        let (w_less, w_equal) = (sum(lo..lt), sum(lt..gt));
        if below + w_less >= half {
            hi = lt;
        } else if below + w_less + w_equal >= half {
            return pivot;
        } else {
            below += w_less + w_equal;
            lo = gt;
        }
    }
    // Only reached when `half` exceeds the total weight: the largest value.
    values.iter().copied().fold(f32::MIN, f32::max)
}

/// A finite value, its weight (below 2¹⁶) and a number unique among the keys of one
/// selection (below 2¹⁶) as one sort key: the value's bits mapped so that integer
/// order is the value order (−0 just below +0), the number and the weight below them,
/// so no two keys of a selection are equal.
#[inline(always)]
pub(super) fn key(value: f32, weight: u32, unique: usize) -> u64 {
    let bits = value.to_bits();
    let ordered = if bits >> 31 == 1 {
        !bits
    } else {
        bits | 0x8000_0000
    };
    let low = ((unique as u32 & 0xFFFF) << 16) | (weight & 0xFFFF);
    (u64::from(ordered) << 32) | u64::from(low)
}

/// The weight of a [`key`].
#[inline(always)]
fn weight_of(key: u64) -> u64 {
    key & 0xFFFF
}

/// The value of [`key`].
#[inline(always)]
fn value_of(key: u64) -> f32 {
    let ordered = (key >> 32) as u32;
    f32::from_bits(if ordered >> 31 == 1 {
        ordered & 0x7FFF_FFFF
    } else {
        !ordered
    })
}

/// [`weighted_median`] of the distinct keys `keys` (made by [`key`]; reordered here):
/// the value of the smallest key whose weight of keys `≤` it reaches `target`, `None`
/// when the total falls short. The answer is that of sorting the keys and scanning
/// them, found by a weighted quickselect: a median-of-three pivot and a branch-free
/// two-way partition (keys are distinct, so the pivot alone is neither side), fewer
/// compares than a sort for the few dozen votes of one side of a window and no
/// mispredicted branch per key. Every access is checked (no panic path; core's
/// `sort_unstable` keeps one, which the firmware's link check counts).
pub(super) fn weighted_median_of_keys(keys: &mut [u64], target: u64) -> Option<f32> {
    if target == 0 {
        // The first key of the sorted scan.
        return keys.iter().copied().min().map(value_of);
    }
    let mut rest = keys;
    let mut below = 0u64;
    while let Some(last) = rest.len().checked_sub(1) {
        // Median of three, moved to the end.
        let mid = last / 2;
        let (a, b, c) = (*rest.first()?, *rest.get(mid)?, *rest.last()?);
        let pick = if (a < b) == (b < c) {
            b
        } else if (b < a) == (a < c) {
            a
        } else {
            c
        };
        let (front, end) = rest.split_at_mut(last);
        let pivot_slot = end.first_mut()?;
        // The pivot goes to the end; the key it leaves is where the pivot was.
        if pick == a {
            *front.first_mut().unwrap_or(pivot_slot) = c;
        } else if pick == b {
            *front.get_mut(mid).unwrap_or(pivot_slot) = c;
        }
        *pivot_slot = pick;
        let pivot = pick;
        // Lomuto without branches: keys below the pivot gather at the front.
        let mut lt = 0usize;
        let mut weight_less = 0u64;
        for i in 0..front.len() {
            let k = front[i];
            let less = k < pivot;
            let at = lt.min(i);
            front[i] = front[at];
            front[at] = k;
            lt += usize::from(less);
            weight_less += if less { weight_of(k) } else { 0 };
        }
        if below + weight_less >= target {
            rest = front.get_mut(..lt)?;
        } else if below + weight_less + weight_of(pivot) >= target {
            return Some(value_of(pivot));
        } else {
            below += weight_less + weight_of(pivot);
            // The keys above the pivot.
            rest = front.get_mut(lt..)?;
        }
    }
    None
}

#[inline(always)]
fn median_of_three(a: f32, b: f32, c: f32) -> f32 {
    a.max(b).min(a.min(b).max(c))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute(values: &[f32], weights: &[u32]) -> f32 {
        let mut pairs: [(f32, u32); 64] = [(0.0, 0); 64];
        let n = values.len();
        for i in 0..n {
            pairs[i] = (values[i], weights[i]);
        }
        pairs[..n].sort_by(|a, b| a.0.total_cmp(&b.0));
        let total: u64 = weights.iter().map(|&w| u64::from(w)).sum();
        let half = total.div_ceil(2);
        let mut acc = 0u64;
        for (v, w) in &pairs[..n] {
            acc += u64::from(*w);
            if acc >= half {
                return *v;
            }
        }
        unreachable!()
    }

    #[test]
    fn weighted_median_matches_sorting() {
        let mut state = 12345u32;
        let mut next = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            state >> 8
        };
        for trial in 0..500 {
            let n = 1 + trial % 40;
            let mut v = [0.0f32; 64];
            let mut w = [0u32; 64];
            for i in 0..n {
                // Few distinct values, so ties are common.
                v[i] = (next() % 7) as f32 * 0.25 - 0.5 + [0.0, 1e-30, -3e5][trial % 3];
                w[i] = 1 + next() % 1000;
            }
            let expected = brute(&v[..n], &w[..n]);
            let total: u64 = w[..n].iter().map(|&x| u64::from(x)).sum();
            let mut keys = [0u64; 64];
            for i in 0..n {
                keys[i] = key(v[i], w[i], i);
            }
            let sorted = weighted_median_of_keys(&mut keys[..n], total.div_ceil(2));
            let got = weighted_median(&mut v[..n], &mut w[..n], total.div_ceil(2));
            assert_eq!(got, expected, "trial {trial}");
            assert_eq!(sorted, Some(expected), "trial {trial}, by sorting keys");
        }
    }

    #[test]
    fn weighted_median_of_keys_equals_the_sorted_scan() {
        let mut state = 777u32;
        let mut next = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            state >> 8
        };
        let values = [-0.0f32, 0.0, 1.5, -2.25, 3.0, -1e-30, 7.0];
        for trial in 0..2000 {
            let n = trial % 70;
            let mut keys = [0u64; 70];
            for (i, k) in keys.iter_mut().take(n).enumerate() {
                let v = values[next() as usize % values.len()];
                *k = key(v, next() % 4, i);
            }
            let total: u64 = keys[..n].iter().map(|&k| weight_of(k)).sum();
            let target = u64::from(next()) % (total + 2);
            let mut sorted = keys;
            sorted[..n].sort_unstable();
            let mut sum = 0;
            let expected = sorted[..n].iter().find_map(|&k| {
                sum += weight_of(k);
                (sum >= target).then(|| value_of(k))
            });
            let got = weighted_median_of_keys(&mut keys[..n], target);
            assert_eq!(
                got.map(f32::to_bits),
                expected.map(f32::to_bits),
                "trial {trial}"
            );
        }
    }
}
