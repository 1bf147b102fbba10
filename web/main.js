// The page: loads a light field (files, a folder, or a synthetic scene), runs the
// estimation in module workers and shows the results. Nothing leaves the machine: the
// only requests are for the page's own files.
import { initSync, stageNames, sceneNames, evaluate, version } from "./pkg/lfdepth_wasm.js";
import { WorkerPool } from "./pool.js";
import { estimate, prepare, synthesize, Cancelled } from "./engine.js";
import { filesFromDrop, arrange, decodeViews, parseConfig, cameraOf } from "./loader.js";
import { parsePfm, writePfm, writePng16, writePly } from "./formats.js";
import { drawMap, drawRgb, drawEpis, drawEpiLine, drawLegend, drawResiduals, viridis, grays, heat } from "./render.js";
import { SurfaceView } from "./surface.js";

const $ = (id) => document.getElementById(id);
const state = { lightField: null, groundTruth: null, result: null, pending: null, controller: null, pool: null, module: null, name: "" };

/** Stage weights of the overall progress bar. */
const WEIGHTS = { load: 0.03 };

function setStatus(status) {
  document.body.dataset.state = status;
}

function showError(message) {
  $("error").hidden = !message;
  $("error").textContent = message ?? "";
}

function setProgress(percent, text) {
  $("progress").value = percent;
  $("progress-text").textContent = text;
}

async function compile() {
  const url = new URL("./pkg/lfdepth_wasm_bg.wasm", import.meta.url);
  const response = await fetch(url);
  try {
    return await WebAssembly.compileStreaming(response.clone());
  } catch {
    return WebAssembly.compile(await response.arrayBuffer()); // a server without application/wasm
  }
}

/** The number of workers the form asks for. */
function workerCount() {
  return Math.max(1, Math.min(32, Number($("workers").value) || navigator.hardwareConcurrency || 4));
}

async function pool() {
  const size = workerCount();
  if (state.pool?.size !== size) {
    state.pool?.terminate();
    state.pool = await WorkerPool.create(state.module, size);
  }
  return state.pool;
}

/** The estimation parameters the form shows: a control the chosen start hides is not
 * sent (the EPI scales for the plane sweep, the sweep trust for the EPI start), so the
 * preset's value holds there. */
function params() {
  const manual = document.querySelector("input[name=range]:checked").value === "manual";
  const initial = $("initial").value;
  const p = {
    preset: $("preset").value,
    initial,
    lambda: Number($("tv-lambda").value),
    iterations: Number($("tv-iterations").value),
    median: $("median").checked,
    align: $("align").value,
  };
  if (usesEpi(initial)) {
    p.innerSigma = Number($("inner-sigma").value);
    p.outerSigma = Number($("outer-sigma").value);
    p.shearStep = Number($("shear-step").value);
    p.fusion = $("fusion").value;
  }
  // An empty or unreadable field is NaN, which the estimator refuses with the range.
  if (usesSweep(initial)) p.sweepTrust = $("sweep-trust").valueAsNumber;
  if (manual) p.range = [Number($("range-min").value), Number($("range-max").value)];
  return p;
}

/** Whether the start `initial` runs the EPI stage (the EPI start, and the fused one). */
const usesEpi = (initial) => initial !== "sweep";
/** Whether the start `initial` runs the plane sweep (the sweep start, and the fused one). */
const usesSweep = (initial) => initial !== "epi";

/** The form's control of each estimator key whose refusal the page shows at the control
 * (the estimator checks every value; its message names the key). */
const CONTROLS = { sweepTrust: "sweep-trust" };

/** The estimator's `message`, reworded to name the form's control when it refuses the
 * value of one (`parameter \`KEY\` must be …`): that control is marked invalid and
 * focused. Other messages as they are. */
function atControl(message) {
  const [, key, reason] = /^parameter `(\w+)` (.*)$/.exec(message) ?? [];
  if (!key || !Object.hasOwn(CONTROLS, key)) return message;
  const control = $(CONTROLS[key]);
  control.setAttribute("aria-invalid", "true");
  control.focus();
  const label = control.labels[0].textContent.trim();
  const got = control.value.trim() === "" ? "it is empty" : `not ${control.value}`;
  return `${label[0].toUpperCase()}${label.slice(1)} ${reason}, ${got}.`;
}

/** Shows the controls of the chosen start only: the sweep trust where the plane sweep
 * runs, the EPI scales where the EPI stage runs. */
function showStart() {
  const initial = $("initial").value;
  $("sweep-trust-label").hidden = !usesSweep(initial);
  $("epi-fields").hidden = !usesEpi(initial);
  $("start-note").textContent = usesEpi(initial) ? "" : "The plane sweep reads no EPI scales: they show for the EPI and fused starts.";
}

// ---------------------------------------------------------------- loading

function setLightField(lightField, groundTruth, name, { ignored = [], camera = null, config = null } = {}) {
  state.lightField = lightField;
  // The workers' estimators belong to the previous light field: the next estimate loads
  // this one (and the previous views can be collected).
  if (state.pool) state.pool.held = null;
  state.groundTruth = groundTruth?.data ?? null;
  state.camera = camera;
  state.result = null;
  state.name = name;
  const { rows, cols, width, height } = lightField.shape;
  const info = $("lf-info");
  const listed = ignored.length > 8 ? `${ignored.slice(0, 8).join(", ")} and ${ignored.length - 8} more` : ignored.join(", ");
  info.textContent =
    `${name}: ${rows}×${cols} views of ${width}×${height}` +
    (groundTruth ? `, with ground truth${groundTruth.name ? ` ${groundTruth.name}` : ""}` : "") +
    (camera ? `, camera from ${config}` : "") +
    "." +
    (ignored.length ? ` Ignored: ${listed}.` : "");
  info.dataset.name = name;
  info.dataset.ignored = ignored.join("/");
  info.dataset.groundTruth = groundTruth ? groundTruth.name || "synthetic" : "";
  $("run").disabled = false;
  $("align-info").textContent = "";
  delete $("align-info").dataset.align;
  $("load-info").textContent = "";
  delete $("load-info").dataset.transport;
  delete $("load-info").dataset.when;
  delete $("load-info").dataset.prepared;
  for (const b of document.querySelectorAll("[data-download]")) b.disabled = true;
  for (const id of ["disparity", "confidence", "error-map"]) {
    const c = $(id);
    c.width = width;
    c.height = height;
    c.getContext("2d").clearRect(0, 0, width, height);
  }
  $("scores").textContent = groundTruth ? "Ground truth loaded: run the estimation." : "Drop a ground-truth PFM, or use a synthetic scene.";
  delete $("scores").dataset.badpix007;
  $("snapshot").replaceChildren();
  $("snapshot").disabled = true;
  $("stage-scores").tBodies[0].replaceChildren();
  $("err-stage").textContent = "";
  $("surface-info").textContent = "Run the estimation to see the surface.";
  state.surface?.show({ disparity: new Float32Array(0), rgb: new Uint8Array(0), channels: 3, width: 0, height: 0, camera: null });
  showEpis((width / 2) | 0, (height / 2) | 0);
  drawResiduals($("residuals"), []);
}

function centreView() {
  const { views, shape } = state.lightField;
  const { rows, cols, width, height, channels } = shape;
  const index = ((rows - 1) >> 1) * cols + ((cols - 1) >> 1);
  const len = width * height * channels;
  return views.subarray(index * len, (index + 1) * len);
}

function showCentre() {
  const { width, height, channels } = state.lightField.shape;
  drawRgb($("centre"), centreView(), width, height, channels);
}

function showEpis(x, y) {
  state.epiAt = [x, y];
  // The picked pixel, marked on the centre view.
  showCentre();
  const centre = $("centre").getContext("2d");
  const arm = Math.max(3, Math.round(state.lightField.shape.width / 40));
  centre.save();
  centre.strokeStyle = "#ff2d95";
  centre.lineWidth = Math.max(1, arm / 4);
  centre.beginPath();
  for (const [dx, dy] of [[-1, 0], [1, 0], [0, -1], [0, 1]]) {
    centre.moveTo(x + 0.5 + dx * 2, y + 0.5 + dy * 2);
    centre.lineTo(x + 0.5 + dx * (arm + 2), y + 0.5 + dy * (arm + 2));
  }
  centre.stroke();
  centre.restore();
  drawEpis($("epi-h"), $("epi-v"), state.lightField, x, y);
  let where = `row ${y}, column ${x}`;
  const shown = shownDisparity();
  const epi = $("epi-h");
  if (shown) {
    const d = shown[y * state.lightField.shape.width + x];
    if (Number.isFinite(d)) {
      const ends = drawEpiLine(epi, $("epi-v"), state.lightField.shape, x, y, d);
      where += `: disparity ${d.toFixed(3)} px; the pink line is the slope it claims`;
      epi.dataset.disparity = d;
      epi.dataset.line = ends.join(",");
    }
  } else {
    delete epi.dataset.disparity;
    delete epi.dataset.line;
  }
  $("epi-where").textContent = where;
}

/** The disparity map the disparity panel shows (the chosen stage's), if any. */
function shownDisparity() {
  const result = state.result;
  if (!result) return null;
  const k = Number($("snapshot").value);
  return result.snapshots?.[k]?.disparity ?? result.disparity;
}

async function loadFiles(files) {
  showError(null);
  try {
    const arranged = arrange(files);
    if (!arranged.views.length) throw new Error("no images among the dropped files (PNG, JPEG, BMP or WebP)");
    state.pending = arranged;
    if (!arranged.known) {
      $("grid-form").hidden = false;
      $("grid-note").textContent = `${arranged.views.filter(Boolean).length} views in name order: confirm the grid`;
      $("grid-rows").value = arranged.rows;
      $("grid-cols").value = arranged.cols;
      return;
    }
    await decodePending(arranged.rows, arranged.cols);
  } catch (e) {
    showError(e.message);
  }
}

async function decodePending(rows, cols) {
  const { views: files, groundTruths, config, ignored, name } = state.pending;
  $("grid-form").hidden = true;
  setProgress(0, "decoding views");
  const lightField = await decodeViews(files, rows, cols, (f) => setProgress(100 * f, "decoding views"));
  const { width, height } = lightField.shape;
  // The first disparity ground truth of the views' size (HCI folders also hold a
  // high-resolution one); a depth PFM is never among the candidates.
  let groundTruth = null;
  const misfits = [];
  for (const file of groundTruths) {
    const pfm = parsePfm(await file.arrayBuffer());
    if (pfm.width === width && pfm.height === height) {
      groundTruth = { data: pfm.data, name: file.name };
      break;
    }
    misfits.push(`${file.name} is ${pfm.width}x${pfm.height}`);
  }
  if (!groundTruth && misfits.length) showError(`${misfits.join(", ")} but the views are ${width}x${height}: ground truth ignored`);
  let camera = null;
  if (config) {
    try {
      camera = cameraOf(parseConfig(await config.text()));
    } catch {
      camera = null;
    }
  }
  setProgress(0, "idle");
  setLightField(lightField, groundTruth, name, { ignored: [...ignored, ...groundTruths.filter((f) => f.name !== groundTruth?.name).map((f) => f.name)], camera, config: config?.name });
  prepareWorkers();
}

async function generate(scene, size, grid, misalign = false) {
  showError(null);
  setStatus("generating");
  const spec = { scene, rows: grid, cols: grid, width: size, height: size, channels: 3, disparityMin: -1.5, disparityMax: 1.5, seed: 1, misalign };
  const start = performance.now();
  const { views, groundTruth, shape } = await synthesize(await pool(), spec, (f) =>
    setProgress(100 * f, `rendering ${scene}: ${Math.round(100 * f)} %`),
  );
  setProgress(0, `rendered in ${((performance.now() - start) / 1000).toFixed(2)} s`);
  setLightField({ views, shape }, { data: groundTruth, name: "" }, `synthetic “${scene}”` + (misalign ? " (misaligned)" : ""));
  prepareWorkers();
  setStatus("idle");
}

// ---------------------------------------------------------------- estimation

/** Hands the light field's views to the workers now, while the user looks at it and sets
 * the parameters: the first estimate then finds them there (unless the align mode
 * changed). Not while an estimate runs (its workers are busy with the old light field:
 * the next estimate hands the new one over itself). */
function prepareWorkers() {
  if (!$("cancel").disabled || !state.lightField) return;
  const lightField = state.lightField;
  const p = params();
  const info = $("load-info");
  const say = (status, text) => {
    info.dataset.prepared = status;
    info.textContent = text;
  };
  say("pending", "Handing the views to the workers …");
  const current = () => state.lightField === lightField && info.dataset.prepared === "pending";
  // Synchronously when the pool exists, so that an estimate started right after waits
  // for this hand-over instead of making its own.
  const go = (workers) =>
    prepare(workers, lightField, p).then(
      () => current() && say("done", "The views are with the workers."),
      // The estimate hands them over itself and reports what went wrong.
      () => current() && say("failed", ""),
    );
  if (state.pool?.size === workerCount()) go(state.pool);
  else pool().then(go, () => {});
}

async function run() {
  if (!state.lightField) return;
  showError(null);
  for (const id of Object.values(CONTROLS)) $(id).setAttribute("aria-invalid", "false");
  setStatus("running");
  $("run").disabled = true;
  $("cancel").disabled = false;
  const controller = new AbortController();
  state.controller = controller;
  const stages = stageNames();
  // Alignment (on one worker) comes first, then every worker loads the views, then the
  // steps of the core's schedule in the order of `stageNames()`.
  const alignStages = ["align", "warp"];
  const order = [...alignStages, "load", ...stages.filter((s) => !alignStages.includes(s))];
  const share = (1 - WEIGHTS.load) / stages.length;
  const weight = (s) => WEIGHTS[s] ?? share;
  const onProgress = (stage, fraction) => {
    const before = order.slice(0, order.indexOf(stage)).reduce((a, s) => a + weight(s), 0);
    const percent = Math.min(100, 100 * (before + weight(stage) * fraction));
    setProgress(percent, `${stage} — ${Math.floor(percent)} %`);
  };
  const tbody = $("timings").tBodies[0];
  tbody.replaceChildren();
  const start = performance.now();
  try {
    const p = params();
    const result = await estimate(await pool(), state.lightField, p, { onProgress, signal: controller.signal });
    showAlignment(result.align);
    showTransport(result.transport);
    const total = performance.now() - start;
    state.result = { ...result, params: p };
    setProgress(100, `done in ${(total / 1000).toFixed(2)} s — 100 %`);
    for (const t of [...result.timings, { stage: `total (${state.pool.size} workers)`, ms: total }]) {
      const row = tbody.insertRow();
      row.insertCell().textContent = t.stage;
      row.insertCell().textContent = `${t.ms.toFixed(0)} ms`;
    }
    $("timings").dataset.totalMs = total.toFixed(1);
    showResult();
    setStatus("done");
  } catch (e) {
    if (e instanceof Cancelled) {
      setProgress(0, "cancelled");
      setStatus("cancelled");
    } else {
      showError(atControl(e.message));
      setProgress(0, "failed");
      setStatus("error");
    }
  } finally {
    $("run").disabled = false;
    $("cancel").disabled = true;
  }
}

/** How the views reached the workers, in words and as data attributes (for tests). */
function showTransport({ shared, views, of, bytesPerWorker, reused, prepared }) {
  const info = $("load-info");
  delete info.dataset.prepared;
  // How the views travelled, and when: with this estimate, when the light field was
  // loaded (`prepare`), or with an earlier estimate.
  info.dataset.transport = shared ? "shared" : "transfer";
  info.dataset.when = prepared ? "light-field" : reused ? "earlier-estimate" : "estimate";
  info.dataset.views = views;
  const which = `${views} of ${of} views (the ones the stages read, ${(bytesPerWorker / 2 ** 20).toFixed(1)} MB)`;
  const how = shared
    ? "read from memory shared with the page (cross-origin isolated)"
    : "one copy per worker, transferred (the page is not cross-origin isolated, so it cannot share memory)";
  info.textContent =
    reused && !prepared
      ? `Views to the workers: none sent, they still hold ${which} from the last estimate of this light field.`
      : `Views to the workers: ${which}, ${how}${prepared ? ", when the light field was loaded" : ""}.`;
  console.info(`lfdepth: ${info.textContent}`);
}

/** What the alignment did, in words and as data attributes (for tests). */
function showAlignment(align) {
  const info = $("align-info");
  info.dataset.align = !align ? "off" : align.warning ? "failed" : align.skipped ? "skipped" : "aligned";
  if (!align) info.textContent = "Alignment off: views taken as rectified.";
  else if (align.warning) info.textContent = `Views not aligned: ${align.warning}`;
  else if (align.skipped) info.textContent = `Already rectified (residual ${align.identityRms.toFixed(3)} px): not aligned.`;
  else info.textContent = `Aligned: reprojection ${align.identityRms.toFixed(2)} px → ${align.rms.toFixed(3)} px.`;
  if (align) info.dataset.rms = align.rms;
}

function showResult() {
  const { disparity, confidence, residuals, snapshots } = state.result;
  const { width, height } = state.lightField.shape;
  // The maps after each stage, labelled by the wasm side; the last is the result.
  const select = $("snapshot");
  select.replaceChildren(...snapshots.map((s, k) => new Option(s.label, String(k))));
  select.value = String(snapshots.length - 1);
  select.disabled = snapshots.length < 2;
  drawMap($("confidence"), confidence, width, height, 0, 1, grays);
  drawResiduals($("residuals"), residuals);
  $("residuals").dataset.iterations = residuals.length;
  for (const b of document.querySelectorAll("[data-download]")) b.disabled = false;
  showSurface(disparity);
  scoreStages();
  showStage();
}

/** The disparity panel, the error map and the EPI line for the stage the select names. */
function showStage() {
  const { range, snapshots } = state.result;
  const { width, height } = state.lightField.shape;
  const k = Number($("snapshot").value);
  const shown = shownDisparity();
  const [min, max] = range;
  drawMap($("disparity"), shown, width, height, min, max);
  $("disparity").dataset.snapshot = snapshots[k]?.label ?? "";
  $("legend-min").textContent = min.toFixed(2);
  $("legend-max").textContent = max.toFixed(2);
  if (state.scored) {
    const error = state.scored[k];
    drawMap($("error-map"), error.map, width, height, 0, 0.2, heat);
    $("err-stage").textContent = snapshots[k]?.label ?? "";
    $("error-map").dataset.snapshot = snapshots[k]?.label ?? "";
    for (const [i, row] of [...$("stage-scores").tBodies[0].rows].entries()) row.classList.toggle("shown", i === k);
  }
  if (state.epiAt) showEpis(...state.epiAt);
}

/** The 3D view of the final map, when WebGL2 is there. */
function showSurface(disparity) {
  const info = $("surface-info");
  if (!state.surface) {
    try {
      state.surface = new SurfaceView($("surface"));
    } catch (e) {
      info.textContent = `No 3D view: ${e.message}.`;
      return;
    }
  }
  const { width, height, channels } = state.lightField.shape;
  const mesh = state.surface.show({ disparity, rgb: centreView(), channels, width, height, camera: state.camera });
  $("surface").dataset.triangles = mesh.triangles;
  $("surface").dataset.metric = mesh.metric;
  info.textContent =
    `${mesh.triangles} triangles, ${mesh.metric ? "metric depth from parameters.cfg (z = b·f·D / (d·D + b·f))" : "disparity as relief (no camera in a parameters.cfg)"}. ` +
    "Drag or use the arrow keys to turn, the wheel or + and − to zoom, 0 to reset.";
}

/** Scores every stage's map against the ground truth (after the alignment's plane, as
 * the result), fills the per-stage table and sets the result's scores. */
function scoreStages() {
  state.scored = null;
  const scores = $("scores");
  if (!state.groundTruth) return;
  const { disparity, snapshots } = state.result;
  const { width, height } = state.lightField.shape;
  const gt = state.groundTruth;
  const border = Math.min(15, Math.floor(Math.min(width, height) / 2) - 1);
  // After alignment the disparity is defined up to a plane no image can observe (the
  // homographies can absorb any shift proportional to each view's baseline): score it
  // after removing the best-fitting plane, and say so.
  const aligned = $("align-info").dataset.align === "aligned";
  const gauge = aligned ? fitDisparityPlane(disparity, gt, width, height, border) : null;
  const score = (map) => {
    const scored = gauge ? map.map((d, i) => d - gauge.at(i % width, Math.floor(i / width))) : map;
    return { scored, map: scored.map((d, i) => Math.abs(d - gt[i])), s: evaluate(scored, gt, width, height, { border }) };
  };
  state.scored = snapshots.map((snapshot) => score(snapshot.disparity));
  const tbody = $("stage-scores").tBodies[0];
  tbody.replaceChildren();
  state.scored.forEach(({ s }, k) => {
    const row = tbody.insertRow();
    row.insertCell().textContent = snapshots[k].label;
    row.insertCell().textContent = `${s.badpix007.toFixed(2)} %`;
    row.insertCell().textContent = s.mse100.toFixed(3);
    row.dataset.badpix007 = s.badpix007;
  });
  const { s } = score(disparity);
  scores.textContent = `BadPix(0.07) ${s.badpix007.toFixed(2)} %, BadPix(0.03) ${s.badpix003.toFixed(2)} %, ` +
    `MSE×100 ${s.mse100.toFixed(3)} (border ${border} px; white = exact, dark red ≥ 0.2 px)` +
    (gauge ? `, after removing the disparity plane alignment cannot observe (offset ${gauge.offset.toFixed(3)} px at the centre)` : "");
  scores.dataset.badpix007 = s.badpix007;
  scores.dataset.mse100 = s.mse100;
  if (gauge) scores.dataset.gaugeOffset = gauge.offset;
  else delete scores.dataset.gaugeOffset;
}

/** Least-squares plane `a + b·x + c·y` through `disparity − gt` inside the border, fitted
 * twice: the second time without the pixels more than 0.2 px off the first plane (depth
 * edges), so that errors do not tilt it. `at(x, y)` evaluates it; `offset` is its value
 * at the image centre. Null when too few pixels remain. */
function fitDisparityPlane(disparity, gt, width, height, border) {
  const fit = (keep) => {
    // Normal equations in centred coordinates (better conditioned).
    const [cx, cy] = [width / 2, height / 2];
    const m = new Float64Array(9);
    const v = new Float64Array(3);
    let n = 0;
    for (let y = border; y < height - border; y++) {
      for (let x = border; x < width - border; x++) {
        const i = y * width + x;
        const r = disparity[i] - gt[i];
        if (!Number.isFinite(r) || !keep(x, y, r)) continue;
        const f = [1, x - cx, y - cy];
        for (let j = 0; j < 3; j++) {
          v[j] += f[j] * r;
          for (let k = 0; k < 3; k++) m[3 * j + k] += f[j] * f[k];
        }
        n++;
      }
    }
    if (n < 16) return null;
    const p = solve3(m, v);
    return p && { offset: p[0], at: (x, y) => p[0] + p[1] * (x - cx) + p[2] * (y - cy) };
  };
  const first = fit(() => true);
  return first && (fit((x, y, r) => Math.abs(r - first.at(x, y)) <= 0.2) ?? first);
}

/** `m · p = v` for a 3×3 `m` (row-major) by Cramer's rule; null when singular. */
function solve3(m, v) {
  const det = (a) => a[0] * (a[4] * a[8] - a[5] * a[7]) - a[1] * (a[3] * a[8] - a[5] * a[6]) + a[2] * (a[3] * a[7] - a[4] * a[6]);
  const d = det(m);
  if (!(Math.abs(d) > 1e-12)) return null;
  return [0, 1, 2].map((c) => det(m.map((x, i) => (i % 3 === c ? v[Math.floor(i / 3)] : x))) / d);
}

// ---------------------------------------------------------------- downloads

function save(blob, name) {
  const a = document.createElement("a");
  a.href = URL.createObjectURL(blob);
  a.download = name;
  a.click();
  setTimeout(() => URL.revokeObjectURL(a.href), 1000);
}

async function download(kind) {
  const { disparity, range } = state.result;
  const { width, height, channels } = state.lightField.shape;
  const base = state.name.replace(/[^\w.-]+/g, "_").replace(/^_+|_+$/g, "") || "lightfield";
  if (kind === "pfm") save(writePfm(disparity, width, height), `${base}_disparity.pfm`);
  if (kind === "png16") save(await writePng16(disparity, width, height, range[0], range[1]), `${base}_disparity16.png`);
  if (kind === "png") {
    // The map the panel shows: a stage's before the last is named after it.
    const k = Number($("snapshot").value);
    const snapshots = state.result.snapshots;
    const stage = k < snapshots.length - 1 ? `_${snapshots[k].label.replace(/[^\w]+/g, "_").replace(/_+$/, "")}` : "";
    $("disparity").toBlob((b) => save(b, `${base}_disparity${stage}.png`), "image/png");
  }
  if (kind === "ply") {
    const centre = centreView();
    const rgb = channels === 3 ? centre : Uint8Array.from({ length: width * height * 3 }, (_, i) => centre[Math.floor(i / 3) * channels + (channels > 2 ? i % 3 : 0)]);
    save(writePly(disparity, rgb, width, height), `${base}_points.ply`);
  }
}

// ---------------------------------------------------------------- wiring

function wire() {
  const drop = $("drop");
  drop.addEventListener("dragover", (e) => {
    e.preventDefault();
    drop.classList.add("over");
  });
  drop.addEventListener("dragleave", () => drop.classList.remove("over"));
  // From the keyboard the drop zone opens the file picker.
  drop.addEventListener("keydown", (e) => {
    if (e.target === drop && (e.key === "Enter" || e.key === " ")) {
      e.preventDefault();
      $("pick-files").click();
    }
  });
  drop.addEventListener("drop", async (e) => {
    e.preventDefault();
    drop.classList.remove("over");
    loadFiles(await filesFromDrop(e.dataTransfer));
  });
  for (const id of ["pick-files", "pick-folder"]) $(id).addEventListener("change", (e) => loadFiles([...e.target.files]));
  $("grid-form").addEventListener("submit", (e) => {
    e.preventDefault();
    decodePending(Number($("grid-rows").value), Number($("grid-cols").value)).catch((err) => showError(err.message));
  });
  $("synth-form").addEventListener("submit", (e) => {
    e.preventDefault();
    generate($("synth-scene").value, Number($("synth-size").value), Number($("synth-grid").value), $("synth-misalign").checked).catch((err) =>
      showError(err.message),
    );
  });
  for (const radio of document.querySelectorAll("input[name=range]")) {
    radio.addEventListener("change", () => {
      const manual = radio.value === "manual" && radio.checked;
      $("range-min").disabled = $("range-max").disabled = !manual;
    });
  }
  $("initial").addEventListener("change", showStart);
  $("sweep-trust").addEventListener("input", () => $("sweep-trust").removeAttribute("aria-invalid"));
  $("run").addEventListener("click", run);
  $("cancel").addEventListener("click", () => state.controller?.abort());
  for (const b of document.querySelectorAll("[data-download]")) b.addEventListener("click", () => download(b.dataset.download).catch((e) => showError(e.message)));
  $("centre").addEventListener("click", (e) => {
    if (!state.lightField) return;
    const rect = e.target.getBoundingClientRect();
    const { width, height } = state.lightField.shape;
    const x = Math.min(width - 1, Math.floor(((e.clientX - rect.left) / rect.width) * width));
    const y = Math.min(height - 1, Math.floor(((e.clientY - rect.top) / rect.height) * height));
    showEpis(x, y);
  });
  // The keyboard moves the picked pixel: arrows by one pixel, with Shift by ten.
  $("centre").addEventListener("keydown", (e) => {
    const move = { ArrowLeft: [-1, 0], ArrowRight: [1, 0], ArrowUp: [0, -1], ArrowDown: [0, 1] }[e.key];
    if (!move || !state.lightField || !state.epiAt) return;
    e.preventDefault();
    const { width, height } = state.lightField.shape;
    const step = e.shiftKey ? 10 : 1;
    const [x, y] = state.epiAt;
    showEpis(Math.max(0, Math.min(width - 1, x + step * move[0])), Math.max(0, Math.min(height - 1, y + step * move[1])));
  });
  $("snapshot").addEventListener("change", () => state.result && showStage());
}

async function main() {
  setStatus("starting");
  wire();
  showStart();
  drawLegend($("legend"), viridis);
  drawResiduals($("residuals"), []);
  $("workers").value = Math.min(32, navigator.hardwareConcurrency || 4);
  state.module = await compile();
  initSync({ module: state.module });
  document.querySelector("footer p").textContent += ` · v${version()}`;
  for (const name of sceneNames()) $("synth-scene").add(new Option(name, name));
  setStatus("idle");
  // ?scene=planes&size=512&grid=9&workers=4&misalign&align=on&run : generate (and run) without clicks.
  const query = new URLSearchParams(location.search);
  if (query.has("workers")) $("workers").value = query.get("workers");
  if (query.has("scene")) {
    $("synth-scene").value = query.get("scene");
    for (const key of ["size", "grid"]) if (query.has(key)) $(`synth-${key}`).value = query.get(key);
    if (query.has("align")) $("align").value = query.get("align");
    $("synth-misalign").checked = query.has("misalign");
    await generate(query.get("scene"), Number(query.get("size") ?? 256), Number(query.get("grid") ?? 9), query.has("misalign"));
    if (query.has("run")) await run();
  }
}

main().catch((e) => {
  showError(`The page could not start: ${e.message}`);
  setStatus("error");
});
