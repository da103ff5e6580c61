#pragma once

#include <cuefusion/common/rgbd_frame.h>
#include <cuefusion/reconstruction/camera_tracker.h>
#include <cuefusion/reconstruction/preprocessing.h>
#include <cuefusion/reconstruction/tsdf_volume.h>

#include <memory>
#include <string>

namespace cuefusion
{
namespace reconstruction
{
struct DenseReconstructionConfig
{
  TSDFVolumeConfig volume;
  DepthPreprocessingConfig preprocessing;
  CameraTrackerConfig tracking;
  bool use_reference_poses = false;   ///< integrate with the frames' own poses, no tracking
  /// Rays behind holes of the depth that found no surface in the last raycast are searched
  /// again only every this many frames (RaycastHoleSkip); 1 = every frame, as a plain raycast
  unsigned hole_refresh_period = 8;

  void validate () const;
};

/** \brief Milliseconds spent per stage on one frame. */
struct StageTimings
{
  double preprocess_ms = 0.0;
  double track_ms = 0.0;
  double integrate_ms = 0.0;
  double raycast_ms = 0.0;
};

/** \brief What happened to one frame. */
struct FrameReport
{
  std::size_t index = 0;
  double timestamp = 0.0;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();  ///< camera-to-world used (last good when lost)
  bool tracked = false;          ///< the pose was accepted and the frame fused
  std::string failure;           ///< why not, when !tracked
  ICPResult icp;
  StageTimings timings;
};

/** \brief The reconstruction stage of §4.1 (KinectFusion as done by InfiniTAM), frame by
  * frame: preprocess (§4.1.2) → track against the last model raycast (§4.1.3) →
  * integrate into the TSDF volume (§4.1.4) → raycast the model at the new pose (§4.1.5).
  *
  * The first frame is placed at its reference pose when it has one (so the trajectory
  * shares the dataset's frame), else at the origin. A frame whose tracking is rejected is
  * neither fused nor raycast; the next frame is tracked from the last good pose against
  * the last good model, which is how tracking recovers when the view returns.
  */
class DenseReconstruction
{
public:
  explicit DenseReconstruction (const DenseReconstructionConfig& config = DenseReconstructionConfig ());

  const DenseReconstructionConfig& config () const { return config_; }

  FrameReport
  process (const RGBDFrame& frame);

  const TSDFVolume& volume () const { return volume_; }
  TSDFVolume& volume () { return volume_; }

  /** \brief Model maps V^m, N^m, L^m rendered at the last good pose. */
  const RaycastResult& model () const { return model_; }

  /** \brief Filtered vertex/normal pyramid of the last processed frame. */
  const FramePyramid& framePyramid () const { return frame_pyramid_; }

  bool initialized () const { return initialized_; }
  const Eigen::Isometry3d& lastGoodPose () const { return last_good_pose_; }

  /** \brief Empties the volume and forgets the trajectory. */
  void
  reset ();

private:
  DenseReconstructionConfig config_;
  DepthPreprocessor preprocessor_;
  CameraTracker tracker_;
  TSDFVolume volume_;
  RaycastResult model_;
  RaycastHoleSkip hole_skip_;  ///< the last raycast's empty holes, for the next one
  FramePyramid frame_pyramid_;
  FramePyramid model_pyramid_;
  Eigen::Isometry3d last_good_pose_ = Eigen::Isometry3d::Identity ();
  bool initialized_ = false;
};
}  // namespace reconstruction
}  // namespace cuefusion
