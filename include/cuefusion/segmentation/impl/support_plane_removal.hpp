// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/segmentation/organized_input.h>
#include <cuefusion/segmentation/support_plane_removal.h>

#include <algorithm>
#include <limits>

namespace cuefusion
{
namespace segmentation
{
template <typename PointT>
void
SupportPlaneRemoval<PointT>::setConfig (const SupportPlaneRemovalConfig& config)
{
  config.validate ();
  config_ = config;
}

template <typename PointT>
bool
SupportPlaneRemoval<PointT>::apply (cv::Mat& labels)
{
  checkOrganizedInput<PointT, pcl::Normal> ("SupportPlaneRemoval", input_.get (), normals_.get ());
  if (normals_)
    planes_.assign (*input_, *normals_);
  else
  {
    planes_.assignPoints (*input_);
    std::fill (planes_.nx.begin (), planes_.nx.end (), std::numeric_limits<float>::quiet_NaN ());
    std::fill (planes_.ny.begin (), planes_.ny.end (), std::numeric_limits<float>::quiet_NaN ());
    std::fill (planes_.nz.begin (), planes_.nz.end (), std::numeric_limits<float>::quiet_NaN ());
  }
  if (!(this->use_indices_ && !this->fake_indices_ && this->indices_))
    return apply (planes_, labels);
  // With indices the plane is fitted to their points only, and labels elsewhere stay.
  keepOnlyIndices ("SupportPlaneRemoval", *this->indices_, planes_);
  if (labels.type () != CV_32S || labels.cols != planes_.width || labels.rows != planes_.height)
    throw Error ("SupportPlaneRemoval", "label image does not match the cloud's size");
  cv::Mat outside (labels.size (), CV_8U, cv::Scalar (1));
  for (const pcl::index_t i : *this->indices_)
    outside.data[i] = 0;
  const cv::Mat before = labels.clone ();
  const bool removed = apply (planes_, labels);
  before.copyTo (labels, outside);
  return removed;
}

template <typename PointT>
bool
SupportPlaneRemoval<PointT>::apply (const SurfacePlanes& planes, cv::Mat& labels)
{
  if (labels.type () != CV_32S || labels.cols != planes.width || labels.rows != planes.height)
    throw Error ("SupportPlaneRemoval", "label image does not match the cloud's size");
  return removeSupportPlane (planes, config_, labels, plane_);
}
}  // namespace segmentation
}  // namespace cuefusion
