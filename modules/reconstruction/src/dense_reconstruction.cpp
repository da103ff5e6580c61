#include <cuefusion/common/exceptions.h>
#include <cuefusion/reconstruction/dense_reconstruction.h>

#include <chrono>

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
}  // namespace

void
DenseReconstructionConfig::validate () const
{
  volume.validate ();
  preprocessing.validate ();
  tracking.validate ();
  if (hole_refresh_period < 1 || hole_refresh_period > 1000)
    throw ParameterError ("hole_refresh_period", "must lie in [1, 1000] frames");
  if (static_cast<std::size_t> (preprocessing.pyramid_levels) < tracking.icp.iterations.size ())
    throw ParameterError ("pyramid_levels", "must be at least the number of ICP levels");
}

DenseReconstruction::DenseReconstruction (const DenseReconstructionConfig& config)
  : config_ (config), preprocessor_ (config.preprocessing), tracker_ (config.tracking), volume_ (config.volume)
{
  config_.validate ();
}

void
DenseReconstruction::reset ()
{
  volume_.reset ();
  model_ = RaycastResult ();
  hole_skip_ = RaycastHoleSkip ();
  frame_pyramid_.clear ();
  model_pyramid_.clear ();
  last_good_pose_ = Eigen::Isometry3d::Identity ();
  initialized_ = false;
}

FrameReport
DenseReconstruction::process (const RGBDFrame& frame)
{
  FrameReport report;
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
  }
  else if (!initialized_)
  {
    report.pose = frame.pose ? *frame.pose : Eigen::Isometry3d::Identity ();
    report.tracked = true;
  }
  else
  {
    const TrackingResult tracking = tracker_.track (frame_pyramid_, model_pyramid_, model_.pose, last_good_pose_);
    report.pose = tracking.pose;
    report.tracked = tracking.tracked;
    report.failure = tracking.failure;
    report.icp = tracking.icp;
  }
  report.timings.track_ms = clock.lap ();
  if (!report.tracked)
  {
    // The next raycast may be far from the last: it searches every hole (the last
    // raycast's empty holes, which would become its skip mask, are dropped).
    model_.empty_holes.release ();
    return report;
  }

  last_good_pose_ = report.pose;
  initialized_ = true;
  volume_.integrate (frame.depth, frame.color, frame.camera, report.pose);
  report.timings.integrate_ms = clock.lap ();

  // The frame just fused tells where the surface is along each ray (see raycast()).
  // The last raycast's empty holes become this one's skip mask (two buffers, swapped).
  std::swap (hole_skip_.empty_holes, model_.empty_holes);
  if (config_.hole_refresh_period <= 1 || hole_skip_.empty_holes.size () != frame_pyramid_[0].depth.size ())
    hole_skip_.empty_holes.release ();
  hole_skip_.refresh_period = config_.hole_refresh_period;
  ++hole_skip_.phase;
  volume_.raycast (frame.camera, report.pose, frame_pyramid_[0].depth, hole_skip_, model_);
  buildModelPyramid (model_.vertices, model_.normals, model_.camera, config_.preprocessing.pyramid_levels,
                     static_cast<float> (config_.preprocessing.max_depth_jump), model_pyramid_);
  report.timings.raycast_ms = clock.lap ();
  return report;
}
}  // namespace reconstruction
}  // namespace cuefusion
