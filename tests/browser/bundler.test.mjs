// The npm package through a bundler, as a web app would use it: a tiny consumer in an
// empty project that installed the packed package (tests/node/packed.mjs) is bundled for
// the browser by esbuild and run in Debian's headless chromium (playwright-core, never a
// downloaded browser). It synthesizes a small light field and estimates its disparity in
// the page; the map equals, bit for bit, the one the installed package computes in Node
// on the same light field.
//
// esbuild leaves wasm-bindgen's `new URL("lfdepth_wasm_bg.wasm", import.meta.url)` alone,
// so the consumer imports the module's URL (`lfdepth/lfdepth_wasm_bg.wasm` with esbuild's
// `file` loader) and hands it to `init`, as the package's README says.
import { test, before, after } from "node:test";
import assert from "node:assert/strict";
import { mkdirSync, mkdtempSync, readFileSync, readdirSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { pathToFileURL } from "node:url";
import * as esbuild from "esbuild";
import { chromium } from "playwright-core";
import { installPacked } from "../node/packed.mjs";
import { serve } from "./serve.mjs";

const executablePath = process.env.CHROMIUM_PATH ?? "/usr/bin/chromium";

/** The light field both sides estimate: small, with every stage running. */
const SPEC = { scene: "mixed", rows: 5, cols: 5, width: 48, height: 40, channels: 3, seed: 3 };

let work, project, server, browser;

before(async () => {
  work = mkdtempSync(join(tmpdir(), "lfdepth-bundler-"));
  ({ project } = installPacked(work));
});

after(async () => {
  await browser?.close();
  await server?.close();
  if (work) rmSync(work, { recursive: true, force: true });
});

/** The disparity of `SPEC` as the installed package computes it in Node. */
async function nodeDisparity() {
  const lf = await import(pathToFileURL(join(project, "node_modules/lfdepth/node.js")).href);
  const field = lf.synthesize(SPEC);
  const { rows, cols, width, height, channels } = field;
  const estimator = new lf.Estimator(field.views, { rows, cols, width, height, channels });
  const result = estimator.estimate();
  estimator.free();
  return { disparity: result.disparity, stages: result.timings.map((t) => t.stage) };
}

test("esbuild bundles a consumer of the package for the browser, and its map there equals Node's", async () => {
  const app = join(project, "app.js");
  writeFileSync(app, `
    import init, { Estimator, synthesize, version } from "lfdepth";
    import wasmUrl from "lfdepth/lfdepth_wasm_bg.wasm";

    try {
      await init({ module_or_path: wasmUrl });
      const field = synthesize(${JSON.stringify(SPEC)});
      const { rows, cols, width, height, channels } = field;
      const result = new Estimator(field.views, { rows, cols, width, height, channels }).estimate();
      window.outcome = {
        version: version(),
        disparity: Array.from(result.disparity),
        stages: result.timings.map((t) => t.stage),
      };
    } catch (e) {
      window.outcome = { error: String(e && e.stack || e) };
    }
  `);
  const out = join(work, "site");
  mkdirSync(out);
  const built = await esbuild.build({
    entryPoints: [app],
    absWorkingDir: project,
    bundle: true,
    format: "esm",
    platform: "browser",
    target: "es2022",
    outdir: out,
    loader: { ".wasm": "file" },
    assetNames: "[name]-[hash]",
    logLevel: "silent",
  });
  assert.deepEqual(built.errors, []);
  assert.deepEqual(built.warnings, [], built.warnings.map((w) => w.text).join("\n"));
  const files = readdirSync(out).sort();
  assert.ok(files.includes("app.js"), files.join(", "));
  const wasm = files.filter((f) => f.endsWith(".wasm"));
  assert.equal(wasm.length, 1, `one .wasm beside the bundle, found ${files.join(", ")}`);
  // The bundle is the browser module: nothing of Node's entry (node:fs) came along.
  const bundle = readFileSync(join(out, "app.js"), "utf8");
  assert.ok(!bundle.includes("node:fs"), "the bundle imports node:fs");
  assert.match(bundle, /lfdepth_wasm_bg-[\w]+\.wasm/);
  writeFileSync(join(out, "index.html"), `<!doctype html><meta charset="utf-8"><title>lfdepth bundled</title><link rel="icon" href="data:,"><script type="module" src="app.js"></script>`);

  server = await serve(out);
  browser = await chromium.launch({ executablePath, headless: true, args: ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--no-first-run"] });
  const page = await browser.newPage();
  const errors = [];
  page.on("pageerror", (e) => errors.push(e.message));
  page.on("console", (m) => m.type() === "error" && errors.push(m.text()));
  await page.goto(`${server.origin}/index.html`);
  await page.waitForFunction(() => window.outcome !== undefined, null, { timeout: 120_000, polling: 100 });
  const outcome = await page.evaluate(() => window.outcome);
  assert.equal(outcome.error, undefined, outcome.error);
  assert.deepEqual(errors, []);
  assert.ok(server.requests.includes(`/${wasm[0]}`), `the page fetched ${server.requests.join(", ")}`);

  const expected = await nodeDisparity();
  assert.deepEqual(outcome.stages, expected.stages);
  assert.ok(outcome.stages.includes("tv"), outcome.stages.join(", "));
  assert.equal(outcome.disparity.length, SPEC.width * SPEC.height);
  const inBrowser = new Float32Array(outcome.disparity);
  let differing = 0;
  for (let i = 0; i < inBrowser.length; i++) if (!Object.is(inBrowser[i], expected.disparity[i])) differing++;
  assert.equal(differing, 0, `${differing} of ${inBrowser.length} pixels differ between the browser and Node`);
  // A map worth comparing: not constant.
  assert.ok(Math.max(...inBrowser) - Math.min(...inBrowser) > 0.5);
});
