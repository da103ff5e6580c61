// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/rgbd_frame.h>
#include <cuefusion/common/sensor_defaults.h>

#include <opencv2/core.hpp>

namespace cuefusion
{
namespace visualization
{
/** \brief A depth image (metres, CV_32F) as a BGR picture: near warm, far cool (OpenCV's
  * TURBO map from \a colour_near to \a colour_far metres), invalid pixels black. */
cv::Mat
colorizeDepth (const cv::Mat& depth, float colour_near = 0.3f, float colour_far = static_cast<float> (kMaxDepth));

/** \brief The thesis' Fig. 5.3 panel of one frame, side by side: the input colour, the
  * input depth, and the map's segment labels seen from the camera (\a labels, CV_32S,
  * labelColor per id, blended 70/30 over the colour image; unlabelled pixels show the
  * colour dimmed). Each panel is titled. Throws cuefusion::Error on mismatched sizes.
  */
cv::Mat
composeFrameView (const RGBDFrame& frame, const cv::Mat& labels);
}  // namespace visualization
}  // namespace cuefusion
