// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>

namespace cuefusion
{
/** \brief Stable, distinguishable colour (R, G, B) of a segment label. Label 0 (no
  * segment) is black. Labels walk a fixed 30-colour palette of well-separated hues and
  * lightnesses; labels more than 30 apart repeat a colour, rarely a problem because
  * neighbouring segments in one view have nearby labels.
  */
cv::Vec3b
labelColor (std::uint32_t label);

/** \brief CV_32S (or CV_16U) label image → CV_8UC3 BGR picture, label 0 black. */
cv::Mat
colorizeLabels (const cv::Mat& labels);
}  // namespace cuefusion
