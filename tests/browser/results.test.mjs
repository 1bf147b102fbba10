// The page's results as a user sees them, in Debian's headless chromium (playwright-core):
// an HCI-layout folder picked as a whole (ground truth by name, other files ignored and
// named, the light field named by its folder, the score equal to the CLI's), the 3D
// view, the maps after each stage, the EPI slope line, keyboard focus and a phone-wide
// screen. Screenshots go to tests/artifacts/.
import { test, before, after } from "node:test";
import assert from "node:assert/strict";
import { execFileSync } from "node:child_process";
import { mkdtempSync, mkdirSync, existsSync, rmSync, writeFileSync, copyFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { dirname, join, resolve } from "node:path";
import { fileURLToPath } from "node:url";
import { chromium } from "playwright-core";
import { serve } from "./serve.mjs";

const root = process.env.LFDEPTH_ROOT ?? resolve(dirname(fileURLToPath(import.meta.url)), "../..");
const web = join(root, "web");
const artifacts = join(root, "tests/artifacts");
const executablePath = process.env.CHROMIUM_PATH ?? "/usr/bin/chromium";
const cli = process.env.LFDEPTH_BIN ?? join(root, "target/release/lfdepth");

let server, context, profile, scratch;
const consoleErrors = [];

before(async () => {
  assert.ok(existsSync(join(web, "pkg/lfdepth_wasm_bg.wasm")), "web/pkg is missing: run wasm-pack build wasm --target web --out-dir ../web/pkg");
  server = await serve(web);
  profile = mkdtempSync(join(tmpdir(), "lfdepth-chromium-"));
  scratch = mkdtempSync(join(tmpdir(), "lfdepth-results-"));
  context = await chromium.launchPersistentContext(profile, {
    executablePath,
    headless: true,
    // WebGL2 without a GPU: ANGLE on SwiftShader, Chromium's software renderer (Debian's
    // chromium falls back to it by itself; newer builds want it asked for explicitly).
    args: ["--headless", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--disable-background-networking", "--disable-component-update", "--no-first-run", "--disable-sync", "--disable-quic"],
    viewport: { width: 1280, height: 1000 },
  });
  context.on("console", (message) => {
    if (message.type() === "error") consoleErrors.push(message.text());
  });
  context.on("weberror", (error) => consoleErrors.push(String(error.error())));
});

after(async () => {
  await context?.close();
  await server?.close();
  for (const dir of [profile, scratch]) if (dir) rmSync(dir, { recursive: true, force: true });
});

async function open(query = "", viewport) {
  const page = await context.newPage();
  if (viewport) await page.setViewportSize(viewport);
  page.on("pageerror", (e) => consoleErrors.push(e.message));
  await page.goto(`${server.origin}/${query}`);
  // Started (a query with `run` goes on to estimate at once).
  await page.waitForFunction(() => !["starting", undefined].includes(document.body.dataset.state), null, { timeout: 60_000 });
  return page;
}

const settled = (page, timeout = 240_000) =>
  page.waitForFunction(() => ["done", "error", "cancelled"].includes(document.body.dataset.state), null, { timeout, polling: 100 });

/** A gray little-endian PFM (stored bottom row first) of `f(x, y)`. */
function pfm(width, height, f) {
  const header = Buffer.from(`Pf\n${width} ${height}\n-1.0\n`);
  const data = Buffer.alloc(width * height * 4);
  for (let y = 0; y < height; y++) for (let x = 0; x < width; x++) data.writeFloatLE(f(x, y), 4 * ((height - 1 - y) * width + x));
  return Buffer.concat([header, data]);
}

/** An HCI training folder as published, built from `lfdepth synth`: the views,
 * gt_disp_lowres.pfm and parameters.cfg, plus a depth PFM (metres: far from the
 * disparities), a high-resolution disparity PFM of another size, masks and an
 * object-id image (PNGs of the views' size, so that counting them as views would break
 * the grid) and a stray text file. */
function hciFolder(scene, size) {
  const dataset = join(scratch, "dataset");
  const dir = join(dataset, scene);
  execFileSync(cli, ["synth", "--scene", scene, "--grid", "5x5", "--size", String(size), "--seed", "3", "--disparity-range=-0.6..0.6", "--out", dir], { stdio: "pipe" });
  writeFileSync(join(dir, "gt_depth_lowres.pfm"), pfm(size, size, (x, y) => 4 + 0.001 * (x + y)));
  writeFileSync(join(dir, "gt_disp_highres.pfm"), pfm(2 * size, 2 * size, () => 0));
  for (const name of ["valid_mask.png", "mask_boundary.png", "object_ids_lowres.png"]) copyFileSync(join(dir, "input_Cam000.png"), join(dir, name));
  writeFileSync(join(dir, "notes.txt"), "not a view\n");
  // The camera of an HCI scene (cotton's, its sensor scaled to these views: the same
  // focal length in pixels), for a metric 3D view.
  writeFileSync(
    join(dir, "parameters.cfg"),
    `[intrinsics]\nfocal_length_mm = 100.0\nimage_resolution_x_px = ${size}\nimage_resolution_y_px = ${size}\nsensor_size_mm = ${(35 * size) / 512}\n\n` +
      "[extrinsics]\nnum_cams_x = 5\nnum_cams_y = 5\nbaseline_mm = 25.0\nfocus_distance_m = 4.25\n\n[meta]\ndisp_min = -1.5\ndisp_max = 1.5\n",
  );
  return { dataset, dir };
}

test("a picked HCI folder: disparity ground truth by name, other files named as ignored, the folder's name, the CLI's score", async () => {
  assert.ok(existsSync(cli), `${cli} is missing: cargo build --release -p lfdepth-cli (or set LFDEPTH_BIN)`);
  const { dataset, dir } = hciFolder("occlusion", 96);
  mkdirSync(artifacts, { recursive: true });
  // The CLI's score of its own estimate of the same folder (same default parameters).
  const expected = JSON.parse(execFileSync(cli, ["eval", "--dataset", dataset, "--json", "--threads", "1"], { encoding: "utf8", stdio: ["ignore", "pipe", "pipe"] })).scenes[0];
  const page = await open("?workers=2");
  // As a user picks a folder: every file under it, with its relative path.
  await page.setInputFiles("#pick-folder", dir);
  await page.waitForFunction(() => document.getElementById("lf-info").dataset.name !== undefined, null, { timeout: 60_000 });
  const info = await page.evaluate(() => ({ ...document.getElementById("lf-info").dataset, text: document.getElementById("lf-info").textContent }));
  console.log("light field:", info.text);
  assert.equal(info.name, "occlusion");
  assert.equal(info.groundTruth, "gt_disp_lowres.pfm");
  assert.deepEqual(info.ignored.split("/").sort(), ["gt_depth_lowres.pfm", "gt_disp_highres.pfm", "mask_boundary.png", "notes.txt", "object_ids_lowres.png", "valid_mask.png"]);
  assert.match(info.text, /^occlusion: 5×5 views of 96×96, with ground truth gt_disp_lowres\.pfm, camera from parameters\.cfg\. Ignored: .*gt_depth_lowres\.pfm/);
  await page.click("#run");
  await settled(page);
  const scores = await page.evaluate(() => ({
    state: document.body.dataset.state,
    error: document.getElementById("error").textContent,
    badpix007: Number(document.getElementById("scores").dataset.badpix007),
    mse100: Number(document.getElementById("scores").dataset.mse100),
    text: document.getElementById("scores").textContent,
  }));
  console.log("page:", scores.text, "— CLI:", JSON.stringify(expected));
  assert.equal(scores.state, "done", scores.error);
  // The same map scored by the same metrics: equal to rounding of the JSON numbers.
  assert.ok(Math.abs(scores.badpix007 - expected.badpix007) < 1e-9, `page ${scores.badpix007}, CLI ${expected.badpix007}`);
  assert.ok(Math.abs(scores.mse100 - expected.mse100) < 1e-6 * Math.max(1, expected.mse100), `page ${scores.mse100}, CLI ${expected.mse100}`);
  assert.ok(scores.badpix007 < 30, scores.text);
  // parameters.cfg gives the camera: the 3D view is metric.
  assert.equal(await page.getAttribute("#surface", "data-metric"), "true");
  assert.match(info.text, /camera from parameters\.cfg/);
  await page.locator("#surface").screenshot({ path: join(artifacts, "surface-metric.png") });
  await page.close();
});

/** Pixels of a canvas (WebGL ones keep their drawing buffer) as RGBA bytes. */
const pixels = (page, id) =>
  page.evaluate((id) => {
    const source = document.getElementById(id);
    const copy = new OffscreenCanvas(source.width, source.height);
    const ctx = copy.getContext("2d");
    ctx.drawImage(source, 0, 0);
    return Array.from(ctx.getImageData(0, 0, source.width, source.height).data);
  }, id);

/** Share of pixels whose colour differs between two RGBA arrays by more than 8 levels. */
function changed(a, b) {
  let n = 0;
  for (let p = 0; p < a.length; p += 4) if (Math.abs(a[p] - b[p]) + Math.abs(a[p + 1] - b[p + 1]) + Math.abs(a[p + 2] - b[p + 2]) > 8) n++;
  return n / (a.length / 4);
}

test("the maps after each stage, their errors, the EPI slope line and the 3D view", async () => {
  const page = await open("?scene=occlusion&size=128&grid=9&workers=2&run");
  await settled(page);
  assert.equal(await page.evaluate(() => document.body.dataset.state), "done", await page.textContent("#error"));

  // Stages: the labels come from the wasm Run; the last map is the result.
  const labels = await page.$$eval("#snapshot option", (options) => options.map((o) => o.textContent));
  console.log("maps after:", labels.join(" | "));
  assert.deepEqual(labels, ["plane-sweep estimate", "refined", "refilled at depth steps", "edge-snapping median", "TV (final)"]);
  assert.equal(await page.inputValue("#snapshot"), String(labels.length - 1));
  const rows = await page.$$eval("#stage-scores tbody tr", (trs) => trs.map((tr) => ({ text: tr.textContent, badpix: Number(tr.dataset.badpix007) })));
  console.log("per stage:", rows.map((r) => r.text).join("; "));
  assert.equal(rows.length, labels.length);
  assert.equal(rows.at(-1).badpix, Number(await page.getAttribute("#scores", "data-badpix007")));
  // The stages improve on the plane sweep's estimate on this scene.
  assert.ok(rows.at(-1).badpix < rows[0].badpix, JSON.stringify(rows));
  // The first snapshot is the start's result itself (bit for bit the estimator run
  // with stage "epi", the plane sweep by default), and the last is the estimate.
  const exact = await page.evaluate(async () => {
    const lf = await import("./pkg/lfdepth_wasm.js");
    const { WorkerPool } = await import("./pool.js");
    const engine = await import("./engine.js");
    const module = await WebAssembly.compileStreaming(fetch("./pkg/lfdepth_wasm_bg.wasm"));
    lf.initSync({ module });
    const spec = { scene: "occlusion", rows: 5, cols: 5, width: 64, height: 64, channels: 3, seed: 5 };
    const views = lf.synthesize(spec).views;
    const shape = { rows: 5, cols: 5, width: 64, height: 64, channels: 3 };
    const same = (a, b) => a.length === b.length && a.every((v, i) => Object.is(v, b[i]));
    const pool = await WorkerPool.create(module, 2);
    const r = await engine.estimate(pool, { views, shape }, {}, { onProgress: () => {}, signal: new AbortController().signal });
    pool.terminate();
    const epi = new lf.Estimator(views, shape, { stage: "epi" }).estimate().disparity;
    const full = new lf.Estimator(views, shape, {}).estimate().disparity;
    return { epi: same(r.snapshots[0].disparity, epi), last: same(r.snapshots.at(-1).disparity, full), result: same(r.disparity, full), differ: !same(epi, full) };
  });
  assert.deepEqual(exact, { epi: true, last: true, result: true, differ: true });
  // Choosing a stage redraws the disparity and the error map.
  const [finalMap, finalError] = [await pixels(page, "disparity"), await pixels(page, "error-map")];
  await page.selectOption("#snapshot", "0");
  assert.equal(await page.getAttribute("#disparity", "data-snapshot"), "plane-sweep estimate");
  assert.equal(await page.textContent("#err-stage"), "plane-sweep estimate");
  assert.ok(changed(finalMap, await pixels(page, "disparity")) > 0.01);
  assert.ok(changed(finalError, await pixels(page, "error-map")) > 0.01);
  mkdirSync(artifacts, { recursive: true });
  await page.locator("#disparity").locator("..").screenshot({ path: join(artifacts, "stage-epi.png") });
  await page.locator("#error-map").locator("..").screenshot({ path: join(artifacts, "stage-epi-error.png") });
  await page.selectOption("#snapshot", String(labels.length - 1));

  // The EPI line: through the picked pixel with the slope of its estimated disparity.
  const epiBefore = await pixels(page, "epi-h");
  const box = await page.locator("#centre").boundingBox();
  await page.locator("#centre").click({ position: { x: box.width * 0.3, y: box.height * 0.5 } });
  const line = await page.evaluate(() => ({ ...document.getElementById("epi-h").dataset, where: document.getElementById("epi-where").textContent }));
  console.log("EPI:", line.where, line.line);
  const picked = /^row (\d+), column (\d+): disparity -?\d+\.\d{3} px/.exec(line.where);
  assert.ok(picked, line.where);
  const x = Number(picked[2]), d = Number(line.disparity);
  assert.ok(Math.abs(x - 0.3 * 128) <= 1 && Math.abs(Number(picked[1]) - 64) <= 1, line.where);
  const [first, last] = line.line.split(",").map(Number);
  // View 0 of 9 lies 4 columns left of the centre: the point is at x + 4d there.
  assert.ok(Math.abs(first - (x + 4 * d)) < 1e-6 && Math.abs(last - (x - 4 * d)) < 1e-6, `${line.line} for d = ${d}`);
  const epiAfter = await pixels(page, "epi-h");
  assert.ok(changed(epiBefore, epiAfter) > 0, "the line is drawn");
  // The keyboard moves the pixel too.
  await page.focus("#centre");
  await page.keyboard.press("ArrowRight");
  assert.match(await page.textContent("#epi-where"), new RegExp(`column ${x + 1}:`));
  await page.locator("#epi-h").locator("..").screenshot({ path: join(artifacts, "epi-line.png") });

  // The 3D view: drawn, and turned by a drag and by the keyboard.
  const surface = page.locator("#surface");
  await surface.scrollIntoViewIfNeeded();
  assert.ok(Number(await surface.getAttribute("data-triangles")) > 10_000);
  await page.waitForFunction(() => Number(document.getElementById("surface").dataset.drawn) > 0);
  const background = (rgba) => {
    let n = 0;
    for (let p = 0; p < rgba.length; p += 4) if (Math.abs(rgba[p] - 236) + Math.abs(rgba[p + 1] - 239) + Math.abs(rgba[p + 2] - 243) < 6) n++;
    return n / (rgba.length / 4);
  };
  const front = await pixels(page, "surface");
  console.log(`3D view: ${(100 * (1 - background(front))).toFixed(1)} % of the canvas covered`);
  assert.ok(background(front) < 0.8, "the surface covers the canvas");
  await surface.screenshot({ path: join(artifacts, "surface-front.png") });
  const drawn = Number(await surface.getAttribute("data-drawn"));
  await surface.hover();
  const s = await surface.boundingBox();
  await page.mouse.move(s.x + s.width / 2, s.y + s.height / 2);
  await page.mouse.down();
  for (let k = 1; k <= 10; k++) await page.mouse.move(s.x + s.width / 2 + 12 * k, s.y + s.height / 2 + 4 * k);
  await page.mouse.up();
  await page.waitForFunction((n) => Number(document.getElementById("surface").dataset.drawn) > n, drawn);
  const turned = await pixels(page, "surface");
  console.log(`3D view: ${(100 * changed(front, turned)).toFixed(1)} % of the pixels changed after the drag`);
  assert.ok(changed(front, turned) > 0.05);
  assert.ok(background(turned) < 0.95);
  await surface.screenshot({ path: join(artifacts, "surface-turned.png") });
  // Each key redraws at the next frame: wait for the frame, then compare.
  const press = async (key) => {
    const before = Number(await surface.getAttribute("data-drawn"));
    await page.keyboard.press(key);
    await page.waitForFunction((n) => Number(document.getElementById("surface").dataset.drawn) > n, before);
  };
  await page.focus("#surface");
  await press("0");
  assert.ok(changed(front, await pixels(page, "surface")) < 0.01, "0 resets the view");
  await press("ArrowLeft");
  await press("-");
  assert.ok(changed(front, await pixels(page, "surface")) > 0.05, "the keys turn and zoom");
  await page.screenshot({ path: join(artifacts, "results.png"), fullPage: true });
  await page.close();
});

test("every control is reached with Tab and shows its focus", async () => {
  const page = await open("?scene=planes&size=128&grid=5&workers=1&run");
  await settled(page);
  const reached = [];
  for (let k = 0; k < 60; k++) {
    await page.keyboard.press("Tab");
    const focus = await page.evaluate(() => {
      const el = document.activeElement;
      const style = getComputedStyle(el);
      return { id: el.id || el.getAttribute("name") || el.tagName, outline: style.outlineStyle, width: parseFloat(style.outlineWidth) };
    });
    if (focus.id === "BODY") break;
    reached.push(focus);
  }
  console.log("Tab order:", reached.map((f) => f.id).join(" "));
  const ids = reached.map((f) => f.id);
  for (const id of ["drop", "pick-files", "pick-folder", "synth-scene", "synth-go", "preset", "workers", "run", "centre", "snapshot", "surface"]) assert.ok(ids.includes(id), `${id} is not reached by Tab`);
  // A visible outline on every focused control (the hidden file inputs show theirs on
  // their label).
  for (const f of reached.filter((f) => !f.id.startsWith("pick-"))) assert.ok(f.outline !== "none" && f.width >= 2, JSON.stringify(f));
  const label = await page.evaluate(() => {
    document.getElementById("pick-folder").focus({ focusVisible: true });
    return getComputedStyle(document.getElementById("pick-folder").parentElement).outlineStyle;
  });
  assert.notEqual(label, "none");
  // Enter on the drop zone opens the file picker (clicks its input).
  await page.evaluate(() => document.getElementById("pick-files").addEventListener("click", (e) => {
    e.preventDefault();
    window.__picked = true;
  }));
  await page.focus("#drop");
  await page.keyboard.press("Enter");
  assert.equal(await page.evaluate(() => window.__picked), true);
  // What a keyboard user sees: the focused control ringed.
  await page.focus("#centre");
  await page.keyboard.press("Shift+Tab");
  await page.keyboard.press("Tab");
  mkdirSync(artifacts, { recursive: true });
  await page.locator("#centre").locator("..").screenshot({ path: join(artifacts, "focus-centre.png") });
  await page.focus("#run");
  await page.keyboard.press("Enter");
  await page.waitForFunction(() => document.body.dataset.state === "running" || document.body.dataset.state === "done");
  await settled(page);
  assert.equal(await page.evaluate(() => document.body.dataset.state), "done");
  await page.close();
});

test("usable on a 390 px wide phone screen", async () => {
  const page = await open("?scene=occlusion&size=128&grid=5&workers=1&run", { width: 390, height: 844 });
  await settled(page);
  const layout = await page.evaluate(() => ({
    scroll: document.documentElement.scrollWidth,
    // Every control and canvas lies within the screen's width.
    outside: [...document.querySelectorAll("button, select, input:not([type=file]), canvas, .button")]
      .filter((el) => el.offsetParent !== null)
      .map((el) => ({ id: el.id || el.textContent.trim().slice(0, 20), right: el.getBoundingClientRect().right }))
      .filter((r) => r.right > 390.5),
  }));
  assert.ok(layout.scroll <= 390, `the page scrolls sideways: ${layout.scroll} px wide`);
  assert.deepEqual(layout.outside, []);
  mkdirSync(artifacts, { recursive: true });
  await page.screenshot({ path: join(artifacts, "phone-390.png"), fullPage: true });
  // What the phone shows at once: the top, and the results further down.
  await page.screenshot({ path: join(artifacts, "phone-390-top.png") });
  await page.locator("#disparity").scrollIntoViewIfNeeded();
  await page.screenshot({ path: join(artifacts, "phone-390-disparity.png") });
  await page.locator("#surface").scrollIntoViewIfNeeded();
  await page.screenshot({ path: join(artifacts, "phone-390-surface.png") });
  await page.close();
});

test("no console errors", () => {
  assert.deepEqual(consoleErrors, []);
});
