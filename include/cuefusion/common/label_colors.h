// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>

namespace cuefusion
{
/** \brief Stable, distinguishable colour (R, G, B) of a segment label. Label 0 (no
  * segment) is black. Labels 1–30 take a fixed palette of well-separated hues and
  * lightnesses; later labels take the colours of a 10-level RGB grid (greys and the
  * palette's colours left out), visited in a scattered order so that consecutive labels
  * differ strongly. No two of the first labelColorCount () labels (about a thousand) share a colour; after that
  * the sequence repeats.
  */
cv::Vec3b
labelColor (std::uint32_t label);

/** \brief The colour outputs draw a surface point of segment \a label in (R, G, B):
  * labelColor, and grey (160, 160, 160) for no segment (label 0), which black would hide
  * in renders and viewers. */
cv::Vec3b
segmentColor (std::uint32_t label);

/** \brief How many labels (1..kLabelColors) have colours of their own in labelColor. */
std::uint32_t
labelColorCount ();

/** \brief CV_32S (or CV_16U) label image → CV_8UC3 BGR picture, label 0 black. */
cv::Mat
colorizeLabels (const cv::Mat& labels);
}  // namespace cuefusion
