// The wasm package from Node: accuracy on a synthetic scene, the schedule by parts equal
// to the serial pipeline, progress and cancel, and errors that say what to change.
import { test } from "node:test";
import assert from "node:assert/strict";
import { readFileSync } from "node:fs";
import { join } from "node:path";
import lf, { root } from "./pkg.mjs";

const SIZE = 128;
const spec = { scene: "planes", rows: 9, cols: 9, width: SIZE, height: SIZE, seed: 3 };
const scene = lf.synthesize(spec);
const shape = { rows: 9, cols: 9, width: SIZE, height: SIZE, channels: 3 };

test("the EPI stage alone is within its accuracy bound", () => {
  const result = new lf.Estimator(scene.views, shape, { stage: "epi", initial: "epi" }).estimate();
  assert.equal(result.disparity.length, SIZE * SIZE);
  assert.equal(result.confidence.length, SIZE * SIZE);
  const scores = lf.evaluate(result.disparity, scene.groundTruth, SIZE, SIZE);
  // Measured (EPI stage only): BadPix(0.07) 10.2 %, MSE×100 32.9 (a few occlusion-edge
  // outliers dominate it), Q25 0. An all-zero map scores 100 %, 187, 150.
  // The bounds leave room for parameter tuning, not for a broken estimate.
  assert.ok(scores.badpix007 < 15, `BadPix(0.07) ${scores.badpix007}`);
  assert.ok(scores.mse100 < 60, `MSE×100 ${scores.mse100}`);
  assert.ok(scores.q25 < 1, `Q25 ${scores.q25}`);
  assert.equal(scores.invalidPct, 0);
  for (const c of result.confidence) assert.ok(c >= 0 && c <= 1);
  // Alignment (auto by default) checks the array, finds it rectified and skips the warp.
  assert.deepEqual(result.timings.map((t) => t.stage), ["align", ...lf.stageNames().filter((s) => s.startsWith("epi"))]);
  // The default start, the plane sweep, in place of the two EPI directions.
  const sweep = new lf.Estimator(scene.views, shape, { stage: "epi" }).estimate();
  assert.deepEqual(sweep.timings.map((t) => t.stage), ["align", "epi range", "sweep"]);
  assert.equal(result.align.skipped, true);
  for (const t of result.timings) assert.ok(t.ms >= 0);
  assert.equal(result.residuals.length, 0, "no TV stage with stage: \"epi\"");
});

test("the full pipeline (plane sweep → refine → refill → median → TV) beats the EPI stage alone", () => {
  const epi = new lf.Estimator(scene.views, shape, { stage: "epi", initial: "epi" }).estimate();
  const full = new lf.Estimator(scene.views, shape).estimate();
  const epiScores = lf.evaluate(epi.disparity, scene.groundTruth, SIZE, SIZE);
  const scores = lf.evaluate(full.disparity, scene.groundTruth, SIZE, SIZE);
  // Loose bounds: the full pipeline scores a few per cent BadPix(0.07) here, and must
  // beat the EPI stage alone.
  assert.ok(scores.badpix007 < 5, `BadPix(0.07) ${scores.badpix007}`);
  assert.ok(scores.mse100 < 15, `MSE×100 ${scores.mse100}`);
  assert.ok(scores.badpix007 <= epiScores.badpix007, `BadPix(0.07) ${scores.badpix007} vs EPI ${epiScores.badpix007}`);
  assert.ok(scores.mse100 <= epiScores.mse100, `MSE×100 ${scores.mse100} vs EPI ${epiScores.mse100}`);
  assert.equal(scores.invalidPct, 0);
  for (const c of full.confidence) assert.ok(c >= 0 && c <= 1);
  // Every stage but the warp (the array is rectified) and the two EPI directions (the
  // plane sweep runs in their place).
  assert.deepEqual(full.timings.map((t) => t.stage), defaultStages());
  for (const t of full.timings) assert.ok(t.ms >= 0);
  const r = full.residuals;
  assert.ok(r.length > 1 && r.length <= 300, `${r.length} TV iterations`);
  for (const v of r) assert.ok(Number.isFinite(v) && v >= 0);
  // TV's PPXA copies start at their fixed point for the start dual, so the curve
  // starts low (measured 0.0115 → 0.0031). It must still fall, and stop by the rule.
  assert.ok(r[r.length - 1] < r[0] / 2, `residual ${r[0]} → ${r[r.length - 1]}`);
  assert.ok(r.length < 300, `TV ran all ${r.length} iterations: the stopping rule never held`);
  // Fewer iterations stop the curve there; refine: false skips the refine stage.
  const short = new lf.Estimator(scene.views, shape, { iterations: 5, refine: false, lambda: 1 }).estimate();
  assert.ok(short.residuals.length <= 5 && short.residuals.length > 0);
  assert.ok(!short.timings.some((t) => t.stage === "refine"));
});

/** Runs every step of the core's schedule by parts as web/engine.js does: a `Run` on
 * "the page" places the parts, `workers` estimators run them (each step's inputs handed
 * to every one), parts dispatched in reverse order and placed in index order. */
function byParts(params, workers) {
  const run = new lf.Run(shape, params, workers);
  const estimators = Array.from({ length: workers }, () => new lf.Estimator(scene.views, shape, { ...params, align: "off" }));
  const stages = [];
  try {
    for (let step = 0; step < run.steps; step++) {
      stages.push(run.stage(step));
      const inputs = run.inputs(step);
      for (const e of estimators) e.setInputs(workers, inputs);
      const parts = run.parts(step);
      const outputs = new Array(parts);
      for (let index = parts - 1; index >= 0; index--) {
        outputs[index] = estimators[index % workers].runPart(workers, step, index);
      }
      outputs.forEach((output, index) => run.place(step, index, output));
      run.finish(step);
    }
    return { disparity: run.disparity, confidence: run.confidence, residuals: run.residuals, range: run.range, stages };
  } finally {
    run.free();
    for (const e of estimators) e.free();
  }
}

const bytes = (a) => new Uint8Array(a.buffer, a.byteOffset, a.byteLength);

/** The stages a default run reports on a rectified array: all but the warp and the EPI
 * directions, which the plane sweep replaces. */
function defaultStages() {
  return lf.stageNames().filter((s) => !["warp", "epi horizontal", "epi vertical"].includes(s));
}

for (const [name, params] of [
  ["the EPI stage, weighted fusion", { fusion: "weighted", stage: "epi", initial: "epi" }],
  ["the plane sweep alone", { stage: "epi" }],
  ["the EPI start", { initial: "epi", refineBandRows: 24, tvTile: 40 }],
  ["defaults (one band, one tile)", {}],
  ["small bands and tiles", { refineBandRows: 24, tvTile: 40 }],
  ["median after TV", { refineBandRows: 50, tvTile: 48, medianBeforeTv: false, iterations: 60 }],
  ["no refine, no median", { refine: false, median: false, tvTile: 64 }],
]) {
  test(`the schedule by parts on 1, 2 and 3 workers is bit-identical to estimate(): ${name}`, () => {
    const serial = new lf.Estimator(scene.views, shape, { ...params, align: "off" }).estimate();
    for (const workers of [1, 2, 3]) {
      const parts = byParts(params, workers);
      assert.deepEqual(bytes(parts.disparity), bytes(serial.disparity), `disparity, ${workers} workers`);
      assert.deepEqual(bytes(parts.confidence), bytes(serial.confidence), `confidence, ${workers} workers`);
      assert.deepEqual(bytes(parts.residuals), bytes(serial.residuals), `residuals, ${workers} workers`);
      assert.deepEqual([...new Set(parts.stages)], serial.timings.map((t) => t.stage));
      assert.equal(parts.range.length, 2);
    }
    if (params.stage !== "epi") assert.ok(serial.residuals.length > 0, "TV ran");
  });
}

test("a run lists its steps and parts, and bad requests say what to change", () => {
  const run = new lf.Run(shape, { refineBandRows: 24, tvTile: 40 }, 2);
  const stages = Array.from({ length: run.steps }, (_, k) => run.stage(k));
  assert.deepEqual(stages, ["epi range", "sweep", "refine", "geofill", "median", "tv"]);
  assert.equal(run.parts(stages.indexOf("refine")), Math.ceil(SIZE / 24));
  assert.equal(run.parts(stages.indexOf("tv")), Math.ceil(SIZE / 40) ** 2);
  assert.equal(run.parts(0), 1);
  assert.throws(() => run.stage(run.steps), /step 6 does not exist: the run has 6 steps/);
  assert.throws(() => run.place(0, 0, new Float32Array(3)), /part 0 has 3 values but its step's parts have 2/);
  const estimator = new lf.Estimator(scene.views, shape, { refineBandRows: 24, tvTile: 40, align: "off" });
  // The refinement needs the range, which only the first step gives.
  estimator.setInputs(2, run.inputs(0));
  assert.throws(() => estimator.runPart(2, stages.indexOf("refine"), 0), /range ran before it: run the steps in order/);
  assert.throws(() => estimator.runPart(2, 0, 1), /part of a step/);
  assert.throws(() => estimator.setInputs(2, { disparity: new Float32Array(5) }), /map of the run/);
  assert.throws(() => estimator.setInputs(2, { range: [1] }), /\[min, max\]/);
  const sweeps = new lf.Run(shape, { median: false, refine: false }, 1);
  assert.deepEqual(Array.from({ length: sweeps.steps }, (_, k) => sweeps.stage(k)), ["epi range", "sweep", "geofill", "tv"]);
  assert.throws(() => new lf.Estimator(scene.views, shape, { tvTile: 4 }), /`tvTile` must be in 8\.\.=4096/);
  assert.throws(() => new lf.Estimator(scene.views, shape, { preset: "quick" }), /params.preset `quick` is unknown: use one of "default", "fast"/);
  run.free();
  sweeps.free();
  estimator.free();
});

test("params.preset: \"default\" is the defaults, \"fast\" sweeps on luminance and changes the later stages, other keys override it", () => {
  const bytes = (params) => new Uint8Array(new lf.Estimator(scene.views, shape, params).estimate().disparity.buffer);
  const defaults = bytes({});
  assert.deepEqual(bytes({ preset: "default" }), defaults);
  const fast = bytes({ preset: "fast" });
  assert.notDeepEqual(fast, defaults);
  // The fast preset's start is the plane sweep on luminance; its later stages differ too.
  assert.deepEqual(bytes({ preset: "fast", stage: "epi" }), bytes({ stage: "epi", sweepColor: "gray" }));
  assert.notDeepEqual(bytes({ preset: "fast", stage: "epi" }), bytes({ stage: "epi" }));
  assert.notDeepEqual(fast, bytes({ sweepColor: "gray" }));
  assert.deepEqual(fast, bytes({ sweepColor: "gray", refineIterations: 1, medianPasses: 3 }));
  // An explicit key wins over the preset: the fast preset without its median.
  const stages = (params) => {
    const run = new lf.Run(shape, params, 1);
    const names = Array.from({ length: run.steps }, (_, k) => run.stage(k));
    run.free();
    return names;
  };
  assert.ok(stages({ preset: "fast" }).includes("median"));
  assert.ok(!stages({ preset: "fast", median: false }).includes("median"));
});

test("Uint8ClampedArray views give the same result as Uint8Array", () => {
  const a = new lf.Estimator(scene.views, shape, { range: [-2, 2] }).estimate();
  const clamped = new Uint8ClampedArray(scene.views);
  const b = new lf.Estimator(clamped, shape, { range: [-2, 2] }).estimate();
  assert.deepEqual(a.disparity, b.disparity);
});

test("progress reaches the end of every stage, and returning false cancels", () => {
  const estimator = new lf.Estimator(scene.views, shape);
  const last = new Map();
  estimator.estimate((p) => {
    assert.ok(p.done <= p.total);
    last.set(p.stage, p);
  });
  // Every stage but the warp (alignment, auto, finds this array rectified) and the EPI
  // directions (the plane sweep runs in their place).
  for (const stage of defaultStages()) {
    const p = last.get(stage);
    assert.ok(p, `no report for ${stage}`);
    assert.equal(p.done, p.total, stage);
  }
  let calls = 0;
  assert.throws(() => estimator.estimate(() => (++calls < 3 ? undefined : false)), {
    name: "Error",
    message: /cancelled/,
  });
  assert.equal(calls, 3);
  assert.throws(() => estimator.estimate(() => { throw new RangeError("from the callback"); }), RangeError);
});

test("bad input throws an Error whose message says what to change", () => {
  const cases = [
    [() => new lf.Estimator(scene.views, { ...shape, rows: 2 }), /2x9 view grid .* between 3x3 and 17x17/],
    [() => new lf.Estimator(scene.views.subarray(1), shape), /holds \d+ elements but its layout needs \d+/],
    [() => new lf.Estimator(scene.views, { ...shape, channels: 2 }), /use 1 \(gray\), 3 \(RGB\) or 4/],
    [() => new lf.Estimator(scene.views, { ...shape, width: 8, height: 8 }), /at least 16x16/],
    [() => new lf.Estimator([1, 2, 3], shape), /views must be a Uint8Array, Uint8ClampedArray or Float32Array/],
    [() => new lf.Estimator(new Float32Array(10), shape), /holds 10 elements but its layout needs \d+/],
    [() => new lf.Estimator(scene.views, { rows: 9, cols: 9 }), /shape.width is missing/],
    [() => new lf.Estimator(scene.views, shape, { lamda: 2 }), /unknown key `lamda`.*innerSigma/],
    [() => new lf.Estimator(scene.views, shape, { stage: "tv" }), /"full" or "epi"/],
    [() => new lf.Estimator(scene.views, shape, { lambda: -1 }), /parameter `lambda` must be in \(0, 1000\]/],
    [() => new lf.Estimator(scene.views, shape, { medianPasses: 9 }), /parameter `medianPasses` must be in 1\.\.=4/],
    [() => new lf.Estimator(scene.views, shape, { alignInterp: "cubic" }), /params\.alignInterp `cubic` is unknown: use "bilinear", "sharpened-bilinear" or "catmull-rom"/],
    [() => new lf.Estimator(scene.views, shape, { iterations: 0 }), /parameter `iterations` must be in 1\.\.=100000/],
    [() => new lf.Estimator(scene.views, shape, { innerSigma: 9 }), /parameter `innerSigma` must be between 0 and 4/],
    // NaN (an empty number field of a form) reaches the core's check of the parameter.
    [() => new lf.Estimator(scene.views, shape, { sweepTrust: NaN }), /^parameter `sweepTrust` must be in \[0, 1\] \(0: off\)$/],
    [() => lf.readViews(shape, { sweepTrust: 2 }), /^parameter `sweepTrust` must be in \[0, 1\] \(0: off\)$/],
    [() => new lf.Estimator(scene.views, shape, { lambda: Infinity }), /params\.lambda must be a finite number/],
    [() => new lf.Estimator(scene.views, shape, { range: [3, -3] }), /parameter `range` must be finite with min <= max/],
    [() => new lf.Estimator(scene.views, shape, { range: "wide" }), /"auto" or \[min, max\]/],
    [() => new lf.Estimator(scene.views, shape, { fusion: "max" }), /"coherence" or "weighted"/],
    [() => new lf.Estimator(scene.views, shape).estimate(42), /onProgress must be a function/],
    [() => new lf.Estimator(scene.views, shape).runPart(1, 99, 0), /step 99 does not exist/],
    [() => new lf.Run(shape, { lamda: 2 }, 1), /unknown key `lamda`/],
    [() => lf.synthesize({ ...spec, scene: "moon" }), /unknown: use one of planes, slanted/],
    [() => lf.synthesize({ ...spec, disparityMax: 9 }), /within -4..4/],
    [() => lf.evaluate(new Float32Array(5), scene.groundTruth, SIZE, SIZE), /estimate has 5 elements but must have exactly 16384/],
    [() => lf.evaluate(scene.groundTruth, scene.groundTruth, SIZE, SIZE, { border: SIZE / 2 }), /border/],
  ];
  for (const [run, message] of cases) {
    assert.throws(run, (e) => {
      assert.ok(e instanceof Error, `not an Error: ${e}`);
      assert.match(e.message, message);
      return true;
    });
  }
});

test("synthetic views render alike whole and one by one; metrics of the truth are perfect", () => {
  const small = { scene: "mixed", rows: 5, cols: 7, width: 32, height: 24, channels: 1, seed: 9 };
  const whole = lf.synthesize(small);
  assert.equal(whole.views.length, 5 * 7 * 32 * 24);
  const viewLen = 32 * 24;
  for (const [r, c] of [[0, 0], [2, 3], [4, 6]]) {
    const one = lf.renderView(small, r, c);
    assert.deepEqual(one, whole.views.subarray((r * 7 + c) * viewLen, (r * 7 + c + 1) * viewLen));
  }
  assert.deepEqual(lf.renderGroundTruth(small), whole.groundTruth);
  const perfect = lf.evaluate(whole.groundTruth, whole.groundTruth, 32, 24, { border: 2 });
  assert.equal(perfect.badpix007, 0);
  assert.equal(perfect.mse100, 0);
  assert.deepEqual(lf.sceneNames(), ["planes", "slanted", "spheres", "occlusion", "thin", "low-texture", "mixed"]);
});

test("every key of the generated EstimateParams type is accepted at its default, and changes nothing there", () => {
  // The keys, types and defaults as wasm/src/estimate_params.d.ts (generated from the
  // core's tunable table) declares them.
  const declaration = readFileSync(join(root, "wasm/src/estimate_params.d.ts"), "utf8");
  const entries = [...declaration.matchAll(/\/\*\*((?:(?!\*\/)[\s\S])*)\*\/\s*(\w+)\?: ([^;]+);/g)];
  assert.ok(entries.length >= 40, `${entries.length} keys`);
  const defaults = {};
  for (const [, doc, key, type] of entries) {
    const text = doc.replace(/\s*\*\s*/g, " ");
    const found = /\(default ("[^"]+"|true|false|[-0-9.e]+)\)/.exec(text) ?? /default ("[^"]+"|true|false|[-0-9.e]+)\)/.exec(text);
    if (key === "preset" || key === "stage" || key === "resampled") continue;
    assert.ok(found, `no default for ${key} in: ${text}`);
    const value = JSON.parse(found[1]);
    if (type === "number") assert.equal(typeof value, "number", key);
    if (type === "boolean") assert.equal(typeof value, "boolean", key);
    defaults[key] = value;
  }
  // One key at a time is accepted; all of them at once give the defaults' map.
  const small = lf.synthesize({ ...spec, width: 48, height: 48 });
  const smallShape = { ...shape, width: 48, height: 48 };
  for (const [key, value] of Object.entries(defaults)) {
    assert.doesNotThrow(() => new lf.Estimator(small.views, smallShape, { [key]: value }), key);
  }
  const bytes = (params) => new Uint8Array(new lf.Estimator(small.views, smallShape, params).estimate().disparity.buffer);
  assert.deepEqual(bytes(defaults), bytes({}));
  // An unknown key is refused, naming it and listing the known ones.
  assert.throws(() => new lf.Estimator(small.views, smallShape, { tvSweep: 1 }), /unknown key `tvSweep`.*tvSweeps/);
});
