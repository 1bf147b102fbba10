// Runs the pipeline over a WorkerPool: the alignment (unless `params.align` is "off")
// on one worker, every worker holding only the views the stages read (`handOver`:
// shared, or copied and transferred); the disparity range on one worker, then the
// horizontal and vertical EPI bands spread over all of them, then the fusion, then the
// refine bands, the weighted-median row bands (every pass at once) and the TV tiles, each
// stage spread over all of them too. Every part is the core's own band/tile function,
// put together as the serial core does (TV histories summed in tile order), so the
// result is bit-identical to `Estimator.estimate()` whatever the number of workers.

/** Lines per band: small enough to balance the workers and to cancel quickly. */
export const BAND_LINES = 16;

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
 * @param {{stages: string[], onProgress: (stage: string, fraction: number) => void, signal: AbortSignal}} options
 *   `stages`: the stage names of `stageNames()` (the EPI ones, starting with "epi", are
 *   range, horizontal and vertical in that order).
 * @returns {Promise<{disparity: Float32Array, confidence: Float32Array, residuals: Float32Array, range: number[], timings: {stage: string, ms: number}[], align: object | null, transport: object}>}
 *   `align`: `{ skipped, warning, rms, identityRms }` of the alignment, null when "off".
 *   `transport`: how the views reached the workers (see `handOver`).
 */
export async function estimate(pool, lightField, params, { stages, onProgress: report, signal }) {
  // Bands still in flight when cancelled finish in their workers; say nothing of them.
  const onProgress = (stage, fraction) => signal.aborted || report(stage, fraction);
  const [rangeStage, horizontalStage, verticalStage] = stages.filter((s) => s.startsWith("epi"));
  // The core's names of the later stages (as `stageNames()` lists them).
  const [refineStage, geofillStage, medianStage, tvStage] = ["refine", "geofill", "median", "tv"];
  const timings = [];
  const check = () => {
    if (signal.aborted) throw new Cancelled();
  };
  const timed = async (stage, work) => {
    const start = performance.now();
    onProgress(stage, 0);
    const result = await work();
    timings.push({ stage, ms: performance.now() - start });
    onProgress(stage, 1);
    return result;
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
  try {
    const loaded = loadedParams(pool, lightField, params);
    const { align, timings: alignTimings, transport } = await handOver(pool, lightField, params, loaded, { onProgress, race: (p) => Promise.race([aborted, p]), check });
    timings.push(...alignTimings);
    check();
    const { range } = await timed(rangeStage, () => pool.run({ op: "range" }));
    check();
    const [min, max] = range;
    const { width, height } = lightField.shape;
    const bands = (stage, direction, lines, n) =>
      timed(stage, async () => {
        const disparity = new Float32Array(lines * n);
        const confidence = new Float32Array(lines * n);
        let done = 0;
        const jobs = [];
        for (let start = 0; start < lines; start += BAND_LINES) {
          const end = Math.min(lines, start + BAND_LINES);
          jobs.push(
            pool.run({ op: "band", direction, start, end, min, max }).then((band) => {
              disparity.set(band.disparity, start * n);
              confidence.set(band.confidence, start * n);
              done += end - start;
              onProgress(stage, done / lines);
            }),
          );
        }
        await Promise.all(jobs);
        return [disparity, confidence];
      });
    const [dh, ch] = await bands(horizontalStage, "horizontal", height, width);
    check();
    const [dv, cv] = await bands(verticalStage, "vertical", width, height);
    check();
    const fused = await timed("fuse", () =>
      pool.run({ op: "fuse", params, width, height, dh, ch, dv, cv }, [dh.buffer, ch.buffer, dv.buffer, cv.buffer]),
    );
    check();
    // The later stages by parts, in the order of the core's `pipeline::regularize`:
    // refine bands, the geodesic refill (when on), then each median pass (before TV unless `median.beforeTv` is false),
    // then TV tiles. Each stage's input maps go to every worker once; its parts then
    // spread over the pool. Cancel drops the queued parts and ignores the in-flight ones.
    const plan = await pool.run({ op: "parts" });
    check();
    // Sends `maps` to every worker, then parts `0..count` over the pool; `place` puts
    // each reply in the result, `progress` gets the share of parts done.
    const parts = async (maps, count, request, place, progress) => {
      await Promise.race([aborted, pool.all({ op: "maps", ...maps })]);
      check();
      let done = 0;
      const jobs = [];
      for (let index = 0; index < count; index++) {
        jobs.push(
          pool.run(request(index)).then((reply) => {
            if (signal.aborted) return;
            place(index, reply);
            progress(++done / count);
          }),
        );
      }
      await Promise.race([aborted, Promise.all(jobs)]);
      check();
    };
    let disparity = fused.disparity;
    let confidence = fused.confidence;
    if (plan.refineBands > 0) {
      const refined = new Float32Array(width * height);
      const refinedConfidence = new Float32Array(width * height);
      await timed(refineStage, () =>
        parts(
          { disparity, confidence },
          plan.refineBands,
          (index) => ({ op: "refineBand", index, min, max }),
          (index, band) => {
            const offset = plan.refineRows[index][0] * width;
            refined.set(band.disparity, offset);
            refinedConfidence.set(band.confidence, offset);
          },
          (fraction) => onProgress(refineStage, fraction),
        ),
      );
      disparity = refined;
      confidence = refinedConfidence;
    }
    // The geodesic refill: one whole-map part (its sweeps have one order).
    if (plan.geofill) {
      let filled = disparity;
      await timed(geofillStage, () =>
        parts(
          { disparity, confidence },
          1,
          () => ({ op: "geofill" }),
          (_, reply) => {
            filled = reply.disparity;
          },
          (fraction) => onProgress(geofillStage, fraction),
        ),
      );
      disparity = filled;
    }
    // Every pass in one part per row band (wasm `medianAllPassesRows`): a band filters,
    // pass after pass, the rows a later pass reads, so no map travels between passes
    // (a copy of the whole map to every worker and a round trip per band for each pass
    // cost more than the band's halo rows). One band per worker, at least BAND_LINES rows.
    const medianRows = Math.max(BAND_LINES, Math.ceil(height / pool.size));
    const median = () =>
      timed(medianStage, async () => {
        const filtered = new Float32Array(width * height);
        await parts(
          { disparity, confidence },
          Math.ceil(height / medianRows),
          (index) => ({ op: "medianAllPassesRows", start: index * medianRows, end: Math.min(height, (index + 1) * medianRows) }),
          (index, reply) => filtered.set(reply.disparity, index * medianRows * width),
          (fraction) => onProgress(medianStage, fraction),
        );
        disparity = filtered;
      });
    if (plan.medianPasses > 0 && plan.medianBeforeTv) await median();
    const regularized = new Float32Array(width * height);
    const histories = new Float32Array(plan.tvTiles * plan.tvIterations);
    await timed(tvStage, () =>
      parts(
        { disparity, confidence },
        plan.tvTiles,
        (index) => ({ op: "tvTile", index }),
        (index, tile) => {
          for (let y = 0; y < tile.height; y++) {
            regularized.set(tile.disparity.subarray(y * tile.width, (y + 1) * tile.width), (tile.y + y) * width + tile.x);
          }
          histories.set(tile.history, index * plan.tvIterations);
        },
        (fraction) => onProgress(tvStage, fraction),
      ),
    );
    disparity = regularized;
    const { residuals } = await pool.run({ op: "residuals", histories }, [histories.buffer]);
    check();
    if (plan.medianPasses > 0 && !plan.medianBeforeTv) await median();
    // Free the per-worker maps; the views stay for the next estimate (`handOver`).
    pool.all({ op: "clearMaps" });
    return {
      disparity,
      confidence,
      residuals,
      range,
      timings,
      align,
      transport,
    };
  } catch (e) {
    if (signal.aborted) throw new Cancelled();
    throw e;
  } finally {
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
    await race(pool.all({ op: "setParams", params: warped ? { ...loaded, resampled: true } : loaded }));
    check();
    // The first estimate after `prepare` got them when the light field was loaded; any
    // later one from an earlier estimate.
    const transport = { ...held.transport, reused: true, prepared: held.prepared };
    if (!prepared) held.prepared = false;
    return { align: held.align, timings: [{ stage: "load", ms: performance.now() - start }], transport };
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
        source = new Uint8Array(new SharedArrayBuffer(packed.length));
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
  const transport = { shared, views: read.length, of: shape.rows * shape.cols, bytesPerWorker: read.length * viewLen, reused: false, prepared: false };
  pool.held = { views, mode, read: read.join(), align, transport, prepared };
  return { align, timings, transport };
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
