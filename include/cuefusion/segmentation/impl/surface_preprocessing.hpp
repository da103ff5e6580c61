// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/segmentation/parallel.h>
#include <cuefusion/segmentation/edge_operators.h>
#include <cuefusion/segmentation/surface_planes.h>
#include <cuefusion/segmentation/organized_input.h>
#include <cuefusion/segmentation/surface_preprocessing.h>

#include <pcl/common/time.h>

#include <opencv2/imgproc.hpp>

#include <limits>

namespace cuefusion
{
namespace segmentation
{
template <typename PointT>
void
computeCentralDifferenceNormals (const pcl::PointCloud<PointT>& cloud, int step, float max_depth_jump,
                                 pcl::PointCloud<pcl::Normal>& normals)
{
  SurfacePlanes planes;
  planes.assignPoints (cloud);
  computeNormalPlanes (planes, reconstruction::NormalMapConfig{step, max_depth_jump});
  planes.copyNormalsTo (normals);
}

template <typename PointT>
void
SurfacePreprocessing<PointT>::setConfig (const SurfacePreprocessingConfig& config)
{
  config.validate ();
  config_ = config;
}

template <typename PointT>
void
SurfacePreprocessing<PointT>::compute (SurfacePlanes& planes)
{
  checkOrganizedInput<PointT, pcl::Normal> ("SurfacePreprocessing", input_.get (), nullptr);
  pcl::StopWatch watch;
  planes.assignPoints (*input_);
  const double copy_ms = watch.getTime ();
  preprocessPlanes (planes, config_, &smoothing_ms_, &normal_ms_);
  smoothing_ms_ += copy_ms;
}

template <typename PointT>
void
SurfacePreprocessing<PointT>::compute (pcl::PointCloud<PointT>& smoothed, pcl::PointCloud<pcl::Normal>& normals)
{
  if (&smoothed == input_.get ())
    throw Error ("SurfacePreprocessing", "the output cloud may not be the input cloud");
  compute (planes_);
  // The PCL-typed outputs are copies of the planes; their cost counts in the timings.
  pcl::StopWatch watch;
  smoothed = *input_;
  parallelFor (smoothed.size (), [&] (std::size_t i) {
    if (std::isfinite (planes_.z[i]))
    {
      smoothed[i].x = planes_.x[i];
      smoothed[i].y = planes_.y[i];
      smoothed[i].z = planes_.z[i];
    }
  });
  smoothing_ms_ += watch.getTime ();
  watch.reset ();
  planes_.copyNormalsTo (normals);
  normal_ms_ += watch.getTime ();
}
}  // namespace segmentation
}  // namespace cuefusion
