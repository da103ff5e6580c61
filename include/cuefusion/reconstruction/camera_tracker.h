// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/reconstruction/projective_icp.h>

#include <Eigen/Geometry>

#include <string>

namespace cuefusion
{
namespace reconstruction
{
/** \brief Camera tracking with failure detection (§4.1.3). */
struct CameraTrackerConfig
{
  ProjectiveICPConfig icp;
  double min_inlier_fraction = 0.25;   ///< of the frame's valid vertices
  std::size_t min_inliers = 300;
  double max_rmse = 0.02;              ///< point-to-plane RMS (metres)
  /** Minimum ICPResult::translation_conditioning: below it the view constrains one
    * translation too weakly to trust (a floor or a wall alone). Measured: a noisy plane
    * ≤ 0.0043; the real sequences ≥ 0.0147 (7scenes-redkitchen) and ≥ 0.066
    * (icl-livingroom1), the generated tabletop ≥ 0.035. 0 = off. */
  double min_translation_conditioning = 0.008;
  double max_translation = 0.20;       ///< per frame, metres
  double max_rotation_deg = 20.0;      ///< per frame

  void validate () const;
};

/** \brief Outcome of CameraTracker::track. */
struct TrackingResult
{
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();  ///< camera-to-world; the guess when lost
  Eigen::Isometry3d estimate = Eigen::Isometry3d::Identity ();  ///< ICP's pose, accepted or not
  bool tracked = false;
  bool implausible_motion = false;  ///< rejected for its motion alone (ICP itself was fine)
  /// rejected for its inlier share alone (min_inlier_fraction): enough inliers that agree,
  /// constrain every direction and fit, and a plausible motion, over too small a part of
  /// the frame — the map's overlap with a view that moved on into space it has not seen
  bool short_of_overlap = false;
  std::string failure;     ///< why tracking was rejected (empty when tracked)
  ICPResult icp;
};

/** \brief Frame-to-model tracking: aligns the frame's pyramid to the model pyramid rendered
  * at \a model_pose, starting from \a guess (camera-to-world), and rejects the result when
  * too few points agree, the residual is too large or the motion implausible for one
  * frame. A rejected frame keeps the guess as its pose, so the caller can skip it and
  * retry the next frame from the last good pose.
  */
class CameraTracker
{
public:
  explicit CameraTracker (const CameraTrackerConfig& config = CameraTrackerConfig ());

  const CameraTrackerConfig& getConfig () const { return config_; }

  TrackingResult
  track (const FramePyramid& frame, const FramePyramid& model, const Eigen::Isometry3d& model_pose,
         const Eigen::Isometry3d& guess) const;

private:
  CameraTrackerConfig config_;
  ProjectiveICP icp_;
};
}  // namespace reconstruction
}  // namespace cuefusion
