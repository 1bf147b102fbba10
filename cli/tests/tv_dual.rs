//! Verification of the TV solver on small random graphs against an independent solver
//! (a long Chambolle–Pock run on the primal, written only for this test, in f64): the
//! objective, the duality gap, and the primal–dual relation of Eq. 16.

use lfdepth::tv::{self, Guide, Maps, Rect, SolveOutput, TvNorm, TvParams};
use lfdepth::Q16;

/// A small random problem: disparity, confidence (some pixels unreliable), edge weights.
struct Problem {
    w: usize,
    h: usize,
    d: Vec<f32>,
    c: Vec<f32>,
    wh: Vec<f32>,
    wv: Vec<f32>,
}

fn lcg(seed: &mut u64) -> f64 {
    *seed = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*seed >> 11) as f64 / (1u64 << 53) as f64
}

fn problem(w: usize, h: usize, seed: u64) -> Problem {
    let mut s = seed;
    let n = w * h;
    // Piecewise-constant disparity plus noise, so TV has work to do.
    let d = (0..n)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let base = if x * 2 < w { -1.0 } else { 0.8 } + if y * 3 < h { 0.5 } else { 0.0 };
            (base + (lcg(&mut s) - 0.5) * 0.8) as f32
        })
        .collect();
    let c = (0..n)
        .map(|_| {
            let v = lcg(&mut s);
            if v < 0.2 {
                0.0
            } else {
                v as f32
            }
        })
        .collect();
    let wh = (0..n).map(|_| (0.05 + lcg(&mut s) * 0.95) as f32).collect();
    let wv = (0..n).map(|_| (0.05 + lcg(&mut s) * 0.95) as f32).collect();
    Problem { w, h, d, c, wh, wv }
}

fn params(norm: TvNorm) -> TvParams {
    TvParams {
        lambda: 0.5,
        tikhonov: 0.05,
        confidence_threshold: 0.3,
        confidence_power: 2.0,
        norm,
        max_iterations: 4000,
        tolerance: 0.0,
        step: 1.0,
        relaxation: 1.5,
        ..TvParams::default()
    }
}

/// `a_i = m_i v_i + ℸ` as documented by the model.
fn data_weights(p: &Problem, params: &TvParams) -> Vec<f64> {
    p.c.iter()
        .map(|&c| {
            let m = if c >= params.confidence_threshold && c > 0.0 {
                (c as f64).powf(params.confidence_power as f64)
            } else {
                0.0
            };
            m + params.tikhonov as f64
        })
        .collect()
}

/// Edge weights with the edges leaving the grid removed.
fn edges(p: &Problem) -> (Vec<f64>, Vec<f64>) {
    let n = p.w * p.h;
    let wh = (0..n)
        .map(|i| {
            if i % p.w + 1 < p.w {
                p.wh[i] as f64
            } else {
                0.0
            }
        })
        .collect();
    let wv = (0..n)
        .map(|i| {
            if i / p.w + 1 < p.h {
                p.wv[i] as f64
            } else {
                0.0
            }
        })
        .collect();
    (wh, wv)
}

fn grad(p: &Problem, wh: &[f64], wv: &[f64], x: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let n = p.w * p.h;
    let gh = (0..n)
        .map(|i| {
            if wh[i] > 0.0 {
                wh[i] * (x[i + 1] - x[i])
            } else {
                0.0
            }
        })
        .collect();
    let gv = (0..n)
        .map(|i| {
            if wv[i] > 0.0 {
                wv[i] * (x[i + p.w] - x[i])
            } else {
                0.0
            }
        })
        .collect();
    (gh, gv)
}

/// `Kᵀ(fh, fv)` with `K = W∇`.
fn grad_adjoint(p: &Problem, wh: &[f64], wv: &[f64], fh: &[f64], fv: &[f64]) -> Vec<f64> {
    let n = p.w * p.h;
    let mut u = vec![0.0; n];
    for i in 0..n {
        u[i] -= wh[i] * fh[i] + wv[i] * fv[i];
        if wh[i] > 0.0 {
            u[i + 1] += wh[i] * fh[i];
        }
        if wv[i] > 0.0 {
            u[i + p.w] += wv[i] * fv[i];
        }
    }
    u
}

fn primal_objective(p: &Problem, params: &TvParams, x: &[f64]) -> f64 {
    let a = data_weights(p, params);
    let (wh, wv) = edges(p);
    let (gh, gv) = grad(p, &wh, &wv, x);
    let tv: f64 = gh
        .iter()
        .zip(&gv)
        .map(|(h, v)| match params.norm {
            TvNorm::L1 => h.abs() + v.abs(),
            TvNorm::L2 => (h * h + v * v).sqrt(),
        })
        .sum();
    let data: f64 = (0..x.len())
        .map(|i| 0.5 * a[i] * (x[i] - p.d[i] as f64).powi(2))
        .sum();
    params.lambda as f64 * tv + data
}

fn project(h: f64, v: f64, norm: TvNorm, radius: f64) -> (f64, f64) {
    match norm {
        TvNorm::L1 => (h.clamp(-radius, radius), v.clamp(-radius, radius)),
        TvNorm::L2 => {
            let r = (h * h + v * v).sqrt();
            if r > radius {
                (h * radius / r, v * radius / r)
            } else {
                (h, v)
            }
        }
    }
}

/// Dual function `q(F) = λ uᵀD − ½ λ² uᵀA⁻¹u`, `u = WᵀF` (lower bound of the primal for F ∈ B).
fn dual_objective(p: &Problem, params: &TvParams, fh: &[f64], fv: &[f64]) -> f64 {
    let a = data_weights(p, params);
    let (wh, wv) = edges(p);
    let u = grad_adjoint(p, &wh, &wv, fh, fv);
    let l = params.lambda as f64;
    (0..u.len())
        .map(|i| l * u[i] * p.d[i] as f64 - 0.5 * l * l * u[i] * u[i] / a[i])
        .sum()
}

/// Chambolle–Pock (accelerated, strongly convex data term) on
/// `min_x λ ‖W∇x‖_α + ½ Σ a (x − D)²`.
fn chambolle_pock(p: &Problem, params: &TvParams, iterations: usize) -> Vec<f64> {
    let a = data_weights(p, params);
    let (wh, wv) = edges(p);
    let n = p.w * p.h;
    let l = params.lambda as f64;
    let d: Vec<f64> = p.d.iter().map(|&v| v as f64).collect();
    let norm_k = 8f64.sqrt();
    let (mut tau, mut sigma) = (1.0 / norm_k, 1.0 / norm_k);
    let mu = a.iter().cloned().fold(f64::INFINITY, f64::min);
    let mut x = d.clone();
    let mut xbar = x.clone();
    let (mut yh, mut yv) = (vec![0.0; n], vec![0.0; n]);
    for _ in 0..iterations {
        let (gh, gv) = grad(p, &wh, &wv, &xbar);
        for i in 0..n {
            let (h, v) = project(yh[i] + sigma * gh[i], yv[i] + sigma * gv[i], params.norm, l);
            yh[i] = h;
            yv[i] = v;
        }
        let kt = grad_adjoint(p, &wh, &wv, &yh, &yv);
        let old = x.clone();
        for i in 0..n {
            x[i] = (x[i] - tau * kt[i] + tau * a[i] * d[i]) / (1.0 + tau * a[i]);
        }
        let theta = 1.0 / (1.0 + 2.0 * mu * tau).sqrt();
        tau *= theta;
        sigma /= theta;
        for i in 0..n {
            xbar[i] = x[i] + theta * (x[i] - old[i]);
        }
    }
    x
}

/// Runs the PPXA solver on the whole problem; returns (x, F) in f64.
fn ppxa<S: lfdepth::Scalar>(
    p: &Problem,
    params: &TvParams,
) -> (Vec<f64>, Vec<f64>, Vec<f64>, usize) {
    let maps = Maps::new(p.w, p.h, &p.d, &p.c).unwrap();
    let guide: Guide<'_, u8> = Guide::Weights {
        horizontal: &p.wh,
        vertical: &p.wv,
    };
    let rect = Rect {
        x: 0,
        y: 0,
        width: p.w,
        height: p.h,
    };
    let n = p.w * p.h;
    let mut out = vec![0.0f32; n];
    let mut dual = vec![0.0f32; 2 * n];
    let mut history = vec![0.0f32; params.max_iterations];
    let mut scratch = vec![S::ZERO; tv::scratch_len_for(p.w, p.h)];
    let report = tv::solve(
        &maps,
        &guide,
        params,
        rect,
        rect,
        SolveOutput {
            disparity: &mut out,
            stride: p.w,
            history: &mut history,
            dual: Some(&mut dual),
        },
        &mut scratch,
    )
    .unwrap();
    let x = out.iter().map(|&v| v as f64).collect();
    let fh = dual.iter().step_by(2).map(|&v| v as f64).collect();
    let fv = dual.iter().skip(1).step_by(2).map(|&v| v as f64).collect();
    (x, fh, fv, report.iterations)
}

fn check(norm: TvNorm, seed: u64) {
    let p = problem(9, 7, seed);
    let params = params(norm);
    let reference = chambolle_pock(&p, &params, 60_000);
    let best = primal_objective(&p, &params, &reference);
    let (x, fh, fv, _) = ppxa::<f32>(&p, &params);
    let ours = primal_objective(&p, &params, &x);
    let rel = (ours - best) / best.abs();
    assert!(
        rel.abs() < 1e-4,
        "{norm:?} seed {seed}: PPXA objective {ours} vs Chambolle–Pock {best} (rel {rel:e})"
    );
    // Duality gap: project the dual onto B (it is feasible only in the limit).
    let (ph, pv): (Vec<f64>, Vec<f64>) = fh
        .iter()
        .zip(&fv)
        .map(|(&h, &v)| project(h, v, norm, 1.0))
        .unzip();
    let lower = dual_objective(&p, &params, &ph, &pv);
    let gap = (best - lower) / best.abs();
    assert!(
        (-1e-6..1e-4).contains(&gap),
        "{norm:?} seed {seed}: relative duality gap {gap:e}"
    );
    // Eq. 16: the primal returned is D − λ A⁻¹ WᵀF for the dual returned.
    let a = data_weights(&p, &params);
    let (wh, wv) = edges(&p);
    let u = grad_adjoint(&p, &wh, &wv, &fh, &fv);
    for i in 0..x.len() {
        let from_dual = p.d[i] as f64 - params.lambda as f64 * u[i] / a[i];
        assert!(
            (from_dual - x[i]).abs() < 1e-4,
            "{norm:?} seed {seed}: pixel {i}: primal {} vs Eq. 16 {from_dual}",
            x[i]
        );
    }
    // And it is close to the reference minimiser itself (strong convexity).
    let worst = x
        .iter()
        .zip(&reference)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-2, "{norm:?} seed {seed}: max |x − x*| = {worst}");
}

#[test]
fn ppxa_reaches_the_chambolle_pock_objective_l2() {
    for seed in [1, 2, 3] {
        check(TvNorm::L2, seed);
    }
}

#[test]
fn ppxa_reaches_the_chambolle_pock_objective_l1() {
    for seed in [4, 5] {
        check(TvNorm::L1, seed);
    }
}

#[test]
fn duality_gap_shrinks_with_iterations() {
    let p = problem(9, 7, 11);
    let mut gaps = Vec::new();
    for iterations in [10, 100, 1000] {
        let params = TvParams {
            max_iterations: iterations,
            ..params(TvNorm::L2)
        };
        let (x, fh, fv, _) = ppxa::<f32>(&p, &params);
        let (ph, pv): (Vec<f64>, Vec<f64>) = fh
            .iter()
            .zip(&fv)
            .map(|(&h, &v)| project(h, v, TvNorm::L2, 1.0))
            .unzip();
        let gap = primal_objective(&p, &params, &x) - dual_objective(&p, &params, &ph, &pv);
        gaps.push(gap);
    }
    assert!(
        gaps[0] > gaps[1] && gaps[1] > gaps[2] && gaps[2] < 1e-3 * gaps[0].max(1e-9) + 1e-5,
        "gaps {gaps:?}"
    );
}

#[test]
fn fixed_point_tracks_f32_on_a_random_problem() {
    let p = problem(12, 10, 21);
    let params = TvParams {
        max_iterations: 300,
        tolerance: 0.0,
        ..params(TvNorm::L2)
    };
    let (xf, _, _, _) = ppxa::<f32>(&p, &params);
    let (xq, _, _, _) = ppxa::<Q16>(&p, &params);
    let worst = xf
        .iter()
        .zip(&xq)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst < 0.01, "Q16.16 vs f32: max difference {worst} px");
}
