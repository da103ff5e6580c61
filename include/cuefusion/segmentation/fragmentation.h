// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/segmentation/global_segment_map.h>

#include <array>
#include <cstddef>
#include <vector>

namespace cuefusion
{
namespace segmentation
{
/** \brief How finely a map is divided, for recordings without truth: segments by size and
  * the share of the labelled surface in small segments. A map of a room should hold its
  * surface in few large segments (furniture, walls, floor, counters) and a handful of
  * small objects; hundreds of segments of a few hundred voxels along counters and edges
  * are splinters. Voxels are the labelled voxels of each segment (SegmentRecord::voxels:
  * the TSDF band around the surface, so proportional to its area).
  */
struct FragmentationReport
{
  /** Size classes in voxels: [1, 100), [100, 1000), [1000, 10000), [10000, ∞). */
  static constexpr std::array<std::size_t, 3> kBounds = {100, 1000, 10000};
  std::size_t segments = 0;                  ///< segments with voxels
  std::size_t voxels = 0;                    ///< their voxels together
  std::array<std::size_t, 4> count_by_size{};  ///< segments per size class
  std::array<double, 4> share_by_size{};       ///< share of all voxels per size class
  /** Segments of at least 100 voxels: the count the benchmarks compare with the scene's
    * objects and stuff surfaces. */
  std::size_t segments_at_least_100 () const { return count_by_size[1] + count_by_size[2] + count_by_size[3]; }
  /** Share of the surface in segments of fewer than \a bound voxels (one of kBounds). */
  double shareBelow (std::size_t bound) const;
};

/** \brief The report of the segments \a segments (GlobalSegmentMap::segments(), after
  * refreshStatistics). Segments without voxels are not counted. */
FragmentationReport
fragmentationReport (const std::vector<SegmentRecord>& segments);
}  // namespace segmentation
}  // namespace cuefusion
