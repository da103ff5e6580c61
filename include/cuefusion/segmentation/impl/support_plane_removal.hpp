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
SupportPlaneRemoval<PointT>::setConfig (const SupportPlaneConfig& config)
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
  return apply (planes_, labels);
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
