// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/label_colors.h>
#include <cuefusion/visualization/frame_view.h>

#include <opencv2/imgproc.hpp>

namespace cuefusion
{
namespace visualization
{
cv::Mat
colorizeDepth (const cv::Mat& depth, float colour_near, float colour_far)
{
  if (depth.type () != CV_32FC1)
    throw Error ("colorizeDepth", "depth must be CV_32FC1");
  cv::Mat scaled (depth.size (), CV_8U);
  cv::Mat valid (depth.size (), CV_8U);
  for (int r = 0; r < depth.rows; ++r)
    for (int c = 0; c < depth.cols; ++c)
    {
      const float z = depth.at<float> (r, c);
      valid.at<std::uint8_t> (r, c) = isValidDepth (z) ? 255 : 0;
      const float t = std::min (1.f, std::max (0.f, (z - colour_near) / (colour_far - colour_near)));
      scaled.at<std::uint8_t> (r, c) = cv::saturate_cast<std::uint8_t> (255.f * (1.f - t));
    }
  cv::Mat out;
  cv::applyColorMap (scaled, out, cv::COLORMAP_TURBO);
  out.setTo (cv::Scalar::all (0), valid == 0);
  return out;
}

namespace
{
void
title (cv::Mat& panel, const std::string& text)
{
  const double scale = std::max (0.4, panel.cols / 1000.0);
  cv::putText (panel, text, cv::Point (8, static_cast<int> (24 * scale + 4)), cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar::all (0),
               3, cv::LINE_AA);
  cv::putText (panel, text, cv::Point (8, static_cast<int> (24 * scale + 4)), cv::FONT_HERSHEY_SIMPLEX, scale,
               cv::Scalar::all (255), 1, cv::LINE_AA);
}
}  // namespace

cv::Mat
composeFrameView (const RGBDFrame& frame, const cv::Mat& labels)
{
  if (frame.color.empty () || frame.depth.empty () || frame.color.size () != frame.depth.size ())
    throw Error ("composeFrameView", "the frame needs colour and depth of one size");
  if (labels.type () != CV_32SC1 || labels.size () != frame.depth.size ())
    throw Error ("composeFrameView", "labels must be CV_32SC1 of the frame's size");
  cv::Mat color = frame.color.clone ();
  cv::Mat depth = colorizeDepth (frame.depth);
  cv::Mat overlay (color.size (), CV_8UC3);
  for (int r = 0; r < labels.rows; ++r)
    for (int c = 0; c < labels.cols; ++c)
    {
      const auto label = static_cast<std::uint32_t> (labels.at<std::int32_t> (r, c));
      const cv::Vec3b& bgr = color.at<cv::Vec3b> (r, c);
      if (label == 0)
      {
        overlay.at<cv::Vec3b> (r, c) = bgr * 0.4;
        continue;
      }
      const cv::Vec3b rgb = labelColor (label);
      overlay.at<cv::Vec3b> (r, c) = cv::Vec3b (cv::saturate_cast<std::uint8_t> (0.7 * rgb[2] + 0.3 * bgr[0]),
                                                cv::saturate_cast<std::uint8_t> (0.7 * rgb[1] + 0.3 * bgr[1]),
                                                cv::saturate_cast<std::uint8_t> (0.7 * rgb[0] + 0.3 * bgr[2]));
    }
  title (color, "colour " + frame.name);
  title (depth, "depth");
  title (overlay, "map segments");
  cv::Mat out;
  cv::hconcat (std::vector<cv::Mat>{color, depth, overlay}, out);
  return out;
}
}  // namespace visualization
}  // namespace cuefusion
