//! The `volasso` binary: parses the command line, runs it, reports the one error.
fn main() -> std::process::ExitCode {
    keep_large_buffers_in_the_heap();
    volasso::cli::main()
}

/// Every classification allocates buffers of megabytes (the label volume, the feature readers'
/// planes). glibc maps each one afresh and unmaps it when freed until its adaptive threshold
/// has grown past their size, and each fresh page is a fault. Here buffers up to 32 MB come from
/// the heap, and up to 256 MB of freed heap is kept for the next classification. Measured on the
/// lobster (`classify --repeat 7` against `--repeat 1`, medians of 12 alternating rounds under
/// `perf stat`): runs 2 to 7 faulted 480 pages each instead of 1171 (its label volume is 5.5 MB)
/// and took 17.0 ms of CPU instead of 19.2. Larger buffers (the label volume of a 512³ scan) are
/// still mapped and returned.
fn keep_large_buffers_in_the_heap() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only sets glibc's allocator parameters; it is called before any other
    // thread exists.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 256 << 20);
    }
}
