#include "core/memory.h"

#include <malloc.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
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

namespace {

constexpr size_t kHugePage = size_t{2} << 20;

std::atomic<PageSize> g_page_size{PageSize::kSmall};

char* AlignUp(char* p, size_t a) {
  return reinterpret_cast<char*>((reinterpret_cast<uintptr_t>(p) + a - 1) & ~(uintptr_t(a) - 1));
}
char* AlignDown(char* p, size_t a) {
  return reinterpret_cast<char*>(reinterpret_cast<uintptr_t>(p) & ~(uintptr_t(a) - 1));
}

// Seconds to write one byte in each page of [p, p + bytes): the first touches.
double TouchSeconds(char* p, size_t bytes, size_t page) {
  const auto t0 = std::chrono::steady_clock::now();
  for (size_t i = 0; i < bytes; i += page) static_cast<volatile char*>(p)[i] = 1;
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Whether a 2 MB page faults in at least twice as fast as the same bytes of small pages
// here: the best of two touches of each (1 MB of small pages against one 2 MB page),
// alternating, in windows of one fresh mapping (ChoosePageSize).
bool HugePagesFaultFaster() {
  constexpr int kRounds = 2;
  const size_t page = size_t(sysconf(_SC_PAGESIZE));
  const size_t bytes = (2 * kRounds + 1) * kHugePage;  // one spare page for the alignment
  void* m = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (m == MAP_FAILED) return false;
  char* base = AlignUp(static_cast<char*>(m), kHugePage);
  double small = HUGE_VAL, huge = HUGE_VAL;
  bool advised = true;
  for (int r = 0; r < kRounds; ++r) {
    char* s = base + size_t(2 * r) * kHugePage;
    char* h = s + kHugePage;
    advised = advised && madvise(s, kHugePage, MADV_NOHUGEPAGE) == 0 &&
              madvise(h, kHugePage, MADV_HUGEPAGE) == 0;
    if (!advised) break;
    small = std::min(small, TouchSeconds(s, kHugePage / 2, page));
    huge = std::min(huge, TouchSeconds(h, kHugePage, page));
  }
  munmap(m, bytes);
  return advised && huge < small;
}

// Grows the heap by kHugeHeapReserveBytes of untouched address space and advises it for
// huge pages (ChoosePageSize). glibc grows its heap by M_TOP_PAD beyond each request; a
// request above what the young heap has free makes it grow, and freeing it leaves the
// whole pad as the heap's free top, which RetainFreedMemory's trim threshold keeps.
void AdviseHeapForHugePages() {
#if defined(M_TOP_PAD) && defined(M_MMAP_THRESHOLD)
  constexpr size_t kRequest = size_t{16} << 20;  // below RetainFreedMemory's mmap threshold
  char* before = static_cast<char*>(sbrk(0));
  mallopt(M_TOP_PAD, int(kHugeHeapReserveBytes));
  void* p = std::malloc(kRequest);
  // Kept: a compiler may drop an allocation that is freed unused.
  asm volatile("" : : "r"(p) : "memory");
  std::free(p);
  mallopt(M_TOP_PAD, 128 << 10);  // glibc's default
  char* after = static_cast<char*>(sbrk(0));
  if (before == reinterpret_cast<char*>(-1) || after == reinterpret_cast<char*>(-1)) return;
  char* lo = AlignUp(before, kHugePage);
  char* hi = AlignDown(after, kHugePage);
  if (hi > lo) madvise(lo, size_t(hi - lo), MADV_HUGEPAGE);
#endif
}

}  // namespace

PageSize ChoosePageSize() {
  // Measured on two kinds of 2-core virtual machine. On one, a fresh 256 MB mapping
  // written once took 1.0-1.9 s in 2 MB pages against 0.1-0.2 s in 4 KB pages, and a
  // Robovision instant's `dome run` with the system set to "always" 4.32 s of wall
  // against 3.21 s without huge pages (0.74x). On the other (an AMD EPYC), the same
  // mapping took 0.016-0.55 s in 2 MB pages against 0.66-0.90 s in 4 KB pages (about
  // 10 us a small page), and that `dome run` faulted 127,000 small pages (about 1.3 CPU
  // s of the kernel's); with huge pages 2,400 faults. The probe tells the two apart with
  // a wide margin. No loop measured faster or slower with either (fusion's tables,
  // fusion/integrate.cc): it is the first touch that differs.
  const char* env = std::getenv("DOME_TRANSPARENT_HUGEPAGES");
  bool huge;
  if (env != nullptr && std::strcmp(env, "1") == 0) {
    huge = true;
  } else if (env != nullptr && std::strcmp(env, "0") == 0) {
    huge = false;
  } else {
#ifdef PR_SET_THP_DISABLE
    // A parent's choice of small pages is inherited; the probe needs huge pages allowed.
    prctl(PR_SET_THP_DISABLE, 0, 0, 0, 0);
#endif
    huge = HugePagesFaultFaster();
  }
#ifdef PR_SET_THP_DISABLE
  prctl(PR_SET_THP_DISABLE, huge ? 0 : 1, 0, 0, 0);
#endif
  if (huge) AdviseHeapForHugePages();
  g_page_size.store(huge ? PageSize::kHuge : PageSize::kSmall);
  return huge ? PageSize::kHuge : PageSize::kSmall;
}

PageSize ChosenPageSize() { return g_page_size.load(); }

void AdviseHugePages(void* base, size_t bytes) {
  if (g_page_size.load() != PageSize::kHuge || base == nullptr) return;
  char* lo = AlignUp(static_cast<char*>(base), kHugePage);
  char* hi = AlignDown(static_cast<char*>(base) + bytes, kHugePage);
  if (hi > lo) madvise(lo, size_t(hi - lo), MADV_HUGEPAGE);
}

void ReleaseFreedMemory() {
#ifdef M_TRIM_THRESHOLD
  malloc_trim(0);
#endif
}

}  // namespace dome::core
