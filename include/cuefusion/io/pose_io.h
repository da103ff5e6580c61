// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <Eigen/Geometry>

#include <optional>
#include <string>
#include <vector>

namespace cuefusion
{
namespace io
{
/** \brief A camera-to-world pose at a time (seconds). */
struct StampedPose
{
  double timestamp = 0.0;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();
};
using Trajectory = std::vector<StampedPose, Eigen::aligned_allocator<StampedPose>>;
using PoseList = std::vector<Eigen::Isometry3d, Eigen::aligned_allocator<Eigen::Isometry3d>>;

/** \brief Checks a 4×4 matrix is a rigid transform (orthonormal rotation, last row 0 0 0 1);
  * throws cuefusion::Error naming \a where otherwise.
  */
Eigen::Isometry3d
rigidFromMatrix (const Eigen::Matrix4d& m, const std::string& where);

/** \brief A file holding one 4×4 row-major matrix (7-Scenes, ScanNet pose/N.txt).
  * Returns nullopt when the matrix holds inf/NaN (ScanNet's mark for a lost frame).
  */
std::optional<Eigen::Isometry3d>
readPoseMatrixFile (const std::string& path);

/** \brief Writes one 4×4 row-major matrix. */
void
writePoseMatrixFile (const std::string& path, const Eigen::Isometry3d& pose);

/** \brief TUM trajectory: "timestamp tx ty tz qx qy qz qw" lines, '#' comments.
  * Throws on malformed lines and on timestamps that are not strictly increasing.
  */
Trajectory
readTumTrajectory (const std::string& path);

void
writeTumTrajectory (const std::string& path, const Trajectory& trajectory);

/** \brief Pose at time \a t: linear in translation, slerp in rotation between the two
  * neighbouring entries. nullopt when t lies outside the trajectory by more than
  * \a max_extrapolation seconds or the bracketing entries are more than \a max_gap apart.
  */
std::optional<Eigen::Isometry3d>
interpolatePose (const Trajectory& trajectory, double t, double max_gap = 0.5, double max_extrapolation = 0.02);

/** \brief Redwood / Open3D .log: per frame a line "i i n" then the 4 rows of the matrix. */
PoseList
readRedwoodLog (const std::string& path);

void
writeRedwoodLog (const std::string& path, const PoseList& poses);
}  // namespace io
}  // namespace cuefusion
