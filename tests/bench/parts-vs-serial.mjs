// The stages after EPI by parts (refine bands, median row bands, TV tiles, as the page's
// workers run them, here one after the other on one thread) against the single
// `refineAndRegularize` call, in Node: what the wasm part entry points cost of their own.
//   node tests/bench/parts-vs-serial.mjs [scene] [size] [grid] [rounds]
// Timing only (not a test); prints one JSON line per round and checks the two maps agree.
import lf from "../node/pkg.mjs";

const [scene = "planes", size = "512", grid = "9", rounds = "3"] = process.argv.slice(2);
const n = Number(size), g = Number(grid);
const views = lf.synthesize({ scene, rows: g, cols: g, width: n, height: n, seed: 1 }).views;
const e = new lf.Estimator(views, { rows: g, cols: g, width: n, height: n, channels: 3 }, { align: "off" });
const [min, max] = e.disparityRange();
const maps = {};
for (const direction of ["horizontal", "vertical"]) {
  const band = e.estimateBand(direction, 0, e.lines(direction), min, max);
  maps[direction] = [band.disparity, band.confidence];
}
const [d, c] = lf.fuseBands(undefined, n, n, ...maps.horizontal, ...maps.vertical);
const medianRows = Math.max(16, Math.ceil(n / 8)); // the page's cut for 2 workers

function byParts() {
  const times = {};
  let t = performance.now();
  let disparity = d, confidence = c;
  if (e.refineBands > 0) {
    e.setMaps(disparity, confidence);
    const rd = new Float32Array(n * n), rc = new Float32Array(n * n);
    for (let i = 0; i < e.refineBands; i++) {
      const [start] = e.refineBandRange(i);
      const band = e.refineBand(i, min, max);
      rd.set(band.disparity, start * n);
      rc.set(band.confidence, start * n);
      band.free();
    }
    [disparity, confidence] = [rd, rc];
  }
  times.refine = performance.now() - t;
  // The geodesic refill, one whole-map part (web/engine.js does the same).
  if (e.geofill) {
    t = performance.now();
    e.setMaps(disparity, confidence);
    disparity = e.geofillMap();
    times.geofill = performance.now() - t;
  }
  const median = () => {
    t = performance.now();
    // From the second pass on, the map the pass before read goes along, as the page's
    // workers get it (same values, less work).
    let previous = null;
    for (let pass = 0; pass < e.medianPasses; pass++) {
      e.setMaps(disparity, confidence);
      if (previous) e.setPreviousDisparity(previous);
      else e.clearPreviousDisparity();
      const filtered = new Float32Array(n * n);
      for (let start = 0; start < n; start += medianRows) filtered.set(e.medianRows(start, Math.min(n, start + medianRows)), start * n);
      previous = disparity;
      disparity = filtered;
    }
    e.clearPreviousDisparity();
    times.median = performance.now() - t;
  };
  if (e.medianBeforeTv) median();
  t = performance.now();
  e.setMaps(disparity, confidence);
  const out = new Float32Array(n * n);
  const histories = new Float32Array(e.tvTiles * e.tvIterations);
  for (let i = 0; i < e.tvTiles; i++) {
    const tile = e.tvTile(i);
    const td = tile.disparity;
    for (let y = 0; y < tile.height; y++) out.set(td.subarray(y * tile.width, (y + 1) * tile.width), (tile.y + y) * n + tile.x);
    histories.set(tile.history, i * e.tvIterations);
    tile.free();
  }
  e.tvResiduals(histories);
  disparity = out;
  times.tv = performance.now() - t;
  if (!e.medianBeforeTv) median();
  return { disparity, times };
}

for (let round = 0; round < Number(rounds); round++) {
  let t = performance.now();
  const whole = e.refineAndRegularize(d, c, min, max);
  const serialMs = performance.now() - t;
  const serialStages = Object.fromEntries(whole.timings.map((s) => [s.stage, Number(s.ms.toFixed(0))]));
  t = performance.now();
  const parts = byParts();
  const partsMs = performance.now() - t;
  const same = parts.disparity.every((v, i) => Object.is(v, whole.disparity[i]));
  console.log(JSON.stringify({
    scene, size: n, grid: g,
    serial_ms: Number(serialMs.toFixed(0)), serial_stages: serialStages,
    parts_ms: Number(partsMs.toFixed(0)), parts_stages: Object.fromEntries(Object.entries(parts.times).map(([k, v]) => [k, Number(v.toFixed(0))])),
    bit_identical: same,
  }));
}
