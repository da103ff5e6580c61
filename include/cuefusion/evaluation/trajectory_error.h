#pragma once

#include <cuefusion/io/pose_io.h>

#include <Eigen/Geometry>

#include <cstddef>

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

/** \brief ATE of \a estimate against \a reference: each estimated pose is paired with the
  * reference pose of the nearest timestamp (within \a max_time_difference seconds), the
  * estimate is rigidly aligned to the reference by Horn/Umeyama (no scale) when \a align,
  * and the translational differences summarised. Throws cuefusion::Error when fewer than
  * three poses pair up.
  */
TrajectoryError
absoluteTrajectoryError (const io::Trajectory& estimate, const io::Trajectory& reference,
                         double max_time_difference = 0.02, bool align = true);
}  // namespace evaluation
}  // namespace cuefusion
