#!/usr/bin/env node
// Disparity of a light field's centre view from a folder of views, in one thread:
//
//   node examples/estimate.mjs SCENE_DIR OUT.pfm [--png OUT.png]
//
// SCENE_DIR holds the views as the HCI benchmark names them (input_Cam000.png …,
// row-major); the grid comes from its parameters.cfg (num_cams_y × num_cams_x) or is the
// smallest square holding every view. Writes the disparity as PFM (and, with --png, the
// colour-mapped picture with its legend), shows progress on stderr and prints the time
// of each stage. With default parameters the files are byte for byte those of
// `lfdepth estimate SCENE_DIR -o OUT.pfm --png OUT.png`.
import { existsSync, readdirSync, readFileSync, renameSync, statSync, writeFileSync } from "node:fs";
import { basename, dirname, join, resolve } from "node:path";
import { performance } from "node:perf_hooks";
import { Estimator, decodePng, disparityPng } from "lfdepth";

const USAGE = "usage: node examples/estimate.mjs SCENE_DIR OUT.pfm [--png OUT.png]";
const VIEW_NAME = /^input_Cam(\d{3,})\.png$/;

/** Stops with a message saying what to change. */
function fail(message, code = 1) {
  process.stderr.write(`error: ${message}\n`);
  process.exit(code);
}

function parseArgs(args) {
  const positional = [];
  let png = null;
  for (let i = 0; i < args.length; i++) {
    if (args[i] === "--png") {
      if (i + 1 >= args.length) fail(`--png needs a file name\n${USAGE}`, 2);
      png = args[++i];
    } else if (args[i] === "-h" || args[i] === "--help") {
      process.stdout.write(`${USAGE}\n`);
      process.exit(0);
    } else if (args[i].startsWith("-")) {
      fail(`unknown option ${args[i]}\n${USAGE}`, 2);
    } else {
      positional.push(args[i]);
    }
  }
  if (positional.length !== 2) fail(USAGE, 2);
  const [scene, pfm] = positional;
  const outputs = [pfm, png].filter(Boolean).map((p) => resolve(p));
  if (new Set(outputs).size !== outputs.length) fail("OUT.pfm and --png name the same file: give two names");
  for (const out of outputs) {
    if (!existsSync(dirname(out))) fail(`${dirname(out)} does not exist: create the folder first`);
    const name = basename(out);
    if (dirname(out) === resolve(scene) && (VIEW_NAME.test(name) || name === "parameters.cfg" || name.startsWith("gt_"))) {
      fail(`${out} is a file of the scene (a view, its parameters or its ground truth): write elsewhere`);
    }
  }
  return { scene, pfm, png };
}

/** `num_cams_y` × `num_cams_x` of the scene's parameters.cfg, when it gives both. */
function configGrid(scene) {
  const path = join(scene, "parameters.cfg");
  if (!existsSync(path)) return null;
  const value = (key) => {
    const line = readFileSync(path, "utf8").split(/\r?\n/).find((l) => l.split("=")[0].trim() === key);
    const n = line === undefined ? NaN : Number(line.split("=")[1]);
    return Number.isInteger(n) && n > 0 ? n : null;
  };
  const rows = value("num_cams_y"), cols = value("num_cams_x");
  return rows && cols ? { rows, cols } : null;
}

/** The view files in row-major grid order, and the grid. */
function locateViews(scene) {
  if (!existsSync(scene) || !statSync(scene).isDirectory()) fail(`${scene} is not a folder: give the folder that holds the views`);
  const found = new Map();
  for (const name of readdirSync(scene)) {
    const match = VIEW_NAME.exec(name);
    if (match) found.set(Number(match[1]), name);
  }
  if (found.size === 0) fail(`${scene} holds no views named like input_Cam000.png`);
  const highest = Math.max(...found.keys());
  let side = 1;
  while (side * side < highest + 1) side++;
  const grid = configGrid(scene) ?? { rows: side, cols: side };
  const count = grid.rows * grid.cols;
  const extra = [...found.keys()].filter((i) => i >= count);
  if (extra.length) fail(`${scene}: ${extra.length} view(s) do not fit the ${grid.rows}x${grid.cols} grid, e.g. ${found.get(extra[0])}: remove them`);
  const missing = [];
  for (let i = 0; i < count; i++) if (!found.has(i)) missing.push(`input_Cam${String(i).padStart(3, "0")}.png`);
  if (missing.length) fail(`${scene}: ${missing.length} of the ${grid.rows}x${grid.cols} views are missing: ${missing.slice(0, 6).join(", ")}`);
  return { grid, files: Array.from({ length: count }, (_, i) => join(scene, found.get(i))) };
}

/** Decodes every view into one packed buffer, checking they agree in size and samples. */
function readViews(files, report) {
  let shape = null, views = null;
  files.forEach((file, i) => {
    let image;
    try {
      image = decodePng(readFileSync(file));
    } catch (e) {
      fail(`${file}: ${e.message}`);
    }
    const { width, height, channels } = image;
    if (shape === null) {
      shape = { width, height, channels };
      views = new Uint8Array(files.length * width * height * channels);
    } else if (width !== shape.width || height !== shape.height || channels !== shape.channels) {
      fail(`${file} is ${width}x${height} with ${channels} channel(s) but ${files[0]} is ${shape.width}x${shape.height} with ${shape.channels}: all views must be alike`);
    }
    views.set(image.samples, i * width * height * channels);
    image.free();
    report("read", i + 1, files.length);
  });
  return { shape, views };
}

/** Progress on stderr: one rewritten line on a terminal, a line per finished stage otherwise. */
function progressReporter() {
  const tty = process.stderr.isTTY;
  let last = 0;
  return (stage, done, total) => {
    const now = performance.now();
    if (tty && (done === total || now - last > 100)) {
      last = now;
      process.stderr.write(`\r\x1b[K${stage.padStart(8)} ${done}/${total}`);
      if (stage === "read" && done === total) process.stderr.write("\n");
    } else if (!tty && done === total) {
      process.stderr.write(`${stage}: ${done}/${total}\n`);
    }
  };
}

/** A single-channel PFM, little-endian (scale -1), bottom row first: the tool's layout. */
function encodePfm(map, width, height) {
  const header = new TextEncoder().encode(`Pf\n${width} ${height}\n-1\n`);
  const out = new Uint8Array(header.length + 4 * width * height);
  out.set(header);
  const data = new DataView(out.buffer, header.length);
  for (let y = 0; y < height; y++) {
    const row = height - 1 - y;
    for (let x = 0; x < width; x++) data.setFloat32(4 * (y * width + x), map[row * width + x], true);
  }
  return out;
}

/** Writes through a temporary file, so a failed run leaves an older file whole. */
function writeAtomically(path, bytes) {
  const temporary = join(dirname(path), `.${basename(path)}.${process.pid}.tmp`);
  writeFileSync(temporary, bytes);
  renameSync(temporary, path);
}

/** One line per stage, then the total, as `lfdepth estimate` prints them. */
function timingTable(rows) {
  const width = Math.max(5, ...rows.map(([name]) => name.length));
  const line = (name, ms) => `${name.padEnd(width)} ${(ms / 1000).toFixed(3).padStart(8)} s\n`;
  const total = rows.reduce((sum, [, ms]) => sum + ms, 0);
  return rows.map(([name, ms]) => line(name, ms)).join("") + line("total", total);
}

const args = parseArgs(process.argv.slice(2));
const report = progressReporter();
const start = performance.now();
const { grid, files } = locateViews(args.scene);
const { shape, views } = readViews(files, report);
const loadMs = performance.now() - start;
process.stderr.write(`${args.scene}: ${grid.rows}x${grid.cols} views of ${shape.width}x${shape.height} pixels (8-bit)\n`);

let result;
try {
  const estimator = new Estimator(views, { ...grid, ...shape });
  result = estimator.estimate(({ stage, done, total }) => report(stage, done, total));
  estimator.free();
} catch (e) {
  if (process.stderr.isTTY) process.stderr.write("\n");
  fail(`estimating ${args.scene}: ${e.message}`);
}
if (process.stderr.isTTY) process.stderr.write("\r\x1b[K");
const align = result.align;
if (align?.warning) process.stderr.write(`warning: the views were not aligned (align "auto"): ${align.warning}\n`);
else if (align?.skipped) process.stderr.write(`alignment: skipped, the array is rectified (residual ${align.identityRms.toFixed(3)} px with identity homographies)\n`);
else if (align) process.stderr.write(`alignment: views aligned, reprojection RMS ${align.rms.toFixed(3)} px (${align.identityRms.toFixed(3)} px before)\n`);

const { width, height } = result;
const disparity = result.disparity;
writeAtomically(args.pfm, encodePfm(disparity, width, height));
if (args.png) writeAtomically(args.png, disparityPng(disparity, width, height));
const rows = [["load", loadMs], ...result.timings.map((t) => [t.stage, t.ms])];
process.stdout.write(timingTable(rows));
