// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/reconstruction/dense_reconstruction.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <sstream>

namespace cuefusion
{
namespace reconstruction
{
namespace
{
class StageClock
{
public:
  double
  lap ()
  {
    const auto now = std::chrono::steady_clock::now ();
    const double ms = std::chrono::duration<double, std::milli> (now - last_).count ();
    last_ = now;
    return ms;
  }

private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now ();
};

const char* const kMotionModel = "motion model";

/** \a motion applied \a steps times (a real number: the rotation about the same axis and
  * the translation scaled for the fraction; repeated squaring for the whole part). */
Eigen::Isometry3d
repeatMotion (const Eigen::Isometry3d& motion, double steps)
{
  Eigen::Isometry3d result = Eigen::Isometry3d::Identity (), power = motion;
  for (auto whole = static_cast<std::uint64_t> (std::floor (steps)); whole > 0; whole >>= 1)
  {
    if (whole & 1u)
      result = result * power;
    power = power * power;
  }
  const double fraction = steps - std::floor (steps);
  if (fraction > 0.0)
  {
    const Eigen::AngleAxisd rotation (motion.rotation ());
    Eigen::Isometry3d part = Eigen::Isometry3d::Identity ();
    part.linear () = Eigen::AngleAxisd (rotation.angle () * fraction, rotation.axis ()).toRotationMatrix ();
    part.translation () = motion.translation () * fraction;
    result = result * part;
  }
  return result;
}
}  // namespace

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

std::optional<DenseReconstruction::Prediction>
DenseReconstruction::predictedPose (const RGBDFrame& frame) const
{
  if (!velocity_valid_)
    return std::nullopt;
  const double elapsed = frame.timestamp - last_tracked_timestamp_;
  const bool stamped = velocity_seconds_ > 0.0 && elapsed > 0.0 && std::isfinite (elapsed);
  // The frame after a tracked one, its stamp not showing frames dropped: the motion once
  // (stamps jitter by milliseconds; 1.5 intervals is a dropped frame).
  if (frames_since_tracked_ == 0 && !(stamped && elapsed > 1.5 * velocity_seconds_))
    return Prediction{last_good_pose_ * velocity_, false};
  // Through lost or dropped frames: once per frame interval, by the stamps when usable.
  double steps = static_cast<double> (frames_since_tracked_ + 1);
  double seconds = velocity_seconds_ > 0.0 ? steps * velocity_seconds_ : 0.0;
  if (stamped)
  {
    steps = elapsed / velocity_seconds_;
    seconds = elapsed;
  }
  if (seconds > config_.max_prediction_gap || steps > 1e4)
    return std::nullopt;
  return Prediction{last_good_pose_ * repeatMotion (velocity_, steps), true};
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

std::optional<DenseReconstruction::Candidate>
DenseReconstruction::featureCandidate (const RGBDFrame& frame, const KeyframeDatabase::Code& code)
{
  // Beside the last tracked frame one keyframe a round (a match costs ~10 ms): the most like
  // the frame by its fern code, and on every other round the next one round-robin.
  std::vector<std::size_t> views;
  const std::vector<std::size_t> stored = features_.keyframeIds ();
  if (feature_rounds_ % 2 == 0)
  {
    for (const KeyframeDatabase::Match& m : keyframes_.query (code, 1))
      views.push_back (m.keyframe);
  }
  else if (!stored.empty ())
    views.push_back (stored[(feature_rounds_ / 2) % stored.size ()]);
  ++feature_rounds_;
  const std::optional<FeatureRelocaliser::Estimate> found = features_.relocalise (frame.color, frame.depth, frame.camera, views);
  if (!found)
    return std::nullopt;
  return Candidate{found->pose, "features (" + found->view + ")", true};
}

void
DenseReconstruction::relocalise (const RGBDFrame& frame, bool features, std::vector<Candidate> candidates,
                                 const KeyframeDatabase::Code& code, FrameReport& report)
{
  for (const KeyframeDatabase::Match& m : keyframes_.query (code, config_.relocalisation_candidates))
    candidates.push_back ({m.pose, "keyframe " + std::to_string (m.keyframe), false});
  // Features on every other lost frame, the first of a stretch included (not while the view
  // is blank, a hand over the lens: nothing to describe). They cost about what verifying a
  // candidate does, so on their rounds they take one candidate's place in the budget.
  const bool feature_round = features && config_.feature_relocalisation && !frame.color.empty () && lost_streak_ % 2 == 0 &&
                             cv::countNonZero (frame_pyramid_.back ().depth > 0.f) >= 100;
  const std::optional<Candidate> found = feature_round ? featureCandidate (frame, code) : std::nullopt;
  // A time budget: a few candidates a frame, the next few on the next lost frame.
  const std::size_t budget = config_.relocalisation_candidates_per_frame;
  if (budget > 0 && !candidates.empty ())
  {
    const std::size_t take = std::min (candidates.size (), budget - (feature_round ? 1 : 0));
    std::vector<Candidate> chosen;
    for (std::size_t k = 0; k < take; ++k)
      chosen.push_back (candidates[(round_robin_ + k) % candidates.size ()]);
    round_robin_ += take;
    candidates = std::move (chosen);
  }
  if (found)
    candidates.insert (candidates.begin (), *found);
  ++lost_streak_;
  RaycastResult view;
  FramePyramid view_pyramid;
  for (const auto& [candidate, source, evidenced] : candidates)
  {
    // The model as seen from the candidate, and the frame aligned to it from there: a
    // right candidate converges close by with most points agreeing.
    // The frame's own depth as the raycast's start: where the candidate is right, each ray
    // settles by a Newton step or two near it instead of marching (a third of the cost).
    RaycastOptions hinted;
    hinted.depth_hint = frame_pyramid_[0].depth;
    volume_.raycast (frame.camera, candidate, view, hinted);
    buildModelPyramid (view.vertices, view.normals, view.camera, config_.preprocessing.pyramid_levels,
                       static_cast<float> (config_.preprocessing.max_depth_jump), view_pyramid);
    const TrackingResult verified = tracker_.track (frame_pyramid_, view_pyramid, candidate, candidate);
    // The motion model's and the features' candidates have evidence of their own: the frame
    // must agree with the model where the model exists (a view that moved on into space the
    // map has not seen yet overlaps it in part) and still explain a fair share of the frame
    // (relocalisation_min_overlap). The others must agree over most of the frame.
    const bool passed = evidenced ? verified.icp.agreement () >= config_.relocalisation_min_agreement &&
                                      verified.icp.inlierShare () >= config_.relocalisation_min_overlap
                                  : verified.icp.inlierShare () >= config_.relocalisation_min_inlier_fraction;
    if (!verified.tracked || !passed)
      continue;
    report.pose = verified.pose;
    report.tracked = true;
    report.relocalised = true;
    report.relocalised_from = source;
    report.failure.clear ();
    report.icp = verified.icp;
    return;
  }
}

bool
DenseReconstruction::refuseDroppedAgreement (TrackingResult& tracking) const
{
  if (!tracking.tracked || !(config_.min_inlier_share_ratio > 0.0) || recent_shares_.size () < 3)
    return false;
  // Agreement where frame and model overlap, not the share of the whole frame: a camera
  // turning into space the map has not seen yet overlaps it less, rightly.
  const double share = tracking.icp.agreement ();
  std::vector<double> sorted = recent_shares_;
  std::nth_element (sorted.begin (), sorted.begin () + static_cast<long> (sorted.size () / 2), sorted.end ());
  const double median = sorted[sorted.size () / 2];
  if (share >= config_.min_inlier_share_ratio * median)
    return false;
  std::ostringstream why;
  why << "agreement with the model dropped to " << std::lround (100.0 * share) << " % of the matched points (recent frames "
      << std::lround (100.0 * median) << " %)";
  tracking.tracked = false;
  tracking.failure = why.str ();
  tracking.pose = last_good_pose_;
  return true;
}

FrameReport
DenseReconstruction::process (const RGBDFrame& frame)
{
  FrameReport report;
  KeyframeDatabase::Code code;
  report.index = frame.index;
  report.timestamp = frame.timestamp;
  StageClock clock;

  preprocessor_.compute (frame.depth, frame.camera, frame_pyramid_);
  report.timings.preprocess_ms = clock.lap ();

  if (config_.use_reference_poses)
  {
    if (!frame.pose)
    {
      report.pose = last_good_pose_;
      report.failure = "no reference pose";
      return report;
    }
    report.pose = *frame.pose;
    report.tracked = true;
    report.timings.track_ms = clock.lap ();
  }
  else if (awaiting_placement_)
  {
    // A loaded volume: the frame must be found in it before anything is fused.
    std::vector<Candidate> first;
    if (frame.pose)
      first.push_back ({*frame.pose, "reference pose", false});
    code = keyframes_.encode (frame.depth);
    relocalise (frame, false, std::move (first), code, report);
    report.timings.relocalise_ms = clock.lap ();
    if (!report.tracked)
      report.failure = "not placed in the loaded volume (no candidate pose verified by ICP)";
    else
      awaiting_placement_ = false;
  }
  else if (!initialized_)
  {
    report.pose = frame.pose ? *frame.pose : Eigen::Isometry3d::Identity ();
    report.tracked = true;
    report.timings.track_ms = clock.lap ();
  }
  else
  {
    const std::optional<Prediction> prediction = config_.motion_model ? predictedPose (frame) : std::nullopt;
    const bool predict = prediction.has_value ();
    TrackingResult tracking = tracker_.track (frame_pyramid_, model_pyramid_, model_.pose, predict ? prediction->pose : last_good_pose_);
    if (!tracking.tracked && predict)
    {
      // The camera stopped or turned: the prediction misled ICP; start from the last pose.
      TrackingResult still = tracker_.track (frame_pyramid_, model_pyramid_, model_.pose, last_good_pose_);
      if (still.tracked)
        tracking = std::move (still);
    }
    if (!tracking.tracked)
      tracking.pose = last_good_pose_;
    // ICP itself was fine: its motion, or its agreement with the model, was not.
    const bool verify_estimate = tracking.implausible_motion || refuseDroppedAgreement (tracking);
    report.pose = tracking.pose;
    report.tracked = tracking.tracked;
    report.failure = tracking.failure;
    report.icp = tracking.icp;
    report.timings.track_ms = clock.lap ();
    if (!report.tracked && config_.relocalise)
    {
      code = keyframes_.encode (frame.depth);
      std::vector<Candidate> first;
      if (predict && prediction->across_gap)  // the model seen from where the motion leads
        first.push_back ({prediction->pose, kMotionModel, true});
      if (verify_estimate)
        first.push_back ({tracking.estimate, "ICP estimate", false});
      relocalise (frame, true, std::move (first), code, report);
      report.timings.relocalise_ms = clock.lap ();
    }
  }
  if (!report.tracked)
  {
    // The next raycast may be far from the last: it searches every hole (the last
    // raycast's empty holes, which would become its skip mask, are dropped).
    model_.empty_holes.release ();
    // The motion stays known (predictedPose carries it through the gap).
    ++frames_since_tracked_;
    return report;
  }
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
  if (report.relocalised && report.relocalised_from != kMotionModel)
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
  return report;
}
}  // namespace reconstruction
}  // namespace cuefusion
