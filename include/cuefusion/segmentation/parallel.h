#pragma once

#include <opencv2/core/utility.hpp>

namespace cuefusion
{
namespace segmentation
{
/** \brief Runs fn(i) for i in [0, n) on OpenCV's thread pool (TBB in Debian's OpenCV).
  * The segmentation calls OpenCV's bilateral filter, morphology and connected components,
  * which use that pool; OpenMP loops in between left OpenMP's workers spinning for the
  * cores OpenCV's workers needed (measured: 1–2 ms of a 14 ms frame on 2 cores), so the
  * module's own loops use the same pool.
  */
template <typename Index, typename F>
void
parallelFor (Index n, F&& fn)
{
  cv::parallel_for_ (cv::Range (0, static_cast<int> (n)), [&fn] (const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i)
      fn (static_cast<Index> (i));
  });
}
}  // namespace segmentation
}  // namespace cuefusion
