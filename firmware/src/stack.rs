//! Stack high-water mark.
//!
//! cortex-m-rt's `paint-stack` feature fills the stack region `_stack_end .. _stack_start`
//! (everything between the end of `.bss` and the top of RAM) with `0xCCCC_CCCC` before `main`.
//! [`peak_bytes`] scans up from the bottom for the first word that is no longer paint: the
//! deepest the stack has reached. [`repaint`] paints the unused part again so that a later
//! phase (the per-frame processing) gets its own peak. A word that was pushed with the value
//! `0xCCCC_CCCC` at the very deepest point would be missed: the peak can be low by a few
//! words, never high.

use core::ptr::{addr_of, read_volatile, write_volatile};

use cortex_m_rt::STACK_PAINT_VALUE;

extern "C" {
    /// Top of the stack (initial SP), from cortex-m-rt's `link.x`.
    static _stack_start: u32;
    /// Lowest address the stack may grow to, from cortex-m-rt's `link.x`.
    static _stack_end: u32;
}

/// Bytes kept free below the caller's stack pointer when repainting: `repaint`'s own frame
/// lives there.
const REPAINT_MARGIN: usize = 256;

/// `(bottom, top)` addresses of the stack region.
fn region() -> (usize, usize) {
    // Only the addresses of the linker-defined symbols are taken, never their values.
    (
        addr_of!(_stack_end) as usize,
        addr_of!(_stack_start) as usize,
    )
}

/// Bytes of stack used so far (since reset or the last [`repaint`]).
#[allow(unsafe_code)]
pub fn peak_bytes() -> usize {
    let (bottom, top) = region();
    let mut p = bottom;
    // SAFETY: every address in `bottom..top` is word-aligned RAM of the stack region
    // (cortex-m-rt asserts the alignment), owned by no Rust object below the live stack.
    while p < top && unsafe { read_volatile(p as *const u32) } == STACK_PAINT_VALUE {
        p += 4;
    }
    top - p
}

/// Paint the unused stack below the current stack pointer (minus a margin) again.
#[inline(never)]
#[allow(unsafe_code)]
pub fn repaint() {
    let (bottom, _) = region();
    let sp = cortex_m::register::msp::read() as usize;
    let end = sp.saturating_sub(REPAINT_MARGIN) & !3;
    let mut p = bottom;
    while p < end {
        // SAFETY: `bottom..end` is stack memory below the live stack pointer (with a margin
        // for this function's own frame); no interrupt is enabled, so nothing else uses it.
        unsafe { write_volatile(p as *mut u32, STACK_PAINT_VALUE) };
        p += 4;
    }
}
