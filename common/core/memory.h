// Process-wide allocator settings for the compute binaries.
#pragma once

#include <cstddef>

namespace dome::core {

// Keeps freed large buffers in the heap instead of returning them to the kernel.
// Stereo, fusion and texture jobs allocate and free buffers of 1-30 MB every job; with
// glibc's defaults each becomes a fresh mmap whose pages fault in again (zero-filled
// by the kernel, serialised on the process's memory map when two in-process workers
// do it at once). With these settings the second job of a size reuses the first one's
// pages, and every thread allocates from one arena (memory.cc says why). Call once at
// the start of main(), before any thread starts; idempotent.
void RetainFreedMemory();

// The pages a process's fresh memory gets: 4 KB pages, or transparent 2 MB pages where
// the process asks for them (madvise MADV_HUGEPAGE).
enum class PageSize { kSmall, kHuge };

// Chooses the pages of this process's fresh memory by what the machine's first touch of
// memory costs, and sets the process up for it. What a dome process does is mostly
// first touches (a Robovision instant's `dome run` faults in about 500 MB once), and on
// the virtual machines dome is measured on their cost differs by an order of magnitude
// either way (memory.cc has the figures). DOME_TRANSPARENT_HUGEPAGES in the environment
// decides: "1" huge pages, "0" small pages; unset or anything else, a probe at start
// (about 6 ms) times the first touch of 1 MB in 4 KB pages against one 2 MB page, twice
// each, and takes huge pages where the best 2 MB touch is faster than the best 1 MB one
// (at least twice as fast per byte).
//  * kSmall: transparent huge pages off for this process and the processes it starts
//    (prctl PR_SET_THP_DISABLE), also where the system gives them to every mapping
//    (/sys/kernel/mm/transparent_hugepage/enabled "always").
//  * kHuge: huge pages on for the process (the prctl flag cleared); the heap is grown
//    once by kHugeHeapReserveBytes of address space (nothing touched) and that range
//    advised for huge pages, so that the buffers malloc places there fault in 2 MB at a
//    time; mappings of dome's own (fusion's tables) ask for them with AdviseHugePages.
//    Where the system's setting is "never" no page is huge and the probe finds no gain.
//    (dome-master hands its heap's free top back every few seconds, ReleaseFreedMemory:
//    there the reserve lasts until then, and later heap is advised no more.)
// Call once at the start of main(), after RetainFreedMemory (whose heap settings keep
// the reserve in the heap) and before any thread starts. Returns the choice.
PageSize ChoosePageSize();

// The choice ChoosePageSize made (kSmall before it ran).
PageSize ChosenPageSize();

// Where the process chose kHuge, advises [base, base + bytes) for transparent huge
// pages (the whole 2 MB pages inside it); otherwise nothing. For a fresh mapping,
// before its first touch.
void AdviseHugePages(void* base, size_t bytes);

// Heap address space advised for huge pages under kHuge, bytes (below RetainFreedMemory's
// trim threshold, so that free() never hands it back).
constexpr size_t kHugeHeapReserveBytes = size_t{512} << 20;

// Returns the heap's free pages to the kernel (glibc malloc_trim): for a long-running
// process whose peers' messages (a flood of large ones) would otherwise keep its
// resident memory at their peak for good. Costs about a millisecond per 100 MB of
// heap; a no-op where the allocator has no such call.
void ReleaseFreedMemory();

}  // namespace dome::core
