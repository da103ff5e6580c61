// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <opencv2/core/utility.hpp>

#include <algorithm>

namespace cuefusion
{
/** \brief Runs fn(i) for i in [0, n) on OpenCV's thread pool (TBB in Debian's OpenCV).
  *
  * Every parallel loop of the project goes through this one pool. OpenCV's own calls
  * (bilateral filter, morphology, connected components) already use it, and a second pool
  * (OpenMP) left its workers spinning for the cores OpenCV's workers needed — measured: 1–2
  * ms of a 14 ms segmentation on 2 cores, and about a third of all CPU samples of a whole
  * `cuefusion run` were OpenMP spin-waits.
  */
namespace detail
{
/** Builds with ThreadSanitizer (scripts/test --tsan) only: OpenCV's pool (TBB in Debian)
  * is not instrumented, so TSan cannot see how it hands work to its threads and reports
  * every loop below as a race. There the loops run on the calling thread, and what TSan
  * checks is cuefusion's own threads (mask thread, viewer hand-off, grabber thread). */
inline void
serialUnderThreadSanitizer ()
{
#if defined(__SANITIZE_THREAD__)
  static const bool serial = [] {
    cv::setNumThreads (0);
    return true;
  }();
  (void) serial;
#endif
}
}  // namespace detail

template <typename Index, typename F>
void
parallelFor (Index n, F&& fn)
{
  detail::serialUnderThreadSanitizer ();
  cv::parallel_for_ (cv::Range (0, static_cast<int> (n)), [&fn] (const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i)
      fn (static_cast<Index> (i));
  });
}

/** \brief Splits [0, n) into fixed chunks of \a chunk indices and runs fn(k, begin, end)
  * for chunk k on the pool, which balances them dynamically. The partition does not
  * depend on the thread count, so per-chunk partial results (sums, candidate lists)
  * stored by k and combined in k order give the same answer on every run and machine.
  */
template <typename F>
void
parallelForChunks (int n, int chunk, F&& fn)
{
  if (n <= 0)
    return;
  chunk = std::max (1, chunk);
  const int chunks = (n + chunk - 1) / chunk;
  detail::serialUnderThreadSanitizer ();
  cv::parallel_for_ (cv::Range (0, chunks), [&] (const cv::Range& range) {
    for (int k = range.start; k < range.end; ++k)
      fn (k, k * chunk, std::min (n, (k + 1) * chunk));
  }, chunks);
}

/** \brief Number of chunks parallelForChunks makes of \a n indices. */
inline int
chunkCount (int n, int chunk)
{
  chunk = std::max (1, chunk);
  return n <= 0 ? 0 : (n + chunk - 1) / chunk;
}
}  // namespace cuefusion
