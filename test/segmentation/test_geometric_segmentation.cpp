// SPDX-License-Identifier: BSD-3-Clause
// GeometricSegmentation (§4.2.1.1) on synthetic views, scored against the generator's
// exact instance masks; the edge operators on analytic geometry; bad input.
#include "segmentation_fixtures.h"

#include <cuefusion/segmentation/concavity_edge_estimation.h>
#include <cuefusion/segmentation/depth_discontinuity_edge_estimation.h>
#include <cuefusion/segmentation/support_plane_removal.h>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

using namespace cuefusion;
using test::scoreObject;
using test::segmentScene;

namespace
{
using test::kTable;
using test::kTwoBoxes;
using test::kTableTarget;
using test::kObliqueEye;
const std::string kConvex = kTable +
                            "object box class=box color=200,40,40\n"
                            "  box center=-0.25,0.05,0.80 size=0.16,0.12,0.12 yaw=30\n"
                            "object ball class=ball color=40,60,210\n"
                            "  sphere center=0.0,-0.05,0.81 radius=0.07\n"
                            "object can class=can color=40,160,80\n"
                            "  cylinder center=0.25,0.05,0.82 radius=0.05 height=0.16\n";
const std::string kLBlock = kTable +
                            "object lblock class=block color=150,60,170\n"
                            "  box center=0.0,0.0,0.79 size=0.20,0.06,0.10\n"
                            "  box center=-0.07,-0.08,0.79 size=0.06,0.10,0.10\n";  // inner corner faces the camera
const std::string kWall = "object floor class=floor color=170,165,150 detectable=no\n"
                          "  box center=0,0,-0.01 size=4,4,0.02\n"
                          "object wall class=wall color=200,200,190 detectable=no\n"
                          "  box center=0,1.2,1.0 size=4,0.1,2.0\n"
                          "object crate class=box color=200,120,40\n"
                          "  box center=0,0.5,0.7 size=0.3,0.3,0.3\n";  // floats 0.55 m above the floor, 0.5 m before the wall
}  // namespace

// Thresholds, stated before running: noise-free views reproduce each object closely
// (IoU ≥ 0.85: the edge band is given back to the segments, but faces seen at grazing
// angles, a few pixels wide, are all depth edge and stay 0); with the Kinect noise model
// on, IoU ≥ 0.75 and convex objects stay in one piece.

TEST (GeometricSegmentation, TouchingBoxesAreSeparatedByTheConcaveSeam)
{
  for (const bool noise : {false, true})
  {
    const auto s = segmentScene (kTwoBoxes, kObliqueEye, kTableTarget, noise);
    const auto a = scoreObject (s, 2), b = scoreObject (s, 3);
    ASSERT_GT (a.pixels, 2000);
    ASSERT_GT (b.pixels, 2000);
    EXPECT_NE (a.best_label, b.best_label) << "noise " << noise;
    EXPECT_GE (a.best_iou, noise ? 0.75 : 0.85) << "noise " << noise;
    EXPECT_GE (b.best_iou, noise ? 0.75 : 0.85) << "noise " << noise;
  }
}

TEST (GeometricSegmentation, WithoutConcavityEdgesTouchingBoxesMerge)
{
  // Ablation: the concave seam is the only cue between the two boxes.
  segmentation::GeometricSegmentationConfig config;
  config.use_concavity_edges = false;
  const auto s = segmentScene (kTwoBoxes, kObliqueEye, kTableTarget, false, config);
  EXPECT_EQ (scoreObject (s, 2).best_label, scoreObject (s, 3).best_label);
}

TEST (GeometricSegmentation, BoxIsSeparatedFromTheTable)
{
  for (const bool noise : {false, true})
  {
    const auto s = segmentScene (kTwoBoxes, Eigen::Vector3d (-0.5, -0.9, 1.35), kTableTarget, noise);
    const auto table = scoreObject (s, 1), a = scoreObject (s, 2);
    EXPECT_NE (table.best_label, a.best_label) << "noise " << noise;
    EXPECT_GE (a.best_iou, noise ? 0.75 : 0.85) << "noise " << noise;
    EXPECT_GE (table.best_iou, noise ? 0.75 : 0.85) << "noise " << noise;
  }
}

TEST (GeometricSegmentation, ConvexObjectsSeenObliquelyStayWhole)
{
  for (const bool noise : {false, true})
  {
    const auto s = segmentScene (kConvex, kObliqueEye, kTableTarget, noise);
    for (const std::uint16_t id : {2, 3, 4})
    {
      const auto score = scoreObject (s, id);
      ASSERT_GT (score.pixels, 1500) << "object " << id;
      EXPECT_EQ (score.segments, 1) << "object " << id << " noise " << noise;
      EXPECT_GE (score.coverage, noise ? 0.85 : 0.9) << "object " << id << " noise " << noise;
      EXPECT_GE (score.best_iou, noise ? 0.75 : 0.85) << "object " << id << " noise " << noise;
    }
  }
}

TEST (GeometricSegmentation, ObjectBeforeAWallIsCutAtTheDepthJump)
{
  for (const bool noise : {false, true})
  {
    const auto s = segmentScene (kWall, Eigen::Vector3d (0.2, -1.2, 1.0), Eigen::Vector3d (0, 0.5, 0.7), noise);
    const auto crate = scoreObject (s, 3), wall = scoreObject (s, 2);
    ASSERT_GT (crate.pixels, 5000);
    EXPECT_NE (crate.best_label, wall.best_label);
    EXPECT_EQ (crate.segments, 1) << "noise " << noise;
    EXPECT_GE (crate.best_iou, noise ? 0.75 : 0.85) << "noise " << noise;
  }
}

TEST (GeometricSegmentation, NonConvexBlocks)
{
  // Documented behaviour. An extruded L (the tabletop scene's block) has a concave
  // vertical crease, which is marked, but its flat top joins both arms: one segment.
  {
    const auto s = segmentScene (kLBlock, kObliqueEye, kTableTarget, false);
    const auto block = scoreObject (s, 2);
    ASSERT_GT (block.pixels, 2000);
    EXPECT_EQ (block.segments, 1);
    EXPECT_GE (block.best_iou, 0.85);
    EXPECT_NE (block.best_label, scoreObject (s, 1).best_label);
  }
  // With one arm taller, the crease runs all round and the concavity cue cuts the block
  // into its two convex parts; the instance cue (InstanceGuidedRegionMerge) re-unites them.
  {
    std::string stepped = kLBlock;
    stepped.replace (stepped.find ("center=-0.07,-0.08,0.79 size=0.06,0.10,0.10"),
                     std::string ("center=-0.07,-0.08,0.79 size=0.06,0.10,0.10").size (),
                     "center=-0.07,-0.08,0.815 size=0.06,0.10,0.15");
    const auto s = segmentScene (stepped, kObliqueEye, kTableTarget, false);
    const auto block = scoreObject (s, 2);
    ASSERT_GT (block.pixels, 2000);
    EXPECT_EQ (block.segments, 2);
    EXPECT_LT (block.coverage, 0.9);
  }
}

TEST (GeometricSegmentation, LabelsAreValidDepthOnlyAndRepeatable)
{
  const auto s1 = segmentScene (kConvex, kObliqueEye, kTableTarget, true);
  const auto s2 = segmentScene (kConvex, kObliqueEye, kTableTarget, true);
  EXPECT_EQ (cv::countNonZero (s1.labels != s2.labels), 0);
  // Pixels without depth carry a label only inside the small holes the preprocessing
  // fills (max_hole_pixels, not open to the border); the labelled cloud has none there.
  cv::Mat missing = s1.view.depth <= 0.f, holes, stats, centroids;
  cv::connectedComponentsWithStats (missing, holes, stats, centroids, 8, CV_32S);
  const int max_hole = segmentation::SurfacePreprocessingConfig ().max_hole_pixels;
  pcl::PointCloud<pcl::PointXYZRGBL> labelled;
  segmentation::toLabelledCloud (*s1.cloud, s1.labels, labelled);
  int filled = 0;
  for (int y = 0; y < s1.labels.rows; ++y)
    for (int x = 0; x < s1.labels.cols; ++x)
      if (!(s1.view.depth.at<float> (y, x) > 0.f))
      {
        ASSERT_EQ (labelled (x, y).label, 0u) << x << "," << y;
        if (s1.labels.at<std::int32_t> (y, x) == 0)
          continue;
        ++filled;
        const int hole = holes.at<std::int32_t> (y, x);
        ASSERT_LE (stats.at<int> (hole, cv::CC_STAT_AREA), max_hole) << x << "," << y;
        ASSERT_GT (stats.at<int> (hole, cv::CC_STAT_LEFT), 0);
        ASSERT_GT (stats.at<int> (hole, cv::CC_STAT_TOP), 0);
      }
  EXPECT_LT (filled, cv::countNonZero (missing));
}

TEST (GeometricSegmentation, AFarTableSeenAtAGrazingAngleIsOneSegment)
{
  // Kinect noise, the camera 2.4–3.2 m from a table with objects, 20–30° above its top
  // (60–70° incidence): the depth changes by more than the 2 % edge rule over the
  // normals' ±4 px. The table top is one segment (≥ 90 % of it; before 2026-11-26 0.68–0.84
  // at 20°, its pixels without normals all depth edges) and no object joins it, from
  // either side. (Beyond 70° the sensor model drops a rising share of the pixels, half at
  // 75°: such a top is a sieve in one frame and left to the map.)
  for (const double distance : {2.4, 3.2})
    for (const double elevation : {20.0, 30.0})
      for (const double azimuth : {-100.0, -70.0})
      {
        const double a = azimuth * M_PI / 180.0, e = elevation * M_PI / 180.0;
        const Eigen::Vector3d eye =
          kTableTarget + distance * Eigen::Vector3d (std::cos (e) * std::cos (a), std::cos (e) * std::sin (a), std::sin (e));
        const auto s = segmentScene (kConvex, eye, kTableTarget, true);
        const auto table = scoreObject (s, 1);
        const std::string where = "distance " + std::to_string (distance) + " elevation " + std::to_string (elevation) +
                                  " azimuth " + std::to_string (azimuth);
        ASSERT_GT (table.pixels, 5000) << where;
        EXPECT_GE (table.coverage, 0.9) << where;
        for (const std::uint16_t id : {2, 3, 4})
          EXPECT_NE (scoreObject (s, id).best_label, table.best_label) << "object " << id << ", " << where;
      }
}

TEST (GeometricSegmentation, AStereoCamerasFrameIsSegmentedAtItsMeasuredNoise)
{
  // The RealSense-like model (σ_z ∝ z², speckle, fattened edges, holes on dark surfaces)
  // from 1.6–2.4 m: the class on the raw cloud with its defaults measures the frame's
  // noise (about twice Kinect's) and keeps the table whole (and, at 1.6 m, the objects
  // apart); the thresholds left at Kinect's noise (noise_scale 1) break the table up.
  const simulation::SyntheticScene scene =
    simulation::SyntheticScene::parse ("scene test\ncamera 640 480 525 525 319.5 239.5\n" + kConvex, "test scene");
  simulation::DepthNoiseConfig stereo;
  stereo.enabled = true;
  stereo.sensor = simulation::DepthSensor::RealSense;
  for (const double distance : {1.6, 2.4})
  {
    const double a = -80.0 * M_PI / 180.0, e = 25.0 * M_PI / 180.0;
    const Eigen::Vector3d eye =
      kTableTarget + distance * Eigen::Vector3d (std::cos (e) * std::cos (a), std::cos (e) * std::sin (a), std::sin (e));
    test::SegmentedView s;
    s.view = simulation::SceneRenderer (scene).render (scene.camera, test::lookAt (eye, kTableTarget), stereo, 5);
    s.cloud = test::cloudFromDepth (s.view.depth, scene.camera);
    auto coverage = [&] (float noise_scale, float* measured) {
      segmentation::GeometricSegmentationConfig config;
      config.noise_scale = noise_scale;
      segmentation::GeometricSegmentation<pcl::PointXYZ, pcl::Normal> segmentation (config);
      segmentation.setInputCloud (s.cloud);
      pcl::PointCloud<pcl::Label> labels;
      segmentation.segment (labels);
      s.labels = segmentation.getLabelImage ().clone ();
      if (measured)
        *measured = segmentation.getNoiseScale ();
      return scoreObject (s, 1);
    };
    float scale = 0.f;
    const auto table = coverage (0.f, &scale);
    const std::string where = "distance " + std::to_string (distance);
    EXPECT_GT (scale, 1.4f) << where;
    EXPECT_LT (scale, 2.4f) << where;
    EXPECT_GE (table.coverage, 0.9) << where;
    // At 2.4 m (σ_z ≈ 1.8 cm) whether a small object's base shows a closed crease in one
    // frame turns on single pixels, at either scale (the can joins the table at 1, the
    // ball at the measured scale): left to the map, which sees many frames.
    if (distance < 2.0)
    {
      for (const std::uint16_t id : {2, 3, 4})
        EXPECT_NE (scoreObject (s, id).best_label, table.best_label) << "object " << id << ", " << where;
    }
    const auto at_kinects = coverage (1.f, nullptr);
    EXPECT_LT (at_kinects.coverage, table.coverage - 0.1) << where;
    if (std::getenv ("CUEFUSION_TEST_VERBOSE"))
      std::cerr << where << ": scale " << scale << ", table coverage " << table.coverage << ", at 1: " << at_kinects.coverage << "\n";
  }
}

TEST (SupportPlaneRemoval, DropsTheTableAndKeepsTheObjects)
{
  auto s = segmentScene (kConvex, kObliqueEye, kTableTarget, true);
  segmentation::SupportPlaneRemoval<pcl::PointXYZ> removal;
  removal.setInputCloud (s.smoothed);
  removal.setInputNormals (s.normals);
  ASSERT_TRUE (removal.apply (s.labels));
  // The table top is z = 0.74 in the world: its normal is the camera's view of world up.
  const Eigen::Isometry3d pose = test::lookAt (kObliqueEye, kTableTarget);
  const Eigen::Vector3f up = (pose.linear ().transpose () * Eigen::Vector3d::UnitZ ()).cast<float> ();
  EXPECT_GT (std::abs (removal.getPlane ().head<3> ().dot (up)), 0.99f);
  const auto table = scoreObject (s, 1);
  EXPECT_LT (table.best_iou, 0.05);
  for (const std::uint16_t id : {2, 3, 4})
    EXPECT_GE (scoreObject (s, id).best_iou, 0.75) << "object " << id;
}
