// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <Eigen/Core>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstddef>
#include <cstdint>
#include <map>

namespace cuefusion
{
namespace segmentation
{
/** \brief A box around a segment's points along their principal axes (PCA of the points'
  * covariance, as pcl::MomentOfInertiaEstimation's OBB): what a grasp planner or an
  * inventory wants of an object.
  */
struct OrientedBox
{
  Eigen::Vector3f center = Eigen::Vector3f::Zero ();  ///< world frame, the box's middle (not the centroid)
  /** Columns: unit axes, the direction of greatest spread first; a right-handed frame. */
  Eigen::Matrix3f axes = Eigen::Matrix3f::Identity ();
  Eigen::Vector3f extents = Eigen::Vector3f::Zero ();  ///< full side lengths along the axes (m)
};

/** \brief Where one segment of a labelled map lies. */
struct ObjectGeometry
{
  std::size_t points = 0;
  Eigen::Vector3f centroid = Eigen::Vector3f::Zero ();  ///< mean of the points
  OrientedBox box;
};

/** \brief Per label (> 0) of \a map (a labelled cloud such as FusionPipeline::labelledCloud,
  * world frame): its points' count, centroid and oriented box. Points without finite
  * coordinates and label 0 are left out. One pass to group the points, then one PCA per
  * label (Eigen's SelfAdjointEigenSolver on the 3×3 covariance).
  */
std::map<std::uint32_t, ObjectGeometry>
objectGeometry (const pcl::PointCloud<pcl::PointXYZRGBL>& map);
}  // namespace segmentation
}  // namespace cuefusion
