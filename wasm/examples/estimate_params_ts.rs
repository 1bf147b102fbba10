//! Prints the TypeScript declaration of `EstimateParams`, generated from the core's
//! tunable table: `cargo xtask types` writes it to `wasm/src/estimate_params.d.ts`.

fn main() {
    print!("{}", lfdepth_wasm::estimate_params_typescript());
}
