// The npm package as a user gets it, for the tests that use it: `npm pack` of
// target/npm/lfdepth (assembled by `cargo xtask package`, or the npm-package step of
// `cargo xtask test`), installed from the tarball into an empty project.
import assert from "node:assert/strict";
import { spawnSync } from "node:child_process";
import { existsSync, mkdirSync, writeFileSync } from "node:fs";
import { dirname, join, resolve } from "node:path";
import { fileURLToPath } from "node:url";

export const root = process.env.LFDEPTH_ROOT ?? resolve(dirname(fileURLToPath(import.meta.url)), "../..");

export const packageDir = process.env.LFDEPTH_NPM_PACKAGE ?? join(root, "target/npm/lfdepth");

/** Runs `program`, failing the test with its output unless it exits with 0. */
export function run(program, args, options = {}) {
  const result = spawnSync(program, args, { encoding: "utf8", maxBuffer: 64 << 20, ...options });
  if (result.error) throw result.error;
  assert.equal(result.status, 0, `${program} ${args.join(" ")} failed (${result.status}):\n${result.stdout}\n${result.stderr}`);
  return result;
}

/** Packs the package into `work` and installs the tarball into `work/project`, an empty
 *  ES-module project; returns the tarball's and the project's paths. */
export function installPacked(work) {
  if (!existsSync(join(packageDir, "package.json"))) {
    throw new Error(`${packageDir} is missing: build it with \`cargo xtask package\` (cargo xtask test does)`);
  }
  const packed = JSON.parse(run("npm", ["pack", "--json", "--pack-destination", work], { cwd: packageDir }).stdout);
  const tarball = join(work, packed[0].filename);
  const project = join(work, "project");
  mkdirSync(project);
  writeFileSync(join(project, "package.json"), JSON.stringify({ name: "a-user-project", private: true, type: "module" }));
  // The package has no dependencies: the tarball installs without a registry.
  run("npm", ["install", "--offline", "--no-audit", "--no-fund", tarball], { cwd: project });
  return { tarball, project };
}
