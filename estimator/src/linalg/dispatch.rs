//! Which kernels a filter step runs on: AVX2 with FMA where the CPU has them,
//! the portable loops otherwise, or the portable loops on request.
//!
//! The portable path is what every CPU without AVX2 and FMA runs (aarch64
//! among them); forcing it on an x86-64 machine is how it is tested end to
//! end there. Two ways, both checked on every step without allocating:
//!
//! * the environment variable `KALFMU_PORTABLE` set to anything but `0` or
//!   the empty string, read once per process (when the first filter is
//!   built): every thread runs the portable path, e.g.
//!   `KALFMU_PORTABLE=1 cargo test -p estimator`;
//! * [`with_portable_kernels`], for the current thread and the duration of a
//!   closure: a test can run the same filter both ways in one process
//!   without changing what the tests on other threads run.

use std::cell::Cell;
use std::sync::atomic::{AtomicU8, Ordering};

/// The kernels a filter step runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kernels {
    /// Plain Rust loops, compiled for the baseline CPU.
    Portable,
    /// AVX2 and FMA intrinsics, the step compiled with those features.
    Avx2,
}

/// The environment variable that forces the portable kernels for the whole process.
pub const PORTABLE_VARIABLE: &str = "KALFMU_PORTABLE";

thread_local! {
    /// Forced on this thread by [`with_portable_kernels`].
    static FORCED_HERE: Cell<bool> = const { Cell::new(false) };
}

/// The process's choice from the CPU and the environment: not made yet, or the kernels.
static PROCESS_CHOICE: AtomicU8 = AtomicU8::new(NOT_CHOSEN);
const NOT_CHOSEN: u8 = 0;
const PORTABLE: u8 = 1;
const AVX2: u8 = 2;

/// Makes the process's choice if it was not made yet. Filters call this when
/// they are built, so that their steps never read the environment (which allocates).
pub(crate) fn read_environment() {
    if PROCESS_CHOICE.load(Ordering::Relaxed) == NOT_CHOSEN {
        choose_for_the_process();
    }
}

/// The fastest kernels unless [`PORTABLE_VARIABLE`] forbids them; out of
/// line, so that the check on every step stays two loads.
#[cold]
#[inline(never)]
fn choose_for_the_process() -> Kernels {
    let forced = std::env::var_os(PORTABLE_VARIABLE).is_some_and(|v| !v.is_empty() && v != "0");
    let kernels = if forced { Kernels::Portable } else { kernels_available() };
    PROCESS_CHOICE.store(if kernels == Kernels::Avx2 { AVX2 } else { PORTABLE }, Ordering::Relaxed);
    kernels
}

/// The kernels a step on this thread runs now.
#[inline(always)]
pub(crate) fn choice() -> Kernels {
    if FORCED_HERE.with(Cell::get) {
        return Kernels::Portable;
    }
    match PROCESS_CHOICE.load(Ordering::Relaxed) {
        AVX2 => Kernels::Avx2,
        PORTABLE => Kernels::Portable,
        _ => choose_for_the_process(),
    }
}

/// The kernels a filter step on this thread runs now.
pub fn kernels_in_use() -> Kernels {
    choice()
}

/// The fastest kernels this CPU has, whether forced off or not.
pub fn kernels_available() -> Kernels {
    #[cfg(target_arch = "x86_64")]
    if crate::linalg::Avx2::detect().is_some() {
        return Kernels::Avx2;
    }
    Kernels::Portable
}

/// Runs `f` with the portable kernels on this thread, whatever the CPU has
/// (see the module documentation); the previous choice is back afterwards,
/// also when `f` panics.
pub fn with_portable_kernels<T>(f: impl FnOnce() -> T) -> T {
    struct Restore(bool);
    impl Drop for Restore {
        fn drop(&mut self) {
            FORCED_HERE.with(|forced| forced.set(self.0));
        }
    }
    let _restore = Restore(FORCED_HERE.with(|forced| forced.replace(true)));
    f()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_portable_kernels_are_forced_inside_the_closure_only() {
        let outside = kernels_in_use();
        assert_eq!(with_portable_kernels(kernels_in_use), Kernels::Portable);
        let nested = with_portable_kernels(|| (with_portable_kernels(kernels_in_use), kernels_in_use()));
        assert_eq!(nested, (Kernels::Portable, Kernels::Portable), "a nested closure restores the outer one's choice");
        assert_eq!(kernels_in_use(), outside, "the choice is back after the closure");
        let panicked = std::panic::catch_unwind(|| with_portable_kernels(|| panic!("inside")));
        assert!(panicked.is_err());
        assert_eq!(kernels_in_use(), outside, "and after a panic in it");
    }
}
