//! Cache hints: requests to fetch memory early, with no effect on any result.
//!
//! The partition's region growing visits points in cost order, which jumps all
//! over the cloud; on large clouds its time goes mostly to waiting for memory.
//! Asking for a point's rows one step before they are read hides much of that
//! wait (1M points: a quarter of the clustering time, `bench/notes.md`).
//!
//! The second module of the crate that uses `unsafe`, for the one instruction:
//! a prefetch never faults, whatever the address, and reads nothing into the
//! program.
#![allow(unsafe_code)]

/// Ask for the cache line holding `p`. `p` need not be valid: it is never
/// dereferenced. A no-op on targets other than x86-64 and AArch64.
#[inline(always)]
pub fn prefetch<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: PREFETCHT0 is a hint: it never faults and changes no state the
    // program can observe.
    unsafe {
        core::arch::x86_64::_mm_prefetch(p as *const i8, core::arch::x86_64::_MM_HINT_T0);
    }
    #[cfg(target_arch = "aarch64")]
    // SAFETY: PRFM is a hint: it never faults and changes no register, flag or
    // memory the program can observe.
    unsafe {
        core::arch::asm!("prfm pldl1keep, [{0}]", in(reg) p, options(nostack, readonly, preserves_flags));
    }
    #[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
    let _ = p;
}
