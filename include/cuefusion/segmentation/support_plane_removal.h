// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/segmentation/surface_planes.h>

#include <opencv2/core.hpp>

#include <pcl/pcl_base.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <memory>

namespace cuefusion
{
namespace segmentation
{
/** \brief Parameters of SupportPlaneRemoval. */
struct SupportPlaneRemovalConfig
{
  float distance_threshold = 0.015f;        ///< RANSAC inlier band (metres), ~3σ of Kinect noise at 1.5 m
  int max_iterations = 200;                 ///< RANSAC iterations
  int sample_step = 4;                      ///< the plane is fitted to every sample_step-th pixel in x and y
  float min_plane_fraction = 0.1f;          ///< a plane holding fewer of the valid points is not "dominant"
  float min_segment_inlier_fraction = 0.5f; ///< a segment with this share of plane inliers is the support
  float max_normal_angle_deg = 25.f;        ///< other in-band pixels go too when their normal is this close
  void validate () const;
};
/// The name before 0.2 (one config per class, named after it).
using SupportPlaneConfig [[deprecated ("renamed SupportPlaneRemovalConfig")]] = SupportPlaneRemovalConfig;

/** \brief The work of SupportPlaneRemoval on SurfacePlanes (normals may be all NaN).
  * Returns false, leaving \a labels as they are, when there is no dominant plane; else
  * the plane (unit normal towards the sensor) in \a plane.
  */
bool
removeSupportPlane (const SurfacePlanes& planes, const SupportPlaneRemovalConfig& config, cv::Mat& labels,
                    Eigen::Vector4f& plane);

/** \brief Finds the dominant plane of an organized cloud (table or floor: PCL's RANSAC
  * plane segmentation, SACSegmentation with SACMODEL_PLANE) and labels it 0 in a label
  * image, as tabletop grasping users want (thesis §2.1.2): every segment that is mostly
  * plane inliers becomes 0, and so does any other pixel inside the inlier band whose
  * normal (when normals are given) is parallel to the plane's — a rim of table stuck to
  * an object. The plane is fitted with a fixed RANSAC seed, so results repeat.
  */
template <typename PointT>
class SupportPlaneRemoval : public pcl::PCLBase<PointT>
{
public:
  using Ptr = std::shared_ptr<SupportPlaneRemoval>;
  using ConstPtr = std::shared_ptr<const SupportPlaneRemoval>;
  using NormalCloudConstPtr = typename pcl::PointCloud<pcl::Normal>::ConstPtr;

  explicit SupportPlaneRemoval (const SupportPlaneRemovalConfig& config = SupportPlaneRemovalConfig ()) { setConfig (config); }

  void setInputNormals (const NormalCloudConstPtr& normals) { normals_ = normals; }
  /** \brief Throws cuefusion::ParameterError for an invalid configuration. */
  void setConfig (const SupportPlaneRemovalConfig& config);
  const SupportPlaneRemovalConfig& getConfig () const { return config_; }

  /** \brief Removes the plane from \a labels (CV_32S, the cloud's size). Returns false
    * (labels untouched) when no dominant plane was found. With indices (setIndices) the
    * plane is fitted to those points and only their labels can change. Throws
    * cuefusion::Error on unorganized, empty or all-NaN input, an index outside the cloud
    * and a label image of another size.
    */
  bool apply (cv::Mat& labels);

  /** \brief The same on SurfacePlanes (points and normals); the input cloud is not used. */
  bool apply (const SurfacePlanes& planes, cv::Mat& labels);

  /** \brief Plane of the last apply (a, b, c, d with unit normal towards the sensor). */
  const Eigen::Vector4f& getPlane () const { return plane_; }

protected:
  using pcl::PCLBase<PointT>::input_;

  NormalCloudConstPtr normals_;
  SupportPlaneRemovalConfig config_;
  SurfacePlanes planes_;
  Eigen::Vector4f plane_ = Eigen::Vector4f::Zero ();
};
}  // namespace segmentation
}  // namespace cuefusion

#ifdef PCL_NO_PRECOMPILE
#include <cuefusion/segmentation/impl/support_plane_removal.hpp>
#endif
