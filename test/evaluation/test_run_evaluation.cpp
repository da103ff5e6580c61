// SPDX-License-Identifier: BSD-3-Clause
// The chapter 5 evaluation as a library call (evaluation::evaluateRuns): a "run" made of
// the generated sequence's own truth scores perfectly, and each known damage to it costs
// exactly what it should.
#include "../test_utils.h"
#include "../io/synthetic_fixtures.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/evaluation/run_evaluation.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/simulation/synthetic_sequence.h>

#include <boost/filesystem.hpp>
#include <pcl/io/pcd_io.h>
#include <gtest/gtest.h>

#include <iomanip>
#include <random>
#include <sstream>

using namespace cuefusion;
namespace fs = boost::filesystem;

namespace
{
class RunEvaluationFixture : public ::testing::Test
{
protected:
  static constexpr std::size_t kFrames = 8;

  void
  SetUp () override
  {
    const simulation::SyntheticSequence sequence = test::smallTabletop (kFrames, 160, 120);
    simulation::writeSyntheticSequence (sequence, io::DatasetLayout::TUM, dir / "seq");
    truth = evaluation::readSequenceTruth (dir / "seq");
    ASSERT_TRUE (truth.cloud.has_value ());
    for (std::size_t i = 0; i < kFrames; ++i)
    {
      const RGBDFrame::Ptr frame = truth.dataset->readFrame (i);
      masks.push_back (frame->instance_mask.clone ());
      std::map<std::uint32_t, std::size_t> pixels;
      for (int r = 0; r < frame->instance_mask.rows; ++r)
        for (int c = 0; c < frame->instance_mask.cols; ++c)
          ++pixels[frame->instance_mask.at<std::uint16_t> (r, c)];
      // The objects the evaluation scores: seen with enough pixels in some frame.
      for (const auto& [id, n] : pixels)
        if (id != 0 && !truth.stuff.count (id) && n >= evaluation::RunEvaluationConfig ().frame_iou.min_truth_pixels)
          objects.insert (id);
    }
    ASSERT_GE (objects.size (), 3u);
  }

  /** A run folder whose trajectory, per-frame labels, map and segments are the truth's,
    * each passed through \a relabel (0 = no segment). */
  std::string
  runOfTheTruth (const std::string& name, const std::function<std::uint32_t (std::uint32_t)>& relabel, const io::Trajectory& trajectory)
  {
    const fs::path run = fs::path (dir.str ()) / name;
    fs::create_directories (run / "labels");
    io::writeTumTrajectory ((run / "trajectory.txt").string (), trajectory);
    std::set<std::uint32_t> segments;
    for (std::size_t i = 0; i < masks.size (); ++i)
    {
      cv::Mat labels = masks[i].clone ();
      labels.forEach<std::uint16_t> ([&] (std::uint16_t& v, const int*) { v = static_cast<std::uint16_t> (relabel (v)); });
      std::ostringstream file;
      file << std::setw (6) << std::setfill ('0') << i << ".png";
      io::writeImageAtomic ((run / "labels" / file.str ()).string (), labels);
    }
    pcl::PointCloud<pcl::PointXYZL> map;
    for (const auto& p : *truth.cloud->cloud)
    {
      pcl::PointXYZL q = p;
      q.label = relabel (p.label);
      map.push_back (q);
      if (q.label != 0)
        segments.insert (q.label);
    }
    pcl::io::savePCDFileBinary ((run / "map.pcd").string (), map);
    std::string json = "{\"segments\": [";
    for (const std::uint32_t id : segments)
      json += (id == *segments.begin () ? "" : ", ") + std::string ("{\"id\": ") + std::to_string (id) + "}";
    io::writeTextAtomic ((run / "segments.json").string (), json + "]}\n");
    return run.string ();
  }

  evaluation::RunEvaluation
  evaluate (const std::string& run) const
  {
    evaluation::RunEvaluationConfig config;
    config.labels = evaluation::RunEvaluationConfig::Labels::PerFrame;
    return evaluation::evaluateRun (evaluation::readRunOutputs (run, false), truth, config);
  }

  test::TempDir dir;
  evaluation::SequenceTruth truth;
  std::vector<cv::Mat> masks;
  std::set<std::uint32_t> objects;
};

const auto kSame = [] (std::uint32_t id) { return id; };
}  // namespace

TEST_F (RunEvaluationFixture, TheTruthItselfScoresPerfectlyUnderAnyNaming)
{
  std::mt19937 random (std::random_device{} ());
  const std::uint32_t offset = 100 + random () % 5000;  // segment ids are arbitrary: matching must not care
  for (const auto& [name, relabel] : {std::make_pair (std::string ("same"), std::function<std::uint32_t (std::uint32_t)> (kSame)),
                                      std::make_pair (std::string ("renamed"), std::function<std::uint32_t (std::uint32_t)> (
                                                                                   [offset] (std::uint32_t id) { return id == 0 ? 0 : id * 7 + offset; }))})
  {
    SCOPED_TRACE (name);
    const evaluation::RunEvaluation found = evaluate (runOfTheTruth (name, relabel, truth.reference));
    ASSERT_TRUE (found.tracking.has_value ());
    EXPECT_LT (found.tracking->ate.rmse, 1e-6);
    EXPECT_EQ (found.tracking->ate.pairs, kFrames);
    EXPECT_EQ (found.frame_iou.size (), kFrames);
    EXPECT_EQ (found.frames_skipped, 0u);
    EXPECT_EQ (found.frames_with_masks, kFrames);
    EXPECT_EQ (found.object_iou.object_mean.size (), objects.size ());
    for (const auto& [id, mean] : found.object_iou.object_mean)
    {
      EXPECT_TRUE (objects.count (id)) << "stuff instance " << id << " was scored";
      EXPECT_DOUBLE_EQ (mean, 1.0) << "object " << id;
    }
    ASSERT_TRUE (found.instance_ap.has_value ());
    EXPECT_DOUBLE_EQ (found.instance_ap->class_agnostic.ap50, 1.0);
  }
}

TEST_F (RunEvaluationFixture, EachDamageCostsWhatItShould)
{
  std::mt19937 random (std::random_device{} ());
  std::vector<std::uint32_t> ids (objects.begin (), objects.end ());
  std::shuffle (ids.begin (), ids.end (), random);
  const std::uint32_t missing = ids[0], merged_a = ids[1], merged_b = ids[2];

  // A pose error of ±d alternating along x, which no rigid alignment can take away.
  const double d = 0.005 + 0.02 * std::uniform_real_distribution<double> (0.0, 1.0) (random);
  io::Trajectory shaken = truth.reference;
  for (std::size_t i = 0; i < shaken.size (); ++i)
    shaken[i].pose.translation ().x () += (i % 2 == 0 ? d : -d);

  // One object never segmented; two objects one segment.
  const evaluation::RunEvaluation found = evaluate (runOfTheTruth ("damaged", [&] (std::uint32_t id) -> std::uint32_t {
    if (id == missing)
      return 0;
    return id == merged_b ? merged_a : id;
  }, shaken));
  ASSERT_TRUE (found.tracking.has_value ());
  EXPECT_GT (found.tracking->ate.rmse, 0.8 * d);
  EXPECT_LT (found.tracking->ate.rmse, 1.01 * d);
  ASSERT_TRUE (found.tracking->rpe_frame.has_value ());
  EXPECT_NEAR (found.tracking->rpe_frame->translation_rmse, 2.0 * d, 0.2 * d);

  EXPECT_DOUBLE_EQ (found.object_iou.object_mean.at (missing), 0.0);
  for (const auto& [id, mean] : found.object_iou.object_mean)
    if (id != missing && id != merged_a && id != merged_b)
    {
      EXPECT_DOUBLE_EQ (mean, 1.0) << "object " << id;
    }
  // The merged segment goes to one of the two; neither is whole.
  EXPECT_LT (std::min (found.object_iou.object_mean.at (merged_a), found.object_iou.object_mean.at (merged_b)), 1.0);
  EXPECT_LT (std::max (found.object_iou.object_mean.at (merged_a), found.object_iou.object_mean.at (merged_b)), 1.0);
  ASSERT_TRUE (found.instance_ap.has_value ());
  EXPECT_LT (found.instance_ap->class_agnostic.ap50, 1.0);
}

TEST_F (RunEvaluationFixture, FramesARunHasNoLabelsForAreCountedAsSkipped)
{
  const std::string run = runOfTheTruth ("short", kSame, truth.reference);
  fs::remove (fs::path (run) / "labels" / "000003.png");
  const evaluation::RunEvaluation found = evaluate (run);
  EXPECT_EQ (found.frames_skipped, 1u);
  EXPECT_EQ (found.frame_iou.size (), kFrames - 1);
  EXPECT_EQ (std::count (found.frame_index.begin (), found.frame_index.end (), 3u), 0);
}

TEST_F (RunEvaluationFixture, BadRunsAndSettingsNameTheFileOrField)
{
  const std::string run = runOfTheTruth ("bad", kSame, truth.reference);
  test::expectError ([&] { evaluation::readRunOutputs (dir / "none", false); }, dir / "none", "not a `cuefusion run` output folder");
  test::expectError ([&] { evaluation::readRunOutputs (run, true); }, run + "/mesh.ply", "");
  fs::remove (fs::path (run) / "segments.json");
  test::expectError ([&] { evaluation::readRunOutputs (run, false); }, run + "/segments.json", "");
  evaluation::RunEvaluationConfig config;
  config.every = 0;
  try
  {
    config.validate ();
    ADD_FAILURE () << "every = 0 accepted";
  }
  catch (const ParameterError& e)
  {
    EXPECT_EQ (e.parameter (), "RunEvaluationConfig::every");
  }
}
