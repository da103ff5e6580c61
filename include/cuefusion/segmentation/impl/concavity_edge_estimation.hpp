#pragma once

#include <cuefusion/common/exceptions.h>
#include <cuefusion/segmentation/concavity_edge_estimation.h>
#include <cuefusion/segmentation/impl/cloud_images.hpp>
#include <cuefusion/segmentation/surface_planes.h>
#include <cuefusion/segmentation/organized_input.h>


namespace cuefusion
{
namespace segmentation
{
template <typename PointT, typename PointNT>
void
ConcavityEdgeEstimation<PointT, PointNT>::setConfig (const ConcavityEdgeConfig& config)
{
  config.validate ();
  config_ = config;
}

template <typename PointT, typename PointNT>
void
ConcavityEdgeEstimation<PointT, PointNT>::setThreshold (float threshold)
{
  ConcavityEdgeConfig config = config_;
  config.threshold = threshold;
  setConfig (config);
}

template <typename PointT, typename PointNT>
void
ConcavityEdgeEstimation<PointT, PointNT>::setNeighbourStep (int step)
{
  ConcavityEdgeConfig config = config_;
  config.neighbour_step = step;
  setConfig (config);
}

template <typename PointT, typename PointNT>
void
ConcavityEdgeEstimation<PointT, PointNT>::compute (pcl::PointCloud<pcl::Label>& edges,
                                                   pcl::PointCloud<pcl::Intensity>* phi)
{
  checkOrganizedInput<PointT, PointNT> ("ConcavityEdgeEstimation", input_.get (), normals_.get ());
  if (!normals_)
    throw Error ("ConcavityEdgeEstimation", "no input normals (setInputNormals)");
  SurfacePlanes planes;
  planes.assign (*input_, *normals_);
  cv::Mat values, mask;
  computeConcavityMap (planes, config_.neighbour_step, config_.convexity_test, values);
  concavityEdges (values, config_.threshold, mask);
  detail::copyToCloud (mask, edges);
  if (phi)
    detail::copyToCloud (values, *phi);
}
}  // namespace segmentation
}  // namespace cuefusion
