// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/segmentation/parallel.h>

#include <opencv2/core.hpp>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstdint>

namespace cuefusion
{
namespace segmentation
{
namespace detail
{
/** \brief An image as an organized PCL cloud of the same size. */
inline void
copyToCloud (const cv::Mat& mask, pcl::PointCloud<pcl::Label>& cloud)
{
  CV_Assert (mask.type () == CV_8U || mask.type () == CV_32S);
  cloud.resize (mask.total ());
  cloud.width = static_cast<std::uint32_t> (mask.cols);
  cloud.height = static_cast<std::uint32_t> (mask.rows);
  cloud.is_dense = true;
  parallelFor (mask.rows, [&] (int y) {
    for (int x = 0; x < mask.cols; ++x)
      cloud[static_cast<std::size_t> (y) * mask.cols + x].label =
        mask.type () == CV_8U ? mask.at<std::uint8_t> (y, x) : static_cast<std::uint32_t> (mask.at<std::int32_t> (y, x));
  });
}

inline void
copyToCloud (const cv::Mat& values, pcl::PointCloud<pcl::Intensity>& cloud)
{
  CV_Assert (values.type () == CV_32F);
  cloud.resize (values.total ());
  cloud.width = static_cast<std::uint32_t> (values.cols);
  cloud.height = static_cast<std::uint32_t> (values.rows);
  cloud.is_dense = false;
  parallelFor (values.rows, [&] (int y) {
    for (int x = 0; x < values.cols; ++x)
      cloud[static_cast<std::size_t> (y) * values.cols + x].intensity = values.at<float> (y, x);
  });
}
}  // namespace detail
}  // namespace segmentation
}  // namespace cuefusion
