// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/rgbd_frame.h>
#include <cuefusion/reconstruction/camera_tracker.h>
#include <cuefusion/reconstruction/feature_relocaliser.h>
#include <cuefusion/reconstruction/keyframe_database.h>
#include <cuefusion/reconstruction/preprocessing.h>
#include <cuefusion/reconstruction/tsdf_volume.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace cuefusion
{
namespace reconstruction
{
struct DenseReconstructionConfig
{
  TSDFVolumeConfig volume;
  DepthPreprocessorConfig preprocessing;
  CameraTrackerConfig tracking;
  bool use_reference_poses = false;   ///< integrate with the frames' own poses, no tracking
  /// Rays behind holes of the depth that found no surface in the last raycast are searched
  /// again only every this many frames (RaycastHoleSkip); 1 = every frame, as a plain raycast
  unsigned hole_refresh_period = 8;
  /// When tracking fails: try candidate poses (the rejected ICP estimate, then the most
  /// similar keyframes), each verified by ICP against the model raycast at that pose
  bool relocalise = true;
  KeyframeDatabaseConfig keyframes;
  unsigned keyframe_period = 5;   ///< every this many tracked frames one is offered as a keyframe
  std::size_t relocalisation_candidates = 3;   ///< keyframes tried per lost frame
  /// A verified candidate needs at least this share of the frame's points as inliers
  /// (stricter than tracking's min_inlier_fraction: a wrong pose must not pass)
  double relocalisation_min_inlier_fraction = 0.5;
  /// The motion model's and the features' candidates (and ICP's pose from the motion carried
  /// across lost frames, which refines the former) are verified by their agreement with
  /// the model where the two overlap (ICPResult::agreement: their view may reach into space
  /// the map has not seen) of at least this much, and at least relocalisation_min_overlap
  /// of the frame's points as inliers. Measured (generated orbits, 640×480, Kinect noise):
  /// right poses after 30° jumps agreed 0.64–0.66 (0.83–0.91 nearer), with 0.36–0.38 of
  /// the frame; wrong ones ICP found near the motion model's pose 0.3–0.6 s into sudden
  /// 90° turns agreed 0.555 and 0.56, with 0.33 and 0.25 of the frame — a thin margin,
  /// docs/reconstruction.md.
  double relocalisation_min_agreement = 0.6;
  double relocalisation_min_overlap = 0.3;
  /// A features' candidate that ICP from there moves by at most this much (metres, and
  /// degrees) is confirmed by two cues: it needs relocalisation_min_agreement and the
  /// tracker's own min_inlier_fraction, not relocalisation_min_overlap — a view 40–50° on
  /// from a small map overlaps it by a quarter. Measured (generated printed orbits, SIFT
  /// poses after 46° jumps): right poses moved 0.3–2.3 cm and 0.1–0.5°, with 0.25–0.28 of the
  /// frame and agreement 0.64–0.66; the features' own tolerance is 2 cm plus 3 σ_z.
  double relocalisation_confirmation_shift = 0.04;
  double relocalisation_confirmation_deg = 2.0;
  /// ICP's pose after lost frames (a blackout; from the motion carried across them, or from
  /// the last pose) is confirmed by the frame's texture (textureAgreement at that pose against the model raycast there) of at
  /// least this much, the pose its peak (texturePeak, over moves of
  /// relocalisation_confirmation_shift), with relocalisation_min_agreement: then neither
  /// relocalisation_min_overlap nor the tracker's min_inlier_fraction applies — a view 90°
  /// round from a map of ten frames shares a quarter of itself with it. Where there is
  /// texture to judge by, it decides. Measured (the stress matrix's printed tabletop and
  /// clutter, Kinect noise, 354 verified candidates; docs/reconstruction.md): right poses
  /// 0.25–0.60, wrong ones ≤ 0.196 and never a peak, wrong ones that agree with the model
  /// ≤ 0.09 — ICP's pose in sudden 90° turns among them, which the overlap rule alone
  /// accepted. A scene without texture (NaN) keeps the overlap rule.
  double relocalisation_min_texture_agreement = 0.2;
  /// A tracked frame whose inlier share falls below this times the median share of the
  /// last 10 tracked frames is not trusted (ICP converged, but onto a wrong pose: a jump
  /// back to an earlier view, a fast turn); it goes to relocalisation. 0 = off.
  double min_inlier_share_ratio = 0.6;
  /// ICP starts from the constant-velocity prediction (the last tracked frame-to-frame
  /// motion repeated) when the two frames before were both tracked; when tracking from
  /// there fails it is tried once more from the last pose. The motion check
  /// (CameraTrackerConfig::max_translation, max_rotation_deg) then bounds the change
  /// against the prediction. Off: ICP always starts at the last pose (KinectFusion).
  bool motion_model = true;
  /// The motion model is carried through lost frames (a blackout, a hand over the lens,
  /// frames that fail) for at most this many seconds since the last tracked frame: the
  /// last tracked motion repeated once per frame interval is ICP's start and the first
  /// relocalisation candidate ("motion model") when the view comes back. 0 = not carried.
  /// 3 s: the blackouts `scripts/bench tracking` draws (5–60 frames at 30 Hz) end at most
  /// 2.03 s after the last tracked frame, and the view after them is placed for 30 frames
  /// more; ICP's pose from this far is confirmed by the frame's texture
  /// (relocalisation_min_texture_agreement). Keyframes wait while it is tried.
  double max_prediction_gap = 3.0;
  /// Candidate poses verified per lost frame (each costs a raycast and an ICP): a lost
  /// stretch goes round-robin over its candidates instead of trying all on every frame,
  /// so it runs at no less than about half the tracked frame rate (one candidate and its
  /// depth-started raycast: ~1.25× a tracked frame's loop, docs/reconstruction.md); the
  /// features (feature_relocalisation), every other lost frame, take one candidate's place
  /// on their frames and add the verification of the pose they find. 0 = all on every frame.
  std::size_t relocalisation_candidates_per_frame = 1;
  /// When tracking fails: the pose from ORB features of the colour image matched to the
  /// last tracked frame's and to one keyframe's (FeatureRelocaliser: the keyframe most
  /// similar by its fern code, on every other feature round the next one round-robin),
  /// verified by ICP like every candidate and tried before them; on every other lost frame,
  /// in place of one candidate of the per-frame budget. Recovers from jumps too wide for ICP
  /// and from views no keyframe is close to; needs colour.
  bool feature_relocalisation = true;
  FeatureRelocaliserConfig features;

  void validate () const;
};

/** \brief Milliseconds spent per stage on one frame. */
struct StageTimings
{
  double preprocess_ms = 0.0;
  double track_ms = 0.0;
  double integrate_ms = 0.0;
  double raycast_ms = 0.0;
  double relocalise_ms = 0.0;  ///< only on frames where tracking failed
};

/** \brief What happened to one frame. */
struct FrameReport
{
  std::size_t index = 0;
  double timestamp = 0.0;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();  ///< camera-to-world used (last good when lost)
  bool tracked = false;          ///< the pose was accepted and the frame fused
  std::string failure;           ///< why not, when !tracked
  bool relocalised = false;      ///< tracking failed and a verified relocalisation placed it
  /// which candidate: "motion model", "features (last tracked frame)", "features (keyframe K)",
  /// "ICP estimate", "keyframe K" or "reference pose"
  std::string relocalised_from;
  ICPResult icp;
  StageTimings timings;
};

/** \brief The reconstruction stage of §4.1 (KinectFusion as done by InfiniTAM), frame by
  * frame: preprocess (§4.1.2) → track against the last model raycast (§4.1.3) →
  * integrate into the TSDF volume (§4.1.4) → raycast the model at the new pose (§4.1.5).
  *
  * The first frame is placed at its reference pose when it has one (so the trajectory
  * shares the dataset's frame), else at the origin. A frame whose tracking is rejected is
  * relocalised (getConfig().relocalise): candidate poses — ICP's own estimate when only its
  * motion was implausible (a jump after dropped frames), then the poses of the most
  * similar keyframes (KeyframeDatabase; tracked frames that look new are added) — are
  * each verified by ICP of the frame against the model raycast at the candidate, with the
  * tracker's checks and a stricter inlier share; the first that passes places the frame.
  * A frame that is neither tracked nor relocalised is neither fused nor raycast; the next
  * frame is tracked from the last good pose against the last good model.
  */
class DenseReconstruction
{
public:
  explicit DenseReconstruction (const DenseReconstructionConfig& config = DenseReconstructionConfig ());

  const DenseReconstructionConfig& getConfig () const { return config_; }
  /** \brief Preprocessing from the next frame on with \a config (validated first; a bad
    * config changes nothing): FusionPipeline's smoothing follows the measured depth noise.
    */
  void setPreprocessingConfig (const DepthPreprocessorConfig& config);
  /** \brief Tracking (and the relocalisation's verification) from the next frame on with
    * \a config (validated first; a bad config changes nothing): FusionPipeline's normal
    * gate follows the measured depth noise (ProjectiveICPConfig::noise_scale).
    */
  void setTrackingConfig (const CameraTrackerConfig& config);
  /** \brief The volume's truncation (TSDFVolumeConfig::truncation_voxels) from the next
    * frame on, while nothing is fused yet: the volume keeps its distances in truncation
    * units, so once a frame is fused (or a volume continued) it keeps its own and this
    * returns false. FusionPipeline's truncation follows the depth noise measured on the
    * first frame. Throws ParameterError (nothing changed) for a value out of range.
    */
  bool setTruncation (double truncation_voxels);

  FrameReport
  process (const RGBDFrame& frame);
  /** \brief process(), with \a alongside run on a second thread from the moment the
    * frame's pyramid is built (sharedMaps().frame: level 0's filtered depth, vertices and
    * normals) while tracking, integration and the raycast run: work on the frame alone,
    * such as its segmentation, overlaps them. \a alongside may read sharedMaps().frame and
    * nothing else of this object. It is joined before process returns, also when the
    * frame is lost; an exception it throws is rethrown then.
    */
  FrameReport
  process (const RGBDFrame& frame, const std::function<void ()>& alongside);

  const TSDFVolume& volume () const { return volume_; }
  TSDFVolume& volume () { return volume_; }

  /** \brief Model maps V^m, N^m (and colours, voxels, sampled values) rendered at the last good pose. */
  const RaycastResult& model () const { return model_; }

  /** \brief A layer beside the volume (VoxelValueLayer) that each frame's model raycast
    * samples into model ().values, e.g. the segmentation's labels (L^m of §4.2.2.1);
    * nullptr: none. The layer must outlive its use here.
    */
  void setModelValues (const VoxelValueLayer* values) { model_values_ = values; }

  /** \brief Filtered vertex/normal pyramid of the last processed frame. */
  const FramePyramid& framePyramid () const { return frame_pyramid_; }

  /** \brief What the frame just processed shares with the stages after tracking (the
    * segmentation of §4.2 reads these instead of computing them again). */
  struct SharedMaps
  {
    const PyramidLevel& frame;  ///< level 0: the filtered depth (0 = invalid), its vertices and normals
    /** The frame's normals are DepthPreprocessorConfig::normals' (the configured span and
      * edge test); false where the image is too small for that span and level 0 has ±1 px
      * normals (DepthPreprocessorConfig::levelZeroUsesNormals). */
    bool configured_normals;
    const RaycastResult& model;  ///< V^m, N^m and the sampled values (setModelValues) at the frame's pose
  };
  SharedMaps sharedMaps () const;

  bool initialized () const { return initialized_; }
  const Eigen::Isometry3d& lastGoodPose () const { return last_good_pose_; }
  /** \brief Where \a frame is expected before it is tracked: its reference pose when those
    * are used, else the motion model's prediction (predictedPose), else the last good pose
    * once a frame was placed; none before. */
  std::optional<Eigen::Isometry3d> expectedPose (const RGBDFrame& frame) const;

  /** \brief The relocalisation keyframes stored so far. */
  const KeyframeDatabase& keyframes () const { return keyframes_; }

  /** \brief keyframes() and the last fused frame with its pose, novel or not: what a run
    * continuing this volume relocalises its first frame against (a camera that goes on
    * where it stopped is found by the last frame). */
  KeyframeDatabase
  keyframesForContinuing () const;

  /** \brief Empties the volume and forgets the trajectory and the keyframes. */
  void
  reset ();

  /** \brief Continues a saved reconstruction: \a volume (TSDFVolume::load) and its
    * \a keyframes (KeyframeDatabase::load; may be empty) replace this one's, the
    * trajectory is forgotten, and the next frame is not placed at its own pose but
    * relocalised in the loaded model: candidates are the frame's reference pose (when it
    * has one; a run continuing the same dataset shares its frame), then the keyframes most
    * similar to it, each verified by ICP as after a tracking failure. Until one frame
    * passes, frames are reported lost ("not placed in the loaded volume") and nothing is
    * fused. The volume's configuration and the keyframes' replace getConfig().volume and
    * getConfig().keyframes; with use_reference_poses frames are placed at their own poses.
    */
  void
  continueFrom (TSDFVolume volume, KeyframeDatabase keyframes);

  /** \brief Whether the next frame must be placed in a loaded volume (continueFrom). */
  bool awaitingPlacement () const { return awaiting_placement_; }

private:
  /** The source names of a pose from the motion model (FrameReport::relocalised_from), as
    * predicted and as ICP refined it from there (after lost frames): both keep the motion. */
  static constexpr const char* kMotionModel = "motion model";
  static constexpr const char* kMotionModelRefined = "motion model, refined by ICP";
  /** ... and of ICP's pose from the last tracked pose after lost frames (a camera that
    * stopped in the dark), which keeps the motion as a tracked frame's does. */
  static constexpr const char* kLastPoseRefined = "last pose, refined by ICP";

  /** §4.1.3 (pose_estimation.cpp): the frame's pose — its reference pose, its placement in
    * a loaded volume, the first frame's, or ICP from the motion model's or the last pose,
    * refused by the failure checks (implausible motion, dropped agreement) and then
    * relocalised. Fills \a report's pose, tracked, failure, icp, relocalisation and their
    * times; \a code gets the frame's keyframe code when one was made. False when the frame
    * has nothing to be placed with (reference poses, and it has none): it ends there. */
  bool
  estimatePose (const RGBDFrame& frame, FrameReport& report, KeyframeDatabase::Code& code);

  /** process() after the pyramid: the pose (estimatePose), then, when tracked, its
    * bookkeeping (acceptPose) and fuseAndRender. */
  void
  placeAndFuse (const RGBDFrame& frame, FrameReport& report);

  /** An accepted pose's bookkeeping: the motion model, the recent agreement shares,
    * keyframes and the features' memory of the last tracked frame. */
  void
  acceptPose (const RGBDFrame& frame, const FrameReport& report, KeyframeDatabase::Code& code);

  /** §4.1.4–§4.1.5: fuses the frame at its pose and renders the model there, the frame's
    * depth the raycast's hint; times both into \a report. */
  void
  fuseAndRender (const RGBDFrame& frame, FrameReport& report);

  /** A candidate pose for relocalisation and where it came from. */
  struct Candidate
  {
    Eigen::Isometry3d pose;
    std::string source;
    /// Found from the frame's own motion or features (not a stored view's pose): it must
    /// agree with the model where the two overlap, not over most of the frame, since a
    /// view that moved on into space the map has not seen overlaps it in part
    bool evidenced = false;
    /// Found by matched features (FeatureRelocaliser): ICP from it that moves it by no more
    /// than relocalisation_confirmation_shift / _deg confirms it (two cues agree), and then
    /// relocalisation_min_overlap does not apply
    bool from_features = false;
    /// May pass on the frame's texture instead of its overlap: when it agrees with the model
    /// (relocalisation_min_agreement) and the texture at its pose lines up with the model's
    /// colours (texturePeak: agreement ≥ relocalisation_min_texture_agreement, a peak), the
    /// verification's inlier share need not reach relocalisation_min_overlap nor the
    /// tracker's own min_inlier_fraction (it is short of overlap only: CameraTracker's other
    /// checks hold); where there is texture to judge by, it decides
    bool by_texture = false;
    /// May pass on its overlap as an evidenced candidate (relocalisation_min_overlap)
    bool by_overlap = true;
  };

  /** Relocalises the current frame (its pyramid is built): \a own first when \a own_first
    * (ICP's pose after lost frames that passed every tracking check), then the features'
    * pose (when \a features and a feature round: featureCandidate), then \a own on a round
    * without features (ICP's pose from the motion carried across lost frames), then
    * candidates \a first (the motion model's prediction, ICP's rejected pose when worth
    * verifying, a loaded run's reference pose) and the keyframes most similar to \a code, at
    * most relocalisation_candidates_per_frame of those, less one on a feature round or
    * with \a own, taken round-robin over a lost stretch; fills \a report when one passes. */
  void
  relocalise (const RGBDFrame& frame, bool features, std::vector<Candidate> first, const KeyframeDatabase::Code& code,
              FrameReport& report, const std::optional<Candidate>& own = std::nullopt, bool own_first = false);

  /** Verifies \a candidate (the model raycast there into \a view and \a view_pyramid, ICP
    * from it, passesVerification) and fills \a report when it passes; true then. */
  bool
  placeAt (const RGBDFrame& frame, const Candidate& candidate, RaycastResult& view, FramePyramid& view_pyramid,
           FrameReport& report);

  /** Whether \a candidate passes, \a verified being ICP from it against the model raycast
    * there (\a view): its agreement and overlap, the features' confirmation, the texture. */
  bool
  passesVerification (const RGBDFrame& frame, const Candidate& candidate, const TrackingResult& verified,
                      const RaycastResult& view) const;

  /** The features' candidate for a lost \a frame (FeatureRelocaliser), or none. */
  std::optional<Candidate>
  featureCandidate (const RGBDFrame& frame, const KeyframeDatabase::Code& code);

  /** min_inlier_share_ratio's check: refuses a tracked \a tracking (its pose back to the
    * last good one, its failure said) whose agreement with the model fell below that
    * ratio of the recent frames' median; true when it did. */
  bool
  refuseDroppedAgreement (TrackingResult& tracking) const;

  /** The motion model's pose for a frame, and whether it spans lost or dropped frames. */
  struct Prediction
  {
    Eigen::Isometry3d pose;
    bool across_gap = false;
  };

  /** The motion model's pose for \a frame: the last tracked pose moved on by the last
    * tracked motion once per frame interval since (through lost frames, and dropped ones
    * the stamps show, up to max_prediction_gap); none without a motion. */
  std::optional<Prediction>
  predictedPose (const RGBDFrame& frame) const;

  DenseReconstructionConfig config_;
  DepthPreprocessor preprocessor_;
  CameraTracker tracker_;
  TSDFVolume volume_;
  RaycastResult model_;
  RaycastHoleSkip hole_skip_;  ///< the last raycast's empty holes, for the next one
  const VoxelValueLayer* model_values_ = nullptr;  ///< sampled by the model raycast (setModelValues)
  FramePyramid frame_pyramid_;
  FramePyramid model_pyramid_;
  KeyframeDatabase keyframes_;
  FeatureRelocaliser features_;
  cv::Mat last_fused_depth_;  ///< of the last fused frame (when relocalising), for keyframesForContinuing and features_
  std::vector<double> recent_shares_;  ///< inlier shares of the last tracked frames
  std::size_t tracked_frames_ = 0;
  Eigen::Isometry3d last_good_pose_ = Eigen::Isometry3d::Identity ();
  Eigen::Isometry3d velocity_ = Eigen::Isometry3d::Identity ();  ///< last tracked frame-to-frame motion
  bool velocity_valid_ = false;       ///< a motion of two frames tracked one after the other is known
  double velocity_seconds_ = 0.0;     ///< the time velocity_ took (0: the frames had no usable stamps)
  double last_tracked_timestamp_ = 0.0;
  std::size_t frames_since_tracked_ = 0;  ///< lost frames since the last tracked one (0: the last frame was tracked)
  std::size_t lost_streak_ = 0;           ///< relocalisation rounds in this lost stretch
  std::size_t round_robin_ = 0;           ///< candidates taken so far in this lost stretch (the round-robin's phase)
  std::size_t feature_rounds_ = 0;        ///< feature rounds in this lost stretch
  bool initialized_ = false;
  bool awaiting_placement_ = false;  ///< continueFrom: the first frame is relocalised
};
}  // namespace reconstruction
}  // namespace cuefusion
