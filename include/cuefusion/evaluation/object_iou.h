// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <opencv2/core.hpp>

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <map>
#include <vector>

namespace cuefusion
{
namespace evaluation
{
/** \brief Maximum-weight assignment of rows to columns (Hungarian method, Kuhn–Munkres
  * with potentials, O(n² m)). Returns for every row its column, or −1 where the row has
  * none (more rows than columns) or only a zero-weight pairing. Weights must be ≥ 0.
  * Written here because neither PCL, OpenCV nor Eigen exposes one.
  */
std::vector<int>
maximumWeightAssignment (const Eigen::MatrixXd& weights);

/** \brief One ground-truth object in one frame. */
struct ObjectIoU
{
  std::uint32_t instance = 0;     ///< ground-truth instance id
  std::int32_t segment = 0;       ///< the map segment matched to it (0 = none)
  std::size_t truth_pixels = 0;
  std::size_t segment_pixels = 0;
  std::size_t intersection = 0;
  double iou = 0.0;               ///< 0 when unmatched
};

struct FrameIoUConfig
{
  /** Objects with fewer visible ground-truth pixels in a frame are not scored there. */
  std::size_t min_truth_pixels = 100;
  void validate () const;
};

/** \brief Per-frame object IoU (thesis §5.3.2): map segments (\a predicted, CV_32S or
  * CV_16U, 0 = no segment) are matched one-to-one to ground-truth instances (\a truth,
  * CV_16U or CV_32S, 0 = no object) by the Hungarian method maximising the summed IoU;
  * every instance with at least min_truth_pixels gets the IoU of its match (0 if none).
  * Only pixels where \a valid (CV_8U, optional) is non-zero count. Throws
  * cuefusion::Error when sizes or types disagree.
  */
std::vector<ObjectIoU>
frameObjectIoU (const cv::Mat& predicted, const cv::Mat& truth, const cv::Mat& valid = cv::Mat (),
                const FrameIoUConfig& config = FrameIoUConfig ());

/** \brief Per-object IoU over a sequence: the mean over the frames where the object was
  * scored, and the mean of those means over objects (the thesis' headline number).
  */
struct SequenceIoU
{
  std::map<std::uint32_t, double> object_mean;        ///< instance → mean IoU
  std::map<std::uint32_t, std::size_t> object_frames; ///< instance → frames scored
  double mean = 0.0;                                  ///< over objects (0 when none)
};

SequenceIoU
summarizeObjectIoU (const std::vector<std::vector<ObjectIoU>>& frames);
}  // namespace evaluation
}  // namespace cuefusion
