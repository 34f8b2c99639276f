//! A minimal measurement probe for images run under QEMU: stack painting and a high-water
//! mark, and output/exit through ARM semihosting with a handful of instructions (no
//! `core::fmt`, so the footprint images measure the core, not a formatter).
//!
//! Stack painting: [`paint_stack`] fills the region between `_stack_start − PAINTED` and a
//! little below the current stack pointer with a pattern; after the workload
//! [`stack_used`] finds the lowest word that no longer holds the pattern. The distance from
//! the top of the stack (`_stack_start`, cortex-m-rt's symbol) to that word is the stack the
//! program has used since reset, reset handler and `main`'s frame included.

use core::arch::asm;

/// Bytes of stack below `_stack_start` that are painted and scanned.
pub const PAINTED: usize = 256 * 1024;
const PATTERN: u32 = 0xC0FF_EE11;

const SYS_WRITE0: usize = 0x04;
const SYS_EXIT: usize = 0x18;
/// `ADP_Stopped_ApplicationExit`: QEMU exits with status 0.
const EXIT_SUCCESS: usize = 0x20026;
/// `ADP_Stopped_RunTimeErrorUnknown`: QEMU exits with status 1.
const EXIT_FAILURE: usize = 0x20023;

unsafe extern "C" {
    static _stack_start: u32;
}

fn stack_top() -> usize {
    // Only the address of the linker symbol is taken.
    core::ptr::addr_of!(_stack_start) as usize
}

fn stack_bottom() -> usize {
    stack_top() - PAINTED
}

fn stack_pointer() -> usize {
    let sp: usize;
    // SAFETY: reads the stack pointer register.
    unsafe { asm!("mov {}, sp", out(reg) sp, options(nomem, nostack, preserves_flags)) };
    sp
}

/// Paints the unused stack below the caller with the pattern.
#[inline(never)]
pub fn paint_stack() {
    let end = stack_pointer() - 64;
    let mut addr = stack_bottom();
    while addr < end {
        // SAFETY: the range lies in RAM below the live stack (cortex-m-rt's stack grows down
        // from `_stack_start`; the images keep their statics far below `PAINTED`).
        unsafe { core::ptr::write_volatile(addr as *mut u32, PATTERN) };
        addr += 4;
    }
}

/// The stack used since reset, in bytes: `_stack_start` minus the lowest overwritten word.
#[inline(never)]
pub fn stack_used() -> usize {
    let mut addr = stack_bottom();
    // SAFETY: reads the painted region.
    while addr < stack_top() && unsafe { core::ptr::read_volatile(addr as *const u32) } == PATTERN {
        addr += 4;
    }
    stack_top() - addr
}

fn semihost(op: usize, arg: usize) {
    // SAFETY: the semihosting call of the Cortex-M (QEMU handles `bkpt 0xAB`).
    unsafe {
        asm!("bkpt 0xAB", inout("r0") op => _, in("r1") arg, options(nostack, preserves_flags))
    };
}

/// Writes `label`, a space, `value` in decimal and a newline to the host's stdout.
/// (Checked writes only: the images that call it must stay free of panic paths.)
pub fn report(label: &str, value: usize) {
    let mut line = [0u8; 96];
    let mut slots = line.iter_mut().take(95);
    let mut put = |b: u8| {
        if let Some(slot) = slots.next() {
            *slot = b;
        }
    };
    label.bytes().take(64).for_each(&mut put);
    put(b' ');
    let mut digits = [0u8; 20];
    let mut n = 0;
    let mut v = value;
    for d in digits.iter_mut() {
        *d = b'0' + (v % 10) as u8;
        n += 1;
        v /= 10;
        if v == 0 {
            break;
        }
    }
    digits.iter().take(n).rev().for_each(|&d| put(d));
    put(b'\n');
    semihost(SYS_WRITE0, line.as_ptr() as usize);
}

/// Ends the QEMU run with status 0 (`success`) or 1.
pub fn exit(success: bool) -> ! {
    semihost(SYS_EXIT, if success { EXIT_SUCCESS } else { EXIT_FAILURE });
    loop {
        cortex_m::asm::wfi();
    }
}
