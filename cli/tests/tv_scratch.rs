//! A TV tile's result does not depend on what an earlier solve left in the scratch: the
//! engine's workers and the serial loop reuse one scratch for tile after tile, the page's
//! workers start each tile fresh, and both must give the same bits. Unreliable pixels
//! (confidence 0) are included so that the per-node metric is exercised in some tiles.

use lfdepth::tv::{self, Guide, Maps, SolveOutput, TvParams};
use lfdepth::{Grid, Layout, Params, Plan};

#[test]
fn a_tile_gives_the_same_bits_after_another_tile_in_the_same_scratch() {
    let (w, h) = (128usize, 128usize);
    let layout = Layout::packed(Grid::new(3, 3), w, h, 3);
    let params = Params {
        tv: TvParams {
            tile: 64,
            ..TvParams::default()
        },
        ..Params::default()
    };
    let plan = Plan::new(layout, params).unwrap();
    let mut d = vec![0f32; w * h];
    let mut c = vec![0f32; w * h];
    let mut seed = 12345u32;
    let mut rnd = || {
        seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
        (seed >> 8) as f32 / 16777216.0
    };
    for i in 0..w * h {
        d[i] = (i % w) as f32 / 40.0 + rnd() * 0.5;
        c[i] = if rnd() < 0.3 { 0.0 } else { rnd() };
    }
    let view: Vec<u8> = (0..w * h * 3).map(|i| ((i * 7919) % 251) as u8).collect();
    let cv = lfdepth::View::new(&view, w, h, 3, w * 3).unwrap();
    let maps = Maps::new(w, h, &d, &c).unwrap();
    let guide = Guide::View(cv);
    let tiles = tv::tile_count(plan.tv());
    let n = tiles.0 * tiles.1;
    let run = |idx: usize, scratch: &mut [f32]| {
        let (core, _) = tv::tile_rects(plan.tv(), idx).unwrap();
        let mut out = vec![0f32; core.width * core.height];
        let mut hist = vec![0f32; plan.params().tv.max_iterations];
        tv::refine_tile(
            plan.tv(),
            &maps,
            &guide,
            idx,
            SolveOutput {
                disparity: &mut out,
                stride: core.width,
                history: &mut hist,
                dual: None,
            },
            scratch,
        )
        .unwrap();
        out
    };
    for idx in 1..n {
        let mut fresh = vec![0f32; tv::scratch_len(plan.tv())];
        let a = run(idx, &mut fresh);
        let mut dirty = vec![0f32; tv::scratch_len(plan.tv())];
        run(idx - 1, &mut dirty);
        let b = run(idx, &mut dirty);
        let diff = a
            .iter()
            .zip(&b)
            .filter(|(x, y)| x.to_bits() != y.to_bits())
            .count();
        assert_eq!(
            diff,
            0,
            "tile {idx}: {diff} pixels differ after tile {} ran in the same scratch",
            idx - 1
        );
    }
}
