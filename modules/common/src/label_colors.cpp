// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/label_colors.h>

#include <iterator>
#include <numeric>
#include <vector>

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

/** The colours after the palette: a 10-level RGB grid without greys (black included) and
  * without the palette's own colours, in a scattered order (stride coprime to the count,
  * near its golden section, so label k and k + 1 lie far apart on the grid). */
const std::vector<cv::Vec3b>&
gridColors ()
{
  static const std::vector<cv::Vec3b> colors = [] {
    std::vector<cv::Vec3b> grid;
    const auto level = [] (int i) { return static_cast<std::uint8_t> ((255 * i + 4) / 9); };
    for (int r = 0; r < 10; ++r)
      for (int g = 0; g < 10; ++g)
        for (int b = 0; b < 10; ++b)
        {
          const cv::Vec3b c (level (r), level (g), level (b));
          bool taken = r == g && g == b;
          for (const auto& p : kPalette)
            taken = taken || (p[0] == c[0] && p[1] == c[1] && p[2] == c[2]);
          if (!taken)
            grid.push_back (c);
        }
    const std::size_t n = grid.size ();
    std::size_t stride = static_cast<std::size_t> (0.618 * static_cast<double> (n));
    while (std::gcd (stride, n) != 1)
      ++stride;
    std::vector<cv::Vec3b> ordered (n);
    for (std::size_t k = 0; k < n; ++k)
      ordered[k] = grid[(k * stride) % n];
    return ordered;
  }();
  return colors;
}
}  // namespace

cv::Vec3b
labelColor (std::uint32_t label)
{
  if (label == 0)
    return cv::Vec3b (0, 0, 0);
  const auto palette = static_cast<std::uint32_t> (std::size (kPalette)), count = labelColorCount ();
  const std::uint32_t k = (label - 1) % count;
  if (k < palette)
  {
    const std::uint8_t* c = kPalette[k];
    return cv::Vec3b (c[0], c[1], c[2]);
  }
  return gridColors ()[k - palette];
}

cv::Vec3b
segmentColor (std::uint32_t label)
{
  return label ? labelColor (label) : cv::Vec3b (160, 160, 160);
}

std::uint32_t
labelColorCount ()
{
  return static_cast<std::uint32_t> (std::size (kPalette) + gridColors ().size ());
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
