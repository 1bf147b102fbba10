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
    // WebGL2 without a GPU: ANGLE on SwiftShader, Chromium's software renderer.
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
  await page.waitForFunction(() => document.body.dataset.state === "idle");
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
  execFileSync(cli, ["synth", "--scene", scene, "--grid", "5x5", "--size", String(size), "--seed", "3", "--out", dir], { stdio: "pipe" });
  writeFileSync(join(dir, "gt_depth_lowres.pfm"), pfm(size, size, (x, y) => 4 + 0.001 * (x + y)));
  writeFileSync(join(dir, "gt_disp_highres.pfm"), pfm(2 * size, 2 * size, () => 0));
  for (const name of ["valid_mask.png", "mask_boundary.png", "object_ids_lowres.png"]) copyFileSync(join(dir, "input_Cam000.png"), join(dir, name));
  writeFileSync(join(dir, "notes.txt"), "not a view\n");
  return { dataset, dir };
}

test("a picked HCI folder: disparity ground truth by name, other files named as ignored, the folder's name, the CLI's score", async () => {
  assert.ok(existsSync(cli), `${cli} is missing: cargo build --release -p lfdepth-cli (or set LFDEPTH_BIN)`);
  const { dataset, dir } = hciFolder("occlusion", 96);
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
  assert.match(info.text, /^occlusion: 5×5 views of 96×96, with ground truth gt_disp_lowres\.pfm\. Ignored: .*gt_depth_lowres\.pfm/);
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
  await page.close();
});

test("no console errors", () => {
  assert.deepEqual(consoleErrors, []);
});
