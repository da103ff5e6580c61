#pragma once

#include <cuefusion/segmentation/edge_operators.h>
#include <cuefusion/segmentation/organized_input.h>
#include <cuefusion/segmentation/support_plane_removal.h>

#include <pcl/ModelCoefficients.h>
#include <pcl/PointIndices.h>
#include <pcl/sample_consensus/method_types.h>
#include <pcl/sample_consensus/model_types.h>
#include <pcl/segmentation/sac_segmentation.h>

#include <cmath>
#include <unordered_map>

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
  const pcl::PointCloud<PointT>& cloud = *input_;
  const int w = static_cast<int> (cloud.width), h = static_cast<int> (cloud.height);
  if (labels.type () != CV_32S || labels.cols != w || labels.rows != h)
    throw Error ("SupportPlaneRemoval", "label image does not match the cloud's size");

  pcl::PointCloud<pcl::PointXYZ>::Ptr samples (new pcl::PointCloud<pcl::PointXYZ>);
  for (int y = 0; y < h; y += config_.sample_step)
    for (int x = 0; x < w; x += config_.sample_step)
    {
      const PointT& p = cloud[static_cast<std::size_t> (y) * w + x];
      if (std::isfinite (p.x) && std::isfinite (p.y) && std::isfinite (p.z))
        samples->push_back (pcl::PointXYZ (p.x, p.y, p.z));
    }
  if (samples->size () < 3)
    return false;
  pcl::SACSegmentation<pcl::PointXYZ> sac;
  sac.setModelType (pcl::SACMODEL_PLANE);
  sac.setMethodType (pcl::SAC_RANSAC);
  sac.setDistanceThreshold (config_.distance_threshold);
  sac.setMaxIterations (config_.max_iterations);
  sac.setOptimizeCoefficients (true);
  sac.setInputCloud (samples);
  pcl::ModelCoefficients coefficients;
  pcl::PointIndices inliers;
  sac.segment (inliers, coefficients);
  if (coefficients.values.size () != 4 ||
      inliers.indices.size () < config_.min_plane_fraction * static_cast<float> (samples->size ()))
    return false;
  Eigen::Vector4f plane (coefficients.values[0], coefficients.values[1], coefficients.values[2], coefficients.values[3]);
  plane /= plane.head<3> ().norm ();
  if (plane[3] < 0.f)  // the sensor (origin) on the positive side: normal towards it
    plane = -plane;
  plane_ = plane;

  // Per segment: pixels, plane inliers.
  cv::Mat inlier (h, w, CV_8U, cv::Scalar (0));
  std::unordered_map<std::int32_t, std::pair<int, int>> counts;
  const float cos_max = std::cos (config_.max_normal_angle_deg * static_cast<float> (M_PI) / 180.f);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
    {
      const std::int32_t label = labels.at<std::int32_t> (y, x);
      const Eigen::Vector3f v = cloud[static_cast<std::size_t> (y) * w + x].getVector3fMap ();
      const bool in_band = isFiniteVector (v) && std::abs (plane.head<3> ().dot (v) + plane[3]) < config_.distance_threshold;
      if (in_band)
      {
        inlier.at<std::uint8_t> (y, x) = 1;
        if (normals_)
        {
          const Eigen::Vector3f n = (*normals_)[static_cast<std::size_t> (y) * w + x].getNormalVector3fMap ();
          if (isFiniteVector (n) && std::abs (n.dot (plane.head<3> ())) >= cos_max)
            inlier.at<std::uint8_t> (y, x) = 2;
        }
      }
      if (label > 0)
      {
        auto& c = counts[label];
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
      const auto& c = counts[label];
      if (c.second >= config_.min_segment_inlier_fraction * static_cast<float> (c.first) ||
          inlier.at<std::uint8_t> (y, x) == 2)
        label = 0;
    }
  return true;
}
}  // namespace segmentation
}  // namespace cuefusion
