// SPDX-License-Identifier: BSD-3-Clause
// FusionPipeline on generated sequences, scored against the generator's labelled
// ground-truth cloud.
#include "test_utils.h"

#include <cuefusion/simulation/random_room.h>
#include <cuefusion/simulation/synthetic_sequence.h>
#include <cuefusion/pipeline/fusion_pipeline.h>
#include <cuefusion/reconstruction/keyframe_database.h>
#include <cuefusion/reconstruction/tsdf_volume.h>

#include <gtest/gtest.h>
#include <pcl/kdtree/kdtree_flann.h>

#include <cstdint>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <map>
#include <random>
#include <set>
#include <utility>

using namespace cuefusion;

namespace
{
/** A pipeline in \a mode that integrates with the sequence's poses. */
pipeline::FusionPipeline
withReferencePoses (pipeline::SegmentationMode mode)
{
  pipeline::FusionPipelineConfig config;
  config.mode = mode;
  config.reconstruction.use_reference_poses = true;
  return pipeline::FusionPipeline (config);
}

/** Gives \a fusion frames [begin, end) of \a sequence with its simulated detector's masks. */
void
fuseFrames (pipeline::FusionPipeline& fusion, const simulation::SyntheticSequence& sequence, std::size_t begin, std::size_t end)
{
  for (std::size_t i = begin; i < end; ++i)
  {
    const RGBDFrame::Ptr frame = sequence.frame (i);
    const std::vector<Instance> instances = simulation::toInstances (sequence.detections (*frame));
    EXPECT_TRUE (fusion.process (*frame, &instances).segmented) << i;
  }
}

/** Runs the pipeline over \a sequence with its poses and its simulated detector's masks. */
pipeline::FusionPipeline
runSequence (pipeline::SegmentationMode mode, const simulation::SyntheticSequence& sequence)
{
  pipeline::FusionPipeline fusion = withReferencePoses (mode);
  fuseFrames (fusion, sequence, 0, sequence.size ());
  return fusion;
}

/** Best IoU, over the map's points, of each ground-truth object with one map segment. */
std::map<std::uint16_t, double>
objectIoU (const pcl::PointCloud<pcl::PointXYZRGBL>& map, const pcl::PointCloud<pcl::PointXYZRGBL>::Ptr& truth)
{
  pcl::KdTreeFLANN<pcl::PointXYZRGBL> tree;
  tree.setInputCloud (truth);
  std::map<std::uint16_t, int> object_size;
  std::map<std::uint32_t, int> segment_size;
  std::map<std::pair<std::uint16_t, std::uint32_t>, int> both;
  std::vector<int> index (1);
  std::vector<float> distance (1);
  for (const auto& p : map.points)
  {
    if (tree.nearestKSearch (p, 1, index, distance) < 1 || distance[0] > 0.02f * 0.02f)
      continue;
    const auto object = static_cast<std::uint16_t> ((*truth)[static_cast<std::size_t> (index[0])].label);
    ++object_size[object];
    if (p.label == 0)
    {
      ++both[{object, 0}];
      continue;
    }
    ++segment_size[p.label];
    ++both[{object, p.label}];
  }
  if (std::getenv ("CUEFUSION_TEST_VERBOSE"))
    for (const auto& [key, n] : both)
      if (n > 20)
        std::cerr << "object " << key.first << " (" << object_size[key.first] << " map points) label " << key.second << " ("
                  << segment_size[key.second] << "): " << n << "\n";
  std::map<std::uint16_t, double> best;
  for (const auto& [key, n] : both)
  {
    if (key.second == 0)
      continue;
    const double iou = static_cast<double> (n) / (object_size[key.first] + segment_size[key.second] - n);
    best[key.first] = std::max (best[key.first], iou);
  }
  return best;
}

/** What a geometry-only run did: merges made, and whether object \a id was seen under two
  * or more labels of L^p in the first frame. */
struct SplitRun
{
  std::size_t merges = 0;
  bool split_at_first = false;
};

/** Runs \a fusion (geometry only) over \a sequence from its start, frame by frame. */
SplitRun
runGeometrySplitAtFirst (const simulation::SyntheticSequence& sequence, std::uint16_t id, pipeline::FusionPipeline& fusion)
{
  SplitRun run;
  for (std::size_t i = 0; i < sequence.size (); ++i)
  {
    const RGBDFrame::Ptr frame = sequence.frame (i);
    run.merges += fusion.process (*frame, nullptr).merges;
    if (i != 0)
      continue;
    std::set<std::int32_t> labels;
    const cv::Mat& lp = fusion.frameLabels ();
    for (int y = 0; y < lp.rows; ++y)
      for (int x = 0; x < lp.cols; ++x)
        if (frame->instance_mask.at<std::uint16_t> (y, x) == id && lp.at<std::int32_t> (y, x) > 0)
          labels.insert (lp.at<std::int32_t> (y, x));
    run.split_at_first = labels.size () >= 2;
  }
  return run;
}
}  // namespace

TEST (FusionPipeline, LabelledMapMatchesTheGroundTruthAndFusionBeatsGeometry)
{
  simulation::SyntheticSequenceConfig config;
  config.frames = 30;
  const simulation::SyntheticSequence sequence (simulation::SyntheticScene::load (test::tabletopScenePath ()), config);
  const auto truth = sequence.groundTruthCloud ();

  pipeline::FusionPipeline fused = runSequence (pipeline::SegmentationMode::Fused, sequence);
  pipeline::FusionPipeline geometry = runSequence (pipeline::SegmentationMode::Geometry, sequence);
  const auto fused_iou = objectIoU (*fused.labelledCloud (), truth);
  const auto geometry_iou = objectIoU (*geometry.labelledCloud (), truth);

  // Object ids in file order: 5 mug, 6 ball, 7 book, 8 bottle, 9 L-block, 10 teddy,
  // 11 and 12 the touching boxes. Threshold: ≥ 0.7 for every single object in fused mode
  // with a perfect detector (1 cm voxels: points within a voxel of a neighbour go either
  // way, up to a quarter of a 5–10 cm object's points).
  for (std::uint16_t id = 5; id <= 10; ++id)
  {
    if (std::getenv ("CUEFUSION_TEST_VERBOSE") && fused_iou.count (id))
      std::cerr << "object " << id << " IoU fused " << fused_iou.at (id) << " geometry "
                << (geometry_iou.count (id) ? geometry_iou.at (id) : 0.0) << "\n";
    ASSERT_TRUE (fused_iou.count (id)) << id;
    EXPECT_GE (fused_iou.at (id), 0.7) << "object " << id;
  }
  // Documented limitation (thesis Fig. 5.19): the two boxes stand side by side with
  // coplanar faces, so geometry rarely sees a seam between them, and the instance cue only
  // groups geometric segments — it never splits one. They share a segment here.
  ASSERT_TRUE (fused_iou.count (11) && fused_iou.count (12));
  // The teddy (six spheres) is cut by geometry and re-united by the masks (§4.2.1.3); the
  // extruded L-block is whole in geometry already (its flat top joins the arms).
  EXPECT_GT (fused_iou.at (10), geometry_iou.count (10) ? geometry_iou.at (10) + 0.1 : 0.1);
  EXPECT_GE (fused_iou.at (9), geometry_iou.count (9) ? geometry_iou.at (9) : 0.0);

  // Segments carry the detector's classes.
  std::map<std::string, int> classes;
  for (const auto& s : fused.segments ())
    if (!s.bestClass ().empty ())
      ++classes[s.bestClass ()];
  for (const char* name : {"cup", "sports ball", "book", "bottle", "block", "teddy bear", "box"})
    EXPECT_GE (classes[name], 1) << name;
}

TEST (FusionPipeline, AnObjectSeenInTwoPartsIsMergedOnceRevealed)
{
  // Thesis Fig. 4.17: at first a pole stands between the camera and a long box, so the box
  // is seen as two parts that get two labels; as the camera moves the pole no longer
  // splits it, a frame segment covers both labels, and after enough frames they merge.
  const std::string text = "scene occluder\n"
                           "camera 640 480 525 525 319.5 239.5\n"
                           "trajectory target=0,0,0.8 radius=1.2 height=0.0 start=270 sweep=70 bob=0\n"
                           "object floor class=floor color=170,165,150 detectable=no\n"
                           "  box center=0,0,-0.01 size=6,6,0.02\n"
                           "object wall class=wall color=200,200,190 detectable=no\n"
                           "  box center=0,1.5,1.25 size=6,0.1,2.5\n"
                           "object bench class=box color=200,120,40\n"
                           "  box center=0,0,0.8 size=0.6,0.1,0.2\n"
                           "object pole class=pole color=60,60,60\n"
                           "  cylinder center=0,-0.5,0.8 radius=0.03 height=1.0\n";
  simulation::SyntheticSequenceConfig config;
  config.frames = 30;
  const simulation::SyntheticSequence sequence (simulation::SyntheticScene::parse (text, "occluder scene"), config);
  pipeline::FusionPipeline fusion = withReferencePoses (pipeline::SegmentationMode::Geometry);
  const SplitRun run = runGeometrySplitAtFirst (sequence, 3, fusion);
  ASSERT_TRUE (run.split_at_first);  // the precondition: the box is seen in two parts with two labels
  EXPECT_GE (run.merges, 1u);
  const auto iou = objectIoU (*fusion.labelledCloud (), sequence.groundTruthCloud ());
  ASSERT_TRUE (iou.count (3));
  EXPECT_GE (iou.at (3), 0.8);  // one segment for the whole box
}

namespace
{
// Grouping as evidence (GlobalSegmentMap): two boxes touching with their front and top
// faces flush (geometry sees no seam between them), an L whose arms differ in height
// (geometry cuts it at the crease in every view), on a table before a wall.
const std::string kGroupingScene = "scene grouping\n"
                                   "camera 640 480 525 525 319.5 239.5\n"
                                   "trajectory target=0,0,0.8 radius=1.2 height=0.5 start=230 sweep=60 bob=0.03\n"
                                   "object floor class=floor color=170,165,150 detectable=no\n"
                                   "  box center=0,0,-0.01 size=6,6,0.02\n"
                                   "object table class=dining_table color=140,100,60 detectable=no\n"
                                   "  box center=0,0,0.72 size=1.2,0.8,0.04\n"
                                   "object box_a class=box color=220,120,30\n"
                                   "  box center=-0.20,0.10,0.82 size=0.12,0.08,0.16\n"
                                   "object box_b class=box color=30,170,190\n"
                                   "  box center=-0.08,0.10,0.82 size=0.12,0.08,0.16\n"
                                   "object lblock class=block color=150,60,170\n"
                                   "  box center=0.15,-0.05,0.79 size=0.20,0.06,0.10\n"
                                   "  box center=0.08,-0.13,0.815 size=0.06,0.10,0.15\n";
constexpr std::uint16_t kBoxA = 3, kBoxB = 4, kLBlock = 5;
/** The same with box_b 3 cm further back and 2 cm lower: a concave seam shows on the front
  * and along the top, geometry keeps the boxes apart, and only the masks' word can unite
  * them (in the map's evidence). (Until 2026-11-26 box_b was as tall as box_a: their tops
  * were one plane, which geometry kept apart only because the normals near the front step
  * were missing; with normals on both sides the tops join, as they should.) With
  * \a same_color box_b is orange like box_a: the colour cannot tell them apart either
  * (InstanceGuidedRegionMergeConfig::color_split_distance). */
std::string
steppedBoxes (bool same_color)
{
  std::string text = kGroupingScene;
  const std::string flush = "box center=-0.08,0.10,0.82 size=0.12,0.08,0.16", stepped = "box center=-0.08,0.13,0.81 size=0.12,0.08,0.14";
  text.replace (text.find (flush), flush.size (), stepped);
  const std::string teal = "box_b class=box color=30,170,190", orange = "box_b class=box color=220,120,30";
  if (same_color)
    text.replace (text.find (teal), teal.size (), orange);
  return text;
}

/** Fused run over \a sequence with reference poses; \a masks gives each frame's instances. */
pipeline::FusionPipeline
runFused (const simulation::SyntheticSequence& sequence, const std::function<std::vector<Instance> (const RGBDFrame&)>& masks,
          const std::function<void (std::size_t, const pipeline::FusionPipeline&)>& after = nullptr)
{
  pipeline::FusionPipeline fusion = withReferencePoses (pipeline::SegmentationMode::Fused);
  for (std::size_t i = 0; i < sequence.size (); ++i)
  {
    const RGBDFrame::Ptr frame = sequence.frame (i);
    const std::vector<Instance> instances = masks (*frame);
    EXPECT_TRUE (fusion.process (*frame, &instances).segmented) << i;
    if (after)
      after (i, fusion);
  }
  return fusion;
}

/** How object \a id sits in the map: the label most of its labelled points carry, the
  * share of its labelled points with that label (coverage), and the share of that label's
  * points that are the object's (purity). Unlabelled points count for neither: the voxel
  * update leaves part of a small object's surface unlabelled whatever the grouping.
  */
struct SegmentFit
{
  std::uint32_t label = 0;
  double coverage = 0.0, purity = 0.0;
};

SegmentFit
segmentFit (const pcl::PointCloud<pcl::PointXYZRGBL>& map, const pcl::PointCloud<pcl::PointXYZRGBL>::Ptr& truth,
            std::uint16_t id)
{
  pcl::KdTreeFLANN<pcl::PointXYZRGBL> tree;
  tree.setInputCloud (truth);
  std::map<std::uint32_t, int> votes, size;
  int labelled = 0;
  std::vector<int> index (1);
  std::vector<float> distance (1);
  for (const auto& p : map.points)
    if (p.label && tree.nearestKSearch (p, 1, index, distance) == 1 && distance[0] < 0.02f * 0.02f)
    {
      ++size[p.label];
      if ((*truth)[static_cast<std::size_t> (index[0])].label == id)
      {
        ++votes[p.label];
        ++labelled;
      }
    }
  SegmentFit fit;
  int most = 0;
  for (const auto& [label, n] : votes)
    if (n > most)
    {
      fit.label = label;
      most = n;
    }
  if (most > 0)
  {
    fit.coverage = static_cast<double> (most) / labelled;
    fit.purity = static_cast<double> (most) / size[fit.label];
  }
  return fit;
}

std::uint32_t
majorityLabel (const pcl::PointCloud<pcl::PointXYZRGBL>& map, const pcl::PointCloud<pcl::PointXYZRGBL>::Ptr& truth,
               std::uint16_t id)
{
  return segmentFit (map, truth, id).label;
}

/** Both boxes in segments of their own: different labels, each holding ≥ 85 % of its
  * box's labelled points and made of ≥ 85 % of it.
  */
void
expectBoxesApart (const pcl::PointCloud<pcl::PointXYZRGBL>& map, const pcl::PointCloud<pcl::PointXYZRGBL>::Ptr& truth)
{
  const SegmentFit a = segmentFit (map, truth, kBoxA), b = segmentFit (map, truth, kBoxB);
  EXPECT_NE (a.label, b.label);
  for (const SegmentFit& fit : {a, b})
  {
    EXPECT_GE (fit.coverage, 0.85);
    EXPECT_GE (fit.purity, 0.85);
  }
}
}  // namespace

TEST (FusionPipeline, TouchingPairMergedByTheMasksInAMinorityOfFramesStaysTwo)
{
  simulation::SyntheticSequenceConfig config;
  config.frames = 30;
  config.detector.merge_probability = 0.25;  // per frame
  config.seed = 2;
  const simulation::SyntheticSequence sequence (simulation::SyntheticScene::parse (kGroupingScene, "grouping scene"), config);
  // The precondition: the masks do merge the pair in some frames, and geometry alone
  // keeps them in one segment (flush faces, no seam).
  int merged_frames = 0;
  for (std::size_t i = 0; i < sequence.size (); ++i)
    for (const simulation::Detection& d : sequence.detections (*sequence.frame (i)).detections)
      merged_frames += d.gt_instances.size () == 2 ? 1 : 0;
  ASSERT_GE (merged_frames, 4);
  ASSERT_LE (merged_frames, 12);
  const auto truth = sequence.groundTruthCloud ();
  pipeline::FusionPipeline geometry = runSequence (pipeline::SegmentationMode::Geometry, sequence);
  ASSERT_EQ (majorityLabel (*geometry.labelledCloud (), truth, kBoxA), majorityLabel (*geometry.labelledCloud (), truth, kBoxB));

  pipeline::FusionPipeline fused =
    runFused (sequence, [&] (const RGBDFrame& f) { return simulation::toInstances (sequence.detections (f)); });
  const auto map = fused.labelledCloud ();
  expectBoxesApart (*map, truth);
  EXPECT_GE (objectIoU (*map, truth).at (kLBlock), 0.7);  // and the L is whole
}

TEST (FusionPipeline, AnLSplitByGeometryInEveryFrameBecomesOne)
{
  simulation::SyntheticSequenceConfig config;
  config.frames = 20;
  config.width = 320;  // half the scene's camera: this test runs in the sanitized pass too
  config.height = 240;
  const simulation::SyntheticSequence sequence (simulation::SyntheticScene::parse (kGroupingScene, "grouping scene"), config);
  const auto truth = sequence.groundTruthCloud ();
  // Geometry alone leaves the L in two parts.
  pipeline::FusionPipeline geometry = runSequence (pipeline::SegmentationMode::Geometry, sequence);
  ASSERT_LT (objectIoU (*geometry.labelledCloud (), truth).at (kLBlock), 0.7);
  pipeline::FusionPipeline fused =
    runFused (sequence, [&] (const RGBDFrame& f) { return simulation::toInstances (sequence.detections (f)); });
  EXPECT_GE (objectIoU (*fused.labelledCloud (), truth).at (kLBlock), 0.8);

}

TEST (FusionPipeline, AWrongEarlyMergeIsUndoneByLaterFrames)
{
  simulation::SyntheticSequenceConfig config;
  config.frames = 30;
  const simulation::SyntheticScene scene = simulation::SyntheticScene::parse (steppedBoxes (true), "stepped boxes");
  const simulation::SyntheticSequence sequence (scene, config);
  simulation::DetectorErrorConfig always_merges;
  always_merges.merge_probability = 1.0;
  const simulation::SimulatedDetector merging (scene, always_merges, 1);
  const auto truth = sequence.groundTruthCloud ();
  // The precondition: geometry alone keeps the boxes apart.
  pipeline::FusionPipeline geometry = runSequence (pipeline::SegmentationMode::Geometry, sequence);
  ASSERT_NE (majorityLabel (*geometry.labelledCloud (), truth, kBoxA), majorityLabel (*geometry.labelledCloud (), truth, kBoxB));
  // The first eight frames report the two boxes as one object, every later frame apart.
  bool merged_at_eight = false;
  pipeline::FusionPipeline fused = runFused (
    sequence,
    [&] (const RGBDFrame& f) {
      return simulation::toInstances (f.index < 8 ? merging.detect (f.instance_mask, f.index) : sequence.detections (f));
    },
    [&] (std::size_t i, const pipeline::FusionPipeline& p) {
      if (i == 7)
      {
        const auto map = p.labelledCloud ();
        merged_at_eight = majorityLabel (*map, truth, kBoxA) == majorityLabel (*map, truth, kBoxB);
      }
    });
  EXPECT_TRUE (merged_at_eight);  // the merge was made (five frames agreed, none disagreed) ...
  expectBoxesApart (*fused.labelledCloud (), truth);  // ... and undone
}

TEST (FusionPipeline, MasksMergingTwoBoxesOfDifferentColoursInEveryFrameLeaveThemApart)
{
  // A depth network's typical mistake: the two touching boxes reported as one object in
  // every frame. Their colours (orange, teal) keep them apart; painted alike, the masks'
  // word unites them; the L (one colour) is whole either way.
  simulation::SyntheticSequenceConfig config;
  config.frames = 20;
  simulation::DetectorErrorConfig always_merges;
  always_merges.merge_probability = 1.0;
  for (const bool same_color : {false, true})
  {
    const simulation::SyntheticScene scene = simulation::SyntheticScene::parse (steppedBoxes (same_color), "stepped boxes");
    const simulation::SyntheticSequence sequence (scene, config);
    const simulation::SimulatedDetector merging (scene, always_merges, 1);
    const auto truth = sequence.groundTruthCloud ();
    pipeline::FusionPipeline fused =
      runFused (sequence, [&] (const RGBDFrame& f) { return simulation::toInstances (merging.detect (f.instance_mask, f.index)); });
    const auto map = fused.labelledCloud ();
    if (same_color)
      EXPECT_EQ (majorityLabel (*map, truth, kBoxA), majorityLabel (*map, truth, kBoxB));
    else
      expectBoxesApart (*map, truth);
    EXPECT_GE (objectIoU (*map, truth).at (kLBlock), 0.8) << same_color;
  }
}

TEST (FusionPipeline, AWallSeenInTwoPiecesBecomesOneSegment)
{
  // A pole from floor to ceiling stands between the camera and a wall: the first views
  // see the wall in two pieces (two labels); as the camera moves the pole passes out of
  // the wall's view and frames see the wall whole.
  const std::string text = "scene wall\n"
                           "camera 640 480 525 525 319.5 239.5\n"
                           "trajectory target=0,1.0,1.0 radius=1.5 height=0.0 start=270 sweep=50 bob=0\n"
                           "object floor class=floor color=170,165,150 detectable=no\n"
                           "  box center=0,0,-0.01 size=6,6,0.02\n"
                           "object wall class=wall color=200,200,190 detectable=no\n"
                           "  box center=0,1.6,1.25 size=3,0.1,2.5\n"
                           "object pole class=pole color=60,60,60\n"
                           "  box center=0,0.2,1.25 size=0.08,0.08,2.5\n";
  simulation::SyntheticSequenceConfig config;
  config.frames = 30;
  const simulation::SyntheticSequence sequence (simulation::SyntheticScene::parse (text, "wall scene"), config);
  pipeline::FusionPipeline fusion = withReferencePoses (pipeline::SegmentationMode::Geometry);
  ASSERT_TRUE (runGeometrySplitAtFirst (sequence, 2, fusion).split_at_first);
  const auto iou = objectIoU (*fusion.labelledCloud (), sequence.groundTruthCloud ());
  ASSERT_TRUE (iou.count (2));
  EXPECT_GE (iou.at (2), 0.8);  // one segment for the whole wall
}

TEST (FusionPipeline, AWallAPillarPartsInEveryViewIsOneSegmentTwoTablesWithFloorBetweenAreTwo)
{
  // A pillar from floor to ceiling stands 10 cm before a wall and parts it in every view
  // (the camera sweeps 30° at 2 m): no frame sees the wall's two sides touch, so no frame
  // can say they are one; they are one flat surface on one plane, and the map shows them
  // as one segment (GlobalSegmentMapConfig::surface_min_extent). Two table tops at one
  // height with the floor seen between them are flat and on one plane too, but the volume
  // has observed free space on that plane between them: they stay two. Geometry alone,
  // Kinect noise, the true poses.
  const auto run = [] (const std::string& text, float surface_min_extent) {
    simulation::SyntheticSequenceConfig config;
    config.frames = 30;
    config.width = 320;
    config.height = 240;
    config.noise.enabled = true;
    const simulation::SyntheticSequence sequence (simulation::SyntheticScene::parse (text, "flat surfaces scene"), config);
    pipeline::FusionPipelineConfig settings;
    settings.mode = pipeline::SegmentationMode::Geometry;
    settings.reconstruction.use_reference_poses = true;
    settings.merging.surface_min_extent = surface_min_extent;
    pipeline::FusionPipeline fusion (settings);
    for (std::size_t i = 0; i < sequence.size (); ++i)
      fusion.process (*sequence.frame (i), nullptr);
    return objectIoU (*fusion.labelledCloud (), sequence.groundTruthCloud ());
  };
  const std::string wall = "scene pillar\n"
                           "camera 640 480 525 525 319.5 239.5\n"
                           "trajectory target=0,1.3,1.2 radius=2.0 height=0.0 start=255 sweep=30 bob=0\n"
                           "object floor class=floor color=170,165,150 detectable=no\n"
                           "  box center=0,0,-0.01 size=6,6,0.02\n"
                           "object wall class=wall color=200,200,190 detectable=no\n"
                           "  box center=0,1.6,1.25 size=3,0.1,2.5\n"
                           "object pillar class=pillar color=60,60,60\n"
                           "  box center=0,1.3,1.25 size=0.3,0.3,2.5\n";
  const float on = segmentation::GlobalSegmentMapConfig ().surface_min_extent;
  const auto parted = run (wall, 0.f), joined = run (wall, on);
  ASSERT_TRUE (parted.count (2) && joined.count (2));
  EXPECT_LT (parted.at (2), 0.7);  // the precondition: without the rule, two segments
  EXPECT_GE (joined.at (2), 0.9);
  EXPECT_GE (joined.at (3), 0.8);  // the pillar stays itself
  const std::string tables = "scene tables\n"
                             "camera 640 480 525 525 319.5 239.5\n"
                             "trajectory target=0,0,0.75 radius=1.8 height=1.0 start=250 sweep=40 bob=0\n"
                             "object floor class=floor color=170,165,150 detectable=no\n"
                             "  box center=0,0,-0.01 size=6,6,0.02\n"
                             "object left class=table color=120,90,60\n"
                             "  box center=-0.6,0,0.735 size=0.8,0.8,0.03\n"
                             "object right class=table color=120,90,60\n"
                             "  box center=0.6,0,0.735 size=0.8,0.8,0.03\n";
  const auto apart = run (tables, on);
  ASSERT_TRUE (apart.count (2) && apart.count (3));
  EXPECT_GE (apart.at (2), 0.8);
  EXPECT_GE (apart.at (3), 0.8);
}

TEST (FusionPipeline, AStereoCamerasNoiseIsMeasuredAndItsMapHasNoSplinters)
{
  // The tabletop through the RealSense-like sensor model (σ_z ∝ z², about twice Kinect's
  // beyond a metre, speckle): with the thresholds at Kinect's noise the floor and table
  // break into hundreds of splinters; measured, the map has about one segment per object
  // or stuff surface. Geometry alone, so only the noise thresholds speak.
  simulation::SyntheticSequenceConfig config;
  config.frames = 12;
  config.width = 320;
  config.height = 240;
  config.noise.enabled = true;
  config.noise.sensor = simulation::DepthSensor::RealSense;
  const simulation::SyntheticSequence sequence (simulation::SyntheticScene::load (test::tabletopScenePath ()), config);
  const std::size_t surfaces = sequence.scene ().objects.size ();
  auto largeSegments = [] (pipeline::FusionPipeline& fusion) {
    std::size_t n = 0;
    for (const auto& s : fusion.segments ())
      n += s.voxels >= 100 ? 1 : 0;
    return n;
  };
  pipeline::FusionPipeline measured = withReferencePoses (pipeline::SegmentationMode::Geometry);
  for (std::size_t i = 0; i < sequence.size (); ++i)
    measured.process (*sequence.frame (i), nullptr);
  // The model's ratio to Kinect's is 1.6–2.1 over the scene's 1–4 m.
  EXPECT_GT (measured.noiseScale (), 1.5f);
  EXPECT_LT (measured.noiseScale (), 2.4f);
  const std::size_t measured_segments = largeSegments (measured);
  EXPECT_LE (2 * measured_segments, 5 * surfaces) << surfaces << " objects and stuff surfaces";

  pipeline::FusionPipelineConfig kinect;
  kinect.mode = pipeline::SegmentationMode::Geometry;
  kinect.reconstruction.use_reference_poses = true;
  kinect.geometry.noise_scale = 1.f;  // the thresholds as written, for Kinect-class noise
  pipeline::FusionPipeline fixed (kinect);
  for (std::size_t i = 0; i < sequence.size (); ++i)
    fixed.process (*sequence.frame (i), nullptr);
  EXPECT_FLOAT_EQ (fixed.noiseScale (), 1.f);
  const std::size_t fixed_segments = largeSegments (fixed);
  EXPECT_GT (fixed_segments, 4 * measured_segments);
  if (std::getenv ("CUEFUSION_TEST_VERBOSE"))
    std::cerr << "noise scale " << measured.noiseScale () << ": " << measured_segments << " segments of >= 100 voxels; at 1: "
              << fixed_segments << "; " << surfaces << " surfaces\n";
}

TEST (FusionPipeline, AContinuedMapKeepsItsObjects)
{
  // Frames 0–19 fused and saved (run --save-volume); a new pipeline continues the saved
  // volume with frames 20–39 (run --load-volume). It starts with the saved map's objects
  // under new labels, one for one, and ends as good as one run over all 40 frames.
  simulation::SyntheticSequenceConfig config;
  config.frames = 40;
  config.width = 320;
  config.height = 240;
  const simulation::SyntheticSequence sequence (simulation::SyntheticScene::load (test::tabletopScenePath ()), config);
  const auto truth = sequence.groundTruthCloud ();
  const test::TempDir dir;
  pipeline::FusionPipeline first = withReferencePoses (pipeline::SegmentationMode::Fused);
  fuseFrames (first, sequence, 0, 20);
  first.saveVolume (dir / "volume.tsdf", dir / "volume.labels", dir / "volume.keyframes");
  const auto saved = first.labelledCloud ();

  pipeline::FusionPipeline continued = withReferencePoses (pipeline::SegmentationMode::Fused);
  reconstruction::TSDFVolume volume = reconstruction::TSDFVolume::load (dir / "volume.tsdf");
  segmentation::VoxelLabelLayer labels = segmentation::VoxelLabelLayer::load (dir / "volume.labels", volume);
  reconstruction::KeyframeDatabase keyframes = reconstruction::KeyframeDatabase::load (dir / "volume.keyframes", volume);
  continued.continueFrom (std::move (volume), std::move (labels), std::move (keyframes));
  const auto loaded = continued.labelledCloud ();
  ASSERT_EQ (loaded->size (), saved->size ());
  std::map<std::uint32_t, std::uint32_t> forward, backward;  // saved ↔ loaded labels, one for one
  for (std::size_t i = 0; i < saved->size (); ++i)
  {
    const std::uint32_t a = (*saved)[i].label, b = (*loaded)[i].label;
    ASSERT_EQ (a == 0, b == 0) << i;
    EXPECT_EQ (forward.try_emplace (a, b).first->second, b) << "saved label " << a;
    EXPECT_EQ (backward.try_emplace (b, a).first->second, a) << "loaded label " << b;
  }
  EXPECT_GE (forward.size (), 8u);
  const auto segments = continued.segments ();
  EXPECT_GE (segments.size (), forward.size () - forward.count (0));  // labels on the surface, and maybe inside
  for (const auto& s : segments)
    EXPECT_TRUE (s.loaded) << s.id;

  fuseFrames (continued, sequence, 20, 40);
  pipeline::FusionPipeline whole = withReferencePoses (pipeline::SegmentationMode::Fused);
  fuseFrames (whole, sequence, 0, 40);
  const auto continued_iou = objectIoU (*continued.labelledCloud (), truth);
  const auto whole_iou = objectIoU (*whole.labelledCloud (), truth);
  for (std::uint16_t id = 5; id <= 10; ++id)
  {
    ASSERT_TRUE (continued_iou.count (id) && whole_iou.count (id)) << id;
    if (std::getenv ("CUEFUSION_TEST_VERBOSE"))
      std::cerr << "object " << id << " IoU continued " << continued_iou.at (id) << " one run " << whole_iou.at (id) << "\n";
    EXPECT_GE (continued_iou.at (id), whole_iou.at (id) - 0.1) << "object " << id;
  }
}

namespace
{
/** Map points of each truth object under each map label (nearest truth point within 2 cm). */
struct Contingency
{
  std::map<std::uint16_t, std::map<std::uint32_t, int>> counts;
  std::map<std::uint16_t, int> object_points;
  std::map<std::uint32_t, int> label_points;

  Contingency (const pcl::PointCloud<pcl::PointXYZRGBL>& map, const pcl::PointCloud<pcl::PointXYZRGBL>::Ptr& truth)
  {
    pcl::KdTreeFLANN<pcl::PointXYZRGBL> tree;
    tree.setInputCloud (truth);
    std::vector<int> index (1);
    std::vector<float> distance (1);
    for (const auto& p : map.points)
      if (tree.nearestKSearch (p, 1, index, distance) == 1 && distance[0] < 0.02f * 0.02f)
      {
        const auto object = static_cast<std::uint16_t> ((*truth)[static_cast<std::size_t> (index[0])].label);
        ++counts[object][p.label];
        ++object_points[object];
        ++label_points[p.label];
      }
  }
  /** The label holding most of \a object's points (0 = unlabelled counts too) and its share. */
  std::pair<std::uint32_t, double> majority (std::uint16_t object) const
  {
    std::pair<std::uint32_t, int> best{0, 0};
    for (const auto& [label, n] : counts.at (object))
      if (n > best.second)
        best = {label, n};
    return {best.first, static_cast<double> (best.second) / object_points.at (object)};
  }
  /** Share of \a object's points under \a label. */
  double share (std::uint16_t object, std::uint32_t label) const
  {
    const auto& c = counts.at (object);
    const auto it = c.find (label);
    return it == c.end () ? 0.0 : static_cast<double> (it->second) / object_points.at (object);
  }
};
}  // namespace

TEST (RoomMap, TheFloorAndEachWallAreOneSegmentEachAndNoSegmentSpansTwo)
{
  // Generated rooms (simulation::generateRoom: a kitchen and an office, 3–6 m) along their
  // hand-held paths from 1–4 m, Kinect noise, the true poses, geometry alone (no mask
  // speaks for floors and walls): the floor and each wall the map holds are each one
  // segment (≥ 90 % of its points in one segment, ≥ 90 % of whose points are its), and no
  // segment holds a tenth of two of them. Before the wide crease test
  // (ConcavityEdgeEstimationConfig::wide_step) the floor and the walls seen from across
  // the room were one segment; before flat surfaces were joined
  // (GlobalSegmentMapConfig::surface_min_extent) a floor or wall that furniture parts in
  // every view of the path stayed in pieces (the kitchen's floor 82 % + 17 %, a wall
  // 48 % + 50 %).
  for (const auto& [type, seed] : {std::make_pair (simulation::RoomType::Kitchen, 1u), std::make_pair (simulation::RoomType::Office, 2u)})
  {
    simulation::RoomConfig room;
    room.type = type;
    simulation::SyntheticSequenceConfig config;
    config.frames = 60;
    config.width = 320;
    config.height = 240;
    config.noise.enabled = true;
    config.seed = seed;
    const simulation::SyntheticSequence sequence (simulation::generateRoom (room, seed), config);
    const auto truth = sequence.groundTruthCloud ();
    const auto run = [&] (int wide_step, float surface_min_extent) {
      pipeline::FusionPipelineConfig settings;
      settings.mode = pipeline::SegmentationMode::Geometry;
      settings.reconstruction.use_reference_poses = true;
      settings.geometry.concavity.wide_step = wide_step;
      settings.merging.surface_min_extent = surface_min_extent;
      pipeline::FusionPipeline fusion (settings);
      for (std::size_t i = 0; i < sequence.size (); ++i)
        fusion.process (*sequence.frame (i), nullptr);
      return Contingency (*fusion.labelledCloud (), truth);
    };
    const int wide_step = segmentation::ConcavityEdgeEstimationConfig ().wide_step;
    const float surface_min_extent = segmentation::GlobalSegmentMapConfig ().surface_min_extent;
    const Contingency c = run (wide_step, surface_min_extent);
    std::vector<std::uint16_t> stuff;  // the floor first, then the walls the map holds
    for (const simulation::SceneObject& o : sequence.scene ().objects)
      if ((o.class_name == "floor" || o.class_name == "wall") && c.object_points.count (o.id) && c.object_points.at (o.id) >= 1000)
        stuff.push_back (o.id);
    const std::string where = std::string (simulation::roomTypeName (type)) + " seed " + std::to_string (seed);
    ASSERT_GE (stuff.size (), 3u) << where;
    ASSERT_EQ (sequence.scene ().objectById (stuff[0])->class_name, "floor") << where;
    // Segments holding a tenth of two of them.
    const auto spanning = [&stuff] (const Contingency& m) {
      int n = 0;
      for (std::size_t a = 0; a < stuff.size (); ++a)
        for (std::size_t b = a + 1; b < stuff.size (); ++b)
          for (const auto& [label, count] : m.counts.at (stuff[a]))
            n += label != 0 && m.share (stuff[a], label) >= 0.1 && m.counts.count (stuff[b]) && m.share (stuff[b], label) >= 0.1 ? 1 : 0;
      return n;
    };
    EXPECT_EQ (spanning (c), 0) << where;
    // Each of them one segment.
    const auto whole = [&stuff] (const Contingency& m) {
      int n = 0;
      for (const std::uint16_t id : stuff)
      {
        const auto [label, share] = m.majority (id);
        n += label != 0 && share >= 0.9 && static_cast<double> (m.counts.at (id).at (label)) / m.label_points.at (label) >= 0.9 ? 1 : 0;
      }
      return n;
    };
    EXPECT_EQ (whole (c), static_cast<int> (stuff.size ())) << where;
    if (type == simulation::RoomType::Kitchen)  // the preconditions, once: without the wide test they are one,
    {                                           // without joining flat surfaces some are in pieces
      EXPECT_GE (spanning (run (0, surface_min_extent)), 3) << where;
      EXPECT_LT (whole (run (wide_step, 0.f)), static_cast<int> (stuff.size ())) << where;
    }
    if (std::getenv ("CUEFUSION_TEST_VERBOSE"))
      for (const std::uint16_t id : stuff)
      {
        std::cerr << where << ": " << sequence.scene ().objectById (id)->name << " " << c.object_points.at (id) << " points:";
        for (const auto& [label, n] : c.counts.at (id))
          if (n >= 0.02 * c.object_points.at (id))
            std::cerr << " " << label << " " << static_cast<double> (n) / c.object_points.at (id) << " (of " << c.label_points.at (label) << ")";
        std::cerr << "\n";
      }
  }
}

TEST (RoomMap, ACrowdedCounterKeepsItsObjectsApart)
{
  // Generated kitchens (the first three seeds), their counters crowded with small objects
  // touching one another (boxes flush against boxes, cans against balls, books and boxes
  // lying flat, a sphere on a sphere), 640×480 with Kinect noise and grazing-angle dropout,
  // seen along the hand-held path from 1–4 m with the true poses, fused with a detector of
  // typical errors (boundaries 1–2 px off, 10 % merged pairs, 5 % misses, false
  // positives). Of the objects on the counters the map holds (≥ 100 points), at least 90 %
  // are each the majority of a segment of their own: not unlabelled, not in the counter's
  // or the wall's segment, not sharing one with a neighbour. Before 2026-11-28 a flat box
  // stayed in the counter (the masks only grouped segments) and objects the dropout
  // speckled, or that met a claimed neighbour in a pixel or two, were lost.
  for (const unsigned seed : {1u, 2u, 3u})
  {
    simulation::RoomConfig room;
    room.type = simulation::RoomType::Kitchen;
    simulation::SyntheticSequenceConfig config;
    config.frames = 60;
    config.noise.enabled = true;
    config.seed = seed;
    config.detector.boundary_px = 1;
    config.detector.boundary_jitter_px = 1;
    config.detector.merge_probability = 0.1;
    config.detector.miss_probability = 0.05;
    config.detector.false_positives = 0.2;
    const simulation::SyntheticSequence sequence (simulation::generateRoom (room, seed), config);
    pipeline::FusionPipeline fusion = runSequence (pipeline::SegmentationMode::Fused, sequence);
    const Contingency c (*fusion.labelledCloud (), sequence.groundTruthCloud ());
    std::vector<Eigen::AlignedBox3d> counters;
    for (const simulation::SceneObject& o : sequence.scene ().objects)
      if (o.class_name == "counter")
        counters.push_back (o.bounds ());
    ASSERT_FALSE (counters.empty ()) << "seed " << seed;
    std::map<std::uint16_t, std::uint32_t> majority;  // counter object → the label holding most of it
    std::map<std::uint32_t, int> holders;             // label → counter objects it is the majority of
    for (const simulation::SceneObject& o : sequence.scene ().objects)
    {
      const Eigen::AlignedBox3d box = o.bounds ();
      const bool on_counter = o.detectable && std::any_of (counters.begin (), counters.end (), [&] (const Eigen::AlignedBox3d& top) {
        return std::abs (box.min ().z () - top.max ().z ()) < 1e-3 &&
               top.contains (Eigen::Vector3d (box.center ().x (), box.center ().y (), top.center ().z ()));
      });
      if (on_counter && c.object_points.count (o.id) && c.object_points.at (o.id) >= 100)
        ++holders[majority[o.id] = c.majority (o.id).first];
    }
    int apart = 0;
    for (const auto& [object, label] : majority)
    {
      const bool own = label != 0 && holders.at (label) == 1 && 2 * c.counts.at (object).at (label) >= c.label_points.at (label);
      apart += own ? 1 : 0;
      if (!own || std::getenv ("CUEFUSION_TEST_VERBOSE"))
        std::cerr << "seed " << seed << ": " << sequence.scene ().objectById (object)->name << " " << c.object_points.at (object)
                  << " points, " << c.share (object, label) << " in segment " << label << " (of " << c.label_points.at (label)
                  << ", the majority of " << holders.at (label) << " objects)" << (own ? "" : ": not apart") << "\n";
    }
    EXPECT_GE (majority.size (), 8u) << "seed " << seed;
    EXPECT_GE (apart, 0.9 * static_cast<double> (majority.size ())) << "seed " << seed << ": " << apart << " of " << majority.size ();
  }
}

TEST (RoomRange, ANoisierSensorIsTrackedInARoom)
{
  // Generated rooms' hand-held paths (1–4 m from the walls) through the RealSense-like model
  // (depth noise about twice the Kinect's, which the pipeline measures): every frame after
  // the first is tracked to within 3 cm, and is not when the setting that follows the noise
  // is held at the Kinect's.
  // - A kitchen seen from across (30 frames): the ICP normal gate
  //   (ProjectiveICPConfig::noise_scale). Held, most of a frame's points are outliers and
  //   the frames after the first are lost (with the truncation following the noise too).
  // - A living room, its walls 3–4 m away (15 frames): the TSDF truncation
  //   (TSDFVolumeConfig::truncation_voxels, set by FusionPipeline for the measured noise).
  //   Held at 4 voxels, the noise (≈ 4 cm there) reaches the truncation, a single frame's
  //   zero crossing is ragged and its raycast full of holes: 24 % of the second frame's
  //   points met the model and passed the gates, and all 149 frames after the first were lost.
  enum class Held { Gate, Truncation };
  struct Case
  {
    simulation::RoomType type;
    unsigned seed;
    std::size_t frames;
    Held held;
  };
  for (const Case& test : {Case{simulation::RoomType::Kitchen, 1u, 30, Held::Gate},
                           Case{simulation::RoomType::Living, 1u, 15, Held::Truncation}})
  {
    const std::string where = std::string (simulation::roomTypeName (test.type)) + " seed " + std::to_string (test.seed);
    simulation::RoomConfig room;
    room.type = test.type;
    simulation::SyntheticSequenceConfig config;
    config.frames = 150;  // the path's own pace; the first test.frames are run
    config.noise.enabled = true;
    config.noise.sensor = simulation::DepthSensor::RealSense;
    config.seed = test.seed;
    const simulation::SyntheticSequence sequence (simulation::generateRoom (room, test.seed), config);
    // held_by divides the setting (the pipeline multiplies it by the measured scale): the
    // measured scale holds it at the Kinect's.
    const auto run = [&] (double held_by, float& noise_scale) {
      pipeline::FusionPipelineConfig settings;
      settings.mode = pipeline::SegmentationMode::Geometry;
      if (test.held == Held::Gate)
        settings.reconstruction.tracking.icp.noise_scale /= held_by;
      else
        settings.reconstruction.volume.truncation_voxels /= held_by;
      pipeline::FusionPipeline fusion (settings);
      int tracked = 0;
      double worst = 0.0;
      for (std::size_t i = 0; i < test.frames; ++i)
      {
        const auto frame = sequence.frame (i);
        const pipeline::PipelineFrameReport report = fusion.process (*frame, nullptr);
        if (std::getenv ("CUEFUSION_TEST_VERBOSE"))
          std::cerr << where << " frame " << i << ": " << (report.reconstruction.tracked ? "tracked" : report.reconstruction.failure)
                    << ", gate " << report.reconstruction.icp.normal_gate_deg << "°, error "
                    << (report.reconstruction.pose.translation () - frame->pose->translation ()).norm () << " m\n";
        if (i > 0 && report.reconstruction.tracked)
        {
          ++tracked;
          worst = std::max (worst, (report.reconstruction.pose.translation () - frame->pose->translation ()).norm ());
        }
      }
      noise_scale = fusion.noiseScale ();
      return std::make_pair (tracked, worst);
    };
    float scale = 0.f, held_scale = 0.f;
    const auto [tracked, worst] = run (1.0, scale);
    EXPECT_GT (scale, 1.5f) << where;
    EXPECT_EQ (tracked, static_cast<int> (test.frames) - 1) << where;
    EXPECT_LT (worst, 0.03) << where;
    const auto held = run (scale, held_scale);
    EXPECT_LT (held.first, static_cast<int> (test.frames) / 2) << where << ": a case the Kinect's setting tracks does not test this";
  }
}

namespace
{
/** The printed clutter seen from its 0° side (start drawn in ±10°) at \a rates degrees a
  * frame (drawn), the depth blank for \a gaps frames (drawn) after the first 10, then 30
  * frames more, through FusionPipeline (the measured noise scale sets ICP's gates and the
  * truncation), \a draws times: every tracked frame within 2 cm of the truth, and at least
  * \a share of the frames after the gap tracked. */
void
expectTrackedAfterBlackouts (std::uint32_t seed, int draws, std::pair<std::size_t, std::size_t> gaps,
                             std::pair<double, double> rates, double share)
{
  std::mt19937 random (seed);
  const std::string path = std::string (CUEFUSION_TEST_DATA_DIR) + "/scenes/clutter.scene";
  for (int draw = 0; draw < draws; ++draw)
  {
    const std::size_t gap = std::uniform_int_distribution<std::size_t> (gaps.first, gaps.second) (random);
    const double rate = std::uniform_real_distribution<double> (rates.first, rates.second) (random);
    const double start = std::uniform_real_distribution<double> (-10.0, 10.0) (random);
    const std::size_t begin = 10, end = begin + gap, frames = end + 30;
    const std::string trajectory =
      test::changedTrajectory (path, {{"start", start}, {"sweep", rate * static_cast<double> (frames - 1)}, {"bob", 0.03}});
    SCOPED_TRACE (std::to_string (gap) + " frames blank at " + std::to_string (rate) + "° a frame from " + std::to_string (start) + "°");
    simulation::SyntheticSequenceConfig config;
    config.frames = frames;
    config.noise.enabled = true;
    config.seed = seed + static_cast<std::uint64_t> (draw);
    const simulation::SyntheticSequence sequence (
      simulation::SyntheticScene::parse (test::printedSceneText (path, trajectory), "clutter printed"), config);
    pipeline::FusionPipelineConfig settings;
    settings.mode = pipeline::SegmentationMode::Geometry;
    pipeline::FusionPipeline fusion (settings);
    std::size_t after = 0;
    for (std::size_t i = 0; i < frames; ++i)
    {
      const RGBDFrame::Ptr frame = sequence.frame (i);
      const Eigen::Isometry3d truth = *frame->pose;
      if (i >= begin && i < end)
        frame->depth.setTo (0.f);
      const pipeline::PipelineFrameReport report = fusion.process (*frame, nullptr);
      if (!report.reconstruction.tracked)
        continue;
      after += i >= end ? 1 : 0;
      EXPECT_LT ((report.reconstruction.pose.translation () - truth.translation ()).norm (), 0.02) << "frame " << i;
    }
    EXPECT_GE (static_cast<double> (after), share * static_cast<double> (frames - end));
  }
}
}  // namespace

TEST (FusionPipeline, AfterABlackoutTheCameraIsFoundWhereItTurnedTo)
{
  // 20–30 frames blank at 1.2–1.6° a frame: the camera turned 25–45° meanwhile. ICP from the
  // motion carried through the gap finds the right pose, but judged against the model
  // raycast at the last pose before the gap half its matches meet other surfaces (the
  // boxes' faces that turned into view) and the drop in agreement refuses it. Verified as
  // the motion model's candidate — raycast at its own pose — it passes (before: every later
  // frame lost, as in the stress matrix's clutter blackout of 25 frames).
  expectTrackedAfterBlackouts (34, 2, {20, 30}, {1.2, 1.6}, 0.7);
}

TEST (FusionPipeline, APoseICPFindsAfterASuddenTurnIsVerifiedBeforeItIsFused)
{
  // The held-out draw of `scripts/bench tracking` that found it (tabletop, seed 10): the
  // printed tabletop orbit at 1.5° a frame, ten frames, then the camera 90° further on from
  // one frame to the next (the stamps hide it) and on for 30 frames. Fifteen frames into
  // the turn ICP from the last tracked pose converged 2.2 m off with 45 % of its matches
  // agreeing with the model raycast at that pose — within every check — and was fused, and
  // every later frame tracked from there. The first pose after lost frames is now verified
  // at its own raycast (agreement, texture): no frame reported tracked may be off.
  const std::string path = test::tabletopScenePath ();
  const std::string trajectory = test::changedTrajectory (path, {{"start", 262.91}, {"sweep", 148.5}, {"bob", 0.03}});
  simulation::SyntheticSequenceConfig config;
  config.frames = 100;
  config.noise.enabled = true;
  config.seed = 10;
  const simulation::SyntheticSequence sequence (
    simulation::SyntheticScene::parse (test::printedSceneText (path, trajectory), "tabletop printed"), config);
  pipeline::FusionPipelineConfig settings;
  settings.mode = pipeline::SegmentationMode::Geometry;
  pipeline::FusionPipeline fusion (settings);
  int tracked = 0;
  for (std::size_t k = 0; k < 40; ++k)  // frames 0–9 and 70–99, with the stamps of 0–39
  {
    const RGBDFrame::Ptr frame = sequence.frame (k < 10 ? k : k + 60);
    frame->timestamp -= static_cast<double> (k < 10 ? 0 : 60) / config.fps;
    const Eigen::Isometry3d truth = *frame->pose;
    const pipeline::PipelineFrameReport report = fusion.process (*frame, nullptr);
    if (!report.reconstruction.tracked)
      continue;
    ++tracked;
    EXPECT_LT ((report.reconstruction.pose.translation () - truth.translation ()).norm (), 0.03) << "frame " << k;
  }
  EXPECT_GE (tracked, 10);
}

TEST (FusionPipeline, AfterALongBlackoutTheTextureConfirmsWhereTheCameraIs)
{
  // 40–55 frames blank at 1.3–1.7° a frame: the camera turned 52–94°, and raycast at ICP's
  // right pose the map of the first ten frames covers a quarter of the view — less than
  // relocalisation_min_overlap and the tracker's min_inlier_fraction (before: every later
  // frame lost, as in the stress matrix's clutter blackout of 50 frames). The frame's texture
  // lining up with the map's colours there confirms it.
  expectTrackedAfterBlackouts (52, 2, {40, 55}, {1.3, 1.7}, 0.5);
}
