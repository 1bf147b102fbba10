// An estimator over only the views its stages read (`readViews`,
// `Estimator.fromReadViews`): what the page hands each worker. Same bits as an estimator
// over every view, from a packed copy or from a SharedArrayBuffer holding the whole
// light field, before and after alignment; errors that say what to change.
import { test } from "node:test";
import assert from "node:assert/strict";
import lf from "./pkg.mjs";

const same = (a, b) => a.length === b.length && a.every((v, i) => Object.is(v, b[i]));

/** `read`'s views of `views`, packed. */
function pack(views, read, len) {
  const out = new views.constructor(read.length * len);
  read.forEach((v, i) => out.set(views.subarray(v * len, (v + 1) * len), i * len));
  return out;
}

/** One subarray per view of packed `bytes`. */
const cut = (bytes, len) => Array.from({ length: bytes.length / len }, (_, i) => bytes.subarray(i * len, (i + 1) * len));

test("the stages read the centre row and column, and the refinement's views", () => {
  const cross = (rows, cols) => {
    const [r0, c0] = [(rows - 1) >> 1, (cols - 1) >> 1];
    return Array.from({ length: rows * cols }, (_, v) => v).filter((v) => Math.floor(v / cols) === r0 || v % cols === c0);
  };
  const shape = { rows: 9, cols: 9, width: 64, height: 48, channels: 3 };
  assert.deepEqual(Array.from(lf.readViews(shape)), cross(9, 9));
  assert.equal(lf.readViews(shape).length, 17);
  assert.deepEqual(Array.from(lf.readViews(shape, { stage: "epi", align: "off" })), cross(9, 9));
  assert.deepEqual(Array.from(lf.readViews({ ...shape, rows: 5, cols: 7 })), cross(5, 7));
  assert.throws(() => lf.readViews({ ...shape, rows: 0 }), /grid/);
});

test("an estimator over the read views alone gives the bits of one over every view", () => {
  const spec = { scene: "occlusion", rows: 7, cols: 7, width: 80, height: 64, seed: 5 };
  const shape = { rows: 7, cols: 7, width: 80, height: 64, channels: 3 };
  const len = 80 * 64 * 3;
  const { views } = lf.synthesize(spec);
  for (const params of [{ align: "off" }, { align: "off", refineBandRows: 24, tvTile: 32, geofill: true }, { align: "off", stage: "epi" }]) {
    const read = Array.from(lf.readViews(shape, params));
    const whole = new lf.Estimator(views, shape, params).estimate();
    // Packed copy (the transfer path) and subarrays of a SharedArrayBuffer with every
    // view (the shared path).
    const packed = lf.Estimator.fromReadViews(cut(pack(views, read, len), len), shape, params);
    const sab = new Uint8Array(new SharedArrayBuffer(views.length));
    sab.set(views);
    const shared = lf.Estimator.fromReadViews(read.map((v) => sab.subarray(v * len, (v + 1) * len)), shape, params);
    for (const e of [packed, shared]) {
      const r = e.estimate();
      assert.ok(same(r.disparity, whole.disparity) && same(r.confidence, whole.confidence) && same(r.residuals, whole.residuals), JSON.stringify(params));
      // What it hands on is what it was given.
      assert.ok(same(e.readViews, pack(views, read, len)));
    }
    // The other views really are absent: zero in the estimator's light field.
    const held = shared.views;
    const unread = Array.from({ length: 49 }, (_, v) => v).filter((v) => !read.includes(v));
    assert.equal(unread.length, 49 - 13);
    assert.ok(unread.every((v) => held.subarray(v * len, (v + 1) * len).every((b) => b === 0)));
  }
});

test("the aligner's rectified read views give the aligned estimate", () => {
  const shape = { rows: 5, cols: 5, width: 96, height: 96, channels: 3 };
  const len = 96 * 96 * 3;
  const bent = lf.synthesize({ scene: "mixed", rows: 5, cols: 5, width: 96, height: 96, seed: 4, misalign: true });
  const params = { align: "on", iterations: 60 };
  const aligner = new lf.Estimator(bent.views, shape, params);
  assert.equal(aligner.align().skipped, false);
  const rectified = aligner.readViews;
  const read = Array.from(lf.readViews(shape, params));
  assert.ok(same(rectified, pack(aligner.views, read, len)));
  assert.ok(!same(rectified, pack(bent.views, read, len)), "the read views were warped");
  // Told that the views were warped (`resampled`), the refinement compares them as the
  // aligner's own pipeline does (its sampling slack); not told, it differs.
  const loaded = lf.Estimator.fromReadViews(cut(rectified, len), shape, { ...params, align: "off", resampled: true }).estimate();
  const serial = new lf.Estimator(bent.views, shape, params).estimate();
  assert.ok(same(loaded.disparity, serial.disparity) && same(loaded.confidence, serial.confidence));
  const untold = lf.Estimator.fromReadViews(cut(rectified, len), shape, { ...params, align: "off" }).estimate();
  assert.ok(!same(untold.disparity, serial.disparity));
});

test("setParams runs new parameters over the views held, with the bits of a new estimator", () => {
  const spec = { scene: "occlusion", rows: 7, cols: 7, width: 80, height: 64, seed: 5 };
  const shape = { rows: 7, cols: 7, width: 80, height: 64, channels: 3 };
  const len = 80 * 64 * 3;
  const { views } = lf.synthesize(spec);
  const first = { align: "off" };
  const read = Array.from(lf.readViews(shape, first));
  const held = lf.Estimator.fromReadViews(read.map((v) => views.subarray(v * len, (v + 1) * len)), shape, first);
  held.estimate();
  for (const next of [{ align: "off", refineBandRows: 24, tvTile: 32, medianBeforeTv: false, iterations: 80 }, { align: "off", lambda: 1, median: false }]) {
    held.setParams(next);
    const r = held.estimate();
    const fresh = new lf.Estimator(views, shape, next).estimate();
    assert.ok(same(r.disparity, fresh.disparity) && same(r.confidence, fresh.confidence) && same(r.residuals, fresh.residuals), JSON.stringify(next));
  }
  // The inputs of setInputs are forgotten (they belonged to the old parameters).
  held.setInputs(1, { range: new Float32Array([-1, 1]) });
  held.setParams(first);
  assert.throws(() => held.runPart(1, 1, 0), /range ran before it/);
  assert.throws(() => held.setParams({ align: "auto" }), /pass params\.align "off"/);
  assert.throws(() => held.setParams({ align: "off", lambda: -1 }), /lambda|λ/i);
  // An aligned estimator keeps its rectified views: no second alignment.
  const small = { rows: 5, cols: 5, width: 96, height: 96, channels: 3 };
  const bent = lf.synthesize({ scene: "mixed", ...small, seed: 4, misalign: true });
  const aligner = new lf.Estimator(bent.views, small, { align: "on", iterations: 60 });
  assert.equal(aligner.align().skipped, false);
  aligner.setParams({ align: "off", iterations: 60, lambda: 1 });
  const r = aligner.estimate();
  assert.equal(r.align.skipped, false, "the alignment's report is kept");
  assert.ok(!r.timings.some((t) => t.stage === "align"), "and it did not run again");
  const serial = new lf.Estimator(bent.views, small, { align: "on", iterations: 60, lambda: 1 }).estimate();
  assert.ok(same(r.disparity, serial.disparity) && same(r.confidence, serial.confidence));
});

test("fromReadViews rejects what it cannot hold, saying what to change", () => {
  const shape = { rows: 3, cols: 3, width: 16, height: 16, channels: 1 };
  const view = () => new Uint8Array(16 * 16);
  const five = Array.from({ length: 5 }, view);
  assert.throws(() => lf.Estimator.fromReadViews(five, shape), /pass params\.align "off"/);
  assert.throws(() => lf.Estimator.fromReadViews(five.slice(1), shape, { align: "off" }), /views has 4 entries but the stages read 5 views/);
  const short = [...five.slice(1), new Uint8Array(16 * 16 - 1)];
  assert.throws(() => lf.Estimator.fromReadViews(short, shape, { align: "off" }), /views\[4\] \(grid view 7\) must be a Uint8Array of 256 bytes .* not 255 bytes/);
  assert.throws(() => lf.Estimator.fromReadViews([...five.slice(1), [1, 2]], shape, { align: "off" }), /views\[4\].*not another type/);
  assert.ok(lf.Estimator.fromReadViews([...five.slice(1), new Uint8ClampedArray(256)], shape, { align: "off" }));
});
