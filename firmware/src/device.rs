//! The bare-metal side: reset vector, `.data`/`.bss` set-up, the static memory and the
//! panic handler. The only `unsafe` of the project lives here, and only here.
#![allow(unsafe_code)]

use core::panic::PanicInfo;
use core::ptr::{addr_of, addr_of_mut};

#[cfg(feature = "whole-frame")]
use crate::frame::{run, Memory};
#[cfg(not(feature = "whole-frame"))]
use crate::stream::{run, Memory};

/// Every buffer of the run (the stream's, or the whole frame's with `whole-frame`), in
/// `.bss`.
static mut MEMORY: Memory = Memory::ZERO;

/// Where a debugger finds the result: the checksum, or `u32::MAX` after an error.
#[no_mangle]
pub static mut LFDEPTH_RESULT: u32 = 0;

/// The reset vector (the initial stack pointer precedes it, see `link.x`).
#[link_section = ".vector_table.reset"]
#[no_mangle]
pub static LFDEPTH_RESET_VECTOR: extern "C" fn() -> ! = lfdepth_reset;

extern "C" {
    static mut __sbss: u32;
    static mut __ebss: u32;
    static mut __sdata: u32;
    static mut __edata: u32;
    static __sidata: u32;
}

#[no_mangle]
pub extern "C" fn lfdepth_reset() -> ! {
    // SAFETY: runs once at reset, before anything reads statics; the symbols come from
    // link.x and bound word-aligned RAM regions (and the flash image of `.data`).
    unsafe {
        let mut p = addr_of_mut!(__sbss);
        while p < addr_of_mut!(__ebss) {
            p.write_volatile(0);
            p = p.add(1);
        }
        let (mut to, mut from) = (addr_of_mut!(__sdata), addr_of!(__sidata));
        while to < addr_of_mut!(__edata) {
            to.write_volatile(from.read());
            to = to.add(1);
            from = from.add(1);
        }
    }
    // SAFETY: the only reference ever taken to MEMORY; no interrupts or threads exist.
    let memory = unsafe { &mut *addr_of_mut!(MEMORY) };
    let result = match run(memory) {
        Ok(summary) => summary.checksum,
        Err(_) => u32::MAX,
    };
    // SAFETY: single-threaded; written once for a debugger to read.
    unsafe { addr_of_mut!(LFDEPTH_RESULT).write_volatile(result) };
    loop {
        core::hint::spin_loop();
    }
}

#[cfg(not(feature = "panic-free"))]
#[panic_handler]
fn panic(_: &PanicInfo) -> ! {
    loop {
        core::hint::spin_loop();
    }
}

#[cfg(feature = "panic-free")]
#[panic_handler]
fn panic(_: &PanicInfo) -> ! {
    extern "C" {
        /// Deliberately undefined: linking fails when a panic path survives.
        fn lfdepth_firmware_reached_a_panic_path() -> !;
    }
    // SAFETY: never defined, so never called: the link fails first.
    unsafe { lfdepth_firmware_reached_a_panic_path() }
}
