//! The bare-metal side: vector table, reset (FPU enable, `.data`/`.bss` set-up), the
//! static memory, the fault and panic handlers and, with the feature `qemu`, the report
//! through Arm semihosting. The only `unsafe` of the project lives here, and only here.
#![allow(unsafe_code)]

use core::panic::PanicInfo;
use core::ptr::{addr_of, addr_of_mut};

#[cfg(feature = "whole-frame")]
use crate::frame::{run, Memory, HEIGHT, WIDTH};
#[cfg(not(feature = "whole-frame"))]
use crate::stream::{run, Memory, HEIGHT, WIDTH};

/// The image's name in the report (`cargo xtask firmware` matches it).
#[cfg_attr(not(feature = "qemu"), allow(dead_code))]
const IMAGE: &str = if cfg!(feature = "whole-frame") {
    "whole-frame"
} else {
    "stream"
};

/// Every buffer of the run (the stream's, or the whole frame's with `whole-frame`), in
/// `.bss`.
static mut MEMORY: Memory = Memory::ZERO;

/// The whole frame's alignment report (a static of its own: `Memory` stays in `.bss`).
#[cfg(feature = "whole-frame")]
static mut REPORT: lfdepth::align::AlignReport = lfdepth::align::AlignReport::EMPTY;

/// Where a debugger finds the result: the checksum, or `u32::MAX` after an error.
#[no_mangle]
pub static mut LFDEPTH_RESULT: u32 = 0;

/// The Armv6-M / Armv7-M exception vectors after the initial stack pointer (which
/// `link.x` places first): reset, then NMI, HardFault, MemManage, BusFault, UsageFault,
/// four reserved, SVCall, DebugMonitor, reserved, PendSV and SysTick. No interrupt is
/// enabled; every exception other than reset is a fault of the image.
#[link_section = ".vector_table.exceptions"]
#[no_mangle]
pub static LFDEPTH_VECTORS: [extern "C" fn() -> !; 15] = [
    lfdepth_reset,
    lfdepth_fault,
    lfdepth_fault,
    lfdepth_fault,
    lfdepth_fault,
    lfdepth_fault,
    lfdepth_fault,
    lfdepth_fault,
    lfdepth_fault,
    lfdepth_fault,
    lfdepth_fault,
    lfdepth_fault,
    lfdepth_fault,
    lfdepth_fault,
    lfdepth_fault,
];

extern "C" {
    static mut __sbss: u32;
    static mut __ebss: u32;
    static mut __sdata: u32;
    static mut __edata: u32;
    static __sidata: u32;
}

#[no_mangle]
pub extern "C" fn lfdepth_reset() -> ! {
    // The FPU (thumbv7em-none-eabihf) is off after reset: grant CP10 and CP11 full access
    // in CPACR before the first floating-point instruction.
    #[cfg(target_abi = "eabihf")]
    // SAFETY: CPACR is the architected System Control Space register at 0xE000ED88; the
    // barriers make the change take effect before any later instruction.
    unsafe {
        let cpacr = 0xE000_ED88 as *mut u32;
        cpacr.write_volatile(cpacr.read_volatile() | (0xF << 20));
        core::arch::asm!("dsb", "isb", options(nostack, preserves_flags));
    }
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
    let mut meter = report::Meter::start();
    // SAFETY: the only reference ever taken to REPORT.
    #[cfg(feature = "whole-frame")]
    let outcome = run(
        memory,
        unsafe { &mut *addr_of_mut!(REPORT) },
        &mut |stage| meter.mark(stage),
    );
    #[cfg(not(feature = "whole-frame"))]
    let outcome = run(memory, &mut |stage| meter.mark(stage));
    let result = match outcome {
        Ok(summary) => summary.checksum,
        Err(_) => u32::MAX,
    };
    meter.mark("");
    // SAFETY: single-threaded; written once for a debugger to read.
    unsafe { addr_of_mut!(LFDEPTH_RESULT).write_volatile(result) };
    report::finish(IMAGE, WIDTH, HEIGHT, result, &meter);
    // Without `qemu` a debugger reads the result; the core stays here. (Ending in a call
    // of a diverging function instead changes LLVM's inlining of the stream: `text` grew
    // by 12 KB on thumbv7em and 33 KB on thumbv6m.)
    loop {
        core::hint::spin_loop();
    }
}

/// Every exception but reset: report (under `qemu`) and stop.
#[no_mangle]
pub extern "C" fn lfdepth_fault() -> ! {
    report::fault()
}

#[cfg(not(feature = "panic-free"))]
#[panic_handler]
fn panic(_: &PanicInfo) -> ! {
    report::fault()
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

/// Without `qemu`: the result stays in `LFDEPTH_RESULT` for a debugger and the core spins.
#[cfg(not(feature = "qemu"))]
mod report {
    pub struct Meter;

    impl Meter {
        pub fn start() -> Meter {
            Meter
        }

        pub fn mark(&mut self, _stage: &'static str) {}
    }

    pub fn finish(_: &str, _: usize, _: usize, _: u32, _: &Meter) {}

    pub fn fault() -> ! {
        spin()
    }

    fn spin() -> ! {
        loop {
            core::hint::spin_loop();
        }
    }
}

/// With `qemu`: the MPS2 boards' timer counts, Arm semihosting prints and exits.
///
/// Report, one line each (`cargo xtask firmware` reads it):
///
/// ```text
/// stream 128x128: checksum 0x6fc09da7
/// stage sensor: 123456 ticks
/// stage stream: 7890123 ticks
/// total: 8013579 ticks
/// ```
///
/// A tick is one period of the board's 25 MHz CMSDK timer 0 (`0x40000000`); under
/// `qemu-system-arm -icount shift=0` the virtual clock advances 1 ns per instruction, so a
/// tick is 40 instructions. The exit status is 0 after a checksum, 1 after an error or a
/// fault.
#[cfg(feature = "qemu")]
mod report {
    /// CMSDK APB timer 0 of the MPS2 AN385 / AN386 / AN500 images: CTRL, VALUE, RELOAD.
    const TIMER_CTRL: usize = 0x4000_0000;
    const TIMER_VALUE: usize = 0x4000_0004;
    const TIMER_RELOAD: usize = 0x4000_0008;

    /// Semihosting operations and `SYS_EXIT` reasons (Arm's "Semihosting for AArch32 and
    /// AArch64").
    const SYS_WRITE0: u32 = 0x04;
    const SYS_EXIT: u32 = 0x18;
    const ADP_STOPPED_APPLICATION_EXIT: usize = 0x2_0026;
    const ADP_STOPPED_RUN_TIME_ERROR_UNKNOWN: usize = 0x2_0023;

    /// Most distinct stages a run reports.
    const STAGES: usize = 12;

    fn write(address: usize, value: u32) {
        // SAFETY: an MMIO register of the board's timer (see the constants).
        unsafe { (address as *mut u32).write_volatile(value) }
    }

    fn read(address: usize) -> u32 {
        // SAFETY: an MMIO register of the board's timer (see the constants).
        unsafe { (address as *const u32).read_volatile() }
    }

    /// One semihosting call (`BKPT 0xAB`, operation in r0, argument in r1).
    fn semihost(op: u32, arg: usize) -> u32 {
        let mut r0 = op;
        // SAFETY: the semihosting trap; QEMU (`-semihosting`) or a debugger serves it and
        // returns in r0. `arg` points to memory that outlives the call.
        unsafe {
            core::arch::asm!("bkpt #0xab", inout("r0") r0, in("r1") arg, options(nostack));
        }
        r0
    }

    /// Ticks spent per stage, in the order the stages first ran.
    pub struct Meter {
        stages: [(&'static str, u32); STAGES],
        count: usize,
        current: Option<usize>,
        last: u32,
        first: u32,
    }

    /// Timer 0 counts down from `u32::MAX` (171 s at 25 MHz, far beyond any run).
    fn now() -> u32 {
        u32::MAX - read(TIMER_VALUE)
    }

    impl Meter {
        pub fn start() -> Meter {
            write(TIMER_CTRL, 0);
            write(TIMER_RELOAD, u32::MAX);
            write(TIMER_VALUE, u32::MAX);
            write(TIMER_CTRL, 1);
            let t = now();
            Meter {
                stages: [("", 0); STAGES],
                count: 0,
                current: None,
                last: t,
                first: t,
            }
        }

        /// From now on the time counts for `stage` (`""`: for nothing).
        pub fn mark(&mut self, stage: &'static str) {
            let t = now();
            if let Some((_, ticks)) = self.current.and_then(|i| self.stages.get_mut(i)) {
                *ticks = ticks.wrapping_add(t.wrapping_sub(self.last));
            }
            self.last = t;
            if stage.is_empty() {
                self.current = None;
                return;
            }
            let known = self
                .stages
                .iter()
                .take(self.count)
                .position(|s| s.0 == stage);
            self.current = match known {
                Some(i) => Some(i),
                None if self.count < STAGES => {
                    if let Some(slot) = self.stages.get_mut(self.count) {
                        *slot = (stage, 0);
                    }
                    self.count += 1;
                    Some(self.count - 1)
                }
                // More stages than slots: the rest counts for the last one.
                None => Some(STAGES - 1),
            };
        }
    }

    /// A line of text, NUL-terminated for `SYS_WRITE0` (longer text is cut).
    struct Line {
        bytes: [u8; 96],
        len: usize,
    }

    impl Line {
        fn new() -> Line {
            Line {
                bytes: [0; 96],
                len: 0,
            }
        }

        fn byte(&mut self, b: u8) -> &mut Line {
            // One byte stays for the NUL.
            if self.len + 1 < self.bytes.len() {
                if let Some(slot) = self.bytes.get_mut(self.len) {
                    *slot = b;
                }
                self.len += 1;
            }
            self
        }

        fn text(&mut self, s: &str) -> &mut Line {
            for &b in s.as_bytes() {
                self.byte(b);
            }
            self
        }

        fn decimal(&mut self, mut n: u32) -> &mut Line {
            let mut digits = [0u8; 10];
            let mut count = 0;
            loop {
                if let Some(d) = digits.get_mut(count) {
                    *d = b'0' + (n % 10) as u8;
                }
                count += 1;
                n /= 10;
                if n == 0 || count == digits.len() {
                    break;
                }
            }
            for &d in digits.iter().take(count).rev() {
                self.byte(d);
            }
            self
        }

        fn hex(&mut self, n: u32) -> &mut Line {
            self.text("0x");
            for shift in (0..8).rev() {
                let nibble = ((n >> (4 * shift)) & 0xF) as u8;
                self.byte(if nibble < 10 {
                    b'0' + nibble
                } else {
                    b'a' + nibble - 10
                });
            }
            self
        }

        fn print(&mut self) {
            self.text("\n");
            if let Some(end) = self.bytes.get_mut(self.len) {
                *end = 0;
            }
            semihost(SYS_WRITE0, self.bytes.as_ptr() as usize);
        }
    }

    fn exit(success: bool) -> ! {
        let reason = if success {
            ADP_STOPPED_APPLICATION_EXIT
        } else {
            ADP_STOPPED_RUN_TIME_ERROR_UNKNOWN
        };
        semihost(SYS_EXIT, reason);
        loop {
            core::hint::spin_loop();
        }
    }

    pub fn finish(image: &str, width: usize, height: usize, result: u32, meter: &Meter) {
        let ok = result != u32::MAX;
        let mut line = Line::new();
        line.text(image)
            .text(" ")
            .decimal(width as u32)
            .text("x")
            .decimal(height as u32);
        if ok {
            line.text(": checksum ").hex(result).print();
        } else {
            line.text(": error").print();
        }
        for &(stage, ticks) in meter.stages.iter().take(meter.count) {
            Line::new()
                .text("stage ")
                .text(stage)
                .text(": ")
                .decimal(ticks)
                .text(" ticks")
                .print();
        }
        Line::new()
            .text("total: ")
            .decimal(meter.last.wrapping_sub(meter.first))
            .text(" ticks")
            .print();
        exit(ok)
    }

    pub fn fault() -> ! {
        Line::new().text("fault").print();
        exit(false)
    }
}
