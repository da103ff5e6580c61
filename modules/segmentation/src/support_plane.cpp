// SPDX-License-Identifier: BSD-3-Clause
// removeSupportPlane: RANSAC plane on a subsample, then the plane's segments and rim to 0.
#include <cuefusion/segmentation/edge_operators.h>
#include <cuefusion/segmentation/support_plane_removal.h>

#include <pcl/ModelCoefficients.h>
#include <pcl/PointIndices.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <cmath>
#include <vector>

namespace cuefusion
{
namespace segmentation
{
bool
removeSupportPlane (const SurfacePlanes& planes, const SupportPlaneRemovalConfig& config, cv::Mat& labels, Eigen::Vector4f& plane)
{
  config.validate ();
  const int w = planes.width, h = planes.height;
  CV_Assert (labels.type () == CV_32S && labels.cols == w && labels.rows == h);
  auto vertex = [&planes] (std::size_t i) { return Eigen::Vector3f (planes.x[i], planes.y[i], planes.z[i]); };

  pcl::PointCloud<pcl::PointXYZ>::Ptr samples = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>> ();
  for (int y = 0; y < h; y += config.sample_step)
    for (int x = 0; x < w; x += config.sample_step)
    {
      const std::size_t i = static_cast<std::size_t> (y) * w + x;
      if (std::isfinite (planes.z[i]))
        samples->push_back (pcl::PointXYZ (planes.x[i], planes.y[i], planes.z[i]));
    }
  if (samples->size () < 3)
    return false;
  pcl::SACSegmentation<pcl::PointXYZ> sac;  // PCL's RANSAC uses a fixed seed: repeatable
  sac.setModelType (pcl::SACMODEL_PLANE);
  sac.setMethodType (pcl::SAC_RANSAC);
  sac.setDistanceThreshold (config.distance_threshold);
  sac.setMaxIterations (config.max_iterations);
  sac.setOptimizeCoefficients (true);
  sac.setInputCloud (samples);
  pcl::ModelCoefficients coefficients;
  pcl::PointIndices inliers;
  sac.segment (inliers, coefficients);
  if (coefficients.values.size () != 4 ||
      inliers.indices.size () < config.min_plane_fraction * static_cast<float> (samples->size ()))
    return false;
  Eigen::Vector4f p (coefficients.values[0], coefficients.values[1], coefficients.values[2], coefficients.values[3]);
  p /= p.head<3> ().norm ();
  if (p[3] < 0.f)  // the sensor (origin) on the positive side: normal towards it
    p = -p;
  plane = p;

  // Per segment: pixels and plane inliers; per pixel: in the band, and parallel to it.
  const float cos_max = std::cos (config.max_normal_angle_deg * static_cast<float> (M_PI) / 180.f);
  cv::Mat inlier (h, w, CV_8U, cv::Scalar (0));
  double max_label = 0.0;
  cv::minMaxLoc (labels, nullptr, &max_label);
  std::vector<std::pair<int, int>> counts (static_cast<std::size_t> (max_label) + 1, {0, 0});  // pixels, inliers
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
    {
      const std::size_t i = static_cast<std::size_t> (y) * w + x;
      const Eigen::Vector3f v = vertex (i);
      const bool in_band = std::isfinite (v.z ()) && std::abs (p.head<3> ().dot (v) + p[3]) < config.distance_threshold;
      if (in_band)
      {
        const Eigen::Vector3f n (planes.nx[i], planes.ny[i], planes.nz[i]);
        inlier.at<std::uint8_t> (y, x) = (isFiniteVector (n) && std::abs (n.dot (p.head<3> ())) >= cos_max) ? 2 : 1;
      }
      const std::int32_t label = labels.at<std::int32_t> (y, x);
      if (label > 0)
      {
        auto& c = counts[static_cast<std::size_t> (label)];
        ++c.first;
        c.second += in_band ? 1 : 0;
      }
    }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
    {
      std::int32_t& label = labels.at<std::int32_t> (y, x);
      if (label <= 0)
        continue;
      const auto& c = counts[static_cast<std::size_t> (label)];
      if (c.second >= config.min_segment_inlier_fraction * static_cast<float> (c.first) ||
          inlier.at<std::uint8_t> (y, x) == 2)
        label = 0;
    }
  return true;
}
}  // namespace segmentation
}  // namespace cuefusion
