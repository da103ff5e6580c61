// FusionPipeline on generated sequences, scored against the generator's labelled
// ground-truth cloud.
#include "test_utils.h"

#include <cuefusion/io/synthetic_sequence.h>
#include <cuefusion/pipeline/fusion_pipeline.h>

#include <gtest/gtest.h>
#include <pcl/kdtree/kdtree_flann.h>

#include <cstdlib>
#include <iostream>
#include <map>
#include <set>

using namespace cuefusion;

namespace
{
/** Runs the pipeline over a 320×240 tabletop orbit with the sequence's poses. */
pipeline::FusionPipeline
runSequence (pipeline::SegmentationMode mode, const io::SyntheticSequence& sequence)
{
  pipeline::FusionPipelineConfig config;
  config.mode = mode;
  config.reconstruction.use_reference_poses = true;
  pipeline::FusionPipeline fusion (config);
  for (std::size_t i = 0; i < sequence.size (); ++i)
  {
    const RGBDFrame::Ptr frame = sequence.frame (i);
    const std::vector<Instance> instances = io::toInstances (sequence.detections (*frame));
    const auto report = fusion.process (*frame, &instances);
    EXPECT_TRUE (report.segmented) << i;
  }
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
      continue;
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
    const double iou = static_cast<double> (n) / (object_size[key.first] + segment_size[key.second] - n);
    best[key.first] = std::max (best[key.first], iou);
  }
  return best;
}
}  // namespace

TEST (FusionPipeline, LabelledMapMatchesTheGroundTruthAndFusionBeatsGeometry)
{
  io::SyntheticSequenceConfig config;
  config.frames = 30;
  const io::SyntheticSequence sequence (io::SyntheticScene::load (test::tabletopScenePath ()), config);
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
  io::SyntheticSequenceConfig config;
  config.frames = 30;
  const io::SyntheticSequence sequence (io::SyntheticScene::parse (text, "occluder scene"), config);
  pipeline::FusionPipelineConfig pipeline_config;
  pipeline_config.mode = pipeline::SegmentationMode::Geometry;
  pipeline_config.reconstruction.use_reference_poses = true;
  pipeline::FusionPipeline fusion (pipeline_config);
  std::size_t merges = 0;
  bool split_at_first = false;
  for (std::size_t i = 0; i < sequence.size (); ++i)
  {
    const RGBDFrame::Ptr frame = sequence.frame (i);
    merges += fusion.process (*frame, nullptr).merges;
    if (i == 0)
    {
      // The precondition: the box is seen in two parts with two labels.
      std::set<std::int32_t> labels;
      const cv::Mat& lp = fusion.frameLabels ();
      for (int y = 0; y < lp.rows; ++y)
        for (int x = 0; x < lp.cols; ++x)
          if (frame->instance_mask.at<std::uint16_t> (y, x) == 3 && lp.at<std::int32_t> (y, x) > 0)
            labels.insert (lp.at<std::int32_t> (y, x));
      split_at_first = labels.size () >= 2;
    }
  }
  ASSERT_TRUE (split_at_first);
  EXPECT_GE (merges, 1u);
  const auto iou = objectIoU (*fusion.labelledCloud (), sequence.groundTruthCloud ());
  ASSERT_TRUE (iou.count (3));
  EXPECT_GE (iou.at (3), 0.8);  // one segment for the whole box
}
