//! How much stack did the program need? Paint the free RAM below the stack with a pattern
//! at start-up, run, then find the deepest word that no longer holds it. Size your stack
//! from this number plus your interrupts' frames.

use core::arch::asm;
use core::ptr::{addr_of, read_volatile, write_volatile};

const PATTERN: u32 = 0xC0FF_EE11;

unsafe extern "C" {
    /// Top of the stack (cortex-m-rt); the stack grows down from here.
    static _stack_start: u32;
    /// End of the statics (cortex-m-rt): the stack may grow down to here.
    static __sheap: u32;
}

fn bounds() -> (usize, usize) {
    // Only the symbols' addresses are taken.
    (addr_of!(__sheap) as usize, addr_of!(_stack_start) as usize)
}

/// Paints everything between the end of the statics and a little below the current stack
/// pointer.
#[inline(never)]
pub fn paint() {
    let sp: usize;
    // SAFETY: reads the stack pointer.
    unsafe { asm!("mov {}, sp", out(reg) sp, options(nomem, nostack, preserves_flags)) };
    let (mut addr, _) = bounds();
    while addr < sp - 64 {
        // SAFETY: the range is free RAM between the statics and the live stack.
        unsafe { write_volatile(addr as *mut u32, PATTERN) };
        addr += 4;
    }
}

/// Bytes of stack used since reset: from the top down to the deepest overwritten word.
#[inline(never)]
pub fn used() -> usize {
    let (mut addr, top) = bounds();
    // SAFETY: reads the painted region.
    while addr < top && unsafe { read_volatile(addr as *const u32) } == PATTERN {
        addr += 4;
    }
    top - addr
}
