//! Homography fitting: normalised DLT (least squares over many pairs, exact through
//! four), a seeded RANSAC around it, and the small random generator it uses.

use nalgebra::{Matrix3, RealField, SMatrix, SVector, Vector3};

/// A 3 × 3 homography as a stack matrix.
pub type Mat = Matrix3<f32>;

/// Maps `(x, y)`; `None` on or behind the line at infinity.
#[inline(always)]
pub fn apply(m: &Mat, x: f32, y: f32) -> Option<(f32, f32)> {
    let w = m[(2, 0)] * x + m[(2, 1)] * y + m[(2, 2)];
    if w.abs().partial_cmp(&1e-9) != Some(core::cmp::Ordering::Greater) {
        return None;
    }
    let u = (m[(0, 0)] * x + m[(0, 1)] * y + m[(0, 2)]) / w;
    let v = (m[(1, 0)] * x + m[(1, 1)] * y + m[(1, 2)]) / w;
    (u.is_finite() && v.is_finite()).then_some((u, v))
}

/// Similarity `x ↦ (x − mean) · scale` that centres points and gives them mean distance
/// √2 from the origin (Hartley's normalisation), as a matrix.
fn normaliser(points: impl Iterator<Item = (f32, f32)> + Clone) -> Option<Mat> {
    let (mut n, mut mx, mut my) = (0.0f32, 0.0f32, 0.0f32);
    for (x, y) in points.clone() {
        n += 1.0;
        mx += x;
        my += y;
    }
    if n < 1.0 {
        return None;
    }
    mx /= n;
    my /= n;
    let mut dist = 0.0f32;
    for (x, y) in points {
        dist += crate::float::sqrtf((x - mx) * (x - mx) + (y - my) * (y - my));
    }
    dist /= n;
    if dist.partial_cmp(&1e-6) != Some(core::cmp::Ordering::Greater) {
        return None;
    }
    let s = core::f32::consts::SQRT_2 / dist;
    Some(Mat::new(s, 0.0, -s * mx, 0.0, s, -s * my, 0.0, 0.0, 1.0))
}

/// Least-squares homography mapping `src[i]` to `dst[i]` for the pairs `pairs` yields
/// (`(x, y, u, v)`), from the normalised DLT with `h₃₃ = 1`. `None` for degenerate input.
pub fn fit(pairs: impl Iterator<Item = (f32, f32, f32, f32)> + Clone) -> Option<Mat> {
    let ns = normaliser(pairs.clone().map(|p| (p.0, p.1)))?;
    let nd = normaliser(pairs.clone().map(|p| (p.2, p.3)))?;
    let mut ata = SMatrix::<f32, 8, 8>::zeros();
    let mut atb = SVector::<f32, 8>::zeros();
    let mut count = 0usize;
    for (x, y, u, v) in pairs {
        let (x, y) = (ns[(0, 0)] * x + ns[(0, 2)], ns[(1, 1)] * y + ns[(1, 2)]);
        let (u, v) = (nd[(0, 0)] * u + nd[(0, 2)], nd[(1, 1)] * v + nd[(1, 2)]);
        let r1 = SVector::<f32, 8>::from_column_slice(&[x, y, 1.0, 0.0, 0.0, 0.0, -u * x, -u * y]);
        let r2 = SVector::<f32, 8>::from_column_slice(&[0.0, 0.0, 0.0, x, y, 1.0, -v * x, -v * y]);
        ata.syger(1.0, &r1, &r1, 1.0);
        ata.syger(1.0, &r2, &r2, 1.0);
        atb.axpy(u, &r1, 1.0);
        atb.axpy(v, &r2, 1.0);
        count += 1;
    }
    if count < 4 {
        return None;
    }
    ata.fill_upper_triangle_with_lower_triangle();
    let h = if count == 4 {
        lu_solve(&ata, &atb)?
    } else {
        ata.cholesky()?.solve(&atb)
    };
    let hn = Mat::new(h[0], h[1], h[2], h[3], h[4], h[5], h[6], h[7], 1.0);
    let m = nd.try_inverse()? * hn * ns;
    let m = m / m[(2, 2)];
    m.iter().all(|v| v.is_finite()).then_some(m)
}

/// Deterministic xorshift64* generator (RANSAC sampling).
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        // SplitMix64 step so that nearby seeds give unrelated streams; never zero.
        let mut z = seed.wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        Rng((z ^ (z >> 31)) | 1)
    }
    /// Uniform in `0..n` (`n > 0`).
    pub fn below(&mut self, n: usize) -> usize {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let r = self.0.wrapping_mul(0x2545_f491_4f6c_dd1d);
        ((r >> 32) as usize) % n.max(1)
    }
}

/// Seeded RANSAC: the homography through four sampled pairs with the most pairs within
/// `threshold` pixels, refitted by least squares on those inliers. `pairs(i)` gives pair
/// `i` of `n` (or `None` to skip it).
pub fn ransac(
    n: usize,
    pairs: &dyn Fn(usize) -> Option<(f32, f32, f32, f32)>,
    threshold: f32,
    rounds: usize,
    rng: &mut Rng,
) -> Option<(Mat, usize)> {
    let valid = (0..n).filter(|&i| pairs(i).is_some()).count();
    if valid < 4 {
        return None;
    }
    let residual = |m: &Mat, p: (f32, f32, f32, f32)| -> f32 {
        match apply(m, p.0, p.1) {
            Some((u, v)) => (u - p.2) * (u - p.2) + (v - p.3) * (v - p.3),
            None => f32::INFINITY,
        }
    };
    let t2 = threshold * threshold;
    let count_inliers = |m: &Mat| {
        (0..n)
            .filter_map(pairs)
            .filter(|&p| residual(m, p) <= t2)
            .count()
    };
    let mut best: Option<(Mat, usize)> = None;
    for _ in 0..rounds {
        let mut pick = [0usize; 4];
        for k in 0..4 {
            // The k-th valid pair after a random skip; distinct by construction.
            let mut i = rng.below(n);
            loop {
                if pairs(i).is_some() && !pick[..k].contains(&i) {
                    break;
                }
                i = (i + 1) % n;
            }
            pick[k] = i;
        }
        let sample = pick.iter().filter_map(|&i| pairs(i));
        let Some(m) = fit(sample) else { continue };
        let inliers = count_inliers(&m);
        if best.as_ref().is_none_or(|b| inliers > b.1) {
            best = Some((m, inliers));
        }
    }
    let (m, _) = best?;
    let inlier_pairs = (0..n)
        .filter_map(pairs)
        .filter(move |&p| residual(&m, p) <= t2);
    let refit = fit(inlier_pairs)?;
    let inliers = count_inliers(&refit);
    Some((refit, inliers))
}

/// The matrix of a [`crate::geometry::Homography`].
pub fn from_homography(h: &crate::geometry::Homography) -> Mat {
    // Not `from_row_slice`, whose length check the link check counts as a panic path.
    let [m0, m1, m2, m3, m4, m5, m6, m7, m8] = h.m;
    Mat::new(m0, m1, m2, m3, m4, m5, m6, m7, m8)
}

/// The [`crate::geometry::Homography`] of a matrix, scaled so that `h₃₃ = 1`.
pub fn to_homography(m: &Mat) -> Option<crate::geometry::Homography> {
    let s = m[(2, 2)];
    if s.abs().partial_cmp(&1e-12) != Some(core::cmp::Ordering::Greater) {
        return None;
    }
    let mut out = [0.0f32; 9];
    for r in 0..3 {
        for c in 0..3 {
            out[r * 3 + c] = m[(r, c)] / s;
        }
    }
    out.iter()
        .all(|v| v.is_finite())
        .then_some(crate::geometry::Homography { m: out })
}

/// `m · (x, y, 1)` as a homogeneous vector.
#[allow(dead_code)]
pub fn hom(m: &Mat, x: f32, y: f32) -> Vector3<f32> {
    m * Vector3::new(x, y, 1.0)
}

/// Solves the N × N system `a · x = b` by LU decomposition with partial pivoting, the
/// same operations in the same order as `a.lu().solve(b)` of nalgebra (so bit for bit
/// the same result), without its run-time shape checks, which the firmware's link check
/// counts as panic paths (see docs/EMBEDDED.md, "Panics"). `None` when `a` is singular.
pub fn lu_solve<T: RealField + Copy, const N: usize>(
    a: &SMatrix<T, N, N>,
    b: &SVector<T, N>,
) -> Option<SVector<T, N>> {
    // nalgebra stores columns: `data.0[c][r]` is `a[(r, c)]`.
    let mut m: [[T; N]; N] = core::array::from_fn(|r| core::array::from_fn(|c| a.data.0[c][r]));
    let mut x: [T; N] = b.data.0[0];
    // Decomposition: the row swaps are applied to `x` in the order they are made, as
    // nalgebra's permutation sequence does.
    let mut swaps = [None; N];
    for i in 0..N {
        let mut piv = i;
        let mut largest = m[i][i].abs();
        for (r, row) in m.iter().enumerate().skip(i + 1) {
            if row[i].abs() > largest {
                largest = row[i].abs();
                piv = r;
            }
        }
        let Some(diag) = m.get(piv).map(|row| row[i]) else {
            break;
        };
        if diag.is_zero() {
            continue;
        }
        if piv != i {
            m.swap(i, piv.min(N - 1));
            swaps[i] = Some(piv);
        }
        let inv_diag = T::one() / diag;
        let pivot = m[i];
        for row in m.iter_mut().skip(i + 1) {
            row[i] *= inv_diag;
            let coeff = row[i];
            for (value, &p) in row.iter_mut().zip(&pivot).skip(i + 1) {
                *value = -p * coeff + *value;
            }
        }
    }
    for (i, swap) in swaps.iter().enumerate() {
        if let Some(piv) = *swap {
            x.swap(i, piv.min(N - 1));
        }
    }
    // Forward substitution, unit lower triangle.
    for i in 0..N.saturating_sub(1) {
        let coeff = x[i] / T::one();
        for (xr, row) in x.iter_mut().zip(&m).skip(i + 1) {
            *xr = -coeff * row[i] + *xr;
        }
    }
    // Back substitution.
    for i in (0..N).rev() {
        let diag = m[i][i];
        if diag.is_zero() {
            return None;
        }
        let coeff = x[i] / diag;
        x[i] = coeff;
        for (xr, row) in x.iter_mut().zip(&m).take(i) {
            *xr = -coeff * row[i] + *xr;
        }
    }
    Some(SVector::from_fn(|r, _| x[r]))
}

/// Least-squares fit of one point seen across a rectified array: each view `v` sees it at
/// `u_v = X − d·b_v` (baseline `b_v`), and `d = −cov(b, u)/var(b)`, `X = mean(u) +
/// d·mean(b)`. The sums are added one observation at a time, so no table is kept.
#[derive(Clone, Copy, Debug, Default)]
pub struct ParallaxFit {
    /// Observations added.
    pub n: f32,
    sb: [f32; 2],
    su: [f32; 2],
    sbb: f32,
    sbu: f32,
}

impl ParallaxFit {
    /// Adds the observation `u` of a view with baseline `b`.
    #[inline]
    pub fn add(&mut self, b: (f32, f32), u: (f32, f32)) {
        self.n += 1.0;
        self.sb[0] += b.0;
        self.sb[1] += b.1;
        self.su[0] += u.0;
        self.su[1] += u.1;
        self.sbb += b.0 * b.0 + b.1 * b.1;
        self.sbu += b.0 * u.0 + b.1 * u.1;
    }

    /// `n·var(b)`: how well the baselines pin `d` down (zero for a single baseline).
    pub fn spread(&self) -> f32 {
        self.sbb - (self.sb[0] * self.sb[0] + self.sb[1] * self.sb[1]) / self.n.max(1.0)
    }

    /// `(X, Y, d)`; non-finite when the spread is zero.
    pub fn solution(&self) -> (f32, f32, f32) {
        let n = self.n;
        let cov = self.sbu - (self.sb[0] * self.su[0] + self.sb[1] * self.su[1]) / n;
        let d = -cov / self.spread();
        (
            (self.su[0] + d * self.sb[0]) / n,
            (self.su[1] + d * self.sb[1]) / n,
            d,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn truth() -> Mat {
        Mat::new(1.01, -0.03, 2.5, 0.025, 0.995, -1.5, 2e-5, -1e-5, 1.0)
    }

    #[test]
    fn lu_solve_is_bit_identical_to_nalgebra() {
        let mut rng = Rng::new(7);
        let mut value = || (rng.below(2001) as f64 - 1000.0) / 37.0;
        let mut checked = 0;
        for case in 0..400 {
            let mut a = Matrix3::<f64>::from_fn(|_, _| value());
            let b = Vector3::<f64>::from_fn(|_, _| value());
            // Some singular and some needing no pivoting.
            if case % 10 == 0 {
                let row = a.row(0).into_owned();
                a.set_row(2, &row);
            }
            if case % 10 == 1 {
                a[(0, 0)] = 1e3;
            }
            let theirs = a.lu().solve(&b);
            let ours = lu_solve(&a, &b);
            assert_eq!(theirs.is_some(), ours.is_some(), "case {case}");
            if let (Some(t), Some(o)) = (theirs, ours) {
                for k in 0..3 {
                    assert_eq!(t[k].to_bits(), o[k].to_bits(), "case {case}");
                }
                checked += 1;
            }
            let (a32, b32) = (a.map(|v| v as f32), b.map(|v| v as f32));
            let (t, o) = (a32.lu().solve(&b32), lu_solve(&a32, &b32));
            assert_eq!(
                t.map(|v| v.map(f32::to_bits)),
                o.map(|v| v.map(f32::to_bits))
            );
            // The 8 × 8 system of `fit`.
            let a8 = SMatrix::<f32, 8, 8>::from_fn(|_, _| value() as f32);
            let b8 = SVector::<f32, 8>::from_fn(|_, _| value() as f32);
            let (t, o) = (a8.lu().solve(&b8), lu_solve(&a8, &b8));
            assert_eq!(
                t.map(|v| v.map(f32::to_bits)),
                o.map(|v| v.map(f32::to_bits))
            );
        }
        assert!(checked > 300);
    }

    #[test]
    fn fit_recovers_a_homography_from_exact_pairs() {
        let h = truth();
        let pts = (0..30).map(|i| {
            let (x, y) = ((i * 37 % 500) as f32, (i * 53 % 480) as f32);
            let (u, v) = apply(&h, x, y).unwrap();
            (x, y, u, v)
        });
        let m = fit(pts).unwrap();
        for (x, y) in [(0.0, 0.0), (511.0, 0.0), (250.0, 400.0)] {
            let (a, b) = apply(&m, x, y).unwrap();
            let (c, d) = apply(&h, x, y).unwrap();
            assert!((a - c).abs() < 2e-3 && (b - d).abs() < 2e-3);
        }
        // Collinear points are degenerate.
        assert!(fit((0..10).map(|i| (i as f32, i as f32, i as f32, 0.0))).is_none());
    }

    #[test]
    fn ransac_ignores_outliers_and_is_deterministic() {
        let h = truth();
        let pairs = |i: usize| {
            let (x, y) = ((i * 37 % 500) as f32, (i * 53 % 480) as f32);
            let (u, v) = apply(&h, x, y)?;
            // Every fourth pair is a gross mismatch.
            Some(if i % 4 == 0 {
                (x, y, u + 25.0, v - 9.0)
            } else {
                (x, y, u, v)
            })
        };
        let (m, inliers) = ransac(60, &pairs, 0.5, 50, &mut Rng::new(7)).unwrap();
        assert_eq!(inliers, 45);
        let (m2, _) = ransac(60, &pairs, 0.5, 50, &mut Rng::new(7)).unwrap();
        assert_eq!(m, m2);
        let (a, b) = apply(&m, 100.0, 100.0).unwrap();
        let (c, d) = apply(&h, 100.0, 100.0).unwrap();
        assert!((a - c).abs() < 1e-2 && (b - d).abs() < 1e-2);
    }
}
