// Static-partition parallel loops on std::thread.
//
// The work is cut into contiguous chunks whose boundaries depend only on the range
// and the chunk count, so results that are written per index are identical for any
// thread count.
#pragma once

#include <cstdint>
#include <functional>

namespace dome::core {

// Number of hardware threads, at least 1.
int HardwareThreads();

// Calls fn(chunk_begin, chunk_end) over [begin, end) split into at most num_threads
// contiguous chunks, each on its own thread (the calling thread runs one of them).
// num_threads <= 0 means HardwareThreads(). Exceptions thrown by fn are rethrown
// (the first one) after every chunk has finished.
void ParallelFor(int64_t begin, int64_t end, int num_threads,
                 const std::function<void(int64_t, int64_t)>& fn);

}  // namespace dome::core
