// SPDX-License-Identifier: BSD-3-Clause
#include "reconstruction_fixtures.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/evaluation/trajectory_error.h>
#include <cuefusion/simulation/synthetic_sequence.h>
#include <cuefusion/reconstruction/dense_reconstruction.h>
#include <cuefusion/reconstruction/projective_icp.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <random>
#include <stdexcept>
#include <tuple>

using namespace cuefusion;
using namespace cuefusion::reconstruction;

namespace
{
/** \a frames of \a scene's trajectory at 320×240, with Kinect noise or exact. */
simulation::SyntheticSequence
sequenceOf (const simulation::SyntheticScene& scene, std::size_t frames, bool noise)
{
  simulation::SyntheticSequenceConfig config;
  config.frames = frames;
  config.width = 320;
  config.height = 240;
  config.noise.enabled = noise;
  return simulation::SyntheticSequence (scene, config);
}

simulation::SyntheticSequence
tabletopSequence (std::size_t frames, bool noise)
{
  return sequenceOf (simulation::SyntheticScene::load (test::tabletopScenePath ()), frames, noise);
}

Eigen::Isometry3d
motion (double tx, double ty, double tz, double deg, const Eigen::Vector3d& axis)
{
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity ();
  T.linear () = Eigen::AngleAxisd (deg * M_PI / 180.0, axis.normalized ()).toRotationMatrix ();
  T.translation () = Eigen::Vector3d (tx, ty, tz);
  return T;
}

double
rotationDeg (const Eigen::Isometry3d& T)
{
  return Eigen::AngleAxisd (T.rotation ()).angle () * 180.0 / M_PI;
}
}  // namespace

class ICPRecoversMotion : public ::testing::TestWithParam<Eigen::Isometry3d>
{
};

TEST_P (ICPRecoversMotion, ToSubMillimetre)
{
  // Target: the tabletop from a pose on its orbit; source: the same scene after the camera
  // moved by the parameter. ICP from identity must find that motion.
  const simulation::SyntheticScene scene = simulation::SyntheticScene::load (test::tabletopScenePath ());
  const PinholeCamera camera = scene.camera.scaled (320, 240);
  const simulation::SceneRenderer renderer (scene);
  const Eigen::Isometry3d target_pose = scene.trajectory.poseAt (0.4);
  const Eigen::Isometry3d delta = GetParam ();
  const Eigen::Isometry3d source_pose = target_pose * delta;
  DepthPreprocessorConfig pre;
  pre.bilateral.enabled = false;  // exact depth: nothing to smooth
  const DepthPreprocessor preprocessor (pre);
  FramePyramid source, target;
  preprocessor.compute (renderer.render (camera, source_pose).depth, camera, source);
  preprocessor.compute (renderer.render (camera, target_pose).depth, camera, target);
  const ICPResult result = ProjectiveICP ().align (source, target, Eigen::Isometry3d::Identity ());
  ASSERT_TRUE (result.solved);
  const Eigen::Isometry3d error = delta.inverse () * result.transform;
  EXPECT_LT (error.translation ().norm (), 0.001);
  EXPECT_LT (rotationDeg (error), 0.1);
  EXPECT_GT (result.inliers, result.source_points / 2);
}

// Hand-held steps between two frames at 30 Hz: up to a few centimetres and degrees.
INSTANTIATE_TEST_SUITE_P (HandHeldSteps, ICPRecoversMotion,
                          ::testing::Values (motion (0.01, 0, 0, 0, Eigen::Vector3d::UnitY ()),
                                             motion (0, 0, 0.03, 0, Eigen::Vector3d::UnitY ()),
                                             motion (0, 0, 0, 2.0, Eigen::Vector3d::UnitY ()),
                                             motion (0.02, -0.01, 0.01, 1.5, Eigen::Vector3d (1, 2, 0.5)),
                                             motion (-0.015, 0.02, -0.02, 3.0, Eigen::Vector3d (0.3, -1, 0.2))));

TEST (DenseReconstruction, TracksASyntheticSequenceToMillimetres)
{
  const simulation::SyntheticSequence sequence = tabletopSequence (100, true);
  DenseReconstruction fusion;
  io::Trajectory estimate, reference;
  for (std::size_t i = 0; i < sequence.size (); ++i)
  {
    const RGBDFrame::Ptr frame = sequence.frame (i);
    const FrameReport report = fusion.process (*frame);
    ASSERT_TRUE (report.tracked) << "frame " << i << ": " << report.failure;
    estimate.push_back ({frame->timestamp, report.pose});
    reference.push_back ({frame->timestamp, *frame->pose});
  }
  const evaluation::TrajectoryError ate = evaluation::absoluteTrajectoryError (estimate, reference);
  EXPECT_EQ (ate.pairs, 100u);
  EXPECT_LT (ate.rmse, 0.005);
  // The model raycast at the last pose covers the view.
  EXPECT_GT (cv::countNonZero (fusion.model ().depth ()), 320 * 240 / 2);
}

TEST (DenseReconstruction, DetectsAGarbageFrameAndRecovers)
{
  const simulation::SyntheticSequence sequence = tabletopSequence (30, false);
  DenseReconstruction fusion;
  std::mt19937 rng (7);
  std::uniform_real_distribution<float> depth (0.5f, 4.0f);
  io::Trajectory estimate, reference;
  for (std::size_t i = 0; i < sequence.size (); ++i)
  {
    const RGBDFrame::Ptr frame = sequence.frame (i);
    if (i == 15)
      for (auto it = frame->depth.begin<float> (); it != frame->depth.end<float> (); ++it)
        *it = depth (rng);
    const Eigen::Isometry3d before = fusion.lastGoodPose ();
    const std::size_t blocks = fusion.volume ().blockCount ();
    const FrameReport report = fusion.process (*frame);
    if (i == 15)
    {
      EXPECT_FALSE (report.tracked);
      EXPECT_FALSE (report.failure.empty ());
      EXPECT_TRUE (report.pose.isApprox (before));       // kept the last good pose
      EXPECT_EQ (fusion.volume ().blockCount (), blocks);  // and fused nothing
      // The next raycast searches every hole: no skip mask from before the failure.
      EXPECT_TRUE (fusion.model ().empty_holes.empty ());
      continue;
    }
    EXPECT_FALSE (fusion.model ().empty_holes.empty ()) << "frame " << i << ": the hinted raycast marks its empty holes";
    ASSERT_TRUE (report.tracked) << "frame " << i << ": " << report.failure;
    estimate.push_back ({frame->timestamp, report.pose});
    reference.push_back ({frame->timestamp, *frame->pose});
  }
  EXPECT_LT (evaluation::absoluteTrajectoryError (estimate, reference).rmse, 0.005);
}

namespace
{
/** Bytes of \a m equal to \a n's (NaN normals compare equal to NaN). */
bool
sameBytes (const cv::Mat& m, const cv::Mat& n)
{
  if (m.size () != n.size () || m.type () != n.type () || !m.isContinuous () || !n.isContinuous ())
    return false;
  return std::equal (m.datastart, m.dataend, n.datastart);
}
}  // namespace

TEST (DenseReconstruction, WorkAlongsideSeesTheFramesPyramidAndChangesNothing)
{
  // Frame 6 is garbage (lost): the work alongside runs for it too, and is joined.
  const simulation::SyntheticSequence sequence = tabletopSequence (12, true);
  DenseReconstruction plain, with_work;
  std::mt19937 rng (11);
  std::uniform_real_distribution<float> garbage (0.5f, 4.0f);
  for (std::size_t i = 0; i < sequence.size (); ++i)
  {
    const RGBDFrame::Ptr frame = sequence.frame (i);
    if (i == 6)
      for (auto it = frame->depth.begin<float> (); it != frame->depth.end<float> (); ++it)
        *it = garbage (rng);
    int calls = 0;
    cv::Mat depth, normals;
    const FrameReport a = plain.process (*frame);
    const FrameReport b = with_work.process (*frame, [&] {
      ++calls;
      const PyramidLevel& level = with_work.sharedMaps ().frame;
      depth = level.depth.clone ();
      normals = level.normals.clone ();
    });
    EXPECT_EQ (calls, 1) << "frame " << i;
    EXPECT_EQ (a.tracked, i != 6) << "frame " << i;
    EXPECT_EQ (b.tracked, a.tracked) << "frame " << i;
    EXPECT_TRUE (b.pose.isApprox (a.pose, 0.0)) << "frame " << i;  // bit for bit
    EXPECT_TRUE (sameBytes (depth, with_work.framePyramid ().front ().depth)) << "frame " << i;
    EXPECT_TRUE (sameBytes (normals, with_work.framePyramid ().front ().normals)) << "frame " << i;
    if (b.tracked)
    {
      EXPECT_TRUE (sameBytes (with_work.model ().depth (), plain.model ().depth ())) << "frame " << i;
    }
  }
  EXPECT_EQ (with_work.volume ().blockCount (), plain.volume ().blockCount ());
}

TEST (DenseReconstruction, AnErrorOfTheWorkAlongsideComesOutOfProcess)
{
  const simulation::SyntheticSequence sequence = tabletopSequence (30, false);  // steps a hand-held camera makes
  DenseReconstruction fusion;
  fusion.process (*sequence.frame (0));
  EXPECT_THROW (fusion.process (*sequence.frame (1), [] { throw std::runtime_error ("alongside"); }), std::runtime_error);
  // The frame itself was processed; the next one is tracked as usual.
  const FrameReport next = fusion.process (*sequence.frame (2), [] {});
  EXPECT_TRUE (next.tracked) << next.failure;
  EXPECT_LT ((next.pose.translation () - sequence.frame (2)->pose->translation ()).norm (), 0.005);
}

TEST (DenseReconstruction, ReferencePosesModeFusesWithTheFramesPoses)
{
  const simulation::SyntheticSequence sequence = tabletopSequence (5, false);
  DenseReconstructionConfig config;
  config.use_reference_poses = true;
  DenseReconstruction fusion (config);
  for (std::size_t i = 0; i < sequence.size (); ++i)
  {
    const RGBDFrame::Ptr frame = sequence.frame (i);
    const FrameReport report = fusion.process (*frame);
    EXPECT_TRUE (report.tracked);
    EXPECT_TRUE (report.pose.isApprox (*frame->pose));
  }
  RGBDFrame::Ptr no_pose = sequence.frame (0);
  no_pose->pose.reset ();
  const FrameReport report = fusion.process (*no_pose);
  EXPECT_FALSE (report.tracked);
  EXPECT_EQ (report.failure, "no reference pose");
}

TEST (DenseReconstruction, TheTruncationIsSetOnlyWhileNothingIsFused)
{
  // The volume keeps its distances in truncation units: a new truncation applies to an empty
  // volume (FusionPipeline's follows the noise measured on the first frame) and is refused
  // once a frame is fused; a value out of range is an error naming the field.
  const simulation::SyntheticSequence sequence = tabletopSequence (2, false);
  DenseReconstruction fusion;
  fusion.volume ().setRecordObservedSurface (true);
  EXPECT_THROW (fusion.setTruncation (0.5), ParameterError);
  ASSERT_TRUE (fusion.setTruncation (7.5));
  EXPECT_EQ (fusion.volume ().getConfig ().truncation_voxels, 7.5);
  EXPECT_EQ (fusion.getConfig ().volume.truncation_voxels, 7.5);
  EXPECT_TRUE (fusion.volume ().getRecordObservedSurface ());
  const FrameReport report = fusion.process (*sequence.frame (0));
  ASSERT_TRUE (report.tracked);
  // The band the frame reached is 7.5 voxels deep: voxels 6 voxels and more from the surface
  // along their pixel's ray, as the default 4 would not reach.
  const double voxel = fusion.volume ().getConfig ().voxel_size;
  double deepest = 0.0;
  for (const std::vector<SurfaceObservation>& part : fusion.volume ().lastObservedSurface ())
    for (const SurfaceObservation& o : part)
      deepest = std::max (deepest, static_cast<double> (o.gap));
  EXPECT_GT (deepest, 6.0 * voxel);
  EXPECT_LT (deepest, 7.5 * voxel);
  EXPECT_FALSE (fusion.setTruncation (4.0));
  EXPECT_EQ (fusion.volume ().getConfig ().truncation_voxels, 7.5);
}

TEST (TrajectoryError, AlignsARigidlyMovedCopyExactly)
{
  io::Trajectory reference, moved;
  const Eigen::Isometry3d offset = motion (1.0, -2.0, 0.5, 40.0, Eigen::Vector3d (1, 1, 0));
  for (int i = 0; i < 20; ++i)
  {
    Eigen::Isometry3d pose = motion (0.1 * i, std::sin (0.3 * i), 0.02 * i * i, 3.0 * i, Eigen::Vector3d::UnitZ ());
    reference.push_back ({0.1 * i, pose});
    moved.push_back ({0.1 * i + 0.001, offset * pose});
  }
  EXPECT_LT (evaluation::absoluteTrajectoryError (moved, reference).rmse, 1e-9);
  // Without alignment the offset shows; with one pose 10 cm off the RMSE is 10 cm / √20.
  EXPECT_GT (evaluation::absoluteTrajectoryError (moved, reference, 0.02, false).rmse, 0.5);
  moved = reference;
  moved[7].pose.translation ().x () += 0.1;
  const double rmse = evaluation::absoluteTrajectoryError (moved, reference, 0.02, false).rmse;
  EXPECT_NEAR (rmse, 0.1 / std::sqrt (20.0), 1e-9);
  test::expectError ([&] { evaluation::absoluteTrajectoryError (moved, io::Trajectory ()); }, "absoluteTrajectoryError",
                     "fewer than three");
}

TEST (DenseReconstruction, MemoryDoesNotGrowWithSequenceLength)
{
  // The same orbit rendered as 10 and as 40 frames covers the same surface: the volume
  // must hold about the same blocks. Played a second time, the 40 frames add none.
  const auto blocksAfter = [] (std::size_t frames, int passes) {
    const simulation::SyntheticSequence sequence = tabletopSequence (frames, true);
    DenseReconstructionConfig config;
    config.use_reference_poses = true;
    DenseReconstruction fusion (config);
    std::vector<std::size_t> counts;
    for (int pass = 0; pass < passes; ++pass)
    {
      for (std::size_t i = 0; i < sequence.size (); ++i)
        EXPECT_TRUE (fusion.process (*sequence.frame (i)).tracked);
      counts.push_back (fusion.volume ().blockCount ());
    }
    return counts;
  };
  const std::size_t short_run = blocksAfter (10, 1).front ();
  const std::vector<std::size_t> long_run = blocksAfter (40, 2);
  EXPECT_LE (static_cast<double> (long_run[0]), 1.05 * static_cast<double> (short_run));
  EXPECT_GE (static_cast<double> (long_run[0]), static_cast<double> (short_run));
  EXPECT_EQ (long_run[1], long_run[0]);
}

namespace
{
/** Runs \a fusion over the frames of \a sequence listed in \a order; per processed frame
  * its report and its position error against the exact pose (metres). */
struct Processed
{
  std::size_t frame;
  FrameReport report;
  double error;
};

std::vector<Processed>
processInOrder (DenseReconstruction& fusion, const simulation::SyntheticSequence& sequence, const std::vector<std::size_t>& order,
                const std::function<void (std::size_t, RGBDFrame&)>& change = nullptr)
{
  std::vector<Processed> out;
  for (const std::size_t i : order)
  {
    const RGBDFrame::Ptr frame = sequence.frame (i);
    if (change)
      change (i, *frame);
    const FrameReport report = fusion.process (*frame);
    out.push_back ({i, report, (report.pose.translation () - frame->pose->translation ()).norm ()});
  }
  return out;
}

std::vector<std::size_t>
frameRange (std::size_t begin, std::size_t end)
{
  std::vector<std::size_t> r;
  for (std::size_t i = begin; i < end; ++i)
    r.push_back (i);
  return r;
}

/** No frame reported tracked is more than 5 cm off; RMSE of the tracked frames. */
double
trackedRmse (const std::vector<Processed>& run)
{
  double sum = 0.0;
  std::size_t n = 0;
  for (const Processed& p : run)
    if (p.report.tracked)
    {
      EXPECT_LT (p.error, 0.05) << "frame " << p.frame << " reported tracked " << p.error * 100.0 << " cm off";
      sum += p.error * p.error;
      ++n;
    }
  return n ? std::sqrt (sum / static_cast<double> (n)) : 0.0;
}
}  // namespace

TEST (Relocalisation, AfterAGapOfDroppedFrames)
{
  // 19 frames missing: the camera jumps 31 cm and 14° between two processed frames, more
  // than one frame's plausible motion; ICP still finds the pose, which is verified.
  const simulation::SyntheticSequence sequence = tabletopSequence (120, true);
  DenseReconstruction fusion;
  std::vector<std::size_t> order = frameRange (0, 50);
  const std::vector<std::size_t> after = frameRange (69, 120);
  order.insert (order.end (), after.begin (), after.end ());
  const std::vector<Processed> run = processInOrder (fusion, sequence, order);
  EXPECT_LT (trackedRmse (run), 0.01);
  std::size_t tracked_after = 0, relocalised = 0;
  for (std::size_t k = 50; k < run.size (); ++k)
  {
    tracked_after += run[k].report.tracked ? 1 : 0;
    relocalised += run[k].report.relocalised ? 1 : 0;
  }
  // The first frame after the gap is placed (the motion carried across the dropped
  // frames' time, or a relocalisation), and every later one.
  EXPECT_TRUE (run[50].report.tracked) << run[50].report.failure;
  EXPECT_GE (tracked_after + relocalised, after.size ());
  for (std::size_t k = 55; k < run.size (); ++k)
    EXPECT_TRUE (run[k].report.tracked) << "frame " << run[k].frame << ": " << run[k].report.failure;
}

TEST (Relocalisation, FromAKeyframeWhenTheViewReturns)
{
  // Frames 0–79, then the camera is back at frame 10 (a jump of ~0.5 m and 40°): ICP from
  // the last pose cannot converge; the keyframe database knows the view (its pose, or its
  // features matched to the frame's).
  const simulation::SyntheticSequence sequence = tabletopSequence (120, true);
  DenseReconstruction fusion;
  std::vector<std::size_t> order = frameRange (0, 80);
  const std::vector<std::size_t> back = frameRange (10, 40);
  order.insert (order.end (), back.begin (), back.end ());
  const std::vector<Processed> run = processInOrder (fusion, sequence, order);
  EXPECT_GT (fusion.keyframes ().size (), 1u);
  EXPECT_LT (trackedRmse (run), 0.01);
  bool from_keyframe = false;
  for (std::size_t k = 80; k < run.size (); ++k)
  {
    const std::string& from = run[k].report.relocalised_from;
    from_keyframe = from_keyframe || from.rfind ("keyframe", 0) == 0 || from.rfind ("features (keyframe", 0) == 0;
  }
  EXPECT_TRUE (from_keyframe);
  for (std::size_t k = 85; k < run.size (); ++k)
    EXPECT_TRUE (run[k].report.tracked) << "frame " << run[k].frame << ": " << run[k].report.failure;
}

TEST (Relocalisation, AfterADepthBlackout)
{
  // Frames 50–59 have no depth (a covered sensor) while the camera moves on.
  const simulation::SyntheticSequence sequence = tabletopSequence (120, true);
  DenseReconstruction fusion;
  std::size_t blocks_before = 0;
  const std::vector<Processed> run = processInOrder (fusion, sequence, frameRange (0, 120), [&] (std::size_t i, RGBDFrame& frame) {
    if (i >= 50 && i < 60)
      frame.depth.setTo (0.f);
    if (i == 50)
      blocks_before = fusion.volume ().blockCount ();
  });
  for (std::size_t k = 50; k < 60; ++k)
  {
    EXPECT_FALSE (run[k].report.tracked);
    EXPECT_NE (run[k].report.failure.find ("valid depth"), std::string::npos) << run[k].report.failure;
  }
  EXPECT_LT (trackedRmse (run), 0.01);
  for (std::size_t k = 65; k < run.size (); ++k)
    EXPECT_TRUE (run[k].report.tracked) << "frame " << run[k].frame << ": " << run[k].report.failure;
  EXPECT_GT (fusion.volume ().blockCount (), blocks_before);  // fusing again after it
}

TEST (Relocalisation, KeyframeDatabaseFindsTheNearestView)
{
  const simulation::SyntheticSequence sequence = tabletopSequence (60, true);
  KeyframeDatabaseConfig config;
  config.min_novelty = 0.0;  // store every view offered, unless its code is identical
  KeyframeDatabase database (config);
  for (std::size_t i = 0; i < 60; i += 10)
    EXPECT_TRUE (database.addIfNovel (database.encode (sequence.frame (i)->depth), *sequence.frame (i)->pose)) << i;
  // A view near a keyframe finds it first; views further away are less similar.
  const auto matches = database.query (database.encode (sequence.frame (31)->depth), 6);
  ASSERT_EQ (matches.size (), 6u);
  EXPECT_EQ (matches[0].keyframe, 3u);  // frame 30
  EXPECT_TRUE (matches[0].pose.isApprox (*sequence.frame (30)->pose));
  for (std::size_t k = 1; k < matches.size (); ++k)
    EXPECT_LE (matches[k - 1].dissimilarity, matches[k].dissimilarity);
  EXPECT_LT (matches[0].dissimilarity, 0.5 * matches[5].dissimilarity);
  // With a novelty threshold, the same view is not stored twice.
  config.min_novelty = 0.2;
  KeyframeDatabase strict (config);
  EXPECT_TRUE (strict.addIfNovel (strict.encode (sequence.frame (20)->depth), *sequence.frame (20)->pose));
  EXPECT_FALSE (strict.addIfNovel (strict.encode (sequence.frame (20)->depth), *sequence.frame (20)->pose));
  EXPECT_EQ (strict.size (), 1u);
  // No depth at all: every test fails, the code is all zeros.
  const KeyframeDatabase::Code blank = database.encode (cv::Mat::zeros (240, 320, CV_32F));
  EXPECT_EQ (std::count (blank.begin (), blank.end (), 0), static_cast<long> (blank.size ()));
  config.decisions = 9;
  EXPECT_THROW (KeyframeDatabase{config}, ParameterError);
}

TEST (Relocalisation, APlanarViewIsLostNotFused)
{
  // A camera sliding along a flat wall 1 m away: the wall fixes the distance and two
  // rotations, nothing else (ICP's system is rank 3). The first frame starts the map; the
  // frames after it must be reported lost, not fused at some guess.
  const PinholeCamera camera (262.5, 262.5, 159.5, 119.5, 320, 240);
  DenseReconstruction fusion;
  for (int i = 0; i < 6; ++i)
  {
    RGBDFrame frame;
    frame.index = static_cast<std::size_t> (i);
    frame.timestamp = i / 30.0;
    frame.camera = camera;
    frame.depth = cv::Mat (240, 320, CV_32F, cv::Scalar (1.f));
    frame.color = cv::Mat (240, 320, CV_8UC3, cv::Scalar (120, 120, 120));
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();
    pose.translation () = Eigen::Vector3d (0.02 * i, 0.0, 0.0);
    frame.pose = pose;
    const std::size_t blocks = fusion.volume ().blockCount ();
    const FrameReport report = fusion.process (frame);
    if (i == 0)
    {
      EXPECT_TRUE (report.tracked);
      continue;
    }
    EXPECT_FALSE (report.tracked) << "frame " << i;
    EXPECT_NE (report.failure.find ("degenerate"), std::string::npos) << report.failure;
    EXPECT_FALSE (report.relocalised);
    EXPECT_EQ (fusion.volume ().blockCount (), blocks) << "frame " << i << " was fused";
  }
}

TEST (Relocalisation, ANoisyFloorAloneIsLostNotFused)
{
  // A camera circling 1.2 m above a plain floor, with Kinect noise: the noisy normals
  // make ICP's system full rank, but the floor leaves two translations free (tracking
  // it drifted 52 cm in 30 frames, reported tracked, before the conditioning check).
  const simulation::SyntheticSequence sequence = sequenceOf (
    simulation::SyntheticScene::parse ("scene floor\ncamera 640 480 525 525 319.5 239.5\n"
                               "trajectory target=0,0,0 radius=0.6 height=1.2 start=0 sweep=20 bob=0.0\n"
                               "object floor class=floor color=170,165,150 detectable=no texture=checker\n"
                               "  box center=0,0,-0.01 size=12,12,0.02\n",
                               "floor scene"),
    10, true);
  DenseReconstruction fusion;
  for (std::size_t i = 0; i < sequence.size (); ++i)
  {
    const std::size_t blocks = fusion.volume ().blockCount ();
    const FrameReport report = fusion.process (*sequence.frame (i));
    if (i == 0)
    {
      EXPECT_TRUE (report.tracked);
      continue;
    }
    EXPECT_FALSE (report.tracked) << "frame " << i;
    EXPECT_NE (report.failure.find ("degenerate"), std::string::npos) << report.failure;
    EXPECT_FALSE (report.relocalised) << "frame " << i;
    EXPECT_EQ (fusion.volume ().blockCount (), blocks) << "frame " << i << " was fused";
  }
}

namespace
{
/** Frames of \a sequence tracked by a DenseReconstruction with \a config, and the RMS
  * position error of those (exact poses). */
std::pair<std::size_t, double>
trackSequence (const simulation::SyntheticSequence& sequence, const DenseReconstructionConfig& config)
{
  DenseReconstruction fusion (config);
  const std::vector<Processed> run = processInOrder (fusion, sequence, frameRange (0, sequence.size ()));
  std::size_t tracked = 0;
  for (const Processed& p : run)
    tracked += p.report.tracked ? 1 : 0;
  return {tracked, trackedRmse (run)};
}
}  // namespace

TEST (MotionModel, AFastOrbitIsTrackedFromTheConstantVelocityPrediction)
{
  // The tabletop orbit in 11 frames: ~18 cm and 8° per frame, more than ICP converges
  // over from the last pose (12 frames, 7°, converge since the normal gate follows the
  // noise and the plausibility check the agreement).
  const simulation::SyntheticSequence sequence = tabletopSequence (11, true);
  DenseReconstructionConfig config;
  config.tracking.icp.noise_weighting = false;  // the prediction alone
  config.motion_model = false;
  config.relocalise = false;  // ICP from the last pose alone (relocalisation places some of these frames)
  const auto still = trackSequence (sequence, config);
  EXPECT_LT (still.first, 12u) << "the case is not fast enough to need the prediction";
  config.motion_model = true;
  const auto predicted = trackSequence (sequence, config);
  EXPECT_EQ (predicted.first, 11u);
  EXPECT_LT (predicted.second, 0.005);
}

TEST (NoiseWeighting, FarPointsPullLessThanNearOnes)
{
  // The tabletop seen twice from one pose; in the source frame every depth beyond 2 m is
  // 1.5 % too long (a real sensor's range-dependent error, which its noise model says
  // to trust less there). ICP from the true motion (identity) is pulled by the far
  // points; weighted by the inverse noise variance, the near table keeps it in place.
  const simulation::SyntheticScene scene = simulation::SyntheticScene::load (test::tabletopScenePath ());
  const PinholeCamera camera = scene.camera.scaled (320, 240);
  const simulation::SceneRenderer renderer (scene);
  const Eigen::Isometry3d pose = scene.trajectory.poseAt (0.4);
  DepthPreprocessorConfig pre;
  pre.bilateral.enabled = false;
  const DepthPreprocessor preprocessor (pre);
  const cv::Mat depth = renderer.render (camera, pose).depth;
  cv::Mat biased = depth.clone ();
  int far = 0, valid = 0;
  for (int y = 0; y < biased.rows; ++y)
    for (int x = 0; x < biased.cols; ++x)
    {
      float& z = biased.at<float> (y, x);
      valid += z > 0.f ? 1 : 0;
      if (z > 2.f)
      {
        z *= 1.015f;
        ++far;
      }
    }
  ASSERT_GT (far, valid / 5) << "the view needs a far part";
  FramePyramid source, target;
  preprocessor.compute (biased, camera, source);
  preprocessor.compute (depth, camera, target);
  auto error_mm = [&] (bool weighted) {
    ProjectiveICPConfig config;
    config.noise_weighting = weighted;
    const ICPResult result = ProjectiveICP (config).align (source, target, Eigen::Isometry3d::Identity ());
    EXPECT_TRUE (result.solved);
    return 1000.0 * result.transform.translation ().norm ();
  };
  const double plain = error_mm (false), weighted = error_mm (true);
  EXPECT_LT (weighted, 0.5 * plain) << "plain " << plain << " mm, weighted " << weighted << " mm";
}

TEST (NoiseWeighting, TracksAGeneratedNoisySequenceAsAccurately)
{
  // On the generator's zero-mean noise both estimates are unbiased: weighting must not
  // make tracking worse than the millimetre it reaches without.
  const simulation::SyntheticSequence sequence = tabletopSequence (40, true);
  DenseReconstructionConfig config;
  const auto weighted = trackSequence (sequence, config);
  EXPECT_EQ (weighted.first, 40u);
  EXPECT_LT (weighted.second, 0.002);
}

namespace
{
/** Frames [begin, end) of \a sequence without their poses: a continued run must find them. */
std::vector<Processed>
processWithoutPoses (DenseReconstruction& fusion, const simulation::SyntheticSequence& sequence, std::size_t begin, std::size_t end)
{
  std::vector<Processed> out;
  for (std::size_t i = begin; i < end; ++i)
  {
    const RGBDFrame::Ptr frame = sequence.frame (i);
    const Eigen::Isometry3d truth = *frame->pose;
    frame->pose.reset ();
    const FrameReport report = fusion.process (*frame);
    out.push_back ({i, report, (report.pose.translation () - truth.translation ()).norm ()});
  }
  return out;
}

/** A reconstruction of frames [0, frames) of \a sequence, saved to \a dir as `run
  * --save-volume` does: volume.tsdf and volume.keyframes (with the last fused frame). */
void
saveFirstFrames (const simulation::SyntheticSequence& sequence, std::size_t frames, const test::TempDir& dir)
{
  DenseReconstruction fusion;
  const std::vector<Processed> run = processInOrder (fusion, sequence, frameRange (0, frames));
  EXPECT_LT (trackedRmse (run), 0.01);
  fusion.volume ().save (dir / "volume.tsdf");
  fusion.keyframesForContinuing ().save (dir / "volume.keyframes", fusion.volume ());
}
}  // namespace

TEST (ContinueVolume, TheFirstFrameIsRelocalisedWhereTheLastRunStopped)
{
  // Frames 0–29 saved; a new run continues with frames 30–49 without their poses (a
  // camera switched off and on again where it stopped: 3 cm and 1.4° from the last frame).
  const simulation::SyntheticSequence sequence = tabletopSequence (50, true);
  const test::TempDir dir;
  saveFirstFrames (sequence, 30, dir);
  TSDFVolume volume = TSDFVolume::load (dir / "volume.tsdf");
  const KeyframeDatabase keyframes = KeyframeDatabase::load (dir / "volume.keyframes", volume);
  ASSERT_GE (keyframes.size (), 2u);
  DenseReconstruction fusion;
  fusion.continueFrom (std::move (volume), keyframes);
  EXPECT_TRUE (fusion.awaitingPlacement ());
  const std::size_t blocks_loaded = fusion.volume ().blockCount ();
  EXPECT_GT (blocks_loaded, 100u);
  const std::vector<Processed> run = processWithoutPoses (fusion, sequence, 30, 50);
  ASSERT_TRUE (run[0].report.relocalised) << run[0].report.failure;
  EXPECT_EQ (run[0].report.relocalised_from, "keyframe " + std::to_string (keyframes.size () - 1));  // the last frame
  EXPECT_LT (run[0].error, 0.01);  // in the saved volume's frame, without any alignment
  for (const Processed& p : run)
    EXPECT_TRUE (p.report.tracked) << "frame " << p.frame << ": " << p.report.failure;
  EXPECT_LT (trackedRmse (run), 0.01);
  EXPECT_FALSE (fusion.awaitingPlacement ());
  EXPECT_GT (fusion.volume ().blockCount (), blocks_loaded);  // the new frames see more of the table
}

TEST (ContinueVolume, TheSequencesOwnPoseIsTriedFirst)
{
  const simulation::SyntheticSequence sequence = tabletopSequence (40, true);
  const test::TempDir dir;
  saveFirstFrames (sequence, 20, dir);
  DenseReconstruction fusion;
  fusion.continueFrom (TSDFVolume::load (dir / "volume.tsdf"), KeyframeDatabase ());  // no keyframes at all
  const std::vector<Processed> run = processInOrder (fusion, sequence, frameRange (25, 35));
  ASSERT_TRUE (run[0].report.relocalised) << run[0].report.failure;
  EXPECT_EQ (run[0].report.relocalised_from, "reference pose");
  EXPECT_LT (trackedRmse (run), 0.01);
}

TEST (ContinueVolume, AViewTheSavedRunNeverSawIsLostAndNothingIsFused)
{
  // The saved run saw frames 0–9; the continued one starts 70 frames (≈ 95°) further on
  // the orbit, without a pose: no keyframe is near, so no candidate passes ICP's check.
  const simulation::SyntheticSequence sequence = tabletopSequence (85, true);
  const test::TempDir dir;
  saveFirstFrames (sequence, 10, dir);
  DenseReconstruction fusion;
  TSDFVolume volume = TSDFVolume::load (dir / "volume.tsdf");
  KeyframeDatabase keyframes = KeyframeDatabase::load (dir / "volume.keyframes", volume);
  fusion.continueFrom (std::move (volume), std::move (keyframes));
  const std::size_t blocks_loaded = fusion.volume ().blockCount ();
  const std::vector<Processed> run = processWithoutPoses (fusion, sequence, 80, 85);
  for (const Processed& p : run)
  {
    EXPECT_FALSE (p.report.tracked) << "frame " << p.frame << " placed " << p.error * 100.0 << " cm off";
    EXPECT_NE (p.report.failure.find ("loaded volume"), std::string::npos) << p.report.failure;
  }
  EXPECT_EQ (fusion.volume ().blockCount (), blocks_loaded);
  EXPECT_TRUE (fusion.awaitingPlacement ());
}

TEST (ContinueVolume, KeyframeFilesReadBackExactlyAndBadOnesAreRefused)
{
  const simulation::SyntheticSequence sequence = tabletopSequence (40, true);
  KeyframeDatabaseConfig config;
  config.min_novelty = 0.0;
  config.ferns = 300;
  config.decisions = 5;
  KeyframeDatabase database (config);
  for (std::size_t i = 0; i < 40; i += 8)
    database.add (database.encode (sequence.frame (i)->depth), *sequence.frame (i)->pose);
  const test::TempDir dir;
  const std::string path = dir / "k.keyframes";
  const TSDFVolume volume;  // an empty volume names itself too (voxel size, no blocks)
  database.save (path, volume);
  const KeyframeDatabase loaded = KeyframeDatabase::load (path, volume);
  ASSERT_EQ (loaded.size (), database.size ());
  EXPECT_EQ (loaded.getConfig ().ferns, 300);
  EXPECT_EQ (loaded.getConfig ().decisions, 5);
  // Same tests (the codes agree) and the same keyframes (the queries agree, poses exactly).
  const cv::Mat probe = sequence.frame (17)->depth;
  EXPECT_EQ (loaded.encode (probe), database.encode (probe));
  const auto a = database.query (database.encode (probe), 5), b = loaded.query (loaded.encode (probe), 5);
  ASSERT_EQ (a.size (), b.size ());
  for (std::size_t k = 0; k < a.size (); ++k)
  {
    EXPECT_EQ (a[k].keyframe, b[k].keyframe);
    EXPECT_EQ (a[k].dissimilarity, b[k].dissimilarity);
    EXPECT_TRUE (a[k].pose.matrix () == b[k].pose.matrix ());
  }

  // Every damage gives one Error naming the file: truncation anywhere, trailing bytes, a
  // wrong magic, version or configuration, a test outside the grid, a bent pose, a code
  // with more bits than decisions.
  std::ifstream in (path, std::ios::binary);
  const std::string bytes ((std::istreambuf_iterator<char> (in)), std::istreambuf_iterator<char> ());
  const auto refused = [&] (const std::string& content, const std::string& what) {
    const std::string bad = dir / "bad.keyframes";
    std::ofstream (bad, std::ios::binary) << content;
    try
    {
      KeyframeDatabase::load (bad, volume);
      ADD_FAILURE () << what << ": loaded";
    }
    catch (const Error& e)
    {
      EXPECT_NE (std::string (e.what ()).find (bad), std::string::npos) << what << ": " << e.what ();
    }
  };
  for (std::size_t cut = 0; cut < bytes.size (); cut += 97)
    refused (bytes.substr (0, cut), "cut at " + std::to_string (cut));
  refused (bytes + "x", "trailing byte");
  const auto patched = [&] (std::size_t offset, const void* value, std::size_t size) {
    std::string b = bytes;
    b.replace (offset, size, static_cast<const char*> (value), size);
    return b;
  };
  const std::uint32_t version = 99;
  const std::int32_t no_ferns = 0, far_cell = 1000;
  const double bent = 2.0;
  const std::uint8_t wide = 0xff;
  const std::size_t header = 8 + 4 + 16 + 16 + 8 + 4 + 8 + 16, tests = 300 * 5 * 12;
  refused ("not a keyframe file at all, just text long enough to fill a header.....", "magic");
  refused (patched (8, &version, 4), "version");
  refused (patched (12, &no_ferns, 4), "ferns");
  refused (patched (header, &far_cell, 4), "test cell");
  refused (patched (header + tests, &bent, 8), "pose");
  refused (patched (header + tests + 96 + 3, &wide, 1), "code");
  EXPECT_THROW (KeyframeDatabase::load (dir / "missing.keyframes", volume), Error);

  // Keyframes belong to the volume they were saved with: their poses are in its frame.
  TSDFVolumeConfig coarse;
  coarse.voxel_size = 0.02;
  test::expectError ([&] { KeyframeDatabase::load (path, TSDFVolume (coarse)); }, path,
                     "saved with a volume of 0.01 m voxels, its volume has 0.02 m");
  for (const std::size_t frame : {0, 20})  // another run's map: same voxel size, other blocks
  {
    DenseReconstruction run;
    processInOrder (run, sequence, frameRange (frame, frame + 1));
    const TSDFVolume& other = run.volume ();
    ASSERT_GT (other.blockCount (), 0u);
    test::expectError ([&] { KeyframeDatabase::load (path, other); }, path, "saved with another volume");
    database.save (path, other);
    EXPECT_EQ (KeyframeDatabase::load (path, other).size (), database.size ());
    EXPECT_NE (TSDFVolume ().fingerprint (), other.fingerprint ());
  }
}

namespace
{
/** \a scene's orbit in \a frames frames at \a width × 3/4 of it with Kinect noise drawn
  * from \a seed. */
simulation::SyntheticSequence
noisyOrbit (const simulation::SyntheticScene& scene, std::size_t frames, std::uint64_t seed, int width = 320)
{
  simulation::SyntheticSequenceConfig config;
  config.frames = frames;
  config.width = width;
  config.height = width * 3 / 4;
  config.noise.enabled = true;
  config.seed = seed;
  return simulation::SyntheticSequence (scene, config);
}

simulation::SyntheticSequence
noisyOrbit (const std::string& scene, std::size_t frames, std::uint64_t seed)
{
  return noisyOrbit (simulation::SyntheticScene::load (std::string (CUEFUSION_TEST_DATA_DIR) + "/scenes/" + scene + ".scene"), frames,
                     seed);
}

/** \a scene (a bundled scene's name) with every object printed (test::printedSceneText). */
simulation::SyntheticScene
printedScene (const std::string& scene)
{
  return simulation::SyntheticScene::parse (
    test::printedSceneText (std::string (CUEFUSION_TEST_DATA_DIR) + "/scenes/" + scene + ".scene"), scene + " printed");
}

/** Of the frames of \a run from position \a from on: the share tracked. */
double
trackedShareFrom (const std::vector<Processed>& run, std::size_t from)
{
  std::size_t tracked = 0;
  for (std::size_t k = from; k < run.size (); ++k)
    tracked += run[k].report.tracked ? 1 : 0;
  return run.size () > from ? static_cast<double> (tracked) / static_cast<double> (run.size () - from) : 0.0;
}

/** \a sequence's frames 0–5 and from 6 + \a gap on (a jump: the frames between cut out)
  * through a DenseReconstruction of \a config with the motion not carried across the cut
  * (max_prediction_gap 0: a jump the motion model cannot foresee). */
std::vector<Processed>
jumpOverCut (const simulation::SyntheticSequence& sequence, std::size_t gap, DenseReconstructionConfig config)
{
  std::vector<std::size_t> order = frameRange (0, 6);
  const std::vector<std::size_t> after = frameRange (6 + gap, sequence.size ());
  order.insert (order.end (), after.begin (), after.end ());
  config.max_prediction_gap = 0.0;
  DenseReconstruction fusion (config);
  return processInOrder (fusion, sequence, order);
}

/** A jump relocalised by features: ≥ 90 % of the frames after it tracked, the tracked
  * frames within 5 mm (RMSE), the first frame placed after it placed by features. */
void
expectRelocalisedByFeatures (const std::vector<Processed>& run)
{
  EXPECT_GE (trackedShareFrom (run, 6), 0.9);
  EXPECT_LT (trackedRmse (run), 0.005);
  const auto first = std::find_if (run.begin () + 6, run.end (), [] (const Processed& p) { return p.report.relocalised; });
  ASSERT_NE (first, run.end ());
  EXPECT_EQ (first->report.relocalised_from.rfind ("features", 0), 0u) << first->report.relocalised_from;
}

/** A generated orbit with a gap in it: \a gap frames blank or cut. */
struct OrbitGap
{
  const char* scene;
  std::size_t frames, gap;
  std::uint64_t seed;
};
}  // namespace

TEST (MotionModel, ABlackoutIsBridgedByThePrediction)
{
  // Orbits of 1.5–1.75° a frame; the depth goes blank for 10 or 25 frames (a hand over the
  // lens, 15–44° of orbit) while the camera keeps its speed. No keyframe lies ahead of the
  // camera: the motion carried through the gap finds it (before: every later frame lost).
  for (const OrbitGap& c : {OrbitGap{"tabletop", 54, 10, 1}, OrbitGap{"clutter", 40, 25, 2}})
  {
    SCOPED_TRACE (std::string (c.scene) + ", " + std::to_string (c.gap) + " frames blank");
    const simulation::SyntheticSequence sequence = noisyOrbit (c.scene, c.frames, c.seed);
    const std::size_t begin = 8, end = begin + c.gap;
    const auto blank = [&] (std::size_t i, RGBDFrame& frame) {
      if (i >= begin && i < end)
        frame.depth.setTo (0.f);
    };
    DenseReconstruction fusion;
    const std::vector<Processed> run = processInOrder (fusion, sequence, frameRange (0, c.frames), blank);
    for (std::size_t k = begin; k < end; ++k)
      EXPECT_FALSE (run[k].report.tracked) << "frame " << k;
    EXPECT_GE (trackedShareFrom (run, end), 0.9);
    if (c.gap > 10)  // a case that needs the motion carried through the gap
    {
      DenseReconstructionConfig uncarried;
      uncarried.max_prediction_gap = 0.0;
      DenseReconstruction without (uncarried);
      EXPECT_LT (trackedShareFrom (processInOrder (without, sequence, frameRange (0, c.frames), blank), end), 0.5);
    }
    EXPECT_TRUE (run[end].report.tracked || run[end + 1].report.tracked) << run[end].report.failure;
    EXPECT_LT (trackedRmse (run), 0.005);
  }
}

TEST (MotionModel, AJumpOfCutFramesIsBridgedByThePrediction)
{
  // 19 or 14 frames cut out of 1.5–1.75° a frame orbits (a 28° or 25° jump between two
  // processed frames; their stamps keep the time that passed).
  for (const OrbitGap& c : {OrbitGap{"tabletop", 54, 19, 3}, OrbitGap{"clutter", 40, 14, 4}})
  {
    SCOPED_TRACE (std::string (c.scene) + ", " + std::to_string (c.gap) + " frames cut");
    const simulation::SyntheticSequence sequence = noisyOrbit (c.scene, c.frames, c.seed);
    DenseReconstruction fusion;
    std::vector<std::size_t> order = frameRange (0, 6);
    const std::vector<std::size_t> after = frameRange (6 + c.gap, c.frames);
    order.insert (order.end (), after.begin (), after.end ());
    const std::vector<Processed> run = processInOrder (fusion, sequence, order);
    EXPECT_GE (trackedShareFrom (run, 6), 0.9);
    EXPECT_LT (trackedRmse (run), 0.005);
    DenseReconstructionConfig uncarried;
    uncarried.max_prediction_gap = 0.0;
    DenseReconstruction without (uncarried);
    const std::vector<Processed> lost = processInOrder (without, sequence, order);
    EXPECT_LT (trackedShareFrom (lost, 6), 0.5) << "a case that does not need the motion carried across the cut";
  }
}

TEST (CameraTracker, AFrameThatMissesTheModelIsNoOverlapNotDegenerate)
{
  // The frame sees the table with its objects (every direction constrained); the model at
  // the guess is a plain floor. The few matches lie on one plane: the reason is the
  // overlap, not the frame's surfaces (a plane or a corridor).
  const simulation::SyntheticScene table = simulation::SyntheticScene::load (test::tabletopScenePath ());
  const simulation::SyntheticScene floor = simulation::SyntheticScene::parse (
    "scene floor\ncamera 640 480 525 525 319.5 239.5\n"
    "trajectory target=0,0,0 radius=0.6 height=1.2 start=0 sweep=20 bob=0.0\n"
    "object floor class=floor color=170,165,150 detectable=no\n"
    "  box center=0,0,-0.01 size=12,12,0.02\n",
    "floor scene");
  const PinholeCamera camera = table.camera.scaled (320, 240);
  const Eigen::Isometry3d frame_pose = table.trajectory.poseAt (0.3), model_pose = floor.trajectory.poseAt (0.5);
  const DepthPreprocessor preprocessor;
  FramePyramid frame, model;
  preprocessor.compute (simulation::SceneRenderer (table).render (camera, frame_pose).depth, camera, frame);
  preprocessor.compute (simulation::SceneRenderer (floor).render (camera, model_pose).depth, camera, model);
  const TrackingResult result = CameraTracker ().track (frame, model, model_pose, model_pose);
  EXPECT_FALSE (result.tracked);
  EXPECT_NE (result.failure.find ("no overlap with the model at the predicted pose"), std::string::npos) << result.failure;
  EXPECT_GT (result.icp.source_conditioning, CameraTrackerConfig ().min_translation_conditioning);

  // The floor itself as the frame: its own surfaces leave translations free.
  FramePyramid floor_frame;
  preprocessor.compute (simulation::SceneRenderer (floor).render (camera, floor.trajectory.poseAt (0.6)).depth, camera, floor_frame);
  const TrackingResult plane = CameraTracker ().track (floor_frame, model, model_pose, model_pose);
  EXPECT_FALSE (plane.tracked);
  EXPECT_NE (plane.failure.find ("degenerate"), std::string::npos) << plane.failure;
}

TEST (RoomRange, ANoisyTableSeenFromAcrossTheRoomIsTracked)
{
  // The tabletop from 2.4 and 3.2 m (orbits of that radius, ~2.5 cm of camera motion a
  // frame, Kinect noise): the normals' noise there is twice that at 1.5 m, and the fixed
  // 20° normal gate took most points for outliers (every frame after the first lost).
  std::string text = test::readFile (test::tabletopScenePath ());
  const std::size_t line = text.find ("\ntrajectory ");
  ASSERT_NE (line, std::string::npos);
  const std::size_t line_end = text.find ('\n', line + 1);
  for (const auto& [radius, sweep, seed] : {std::tuple<double, double, std::uint64_t>{2.4, 18.0, 5}, {3.2, 14.0, 6}})
  {
    SCOPED_TRACE ("radius " + std::to_string (radius) + " m");
    const std::string scene_text = text.substr (0, line) + "\ntrajectory target=0,0,0.8 radius=" + std::to_string (radius) +
                                   " height=0.9 start=200 sweep=" + std::to_string (sweep) + " bob=0.03" + text.substr (line_end);
    simulation::SyntheticSequenceConfig config;
    config.frames = 30;  // at the Kinect's 640×480: at 320×240 a pixel spans 1.2 cm at 3 m
    config.noise.enabled = true;
    config.seed = seed;
    const simulation::SyntheticSequence sequence (simulation::SyntheticScene::parse (scene_text, "far tabletop"), config);
    DenseReconstruction fusion;
    const std::vector<Processed> run = processInOrder (fusion, sequence, frameRange (0, config.frames));
    EXPECT_GE (trackedShareFrom (run, 0), 0.95);
    EXPECT_LT (trackedRmse (run), 0.01);
    EXPECT_GT (run.back ().report.icp.normal_gate_deg, 25.0);

    DenseReconstructionConfig fixed_gate;
    fixed_gate.tracking.icp.angle_reference_depth = 0.0;
    DenseReconstruction fixed (fixed_gate);
    EXPECT_LT (trackedShareFrom (processInOrder (fixed, sequence, frameRange (0, config.frames)), 0), 0.5)
      << "a case the fixed gate tracks does not test the noise-following gate";
  }
}

namespace
{
/** Two noisy views of the printed tabletop on its 80° orbit, \a lo_deg–\a hi_deg apart. */
struct ViewPair
{
  Eigen::Isometry3d stored_pose, frame_pose;
  simulation::RenderedView stored, frame;
  std::string trace;
};

/** \a draws pairs of views of \a table: the first at orbit parameter [0, \a start_max), the
  * second the drawn angle on (both drawn from \a seed), their noise seeded from
  * \a noise_seed on. */
std::vector<ViewPair>
printedViewPairs (const simulation::SyntheticScene& table, int draws, double start_max, double lo_deg, double hi_deg,
                  std::uint32_t seed, unsigned noise_seed)
{
  const simulation::SceneRenderer renderer (table);
  simulation::DepthNoiseConfig noise;
  noise.enabled = true;
  std::mt19937 random (seed);
  std::uniform_real_distribution<double> start (0.0, start_max), apart (lo_deg / 80.0, hi_deg / 80.0);
  std::vector<ViewPair> pairs;
  for (int draw = 0; draw < draws; ++draw)
  {
    const double s = start (random), t = s + apart (random);
    ViewPair p;
    p.stored_pose = table.trajectory.poseAt (s);
    p.frame_pose = table.trajectory.poseAt (t);
    p.stored = renderer.render (table.camera, p.stored_pose, noise, noise_seed + 2u * static_cast<unsigned> (draw));
    p.frame = renderer.render (table.camera, p.frame_pose, noise, noise_seed + 2u * static_cast<unsigned> (draw) + 1u);
    p.trace = "orbit at " + std::to_string (s) + " and " + std::to_string (t);
    pairs.push_back (std::move (p));
  }
  return pairs;
}
}  // namespace

TEST (FeatureRelocaliser, FindsTheMotionBetweenTwoViewsFromTheirFeatures)
{
  // Two views of the printed tabletop 15–25° apart on its orbit (drawn), with Kinect noise:
  // the features of one, matched to the other's, give the pose to 2 cm and 2° (ICP then
  // refines it).
  const simulation::SyntheticScene table = printedScene ("tabletop");
  const FeatureRelocaliser relocaliser;
  for (const ViewPair& p : printedViewPairs (table, 3, 0.5, 15.0, 25.0, 11, 0))
  {
    SCOPED_TRACE (p.trace);
    const FeatureView view = relocaliser.describe (p.stored.color, p.stored.depth, table.camera, p.stored_pose);
    const FeatureView lost = relocaliser.describe (p.frame.color, p.frame.depth, table.camera, Eigen::Isometry3d::Identity ());
    const std::optional<FeatureRelocaliser::Estimate> found = relocaliser.estimate (lost, view);
    ASSERT_TRUE (found.has_value ());
    EXPECT_GE (found->inliers, relocaliser.getConfig ().min_inliers);
    const Eigen::Isometry3d error = p.frame_pose.inverse () * found->pose;
    EXPECT_LT (error.translation ().norm (), 0.02);
    EXPECT_LT (rotationDeg (error), 2.0);
  }

  const simulation::SceneRenderer renderer (table);
  // A view of something else (a noise image on a wall) finds no pose.
  const simulation::RenderedView stored = renderer.render (table.camera, table.trajectory.poseAt (0.2));
  cv::Mat color (stored.color.size (), CV_8UC3), wall (stored.depth.size (), CV_32F, cv::Scalar (1.5f));
  cv::randu (color, cv::Scalar::all (0), cv::Scalar::all (255));
  EXPECT_FALSE (relocaliser
                  .estimate (relocaliser.describe (color, wall, table.camera, Eigen::Isometry3d::Identity ()),
                             relocaliser.describe (stored.color, stored.depth, table.camera, Eigen::Isometry3d::Identity ()))
                  .has_value ());
}

TEST (FeatureRelocaliser, SiftReachesViewsTooFarApartForOrb)
{
  // Two views of the printed tabletop 38–48° apart on its orbit (drawn), with Kinect noise:
  // the lost one's SIFT features matched to the last tracked view's give the pose to 2 cm
  // and 2°, from more agreeing matches than ORB finds between the same two views.
  const simulation::SyntheticScene table = printedScene ("tabletop");
  FeatureRelocaliser relocaliser;
  for (const ViewPair& p : printedViewPairs (table, 2, 0.4, 38.0, 48.0, 12, 20))
  {
    SCOPED_TRACE (p.trace);
    relocaliser.rememberTracked (p.stored.color, p.stored.depth, table.camera, p.stored_pose);
    const std::optional<FeatureRelocaliser::Estimate> found = relocaliser.relocaliseWide (p.frame.color, p.frame.depth, table.camera);
    ASSERT_TRUE (found.has_value ());
    EXPECT_EQ (found->view, "last tracked frame, SIFT");
    const Eigen::Isometry3d error = p.frame_pose.inverse () * found->pose;
    EXPECT_LT (error.translation ().norm (), 0.02);
    EXPECT_LT (rotationDeg (error), 2.0);
    const std::optional<FeatureRelocaliser::Estimate> orb =
      relocaliser.estimate (relocaliser.describe (p.frame.color, p.frame.depth, table.camera, Eigen::Isometry3d::Identity ()),
                            relocaliser.describe (p.stored.color, p.stored.depth, table.camera, p.stored_pose));
    EXPECT_LT (orb ? orb->inliers : 0u, found->inliers);
  }

  // Off (wide_features 0): no pose, whatever the views.
  FeatureRelocaliserConfig off;
  off.wide_features = 0;
  FeatureRelocaliser without (off);
  const simulation::RenderedView stored = simulation::SceneRenderer (table).render (table.camera, table.trajectory.poseAt (0.2));
  without.rememberTracked (stored.color, stored.depth, table.camera, table.trajectory.poseAt (0.2));
  EXPECT_FALSE (without.relocaliseWide (stored.color, stored.depth, table.camera).has_value ());
}

TEST (FeatureRelocalisation, AThirtyDegreeJumpIsRelocalisedByFeatures)
{
  // 20 or 17 frames cut out of 1.5–1.75° a frame orbits (a 30° jump) where the motion is
  // not carried across (max_prediction_gap 0: a jump the motion model cannot foresee):
  // the lost frame's features matched to the last tracked frame's place it.
  for (const OrbitGap& c : {OrbitGap{"tabletop", 54, 20, 7}, OrbitGap{"clutter", 40, 17, 8}})
  {
    SCOPED_TRACE (std::string (c.scene) + ", " + std::to_string (c.gap) + " frames cut");
    // At 640×480: at 320×240 ORB finds too few keypoints for a 30° baseline.
    const simulation::SyntheticSequence sequence = noisyOrbit (printedScene (c.scene), c.frames, c.seed, 640);
    expectRelocalisedByFeatures (jumpOverCut (sequence, c.gap, DenseReconstructionConfig ()));
    DenseReconstructionConfig without;
    without.feature_relocalisation = false;
    EXPECT_LT (trackedShareFrom (jumpOverCut (sequence, c.gap, without), 6), 0.5)
      << "a case that does not need the features";
  }
}

TEST (FeatureRelocalisation, AJumpTooWideForOrbIsRelocalisedBySift)
{
  // 38–48° (drawn) cut out of a 1.5° a frame orbit of each printed scene, the motion not
  // carried across (the stress matrix's 33–36° hidden jumps were lost for good): ORB's
  // matches to the last tracked frame are too few there or SIFT's place it, and ICP
  // confirming the features' pose accepts a view that overlaps the small map by a quarter.
  std::mt19937 random (38);
  for (const char* scene : {"tabletop", "clutter"})
  {
    const std::string path = std::string (CUEFUSION_TEST_DATA_DIR) + "/scenes/" + scene + ".scene";
    const std::size_t cut = static_cast<std::size_t> (std::lround (std::uniform_real_distribution<double> (38.0, 48.0) (random) / 1.5));
    const std::size_t frames = 6 + cut + 20;
    const std::string trajectory = test::changedTrajectory (path, {{"sweep", 1.5 * static_cast<double> (frames - 1)}, {"bob", 0.03}});
    SCOPED_TRACE (std::string (scene) + ", " + std::to_string (1.5 * static_cast<double> (cut)) + "° cut out");
    simulation::SyntheticSequenceConfig sequence_config;
    sequence_config.frames = frames;
    sequence_config.noise.enabled = true;
    sequence_config.seed = 38;
    sequence_config.width = 640;  // the stress matrix's size
    sequence_config.height = 480;
    const simulation::SyntheticSequence sequence (
      simulation::SyntheticScene::parse (test::printedSceneText (path, trajectory), std::string (scene) + " printed"), sequence_config);
    expectRelocalisedByFeatures (jumpOverCut (sequence, cut, DenseReconstructionConfig ()));
    // Before: ORB alone, and every features' pose held to relocalisation_min_overlap.
    DenseReconstructionConfig before;
    before.features.wide_features = 0;
    before.relocalisation_confirmation_shift = 0.0;
    EXPECT_LT (trackedShareFrom (jumpOverCut (sequence, cut, before), 6), 0.5) << "a case the old rules recover";
  }
}

