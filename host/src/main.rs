//! `vsaqem`: point cloud to compact, feature-preserving mesh by VSA-QEM
//! (the command line is `vsaqem::cli`).

use std::process::ExitCode;

fn main() -> ExitCode {
    pin_mmap_threshold();
    vsaqem::cli::main()
}

/// glibc's malloc raises its mmap threshold to the size of each large block
/// freed (up to 32 MiB): blocks up to that size then come from the heap, whose
/// freed space stays resident. The reader's duplicate sort frees one of 8
/// bytes a point, and from then on the run's temporary arrays piled up in the
/// heap: peak RSS 41.8 / 128 / 374 MB at 300k / 1M / 3M points against 38.4 /
/// 117 / 339 MB with the threshold pinned at glibc's default of 128 KiB, so
/// that every larger block has a mapping of its own, unmapped when freed (the
/// bunny: 9.4 against 9.5 MB; the times within the noise). Only the program
/// does this, not the library: how a process allocates is its own choice.
/// musl's allocator has no such threshold.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn pin_mmap_threshold() {
    use std::os::raw::c_int;
    extern "C" {
        fn mallopt(param: c_int, value: c_int) -> c_int;
    }
    /// glibc's `M_MMAP_THRESHOLD` and its default value.
    const M_MMAP_THRESHOLD: c_int = -3;
    const DEFAULT: c_int = 128 * 1024;
    // SAFETY: mallopt takes two integers and only sets malloc's parameters; it
    // is called first thing in main, before any other thread exists. Setting
    // the threshold turns its dynamic raise off. A refusal (0) leaves glibc's
    // own behaviour, which is correct too, so it is not an error.
    unsafe {
        mallopt(M_MMAP_THRESHOLD, DEFAULT);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn pin_mmap_threshold() {}
