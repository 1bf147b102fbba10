// wasm single-threaded vs native single-threaded on the same synthetic scene, in one run.
//   cargo build --release -p lfdepth-wasm --example native_timing
//   node tests/bench/wasm-vs-native.mjs [scene] [size] [grid] [repetitions] [rounds] [stages]
// `stages`: "epi" (default: the EPI stage alone) or "full" (EPI → refine → median → TV,
// alignment off on both sides).
// Timing only (not a test). Native and wasm runs alternate for `rounds` rounds of
// `repetitions` each, so both see the same machine load; prints both best times, the
// ratio and whether the two disparity maps agree (checksum).
import { spawnSync } from "node:child_process";
import { join } from "node:path";
import lf, { root } from "../node/pkg.mjs";

const [scene = "planes", size = "512", grid = "9", repetitions = "3", rounds = "3", stages = "epi"] = process.argv.slice(2);
if (!["epi", "full"].includes(stages)) throw new Error(`stages must be "epi" or "full", not ${stages}`);
const native = join(root, "target/release/examples/native_timing");
function runNative() {
  const run = spawnSync(native, [scene, size, grid, repetitions, stages], { encoding: "utf8" });
  if (run.status !== 0) {
    throw new Error(`${native} failed (${run.error ?? run.stderr}): build it with cargo build --release -p lfdepth-wasm --example native_timing`);
  }
  return JSON.parse(run.stdout.trim());
}

const n = Number(size), g = Number(grid);
const scene3d = lf.synthesize({ scene, rows: g, cols: g, width: n, height: n, seed: 1 });
const estimator = new lf.Estimator(scene3d.views, { rows: g, cols: g, width: n, height: n, channels: 3 }, stages === "epi" ? { stage: "epi" } : { align: "off" });
let best = Infinity, disparity;
const nativeResult = { best_ms: Infinity };
for (let round = 0; round < Number(rounds); round++) {
  const r = runNative();
  nativeResult.best_ms = Math.min(nativeResult.best_ms, r.best_ms);
  nativeResult.checksum = r.checksum;
  for (let i = 0; i < Number(repetitions); i++) {
    const start = performance.now();
    const result = estimator.estimate();
    best = Math.min(best, performance.now() - start);
    disparity = result.disparity;
  }
}
const checksum = disparity.reduce((a, d) => a + d, 0);
const report = {
  scene, size: n, grid: g, stages,
  native_ms: nativeResult.best_ms,
  wasm_ms: Number(best.toFixed(1)),
  ratio: Number((best / nativeResult.best_ms).toFixed(3)),
  same_result: Math.abs(checksum - nativeResult.checksum) <= 1e-6 * Math.abs(checksum),
};
console.log(JSON.stringify(report));
