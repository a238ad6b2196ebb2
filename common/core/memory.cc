#include "core/memory.h"

#include <malloc.h>

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
}

void ReleaseFreedMemory() {
#ifdef M_TRIM_THRESHOLD
  malloc_trim(0);
#endif
}

}  // namespace dome::core
