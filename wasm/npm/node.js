// The package's entry in Node: the WebAssembly module is compiled and instantiated
// synchronously from the file beside this one when the package is imported, so Node code
// uses the exports at once. `init()` resolves at once, so code written for browsers
// (`await init()`) runs unchanged.
import { readFileSync } from "node:fs";
import { initSync } from "./lfdepth_wasm.js";

const output = initSync({ module: readFileSync(new URL("./lfdepth_wasm_bg.wasm", import.meta.url)) });

export * from "./lfdepth_wasm.js";

/** Resolves to the module's exports: in Node it is initialised on import. */
export default async function init() {
  return output;
}
