//! Thin wasm-bindgen layer over the `lfdepth` core: no algorithm code lives here.
