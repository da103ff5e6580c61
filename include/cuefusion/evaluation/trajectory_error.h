// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/io/pose_io.h>

#include <Eigen/Geometry>

#include <cstddef>
#include <utility>
#include <vector>

namespace cuefusion
{
namespace evaluation
{
/** \brief Absolute trajectory error (Sturm et al. 2012, TUM RGB-D benchmark). */
struct TrajectoryError
{
  std::size_t pairs = 0;          ///< estimated poses matched to a reference pose
  double rmse = 0.0;              ///< metres, translational
  double mean = 0.0;
  double median = 0.0;
  double max = 0.0;
  Eigen::Isometry3d alignment = Eigen::Isometry3d::Identity ();  ///< applied to the estimate
};

/** \brief An estimated pose and the reference pose at (nearly) the same time. */
struct PosePair
{
  double timestamp = 0.0;
  Eigen::Isometry3d estimate = Eigen::Isometry3d::Identity ();
  Eigen::Isometry3d reference = Eigen::Isometry3d::Identity ();
};
using PosePairs = std::vector<PosePair, Eigen::aligned_allocator<PosePair>>;

/** \brief Pairs each estimated pose with the reference pose of the nearest timestamp,
  * dropping estimates with none within \a max_time_difference seconds. Keeps the
  * estimate's order.
  */
PosePairs
associatePoses (const io::Trajectory& estimate, const io::Trajectory& reference, double max_time_difference = 0.02);

/** \brief ATE of \a estimate against \a reference: each estimated pose is paired with the
  * reference pose of the nearest timestamp (within \a max_time_difference seconds), the
  * estimate is rigidly aligned to the reference by Horn/Umeyama (no scale) when \a align,
  * and the translational differences summarised. Throws cuefusion::Error when fewer than
  * three poses pair up.
  */
TrajectoryError
absoluteTrajectoryError (const io::Trajectory& estimate, const io::Trajectory& reference,
                         double max_time_difference = 0.02, bool align = true);

/** \brief Relative pose error (drift) over a fixed interval, Sturm et al. 2012. */
struct RelativePoseError
{
  std::size_t pairs = 0;                 ///< intervals evaluated
  double translation_rmse = 0.0;         ///< metres per interval
  double translation_median = 0.0;
  double rotation_rmse_deg = 0.0;        ///< degrees per interval
  double rotation_median_deg = 0.0;
};

/** \brief How long an RPE interval is. */
struct RelativePoseInterval
{
  enum class Unit
  {
    Frames,   ///< j = i + length among the paired poses
    Seconds   ///< j = the first paired pose at least length seconds after i
  };
  Unit unit = Unit::Frames;
  double length = 1.0;
};

/** \brief RPE: for every interval (i, j), E = (Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j) with Q the
  * reference and P the estimate; the translation of E in metres and its rotation angle.
  * No alignment is needed (relative motions). Throws cuefusion::Error when no interval
  * fits (fewer than two paired poses, or a sequence shorter than the interval).
  */
RelativePoseError
relativePoseError (const io::Trajectory& estimate, const io::Trajectory& reference, const RelativePoseInterval& interval,
                   double max_time_difference = 0.02);
}  // namespace evaluation
}  // namespace cuefusion
