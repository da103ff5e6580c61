// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/label_colors.h>

namespace cuefusion
{
namespace
{
// Kelly's 22 colours of maximum contrast (without white and black) plus 8 of the
// Glasbey set, so that adjacent labels get very different hues. Fixed, not random per
// run: the same segment id always has the same colour in every picture and PCD.
const std::uint8_t kPalette[30][3] = {
  {242, 243, 244}, {243, 195, 0},   {135, 86, 146},  {243, 132, 0},   {161, 202, 241}, {190, 0, 50},
  {194, 178, 128}, {132, 132, 130}, {0, 136, 86},    {230, 143, 172}, {0, 103, 165},   {249, 147, 121},
  {96, 78, 151},   {246, 166, 0},   {179, 68, 108},  {220, 211, 0},   {136, 45, 23},   {141, 182, 0},
  {101, 69, 34},   {226, 88, 34},   {43, 61, 38},    {0, 255, 255},   {255, 0, 255},   {0, 0, 255},
  {255, 0, 0},     {0, 255, 0},     {0, 128, 128},   {128, 0, 255},   {255, 128, 128}, {128, 255, 0}};
}  // namespace

cv::Vec3b
labelColor (std::uint32_t label)
{
  if (label == 0)
    return cv::Vec3b (0, 0, 0);
  const std::uint8_t* c = kPalette[(label - 1) % 30];
  return cv::Vec3b (c[0], c[1], c[2]);
}

cv::Mat
colorizeLabels (const cv::Mat& labels)
{
  if (labels.type () != CV_32S && labels.type () != CV_16U)
    throw Error ("colorizeLabels", "expects a CV_32S or CV_16U label image");
  cv::Mat picture (labels.size (), CV_8UC3);
  for (int y = 0; y < labels.rows; ++y)
    for (int x = 0; x < labels.cols; ++x)
    {
      const std::uint32_t label = labels.type () == CV_32S ? static_cast<std::uint32_t> (labels.at<std::int32_t> (y, x))
                                                          : labels.at<std::uint16_t> (y, x);
      const cv::Vec3b rgb = labelColor (label);
      picture.at<cv::Vec3b> (y, x) = cv::Vec3b (rgb[2], rgb[1], rgb[0]);
    }
  return picture;
}
}  // namespace cuefusion
