// End-to-end time of the page (generate a synthetic scene in workers, then estimate in
// workers) in Debian's headless chromium, the longest the page's own thread went without
// running a 10 ms timer while estimating (how long the page froze at worst), per stage
// shown in the progress text when the gap ended, and the size of the .wasm. `isolated`
// serves the page with COOP/COEP (cross-origin isolated: the workers read the views from
// a SharedArrayBuffer); `transport` says which path ran,
// `unaccounted_ms` the estimate's time outside every stage row, `estimate_cpu_ms` the CPU
// time all the browser's processes spent while it estimated (Linux /proc); `again` also
// times a second estimate of the same scene with another λ (`second`); `settled` clicks
// Estimate only once the page has handed the views to its workers (else at once, and
// the estimate waits for that hand-over).
//   node tests/bench/page-timing.mjs [size] [grid] [workers] [plain|isolated] [again] [settled]
import { gzipSync } from "node:zlib";
import { readFileSync, readdirSync, mkdtempSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import { chromium } from "playwright-core";
import { serve } from "../browser/serve.mjs";
import { root } from "../node/pkg.mjs";

/** User + system CPU time (ms) of this process's descendants (the browser's processes),
 * from /proc (Linux); NaN elsewhere. */
function browserCpuMs() {
  try {
    const stats = readdirSync("/proc")
      .filter((d) => /^\d+$/.test(d))
      .map((pid) => {
        try {
          // Fields after the command name: state ppid … utime (14) stime (15).
          const text = readFileSync(`/proc/${pid}/stat`, "utf8");
          const f = text.slice(text.lastIndexOf(")") + 2).split(" ");
          return { pid: Number(pid), ppid: Number(f[1]), ticks: Number(f[11]) + Number(f[12]) };
        } catch {
          return null;
        }
      })
      .filter(Boolean);
    const ours = new Set([process.pid]);
    for (let grew = true; grew; ) {
      grew = false;
      for (const p of stats) if (!ours.has(p.pid) && ours.has(p.ppid)) grew = ours.add(p.pid) && true;
    }
    return stats.filter((p) => p.pid !== process.pid && ours.has(p.pid)).reduce((sum, p) => sum + p.ticks, 0) * 10; // USER_HZ = 100
  } catch {
    return NaN;
  }
}

const [size = "512", grid = "9", workers = "", ...flags] = process.argv.slice(2);
const web = join(root, "web");
const wasm = readFileSync(join(web, "pkg/lfdepth_wasm_bg.wasm"));
const server = await serve(web, { isolated: flags.includes("isolated") });
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
  const query = `?scene=planes&size=${size}&grid=${grid}${workers ? `&workers=${workers}` : ""}`;
  const start = Date.now();
  await page.goto(`${server.origin}/${query}`);
  await page.waitForFunction(() => document.body.dataset.state === "idle" && !document.getElementById("run").disabled, null, { timeout: 600_000 });
  // `settled`: click only once the page has handed the views to its workers (as a user
  // who looks at the light field first; a page without that step reports no state).
  if (flags.includes("settled")) {
    await page.waitForFunction(() => ["done", "failed", undefined].includes(document.getElementById("load-info")?.dataset.prepared), null, { timeout: 600_000 });
  }
  // CPU time of the browser's processes (all its threads: page, workers) over the
  // estimate alone: steadier than wall time on a loaded machine.
  const cpuBefore = browserCpuMs();
  await page.click("#run");
  await page.waitForFunction(() => ["done", "error"].includes(document.body.dataset.state), null, { timeout: 600_000 });
  const estimateCpuMs = browserCpuMs() - cpuBefore;
  const wall = Date.now() - start;
  const report = await page.evaluate(() => ({
    state: document.body.dataset.state,
    workers: Number(document.getElementById("workers").value),
    hardwareConcurrency: navigator.hardwareConcurrency,
    estimate_ms: Number(document.getElementById("timings").dataset.totalMs),
    stages: [...document.querySelectorAll("#timings tr")].map((r) => r.textContent),
    unaccounted_ms: Math.round(
      Number(document.getElementById("timings").dataset.totalMs) -
        [...document.querySelectorAll("#timings tr")].filter((r) => !r.textContent.startsWith("total")).reduce((sum, r) => sum + parseFloat(r.cells[1].textContent), 0),
    ),
    transport: document.getElementById("load-info")?.dataset.transport,
    when: document.getElementById("load-info")?.dataset.when,
    badpix007: Number(document.getElementById("scores").dataset.badpix007),
    longest_main_thread_gap_ms: Math.max(0, ...Object.values(window.__gaps)),
    longest_gap_by_stage_ms: window.__gaps,
  }));
  // `again`: a second estimate of the same light field with another λ (a user tuning
  // the parameters).
  let second;
  if (flags.includes("again")) {
    await page.fill("#tv-lambda", "0.5");
    const cpu = browserCpuMs();
    await page.evaluate(() => (document.body.dataset.state = "clicked"));
    await page.click("#run");
    await page.waitForFunction(() => ["done", "error"].includes(document.body.dataset.state), null, { timeout: 600_000 });
    second = await page.evaluate(() => ({
      estimate_ms: Number(document.getElementById("timings").dataset.totalMs),
      stages: [...document.querySelectorAll("#timings tr")].map((r) => r.textContent),
      transport: document.getElementById("load-info")?.dataset.transport,
    }));
    second.estimate_cpu_ms = browserCpuMs() - cpu;
  }
  console.log(JSON.stringify({ size: Number(size), grid: Number(grid), load_generate_estimate_ms: wall, estimate_cpu_ms: estimateCpuMs, ...report,
    wasm_bytes: wasm.length, wasm_gzip_bytes: gzipSync(wasm, { level: 9 }).length, second }));
} finally {
  await context.close();
  await server.close();
  rmSync(profile, { recursive: true, force: true });
}
