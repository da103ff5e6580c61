// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/reconstruction/dense_reconstruction.h>

#include "stage_clock.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <future>
#include <sstream>

namespace cuefusion
{
namespace reconstruction
{
void
DenseReconstructionConfig::validate () const
{
  volume.validate ();
  preprocessing.validate ();
  tracking.validate ();
  if (hole_refresh_period < 1 || hole_refresh_period > 1000)
    throw ParameterError ("DenseReconstructionConfig::hole_refresh_period", "must lie in [1, 1000] frames");
  if (static_cast<std::size_t> (preprocessing.pyramid_levels) < tracking.icp.iterations.size ())
    throw ParameterError ("DenseReconstructionConfig::preprocessing.pyramid_levels", "must be at least the number of ICP levels");
  keyframes.validate ();
  if (keyframe_period < 1 || keyframe_period > 1000)
    throw ParameterError ("DenseReconstructionConfig::keyframe_period", "must lie in [1, 1000] frames");
  if (relocalisation_candidates > 100)
    throw ParameterError ("DenseReconstructionConfig::relocalisation_candidates", "must lie in [0, 100]");
  if (!(min_inlier_share_ratio >= 0.0 && min_inlier_share_ratio <= 1.0))
    throw ParameterError ("DenseReconstructionConfig::min_inlier_share_ratio", "must lie in [0, 1]");
  if (!(relocalisation_min_inlier_fraction >= 0.0 && relocalisation_min_inlier_fraction <= 1.0))
    throw ParameterError ("DenseReconstructionConfig::relocalisation_min_inlier_fraction", "must lie in [0, 1]");
  if (!(max_prediction_gap >= 0.0 && max_prediction_gap <= 60.0))
    throw ParameterError ("DenseReconstructionConfig::max_prediction_gap", "must lie in [0, 60] seconds");
  if (!(relocalisation_min_agreement >= 0.0 && relocalisation_min_agreement <= 1.0))
    throw ParameterError ("DenseReconstructionConfig::relocalisation_min_agreement", "must lie in [0, 1]");
  if (!(relocalisation_min_overlap >= 0.0 && relocalisation_min_overlap <= 1.0))
    throw ParameterError ("DenseReconstructionConfig::relocalisation_min_overlap", "must lie in [0, 1]");
  if (!(relocalisation_confirmation_shift >= 0.0 && relocalisation_confirmation_shift <= 1.0))
    throw ParameterError ("DenseReconstructionConfig::relocalisation_confirmation_shift", "must lie in [0, 1] metres");
  if (!(relocalisation_confirmation_deg >= 0.0 && relocalisation_confirmation_deg <= 180.0))
    throw ParameterError ("DenseReconstructionConfig::relocalisation_confirmation_deg", "must lie in [0, 180] degrees");
  if (!(relocalisation_min_texture_agreement >= -1.0 && relocalisation_min_texture_agreement <= 1.0))
    throw ParameterError ("DenseReconstructionConfig::relocalisation_min_texture_agreement", "must lie in [-1, 1]");
  if (relocalisation_candidates_per_frame > 100)
    throw ParameterError ("DenseReconstructionConfig::relocalisation_candidates_per_frame", "must lie in [0, 100]");
  features.validate ();
}

DenseReconstruction::DenseReconstruction (const DenseReconstructionConfig& config)
  : config_ (config), preprocessor_ (config.preprocessing), tracker_ (config.tracking), volume_ (config.volume),
    keyframes_ (config.keyframes), features_ (config.features)
{
  config_.validate ();
}

DenseReconstruction::SharedMaps
DenseReconstruction::sharedMaps () const
{
  const PyramidLevel& level = frame_pyramid_.front ();
  return {level, config_.preprocessing.levelZeroUsesNormals (level.depth.cols), model_};
}

void
DenseReconstruction::setPreprocessingConfig (const DepthPreprocessorConfig& config)
{
  config.validate ();
  config_.preprocessing = config;
  preprocessor_ = DepthPreprocessor (config);
}

void
DenseReconstruction::setTrackingConfig (const CameraTrackerConfig& config)
{
  DenseReconstructionConfig next = config_;
  next.tracking = config;
  next.validate ();  // the ICP levels must fit the pyramid
  config_.tracking = config;
  tracker_ = CameraTracker (config);
}

bool
DenseReconstruction::setTruncation (double truncation_voxels)
{
  TSDFVolumeConfig next = volume_.getConfig ();
  next.truncation_voxels = truncation_voxels;
  next.validate ();
  if (volume_.blockCount () > 0)
    return false;
  const bool record = volume_.getRecordObservedSurface ();
  volume_ = TSDFVolume (next);
  volume_.setRecordObservedSurface (record);
  config_.volume = next;
  return true;
}

void
DenseReconstruction::reset ()
{
  volume_.reset ();
  model_ = RaycastResult ();
  hole_skip_ = RaycastHoleSkip ();
  frame_pyramid_.clear ();
  model_pyramid_.clear ();
  keyframes_.clear ();
  features_.clear ();
  last_fused_depth_.release ();
  recent_shares_.clear ();
  tracked_frames_ = 0;
  last_good_pose_ = Eigen::Isometry3d::Identity ();
  velocity_ = Eigen::Isometry3d::Identity ();
  velocity_valid_ = false;
  velocity_seconds_ = last_tracked_timestamp_ = 0.0;
  frames_since_tracked_ = lost_streak_ = round_robin_ = feature_rounds_ = 0;
  initialized_ = awaiting_placement_ = false;
}

KeyframeDatabase
DenseReconstruction::keyframesForContinuing () const
{
  KeyframeDatabase out = keyframes_;
  if (!last_fused_depth_.empty ())
    out.add (out.encode (last_fused_depth_), last_good_pose_);
  return out;
}

void
DenseReconstruction::continueFrom (TSDFVolume volume, KeyframeDatabase keyframes)
{
  reset ();
  const bool record = volume_.getRecordObservedSurface ();
  volume_ = std::move (volume);
  volume_.setRecordObservedSurface (record);
  keyframes_ = std::move (keyframes);
  config_.volume = volume_.getConfig ();
  config_.keyframes = keyframes_.getConfig ();
  awaiting_placement_ = !config_.use_reference_poses;
}

FrameReport
DenseReconstruction::process (const RGBDFrame& frame)
{
  return process (frame, std::function<void ()> ());
}

FrameReport
DenseReconstruction::process (const RGBDFrame& frame, const std::function<void ()>& alongside)
{
  FrameReport report;
  report.index = frame.index;
  report.timestamp = frame.timestamp;
  StageClock clock;
  preprocessor_.compute (frame.depth, frame.camera, frame_pyramid_);
  report.timings.preprocess_ms = clock.lap ();
  // The pyramid is only read from here on. Should placeAndFuse throw, the future's
  // destructor still waits for the task (std::async), so it never outlives the frame.
  std::future<void> side;
  if (alongside)
    side = std::async (std::launch::async, alongside);
  placeAndFuse (frame, report);
  if (side.valid ())
    side.get ();
  return report;
}

void
DenseReconstruction::placeAndFuse (const RGBDFrame& frame, FrameReport& report)
{
  KeyframeDatabase::Code code;  // the frame's keyframe code, once made
  if (!estimatePose (frame, report, code))
    return;
  if (!report.tracked)
  {
    // The next raycast may be far from the last: it searches every hole (the last
    // raycast's empty holes, which would become its skip mask, are dropped).
    model_.empty_holes.release ();
    // The motion stays known (predictedPose carries it through the gap).
    ++frames_since_tracked_;
    return;
  }
  acceptPose (frame, report, code);
  fuseAndRender (frame, report);
}

void
DenseReconstruction::acceptPose (const RGBDFrame& frame, const FrameReport& report, KeyframeDatabase::Code& code)
{
  lost_streak_ = round_robin_ = feature_rounds_ = 0;
  if (report.relocalised)
  {
    model_.empty_holes.release ();  // the last raycast's holes belong to another view
    recent_shares_.clear ();        // and the shares to another part of the scene
  }
  if (!config_.use_reference_poses && initialized_)
  {
    recent_shares_.push_back (report.icp.agreement ());
    if (recent_shares_.size () > 10)
      recent_shares_.erase (recent_shares_.begin ());
  }
  if (report.relocalised && report.relocalised_from != kMotionModel && report.relocalised_from != kMotionModelRefined &&
      report.relocalised_from != kLastPoseRefined)
    velocity_valid_ = false;  // placed elsewhere: the motion before says nothing about here
  else if (initialized_ && frames_since_tracked_ == 0 && !report.relocalised)  // the frame before was tracked
  {
    velocity_ = last_good_pose_.inverse () * report.pose;
    const double seconds = frame.timestamp - last_tracked_timestamp_;
    velocity_seconds_ = seconds > 0.0 && std::isfinite (seconds) ? seconds : 0.0;
    velocity_valid_ = true;
  }
  frames_since_tracked_ = 0;
  last_tracked_timestamp_ = frame.timestamp;
  last_good_pose_ = report.pose;
  initialized_ = true;
  // With reference poses too: a later run may continue this volume (continueFrom).
  if (config_.relocalise)
  {
    if (tracked_frames_++ % config_.keyframe_period == 0)
    {
      if (code.empty ())
        code = keyframes_.encode (frame.depth);
      if (keyframes_.addIfNovel (code, report.pose) && config_.feature_relocalisation)
        features_.addKeyframe (frame.color, frame.depth, frame.camera, report.pose, keyframes_.size () - 1);
    }
    // Coded only when saved (keyframesForContinuing): a copy costs a tenth of a coding.
    frame.depth.copyTo (last_fused_depth_);
    // Described only when the next frame is lost; the depth is the copy just made.
    if (config_.feature_relocalisation && !frame.color.empty ())
      features_.rememberTracked (frame.color, last_fused_depth_, frame.camera, report.pose);
  }
}

void
DenseReconstruction::fuseAndRender (const RGBDFrame& frame, FrameReport& report)
{
  StageClock clock;
  volume_.integrate (frame.depth, frame.color, frame.camera, report.pose);
  report.timings.integrate_ms = clock.lap ();

  // The frame just fused tells where the surface is along each ray (see raycast()).
  // The last raycast's empty holes become this one's skip mask (two buffers, swapped).
  std::swap (hole_skip_.empty_holes, model_.empty_holes);
  if (config_.hole_refresh_period <= 1 || hole_skip_.empty_holes.size () != frame_pyramid_[0].depth.size ())
    hole_skip_.empty_holes.release ();
  hole_skip_.refresh_period = config_.hole_refresh_period;
  ++hole_skip_.phase;
  RaycastOptions options;
  options.depth_hint = frame_pyramid_[0].depth;
  options.hole_skip = hole_skip_;
  options.values = model_values_;
  volume_.raycast (frame.camera, report.pose, model_, options);
  buildModelPyramid (model_.vertices, model_.normals, model_.camera, config_.preprocessing.pyramid_levels,
                     static_cast<float> (config_.preprocessing.max_depth_jump), model_pyramid_);
  report.timings.raycast_ms = clock.lap ();
}
}  // namespace reconstruction
}  // namespace cuefusion
