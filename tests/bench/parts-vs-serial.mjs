// The core's schedule by parts (every step's parts one after the other on one thread,
// placed by a `Run`, as the page's workers run them) against the serial
// `Estimator.estimate()` in Node: what running by parts costs of its own (the inputs
// copied per step, the outputs placed).
//   node tests/bench/parts-vs-serial.mjs [scene] [size] [grid] [rounds] [workers]
// Timing only (not a test); prints one JSON line per round and checks the two maps agree.
import lf from "../node/pkg.mjs";

const [scene = "planes", size = "512", grid = "9", rounds = "3", workers = "2"] = process.argv.slice(2);
const n = Number(size), g = Number(grid), w = Number(workers);
const shape = { rows: g, cols: g, width: n, height: n, channels: 3 };
const views = lf.synthesize({ scene, rows: g, cols: g, width: n, height: n, seed: 1 }).views;
const e = new lf.Estimator(views, shape, { align: "off" });

function byParts() {
  const run = new lf.Run(shape, { align: "off" }, w);
  try {
    for (let step = 0; step < run.steps; step++) {
      e.setInputs(w, run.inputs(step));
      for (let index = 0; index < run.parts(step); index++) run.place(step, index, e.runPart(w, step, index));
      run.finish(step);
    }
    return run.disparity;
  } finally {
    run.free();
  }
}

for (let round = 0; round < Number(rounds); round++) {
  let t = performance.now();
  const parts = byParts();
  const partsMs = performance.now() - t;
  t = performance.now();
  const serial = e.estimate().disparity;
  const serialMs = performance.now() - t;
  const same = parts.length === serial.length && parts.every((v, i) => Object.is(v, serial[i]));
  console.log(JSON.stringify({ round, bit_identical: same, parts_ms: Math.round(partsMs), serial_ms: Math.round(serialMs) }));
}
