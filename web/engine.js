// Runs the core's schedule over a WorkerPool: the alignment (unless `params.align` is
// "off") on one worker, every worker holding only the views the stages read (`handOver`:
// shared, or copied and transferred); then every step of the schedule in order, its
// inputs handed to the workers that run its parts, its parts spread over them and placed
// in part order by the page's own `Run`. The steps, their parts and their placing are the
// core's: this file names no stage, and its result is bit-identical to
// `Estimator.estimate()` whatever the number of workers.

import { Run } from "./pkg/lfdepth_wasm.js";

/** True when this page may share memory with its workers (it is cross-origin
 * isolated: served with COOP `same-origin` and COEP `require-corp`). */
export const canShare = () => globalThis.crossOriginIsolated === true && typeof SharedArrayBuffer === "function";

/** A zeroed byte array for a light field's views: in a `SharedArrayBuffer` when the page
 * can share memory (the workers then read the page's one copy), else a plain one. */
export function viewBytes(length) {
  return new Uint8Array(canShare() ? new SharedArrayBuffer(length) : length);
}

export class Cancelled extends Error {
  constructor() {
    super("cancelled");
    this.name = "Cancelled";
  }
}

/**
 * @param {import("./pool.js").WorkerPool} pool
 * @param {{views: Uint8Array, shape: object}} lightField
 * @param {object} params  EstimateParams of the wasm package
 * @param {{onProgress: (stage: string, fraction: number) => void, signal: AbortSignal}} options
 * @returns {Promise<{disparity: Float32Array, confidence: Float32Array, residuals: Float32Array, range: number[], snapshots: {label: string, disparity: Float32Array}[], timings: {stage: string, ms: number}[], align: object | null, transport: object}>}
 *   `snapshots`: the disparity after each stage, labelled by the `Run` (the last one is
 *   `disparity`).
 *   `align`: `{ skipped, warning, rms, identityRms }` of the alignment, null when "off".
 *   `transport`: how the views reached the workers (see `handOver`).
 */
export async function estimate(pool, lightField, params, { onProgress: report, signal }) {
  // Parts still in flight when cancelled finish in their workers; say nothing of them.
  const onProgress = (stage, fraction) => signal.aborted || report(stage, fraction);
  const timings = [];
  const check = () => {
    if (signal.aborted) throw new Cancelled();
  };
  // In-flight parts cannot be interrupted inside their worker: each finishes there and
  // its reply is ignored; no further part is dispatched; the page returns at once.
  let abort;
  const aborted = new Promise((_, reject) => (abort = reject));
  aborted.catch(() => {});
  const onAbort = () => {
    pool.clear(new Cancelled());
    abort(new Cancelled());
  };
  signal.addEventListener("abort", onAbort);
  const race = (p) => Promise.race([aborted, p]);
  let run = null;
  try {
    const loaded = loadedParams(pool, lightField, params);
    const { align, timings: alignTimings, transport, workerParams } = await handOver(pool, lightField, params, loaded, { onProgress, race, check });
    timings.push(...alignTimings);
    check();
    const workers = pool.size;
    run = new Run(lightField.shape, workerParams, workers);
    for (let step = 0; step < run.steps; step++) {
      const stage = run.stage(step);
      const parts = run.parts(step);
      const start = performance.now();
      onProgress(stage, 0);
      // A step with fewer parts than workers hands its inputs to as many workers only.
      const used = Math.min(workers, parts);
      const inputs = run.inputs(step);
      await race(Promise.all(Array.from({ length: used }, (_, w) => pool.to(w, { op: "inputs", workers, inputs }))));
      check();
      const outputs = new Array(parts);
      let done = 0;
      const jobs = [];
      for (let index = 0; index < parts; index++) {
        const request = { op: "part", workers, step, index };
        const job = used < workers ? pool.to(index % used, request) : pool.run(request);
        jobs.push(
          job.then((reply) => {
            if (signal.aborted) return;
            outputs[index] = reply.output;
            onProgress(stage, ++done / parts);
          }),
        );
      }
      await race(Promise.all(jobs));
      check();
      // Placed in part order: the TV histories are summed in tile order, as the core does.
      outputs.forEach((output, index) => run.place(step, index, output));
      run.finish(step);
      const ms = performance.now() - start;
      const last = timings[timings.length - 1];
      if (last && last.stage === stage) last.ms += ms;
      else timings.push({ stage, ms });
      onProgress(stage, 1);
    }
    // Free the per-worker inputs; the views stay for the next estimate (`handOver`).
    pool.all({ op: "clearInputs" });
    return {
      disparity: run.disparity,
      confidence: run.confidence,
      residuals: run.residuals,
      range: Array.from(run.range),
      snapshots: run.snapshots,
      timings,
      align,
      transport,
    };
  } catch (e) {
    if (signal.aborted) throw new Cancelled();
    throw e;
  } finally {
    run?.free();
    signal.removeEventListener("abort", onAbort);
  }
}

/**
 * Renders a synthetic light field, views spread over the workers.
 * @returns {Promise<{views: Uint8Array, groundTruth: Float32Array, shape: object}>}
 */
export async function synthesize(pool, spec, onProgress) {
  const { rows, cols, width, height, channels } = spec;
  const viewLen = width * height * channels;
  const views = viewBytes(rows * cols * viewLen);
  let done = 0;
  const jobs = [];
  for (let row = 0; row < rows; row++) {
    for (let col = 0; col < cols; col++) {
      jobs.push(
        pool.run({ op: "view", spec, row, col }).then(({ view }) => {
          views.set(view, (row * cols + col) * viewLen);
          onProgress(++done / (rows * cols));
        }),
      );
    }
  }
  const gt = pool.run({ op: "groundTruth", spec });
  await Promise.all(jobs);
  const { groundTruth } = await gt;
  return { views, groundTruth, shape: { rows, cols, width, height, channels } };
}

/** The parameters of the workers' estimators: no alignment (worker 0 aligns once, see
 * `handOver`) and, unless given, one refine band per worker. The core's refinement is
 * bit-identical for any banding (each band is computed with a halo that covers the reach
 * of its result), so this changes only the speed: fewer, larger bands recompute fewer
 * halo rows, and every worker gets one. */
function loadedParams(pool, lightField, params) {
  const loaded = { ...params, align: "off" };
  loaded.refineBandRows ??= Math.ceil(lightField.shape.height / pool.size);
  return loaded;
}

/**
 * Hands `lightField` to the pool's workers ahead of an estimate with `params`, as the
 * estimate would (`handOver`): the page calls it when a light field is loaded, so that
 * the first estimate finds the views there. An estimate started meanwhile waits for it;
 * preparations run one after the other. Resolves when done; a failure leaves nothing
 * held (the estimate then loads the views itself and reports the error).
 */
export function prepare(pool, lightField, params) {
  const task = (pool.preparing ?? Promise.resolve()).then(() =>
    handOver(pool, lightField, params, loadedParams(pool, lightField, params), {
      onProgress: () => {},
      race: (p) => p,
      check: () => {},
      prepared: true,
    }),
  );
  const settled = task.then(
    () => {},
    () => {},
  );
  pool.preparing = settled;
  settled.then(() => {
    if (pool.preparing === settled) pool.preparing = null;
  });
  return task.then(() => {});
}

/**
 * Gives every worker an estimator over the views the stages read (`readViews`: the
 * centre row and column of the grid with the default parameters, 17 of 81 views on 9×9),
 * after the alignment when `params.align` is not "off". The alignment runs on worker 0
 * over the whole light field and that worker keeps its aligned estimator; the other
 * workers load the read views meanwhile ("auto": most arrays are found rectified, and
 * they reload the rectified views only when they were not).
 *
 * How the bytes travel: when `lightField.views` lies in a `SharedArrayBuffer` (a
 * cross-origin-isolated page, see `viewBytes`), every worker copies the views it needs
 * straight from the page's one copy into its wasm memory ("shared"); else each worker
 * gets its own packed copy of the read views, transferred, not cloned ("transfer").
 * Stage timings: the aligner's (`align`, `warp`) and `load`, the rest of this hand-over's
 * wall time (sending and copying the views, not computing).
 *
 * The next estimate of the same light field (same `views` array, same align mode, same
 * views read) sends nothing: the workers keep their estimators between estimates
 * (`pool.held`) and only take the new parameters (`reused`; `prepared` when they were
 * handed over by `prepare`, not by an earlier estimate).
 * @returns {Promise<{align: object | null, timings: {stage: string, ms: number}[], transport: {shared: boolean, views: number, of: number, bytesPerWorker: number, reused: boolean, prepared: boolean}}>}
 */
async function handOver(pool, lightField, params, loaded, { onProgress, race, check, prepared = false }) {
  const start = performance.now();
  // A preparation in flight (`prepare`) finishes first: it may be handing over these
  // very views.
  if (pool.preparing && !prepared) await race(pool.preparing);
  check();
  const { views, shape } = lightField;
  const viewLen = shape.width * shape.height * shape.channels;
  const shared = typeof SharedArrayBuffer === "function" && views.buffer instanceof SharedArrayBuffer;
  const { read } = await race(pool.run({ op: "readViews", shape, params: loaded }));
  check();
  const mode = params.align ?? "auto";
  // The workers still hold these views from the last estimate (aligned as this one
  // would align them: same light field, same align mode, same views read): new
  // parameters only.
  const held = pool.held;
  if (held && held.views === views && held.mode === mode && held.read === read.join()) {
    // Workers holding warped views compare them as the aligned pipeline does.
    const warped = held.align ? !held.align.skipped : false;
    const workerParams = warped ? { ...loaded, resampled: true } : loaded;
    await race(pool.all({ op: "setParams", params: workerParams }));
    check();
    // The first estimate after `prepare` got them when the light field was loaded; any
    // later one from an earlier estimate.
    const transport = { ...held.transport, reused: true, prepared: held.prepared };
    if (!prepared) held.prepared = false;
    return { align: held.align, timings: [{ stage: "load", ms: performance.now() - start }], transport, workerParams };
  }
  pool.held = null;
  // A load request per worker. `packed`: the read views one after the other (the
  // aligner's rectified ones); null: those of the light field itself.
  const requests = (packed, count) => {
    // The aligner's warped views are compared as the aligned pipeline does.
    const params = packed ? { ...loaded, resampled: true } : loaded;
    if (shared) {
      let source = views;
      if (packed) {
        // The aligner's views are `f32`: the copy keeps their type.
        source = new packed.constructor(new SharedArrayBuffer(packed.byteLength));
        source.set(packed);
      }
      return Array.from({ length: count }, () => [{ op: "load", views: source, indices: packed ? null : read, shape, params }, []]);
    }
    const one = packed ?? pack(views, read, viewLen);
    return Array.from({ length: count }, (_, i) => {
      const copy = i === count - 1 ? one : one.slice();
      return [{ op: "load", views: copy, indices: null, shape, params }, [copy.buffer]];
    });
  };
  let loadedWorkers = 0;
  // Loads workers `indices`; `report()` says whether to show their progress yet.
  const loadAll = async (indices, packed, report) => {
    if (!indices.length) return;
    const loads = requests(packed, indices.length).map(([request, transfer], i) =>
      pool.to(indices[i], request, transfer).then(() => {
        loadedWorkers++;
        if (report()) onProgress("load", loadedWorkers / pool.size);
      }),
    );
    await race(Promise.all(loads));
  };
  const others = Array.from({ length: pool.size - 1 }, (_, i) => i + 1);
  let align = null;
  const timings = [];
  if (mode === "off") {
    await loadAll([0, ...others], null, () => true);
  } else {
    let aligned = false;
    // "auto" usually finds the array rectified: the other workers load the views as
    // they are while worker 0 aligns.
    const early = mode === "auto" ? loadAll(others, null, () => aligned) : null;
    early?.catch(() => {});
    // The alignment reads views outside the read set: the whole light field, shared, or
    // one copy moved to the aligner (a structured clone would copy it twice), copied in
    // chunks so that the page's thread never stalls for the whole copy.
    const whole = shared ? views : await race(copyInChunks(views));
    check();
    const reply = await race(
      pool.to(0, { op: "align", views: whole, shape, params: { ...params, refineBandRows: loaded.refineBandRows }, keep: true }, shared ? [] : [whole.buffer], ({ stage, done, total }) => {
        onProgress(stage, total ? done / total : 1);
      }),
    );
    check();
    timings.push(...reply.timings);
    align = reply.align;
    aligned = true;
    loadedWorkers++;
    if (early) await early;
    check();
    if (reply.views || !early) {
      loadedWorkers = 1;
      await loadAll(others, reply.views ?? null, () => true);
    }
    onProgress("load", 1);
  }
  check();
  const computing = timings.reduce((sum, t) => sum + t.ms, 0);
  timings.push({ stage: "load", ms: Math.max(0, performance.now() - start - computing) });
  // Rectified views travel as `f32`.
  const sampleBytes = align && !align.skipped ? 4 : 1;
  const transport = { shared, views: read.length, of: shape.rows * shape.cols, bytesPerWorker: read.length * viewLen * sampleBytes, reused: false, prepared: false };
  pool.held = { views, mode, read: read.join(), align, transport, prepared };
  // Workers holding warped views compare them as the aligned pipeline does.
  const workerParams = align && !align.skipped ? { ...loaded, resampled: true } : loaded;
  return { align, timings, transport, workerParams };
}

/** Bytes copied between two yields of the page's thread. */
export const COPY_CHUNK = 8 << 20;

/** A copy of `bytes`, made `COPY_CHUNK` bytes at a time with a yield to the page's event
 * loop between chunks. */
async function copyInChunks(bytes) {
  const out = new Uint8Array(bytes.length);
  for (let offset = 0; offset < bytes.length; offset += COPY_CHUNK) {
    out.set(bytes.subarray(offset, offset + COPY_CHUNK), offset);
    await new Promise((resolve) => setTimeout(resolve, 0));
  }
  return out;
}

/** The views at grid indices `read` of `views`, packed one after the other (a copy). */
function pack(views, read, viewLen) {
  const out = new Uint8Array(read.length * viewLen);
  read.forEach((v, i) => out.set(views.subarray(v * viewLen, (v + 1) * viewLen), i * viewLen));
  return out;
}
