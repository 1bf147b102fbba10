//! Checked reads and writes of map elements.

/// `s[i]`, NaN past the end: the indices are in range (every map holds `width · height`
/// values, checked on entry); the checked form keeps panics out of the image.
#[inline]
pub(super) fn at(s: &[f32], i: usize) -> f32 {
    s.get(i).copied().unwrap_or(f32::NAN)
}

/// `s[i] = v`, nothing past the end (see [`at`]).
#[inline]
pub(super) fn put(s: &mut [f32], i: usize, v: f32) {
    if let Some(x) = s.get_mut(i) {
        *x = v;
    }
}
