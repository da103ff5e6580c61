// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/segmentation/depth_discontinuity_edge_estimation.h>
#include <cuefusion/segmentation/impl/cloud_images.hpp>
#include <cuefusion/segmentation/surface_planes.h>


namespace cuefusion
{
namespace segmentation
{
template <typename PointT, typename PointNT>
void
DepthDiscontinuityEdgeEstimation<PointT, PointNT>::compute (pcl::PointCloud<pcl::Label>& edges,
                                                            pcl::PointCloud<pcl::Intensity>* gamma)
{
  SurfacePlanes planes;
  this->toPlanes ("DepthDiscontinuityEdgeEstimation", planes);
  cv::Mat values, mask;
  computeDiscontinuityMap (planes, this->config_.neighbour_step, values);
  discontinuityEdges (planes, values, this->config_.noise_factor, mask);
  detail::copyToCloud (mask, edges);
  if (gamma)
    detail::copyToCloud (values, *gamma);
}
}  // namespace segmentation
}  // namespace cuefusion
