#include "core/memory.h"

#include <malloc.h>
#include <sys/prctl.h>

#include <cstdlib>
#include <cstring>

namespace dome::core {

void RetainFreedMemory() {
#ifdef M_MMAP_THRESHOLD
  // Up to glibc's ceiling (32 MiB on 64-bit) allocations come from the heap; larger
  // ones (a whole fusion arena) stay mmaps that their owners reuse themselves.
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  // Shrink a heap only when 1 GiB at its top is free: the working set of a job is
  // reused by the next job, so trimming it would only fault it in again.
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
#endif
#ifdef M_ARENA_MAX
  // One arena for every thread. Jobs run their loops on threads that core::ParallelFor
  // starts and joins per call, and each thread takes whichever arena is free: a job's
  // buffers end up spread over several arenas, each holding its own peak, and a freed
  // buffer in one arena is no use to the next job allocating from another, whose pages
  // fault in afresh. With one arena the next job reuses the last one's pages
  // (Robovision 12_11_32, `dome run` with one worker of 2 threads: 122,000 page faults
  // and 4.8 CPU s -> 78,000 and 4.4 s; 0.89x wall in alternating pairs). The master
  // needs it too: ZeroMQ's I/O thread allocates each message it receives in an arena of
  // its own, and malloc_trim (ReleaseFreedMemory) does not give back the free top of
  // another arena's heap, so after a burst of large messages it stayed resident
  // (master_flood_bench: 53 or 101 MB after a round; 53.5 MB every round with one
  // arena). Small allocations come from glibc's per-thread caches without the lock;
  // large ones are few per job, so threads seldom wait on it.
  mallopt(M_ARENA_MAX, 1);
#endif
}

bool AvoidTransparentHugePages() {
  // Measured on a 2-core virtual machine with the system set to "always": a Robovision
  // instant's `dome run` took 4.32 s of wall with huge pages against 3.21 s without (4
  // alternating pairs, 0.74x), the Panoptic take 0.98x and the paper take 0.99x (their
  // later instants reuse the memory of the first); set to "madvise" (nothing here asks
  // for them) the setting changes nothing. A fresh 256 MB mapping written once: 1.0-1.9 s
  // in 2 MB pages, 0.1-0.2 s in 4 KB pages. No loop measured faster with huge pages
  // (fusion's tables, fusion/integrate.cc); a host where they pay can keep them.
  const char* keep = std::getenv("DOME_TRANSPARENT_HUGEPAGES");
  if (keep != nullptr && std::strcmp(keep, "1") == 0) return false;
#ifdef PR_SET_THP_DISABLE
  return prctl(PR_SET_THP_DISABLE, 1, 0, 0, 0) == 0;
#else
  return false;
#endif
}

void ReleaseFreedMemory() {
#ifdef M_TRIM_THRESHOLD
  malloc_trim(0);
#endif
}

}  // namespace dome::core
