// Loads the wasm package built for the web (`web/pkg`, or $LFDEPTH_WASM_PKG) in Node:
// the same files the page imports, initialised synchronously from the .wasm bytes.
import { readFileSync, existsSync } from "node:fs";
import { dirname, join, resolve } from "node:path";
import { fileURLToPath, pathToFileURL } from "node:url";

export const root = process.env.LFDEPTH_ROOT ?? resolve(dirname(fileURLToPath(import.meta.url)), "../..");
export const pkgDir = process.env.LFDEPTH_WASM_PKG ?? join(root, "web/pkg");

const entry = join(pkgDir, "lfdepth_wasm.js");
if (!existsSync(entry)) {
  throw new Error(`${entry} is missing: build it with \`wasm-pack build wasm --target web --out-dir ../web/pkg\` (cargo xtask test does)`);
}
const lf = await import(pathToFileURL(entry).href);
lf.initSync({ module: readFileSync(join(pkgDir, "lfdepth_wasm_bg.wasm")) });
export default lf;
