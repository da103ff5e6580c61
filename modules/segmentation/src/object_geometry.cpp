// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/segmentation/object_geometry.h>

#include <Eigen/Eigenvalues>

#include <cmath>
#include <limits>
#include <vector>

namespace cuefusion
{
namespace segmentation
{
namespace
{
/** Centroid and oriented box of one label's points. */
ObjectGeometry
geometryOf (const pcl::PointCloud<pcl::PointXYZRGBL>& map, const std::vector<std::size_t>& members)
{
  ObjectGeometry g;
  g.points = members.size ();
  // Sums in double: a room's coordinates of several metres, squared over 10^5 points.
  Eigen::Vector3d sum = Eigen::Vector3d::Zero ();
  for (const std::size_t i : members)
    sum += map[i].getVector3fMap ().cast<double> ();
  const Eigen::Vector3d mean = sum / static_cast<double> (members.size ());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero ();
  for (const std::size_t i : members)
  {
    const Eigen::Vector3d d = map[i].getVector3fMap ().cast<double> () - mean;
    covariance += d * d.transpose ();
  }
  covariance /= static_cast<double> (members.size ());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver (covariance);
  Eigen::Matrix3d axes;
  // Eigen sorts eigenvalues ascending: the greatest spread is the last column.
  axes.col (0) = solver.eigenvectors ().col (2);
  axes.col (1) = solver.eigenvectors ().col (1);
  axes.col (2) = axes.col (0).cross (axes.col (1));  // right-handed
  Eigen::Vector3d low = Eigen::Vector3d::Constant (std::numeric_limits<double>::max ()), high = -low;
  for (const std::size_t i : members)
  {
    const Eigen::Vector3d local = axes.transpose () * (map[i].getVector3fMap ().cast<double> () - mean);
    low = low.cwiseMin (local);
    high = high.cwiseMax (local);
  }
  g.centroid = mean.cast<float> ();
  g.box.axes = axes.cast<float> ();
  g.box.extents = (high - low).cast<float> ();
  g.box.center = (mean + axes * (0.5 * (low + high))).cast<float> ();
  return g;
}
}  // namespace

std::map<std::uint32_t, ObjectGeometry>
objectGeometry (const pcl::PointCloud<pcl::PointXYZRGBL>& map)
{
  std::map<std::uint32_t, std::vector<std::size_t>> members;
  for (std::size_t i = 0; i < map.size (); ++i)
  {
    const pcl::PointXYZRGBL& p = map[i];
    if (p.label != 0 && std::isfinite (p.x) && std::isfinite (p.y) && std::isfinite (p.z))
      members[p.label].push_back (i);
  }
  std::map<std::uint32_t, ObjectGeometry> out;
  for (const auto& [label, list] : members)
    out.emplace (label, geometryOf (map, list));
  return out;
}
}  // namespace segmentation
}  // namespace cuefusion
