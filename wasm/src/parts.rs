//! The stages after EPI by parts, so the page can spread them over Web Workers: refine
//! bands, the geodesic refill (one whole-map part), weighted-median row bands (one pass
//! at a time), TV tiles. Each part is the
//! core's own band/tile function; put together in the order the core's serial
//! `pipeline::regularize` runs them they give its bits, whatever the split.

use lfdepth::tv::{self, Guide, Maps, SolveOutput};
use lfdepth::{geofill, median, refine};
use wasm_bindgen::prelude::*;

use crate::estimator::{iterations_run, Band, Estimator};
use crate::js::{error, message};

/// The refined disparity of one TV tile's core, with its residual history.
#[wasm_bindgen]
pub struct TvTile {
    x: usize,
    y: usize,
    width: usize,
    height: usize,
    disparity: Vec<f32>,
    history: Vec<f32>,
}

#[wasm_bindgen]
impl TvTile {
    /// Left column of the core in the image.
    #[wasm_bindgen(getter)]
    pub fn x(&self) -> usize {
        self.x
    }
    /// Top row of the core in the image.
    #[wasm_bindgen(getter)]
    pub fn y(&self) -> usize {
        self.y
    }
    /// Core width.
    #[wasm_bindgen(getter)]
    pub fn width(&self) -> usize {
        self.width
    }
    /// Core height.
    #[wasm_bindgen(getter)]
    pub fn height(&self) -> usize {
        self.height
    }
    /// Refined disparity of the core, `width · height`, row-major.
    #[wasm_bindgen(getter)]
    pub fn disparity(&self) -> js_sys::Float32Array {
        js_sys::Float32Array::from(&self.disparity[..])
    }
    /// The tile's squared dual update per iteration (`tvIterations` values, zero past
    /// the iterations it ran): pass every tile's, in tile order, to `tvResiduals`.
    #[wasm_bindgen(getter)]
    pub fn history(&self) -> js_sys::Float32Array {
        js_sys::Float32Array::from(&self.history[..])
    }
}

impl Estimator {
    fn stage_maps(&self) -> Result<(&[f32], &[f32]), JsError> {
        match &self.maps {
            Some((d, c)) => Ok((d, c)),
            None => Err(message(
                "no maps set: call setMaps(disparity, confidence) before a stage part",
            )),
        }
    }
}

#[wasm_bindgen]
impl Estimator {
    /// Sets the maps the stage parts read (copies): the fused EPI maps for
    /// `refineBand`, the previous pass's disparity for `medianRows`, the disparity and
    /// confidence TV regularises for `tvTile`. `plan.pixels()` values each.
    #[wasm_bindgen(js_name = setMaps)]
    pub fn set_maps(&mut self, disparity: &[f32], confidence: &[f32]) -> Result<(), JsError> {
        let pixels = self.plan.pixels();
        for (name, len) in [
            ("disparity", disparity.len()),
            ("confidence", confidence.len()),
        ] {
            if len != pixels {
                return Err(message(&format!(
                    "{name} has {len} values but the view has {pixels} pixels"
                )));
            }
        }
        self.maps = Some((disparity.to_vec(), confidence.to_vec()));
        Ok(())
    }

    /// Frees the maps of `setMaps` and the map of `setPreviousDisparity`.
    #[wasm_bindgen(js_name = clearMaps)]
    pub fn clear_maps(&mut self) {
        self.maps = None;
        self.previous = None;
    }

    /// For a median pass after the first: the disparity the previous pass read (copied,
    /// `plan.pixels()` values). `medianRows` then filters only near the pixels that
    /// moved, with the same result as a full pass.
    #[wasm_bindgen(js_name = setPreviousDisparity)]
    pub fn set_previous_disparity(&mut self, previous: &[f32]) -> Result<(), JsError> {
        let pixels = self.plan.pixels();
        if previous.len() != pixels {
            return Err(message(&format!(
                "the previous disparity has {} values but the view has {pixels} pixels",
                previous.len()
            )));
        }
        self.previous = Some(previous.to_vec());
        Ok(())
    }

    /// Forgets the map of `setPreviousDisparity` (the next `medianRows` is a first pass).
    #[wasm_bindgen(js_name = clearPreviousDisparity)]
    pub fn clear_previous_disparity(&mut self) {
        self.previous = None;
    }

    /// Number of refine bands; 0 when `params.refine` is false (the refined maps are
    /// then the fused EPI maps).
    #[wasm_bindgen(getter, js_name = refineBands)]
    pub fn refine_bands(&self) -> usize {
        if self.plan.params().refine.enabled {
            refine::band_count(&self.plan)
        } else {
            0
        }
    }

    /// Image rows `[start, end)` of refine band `index`.
    #[wasm_bindgen(js_name = refineBandRange)]
    pub fn refine_band_range(&self, index: usize) -> Result<Vec<usize>, JsError> {
        let rows = refine::band_rows(&self.plan, index).map_err(error)?;
        Ok(vec![rows.start, rows.end])
    }

    /// Refines band `index` of the maps of `setMaps` (the fused EPI maps) for the range
    /// `[min, max]` they were estimated over: disparity and confidence of the band's
    /// rows, row-major.
    #[wasm_bindgen(js_name = refineBand)]
    pub fn refine_band(&self, index: usize, min: f32, max: f32) -> Result<Band, JsError> {
        let (input, _) = self.stage_maps()?;
        let lf = self.light_field()?;
        let rows = refine::band_rows(&self.plan, index).map_err(error)?;
        let len = rows.len() * self.plan.layout().width;
        let mut disparity = vec![0.0f32; len];
        let mut confidence = vec![0.0f32; len];
        let mut scratch = vec![0.0f32; refine::scratch_len(&self.plan)];
        refine::refine_band(
            &self.plan,
            &lf,
            (min, max),
            input,
            rows,
            &mut disparity,
            &mut confidence,
            &mut scratch,
        )
        .map_err(error)?;
        Ok(Band {
            disparity,
            confidence,
        })
    }

    /// True when the geodesic refill runs (after the refine bands, before the median).
    #[wasm_bindgen(getter)]
    pub fn geofill(&self) -> bool {
        self.plan.params().geofill.enabled
    }

    /// The geodesic refill of the disparity of `setMaps` (the refined map), guided by the
    /// centre view: `plan.pixels()` values. One serial part: its sweeps run over the
    /// whole map in one order.
    #[wasm_bindgen(js_name = geofillMap)]
    pub fn geofill_map(&self) -> Result<Vec<f32>, JsError> {
        let (input, _) = self.stage_maps()?;
        let lf = self.light_field()?;
        let mut out = vec![0.0f32; self.plan.pixels()];
        let mut scratch = vec![0.0f32; geofill::scratch_len(&self.plan)];
        geofill::fill(&self.plan, &lf.center_view(), input, &mut out, &mut scratch)
            .map_err(error)?;
        Ok(out)
    }

    /// Weighted-median passes to run over the whole map, one after the other; 0 when
    /// `params.median` is false.
    #[wasm_bindgen(getter, js_name = medianPasses)]
    pub fn median_passes(&self) -> usize {
        let median = self.plan.params().median;
        if median.enabled {
            median.passes
        } else {
            0
        }
    }

    /// True when the median passes run between refine and TV, false when after TV.
    #[wasm_bindgen(getter, js_name = medianBeforeTv)]
    pub fn median_before_tv(&self) -> bool {
        self.plan.params().median.before_tv
    }

    /// One median pass over image rows `start..end` of the disparity of `setMaps` (the
    /// previous pass's whole map), guided by the centre view: `(end − start) · width`
    /// values, row-major. With `setPreviousDisparity`, only pixels near the ones the
    /// previous pass moved are recomputed (same values).
    #[wasm_bindgen(js_name = medianRows)]
    pub fn median_rows(&self, start: usize, end: usize) -> Result<Vec<f32>, JsError> {
        let (input, _) = self.stage_maps()?;
        let lf = self.light_field()?;
        let width = self.plan.layout().width;
        let rows = end
            .checked_sub(start)
            .ok_or_else(|| message(&format!("median rows {start}..{end}: start is after end")))?;
        let mut out = vec![0.0f32; rows.saturating_mul(width)];
        let mut scratch = vec![0.0f32; median::scratch_len(&self.plan)];
        let guide = lf.center_view();
        match &self.previous {
            Some(previous) => median::filter_rows_again(
                &self.plan,
                &guide,
                input,
                previous,
                start..end,
                &mut out,
                &mut scratch,
            ),
            None => median::filter_rows(
                &self.plan,
                &guide,
                input,
                start..end,
                &mut out,
                &mut scratch,
            ),
        }
        .map_err(error)?;
        Ok(out)
    }

    /// Every median pass over image rows `start..end`, from the disparity of `setMaps`
    /// (the map before the first pass): `(end − start) · width` values, row-major, the
    /// same as `medianPasses` calls of `medianRows` over the whole map. A pixel's value
    /// after one pass depends only on the input within `radius + 1` rows of it, so pass
    /// `k` (of `n`) filters the rows within `(n − 1 − k) · (radius + 1)` of the band and
    /// no map travels between passes: one call per band instead of a copy of the whole
    /// map to every worker and a round trip per band for each pass.
    #[wasm_bindgen(js_name = medianAllPassesRows)]
    pub fn median_all_passes_rows(&self, start: usize, end: usize) -> Result<Vec<f32>, JsError> {
        let (input, _) = self.stage_maps()?;
        let lf = self.light_field()?;
        let layout = self.plan.layout();
        let (width, height) = (layout.width, layout.height);
        if start > end || end > height {
            return Err(message(&format!(
                "median rows {start}..{end}: need start ≤ end ≤ the height, {height}"
            )));
        }
        let passes = self.median_passes();
        if passes == 0 {
            return Ok(input[start * width..end * width].to_vec());
        }
        let reach = self.plan.params().median.radius + 1;
        let guide = lf.center_view();
        let mut scratch = vec![0.0f32; median::scratch_len(&self.plan)];
        // The input of the pass about to run, the input of the pass before it, and the
        // output; only the rows a later pass reads are ever filled. `settled`: what each
        // pass remembers per pixel for the next (`median::filter_pass`); a pass's rows
        // lie within the previous pass's, so it reads only bytes that pass wrote.
        let mut current = input.to_vec();
        let mut before: Option<Vec<f32>> = None;
        let mut next = vec![0.0f32; input.len()];
        let mut settled = vec![0u8; input.len()];
        for pass in 0..passes {
            let grow = (passes - 1 - pass) * reach;
            let rows = start.saturating_sub(grow)..(end + grow).min(height);
            let band = rows.start * width..rows.end * width;
            median::filter_pass(
                &self.plan,
                &guide,
                &current,
                before.as_deref(),
                rows,
                &mut next[band.clone()],
                &mut settled[band],
                &mut scratch,
            )
            .map_err(error)?;
            // next → current → before; the oldest map becomes the next output.
            let oldest = before.replace(core::mem::replace(&mut current, next));
            next = oldest.unwrap_or_else(|| vec![0.0f32; input.len()]);
        }
        Ok(current[start * width..end * width].to_vec())
    }

    /// Number of TV tiles (row-major).
    #[wasm_bindgen(getter, js_name = tvTiles)]
    pub fn tv_tiles(&self) -> usize {
        let (cols, rows) = tv::tile_count(&self.plan);
        cols.saturating_mul(rows)
    }

    /// Most TV iterations per tile: the length of each tile's `history`.
    #[wasm_bindgen(getter, js_name = tvIterations)]
    pub fn tv_iterations(&self) -> usize {
        self.plan.params().tv.max_iterations
    }

    /// Regularises TV tile `index` of the maps of `setMaps` (disparity and confidence)
    /// guided by the centre view.
    #[wasm_bindgen(js_name = tvTile)]
    pub fn tv_tile(&self, index: usize) -> Result<TvTile, JsError> {
        // A tile solved alone is the first pass only: the outer sweeps need every tile's
        // dual of the previous pass (the whole-map path of `estimate` and
        // `refineAndRegularize` runs them).
        if self.plan.params().tv.sweeps > 0 {
            return Err(message(
                "tvTile solves each tile once, without the outer sweeps of params.tvSweeps:                  pass tvSweeps 0, or run estimate() or refineAndRegularize()",
            ));
        }
        let (disparity, confidence) = self.stage_maps()?;
        let lf = self.light_field()?;
        let layout = self.plan.layout();
        let maps = Maps::new(layout.width, layout.height, disparity, confidence).map_err(error)?;
        let (core, _) = tv::tile_rects(&self.plan, index).map_err(error)?;
        let mut out = vec![0.0f32; core.width * core.height];
        let mut history = vec![0.0f32; self.tv_iterations()];
        let mut scratch = vec![0.0f32; tv::scratch_len(&self.plan)];
        tv::refine_tile(
            &self.plan,
            &maps,
            &Guide::View(lf.center_view()),
            index,
            SolveOutput {
                disparity: &mut out,
                stride: core.width,
                history: &mut history,
                dual: None,
            },
            &mut scratch,
        )
        .map_err(error)?;
        Ok(TvTile {
            x: core.x,
            y: core.y,
            width: core.width,
            height: core.height,
            disparity: out,
            history,
        })
    }

    /// The TV residual curve from every tile's `history`, concatenated in tile order
    /// (`tvTiles · tvIterations` values): summed in tile order and normalised as the
    /// serial pipeline does, without the iterations no tile ran.
    #[wasm_bindgen(js_name = tvResiduals)]
    pub fn tv_residuals(&self, histories: &[f32]) -> Result<Vec<f32>, JsError> {
        let iterations = self.tv_iterations();
        let tiles = self.tv_tiles();
        if Some(histories.len()) != tiles.checked_mul(iterations) {
            return Err(message(&format!(
                "histories has {} values but {tiles} tiles × {iterations} iterations are needed",
                histories.len()
            )));
        }
        let mut history = vec![0.0f32; iterations];
        for tile in histories.chunks_exact(iterations.max(1)) {
            for (h, t) in history.iter_mut().zip(tile) {
                *h += t;
            }
        }
        tv::normalise_history(&self.plan, &mut history);
        Ok(iterations_run(history))
    }
}
