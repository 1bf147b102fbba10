//! Tests of the solve as a whole and of its kernels against their definitions.

extern crate std;

use std::vec;
use std::vec::Vec;

use crate::error::Error;
use crate::lightfield::View;
use crate::scalar::{Scalar, Q16};

use super::super::params::{TvNorm, TvParams};
use super::combine::project_lanes;
use super::graph::Graph;
use super::quadratic::{prox_row, residual_row};
use super::rows::divergence_row;
use super::stopping::FIRST_CHECK;
use super::{scratch_len_for, solve, Guide, Maps, Rect, SolveOutput};

/// `out = WᵀF` over the whole graph (the row kernel, row after row).
fn divergence<S: Scalar>(width: usize, wh: &[S], wv: &[S], fh: &[S], fv: &[S], out: &mut [S]) {
    for (y, row) in out.chunks_exact_mut(width).enumerate() {
        divergence_row(y, width, wh, wv, fh, fv, row);
    }
}

/// A deterministic pseudo-random sequence in [0, 1).
fn lcg(seed: &mut u64) -> f32 {
    *seed = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*seed >> 40) as f32 / (1u64 << 24) as f32
}

/// Both quadratic parts' proximity operators over the whole graph through the row
/// kernels of the sweep: copies `y2` (black part) and `y3` (white part) in, `(p2, p3)`
/// out, each as `(h, v)`; the kernels' own/other layout is formed and undone here.
#[allow(clippy::type_complexity)]
fn prox_parts(
    w: usize,
    wh: &[f32],
    wv: &[f32],
    tau: &[f32],
    sig: &[f32],
    y2: (&[f32], &[f32]),
    y3: (&[f32], &[f32]),
) -> ((Vec<f32>, Vec<f32>), (Vec<f32>, Vec<f32>)) {
    let n = wh.len();
    let black = |i: usize| (i % w + i / w) % 2 == 0;
    let pick = |i: usize, own: bool, a: &[f32], b: &[f32]| {
        if black(i) == own {
            a[i]
        } else {
            b[i]
        }
    };
    let own_h: Vec<f32> = (0..n).map(|i| pick(i, true, y2.0, y3.0)).collect();
    let own_v: Vec<f32> = (0..n).map(|i| pick(i, true, y2.1, y3.1)).collect();
    let other_h: Vec<f32> = (0..n).map(|i| pick(i, false, y2.0, y3.0)).collect();
    let other_v: Vec<f32> = (0..n).map(|i| pick(i, false, y2.1, y3.1)).collect();
    let copies = [&own_h[..], &own_v[..], &other_h[..], &other_v[..]];
    let mut s = vec![0.0f32; n];
    for (y, row) in s.chunks_exact_mut(w).enumerate() {
        residual_row(y, w, [wh, wv], [tau, sig], copies, row);
    }
    let mut out = [vec![0.0f32; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    let rows = n / w;
    for y in 0..rows {
        let r = y * w..(y + 1) * w;
        let below = (y + 1 < rows).then(|| &s[(y + 1) * w..(y + 2) * w]);
        let [a, b, c, d] = &mut out;
        prox_row(
            [&wh[r.clone()], &wv[r.clone()]],
            copies.map(|c| &c[r.clone()]),
            &s[r.clone()],
            below,
            [
                &mut a[r.clone()],
                &mut b[r.clone()],
                &mut c[r.clone()],
                &mut d[r.clone()],
            ],
        );
    }
    let [poh, pov, pxh, pxv] = &out;
    let part = |own: bool, o: &[f32], x: &[f32]| -> Vec<f32> {
        (0..n).map(|i| pick(i, own, o, x)).collect()
    };
    (
        (part(true, poh, pxh), part(true, pov, pxv)),
        (part(false, poh, pxh), part(false, pov, pxv)),
    )
}

#[test]
fn quadratic_prox_solves_its_optimality_condition() {
    // prox_{γg}(y) = p  ⇔  p − y + γ ∇g(p) = 0 with g = Σ_{colour} κ/2 ((Wᵀp)_i − τ_i)²,
    // for the black part (copy y2) and the white part (copy y3) at once.
    let (w, h) = (5usize, 4usize);
    let n = w * h;
    let mut seed = 7;
    let mut r = |s: f32| (lcg(&mut seed) - 0.5) * s;
    let mut wh: Vec<f32> = (0..n).map(|_| r(1.0).abs() + 0.1).collect();
    let mut wv: Vec<f32> = (0..n).map(|_| r(1.0).abs() + 0.1).collect();
    for y in 0..h {
        wh[y * w + w - 1] = 0.0;
    }
    for x in 0..w {
        wv[(h - 1) * w + x] = 0.0;
    }
    let tau: Vec<f32> = (0..n).map(|_| r(4.0)).collect();
    let kappa: Vec<f32> = (0..n).map(|_| r(2.0).abs() + 0.2).collect();
    let gamma = 0.7f32;
    let mut sig = vec![0.0f32; n];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let mut c2 = wh[i] * wh[i] + wv[i] * wv[i];
            if x > 0 {
                c2 += wh[i - 1] * wh[i - 1];
            }
            if y > 0 {
                c2 += wv[i - w] * wv[i - w];
            }
            sig[i] = gamma * kappa[i] / (1.0 + gamma * kappa[i] * c2);
        }
    }
    let copies: Vec<Vec<f32>> = (0..4).map(|_| (0..n).map(|_| r(2.0)).collect()).collect();
    let (y2, y3) = (
        (&copies[0][..], &copies[1][..]),
        (&copies[2][..], &copies[3][..]),
    );
    let (p2, p3) = prox_parts(w, &wh, &wv, &tau, &sig, y2, y3);
    for (colour, (yh, yv), (ph, pv)) in [(0, y2, p2), (1, y3, p3)] {
        // ∇g(p) = W∇(mask κ (Wᵀp − τ)) in the sign convention of `divergence`.
        let mut u = vec![0.0; n];
        divergence(w, &wh, &wv, &ph, &pv, &mut u);
        let r_node: Vec<f32> = (0..n)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if (x + y) % 2 == colour {
                    kappa[i] * (u[i] - tau[i])
                } else {
                    0.0
                }
            })
            .collect();
        for i in 0..n {
            let (x, y) = (i % w, i / w);
            let gh = if x + 1 < w {
                wh[i] * (r_node[i + 1] - r_node[i])
            } else {
                0.0
            };
            let gv = if y + 1 < h {
                wv[i] * (r_node[i + w] - r_node[i])
            } else {
                0.0
            };
            assert!(
                (ph[i] - yh[i] + gamma * gh).abs() < 1e-4,
                "colour {colour} h {i}"
            );
            assert!(
                (pv[i] - yv[i] + gamma * gv).abs() < 1e-4,
                "colour {colour} v {i}"
            );
        }
    }
}

/// A region solved with the optimal dual of the whole map on its border flows (and as
/// its start) returns the whole map's solution on its core: the outer sweeps' fixed
/// point is the untiled optimum.
#[test]
fn a_region_with_the_optimal_border_flows_reproduces_the_whole_solution() {
    for norm in [TvNorm::L2, TvNorm::L1] {
        region_with_optimal_border_flows(norm);
    }
}

fn region_with_optimal_border_flows(norm: TvNorm) {
    let (w, h) = (24usize, 20usize);
    let mut state = 12345u32;
    let mut rand = || {
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (state >> 8) as f32 / (1u32 << 24) as f32
    };
    let d: Vec<f32> = (0..w * h)
        .map(|i| if i % w < 11 { 1.0 } else { -0.5 } + 0.6 * rand())
        .collect();
    let c: Vec<f32> = (0..w * h).map(|_| rand()).collect();
    let wh: Vec<f32> = (0..w * h).map(|_| 0.2 + rand()).collect();
    let wv: Vec<f32> = (0..w * h).map(|_| 0.2 + rand()).collect();
    let guide: Guide<'_, u8> = Guide::Weights {
        horizontal: &wh,
        vertical: &wv,
    };
    let maps = Maps::new(w, h, &d, &c).unwrap();
    let params = TvParams {
        lambda: 0.5,
        norm,
        max_iterations: 8_000,
        tolerance: 0.0,
        ..TvParams::default()
    };
    let full = Rect {
        x: 0,
        y: 0,
        width: w,
        height: h,
    };
    let mut whole = vec![0.0f32; w * h];
    let mut dual = vec![0.0f32; 2 * w * h];
    let mut scratch = vec![0.0f32; scratch_len_for(w, h)];
    let out = SolveOutput {
        disparity: &mut whole,
        stride: w,
        history: &mut [],
        dual: Some(&mut dual),
    };
    solve(&maps, &guide, &params, full, full, out, &mut scratch).unwrap();

    let region = Rect {
        x: 5,
        y: 4,
        width: 12,
        height: 10,
    };
    let core = Rect {
        x: 8,
        y: 7,
        width: 6,
        height: 4,
    };
    let solve_region = |maps: &Maps<'_>, scratch: &mut [f32]| {
        let mut part = vec![0.0f32; core.pixels()];
        let out = SolveOutput {
            disparity: &mut part,
            stride: core.width,
            history: &mut [],
            dual: None,
        };
        solve(maps, &guide, &params, region, core, out, scratch).unwrap();
        part
    };
    let error = |part: &[f32]| {
        let mut worst = 0.0f32;
        for y in 0..core.height {
            for x in 0..core.width {
                let g = (core.y + y) * w + core.x + x;
                worst = worst.max((part[y * core.width + x] - whole[g]).abs());
            }
        }
        worst
    };
    let free = error(&solve_region(&maps, &mut scratch));
    assert!(maps.with_dual(&dual[1..]).is_err());
    let with = maps.with_dual(&dual).unwrap();
    let fixed = error(&solve_region(&with, &mut scratch));
    assert!(
        fixed < 2e-4,
        "{norm:?}: with the optimal border flows: {fixed} px off"
    );
    assert!(
        free > 10.0 * fixed,
        "{norm:?}: free border {free} px vs fixed {fixed} px"
    );
}

/// Started from the optimal dual, the PPXA copies start at their fixed point
/// (`consistent_copies`), so the solve stops at its first check, still at the optimum
/// (with every copy equal to the dual, PPXA first moved them: from HCI cotton's
/// converged dual it ran 24 of the cold start's 28 iterations).
#[test]
fn a_solve_started_at_the_optimum_stops_at_its_first_check() {
    for norm in [TvNorm::L2, TvNorm::L1] {
        let (w, h) = (24usize, 20usize);
        let mut seed = 99;
        let d: Vec<f32> = (0..w * h)
            .map(|i| if i % w < 11 { 1.0 } else { -0.5 } + 0.6 * lcg(&mut seed))
            .collect();
        let c: Vec<f32> = (0..w * h).map(|_| lcg(&mut seed)).collect();
        let wh: Vec<f32> = (0..w * h).map(|_| 0.2 + lcg(&mut seed)).collect();
        let wv: Vec<f32> = (0..w * h).map(|_| 0.2 + lcg(&mut seed)).collect();
        let guide: Guide<'_, u8> = Guide::Weights {
            horizontal: &wh,
            vertical: &wv,
        };
        let maps = Maps::new(w, h, &d, &c).unwrap();
        let full = Rect {
            x: 0,
            y: 0,
            width: w,
            height: h,
        };
        let mut scratch = vec![0.0f32; scratch_len_for(w, h)];
        let mut solve_with = |maps: &Maps<'_>, params: &TvParams, dual: Option<&mut [f32]>| {
            let mut x = vec![0.0f32; w * h];
            let out = SolveOutput {
                disparity: &mut x,
                stride: w,
                history: &mut [],
                dual,
            };
            let report = solve(maps, &guide, params, full, full, out, &mut scratch).unwrap();
            (x, report)
        };
        let converged = TvParams {
            norm,
            max_iterations: 8_000,
            tolerance: 0.0,
            ..TvParams::default()
        };
        let mut dual = vec![0.0f32; 2 * w * h];
        let (optimum, _) = solve_with(&maps, &converged, Some(&mut dual));
        let default = TvParams {
            norm,
            ..TvParams::default()
        };
        let (_, cold) = solve_with(&maps, &default, None);
        let warm_maps = maps.with_dual(&dual).unwrap();
        let (warm, report) = solve_with(&warm_maps, &default, None);
        assert!(
            report.converged && report.iterations == FIRST_CHECK,
            "{norm:?}: {report:?}"
        );
        assert!(cold.iterations > FIRST_CHECK, "{norm:?}: cold {cold:?}");
        let off = warm
            .iter()
            .zip(&optimum)
            .fold(0.0f32, |m, (a, b)| m.max((a - b).abs()));
        // Up to the first check, each iteration moving the map by less than the
        // tolerance (RMS).
        let bound = report.iterations as f32 * default.tolerance;
        assert!(off < bound, "{norm:?}: {off} px from the optimum");
    }
}

#[test]
fn edge_weights_by_blocks_of_columns_equal_those_node_by_node() {
    // A 150 × 9 image (more than two blocks of columns, a partial last one) with
    // regions inside it, at its right and bottom edges and across all of it, for
    // every layout of a view (1, 3, 4 samples).
    let (mw, mh) = (150usize, 9usize);
    let d = vec![0.0f32; mw * mh];
    let c = vec![1.0f32; mw * mh];
    let maps = Maps::new(mw, mh, &d, &c).unwrap();
    let params = TvParams::default();
    let regions = [
        Rect {
            x: 3,
            y: 2,
            width: 140,
            height: 5,
        },
        Rect {
            x: 10,
            y: 4,
            width: 140,
            height: 5,
        },
        Rect {
            x: 0,
            y: 0,
            width: mw,
            height: mh,
        },
        Rect {
            x: 149,
            y: 0,
            width: 1,
            height: 3,
        },
    ];
    let mut seed = 7u64;
    for ch in [1usize, 3, 4] {
        // Small steps (weights between the floor and 1) and a few large ones.
        let data: Vec<u8> = (0..mw * mh * ch)
            .map(|i| {
                let jump = if lcg(&mut seed) < 0.1 { 100.0 } else { 0.0 };
                ((i / ch % mw) as f32 * 0.5 + lcg(&mut seed) * 8.0 + jump) as u8
            })
            .collect();
        let view = View::new(&data, mw, mh, ch, mw * ch).unwrap();
        let guide = Guide::View(view);
        for region in regions {
            let n = region.width * region.height;
            let mut a = vec![0.0f32; scratch_len_for(region.width, region.height)];
            let mut b = a.clone();
            let mut by_view = Graph::split(&mut a, region.width, region.height);
            by_view.weights_from_view(&maps, &view, &params, region);
            let mut by_node = Graph::split(&mut b, region.width, region.height);
            by_node.weights_by_node(&maps, &guide, &params, region);
            assert_eq!(
                by_view.wh[..n],
                by_node.wh[..n],
                "{ch} channels, {region:?}"
            );
            assert_eq!(
                by_view.wv[..n],
                by_node.wv[..n],
                "{ch} channels, {region:?}"
            );
            // The large regions see both kinds of steps.
            if n > 100 {
                let (wh, wv) = (&by_view.wh[..n], &by_view.wv[..n]);
                let between = |w: &f32| *w > params.edge_floor && *w < 1.0;
                assert!(wh.iter().chain(wv).any(between), "{ch} ch., {region:?}");
                let floor = |w: &f32| *w == params.edge_floor;
                assert!(wh.iter().chain(wv).any(floor), "{ch} ch., {region:?}");
            }
        }
    }
}

#[test]
fn projections_land_in_the_constraint_sets() {
    let (mut h, mut v) = ([3.0f32, 0.3], [-0.5f32, 0.4]);
    project_lanes(&mut h, &mut v, &[1.0; 2], TvNorm::L1);
    assert_eq!((h, v), ([1.0, 0.3], [-0.5, 0.4]));
    let (mut h, mut v) = ([3.0f32, 0.3], [4.0f32, 0.4]);
    project_lanes(&mut h, &mut v, &[1.0; 2], TvNorm::L2);
    assert!((h[0] - 0.6).abs() < 1e-6 && (v[0] - 0.8).abs() < 1e-6);
    assert_eq!((h[1], v[1]), (0.3, 0.4));
    let q = Q16::from_f32;
    let (mut h, mut v) = ([q(96.0)], [q(128.0)]);
    project_lanes(&mut h, &mut v, &[q(1.0 / 32.0)], TvNorm::L2);
    assert!((h[0].to_f32() - 19.2).abs() < 1e-3 && (v[0].to_f32() - 25.6).abs() < 1e-3);
}

#[test]
fn bad_buffers_are_errors_not_panics() {
    let (w, h) = (8usize, 8usize);
    let d = vec![0.5f32; w * h];
    let c = vec![1.0f32; w * h];
    let maps = Maps::new(w, h, &d, &c).unwrap();
    let ones = vec![1.0f32; w * h];
    let guide: Guide<'_, u8> = Guide::Weights {
        horizontal: &ones,
        vertical: &ones,
    };
    let rect = Rect {
        x: 0,
        y: 0,
        width: w,
        height: h,
    };
    let params = TvParams::default();
    let mut out = vec![0.0f32; w * h];
    let mut hist = vec![0.0f32; 4];
    let mut small = vec![0.0f32; 10];
    let res = solve(
        &maps,
        &guide,
        &params,
        rect,
        rect,
        SolveOutput {
            disparity: &mut out,
            stride: w,
            history: &mut hist,
            dual: None,
        },
        &mut small,
    );
    assert!(matches!(res, Err(Error::ScratchTooSmall { .. })));
    let mut scratch = vec![0.0f32; scratch_len_for(w, h)];
    let outside = Rect { x: 4, ..rect };
    let res = solve(
        &maps,
        &guide,
        &params,
        outside,
        outside,
        SolveOutput {
            disparity: &mut out,
            stride: w,
            history: &mut hist,
            dual: None,
        },
        &mut scratch,
    );
    assert!(matches!(res, Err(Error::InvalidParameter { .. })));
    // A constant map is its own refinement.
    let report = solve(
        &maps,
        &guide,
        &params,
        rect,
        rect,
        SolveOutput {
            disparity: &mut out,
            stride: w,
            history: &mut hist,
            dual: None,
        },
        &mut scratch,
    )
    .unwrap();
    assert!(report.converged, "{report:?}");
    assert!(out.iter().all(|&v| (v - 0.5).abs() < 1e-3), "{out:?}");
    assert!(Maps::new(w, h, &d[1..], &c).is_err());
}

proptest::proptest! {
    #[test]
    fn solve_never_panics(
        w in 1usize..10, h in 1usize..10,
        rx in 0usize..12, ry in 0usize..12, rw in 0usize..12, rh in 0usize..12,
        cx in 0usize..12, cy in 0usize..12, cw in 0usize..12, ch in 0usize..12,
        stride in 0usize..12, out_len in 0usize..120, scratch_len in 0usize..2000,
        huge in proptest::bool::ANY,
    ) {
        let d: Vec<f32> = (0..w * h).map(|i| (i % 7) as f32 * 0.3 - 1.0).collect();
        let c: Vec<f32> = (0..w * h).map(|i| (i % 5) as f32 * 0.25).collect();
        let maps = Maps::new(w, h, &d, &c).unwrap();
        let ones = vec![0.5f32; w * h];
        let guide: Guide<'_, u8> = Guide::Weights { horizontal: &ones, vertical: &ones };
        let params = TvParams { max_iterations: 3, ..TvParams::default() };
        let region = Rect { x: rx, y: ry, width: if huge { usize::MAX } else { rw }, height: rh };
        let core = Rect { x: cx, y: cy, width: cw, height: ch };
        let mut out = vec![0.0f32; out_len];
        let mut hist = vec![0.0f32; 2];
        let mut scratch = vec![Q16::ZERO; scratch_len];
        let _ = solve(&maps, &guide, &params, region, core, SolveOutput {
            disparity: &mut out, stride, history: &mut hist, dual: None,
        }, &mut scratch);
    }
}

#[test]
fn maps_checked_in_a_region_refuse_non_finite_values_only_there() {
    let (w, h) = (8, 6);
    let mut d = vec![0.5f32; w * h];
    let c = vec![1.0f32; w * h];
    d[5 * w + 7] = f32::NAN; // bottom-right pixel
    let left = Rect {
        x: 0,
        y: 0,
        width: 4,
        height: 3,
    };
    let right = Rect {
        x: 4,
        y: 3,
        width: 4,
        height: 3,
    };
    assert!(Maps::checked_in(w, h, &d, &c, left).is_ok());
    assert!(matches!(
        Maps::checked_in(w, h, &d, &c, right),
        Err(Error::NonFinite { what: "disparity" })
    ));
    assert!(matches!(
        Maps::new(w, h, &d, &c),
        Err(Error::NonFinite { .. })
    ));
    // The dual is read one pixel beyond the region's left and top edges.
    let maps = Maps::new(w, h, &c, &c).unwrap();
    let mut dual = vec![0.0f32; 2 * w * h];
    dual[2 * (2 * w + 3)] = f32::INFINITY; // pixel (3, 2), just left of `beside`
    let beside = Rect {
        x: 4,
        y: 0,
        width: 4,
        height: 3,
    };
    let below = Rect {
        x: 0,
        y: 4,
        width: 8,
        height: 2,
    };
    assert!(maps.with_dual_checked_in(&dual, beside).is_err());
    assert!(maps.with_dual_checked_in(&dual, below).is_ok());
    assert!(maps.with_dual(&dual).is_err());
}
