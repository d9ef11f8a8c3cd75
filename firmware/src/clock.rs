//! The instruction clock: the MPS2 FPGA's 32-bit cycle counter, calibrated in instructions.
//!
//! Under `qemu-system-arm -icount shift=0` QEMU's virtual clock advances exactly 1 ns per
//! guest instruction, and every timer of the board runs on that clock. The FPGA IO block's
//! `COUNTER` register (MPS2 AN385/AN386/AN500, base `0x4002_8000`, offset `0x18`; AN505 below)
//! counts up at the 25 MHz prescaler clock (`PRESCALE` = 0 after reset), so one tick is 40 instructions and
//! the 32-bit counter wraps after 2³² ticks ≈ 1.7·10¹¹ instructions, far beyond one run.
//! SysTick would do as well but is 24 bits wide and wraps every 6.7·10⁸ instructions, less
//! than one ColoRadar frame takes.
//!
//! The 40 is not taken on trust: [`calibrate`] times two runs of `cortex_m::asm::delay`, whose
//! body (cortex-m 0.7.10, pinned by `Cargo.lock`) is the two-instruction loop `subs`; `bne`
//! run `cycles + 1` times, so the two runs differ by exactly `2 · (cycles₂ − cycles₁)`
//! instructions whatever the call overhead.

use core::ptr::read_volatile;

/// Address of the FPGA IO `COUNTER` register (AN386 TRM, "FPGA system control and I/O").
#[cfg(not(mps2_tz))]
const FPGAIO_COUNTER: usize = 0x4002_8018;
/// The same register on the AN505 (Cortex-M33): FPGA IO at `0x4030_2000`, reached through its
/// Secure alias `0x5030_2000` (the core runs Secure; the block's PPC leaves it Secure-only
/// after reset). Its prescaler clock is 20 MHz there: 50 instructions per tick, calibrated.
#[cfg(mps2_tz)]
const FPGAIO_COUNTER: usize = 0x5030_2018;

/// The current counter value, ticks.
#[inline(always)]
#[allow(unsafe_code)]
pub fn ticks() -> u32 {
    // SAFETY: a 32-bit aligned read of a read-only memory-mapped register of the MPS2 FPGA IO
    // block, present on every board this firmware runs on (mps2-an385/386/500/505); reading it has
    // no side effect on the program's memory.
    unsafe { read_volatile(FPGAIO_COUNTER as *const u32) }
}

/// Ticks spent in `f`, and its result.
#[inline(always)]
pub fn time<R>(f: impl FnOnce() -> R) -> (u32, R) {
    let start = ticks();
    let r = f();
    (ticks().wrapping_sub(start), r)
}

/// The instruction clock's calibration.
#[derive(Clone, Copy, Debug)]
pub struct Calibration {
    /// Instructions of the difference between the two calibration runs.
    pub instructions: u32,
    /// Ticks of that difference.
    pub ticks: u32,
    /// Whole instructions per tick: the ratio rounded to the nearest integer.
    pub per_tick: u32,
}

impl Calibration {
    /// Whether the measurement is an integer ratio within its resolution: each of the four
    /// readings is quantised to one tick, so `ticks` may be off by ±2 from `instructions /
    /// per_tick`. Anything else means the clock does not run on the instruction count (QEMU
    /// without `-icount shift=0`, or real hardware).
    pub fn is_exact(&self) -> bool {
        let per = u64::from(self.per_tick);
        per > 0 && u64::from(self.instructions).abs_diff(per * u64::from(self.ticks)) <= 2 * per
    }

    /// Instructions of `ticks` ticks.
    pub fn instructions(&self, ticks: u64) -> u64 {
        ticks * u64::from(self.per_tick)
    }
}

/// Measure instructions per tick with two delay loops of known length.
pub fn calibrate() -> Calibration {
    const SHORT: u32 = 1_000_000;
    const LONG: u32 = 21_000_000;
    let (short, ()) = time(|| cortex_m::asm::delay(SHORT));
    let (long, ()) = time(|| cortex_m::asm::delay(LONG));
    let instructions = 2 * (LONG - SHORT);
    let ticks = long.wrapping_sub(short);
    Calibration {
        instructions,
        ticks,
        per_tick: (instructions + ticks / 2) / ticks.max(1),
    }
}
