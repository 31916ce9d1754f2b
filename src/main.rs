#![recursion_limit = "256"]
//! The `raysplat` binary: a thin front end over the library (see `cli`).

mod cli;

fn main() {
    return_freed_memory();
    std::process::exit(cli::main());
}

/// glibc serves a block of any size up to 32 MiB from its heap once a block that large was
/// freed (the mmap threshold follows the largest freed mapping), and freed heap blocks stay
/// resident: the eye pass's bands, a light pass's waves and the resolve's maps then held
/// about 10 MB of a render's peak that nothing used (docs/benchmarks.md, "Memory"). A fixed
/// threshold of 1 MiB maps every large array of its own, so freeing it gives it back;
/// smaller blocks (the per-task buffers of the hot loops) stay on the heap, as fast as before.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn return_freed_memory() {
    // SAFETY: mallopt only sets a parameter of the allocator, before any thread exists; a
    // refusal (return 0) leaves glibc's default, which is harmless.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 1 << 20);
    }
}

/// Other allocators return large blocks on their own terms.
#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn return_freed_memory() {}
