// A module worker: receives the compiled WebAssembly.Module once, then answers requests
// (alignment, the views the stages read, the inputs and parts of the core's schedule,
// synthetic views) one at a time. Its estimator stays between
// estimates (engine.js reuses it for the same light field). Every request
// carries an `id` and gets exactly one reply with the same id: `{ id, ok: true, ... }` or
// `{ id, ok: false, message }`; a long request may first send `{ id, progress }` reports.
import { initSync, Estimator, readViews, renderView, renderGroundTruth } from "./pkg/lfdepth_wasm.js";

let estimator = null;

/** One typed array per view `fromReadViews` takes (`Uint8Array`, or `Float32Array` for
 * the aligner's rectified views): the views at grid `indices` of a whole light field (a
 * `SharedArrayBuffer` the page shares), or, without `indices`, the views packed one
 * after the other. */
function viewList(views, indices, shape) {
  const len = shape.width * shape.height * shape.channels;
  const at = indices ?? Array.from({ length: Math.floor(views.length / len) }, (_, i) => i);
  return at.map((v, i) => {
    const start = (indices ? v : i) * len;
    return views.subarray(start, start + len);
  });
}

/** Runs one whole estimate of a tiny light field (9×9 views of 64×64 noise, a plane one
 * pixel of disparity away) so that the engine's hot functions are compiled by the
 * browser's optimising tier before the first real estimate. V8 first runs WebAssembly
 * through a baseline compiler and optimises a function only once it has run for a
 * while, so without this the first estimate in each worker ran its stages 1.3–1.5×
 * slower (Node, planes 512² 9×9: first estimate 484–528 ms cold, 327 ms after this
 * 28–87 ms warm-up; warm 281–328 ms). */
function warmUp() {
  const size = 64, grid = 9, channels = 3;
  const texture = new Uint8Array((size + grid) * (size + grid));
  let seed = 1;
  for (let i = 0; i < texture.length; i++) {
    seed = (Math.imul(seed, 1103515245) + 12345) >>> 0;
    texture[i] = seed >>> 24;
  }
  const views = new Uint8Array(grid * grid * size * size * channels);
  let at = 0;
  for (let r = 0; r < grid; r++) {
    for (let c = 0; c < grid; c++) {
      for (let y = 0; y < size; y++) {
        for (let x = 0; x < size; x++) {
          const value = texture[(y + r) * (size + grid) + x + c];
          for (let k = 0; k < channels; k++) views[at++] = value;
        }
      }
    }
  }
  const warm = new Estimator(views, { rows: grid, cols: grid, width: size, height: size, channels }, { align: "off" });
  try {
    warm.estimate().free();
  } finally {
    warm.free();
  }
}

function replace(next) {
  estimator?.free();
  estimator = next;
}

const handlers = {
  init({ module }) {
    initSync({ module });
    warmUp();
    return {};
  },
  readViews({ shape, params }) {
    return { read: Array.from(readViews(shape, params)) };
  },
  /** Holds only the views the stages read (see `viewList`), copied once into wasm memory. */
  load({ views, indices, shape, params }) {
    replace(null);
    replace(Estimator.fromReadViews(viewList(views, indices, shape), shape, params));
    return {};
  },
  /** Aligns the whole light field; replies with the rectified views the stages read
   * (packed, `f32` as the tool keeps them; none when the alignment left the views as
   * they were). With `keep` this
   * worker then estimates with the aligned estimator (it needs no `load`). */
  align({ id, views, shape, params, keep }) {
    // Free the estimator this one replaces first: its memory is then reused (faster
    // than fresh wasm pages).
    if (keep) replace(null);
    const aligner = new Estimator(views, shape, params);
    let kept = false;
    try {
      const result = aligner.align((progress) => {
        self.postMessage({ id, progress: { stage: progress.stage, done: progress.done, total: progress.total } });
      });
      const align = { skipped: result.skipped, warning: result.warning ?? null, rms: result.rms, identityRms: result.identityRms };
      const timings = result.timings.map((t) => {
        const timing = { stage: t.stage, ms: t.ms };
        t.free();
        return timing;
      });
      result.free();
      const rectified = align.skipped ? null : aligner.readViews;
      if (keep) {
        replace(aligner);
        kept = true;
      }
      return { align, timings, views: rectified, transfer: rectified ? [rectified.buffer] : [] };
    } finally {
      if (!kept) aligner.free();
    }
  },
  /** The inputs of a step of the core's schedule (`Run.inputs`). */
  inputs({ workers, inputs }) {
    requireEstimator().setInputs(workers, inputs);
    return {};
  },
  /** One part of a step: the array the page's `Run.place` takes. */
  part({ workers, step, index }) {
    const output = requireEstimator().runPart(workers, step, index);
    return { output, transfer: [output.buffer] };
  },
  view({ spec, row, col }) {
    const view = renderView(spec, row, col);
    return { view, transfer: [view.buffer] };
  },
  groundTruth({ spec }) {
    const gt = renderGroundTruth(spec);
    return { groundTruth: gt, transfer: [gt.buffer] };
  },
  /** New parameters over the views this worker's estimator holds (see engine.js). */
  setParams({ params }) {
    requireEstimator().setParams(params);
    return {};
  },
  clearInputs() {
    estimator?.clearInputs();
    return {};
  },
};

function requireEstimator() {
  if (!estimator) throw new Error("no light field loaded in this worker");
  return estimator;
}

self.onmessage = ({ data }) => {
  const { id, op } = data;
  try {
    const handler = handlers[op];
    if (!handler) throw new Error(`unknown request ${op}`);
    const { transfer = [], ...reply } = handler(data);
    self.postMessage({ id, ok: true, ...reply }, transfer);
  } catch (e) {
    self.postMessage({ id, ok: false, message: e instanceof Error ? e.message : String(e) });
  }
};
