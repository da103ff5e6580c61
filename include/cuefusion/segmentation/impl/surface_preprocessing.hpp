#pragma once

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
SurfacePreprocessing<PointT>::compute (pcl::PointCloud<PointT>& smoothed, pcl::PointCloud<pcl::Normal>& normals)
{
  checkOrganizedInput<PointT, pcl::Normal> ("SurfacePreprocessing", input_.get (), nullptr);
  if (&smoothed == input_.get ())
    throw Error ("SurfacePreprocessing", "the output cloud may not be the input cloud");
  const pcl::PointCloud<PointT>& cloud = *input_;
  const int w = static_cast<int> (cloud.width), h = static_cast<int> (cloud.height);

  pcl::StopWatch watch;
  smoothed = cloud;
  if (config_.bilateral_filter)
  {
    cv::Mat depth (h, w, CV_32F), filtered;
    for (int y = 0; y < h; ++y)
    {
      float* row = depth.ptr<float> (y);
      for (int x = 0; x < w; ++x)
      {
        const float z = cloud[static_cast<std::size_t> (y) * w + x].z;
        row[x] = (std::isfinite (z) && z > 0.f) ? z : 0.f;  // 0 is metres away from any depth: no weight
      }
    }
    noiseAdaptiveBilateral (depth, config_.bilateral_diameter, config_.range_sigma, config_.sigma_space, filtered);
#pragma omp parallel for schedule(static)
    for (int y = 0; y < h; ++y)
    {
      const float* in = depth.ptr<float> (y);
      const float* out = filtered.ptr<float> (y);
      for (int x = 0; x < w; ++x)
        if (in[x] > 0.f && out[x] > 0.f)
        {
          PointT& p = smoothed[static_cast<std::size_t> (y) * w + x];
          const float scale = out[x] / in[x];  // slide along the viewing ray
          p.x *= scale;
          p.y *= scale;
          p.z = out[x];
        }
    }
  }
  smoothing_ms_ = watch.getTime ();

  watch.reset ();
  if (config_.normal_method == NormalMethod::CentralDifference)
  {
    planes_.assignPoints (smoothed);  // member: no fresh 7 MB of planes per frame
    computeNormalPlanes (planes_, config_.normal_step, config_.max_depth_jump);
    planes_.copyNormalsTo (normals);
  }
  else
  {
    pcl::IntegralImageNormalEstimation<PointT, pcl::Normal> estimation;
    estimation.setNormalEstimationMethod (estimation.AVERAGE_3D_GRADIENT);
    estimation.setMaxDepthChangeFactor (config_.max_depth_jump);
    estimation.setNormalSmoothingSize (config_.integral_smoothing);
    // setDepthDependentSmoothing(true) crashes in PCL 1.13.0: left at its default (false).
    estimation.setInputCloud (typename pcl::PointCloud<PointT>::ConstPtr (&smoothed, [] (const void*) {}));
    estimation.compute (normals);
    for (std::size_t i = 0; i < normals.size (); ++i)
    {
      Eigen::Map<Eigen::Vector3f> n = normals[i].getNormalVector3fMap ();
      if (isFiniteVector (n) && n.dot (smoothed[i].getVector3fMap ()) > 0.f)
        n = -n;
    }
  }
  normal_ms_ = watch.getTime ();
}
}  // namespace segmentation
}  // namespace cuefusion
