// The package's types in Node: those of the WebAssembly module, which is initialised on
// import (see node.js).
export * from "./lfdepth_wasm.js";
import type { InitOutput } from "./lfdepth_wasm.js";

/** Resolves to the module's exports at once: in Node it is initialised on import. */
export default function init(): Promise<InitOutput>;
