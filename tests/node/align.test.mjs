// Alignment through the wasm package: `params.align` off/on/auto on a synthetic scene
// rendered misaligned (`spec.misalign`), the rectified views handed to the band path,
// and errors for bad values and textureless views.
import { test } from "node:test";
import assert from "node:assert/strict";
import lf from "./pkg.mjs";

const SIZE = 128;
const shape = { rows: 5, cols: 5, width: SIZE, height: SIZE, channels: 3 };
const spec = { scene: "mixed", rows: 5, cols: 5, width: SIZE, height: SIZE, seed: 4 };
const ideal = lf.synthesize(spec);
const bent = lf.synthesize({ ...spec, misalign: true });

// The EPI stage alone (the EPI start): its error on unaligned views is what the bounds
// below were set on.
const mse = (views, align) => {
  const result = new lf.Estimator(views, shape, { stage: "epi", initial: "epi", align }).estimate();
  return { result, scores: lf.evaluate(result.disparity, ideal.groundTruth, SIZE, SIZE) };
};

test("a misaligned scene aligns and scores close to the rectified one", () => {
  assert.notDeepEqual(bent.views, ideal.views);
  assert.deepEqual(bent.groundTruth, ideal.groundTruth);
  const off = mse(bent.views, "off");
  const on = mse(bent.views, "on");
  const auto = mse(bent.views, "auto");
  const rectified = mse(ideal.views, "auto");
  console.log(`MSE×100: off ${off.scores.mse100}, on ${on.scores.mse100}, auto ${auto.scores.mse100}, rectified ${rectified.scores.mse100}`);
  assert.equal(off.result.align, undefined);
  assert.equal(on.result.align.skipped, false);
  assert.ok(on.result.align.rms < 0.1 && on.result.align.identityRms > 0.5, `${on.result.align.identityRms} → ${on.result.align.rms}`);
  assert.equal(on.result.align.homographies.length, 25 * 9);
  assert.ok(on.result.timings.some((t) => t.stage === "warp"));
  // Stated bound (as the CLI test): alignment removes almost all of the misalignment's
  // error; what is left includes the disparity offset no image can observe.
  assert.ok(off.scores.mse100 > 100, `off ${off.scores.mse100}`);
  assert.ok(on.scores.mse100 < 2 * rectified.scores.mse100 + 5 && on.scores.mse100 < 0.05 * off.scores.mse100, `on ${on.scores.mse100}`);
  assert.equal(auto.result.align.skipped, false);
  assert.deepEqual(auto.result.disparity, on.result.disparity);
  // Auto leaves the rectified scene alone: bit-identical to off.
  assert.equal(rectified.result.align.skipped, true);
  const plain = new lf.Estimator(ideal.views, shape, { stage: "epi", initial: "epi", align: "off" }).estimate();
  assert.deepEqual(rectified.result.disparity, plain.disparity);
});

test("align() hands the rectified views to the parts of the schedule, which then match estimate()", () => {
  const params = { stage: "epi", align: "on" };
  const aligner = new lf.Estimator(bent.views, shape, params);
  const report = aligner.align();
  assert.equal(report.skipped, false);
  assert.equal(aligner.align().rms, report.rms, "align() runs once");
  // Warped views stay f32, as the CLI keeps them (never rounded to 8 bits).
  const rectified = aligner.views;
  assert.ok(rectified instanceof Float32Array, rectified.constructor.name);
  assert.equal(rectified.length, bent.views.length);
  assert.ok(rectified.some((v) => v !== Math.round(v * 255) / 255), "the warped views are 8-bit levels");
  const serial = new lf.Estimator(bent.views, shape, params).estimate().disparity;
  const worker = new lf.Estimator(rectified, shape, { stage: "epi", align: "off", resampled: true });
  const run = new lf.Run(shape, { stage: "epi", resampled: true }, 1);
  for (let step = 0; step < run.steps; step++) {
    worker.setInputs(1, run.inputs(step));
    for (let index = 0; index < run.parts(step); index++) run.place(step, index, worker.runPart(1, step, index));
    run.finish(step);
  }
  const disparity = run.disparity;
  assert.ok(disparity.every((d, i) => Object.is(d, serial[i])));
  run.free();
  worker.free();
});

test("fromReadViews takes the aligner's f32 read views and gives estimate()'s map; views of two types are an Error", () => {
  const params = { align: "on" };
  const aligner = new lf.Estimator(bent.views, shape, params);
  aligner.align();
  const packed = aligner.readViews;
  assert.ok(packed instanceof Float32Array, packed.constructor.name);
  const len = SIZE * SIZE * 3;
  const read = lf.readViews(shape, { align: "off" });
  assert.equal(packed.length, read.length * len);
  const views = Array.from(read, (_, i) => packed.subarray(i * len, (i + 1) * len));
  const worker = lf.Estimator.fromReadViews(views, shape, { align: "off", resampled: true });
  const serial = new lf.Estimator(bent.views, shape, params).estimate().disparity;
  const disparity = worker.estimate().disparity;
  assert.ok(disparity.every((d, i) => Object.is(d, serial[i])));
  worker.free();
  const mixed = [...views.slice(0, -1), new Uint8Array(len)];
  assert.throws(() => lf.Estimator.fromReadViews(mixed, shape, { align: "off" }), new RegExp(`views\\[${read.length - 1}\\] .* not another type \\(the first view is a Float32Array\\)`));
  aligner.free();
});

test("bad align values and textureless views are Errors that say what to change", () => {
  assert.throws(() => new lf.Estimator(ideal.views, shape, { align: "sometimes" }), /params\.align `sometimes` is unknown: use "off", "on" or "auto"/);
  const flat = new Uint8Array(ideal.views.length).fill(128);
  assert.throws(() => new lf.Estimator(flat, shape, { stage: "epi", align: "on" }).estimate(), /alignment of view 12 failed/);
  const auto = new lf.Estimator(flat, shape, { stage: "epi", align: "auto" }).estimate();
  assert.equal(auto.align.skipped, true);
  assert.match(auto.align.warning, /alignment of view 12 failed/);
});
