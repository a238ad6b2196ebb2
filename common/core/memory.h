// Process-wide allocator settings for the compute binaries.
#pragma once

namespace dome::core {

// Keeps freed large buffers in the heap instead of returning them to the kernel.
// Stereo, fusion and texture jobs allocate and free buffers of 1-30 MB every job; with
// glibc's defaults each becomes a fresh mmap whose pages fault in again (zero-filled
// by the kernel, serialised on the process's memory map when two in-process workers
// do it at once). With these settings the second job of a size reuses the first one's
// pages, and every thread allocates from one arena (memory.cc says why). Call once at
// the start of main(), before any thread starts; idempotent.
void RetainFreedMemory();

// Returns the heap's free pages to the kernel (glibc malloc_trim): for a long-running
// process whose peers' messages (a flood of large ones) would otherwise keep its
// resident memory at their peak for good. Costs about a millisecond per 100 MB of
// heap; a no-op where the allocator has no such call.
void ReleaseFreedMemory();

}  // namespace dome::core
