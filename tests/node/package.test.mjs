// The npm package as a user gets it: `npm pack` of target/npm/lfdepth (assembled by
// `cargo xtask package`, or the npm-package step of `cargo xtask test`), installed from
// the tarball into an empty project, imported there, and its example run there on
// synthetic scenes written by `lfdepth synth` (aligned or not) and on the HCI scenes: the
// PFM and the PNG it writes equal, byte for byte, those of `lfdepth estimate` on the same
// folder. The example also runs under Node 18, the oldest Node the package supports
// (installed from the npm registry into target/js-cache on first use).
import { test, before, after } from "node:test";
import assert from "node:assert/strict";
import { execFileSync, spawnSync } from "node:child_process";
import { copyFileSync, existsSync, mkdtempSync, readFileSync, readdirSync, rmSync, statSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import { join, resolve } from "node:path";
import { installPacked, root, run } from "./packed.mjs";

const cli = process.env.LFDEPTH_CLI ?? join(root, "target/release/lfdepth");
const hciDir = resolve(root, "../shared/data/hci");

/** The oldest Node the package's `engines` admits, as a release of the npm registry's
 *  `node-<platform>-<arch>` packages (the binaries the `node` package installs). */
const NODE_18 = "18.20.8";

let work, project, tarball;

before(() => {
  if (!existsSync(cli)) throw new Error(`${cli} is missing: build it with \`cargo build --release -p lfdepth-cli\` (cargo xtask test does)`);
  work = mkdtempSync(join(tmpdir(), "lfdepth-package-"));
  ({ tarball, project } = installPacked(work));
});

after(() => {
  if (work) rmSync(work, { recursive: true, force: true });
});

/** Node ${NODE_18}'s binary, installed from the npm registry into target/js-cache on first use. */
function node18() {
  const platform = { linux: "linux", darwin: "darwin" }[process.platform];
  if (!platform) throw new Error(`Node ${NODE_18} for ${process.platform} is not installed by this test: run it on Linux or macOS`);
  const name = `node-${platform}-${process.arch}`;
  const cache = join(root, "target/js-cache", `node-${NODE_18}`);
  const binary = join(cache, "node_modules", name, "bin/node");
  if (!existsSync(binary)) {
    run("npm", ["install", "--prefix", cache, "--no-save", "--no-package-lock", "--no-audit", "--no-fund", `${name}@${NODE_18}`]);
  }
  assert.equal(run(binary, ["--version"]).stdout.trim(), `v${NODE_18}`);
  return binary;
}

test("the tarball holds the module, both entries, their types, README, licences and the example", () => {
  const listed = run("tar", ["-tzf", tarball]).stdout.trim().split("\n").map((f) => f.replace(/^package\//, "")).sort();
  assert.deepEqual(listed, [
    "LICENSE-APACHE", "LICENSE-MIT", "README.md", "examples/estimate.mjs",
    "lfdepth_wasm.d.ts", "lfdepth_wasm.js", "lfdepth_wasm_bg.wasm", "lfdepth_wasm_bg.wasm.d.ts",
    "node.d.ts", "node.js", "package.json",
  ]);
  const installed = join(project, "node_modules/lfdepth");
  const manifest = JSON.parse(readFileSync(join(installed, "package.json"), "utf8"));
  const workspaceVersion = /\[workspace\.package\][^[]*?\nversion = "([^"]+)"/.exec(readFileSync(join(root, "Cargo.toml"), "utf8"))[1];
  assert.equal(manifest.name, "lfdepth");
  assert.equal(manifest.version, workspaceVersion);
  assert.equal(manifest.license, "MIT OR Apache-2.0");
  assert.equal(manifest.exports["."].node.default, "./node.js");
  const types = readFileSync(join(installed, "lfdepth_wasm.d.ts"), "utf8");
  // The generated EstimateParams (cargo xtask types) and the PNG functions are declared.
  assert.match(types, /export interface EstimateParams \{/);
  assert.ok(types.includes(readFileSync(join(root, "wasm/src/estimate_params.d.ts"), "utf8").split("\n").find((l) => l.includes("preset?:")).trim()));
  assert.match(types, /export function decodePng\(/);
  assert.match(types, /export function disparityPng\(/);
  assert.match(readFileSync(join(installed, "node.d.ts"), "utf8"), /export \* from "\.\/lfdepth_wasm\.js"/);
  assert.match(readFileSync(join(installed, "README.md"), "utf8"), /## In Node/);
});

test("Node imports it ready to use, from ES modules and CommonJS; the browser entry initialises from bytes", () => {
  const esm = run("node", ["--input-type=module", "-e", `
    import init, { version, sceneNames, Estimator, synthesize } from "lfdepth";
    const lf = synthesize({ scene: "planes", rows: 3, cols: 3, width: 32, height: 32 });
    const { rows, cols, width, height, channels } = lf;
    const result = new Estimator(lf.views, { rows, cols, width, height, channels }, { stage: "epi" }).estimate();
    await init();
    console.log(version(), sceneNames().length, result.disparity.length);
  `], { cwd: project });
  const version = JSON.parse(readFileSync(join(project, "node_modules/lfdepth/package.json"), "utf8")).version;
  assert.equal(esm.stdout.trim(), `${version} 7 1024`);
  writeFileSync(join(project, "cjs.cjs"), `import("lfdepth").then((lf) => console.log(lf.version()));`);
  assert.equal(run("node", ["cjs.cjs"], { cwd: project }).stdout.trim(), version);
  // Bundlers and browsers resolve the "browser" condition to the wasm-bindgen module,
  // which needs init(); Node cannot fetch a file URL, so it gets the bytes here.
  const browser = run("node", ["--conditions=browser", "--input-type=module", "-e", `
    import { readFileSync } from "node:fs";
    import init, * as lf from "lfdepth";
    let threw = false;
    try { lf.version(); } catch { threw = true; }
    await init({ module_or_path: readFileSync("node_modules/lfdepth/lfdepth_wasm_bg.wasm") });
    console.log(threw, lf.version());
  `], { cwd: project });
  assert.equal(browser.stdout.trim(), `true ${version}`);
});

test("TypeScript checks a user's code against the package's types, Node and bundler resolution", () => {
  const tsc = join(root, "tests/node_modules/typescript/bin/tsc");
  if (!existsSync(tsc)) throw new Error(`${tsc} is missing: run npm ci in tests/ (cargo xtask test does)`);
  writeFileSync(join(project, "user.ts"), `
    import init, { Estimator, decodePng, disparityPng, synthesize, type EstimateParams } from "lfdepth";
    const params: EstimateParams = { preset: "fast", align: "off", lambda: 0.5 };
    const lf = synthesize({ scene: "planes", width: 32, height: 32 });
    const shape = { rows: lf.rows, cols: lf.cols, width: lf.width, height: lf.height, channels: lf.channels };
    const result = new Estimator(lf.views, shape, params).estimate((p) => console.log(p.stage, p.done, p.total));
    const png: Uint8Array = disparityPng(result.disparity, result.width, result.height);
    const channels: number = decodePng(png).channels;
    await init();
    console.log(channels, result.timings.map((t) => t.stage + " " + t.ms));
  `);
  writeFileSync(join(project, "wrong.ts"), `
    import type { EstimateParams } from "lfdepth";
    export const params: EstimateParams = { preset: "slow" };
  `);
  // wasm-bindgen's classes declare [Symbol.dispose]: the disposable lib is needed.
  const check = (resolution, file) => {
    const module = resolution === "bundler" ? "esnext" : resolution;
    writeFileSync(join(project, "tsconfig.json"), JSON.stringify({
      compilerOptions: { module, moduleResolution: resolution, target: "es2022", lib: ["es2022", "esnext.disposable", "dom"], strict: true, noEmit: true, types: [] },
      files: [file],
    }));
    return spawnSync("node", [tsc, "-p", project], { encoding: "utf8", cwd: project });
  };
  for (const resolution of ["node16", "bundler"]) {
    const ok = check(resolution, "user.ts");
    assert.equal(ok.status, 0, `${resolution}: ${ok.stdout}${ok.stderr}`);
  }
  const wrong = check("node16", "wrong.ts");
  assert.notEqual(wrong.status, 0, "an unknown preset passed the type check");
  assert.match(wrong.stdout, /"slow"' is not assignable/);
});

/** The samples of a PFM the tool or the example wrote (little-endian, one channel). */
function pfmSamples(bytes) {
  let end = 0;
  for (let lines = 0; lines < 3; end++) if (bytes[end] === 10) lines++;
  return new Float32Array(bytes.buffer.slice(bytes.byteOffset + end, bytes.byteOffset + bytes.length));
}

/** Runs the example (copied into the project, as a user would) with `node` and `lfdepth
 *  estimate` on `scene`; returns both runs' files and wall times. */
function runBoth(scene, name, node = "node") {
  const out = join(work, name);
  execFileSync("mkdir", ["-p", out]);
  copyFileSync(join(project, "node_modules/lfdepth/examples/estimate.mjs"), join(project, "estimate.mjs"));
  let t = performance.now();
  const example = run(node, ["estimate.mjs", scene, join(out, "node.pfm"), "--png", join(out, "node.png")], { cwd: project });
  const nodeMs = performance.now() - t;
  t = performance.now();
  run(cli, ["estimate", scene, "-o", join(out, "cli.pfm"), "--png", join(out, "cli.png"), "--quiet"]);
  const cliMs = performance.now() - t;
  // Per-stage timings on stdout, the last line the total; progress on stderr.
  const lines = example.stdout.trim().split("\n");
  assert.match(lines[0], /^load +\d+\.\d{3} s$/);
  assert.ok(lines.some((l) => /^tv +\d+\.\d{3} s$/.test(l)), example.stdout);
  assert.match(lines.at(-1), /^total +\d+\.\d{3} s$/);
  assert.match(example.stderr, /^read: 81\/81$/m);
  assert.match(example.stderr, /^tv: \d+\/\d+$/m);
  const files = Object.fromEntries(["node.pfm", "node.png", "cli.pfm", "cli.png"].map((f) => [f, readFileSync(join(out, f))]));
  return { files, nodeMs, cliMs, stderr: example.stderr };
}

/** Asserts that the example wrote the tool's files, byte for byte. */
function compareWithCli(scene, name, node = "node") {
  const { files, nodeMs, cliMs } = runBoth(scene, name, node);
  for (const ext of ["pfm", "png"]) {
    const a = files[`node.${ext}`], b = files[`cli.${ext}`];
    assert.ok(a.equals(b), `${name}: the example's ${ext.toUpperCase()} differs from lfdepth estimate's (${a.length} vs ${b.length} bytes)`);
  }
  return { nodeMs, cliMs };
}

for (const [name, flags] of [
  ["mixed", ["--scene", "mixed", "--size", "96"]],
  ["gray", ["--scene", "spheres", "--size", "96", "--gray"]],
]) {
  test(`the example's PFM and PNG equal lfdepth estimate's on a synthetic scene (${name})`, () => {
    const scene = join(work, `scene-${name}`);
    run(cli, ["synth", ...flags, "--out", scene]);
    compareWithCli(scene, name);
  });
}

test(`under Node ${NODE_18} the package imports and its example's files equal lfdepth estimate's`, () => {
  const node = node18();
  writeFileSync(join(project, "cjs.cjs"), `import("lfdepth").then((lf) => console.log(lf.version()));`);
  const version = JSON.parse(readFileSync(join(project, "node_modules/lfdepth/package.json"), "utf8")).version;
  assert.equal(run(node, ["cjs.cjs"], { cwd: project }).stdout.trim(), version);
  const scene = join(work, "scene-node18");
  run(cli, ["synth", "--scene", "mixed", "--size", "96", "--out", scene]);
  compareWithCli(scene, "node18", node);
});

test("on views that need alignment the example's PFM and PNG equal lfdepth estimate's", () => {
  // Both warp the views with the core's warp into f32 samples, so the maps agree bit for
  // bit, not only to the 8-bit rounding of the warped views.
  const scene = join(work, "scene-misaligned");
  run(cli, ["synth", "--scene", "spheres", "--size", "96", "--misalign", "--out", scene]);
  const { files, stderr } = runBoth(scene, "misaligned");
  assert.match(stderr, /^alignment: views aligned, reprojection RMS/m);
  const a = pfmSamples(files["node.pfm"]), b = pfmSamples(files["cli.pfm"]);
  assert.equal(a.length, b.length);
  let differing = 0;
  for (let i = 0; i < a.length; i++) if (!Object.is(a[i], b[i])) differing++;
  assert.equal(differing, 0, `${differing} of ${a.length} pixels differ between the example and lfdepth estimate`);
  for (const ext of ["pfm", "png"]) assert.ok(files[`node.${ext}`].equals(files[`cli.${ext}`]), `the ${ext.toUpperCase()} files differ`);
});

test("the example's PFM and PNG equal lfdepth estimate's on the HCI scenes", (t) => {
  if (!existsSync(hciDir)) {
    console.log(`SKIPPED: ${hciDir} not found: the HCI comparison needs ../shared/data/hci`);
    t.skip("no ../shared/data/hci");
    return;
  }
  // Scenes lie in category folders (training/cotton, stratified/backgammon).
  const scenes = readdirSync(hciDir)
    .filter((entry) => statSync(join(hciDir, entry)).isDirectory())
    .flatMap((category) => (existsSync(join(hciDir, category, "input_Cam040.png")) ? [category] : readdirSync(join(hciDir, category)).map((s) => join(category, s))))
    .filter((s) => existsSync(join(hciDir, s, "input_Cam040.png")))
    .sort();
  assert.ok(scenes.length > 0, `${hciDir} holds no scene`);
  for (const scene of scenes) {
    const { nodeMs, cliMs } = compareWithCli(join(hciDir, scene), `hci-${scene.replaceAll("/", "-")}`);
    console.log(`${scene}: example ${(nodeMs / 1000).toFixed(2)} s, lfdepth estimate ${(cliMs / 1000).toFixed(2)} s (wall, whole process)`);
  }
});

test("the example says what to change on bad input", () => {
  const example = join(project, "node_modules/lfdepth/examples/estimate.mjs");
  const cases = [
    [[], /usage: node examples\/estimate\.mjs SCENE_DIR OUT\.pfm/, 2],
    [[join(work, "nowhere"), join(work, "x.pfm")], /is not a folder/, 1],
    [[project, join(work, "x.pfm")], /holds no views named like input_Cam000\.png/, 1],
    [[project, join(work, "no/such/dir/x.pfm")], /does not exist: create the folder first/, 1],
    [[project, join(work, "x.pfm"), "--png"], /--png needs a file name/, 2],
    [[project, join(work, "x.pfm"), "--png", join(work, "x.pfm")], /name the same file/, 1],
    [[project, join(project, "input_Cam000.png")], /is a file of the scene/, 1],
  ];
  for (const [args, message, status] of cases) {
    const result = spawnSync("node", [example, ...args], { encoding: "utf8", cwd: project });
    assert.equal(result.status, status, `${args.join(" ")}: ${result.stderr}`);
    assert.match(result.stderr, message);
  }
  // A view that is not a PNG is named in the error.
  const scene = join(work, "broken");
  run(cli, ["synth", "--scene", "planes", "--size", "32", "--grid", "3x3", "--out", scene]);
  writeFileSync(join(scene, "input_Cam004.png"), "not a png");
  const broken = spawnSync("node", [example, scene, join(work, "b.pfm")], { encoding: "utf8", cwd: project });
  assert.equal(broken.status, 1);
  assert.match(broken.stderr, /input_Cam004\.png: not a readable PNG image/);
  assert.ok(!existsSync(join(work, "b.pfm")));
});
