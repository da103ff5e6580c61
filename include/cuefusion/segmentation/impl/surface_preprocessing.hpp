#pragma once

#include <cuefusion/segmentation/parallel.h>
#include <cuefusion/segmentation/edge_operators.h>
#include <cuefusion/segmentation/surface_planes.h>
#include <cuefusion/segmentation/organized_input.h>
#include <cuefusion/segmentation/surface_preprocessing.h>

#include <pcl/common/time.h>
#include <pcl/features/integral_image_normal.h>
// PCL precompiles the estimator only for some point types (not PointXYZRGBL, PointXYZL).
#include <pcl/features/impl/integral_image_normal.hpp>

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
  computeNormalPlanes (planes, step, max_depth_jump);
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
  const int w = static_cast<int> (input_->width), h = static_cast<int> (input_->height);

  pcl::StopWatch watch;
  planes.assignPoints (*input_);
  if (config_.bilateral_filter)
  {
    const cv::Mat depth (h, w, CV_32F, planes.z.data ());  // NaN = invalid
    cv::Mat filtered;
    noiseAdaptiveBilateral (depth, config_.bilateral_diameter, config_.range_sigma, config_.sigma_space, filtered);
    parallelFor (h, [&] (int y) {
      const float* out = filtered.ptr<float> (y);
      for (int x = 0; x < w; ++x)
      {
        const std::size_t i = static_cast<std::size_t> (y) * w + x;
        if (planes.z[i] > 0.f && out[x] > 0.f)
        {
          const float scale = out[x] / planes.z[i];  // slide along the viewing ray
          planes.x[i] *= scale;
          planes.y[i] *= scale;
          planes.z[i] = out[x];
        }
      }
    });
  }
  smoothing_ms_ = watch.getTime ();

  watch.reset ();
  if (config_.normal_method == NormalMethod::CentralDifference)
    computeNormalPlanes (planes, config_.normal_step, config_.max_depth_jump);
  else
  {
    pcl::PointCloud<pcl::PointXYZ>::Ptr points (new pcl::PointCloud<pcl::PointXYZ> (w, h));
    for (std::size_t i = 0; i < points->size (); ++i)
      (*points)[i] = pcl::PointXYZ (planes.x[i], planes.y[i], planes.z[i]);
    pcl::PointCloud<pcl::Normal> normals;
    pcl::IntegralImageNormalEstimation<pcl::PointXYZ, pcl::Normal> estimation;
    estimation.setNormalEstimationMethod (estimation.AVERAGE_3D_GRADIENT);
    estimation.setMaxDepthChangeFactor (config_.max_depth_jump);
    estimation.setNormalSmoothingSize (config_.integral_smoothing);
    // setDepthDependentSmoothing(true) crashes in PCL 1.13.0: left at its default (false).
    estimation.setInputCloud (points);
    estimation.compute (normals);
    for (std::size_t i = 0; i < normals.size (); ++i)
    {
      Eigen::Vector3f n = normals[i].getNormalVector3fMap ();
      if (n.dot ((*points)[i].getVector3fMap ()) > 0.f)
        n = -n;
      const bool ok = isFiniteVector (n) && std::isfinite (planes.z[i]);
      planes.nx[i] = ok ? n.x () : std::numeric_limits<float>::quiet_NaN ();
      planes.ny[i] = ok ? n.y () : std::numeric_limits<float>::quiet_NaN ();
      planes.nz[i] = ok ? n.z () : std::numeric_limits<float>::quiet_NaN ();
    }
  }
  normal_ms_ = watch.getTime ();
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
