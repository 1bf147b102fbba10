// Generated from lfdepth::options::TUNABLES by `cargo xtask types`: do not edit.

/** Estimation parameters; every key is optional and defaults to the core's default. */
export interface EstimateParams {
  /** Named settings the other keys then override (as the CLI's `--preset`): "default"
   * (the most accurate settings), or "fast" (less CPU: the plane sweep on luminance, one
   * Gauss–Newton step, three median passes). */
  preset?: "default" | "fast";
  /** How far `estimate` goes: "full" (every stage, the default) or "epi" (the initial
   * disparity alone: the plane sweep, or the EPI stage with `initial: "epi"`). */
  stage?: "epi" | "full";
  /** The views were warped (rectified by an alignment elsewhere, e.g. another estimator's
   * `readViews` after `align()`): the refinement compares them with its sampling slack,
   * as an estimator that aligned them itself does (default false). */
  resampled?: boolean;
  /** Align the views by per-view homographies first: off, on (fails on views that cannot
   * be aligned), or auto (only when the array is found not to be rectified; warns and
   * goes on unaligned when it cannot be aligned) (default "auto"). CLI: `--align`. */
  align?: "off" | "on" | "auto";
  /** Alignment: how the views are resampled into the rectified array: bilinear (fastest,
   * blurs fine texture), sharpened-bilinear (bilinear plus a 3-tap sharpening, as sharp
   * as Catmull–Rom on alignment's maps) or catmull-rom (4×4 cubic taps, about 1.4×
   * sharpened-bilinear's warp time) (default "sharpened-bilinear"). CLI:
   * `--align-interp`. */
  alignInterp?: "bilinear" | "sharpened-bilinear" | "catmull-rom";
  /** Alignment: which views get a homography: read (those the stages read), cross (the
   * centre row and column) or all (every view: a smaller disparity offset no image can
   * observe, slower) (default "read"). CLI: `--align-views`. */
  alignViews?: "read" | "cross" | "all";
  /** EPI stage: Gaussian pre-smoothing along the EPI line (px) (0…4; default 0.5). CLI:
   * `--epi-inner-sigma`. */
  innerSigma?: number;
  /** EPI stage: Gaussian smoothing of the structure tensor along the line and across
   * views (px) (0…5; default 2). CLI: `--epi-outer-sigma`. */
  outerSigma?: number;
  /** EPI stage: shear the EPIs over the range (false: one unsheared EPI per direction,
   * the other settings kept) (default true). */
  shear?: boolean;
  /** EPI stage: distance between shear hypotheses in px (larger: fewer hypotheses,
   * faster, coarser) (0.1…2; default 0.5). CLI: `--epi-shear-step`. */
  shearStep?: number;
  /** EPI stage: largest residual slope a hypothesis accepts, in shear steps (0.5…2;
   * default 1). CLI: `--epi-window`. */
  window?: number;
  /** EPI stage: interpolate between adjacent shears at the zero crossing of the residual
   * slope (off: the single most coherent hypothesis) (default true). CLI:
   * `--epi-interpolate`. */
  interpolate?: boolean;
  /** EPI stage: estimate on views box-filtered 2× (a quarter of the samples, half the
   * shears), then upsample the map guided by the centre view's colour (default false).
   * CLI: `--epi-half`. */
  epiHalf?: boolean;
  /** EPI stage: how the horizontal and vertical estimates are combined: coherence (the
   * more confident one) or weighted (their confidence-weighted mean where they agree
   * within 0.1 px) (default "coherence"). CLI: `--epi-fusion`. */
  fusion?: "coherence" | "weighted";
  /** EPI stage: tensor (one structure tensor over R, G, B) or gray (the channels' mean
   * first, a third of the tensor work) (default "tensor"). CLI: `--epi-color`. */
  color?: "tensor" | "gray";
  /** EPI stage, tensor colour: weight of each channel's difference from the channels'
   * mean (in pixels paler than --epi-chroma-knee when that is set; 1: the plain R, G, B
   * tensor; 0: the channels' mean only, the least noise) (0…1; default 1). CLI:
   * `--epi-chroma`. */
  epiChroma?: number;
  /** EPI stage, tensor colour: saturation (colour relative to brightness) above which a
   * pixel keeps its channels' differences whole; paler colour is scaled by --epi-chroma
   * (0: every pixel scaled) (0…1; default 0). CLI: `--epi-chroma-knee`. */
  epiChromaKnee?: number;
  /** Disparity search range in px between adjacent views: auto (estimated from the views)
   * or fixed from a minimum to a maximum (default "auto"). CLI: `--disparity-range`. */
  range?: "auto" | [number, number];
  /** Initial disparity: epi (the structure tensor on sheared EPIs), sweep (a plane sweep
   * over the EPI stage's range with window-aggregated truncated differences to the centre
   * row and column of views) or fused (both, each refined, per pixel the one with the
   * lower photometric cost over a 3×3 window) (default "sweep"). CLI: `--initial`. */
  initial?: "epi" | "sweep" | "fused";
  /** Plane sweep: largest distance between hypotheses (px) (0.05…1; default 0.25). CLI:
   * `--sweep-step`. */
  sweepStep?: number;
  /** Plane sweep: radius (px) of the square window the matching costs are summed over
   * (0…8; default 4). CLI: `--sweep-radius`. */
  sweepRadius?: number;
  /** Plane sweep: each channel's absolute difference to the centre view counts at most
   * this much (unit intensity) (0.001…1; default 0.1). CLI: `--sweep-truncate`. */
  sweepTruncate?: number;
  /** Plane sweep: a one-axis volume's winner replaces the combined one's when its
   * confidence exceeds the combined one's times this (1…4; default 1). CLI:
   * `--sweep-select`. */
  sweepSelect?: number;
  /** Plane sweep: the one-axis volumes' windows are lines this many times the radius long
   * on each side (1…4; default 2). CLI: `--sweep-line`. */
  sweepLine?: number;
  /** Plane sweep: below this sweep confidence the refined confidence is scaled by the
   * square of the sweep's over this, so TV weighs such starts less (0: off) (0…1;
   * default 0). CLI: `--sweep-trust`. */
  sweepTrust?: number;
  /** Plane sweep: side (px, odd) of a small square window whose confident winner per
   * pixel the refinement's first propagation round tries as one more candidate where two
   * opposite neighbours' winners agree with it, for structures narrower than the sweep's
   * windows (1: the pixel alone; 0: off) (0…9; default 0). CLI: `--sweep-candidate`. */
  sweepCandidate?: number;
  /** Plane sweep: match each view on rgb (each colour channel's truncated difference) or
   * gray (the channels' mean, converted once per band: a third of the matching's work)
   * (default "rgb"). CLI: `--sweep-color`. */
  sweepColor?: "rgb" | "gray";
  /** Photometric refinement of the EPI disparity over many views (default true). CLI:
   * `--refine`. */
  refine?: boolean;
  /** Refinement: Gauss–Newton iterations (1…16; default 3). CLI:
   * `--refine-iterations`. */
  refineIterations?: number;
  /** Refinement: rounds of propagation before the iterations (jumps of 8, 4, 2, 1 px, the
   * last N of them) (0…4; default 4). CLI: `--refine-propagation`. */
  refinePropagation?: number;
  /** Refinement: radius of the aggregation window (px) (0…4; default 1). CLI:
   * `--refine-radius`. */
  refineRadius?: number;
  /** Refinement: sampling slack in px of image motion: a view's residual counts only by
   * how far it falls outside the centre view's values over ±F px (0: the plain residual;
   * on warped views the pipeline uses 0.5 when this is 0) (0…1; default 0). CLI:
   * `--refine-slack`. */
  refineSlack?: number;
  /** Refinement: after the first Gauss–Newton iteration, a pixel that kept its
   * statistics and whose window's other pixels each moved by less than F px keeps its
   * disparity and confidence (0: update every pixel in every iteration) (0…1; default
   * 0.05). CLI: `--refine-skip-settled`. */
  refineSkipSettled?: number;
  /** Refinement: slanted window: neighbours' Gauss–Newton statistics are moved along
   * the local slope of the disparity and gated by their distance from that plane (0: the
   * fronto-parallel window) (default false). CLI: `--refine-slant`. */
  refineSlant?: boolean;
  /** Refinement: image rows per band, one part of the refinement step (1…4096; default
   * 128). CLI: `--refine-band-rows`. */
  refineBandRows?: number;
  /** Geodesic refill of the band around depth steps (after the refinement, before the
   * median): each pixel near a step takes the value of the outside pixel it reaches
   * through the most uniform colour, so a foreground fattened into a flat background
   * returns to its colour edge (default true). CLI: `--fill`. */
  geofill?: boolean;
  /** Geodesic refill: width (px, city-block) of the band refilled around each step (the
   * seeds' reach grows to twice it when needed) (1…32; default 5). CLI: `--fill-band`. */
  fillBand?: number;
  /** Geodesic refill: a disparity difference between 4-neighbours larger than this (px)
   * is a depth step (0.01…16; default 0.8). CLI: `--fill-step`. */
  fillStep?: number;
  /** Geodesic refill: a depth step with a colour step (largest channel difference, unit
   * intensity) of at least this within 2 px across it sits on its colour edge and is left
   * alone (0.001…1; default 0.03). CLI: `--fill-edge`. */
  fillEdge?: number;
  /** Geodesic refill: a band pixel whose cheapest colour path to a pixel outside the band
   * costs more than this (unit intensity) keeps its value (0.001…16; default 0.15).
   * CLI: `--fill-max-cost`. */
  fillMaxCost?: number;
  /** Geodesic refill: path cost per pixel of length, in unit intensity, against the
   * colour differences crossed (0.0001…1; default 0.004). CLI: `--fill-spatial`. */
  fillSpatial?: number;
  /** Geodesic refill: extrapolate the source pixel's value along its slope instead of
   * copying it (default false). CLI: `--fill-planar` sets true. */
  fillPlanar?: boolean;
  /** Edge-snapping weighted median guided by the centre view (default true). */
  median?: boolean;
  /** Edge-snapping weighted median guided by the centre view: window radius in px, or 0
   * to switch it off (0…7; default 7). CLI: `--median`. */
  medianRadius?: number;
  /** Weighted median: colour scale σ of the weights (unit intensity) (0.005…0.5;
   * default 0.04). CLI: `--median-sigma`. */
  medianSigma?: number;
  /** Weighted median: passes (each moves a fattened band a window further back onto its
   * colour edge) (1…4; default 4). CLI: `--median-passes`. */
  medianPasses?: number;
  /** Weighted median: only pixels whose window holds a step between adjacent pixels
   * larger than this (px) are filtered (0…16; default 0.2). CLI: `--median-gate`. */
  medianGate?: number;
  /** Weighted median: a pixel takes the median only when it differs from it by more than
   * this (px) (0…16; default 0.2). CLI: `--median-snap`. */
  medianSnap?: number;
  /** Weighted median: a pixel keeps its value when the pixels of its value joined to it
   * cross its window with a mean width of at most this (px): thin structures survive; 0
   * switches the test off (0…16; default 3). CLI: `--median-thin`. */
  medianThin?: number;
  /** Weighted median: neighbours vote with their own value instead of extrapolating along
   * the local slope (default false). CLI: `--median-flat` sets true. */
  medianFlat?: boolean;
  /** Weighted median: run it between the refinement and TV (true) or after TV (false)
   * (default true). CLI: `--median-after-tv` sets false. */
  medianBeforeTv?: boolean;
  /** TV refinement: weight λ of the total variation against the data term (larger:
   * smoother) ((0, 1000]; default 0.25). CLI: `--lambda`. */
  lambda?: number;
  /** TV refinement: most PPXA iterations per tile (1…100000; default 300). CLI:
   * `--tv-iterations`. */
  iterations?: number;
  /** TV refinement: stopping tolerance, the RMS change of the refined disparity over one
   * iteration in px (0: run every iteration; smaller: closer to the exact minimiser) (≥
   * 0; default 0.0007). CLI: `--tv-tolerance`. */
  tvTolerance?: number;
  /** TV refinement: side of a tile's core in px (one part of each TV step) (8…4096;
   * default 256). CLI: `--tv-tile`. */
  tvTile?: number;
  /** TV refinement: pixels of context around each tile (0…256; default 16). CLI:
   * `--tv-halo`. */
  tvHalo?: number;
  /** TV refinement: outer sweeps: solve every tile again from the previous pass's dual
   * with the flows across its border held at the neighbours' values, so tiles agree where
   * they meet (0…8; default 0). CLI: `--tv-sweeps`. */
  tvSweeps?: number;
}
