// SPDX-License-Identifier: BSD-3-Clause
// InstanceGuidedRegionMerge's parts share these (§4.2.1.3): cutting along masks
// (instance_guided_region_merge.cpp), dividing by colour (color_division.cpp) and grouping
// (instance_grouping.cpp). Internal to the segmentation module.
#pragma once

#include <cuefusion/common/instance.h>
#include <cuefusion/segmentation/instance_guided_region_merge.h>

#include "overlap_table.h"

#include <opencv2/core.hpp>

#include <array>
#include <vector>

namespace cuefusion
{
namespace segmentation
{
namespace detail
{
/** \brief The 4-neighbours of pixel index \a i of a \a rows × \a cols image (left, right,
  * above, below), −1 where the image ends. */
inline std::array<int, 4>
fourNeighbours (int i, int rows, int cols)
{
  const int x = i % cols, y = i / cols;
  return {x > 0 ? i - 1 : -1, x + 1 < cols ? i + 1 : -1, y > 0 ? i - cols : -1, y + 1 < rows ? i + cols : -1};
}

/** \brief Breadth-first growth over the 4-connected pixels of a \a rows × \a cols image
  * from every index in \a queue: a neighbour j of a reached pixel i is reached when
  * join(i, j) accepts (and marks) it. \a queue ends holding every pixel reached. */
template <typename Join>
void
growFourConnected (std::vector<int>& queue, int rows, int cols, Join&& join)
{
  for (std::size_t k = 0; k < queue.size (); ++k)
  {
    const int i = queue[k];
    for (const int j : fourNeighbours (i, rows, cols))
      if (j >= 0 && join (i, j))
        queue.push_back (j);
  }
}

/** \brief Per label of \a labels (CV_32S, 1..max): its pixel count and the instance ids
  * of \a ids it meets, with their pixels; with \a color (CV_8UC3) and \a sums, also
  * those pixels' summed colour (BGR), sums[l][e] for entry e of label l. */
OverlapTable<int>
countOverlaps (const cv::Mat& labels, const cv::Mat& ids, const cv::Mat& color = cv::Mat (),
               std::vector<std::vector<cv::Vec3d>>* sums = nullptr);

/** \brief Throws cuefusion::Error unless L^G is a non-empty CV_32S image and every mask is CV_8U of its size. */
void
checkInputs (const cv::Mat& geometric, const std::vector<Instance>& instances);

/** \brief What a piece claimed by instance \a id (1-based; 0 = none) is: its class and score. */
SegmentInstance
describe (const std::vector<Instance>& instances, int id);

/** \brief Whether the colour division runs: a colour, the cue on, masks to divide; throws on a
  * colour image of the wrong kind. */
bool
colorDivisionApplies (const InstanceGuidedRegionMergeConfig& config, const cv::Mat& geometric, const std::vector<Instance>& instances,
                      const cv::Mat& color);

/** \brief countOverlaps of \a geometric against \a ids with the colour; where a claimed segment is
  * two colours side by side, \a geometric becomes the divided label image, counted again. */
OverlapTable<int>
countDividingByColor (const InstanceGuidedRegionMergeConfig& config, cv::Mat& geometric, const cv::Mat& ids, const cv::Mat& color,
                      std::vector<std::vector<cv::Vec3d>>& sums);

/** \brief divideByColor on counts already made: \a owned and \a sums from countOverlaps of L^G
  * against \a ids (the instances' id image) with the colour. */
std::vector<Instance>
divideOwned (const InstanceGuidedRegionMergeConfig& config, const cv::Mat& geometric, const std::vector<Instance>& instances,
             const cv::Mat& ids, const OverlapTable<int>& owned, const std::vector<std::vector<cv::Vec3d>>& sums);
}  // namespace detail
}  // namespace segmentation
}  // namespace cuefusion
