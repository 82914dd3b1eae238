//! Wider vectors for the solver's own hot loops, chosen at run time.
//!
//! The crate is built for baseline x86-64 (SSE2: two doubles a register) so that the wheel runs
//! on any x86-64 CPU; rustfft picks AVX at run time, and so do the loops wrapped in
//! [`wide_fn!`]: each gets a second copy compiled with AVX2 enabled (four doubles a register),
//! called when the CPU has it. Both copies are the same Rust code: no FMA (Rust never contracts
//! a multiply and an add, and FMA is not enabled), no reassociation (floating-point operations
//! are never reordered without fast-math), so the two give bitwise the same results; only the
//! instructions differ. `tests/wide_vectors.rs` checks it on whole solves, both paths in one run.

use std::sync::atomic::{AtomicBool, Ordering};

/// Set by [`set_wide_vectors`]`(false)`: every wrapped loop runs its baseline copy.
static BASELINE_ONLY: AtomicBool = AtomicBool::new(false);

/// Whether the wrapped loops run their AVX2 copies: the CPU has AVX2 and they are not switched off.
#[inline]
pub(crate) fn avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        !BASELINE_ONLY.load(Ordering::Relaxed) && std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// `false`: the solver's loops use their baseline (SSE2) copies from now on, in every thread;
/// `true`: their AVX2 copies where the CPU has AVX2 (the default). Results are bitwise the same
/// either way; this exists for the tests that show it and for benchmarks.
#[doc(hidden)]
pub fn set_wide_vectors(enabled: bool) {
    BASELINE_ONLY.store(!enabled, Ordering::Relaxed);
}

/// Whether the AVX2 copies run (see [`set_wide_vectors`]).
#[doc(hidden)]
pub fn wide_vectors() -> bool {
    avx2()
}

/// A function whose body is compiled twice, for baseline x86-64 and with AVX2 enabled, the
/// second called when [`avx2`] says so. Arguments must be plain identifiers.
macro_rules! wide_fn {
    ($(#[$meta:meta])* $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $(#[$meta])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2")]
                #[allow(unused_unsafe, clippy::too_many_arguments)]
                unsafe fn with_avx2($($arg: $ty),*) $(-> $ret)? $body
                if $crate::solver::wide::avx2() {
                    // SAFETY: the CPU has AVX2 (detected at run time).
                    return unsafe { with_avx2($($arg),*) };
                }
            }
            $body
        }
    };
}

pub(crate) use wide_fn;
