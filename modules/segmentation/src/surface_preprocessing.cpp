// SPDX-License-Identifier: BSD-3-Clause
// preprocessPlanes: the work of SurfacePreprocessing on SurfacePlanes.
#include <cuefusion/common/exceptions.h>
#include <cuefusion/segmentation/edge_operators.h>
#include <cuefusion/segmentation/parallel.h>
#include <cuefusion/segmentation/surface_preprocessing.h>

#include <pcl/common/time.h>
#include <pcl/features/integral_image_normal.h>

#include <algorithm>
#include <limits>
#include <string>
#include <vector>

namespace cuefusion
{
namespace segmentation
{
void
preprocessPlanes (SurfacePlanes& planes, const SurfacePreprocessingConfig& config, double* smoothing_ms, double* normal_ms)
{
  config.validate ();
  const int w = planes.width, h = planes.height;
  pcl::StopWatch watch;
  fillSmallHoles (planes, config.max_hole_pixels, config.normals.max_depth_jump, false);
  if (config.bilateral.enabled)
  {
    const cv::Mat depth (h, w, CV_32F, planes.z.data ());  // NaN = invalid
    cv::Mat filtered;
    reconstruction::bilateralFilterDepth (depth, config.bilateral, filtered);
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
  if (smoothing_ms)
    *smoothing_ms = watch.getTime ();

  watch.reset ();
  if (config.normal_method == NormalMethod::CentralDifference)
    computeNormalPlanes (planes, config.normals);
  else
  {
    // PCL's integral images read a window of the smoothing size around every pixel and
    // overrun a frame that is not larger than twice that (PCL 1.13 crashes).
    if (!(2.f * config.integral_smoothing < static_cast<float> (std::min (w, h))))
      throw ParameterError ("SurfacePreprocessingConfig::integral_smoothing",
                            "must be less than half the frame's smaller side (" + std::to_string (std::min (w, h)) + " px)");
    pcl::PointCloud<pcl::PointXYZ>::Ptr points = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>> (w, h);
    for (std::size_t i = 0; i < points->size (); ++i)
      (*points)[i] = pcl::PointXYZ (planes.x[i], planes.y[i], planes.z[i]);
    pcl::PointCloud<pcl::Normal> normals;
    pcl::IntegralImageNormalEstimation<pcl::PointXYZ, pcl::Normal> estimation;
    estimation.setNormalEstimationMethod (estimation.AVERAGE_3D_GRADIENT);
    estimation.setMaxDepthChangeFactor (config.normals.max_depth_jump);
    estimation.setNormalSmoothingSize (config.integral_smoothing);
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
  if (normal_ms)
    *normal_ms = watch.getTime ();
}
}  // namespace segmentation
}  // namespace cuefusion

namespace cuefusion
{
namespace segmentation
{
void
SurfacePlanes::assignDepth (const cv::Mat& depth, double fx, double fy, double cx, double cy)
{
  CV_Assert (depth.type () == CV_32F);
  width = depth.cols;
  height = depth.rows;
  const std::size_t n = depth.total ();
  for (std::vector<float>* plane : {&x, &y, &z, &nx, &ny, &nz})
    plane->resize (n);
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  // (u − cx) / fx per column once, not a double division per pixel (the same floats).
  std::vector<float> rx (static_cast<std::size_t> (width));
  for (int u = 0; u < width; ++u)
    rx[static_cast<std::size_t> (u)] = static_cast<float> ((u - cx) / fx);
  parallelFor (height, [&] (int v) {
    const float* d = depth.ptr<float> (v);
    const float ry = static_cast<float> ((v - cy) / fy);
    for (int u = 0; u < width; ++u)
    {
      const std::size_t i = static_cast<std::size_t> (v) * width + u;
      const bool valid = d[u] > 0.f && std::isfinite (d[u]);
      x[i] = valid ? rx[static_cast<std::size_t> (u)] * d[u] : nan;
      y[i] = valid ? ry * d[u] : nan;
      z[i] = valid ? d[u] : nan;
    }
  });
}

void
SurfacePlanes::assignNormals (const cv::Mat& normals)
{
  CV_Assert (normals.type () == CV_32FC3 && normals.cols == width && normals.rows == height);
  for (std::vector<float>* plane : {&nx, &ny, &nz})
    plane->resize (static_cast<std::size_t> (width) * height);
  cv::Mat planes[3] = {cv::Mat (height, width, CV_32F, nx.data ()), cv::Mat (height, width, CV_32F, ny.data ()),
                       cv::Mat (height, width, CV_32F, nz.data ())};
  cv::split (normals, planes);  // writes into the planes' own buffers: the sizes match
}
}  // namespace segmentation
}  // namespace cuefusion
