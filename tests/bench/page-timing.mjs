// End-to-end time of the page (generate a synthetic scene in workers, then estimate in
// workers) in Debian's headless chromium, the longest the page's own thread went without
// running a 10 ms timer while estimating (how long the page froze at worst), per stage
// shown in the progress text when the gap ended, and the size of the .wasm.
//   node tests/bench/page-timing.mjs [size] [grid] [workers]
import { gzipSync } from "node:zlib";
import { readFileSync, mkdtempSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { chromium } from "playwright-core";
import { serve } from "../browser/serve.mjs";
import { root } from "../node/pkg.mjs";

const [size = "512", grid = "9", workers = ""] = process.argv.slice(2);
const web = join(root, "web");
const wasm = readFileSync(join(web, "pkg/lfdepth_wasm_bg.wasm"));
const server = await serve(web);
const profile = mkdtempSync(join(tmpdir(), "lfdepth-bench-"));
const context = await chromium.launchPersistentContext(profile, {
  executablePath: process.env.CHROMIUM_PATH ?? "/usr/bin/chromium",
  headless: true,
  args: ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update", "--no-first-run"],
});
try {
  const page = await context.newPage();
  // The longest gap between two ticks of a 10 ms timer while the page estimates.
  await page.addInitScript(() => {
    window.__gaps = {};
    let last = performance.now();
    setInterval(() => {
      const now = performance.now();
      if (document.body?.dataset.state === "running") {
        const stage = (document.getElementById("progress-text")?.textContent ?? "").split(" — ")[0];
        window.__gaps[stage] = Math.max(window.__gaps[stage] ?? 0, Math.round(now - last));
      }
      last = now;
    }, 10);
  });
  const query = `?scene=planes&size=${size}&grid=${grid}${workers ? `&workers=${workers}` : ""}&run`;
  const start = Date.now();
  await page.goto(`${server.origin}/${query}`);
  await page.waitForFunction(() => ["done", "error"].includes(document.body.dataset.state), null, { timeout: 600_000 });
  const wall = Date.now() - start;
  const report = await page.evaluate(() => ({
    state: document.body.dataset.state,
    workers: Number(document.getElementById("workers").value),
    hardwareConcurrency: navigator.hardwareConcurrency,
    estimate_ms: Number(document.getElementById("timings").dataset.totalMs),
    stages: [...document.querySelectorAll("#timings tr")].map((r) => r.textContent),
    badpix007: Number(document.getElementById("scores").dataset.badpix007),
    longest_main_thread_gap_ms: Math.max(0, ...Object.values(window.__gaps)),
    longest_gap_by_stage_ms: window.__gaps,
  }));
  console.log(JSON.stringify({ size: Number(size), grid: Number(grid), load_generate_estimate_ms: wall, ...report,
    wasm_bytes: wasm.length, wasm_gzip_bytes: gzipSync(wasm, { level: 9 }).length }));
} finally {
  await context.close();
  await server.close();
  rmSync(profile, { recursive: true, force: true });
}
