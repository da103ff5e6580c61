#pragma once

#include <cuefusion/common/exceptions.h>
#include <cuefusion/segmentation/depth_discontinuity_edge_estimation.h>
#include <cuefusion/segmentation/impl/cloud_images.hpp>
#include <cuefusion/segmentation/surface_planes.h>
#include <cuefusion/segmentation/organized_input.h>


namespace cuefusion
{
namespace segmentation
{
template <typename PointT, typename PointNT>
void
DepthDiscontinuityEdgeEstimation<PointT, PointNT>::setConfig (const DepthDiscontinuityEdgeConfig& config)
{
  config.validate ();
  config_ = config;
}

template <typename PointT, typename PointNT>
void
DepthDiscontinuityEdgeEstimation<PointT, PointNT>::setNoiseFactor (float k)
{
  DepthDiscontinuityEdgeConfig config = config_;
  config.noise_factor = k;
  setConfig (config);
}

template <typename PointT, typename PointNT>
void
DepthDiscontinuityEdgeEstimation<PointT, PointNT>::setNeighbourStep (int step)
{
  DepthDiscontinuityEdgeConfig config = config_;
  config.neighbour_step = step;
  setConfig (config);
}

template <typename PointT, typename PointNT>
void
DepthDiscontinuityEdgeEstimation<PointT, PointNT>::compute (pcl::PointCloud<pcl::Label>& edges,
                                                            pcl::PointCloud<pcl::Intensity>* gamma)
{
  checkOrganizedInput<PointT, PointNT> ("DepthDiscontinuityEdgeEstimation", input_.get (), normals_.get ());
  if (!normals_)
    throw Error ("DepthDiscontinuityEdgeEstimation", "no input normals (setInputNormals)");
  SurfacePlanes planes;
  planes.assign (*input_, *normals_);
  cv::Mat values, mask;
  computeDiscontinuityMap (planes, config_.neighbour_step, values);
  discontinuityEdges (planes, values, config_.noise_factor, mask);
  detail::copyToCloud (mask, edges);
  if (gamma)
    detail::copyToCloud (values, *gamma);
}
}  // namespace segmentation
}  // namespace cuefusion
