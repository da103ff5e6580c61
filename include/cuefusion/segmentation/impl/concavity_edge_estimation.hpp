// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/segmentation/concavity_edge_estimation.h>
#include <cuefusion/segmentation/impl/cloud_images.hpp>
#include <cuefusion/segmentation/surface_planes.h>


namespace cuefusion
{
namespace segmentation
{
template <typename PointT, typename PointNT>
void
ConcavityEdgeEstimation<PointT, PointNT>::compute (pcl::PointCloud<pcl::Label>& edges,
                                                   pcl::PointCloud<pcl::Intensity>* phi)
{
  SurfacePlanes planes;
  this->toPlanes ("ConcavityEdgeEstimation", planes);
  cv::Mat values, mask;
  computeConcavityMap (planes, this->config_.neighbour_step, this->config_.convexity_test, values);
  concavityEdges (planes, values, this->config_, mask);
  detail::copyToCloud (mask, edges);
  if (phi)
    detail::copyToCloud (values, *phi);
}
}  // namespace segmentation
}  // namespace cuefusion
