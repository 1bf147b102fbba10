//! A firmware-style binary: the lfdepth stream on a small synthetic 9×9 frame, with every
//! buffer static and sized at compile time — the shape of a microcontroller integration.
//!
//! On `thumbv7em-none-eabihf` the kernels compute in `f32`, on `thumbv6m-none-eabi` (no
//! FPU) in Q16.16 fixed point. On the host the same code runs as an ordinary program that
//! prints its result, so `cargo run -p lfdepth-firmware` checks it without a board. With
//! the feature `qemu` the device image reports through Arm semihosting and exits, and
//! `cargo xtask firmware` runs it on an emulated Cortex-M and compares its checksum with
//! the host's. See docs/EMBEDDED.md.
#![cfg_attr(target_os = "none", no_std, no_main)]

mod frame;
mod sensor;
mod stream;

#[cfg(target_os = "none")]
mod device;

#[cfg(not(target_os = "none"))]
fn main() {
    let mut memory = Box::new(frame::Memory::ZERO);
    let mut report = Box::new(lfdepth::align::AlignReport::EMPTY);
    match frame::run(&mut memory, &mut report, &mut |_| {}) {
        Ok(summary) => println!(
            "whole-frame {}x{}: checksum {:#010x}, {} scratch bytes, mean |d - gt| = {:.4} px",
            frame::WIDTH,
            frame::HEIGHT,
            summary.checksum,
            summary.scratch_bytes,
            summary.mean_abs_error,
        ),
        Err(e) => {
            eprintln!("whole-frame pipeline failed: {e}");
            std::process::exit(1);
        }
    }
    let mut memory = Box::new(stream::Memory::ZERO);
    match stream::run(&mut memory, &mut |_| {}) {
        Ok(summary) => {
            println!(
                "stream {}x{}: checksum {:#010x}, {} scratch bytes, mean |d - gt| = {:.4} px",
                stream::WIDTH,
                stream::HEIGHT,
                summary.checksum,
                summary.scratch_bytes,
                summary.mean_abs_error,
            );
        }
        Err(e) => {
            eprintln!("stream failed: {e}");
            std::process::exit(1);
        }
    }
}
