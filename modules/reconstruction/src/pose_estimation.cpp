// SPDX-License-Identifier: BSD-3-Clause
// DenseReconstruction's pose estimation (§4.1.3): the motion model's prediction, ICP and
// its failure checks, and relocalisation when they fail (features, candidates, keyframes).
// The fusing and rendering that follow an accepted pose are in dense_reconstruction.cpp.
#include <cuefusion/common/exceptions.h>
#include <cuefusion/reconstruction/dense_reconstruction.h>
#include <cuefusion/reconstruction/texture_agreement.h>

#include "stage_clock.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>

namespace cuefusion
{
namespace reconstruction
{
namespace
{
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

bool
DenseReconstruction::estimatePose (const RGBDFrame& frame, FrameReport& report, KeyframeDatabase::Code& code)
{
  StageClock clock;
  if (config_.use_reference_poses)
  {
    if (!frame.pose)
    {
      report.pose = last_good_pose_;
      report.failure = "no reference pose";
      return false;  // nothing to place it with: the frame ends here
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
    bool across_gap = predict && prediction->across_gap;  // ICP started from the motion carried through lost frames
    if (!tracking.tracked && predict)
    {
      // The camera stopped or turned: the prediction misled ICP; start from the last pose.
      TrackingResult still = tracker_.track (frame_pyramid_, model_pyramid_, model_.pose, last_good_pose_);
      if (still.tracked)
      {
        tracking = std::move (still);
        across_gap = false;
      }
    }
    if (!tracking.tracked)
      tracking.pose = last_good_pose_;
    // ICP itself was fine: its motion, or its agreement with the model, was not.
    const bool verify_estimate = tracking.implausible_motion || refuseDroppedAgreement (tracking);
    // The first pose after lost frames is verified where it looks, even where every check
    // passed: those judged it against the model raycast at the last pose before the gap,
    // another view, and ICP from there converges onto a wrong pose that passes them (90°
    // into a sudden turn: 2.2 m off with 45 % agreement, fused, in the stress matrix's
    // held-out draws; docs/benchmarks.md, 2026-12-08).
    const bool after_gap = tracking.tracked && frames_since_tracked_ > 0 && config_.relocalise;
    report.pose = after_gap ? last_good_pose_ : tracking.pose;
    report.tracked = tracking.tracked && !after_gap;
    report.failure = after_gap ? "after lost frames, ICP's pose not confirmed where it looks (its agreement, texture or overlap)"
                               : tracking.failure;
    report.icp = tracking.icp;
    report.timings.track_ms = clock.lap ();
    if (!report.tracked && config_.relocalise)
    {
      code = keyframes_.encode (frame.depth);
      std::vector<Candidate> first;
      // After lost frames the model seen from where the motion leads; where ICP from there
      // converged, its pose instead: that candidate refined by the frame's own evidence.
      // Judged against the model raycast at the last pose before the gap, which a camera
      // that turned 30° meanwhile meets with half its matches on other surfaces (new faces
      // of the objects), it failed; raycast at the estimate itself the model agrees with ~90 %
      // of them, over as little as a quarter of the frame after a long blackout. So it
      // passes on the frame's texture lining up with the model's colours, and without
      // texture on its overlap only where the tracker found ICP sound but its motion or
      // agreement suspect: ICP's pose in a sudden 90° turn, wrong by 1.8 m, agreed 0.62 over
      // 0.43 of the frame (docs/reconstruction.md, 2026-12-08). It is tried on every lost
      // round without features, in a keyframe's place (the budget holds; keyframes wait while
      // the motion is carried) — and first, before anything is described, where ICP passed
      // every tracking check.
      std::optional<Candidate> own;
      if (after_gap)  // ICP's checks passed: its overlap may stand where there is no texture
        own = Candidate{tracking.estimate, across_gap ? kMotionModelRefined : kLastPoseRefined, /*evidenced*/ true,
                        /*from_features*/ false, /*by_texture*/ true, /*by_overlap*/ true};
      else if (across_gap && tracking.icp.solved)
        own = Candidate{tracking.estimate, kMotionModelRefined, /*evidenced*/ true, /*from_features*/ false,
                        /*by_texture*/ true, /*by_overlap*/ verify_estimate};
      else if (predict && prediction->across_gap)
        first.push_back ({prediction->pose, kMotionModel, true});
      if (verify_estimate && !across_gap)
        first.push_back ({tracking.estimate, "ICP estimate", false});
      relocalise (frame, true, std::move (first), code, report, own, after_gap);
      report.timings.relocalise_ms = clock.lap ();
    }
  }
  return true;
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

std::optional<Eigen::Isometry3d>
DenseReconstruction::expectedPose (const RGBDFrame& frame) const
{
  if (config_.use_reference_poses)
    return frame.pose;
  if (const std::optional<Prediction> predicted = predictedPose (frame))
    return predicted->pose;
  if (initialized_)
    return last_good_pose_;
  return std::nullopt;
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
  return Candidate{found->pose, "features (" + found->view + ")", true, true};
}

void
DenseReconstruction::relocalise (const RGBDFrame& frame, bool features, std::vector<Candidate> candidates,
                                 const KeyframeDatabase::Code& code, FrameReport& report, const std::optional<Candidate>& own,
                                 bool own_first)
{
  RaycastResult view;
  FramePyramid view_pyramid;
  // ICP's pose that passed every tracking check: verified before anything is described.
  if (own && own_first && placeAt (frame, *own, view, view_pyramid, report))
    return;
  const bool own_in_turn = own && !own_first;
  for (const KeyframeDatabase::Match& m : keyframes_.query (code, config_.relocalisation_candidates))
    candidates.push_back ({m.pose, "keyframe " + std::to_string (m.keyframe), false});
  // ORB features on every other lost frame, the first of a stretch included (not while the
  // view is blank, a hand over the lens: nothing to describe); SIFT against the last tracked
  // frame on every fourth, the second of a stretch included (a jump wider than ORB reaches
  // comes back one frame later). ORB costs about what verifying a candidate does, so on its
  // rounds it takes one candidate's place in the budget; SIFT ~2–3 candidates' (a quarter of
  // a stretch's frames: the stretch's median frame stays a candidate's).
  const bool describable = features && config_.feature_relocalisation && !frame.color.empty () &&
                           cv::countNonZero (frame_pyramid_.back ().depth > 0.f) >= 100;
  const bool feature_round = describable && lost_streak_ % 2 == 0;
  const bool wide_round = describable && config_.features.wide_features > 0 && lost_streak_ % 4 == 1;
  std::optional<Candidate> found = feature_round ? featureCandidate (frame, code) : std::nullopt;
  if (wide_round)
    if (const std::optional<FeatureRelocaliser::Estimate> wide = features_.relocaliseWide (frame.color, frame.depth, frame.camera))
      found = Candidate{wide->pose, "features (" + wide->view + ")", true, true};
  // A time budget: a few candidates a frame, the next few on the next lost frame.
  const std::size_t budget = config_.relocalisation_candidates_per_frame;
  if (budget > 0 && !candidates.empty ())
  {
    const std::size_t take = std::min (candidates.size (), budget - (feature_round || wide_round || own_in_turn ? 1 : 0));
    std::vector<Candidate> chosen;
    for (std::size_t k = 0; k < take; ++k)
      chosen.push_back (candidates[(round_robin_ + k) % candidates.size ()]);
    round_robin_ += take;
    candidates = std::move (chosen);
  }
  // ICP's carried pose that did not pass every check takes a keyframe's place, on the rounds
  // without features only (theirs is a candidate's cost), so a lost frame costs what it did.
  if (own_in_turn && !feature_round && !wide_round)
    candidates.insert (candidates.begin (), *own);
  if (found)
    candidates.insert (candidates.begin (), *found);
  ++lost_streak_;
  for (const Candidate& candidate : candidates)
    if (placeAt (frame, candidate, view, view_pyramid, report))
      return;
}

bool
DenseReconstruction::placeAt (const RGBDFrame& frame, const Candidate& candidate, RaycastResult& view,
                              FramePyramid& view_pyramid, FrameReport& report)
{
  // The model as seen from the candidate, and the frame aligned to it from there: a right
  // candidate converges close by with most points agreeing.
  // The frame's own depth as the raycast's start: where the candidate is right, each ray
  // settles by a Newton step or two near it instead of marching (a third of the cost).
  RaycastOptions hinted;
  hinted.depth_hint = frame_pyramid_[0].depth;
  volume_.raycast (frame.camera, candidate.pose, view, hinted);
  buildModelPyramid (view.vertices, view.normals, view.camera, config_.preprocessing.pyramid_levels,
                     static_cast<float> (config_.preprocessing.max_depth_jump), view_pyramid);
  const TrackingResult verified = tracker_.track (frame_pyramid_, view_pyramid, candidate.pose, candidate.pose);
  if (!passesVerification (frame, candidate, verified, view))
    return false;
  report.pose = verified.estimate;  // the tracked pose, or ICP's where only the overlap was short
  report.tracked = true;
  report.relocalised = true;
  report.relocalised_from = candidate.source;
  report.failure.clear ();
  report.icp = verified.icp;
  return true;
}

bool
DenseReconstruction::passesVerification (const RGBDFrame& frame, const Candidate& candidate, const TrackingResult& verified,
                                         const RaycastResult& view) const
{
  // The motion model's and the features' candidates have evidence of their own: the frame
  // must agree with the model where the model exists (a view that moved on into space the
  // map has not seen yet overlaps it in part) and still explain a fair share of the frame
  // (relocalisation_min_overlap), unless ICP confirms the features' pose where it stands or
  // the frame's texture confirms ICP's. The others must agree over most of the frame.
  if (!candidate.evidenced)
    return verified.tracked && verified.icp.inlierShare () >= config_.relocalisation_min_inlier_fraction;
  if (verified.icp.agreement () < config_.relocalisation_min_agreement)
    return false;
  const Eigen::Isometry3d shift = candidate.pose.inverse () * verified.pose;
  const bool confirmed = candidate.from_features && shift.translation ().norm () <= config_.relocalisation_confirmation_shift &&
                         Eigen::AngleAxisd (shift.rotation ()).angle () <= config_.relocalisation_confirmation_deg * M_PI / 180.0;
  if (candidate.by_texture && (verified.tracked || verified.short_of_overlap))
  {
    // Compared where the frame's points meet the model within ICP's correspondence distance;
    // a peak over moves of the confirmation's tolerance. Where there is texture to judge by,
    // it decides.
    const TexturePeak texture = texturePeak (frame.color, frame_pyramid_[0].vertices, view, verified.estimate,
                                             config_.relocalisation_confirmation_shift, config_.tracking.icp.max_distance,
                                             config_.tracking.min_inliers);
    if (!std::isnan (texture.agreement))
      return texture.peak && texture.agreement >= config_.relocalisation_min_texture_agreement;
  }
  return verified.tracked && (confirmed || (candidate.by_overlap && verified.icp.inlierShare () >= config_.relocalisation_min_overlap));
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

}  // namespace reconstruction
}  // namespace cuefusion
