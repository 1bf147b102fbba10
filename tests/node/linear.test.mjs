// A linear array (one row or one column of cameras) through the wasm package: the
// Estimator takes a 1×N or N×1 shape, runs the one EPI direction it has (the EPI start,
// `initial: "epi"`) and every later stage, scores near the CLI's rail, and the schedule by
// parts equals estimate(); the default start, the plane sweep, estimates a rail too.
import { test } from "node:test";
import assert from "node:assert/strict";
import lf from "./pkg.mjs";

const SIZE = 96;
const bytes = (a) => new Uint8Array(a.buffer, a.byteOffset, a.byteLength);

for (const [rows, cols, present, absent] of [
  [1, 9, "epi horizontal", "epi vertical"],
  [9, 1, "epi vertical", "epi horizontal"],
]) {
  test(`a ${rows}x${cols} rail estimates from its one direction, by parts as serially`, () => {
    const scene = lf.synthesize({ scene: "planes", rows, cols, width: SIZE, height: SIZE, seed: 3 });
    const shape = { rows, cols, width: SIZE, height: SIZE, channels: 3 };
    const serial = new lf.Estimator(scene.views, shape, { align: "off", initial: "epi" }).estimate();
    const stages = serial.timings.map((t) => t.stage);
    assert.ok(stages.includes(present) && !stages.includes(absent), stages.join(", "));
    const scores = lf.evaluate(serial.disparity, scene.groundTruth, SIZE, SIZE);
    // Measured: 1×9 2.23 %, 9×1 2.27 % (the 9×9 grid of the scene at this size 1.86 %);
    // an all-zero map scores 100 %.
    assert.ok(scores.badpix007 < 3, `BadPix(0.07) ${scores.badpix007}`);
    assert.equal(scores.invalidPct, 0);

    const sweep = new lf.Estimator(scene.views, shape, { align: "off" }).estimate();
    assert.ok(sweep.timings.some((t) => t.stage === "sweep"));
    const sweepScores = lf.evaluate(sweep.disparity, scene.groundTruth, SIZE, SIZE);
    assert.ok(sweepScores.badpix007 < 10, `plane sweep: BadPix(0.07) ${sweepScores.badpix007}`);

    const params = { refineBandRows: 24, tvTile: 40, initial: "epi" };
    const reference = new lf.Estimator(scene.views, shape, { ...params, align: "off" }).estimate();
    const run = new lf.Run(shape, params, 2);
    const workers = [0, 1].map(() => new lf.Estimator(scene.views, shape, { ...params, align: "off" }));
    try {
      const steps = [];
      for (let step = 0; step < run.steps; step++) {
        steps.push(run.stage(step));
        const inputs = run.inputs(step);
        for (const e of workers) e.setInputs(2, inputs);
        const parts = run.parts(step);
        const outputs = new Array(parts);
        for (let index = parts - 1; index >= 0; index--) outputs[index] = workers[index % 2].runPart(2, step, index);
        outputs.forEach((output, index) => run.place(step, index, output));
        run.finish(step);
      }
      assert.ok(!steps.includes(absent), steps.join(", "));
      assert.deepEqual(bytes(run.disparity), bytes(reference.disparity));
      assert.deepEqual(bytes(run.confidence), bytes(reference.confidence));
    } finally {
      run.free();
      for (const e of workers) e.free();
    }
  });
}

test("a rail of two views is refused with the sizes that work", () => {
  const scene = lf.synthesize({ scene: "planes", rows: 1, cols: 3, width: SIZE, height: SIZE, seed: 3 });
  const shape = { rows: 1, cols: 2, width: SIZE, height: SIZE, channels: 3 };
  assert.throws(() => new lf.Estimator(scene.views, shape), /1x2 view grid .*\(1x3 to 1x17/);
  assert.throws(() => lf.synthesize({ scene: "planes", rows: 2, cols: 1, width: SIZE, height: SIZE }), /2x1 view grid/);
});
