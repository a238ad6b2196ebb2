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

// Turns transparent huge pages off for this process and the processes it starts
// (prctl PR_SET_THP_DISABLE), unless the environment's DOME_TRANSPARENT_HUGEPAGES is 1.
// Where the system gives every large mapping 2 MB pages
// (/sys/kernel/mm/transparent_hugepage/enabled "always"), each first touch of one zeroes
// and faults in 2 MB, which on the virtual machines dome is measured on costs about ten
// times as much as the same memory in 4 KB pages (memory.cc has the figures); a dome
// process touches most of its memory once. Call once at the start of main(); idempotent.
// Returns whether huge pages are off for the process.
bool AvoidTransparentHugePages();

// Returns the heap's free pages to the kernel (glibc malloc_trim): for a long-running
// process whose peers' messages (a flood of large ones) would otherwise keep its
// resident memory at their peak for good. Costs about a millisecond per 100 MB of
// heap; a no-op where the allocator has no such call.
void ReleaseFreedMemory();

}  // namespace dome::core
