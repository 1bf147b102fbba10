// The page in Debian's headless chromium (playwright-core, never a downloaded browser):
// a synthetic scene end to end in workers, accuracy read back from the page, progress at
// 100 %, cancel, no console errors, no request beyond the page's own files, a screenshot.
import { test, before, after } from "node:test";
import assert from "node:assert/strict";
import { mkdtempSync, mkdirSync, existsSync, readFileSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { dirname, join, resolve } from "node:path";
import { fileURLToPath } from "node:url";
import { chromium } from "playwright-core";
import { serve } from "./serve.mjs";

const root = process.env.LFDEPTH_ROOT ?? resolve(dirname(fileURLToPath(import.meta.url)), "../..");
const web = join(root, "web");
const artifacts = join(root, "tests/artifacts");
const executablePath = process.env.CHROMIUM_PATH ?? "/usr/bin/chromium";

let server, context, profile;
const consoleErrors = [];
const foreign = [];
/** The page's own servers (the plain one and the cross-origin-isolated one). */
const origins = [];

before(async () => {
  assert.ok(existsSync(join(web, "pkg/lfdepth_wasm_bg.wasm")), "web/pkg is missing: run wasm-pack build wasm --target web --out-dir ../web/pkg");
  server = await serve(web);
  origins.push(server.origin);
  profile = mkdtempSync(join(tmpdir(), "lfdepth-chromium-"));
  context = await chromium.launchPersistentContext(profile, {
    executablePath,
    headless: true,
    args: ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update", "--no-first-run", "--disable-sync", "--disable-quic"],
    viewport: { width: 1280, height: 1000 },
  });
  context.on("request", (request) => {
    const url = request.url();
    if (!origins.some((o) => url.startsWith(o + "/")) && !url.startsWith("blob:") && !url.startsWith("data:")) foreign.push(url);
  });
  context.on("console", (message) => {
    if (message.type() === "error") consoleErrors.push(message.text());
  });
  context.on("weberror", (error) => consoleErrors.push(String(error.error())));
});

after(async () => {
  await context?.close();
  await server?.close();
  if (profile) rmSync(profile, { recursive: true, force: true });
});

async function open(query) {
  const page = await context.newPage();
  page.on("pageerror", (e) => consoleErrors.push(e.message));
  await page.goto(`${server.origin}/${query}`);
  return page;
}

const settled = (page, timeout = 240_000) =>
  page.waitForFunction(() => ["done", "error", "cancelled"].includes(document.body.dataset.state), null, { timeout, polling: 100 });

test("a synthetic scene runs end to end in workers and is accurate", async () => {
  const page = await open("?scene=planes&size=128&grid=9&run");
  await settled(page);
  const report = await page.evaluate(() => ({
    state: document.body.dataset.state,
    error: document.getElementById("error").textContent,
    progress: document.getElementById("progress").value,
    progressText: document.getElementById("progress-text").textContent,
    badpix: Number(document.getElementById("scores").dataset.badpix007),
    mse: Number(document.getElementById("scores").dataset.mse100),
    totalMs: Number(document.getElementById("timings").dataset.totalMs),
    workers: Number(document.getElementById("workers").value),
    timings: [...document.querySelectorAll("#timings tr")].map((r) => r.textContent),
    iterations: Number(document.getElementById("residuals").dataset.iterations),
    downloads: [...document.querySelectorAll("[data-download]")].every((b) => !b.disabled),
    transport: document.getElementById("load-info").dataset.transport,
    when: document.getElementById("load-info").dataset.when,
    views: Number(document.getElementById("load-info").dataset.views),
    loadInfo: document.getElementById("load-info").textContent,
  }));
  console.log("page report:", JSON.stringify(report));
  // Served without COOP/COEP the page cannot share memory: each worker gets a copy of
  // the 17 views the stages read (of 81), and the page says so; they went to the workers
  // as soon as the scene was rendered (the estimate waited for that hand-over).
  assert.equal(report.transport, "transfer");
  assert.equal(report.when, "light-field");
  assert.equal(report.views, 17);
  assert.match(report.loadInfo, /17 of 81 views .* transferred \(the page is not cross-origin isolated, .*\), when the light field was loaded\.$/);
  assert.equal(report.state, "done", report.error);
  assert.equal(report.progress, 100);
  assert.match(report.progressText, /100 %/);
  // Measured: BadPix(0.07) 0.80 %, MSE×100 1.95 on this scene with the full pipeline from
  // the plane sweep (from the EPI start 1.6 % and 2.1, the EPI stage alone 5.3 %, 5.7); an
  // all-zero map scores about 100 % and 190.
  assert.ok(report.badpix < 5, `BadPix(0.07) ${report.badpix}`);
  assert.ok(report.mse < 10, `MSE×100 ${report.mse}`);
  for (const stage of ["sweep", "refine", "tv"]) {
    assert.ok(report.timings.some((t) => t.startsWith(stage)), `${stage}: ${report.timings.join("; ")}`);
  }
  // The convergence plot got the TV residual history.
  assert.ok(report.iterations > 1, `${report.iterations} TV iterations plotted`);
  assert.ok(report.downloads);
  // Click the centre view: the EPI caption follows.
  await page.click("#centre", { position: { x: 10, y: 20 } });
  assert.match(await page.textContent("#epi-where"), /row \d+, column \d+/);
  mkdirSync(artifacts, { recursive: true });
  await page.screenshot({ path: join(artifacts, "page.png"), fullPage: true });
  // A download is produced locally (a blob: URL, no request).
  const [download] = await Promise.all([page.waitForEvent("download"), page.click("[data-download=pfm]")]);
  assert.match(download.suggestedFilename(), /_disparity\.pfm$/);
  await page.close();
});

test("the page's result is bit-identical to the serial estimator, for 1 and 3 workers", async () => {
  const page = await open("");
  await page.waitForFunction(() => document.body.dataset.state === "idle");
  const results = await page.evaluate(async () => {
    const lf = await import("./pkg/lfdepth_wasm.js");
    const { WorkerPool } = await import("./pool.js");
    const engine = await import("./engine.js");
    const module = await WebAssembly.compileStreaming(fetch("./pkg/lfdepth_wasm_bg.wasm"));
    lf.initSync({ module });
    const spec = { scene: "occlusion", rows: 7, cols: 7, width: 80, height: 64, channels: 3, seed: 5 };
    // (`views` of a SyntheticLightField is a new copy at each read: read it once.)
    const scenes = { occlusion: { views: lf.synthesize(spec).views }, lowTexture: { views: lf.synthesize({ ...spec, scene: "low-texture" }).views } };
    const shape = { rows: 7, cols: 7, width: 80, height: 64, channels: 3 };
    const same = (a, b) => a.length === b.length && a.every((v, i) => Object.is(v, b[i]));
    const out = [];
    // Defaults (one refine band and one TV tile at this size), then parameters that cut
    // refine, median and TV into many parts (one set without the geodesic refill), with
    // the median before and after TV; a weakly textured scene, where the refill has
    // fattened edges to move.
    const runs = [
      [{}, "occlusion"],
      [{ refineBandRows: 24, tvTile: 32, geofill: false }, "occlusion"],
      [{ refineBandRows: 20, tvTile: 40, medianBeforeTv: false, iterations: 80 }, "occlusion"],
      [{ tvTile: 32 }, "lowTexture"],
      [{ preset: "fast", tvTile: 32 }, "occlusion"],
    ];
    // One pool per worker count for all the runs: the runs after the first on a scene
    // reuse the views the workers hold (new parameters only).
    for (const size of [1, 3]) {
      const pool = await WorkerPool.create(module, size);
      for (const [params, name] of runs) {
        const scene = scenes[name];
        const serial = new lf.Estimator(scene.views, shape, params).estimate();
        const stages = new Set();
        const r = await engine.estimate(pool, { views: scene.views, shape }, params, {
          stages: lf.stageNames(), onProgress: (stage) => stages.add(stage), signal: new AbortController().signal,
        });
        out.push({
          params: JSON.stringify(params),
          workers: size,
          disparity: same(r.disparity, serial.disparity),
          confidence: same(r.confidence, serial.confidence),
          residuals: same(r.residuals, serial.residuals) && r.residuals.length > 0,
          stages: ["refine", "median", "tv"].every((s) => stages.has(s)),
          timings: r.timings.map((t) => t.stage).filter((s) => ["refine", "geofill", "median", "tv"].includes(s)).join(),
          transport: r.transport.reused ? "reused" : r.transport.shared ? "shared" : "transfer",
        });
      }
      pool.terminate();
    }
    return out;
  });
  for (const r of results) {
    assert.ok(r.disparity && r.confidence && r.residuals && r.stages, JSON.stringify(r));
    const p = JSON.parse(r.params);
    // The geodesic refill is on by default and runs right after the refinement.
    const refined = p.geofill === false ? "refine" : "refine,geofill";
    const order = p.medianBeforeTv === false ? `${refined},tv,median` : `${refined},median,tv`;
    assert.equal(r.timings, order, JSON.stringify(r));
  }
  assert.equal(results.length, 10);
  // Not cross-origin isolated: copies transferred, then reused on the same scene.
  const perPool = ["transfer", "reused", "reused", "transfer", "transfer"];
  assert.deepEqual(results.map((r) => r.transport), [...perPool, ...perPool]);
  await page.close();
});

/** In `page`: the engine over 2 and 3 workers against the serial estimator, on a
 * rectified scene and a misaligned one (auto: the other workers reload the rectified
 * views; on), each estimated a second time with another λ (the views reused). */
function transportCases(page) {
  return page.evaluate(async () => {
    const lf = await import("./pkg/lfdepth_wasm.js");
    const { WorkerPool } = await import("./pool.js");
    const engine = await import("./engine.js");
    const module = await WebAssembly.compileStreaming(fetch("./pkg/lfdepth_wasm_bg.wasm"));
    lf.initSync({ module });
    const same = (a, b) => a.length === b.length && a.every((v, i) => Object.is(v, b[i]));
    const occlusion = { scene: "occlusion", rows: 7, cols: 7, width: 80, height: 64, channels: 3, seed: 5 };
    const bent = { scene: "mixed", rows: 5, cols: 5, width: 96, height: 96, channels: 3, seed: 4, misalign: true };
    const options = () => ({ stages: lf.stageNames(), onProgress: () => {}, signal: new AbortController().signal });
    const out = [];
    for (const [spec, params] of [[occlusion, {}], [bent, { align: "auto", iterations: 60 }], [bent, { align: "on", iterations: 60 }]]) {
      const { rows, cols, width, height, channels } = spec;
      const shape = { rows, cols, width, height, channels };
      const plain = lf.synthesize(spec).views;
      // Where the page keeps a light field's views: shared memory when isolated.
      const views = engine.viewBytes(plain.length);
      views.set(plain);
      const serial = new lf.Estimator(plain, shape, params).estimate();
      const serialAgain = new lf.Estimator(plain, shape, { ...params, lambda: 1 }).estimate();
      for (const size of [2, 3]) {
        const pool = await WorkerPool.create(module, size);
        // With 3 workers the views are handed over ahead (as the page does when a light
        // field is loaded); the estimate, started at once, waits for that.
        if (size === 3) engine.prepare(pool, { views, shape }, params);
        const r = await engine.estimate(pool, { views, shape }, params, options());
        const again = await engine.estimate(pool, { views, shape }, { ...params, lambda: 1 }, options());
        pool.terminate();
        out.push({
          spec: spec.scene,
          params: JSON.stringify(params),
          workers: size,
          isolated: crossOriginIsolated,
          shared: r.transport.shared && views.buffer instanceof SharedArrayBuffer,
          aligned: r.align?.skipped === false,
          bits: same(r.disparity, serial.disparity) && same(r.confidence, serial.confidence) && same(r.residuals, serial.residuals),
          reused: again.transport.reused && !again.transport.prepared && r.transport.reused === (size === 3) && r.transport.prepared === (size === 3) && again.align?.skipped === r.align?.skipped,
          bitsAgain: same(again.disparity, serialAgain.disparity) && same(again.confidence, serialAgain.confidence),
        });
      }
    }
    return out;
  });
}

test("views copied and transferred (plain host): same bits, aligned or not, and reused", async () => {
  const page = await open("");
  await page.waitForFunction(() => document.body.dataset.state === "idle");
  const results = await transportCases(page);
  for (const r of results) assert.ok(!r.isolated && !r.shared && r.bits && r.reused && r.bitsAgain, JSON.stringify(r));
  assert.deepEqual(results.map((r) => r.aligned), [false, false, true, true, true, true]);
  await page.close();
});

test("cross-origin isolated, the workers read the views from memory shared with the page: same bits", async () => {
  const isolated = await serve(web, { isolated: true });
  origins.push(isolated.origin);
  try {
    const page = await context.newPage();
    page.on("pageerror", (e) => consoleErrors.push(e.message));
    await page.goto(`${isolated.origin}/`);
    await page.waitForFunction(() => document.body.dataset.state === "idle");
    const results = await transportCases(page);
    for (const r of results) assert.ok(r.isolated && r.shared && r.bits && r.reused && r.bitsAgain, JSON.stringify(r));
    assert.deepEqual(results.map((r) => r.aligned), [false, false, true, true, true, true]);
    // The page itself: its views live in shared memory, and it says so.
    await page.goto(`${isolated.origin}/?scene=planes&size=128&grid=9&workers=2&run`);
    await settled(page);
    const report = await page.evaluate(() => ({
      state: document.body.dataset.state,
      error: document.getElementById("error").textContent,
      transport: document.getElementById("load-info").dataset.transport,
      loadInfo: document.getElementById("load-info").textContent,
      badpix: Number(document.getElementById("scores").dataset.badpix007),
    }));
    assert.equal(report.state, "done", report.error);
    assert.equal(report.transport, "shared");
    assert.match(report.loadInfo, /17 of 81 views .* shared with the page \(cross-origin isolated\)/);
    assert.ok(report.badpix < 5, `BadPix(0.07) ${report.badpix}`);
    await page.close();
  } finally {
    await isolated.close();
  }
});

test("the align control exists, reaches the workers' requests and aligns a misaligned scene", async () => {
  const page = await context.newPage();
  page.on("pageerror", (e) => consoleErrors.push(e.message));
  // Record what the page asks its workers (op and align parameter of every request).
  await page.addInitScript(() => {
    window.__requests = [];
    const post = Worker.prototype.postMessage;
    Worker.prototype.postMessage = function (message, ...rest) {
      if (message?.op) window.__requests.push({ op: message.op, align: message.params?.align });
      return post.call(this, message, ...rest);
    };
  });
  await page.goto(`${server.origin}/?scene=mixed&size=128&grid=5&misalign&workers=2`);
  // Rendered, and its views handed to the workers (with the default align mode, auto).
  await page.waitForFunction(() => document.body.dataset.state === "idle" && document.getElementById("load-info").dataset.prepared === "done", null, { timeout: 120_000 });
  assert.equal(await page.textContent("#load-info"), "The views are with the workers.");
  assert.match(await page.textContent("#lf-info"), /misaligned/);
  const options = await page.$$eval("#align option", (o) => o.map((x) => x.value));
  assert.deepEqual(options.sort(), ["auto", "off", "on"]);
  assert.equal(await page.inputValue("#align"), "auto");
  const runWith = async (mode) => {
    await page.selectOption("#align", mode);
    await page.evaluate(() => (window.__requests = []));
    await page.click("#run");
    await page.waitForFunction(() => document.body.dataset.state === "running");
    await settled(page);
    return page.evaluate(() => ({
      state: document.body.dataset.state,
      error: document.getElementById("error").textContent,
      progress: document.getElementById("progress").value,
      mse: Number(document.getElementById("scores").dataset.mse100),
      badpix: Number(document.getElementById("scores").dataset.badpix007),
      gauge: document.getElementById("scores").dataset.gaugeOffset,
      scores: document.getElementById("scores").textContent,
      align: document.getElementById("align-info").dataset.align,
      info: document.getElementById("align-info").textContent,
      timings: [...document.querySelectorAll("#timings tr")].map((r) => r.textContent),
      requests: window.__requests.filter((r) => r.op === "align" || r.op === "load"),
    }));
  };
  const off = await runWith("off");
  const on = await runWith("on");
  console.log("align off:", JSON.stringify(off), "\nalign on:", JSON.stringify(on));
  for (const r of [off, on]) {
    assert.equal(r.state, "done", r.error);
    assert.equal(r.progress, 100);
  }
  // Off: no alignment request, the workers load the views as they are.
  assert.equal(off.align, "off");
  assert.ok(!off.requests.some((r) => r.op === "align"));
  assert.ok(off.requests.every((r) => r.align === "off"));
  // On: one alignment request with align "on", then every worker loads the rectified
  // views (with align "off": they do not align again).
  assert.deepEqual(on.requests.filter((r) => r.op === "align"), [{ op: "align", align: "on" }]);
  assert.ok(on.requests.filter((r) => r.op === "load").length >= 1 && on.requests.filter((r) => r.op === "load").every((r) => r.align === "off"));
  assert.equal(on.align, "aligned", on.info);
  assert.match(on.info, /Aligned: reprojection [\d.]+ px → 0\.0\d+ px/);
  assert.ok(on.timings.some((t) => t.startsWith("warp")), on.timings.join("; "));
  // Aligned, the page scores after removing the disparity plane no image can observe
  // (docs/stages/align.md) and says so; unaligned it scores the map as it is.
  assert.equal(off.gauge, undefined);
  assert.ok(Number.isFinite(Number(on.gauge)), on.scores);
  assert.match(on.scores, /after removing the disparity plane alignment cannot observe/);
  // Measured (full pipeline from the plane sweep, 5×5 of 128²): off BadPix(0.07) 87.4 %,
  // MSE×100 42.5; on, after the plane was removed, 5.7 % and 9.6. (From the EPI start the
  // unaligned map scores MSE×100 734.)
  assert.ok(off.mse > 30 && off.badpix > 50, `off: BadPix(0.07) ${off.badpix}, MSE×100 ${off.mse}`);
  assert.ok(on.mse < 15 && on.mse < off.mse / 3, `on: MSE×100 ${on.mse}`);
  assert.ok(on.badpix < 20 && on.badpix < off.badpix / 10, `on: BadPix(0.07) ${on.badpix}`);
  mkdirSync(artifacts, { recursive: true });
  await page.screenshot({ path: join(artifacts, "page-aligned.png"), fullPage: true });
  await page.close();
});

test("the median control exists, is on by default and reaches the workers", async () => {
  const page = await context.newPage();
  page.on("pageerror", (e) => consoleErrors.push(e.message));
  await page.addInitScript(() => {
    window.__medians = [];
    const post = Worker.prototype.postMessage;
    Worker.prototype.postMessage = function (message, ...rest) {
      if (message?.params && "median" in message.params) window.__medians.push(message.params.median);
      return post.call(this, message, ...rest);
    };
  });
  await page.goto(`${server.origin}/?scene=occlusion&size=96&grid=5&workers=2`);
  await page.waitForFunction(() => document.body.dataset.state === "idle" && document.getElementById("load-info").dataset.prepared === "done", null, { timeout: 120_000 });
  assert.equal(await page.isChecked("#median"), true);
  const runWith = async (on) => {
    await page.setChecked("#median", on);
    // A small scene may finish before a poll sees "running": mark the state first.
    await page.evaluate(() => {
      window.__medians = [];
      document.body.dataset.state = "clicked";
    });
    await page.click("#run");
    await settled(page);
    return page.evaluate(() => ({
      state: document.body.dataset.state,
      error: document.getElementById("error").textContent,
      medians: window.__medians,
      timings: [...document.querySelectorAll("#timings tr")].map((r) => r.textContent),
      transport: document.getElementById("load-info").dataset.transport,
      when: document.getElementById("load-info").dataset.when,
      loadInfo: document.getElementById("load-info").textContent,
    }));
  };
  const on = await runWith(true);
  const off = await runWith(false);
  for (const r of [on, off]) assert.equal(r.state, "done", r.error);
  // The views went to the workers when the scene was rendered; the second estimate of
  // the same light field sends none either: the workers hold them.
  assert.equal(on.transport, "transfer");
  assert.equal(on.when, "light-field");
  assert.equal(off.when, "earlier-estimate");
  assert.match(off.loadInfo, /none sent, they still hold 9 of 25 views/);
  assert.ok(on.medians.length > 0 && on.medians.every((m) => m === true), JSON.stringify(on.medians));
  assert.ok(off.medians.length > 0 && off.medians.every((m) => m === false), JSON.stringify(off.medians));
  // The median is a stage of its own only when it ran.
  assert.ok(on.timings.some((t) => t.startsWith("median")), on.timings.join("; "));
  assert.ok(!off.timings.some((t) => t.startsWith("median")), off.timings.join("; "));
  await page.close();
});

test("the start control: its fields follow the choice, it reaches the workers, and the EPI start's map is the estimator's", async () => {
  const page = await context.newPage();
  page.on("pageerror", (e) => consoleErrors.push(e.message));
  // Record the parameters the page sends its workers, and every part it dispatches.
  await page.addInitScript(() => {
    window.__params = [];
    window.__parts = 0;
    const post = Worker.prototype.postMessage;
    Worker.prototype.postMessage = function (message, ...rest) {
      if (message?.op === "load" || message?.op === "setParams") window.__params.push(message.params);
      if (message?.op === "part") window.__parts++;
      return post.call(this, message, ...rest);
    };
  });
  await page.goto(`${server.origin}/?scene=planes&size=96&grid=5&workers=2`);
  await page.waitForFunction(() => document.body.dataset.state === "idle" && document.getElementById("load-info").dataset.prepared === "done", null, { timeout: 120_000 });
  const shown = () =>
    page.evaluate(() => ({
      initial: document.getElementById("initial").value,
      epiFields: !document.getElementById("epi-fields").hidden,
      trust: !document.getElementById("sweep-trust-label").hidden,
      note: document.getElementById("start-note").textContent,
    }));
  // The control is labelled, its choices explained, the plane sweep first and chosen.
  assert.equal(await page.getByLabel("start").getAttribute("id"), "initial");
  assert.equal(await page.getByLabel("sweep trust").getAttribute("id"), "sweep-trust");
  const options = await page.$$eval("#initial option", (o) => o.map((x) => [x.value, x.textContent, x.title]));
  assert.deepEqual(options.map((o) => o[0]), ["sweep", "epi", "fused"]);
  assert.ok(options.every((o) => o[2].length > 20), JSON.stringify(options));
  assert.match(await page.getAttribute("label:has(#initial)", "title"), /plane sweep: .*\nEPI structure tensor: .*\nfused: /);
  // Plane sweep: the trust field, no EPI scales (a note says where they are).
  assert.deepEqual(await shown(), { initial: "sweep", epiFields: false, trust: true, note: "The plane sweep reads no EPI scales: they show for the EPI and fused starts." });
  await page.selectOption("#initial", "epi");
  assert.deepEqual(await shown(), { initial: "epi", epiFields: true, trust: false, note: "" });
  await page.selectOption("#initial", "fused");
  assert.deepEqual(await shown(), { initial: "fused", epiFields: true, trust: true, note: "" });
  // Both settings start from the plane sweep: choosing one leaves the chosen start.
  await page.selectOption("#initial", "sweep");
  await page.selectOption("#preset", "fast");
  assert.deepEqual(await shown(), { initial: "sweep", epiFields: false, trust: true, note: "The plane sweep reads no EPI scales: they show for the EPI and fused starts." });
  await page.selectOption("#initial", "epi");
  await page.selectOption("#preset", "default");
  assert.deepEqual(await shown(), { initial: "epi", epiFields: true, trust: false, note: "" });
  await page.selectOption("#initial", "sweep");

  const runWith = async (initial) => {
    await page.selectOption("#initial", initial);
    // A small scene may finish before a poll sees "running": mark the state first.
    await page.evaluate(() => {
      window.__params = [];
      document.body.dataset.state = "clicked";
    });
    await page.click("#run");
    await settled(page);
    const report = await page.evaluate(() => ({
      state: document.body.dataset.state,
      error: document.getElementById("error").textContent,
      params: window.__params,
      snapshots: [...document.querySelectorAll("#snapshot option")].map((o) => o.textContent),
      scored: [...document.querySelectorAll("#stage-scores tbody tr")].map((r) => r.cells[0].textContent),
      shown: document.getElementById("disparity").dataset.snapshot,
      timings: [...document.querySelectorAll("#timings tr")].map((r) => r.cells[0].textContent),
      badpix: Number(document.getElementById("scores").dataset.badpix007),
    }));
    assert.equal(report.state, "done", report.error);
    assert.ok(report.params.length > 0 && report.params.every((p) => p.initial === initial), JSON.stringify(report.params));
    const [download] = await Promise.all([page.waitForEvent("download"), page.click("[data-download=pfm]")]);
    report.pfm = [...readFileSync(await download.path())];
    return report;
  };
  const sweep = await runWith("sweep");
  const epi = await runWith("epi");
  mkdirSync(artifacts, { recursive: true });
  await page.screenshot({ path: join(artifacts, "page-start.png"), fullPage: true });
  console.log("sweep start:", JSON.stringify({ ...sweep, pfm: undefined }), "\nEPI start:", JSON.stringify({ ...epi, pfm: undefined }));
  // What each start sends: the EPI scales only to the EPI stage, the trust only to the sweep.
  assert.ok(sweep.params.every((p) => p.sweepTrust === 0 && !("innerSigma" in p)), JSON.stringify(sweep.params));
  assert.ok(epi.params.every((p) => !("sweepTrust" in p) && p.innerSigma === 0.5 && p.fusion === "coherence"), JSON.stringify(epi.params));
  // Each start's maps, labelled by the wasm side, in the snapshot select and the table.
  const after = ["refined", "refilled at depth steps", "edge-snapping median", "TV (final)"];
  assert.deepEqual(sweep.snapshots, ["plane-sweep estimate", ...after]);
  assert.deepEqual(epi.snapshots, ["EPI estimate", ...after]);
  assert.deepEqual(epi.scored, epi.snapshots);
  assert.equal(epi.shown, "TV (final)");
  assert.ok(sweep.timings.includes("sweep") && !sweep.timings.includes("epi horizontal"), sweep.timings.join("; "));
  assert.ok(epi.timings.includes("epi horizontal") && epi.timings.includes("epi vertical") && !epi.timings.includes("sweep"), epi.timings.join("; "));
  // Both accurate on this scene (measured: BadPix(0.07) 1.06 % from the sweep, 1.45 % from
  // the EPI start; an all-zero map scores about 100 %).
  assert.ok(sweep.badpix < 10 && epi.badpix < 10, `sweep ${sweep.badpix}, EPI ${epi.badpix}`);
  // The page's maps are the serial estimator's with only `initial` set, bit for bit
  // (the page's other fields hold the core's defaults), and the two starts differ.
  const equal = await page.evaluate(
    async ({ sweepPfm, epiPfm }) => {
      const lf = await import("./pkg/lfdepth_wasm.js");
      const { parsePfm } = await import("./formats.js");
      const spec = { scene: "planes", rows: 5, cols: 5, width: 96, height: 96, channels: 3, disparityMin: -1.5, disparityMax: 1.5, seed: 1 };
      const views = lf.synthesize(spec).views;
      const shape = { rows: 5, cols: 5, width: 96, height: 96, channels: 3 };
      const same = (a, b) => a.length === b.length && a.every((v, i) => Object.is(v, b[i]));
      const page = { sweep: parsePfm(new Uint8Array(sweepPfm).buffer).data, epi: parsePfm(new Uint8Array(epiPfm).buffer).data };
      const serial = (initial) => new lf.Estimator(views, shape, { initial }).estimate().disparity;
      return { sweep: same(page.sweep, serial("sweep")), epi: same(page.epi, serial("epi")), differ: !same(page.sweep, page.epi) };
    },
    { sweepPfm: sweep.pfm, epiPfm: epi.pfm },
  );
  assert.deepEqual(equal, { sweep: true, epi: true, differ: true });

  // The fused start: the EPI estimate, refined, then the choice.
  const fused = await runWith("fused");
  assert.deepEqual(fused.snapshots, ["EPI estimate", "refined", "fused start", ...after.slice(1)]);
  assert.ok(fused.params.every((p) => p.sweepTrust === 0 && p.innerSigma === 0.5), JSON.stringify(fused.params));

  // A sweep trust out of 0..1 (or none: the page sends NaN) is refused by the estimator's
  // check of the parameter, in words naming the page's field, and no part runs; a good
  // one reaches the workers.
  await page.selectOption("#initial", "sweep");
  for (const bad of ["2", "-0.5", ""]) {
    await page.fill("#sweep-trust", bad);
    await page.evaluate(() => {
      window.__parts = 0;
      document.body.dataset.state = "clicked";
    });
    await page.click("#run");
    await settled(page, 10_000);
    const refused = await page.evaluate(() => ({
      state: document.body.dataset.state,
      error: document.getElementById("error").textContent,
      visible: !document.getElementById("error").hidden,
      invalid: document.getElementById("sweep-trust").getAttribute("aria-invalid"),
      focused: document.activeElement?.id,
      parts: window.__parts,
      run: document.getElementById("run").disabled,
    }));
    assert.deepEqual(refused, {
      state: "error",
      error: `Sweep trust must be in [0, 1] (0: off), ${bad === "" ? "it is empty" : `not ${bad}`}.`,
      visible: true,
      invalid: "true",
      focused: "sweep-trust",
      parts: 0,
      run: false,
    });
  }
  // The EPI start does not read the trust: a bad one hidden there stops nothing.
  await page.selectOption("#initial", "epi");
  await page.evaluate(() => (document.body.dataset.state = "clicked"));
  await page.click("#run");
  await settled(page);
  assert.equal(await page.evaluate(() => document.body.dataset.state), "done", await page.textContent("#error"));
  await page.selectOption("#initial", "sweep");
  await page.fill("#sweep-trust", "0.5");
  await page.evaluate(() => {
    window.__params = [];
    document.body.dataset.state = "clicked";
  });
  await page.click("#run");
  await settled(page);
  assert.equal(await page.evaluate(() => document.body.dataset.state), "done", await page.textContent("#error"));
  const sent = await page.evaluate(() => window.__params);
  assert.ok(sent.length > 0 && sent.every((p) => p.sweepTrust === 0.5), JSON.stringify(sent));
  // The trust scales the refinement's confidence by the sweep's, which the workers then
  // get with the refinement's inputs: the page's map is still the serial estimator's.
  const [trustedPfm] = await Promise.all([page.waitForEvent("download"), page.click("[data-download=pfm]")]);
  const trusted = [...readFileSync(await trustedPfm.path())];
  const sameTrusted = await page.evaluate(async (pfm) => {
    const lf = await import("./pkg/lfdepth_wasm.js");
    const { parsePfm } = await import("./formats.js");
    const spec = { scene: "planes", rows: 5, cols: 5, width: 96, height: 96, channels: 3, disparityMin: -1.5, disparityMax: 1.5, seed: 1 };
    const shape = { rows: 5, cols: 5, width: 96, height: 96, channels: 3 };
    const serial = new lf.Estimator(lf.synthesize(spec).views, shape, { sweepTrust: 0.5 }).estimate().disparity;
    const page = parsePfm(new Uint8Array(pfm).buffer).data;
    return page.length === serial.length && page.every((v, i) => Object.is(v, serial[i]));
  }, trusted);
  assert.ok(sameTrusted, "the page's map with sweep trust 0.5 differs from the serial estimator's");
  assert.equal(await page.getAttribute("#sweep-trust", "aria-invalid"), "false");
  assert.equal(await page.isHidden("#error"), true);
  await page.close();
});

test("Cancel stops a running estimation and the page stays usable", async () => {
  // One worker on 512² views: long enough (seconds) to cancel in the middle of the bands.
  const page = await open("?scene=slanted&size=512&grid=9&workers=1");
  await page.waitForFunction(() => document.body.dataset.state === "idle" && !document.getElementById("run").disabled, null, { timeout: 120_000 });
  await page.click("#run");
  await page.waitForFunction(() => /sweep/.test(document.getElementById("progress-text").textContent), null, { timeout: 60_000, polling: 10 });
  await page.click("#cancel");
  await settled(page);
  assert.equal(await page.evaluate(() => document.body.dataset.state), "cancelled");
  assert.equal(await page.textContent("#progress-text"), "cancelled");
  await page.click("#run");
  await page.waitForFunction(() => document.body.dataset.state === "running");
  await settled(page);
  assert.equal(await page.evaluate(() => document.body.dataset.state), "done");
  await page.close();
});

for (const stage of ["refine", "tv"]) {
  test(`Cancel during ${stage} dispatches no further part and the page stays usable`, async () => {
    const page = await context.newPage();
    page.on("pageerror", (e) => consoleErrors.push(e.message));
    // Record the step of every part the page sends its workers.
    await page.addInitScript(() => {
      window.__parts = [];
      const post = Worker.prototype.postMessage;
      Worker.prototype.postMessage = function (message, ...rest) {
        if (message?.op === "part") window.__parts.push(message.step);
        return post.call(this, message, ...rest);
      };
    });
    // 512² views over 2 workers: 2 refine bands (one per worker), then 2 median row bands
    // and 16 TV tiles, so parts are still to come when Cancel comes.
    await page.goto(`${server.origin}/?scene=slanted&size=512&grid=9&workers=2`);
    await page.waitForFunction(() => document.body.dataset.state === "idle" && !document.getElementById("run").disabled, null, { timeout: 120_000 });
    await page.click("#run");
    // The schedule's step of each stage, from the core (the page has initialised the
    // package on its thread).
    const steps = await page.evaluate(async () => {
      const lf = await import("./pkg/lfdepth_wasm.js");
      const run = new lf.Run({ rows: 9, cols: 9, width: 512, height: 512, channels: 3 }, {}, 2);
      const names = Array.from({ length: run.steps }, (_, k) => run.stage(k));
      run.free();
      return names;
    });
    const step = (name) => steps.indexOf(name);
    // Cancel once the stage's first parts are out.
    await page.waitForFunction((k) => window.__parts.includes(k), step(stage), { timeout: 120_000, polling: 5 });
    // Cancel and count the parts sent so far in one turn of the page's event loop.
    const sent = await page.evaluate(() => {
      document.getElementById("cancel").click();
      return window.__parts.length;
    });
    await settled(page, 10_000);
    assert.equal(await page.evaluate(() => document.body.dataset.state), "cancelled");
    assert.equal(await page.textContent("#progress-text"), "cancelled");
    // The parts in flight finish in their workers; nothing more is dispatched.
    await page.waitForTimeout(1500);
    const after = await page.evaluate(() => window.__parts);
    assert.equal(after.length, sent, after.join());
    if (stage === "refine") assert.ok(!after.includes(step("median")) && !after.includes(step("tv")), after.join());
    else assert.ok(after.filter((k) => k === step("tv")).length < 16, after.join());
    assert.equal(await page.isDisabled("#run"), false);
    assert.equal(await page.isDisabled("#cancel"), true);
    await page.click("#run");
    await page.waitForFunction(() => document.body.dataset.state === "running");
    await settled(page);
    assert.equal(await page.evaluate(() => document.body.dataset.state), "done", await page.textContent("#error"));
    assert.ok(await page.evaluate(() => window.__parts.length) > sent);
    await page.close();
  });
}

test("dropped HCI-named views with a ground-truth PFM load, estimate and score", async () => {
  const page = await open("");
  await page.waitForFunction(() => document.body.dataset.state === "idle");
  // Encode a synthetic 5×5 light field as input_CamNNN.png files plus gt_disp_lowres.pfm
  // in the page, then drop them as a user would.
  await page.evaluate(async () => {
    const lf = await import("./pkg/lfdepth_wasm.js");
    const { writePfm } = await import("./formats.js");
    const n = 64;
    const scene = lf.synthesize({ scene: "planes", rows: 5, cols: 5, width: n, height: n, seed: 2 });
    const views = scene.views;
    const transfer = new DataTransfer();
    for (let i = 0; i < 25; i++) {
      const canvas = new OffscreenCanvas(n, n);
      const ctx = canvas.getContext("2d");
      const image = ctx.createImageData(n, n);
      for (let p = 0; p < n * n; p++) {
        image.data.set(views.subarray((i * n * n + p) * 3, (i * n * n + p) * 3 + 3), 4 * p);
        image.data[4 * p + 3] = 255;
      }
      ctx.putImageData(image, 0, 0);
      const blob = await canvas.convertToBlob({ type: "image/png" });
      transfer.items.add(new File([blob], `input_Cam${String(i).padStart(3, "0")}.png`, { type: "image/png" }));
    }
    transfer.items.add(new File([writePfm(scene.groundTruth, n, n)], "gt_disp_lowres.pfm"));
    document.getElementById("drop").dispatchEvent(new DragEvent("drop", { dataTransfer: transfer, bubbles: true, cancelable: true }));
  });
  await page.waitForFunction(() => /5×5 views of 64×64, with ground truth/.test(document.getElementById("lf-info").textContent), null, { timeout: 60_000 });
  await page.click("#run");
  await settled(page);
  const badpix = Number(await page.getAttribute("#scores", "data-badpix007"));
  assert.equal(await page.evaluate(() => document.body.dataset.state), "done");
  // PNG round trip is lossless, so this is the estimate of the synthetic scene itself.
  assert.ok(badpix < 30, `BadPix(0.07) ${badpix}`);
  await page.close();
});

test("images with unknown names wait for the user to confirm the grid", async () => {
  const page = await open("");
  await page.waitForFunction(() => document.body.dataset.state === "idle");
  await page.evaluate(async () => {
    const transfer = new DataTransfer();
    for (let i = 0; i < 15; i++) {
      const canvas = new OffscreenCanvas(32, 24);
      const ctx = canvas.getContext("2d");
      ctx.fillStyle = `rgb(${i * 16}, 90, 200)`;
      ctx.fillRect(0, 0, 32, 24);
      const blob = await canvas.convertToBlob({ type: "image/png" });
      transfer.items.add(new File([blob], `shot${i + 1}.png`, { type: "image/png" }));
    }
    document.getElementById("drop").dispatchEvent(new DragEvent("drop", { dataTransfer: transfer, bubbles: true, cancelable: true }));
  });
  await page.waitForSelector("#grid-form:not([hidden])");
  assert.match(await page.textContent("#grid-note"), /15 views in name order/);
  await page.fill("#grid-rows", "3");
  await page.fill("#grid-cols", "5");
  await page.click("#grid-form button");
  await page.waitForFunction(() => /3×5 views of 32×24/.test(document.getElementById("lf-info").textContent));
  assert.equal(await page.isHidden("#grid-form"), true);
  await page.close();
});

test("no console errors and no request beyond the page's own files", () => {
  assert.deepEqual(consoleErrors, []);
  assert.deepEqual(foreign, []);
  for (const path of server.requests) assert.match(path, /^\/(|index\.html|[\w-]+\.(js|css)|pkg\/lfdepth_wasm(_bg\.wasm|\.js))$/, path);
});
