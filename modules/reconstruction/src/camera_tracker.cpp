// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/reconstruction/camera_tracker.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace cuefusion
{
namespace reconstruction
{
void
CameraTrackerConfig::validate () const
{
  icp.validate ();
  if (!(min_inlier_fraction >= 0.0 && min_inlier_fraction <= 1.0))
    throw ParameterError ("CameraTrackerConfig::min_inlier_fraction", "must lie in [0, 1]");
  if (!(max_rmse > 0.0))
    throw ParameterError ("CameraTrackerConfig::max_rmse", "must be positive");
  if (!(max_translation > 0.0 && max_rotation_deg > 0.0))
    throw ParameterError ("CameraTrackerConfig::max_translation", "motion limits must be positive");
  if (!(min_translation_conditioning >= 0.0 && min_translation_conditioning < 1.0))
    throw ParameterError ("CameraTrackerConfig::min_translation_conditioning", "must lie in [0, 1)");
}

CameraTracker::CameraTracker (const CameraTrackerConfig& config) : config_ (config), icp_ (config.icp)
{
  config_.validate ();
}

TrackingResult
CameraTracker::track (const FramePyramid& frame, const FramePyramid& model, const Eigen::Isometry3d& model_pose,
                      const Eigen::Isometry3d& guess) const
{
  TrackingResult result;
  result.pose = guess;
  result.icp = icp_.align (frame, model, model_pose.inverse () * guess);
  const ICPResult& icp = result.icp;
  const Eigen::Isometry3d pose = model_pose * icp.transform;
  result.estimate = pose;
  const Eigen::Isometry3d motion = guess.inverse () * pose;
  const double translation = motion.translation ().norm ();
  const double rotation_deg = Eigen::AngleAxisd (motion.rotation ()).angle () * 180.0 / M_PI;
  const double fraction = icp.inlierShare ();
  const bool implausible = translation > config_.max_translation || rotation_deg > config_.max_rotation_deg;

  // A degenerate system names its cause: the frame's own surfaces (a plane, a corridor)
  // or its overlap with the model at the guess (the frame is fine, the matches are few).
  const bool degenerate = !icp.solved || icp.translation_conditioning < config_.min_translation_conditioning;
  if (degenerate && icp.source_points >= config_.min_inliers)  // the frame's own normals, only when asked
    result.icp.source_conditioning = ownTranslationConditioning (frame[config_.icp.iterations.size () - 1], config_.icp.noise_weighting);
  const bool frame_constrains = icp.source_conditioning >= std::max (config_.min_translation_conditioning, 1e-6);
  std::ostringstream why;
  if (icp.source_points < config_.min_inliers)
    why << "too little valid depth (" << icp.source_points << " points)";
  else if (degenerate && frame_constrains)
    why << "no overlap with the model at the predicted pose (" << icp.inliers << " of " << icp.source_points
        << " points matched; the frame's own surfaces constrain every direction, conditioning " << icp.source_conditioning
        << ", its matches " << icp.translation_conditioning << ")";
  else if (!icp.solved)
    why << "ICP system degenerate (too few or ill-conditioned correspondences)";
  else if (icp.translation_conditioning < config_.min_translation_conditioning)
    why << "ICP degenerate: the surfaces in view leave a translation free (conditioning "
        << icp.translation_conditioning << ", a plane or a corridor)";
  else if (icp.inliers < config_.min_inliers || fraction < config_.min_inlier_fraction)
  {
    why << "too few inliers (" << icp.inliers << " of " << icp.source_points << ")";
    result.short_of_overlap = icp.inliers >= config_.min_inliers && icp.rmse <= config_.max_rmse && !implausible;
  }
  else if (icp.rmse > config_.max_rmse)
    why << "residual too large (" << icp.rmse * 1000.0 << " mm RMS)";
  else if ((result.implausible_motion = implausible))
    why << "implausible motion (" << translation * 100.0 << " cm, " << rotation_deg << " deg)";
  result.failure = why.str ();
  result.tracked = result.failure.empty ();
  if (result.tracked)
    result.pose = pose;
  return result;
}
}  // namespace reconstruction
}  // namespace cuefusion
