// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace cuefusion
{
/** \brief One object instance reported by an instance-segmentation source (thesis
  * §4.2.1.2): a binary mask at image resolution with its class and score.
  */
struct Instance
{
  cv::Mat mask;              ///< CV_8U, non-zero = the instance, the frame's size
  int class_id = -1;         ///< index into the source's class list; -1 = unknown
  std::string class_name;    ///< "" when unknown
  float score = 1.f;         ///< detection confidence in [0, 1]
  cv::Rect box;              ///< bounding box of the mask (or the detector's box)
};

/** \brief Milliseconds of a mask source's last segment() by stage (a network's: building
  * its input, the forward pass, decoding its output into masks); zeros for a source that
  * does not time its stages. */
struct SegmenterTimings
{
  double input_ms = 0.0;
  double forward_ms = 0.0;
  double decode_ms = 0.0;
};

/** \brief Instances → CV_16U id image (instance i has id i + 1, 0 = none); where masks
  * overlap the higher score wins (the earlier instance on a tie).
  */
cv::Mat
instancesToIdImage (const std::vector<Instance>& instances, cv::Size size);

/** \brief CV_16U (or CV_32S) id image → one Instance per distinct non-zero id, in
  * increasing id order, with class -1 and score 1; \a ids_out receives the ids. More
  * than 1024 distinct ids is a cuefusion::Error (each instance holds a full-frame mask).
  */
std::vector<Instance>
instancesFromIdImage (const cv::Mat& ids, std::vector<int>* ids_out = nullptr);
}  // namespace cuefusion
