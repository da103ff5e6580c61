// SPDX-License-Identifier: BSD-3-Clause
#include "synthetic_fixtures.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/simulation/scene_renderer.h>
#include <cuefusion/simulation/simulated_detector.h>
#include <cuefusion/simulation/synthetic_sequence.h>

#include <gtest/gtest.h>

#include <random>
#include <pcl/io/pcd_io.h>
#include <pcl/kdtree/kdtree_flann.h>

#include <cmath>
#include <set>

using namespace cuefusion;

namespace
{
simulation::SyntheticScene
sceneFromText (const std::string& text)
{
  return simulation::SyntheticScene::parse (text, "test.scene");
}

simulation::SyntheticScene
tabletop ()
{
  return simulation::SyntheticScene::load (test::tabletopScenePath ());
}
}  // namespace

TEST (SceneRenderer, SphereDepthMatchesAnalyticIntersection)
{
  const simulation::SyntheticScene scene = sceneFromText ("object ball\n sphere center=0.1,-0.05,3 radius=0.5\n");
  const PinholeCamera cam (100, 100, 39.5, 29.5, 80, 60);
  const simulation::RenderedView view = simulation::SceneRenderer (scene).render (cam, Eigen::Isometry3d::Identity ());
  int hits = 0;
  const Eigen::Vector3d c (0.1, -0.05, 3.0);
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u)
    {
      const Eigen::Vector3d d = Eigen::Vector3d ((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0).normalized ();
      const double b = d.dot (c), disc = b * b - (c.squaredNorm () - 0.25);
      const float z = view.depth.at<float> (v, u);
      const std::uint16_t id = view.instance.at<std::uint16_t> (v, u);
      if (disc < 0)
      {
        EXPECT_EQ (z, 0.f);
        EXPECT_EQ (id, 0);
        continue;
      }
      ++hits;
      EXPECT_EQ (id, 1);
      EXPECT_NEAR (z, (b - std::sqrt (disc)) * d.z (), 1e-5);
    }
  EXPECT_GT (hits, 500);
}

TEST (SceneRenderer, NearestSurfaceWinsAndBoxFaceIsFlat)
{
  const simulation::SyntheticScene scene = sceneFromText (
    "object wall\n box center=0,0,2.05 size=10,10,0.1\nobject cube\n box center=0,0,1.0 size=0.2,0.2,0.2 yaw=30\n");
  const PinholeCamera cam (100, 100, 39.5, 29.5, 80, 60);
  const simulation::RenderedView view = simulation::SceneRenderer (scene).render (cam, Eigen::Isometry3d::Identity ());
  EXPECT_NEAR (view.depth.at<float> (0, 0), 2.0f, 1e-6);
  EXPECT_EQ (view.instance.at<std::uint16_t> (0, 0), 1);
  EXPECT_NEAR (view.depth.at<float> (29, 39), 0.9f, 1e-5);  // front face of the cube
  EXPECT_EQ (view.instance.at<std::uint16_t> (29, 39), 2);
  EXPECT_EQ (view.class_ids.at<std::uint16_t> (29, 39), 2);
}

TEST (SceneRenderer, NoiseFollowsTheAxialModel)
{
  const simulation::SyntheticScene scene = sceneFromText ("object wall\n box center=0,0,2.05 size=10,10,0.1\n");
  const PinholeCamera cam (300, 300, 79.5, 59.5, 160, 120);
  simulation::DepthNoiseConfig noise;
  noise.enabled = true;
  const simulation::SceneRenderer renderer (scene);
  const simulation::RenderedView exact = renderer.render (cam, Eigen::Isometry3d::Identity ());
  const simulation::RenderedView noisy = renderer.render (cam, Eigen::Isometry3d::Identity (), noise, 7);
  double sum = 0, sum_sq = 0;
  int n = 0;
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u)
    {
      const double z = exact.depth.at<float> (v, u);
      const Eigen::Vector3d d = Eigen::Vector3d ((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0).normalized ();
      const double r = (noisy.depth.at<float> (v, u) - z) / kinectAxialNoise (z, std::acos (d.z ()));
      sum += r;
      sum_sq += r * r;
      ++n;
    }
  EXPECT_NEAR (sum / n, 0.0, 0.05);
  EXPECT_NEAR (std::sqrt (sum_sq / n), 1.0, 0.05);
  // Same seed, same noise.
  const simulation::RenderedView again = renderer.render (cam, Eigen::Isometry3d::Identity (), noise, 7);
  EXPECT_EQ (cv::norm (again.depth, noisy.depth, cv::NORM_INF), 0.0);
}

TEST (SceneRenderer, TheStereoSensorsNoiseGrowsWithDepthSquared)
{
  // The RealSense-like model on a wall at depths drawn over the whole range: the residuals
  // are σ_z = z² · subpixel / (f · baseline) (mean 0, RMS 1 in units of it), about
  // `speckle` of the pixels have no depth, and at 3 m the noise is well above Kinect's.
  const PinholeCamera cam (300, 300, 79.5, 59.5, 160, 120);
  simulation::DepthNoiseConfig noise;
  noise.enabled = true;
  noise.sensor = simulation::DepthSensor::RealSense;
  std::mt19937 draw (5);
  for (int k = 0; k < 4; ++k)
  {
    const double wall = std::uniform_real_distribution<double> (0.6, 4.0) (draw);
    const simulation::SyntheticScene scene =
        sceneFromText ("object wall color=200,200,200\n box center=0,0," + std::to_string (wall + 0.05) + " size=20,20,0.1\n");
    const simulation::SceneRenderer renderer (scene);
    const simulation::RenderedView exact = renderer.render (cam, Eigen::Isometry3d::Identity ());
    const simulation::RenderedView noisy = renderer.render (cam, Eigen::Isometry3d::Identity (), noise, 11 + k);
    double sum = 0, sum_sq = 0;
    int n = 0, missing = 0;
    for (int v = 0; v < cam.height; ++v)
      for (int u = 0; u < cam.width; ++u)
      {
        const float z = exact.depth.at<float> (v, u), measured = noisy.depth.at<float> (v, u);
        if (measured == 0.f)
        {
          ++missing;
          continue;
        }
        const double r = (measured - z) / simulation::stereoAxialNoise (z, cam.fx * 640.0 / cam.width, noise);
        sum += r;
        sum_sq += r * r;
        ++n;
      }
    EXPECT_NEAR (sum / n, 0.0, 0.05) << "wall at " << wall << " m";
    EXPECT_NEAR (std::sqrt (sum_sq / n), 1.0, 0.05) << "wall at " << wall << " m";
    EXPECT_NEAR (static_cast<double> (missing) / (cam.width * cam.height), noise.speckle, 0.006) << "wall at " << wall << " m";
  }
  EXPECT_GT (simulation::stereoAxialNoise (3.0, 525.0, noise), 1.5 * kinectAxialNoise (3.0, 0.0));
}

TEST (SceneRenderer, TheStereoSensorFattensForegroundAndLosesDarkSurfaces)
{
  // Noise off but for one effect at a time: a cube 1 m away before a wall at 2 m takes
  // edge_fattening_px more pixels of the wall on each side along x; a dark object loses
  // about dark_dropout of its pixels, a bright one none.
  const simulation::SyntheticScene scene = sceneFromText ("object wall color=200,200,200\n box center=0,0,2.05 size=10,10,0.1\n"
                                                  "object cube color=200,200,200\n box center=0,0,1.0 size=0.2,0.2,0.2\n"
                                                  "object dark color=15,15,15\n box center=0.45,0,1.5 size=0.2,0.2,0.2\n");
  const PinholeCamera cam (100, 100, 79.5, 59.5, 160, 120);
  const simulation::SceneRenderer renderer (scene);
  simulation::DepthNoiseConfig noise;
  noise.enabled = true;
  noise.sensor = simulation::DepthSensor::RealSense;
  noise.stereo_subpixel = 0.0;
  noise.speckle = 0.0;
  noise.dark_dropout = 0.0;
  const simulation::RenderedView exact = renderer.render (cam, Eigen::Isometry3d::Identity ());
  const simulation::RenderedView fat = renderer.render (cam, Eigen::Isometry3d::Identity (), noise, 3);
  for (int v = 50; v < 70; ++v)
  {
    int exact_cube = 0, fat_cube = 0;
    for (int u = 0; u < 120; ++u)  // the cube's rows, left of the dark object
    {
      exact_cube += std::abs (exact.depth.at<float> (v, u) - 0.9f) < 1e-3f;
      fat_cube += std::abs (fat.depth.at<float> (v, u) - 0.9f) < 1e-3f;
    }
    ASSERT_GT (exact_cube, 10) << "row " << v;
    EXPECT_EQ (fat_cube, exact_cube + 2 * noise.edge_fattening_px) << "row " << v;
  }
  noise.edge_fattening_px = 0;
  noise.dark_dropout = 0.7;
  const simulation::RenderedView holes = renderer.render (cam, Eigen::Isometry3d::Identity (), noise, 4);
  int dark = 0, dark_missing = 0, bright = 0, bright_missing = 0;
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u)
    {
      const std::uint16_t id = exact.instance.at<std::uint16_t> (v, u);
      const bool lost = holes.depth.at<float> (v, u) == 0.f;
      (id == 3 ? dark : bright) += 1;
      (id == 3 ? dark_missing : bright_missing) += lost;
    }
  ASSERT_GT (dark, 200);
  EXPECT_NEAR (static_cast<double> (dark_missing) / dark, 0.7, 0.08);
  EXPECT_EQ (bright_missing, 0);
}

TEST (SceneRenderer, GrazingSurfacesLoseDepth)
{
  const simulation::SyntheticScene scene = sceneFromText ("object floor\n box center=0,0,-0.01 size=40,40,0.02\n");
  const PinholeCamera cam (200, 200, 79.5, 59.5, 160, 120);
  simulation::OrbitTrajectory orbit;
  orbit.target = Eigen::Vector3d (0, 0, 0);
  orbit.radius = 3.0;
  orbit.height = 0.3;  // looking along the floor
  simulation::DepthNoiseConfig noise;
  noise.enabled = true;
  const simulation::RenderedView view = simulation::SceneRenderer (scene).render (cam, orbit.poseAt (0.0), noise, 1);
  int floor_pixels = 0, missing = 0;
  for (int v = 0; v < cam.height; ++v)
    for (int u = 0; u < cam.width; ++u)
      if (view.instance.at<std::uint16_t> (v, u))
      {
        ++floor_pixels;
        missing += view.depth.at<float> (v, u) == 0.f;
      }
  EXPECT_GT (floor_pixels, 1000);
  EXPECT_GT (missing, floor_pixels / 10);
}

TEST (SceneFile, ParsesTheBundledScene)
{
  const simulation::SyntheticScene scene = tabletop ();
  EXPECT_EQ (scene.name, "tabletop");
  EXPECT_EQ (scene.camera.width, 640);
  ASSERT_GE (scene.objects.size (), 10u);
  std::set<std::string> names;
  for (const simulation::SceneObject& o : scene.objects)
    names.insert (o.class_name);
  EXPECT_TRUE (names.count ("teddy bear"));
  EXPECT_EQ (scene.objects[0].detectable, false);  // floor
}

TEST (SceneFile, ErrorsNameTheLine)
{
  try
  {
    sceneFromText ("object a\n box center=0,0,0 size=1,1\n");
    FAIL ();
  }
  catch (const Error& e)
  {
    EXPECT_NE (std::string (e.what ()).find ("test.scene:2"), std::string::npos) << e.what ();
  }
  EXPECT_THROW (sceneFromText ("object a\n sphere center=0,0,0 radius=1 colour=3\n"), Error);  // typo'd key
  EXPECT_THROW (sceneFromText ("sphere center=0,0,0 radius=1\n"), Error);
  EXPECT_THROW (sceneFromText ("object a\n"), Error);
  EXPECT_THROW (sceneFromText ("object a\n sphere center=0,0,0 radius=-1\n"), Error);
}

TEST (SyntheticSequence, MasksPosesAndGroundTruthCloudAgree)
{
  const simulation::SyntheticSequence sequence = test::smallTabletop (5, 160, 120);
  const auto cloud = sequence.groundTruthCloud ();
  ASSERT_GT (cloud->size (), 10000u);
  pcl::KdTreeFLANN<pcl::PointXYZRGBL> tree;
  tree.setInputCloud (cloud);
  for (std::size_t i : {std::size_t (0), std::size_t (4)})
  {
    const RGBDFrame::Ptr frame = sequence.frame (i);
    ASSERT_TRUE (frame->pose.has_value ());
    int checked = 0, agree = 0;
    for (int v = 0; v < frame->depth.rows; v += 2)
      for (int u = 0; u < frame->depth.cols; u += 2)
      {
        const float z = frame->depth.at<float> (v, u);
        if (!isValidDepth (z))
          continue;
        const Eigen::Vector3d p = *frame->pose * frame->camera.backProject (u, v, z).cast<double> ();
        pcl::PointXYZRGBL q;
        q.getVector3fMap () = p.cast<float> ();
        std::vector<int> index (1);
        std::vector<float> sq (1);
        tree.nearestKSearch (q, 1, index, sq);
        ++checked;
        // Every visible surface point is in the cloud (within the sampling spacing) with
        // the label of the instance mask.
        agree += std::sqrt (sq[0]) < 0.015 && (*cloud)[index[0]].label == frame->instance_mask.at<std::uint16_t> (v, u);
      }
    ASSERT_GT (checked, 2000);
    EXPECT_GT (agree, 0.99 * checked) << "frame " << i;
  }
}

TEST (SyntheticSequence, ContactFacesAreNotInTheGroundTruthCloud)
{
  const simulation::SyntheticScene scene = tabletop ();
  simulation::SyntheticSequenceConfig config;
  config.frames = 1;
  const auto cloud = simulation::SyntheticSequence (scene, config).groundTruthCloud ();
  const simulation::SceneObject* mug = nullptr;
  const simulation::SceneObject* table = nullptr;
  for (const simulation::SceneObject& o : scene.objects)
  {
    if (o.name == "mug")
      mug = &o;
    if (o.name == "table")
      table = &o;
  }
  ASSERT_TRUE (mug && table);
  const Eigen::Vector3d axis = mug->parts[0].center;
  for (const auto& p : cloud->points)
  {
    const double radial = std::hypot (p.x - axis.x (), p.y - axis.y ());
    if (p.label == mug->id)
    {
      EXPECT_GT (p.z, 0.7405f);  // the base on the table is hidden
    }
    if (p.label == table->id && radial < 0.04)
    {
      EXPECT_LT (p.z, 0.7395f);  // and so is the table top under the mug
    }
  }
}

TEST (SyntheticSequence, TheWrittenTruthHoldsWhatSomeFrameMeasured)
{
  // gt_cloud.pcd (SyntheticSequenceConfig::gt_observed_only): the table top's upper face
  // is seen from above, its underside and the floor under it never; every kept point lies
  // on the surface some frame saw at its pixel, and the file holds exactly those points.
  const simulation::SyntheticScene scene = tabletop ();
  simulation::SyntheticSequenceConfig config;
  config.frames = 6;
  config.width = 160;
  config.height = 120;
  config.noise.enabled = true;
  const simulation::SyntheticSequence sequence (scene, config);
  const auto all = sequence.groundTruthCloud ();
  std::vector<char> observed (all->size (), 0);
  for (std::size_t i = 0; i < sequence.size (); ++i)
    sequence.markObserved (*all, i, sequence.render (i), observed);
  const simulation::SceneObject* table = nullptr;
  for (const simulation::SceneObject& o : scene.objects)
    if (o.name == "table")
      table = &o;
  ASSERT_TRUE (table);
  const double top = table->parts[0].center.z () + table->parts[0].half_size.z ();
  const double bottom = table->parts[0].center.z () - table->parts[0].half_size.z ();
  int upper = 0, upper_seen = 0, under_seen = 0;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < all->size (); ++i)
  {
    const auto& p = (*all)[i];
    kept += observed[i] ? 1 : 0;
    if (p.label != table->id)
      continue;
    if (std::abs (p.z - top) < 1e-4)
    {
      ++upper;
      upper_seen += observed[i] ? 1 : 0;
    }
    if (std::abs (p.z - bottom) < 1e-4)
      under_seen += observed[i] ? 1 : 0;
  }
  EXPECT_GT (upper_seen, upper / 2);
  EXPECT_EQ (under_seen, 0);
  EXPECT_LT (kept, all->size () * 9 / 10);

  // The cubes of space markObserved passes over when out of view (what the writer uses):
  // every point in exactly one, inside it, and the same flags as testing every point.
  const simulation::CloudCells cells = simulation::SyntheticSequence::cloudCells (*all);
  ASSERT_EQ (cells.points.size (), all->size ());
  ASSERT_EQ (cells.begin.size (), cells.centre.size () + 1);
  std::vector<int> listed (all->size (), 0);
  for (std::size_t c = 0; c < cells.centre.size (); ++c)
    for (std::uint32_t k = cells.begin[c]; k < cells.begin[c + 1]; ++k)
    {
      ++listed[cells.points[k]];
      const Eigen::Vector3f offset = (*all)[cells.points[k]].getVector3fMap () - cells.centre[c];
      EXPECT_LE (offset.cwiseAbs ().maxCoeff (), 0.5f * simulation::CloudCells::kSide + 1e-5f);
    }
  EXPECT_EQ (std::count (listed.begin (), listed.end (), 1), static_cast<long> (all->size ()));
  std::vector<char> by_cells (all->size (), 0);
  for (std::size_t i = 0; i < sequence.size (); ++i)
    sequence.markObserved (*all, i, sequence.render (i), by_cells, &cells);
  EXPECT_TRUE (by_cells == observed);

  const test::TempDir dir;
  simulation::writeSyntheticSequence (sequence, io::DatasetLayout::Redwood, dir / "seq", false);
  pcl::PointCloud<pcl::PointXYZRGBL> written;
  ASSERT_EQ (pcl::io::loadPCDFile (dir / "seq/gt_cloud.pcd", written), 0);
  ASSERT_EQ (written.size (), kept);
  for (std::size_t i = 0, w = 0; i < all->size (); ++i)
    if (observed[i])
    {
      EXPECT_EQ (written[w].getVector3fMap (), (*all)[i].getVector3fMap ());
      EXPECT_EQ (written[w++].label, (*all)[i].label);
    }
}

TEST (SceneRenderer, EachPixelIsItsRaysNearestHitAmongEveryPart)
{
  // render casts each tile's rays against the parts its cone of rays can meet; castRay
  // tests every part. Views drawn around both scenes (0.3–4 m away, any side, a normal
  // and a wide lens) give the same object and depth at every pixel both ways.
  std::mt19937 draw (17);
  std::uniform_real_distribution<double> unit (0.0, 1.0);
  for (const std::string name : {"tabletop", "clutter"})
  {
    const simulation::SyntheticScene scene =
      simulation::SyntheticScene::load (std::string (CUEFUSION_TEST_DATA_DIR) + "/scenes/" + name + ".scene");
    const simulation::SceneRenderer renderer (scene);
    for (int k = 0; k < 6; ++k)
    {
      const double fx = k % 2 ? 60.0 : 140.0;  // 106° and 60° across
      const PinholeCamera camera (fx, fx, 79.5, 59.5, 160, 120);
      const double distance = 0.3 + 3.7 * unit (draw), azimuth = 6.283185307179586 * unit (draw);
      const Eigen::Vector3d target = scene.trajectory.target + Eigen::Vector3d (unit (draw) - 0.5, unit (draw) - 0.5, 0.2 * unit (draw));
      const Eigen::Vector3d eye = target + distance * Eigen::Vector3d (std::cos (azimuth), std::sin (azimuth), 0.2 + unit (draw));
      const Eigen::Isometry3d pose = lookAt (eye, target);
      const simulation::RenderedView view = renderer.render (camera, pose);
      int hits = 0;
      for (int v = 0; v < camera.height; ++v)
        for (int u = 0; u < camera.width; ++u)
        {
          const Eigen::Vector3d dir =
            (pose.rotation () * Eigen::Vector3d ((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0)).normalized ();
          double t = 0.0;
          Eigen::Vector3d normal;
          const std::uint16_t id = renderer.castRay (pose.translation (), dir, t, normal);
          ASSERT_EQ (view.instance.at<std::uint16_t> (v, u), id) << name << " view " << k << " pixel " << u << "," << v;
          if (id == 0)
            continue;
          ++hits;
          EXPECT_EQ (view.exact_depth.at<float> (v, u), static_cast<float> ((pose.rotation ().transpose () * (pose.translation () + t * dir - pose.translation ())).z ()));
        }
      EXPECT_GT (hits, 0) << name << " view " << k;
    }
  }
}

TEST (SyntheticSequence, CameraLooksAtTheTarget)
{
  const simulation::SyntheticScene scene = tabletop ();
  simulation::SyntheticSequenceConfig config;
  config.frames = 10;
  const simulation::SyntheticSequence sequence (scene, config);
  for (std::size_t i = 0; i < 10; ++i)
  {
    const Eigen::Isometry3d pose = sequence.poseAt (i);
    const Eigen::Vector3d to_target = (scene.trajectory.target - pose.translation ()).normalized ();
    EXPECT_NEAR (pose.rotation ().col (2).dot (to_target), 1.0, 1e-9);
    EXPECT_NEAR (pose.rotation ().determinant (), 1.0, 1e-9);
    EXPECT_LT (pose.rotation ().col (1).z (), 0.0);  // image "down" points down in the world
  }
}

namespace
{
struct DetectorFixture : ::testing::Test
{
  simulation::SyntheticScene scene = tabletop ();
  std::vector<RGBDFrame::Ptr> frames;
  void
  SetUp () override
  {
    const simulation::SyntheticSequence sequence = test::smallTabletop (6, 320, 240);
    for (std::size_t i = 0; i < sequence.size (); ++i)
      frames.push_back (sequence.frame (i));
  }
  std::uint16_t
  idOf (const std::string& name) const
  {
    for (const simulation::SceneObject& o : scene.objects)
      if (o.name == name)
        return o.id;
    return 0;
  }
};
}  // namespace

TEST_F (DetectorFixture, PerfectDetectorReproducesTheMasksOfDetectableObjects)
{
  const simulation::SimulatedDetector detector (scene, simulation::DetectorErrorConfig (), 3);
  for (const RGBDFrame::Ptr& f : frames)
  {
    const simulation::DetectionResult r = detector.detect (f->instance_mask, f->index);
    ASSERT_GE (r.detections.size (), 6u);
    for (const simulation::Detection& d : r.detections)
    {
      ASSERT_EQ (d.gt_instances.size (), 1u);
      EXPECT_EQ (cv::countNonZero ((r.ids == d.id) != (f->instance_mask == d.gt_instances[0])), 0);
      EXPECT_EQ (d.class_name, scene.objectById (d.gt_instances[0])->class_name);
      EXPECT_GE (d.score, 0.7f);
    }
    // Floor, walls and table are stuff: never detected.
    for (const char* stuff : {"floor", "wall", "table"})
      EXPECT_EQ (cv::countNonZero ((f->instance_mask == idOf (stuff)) & (r.ids > 0)), 0) << stuff;
  }
}

TEST_F (DetectorFixture, BoundaryErrorsGrowOrShrinkMasks)
{
  simulation::DetectorErrorConfig grow, shrink;
  grow.boundary_px = 3;
  shrink.boundary_px = -2;
  const RGBDFrame& f = *frames[2];
  const simulation::DetectionResult big = simulation::SimulatedDetector (scene, grow, 1).detect (f.instance_mask, 2);
  const simulation::DetectionResult small = simulation::SimulatedDetector (scene, shrink, 1).detect (f.instance_mask, 2);
  const std::uint16_t ball = idOf ("ball");
  const int truth = cv::countNonZero (f.instance_mask == ball);
  auto area_of = [ball] (const simulation::DetectionResult& r) {
    for (const simulation::Detection& d : r.detections)
      if (d.gt_instances == std::vector<std::uint16_t>{ball})
        return cv::countNonZero (r.ids == d.id);
    return -1;
  };
  EXPECT_GT (area_of (big), truth);
  EXPECT_GT (area_of (small), 0);
  EXPECT_LT (area_of (small), truth);
  // A leaking mask spills onto the table.
  EXPECT_GT (cv::countNonZero ((f.instance_mask == idOf ("table")) & (big.ids > 0)), 0);
}

TEST_F (DetectorFixture, MergeMissAndFalsePositives)
{
  simulation::DetectorErrorConfig merge;
  merge.merge_probability = 1.0;
  const simulation::SimulatedDetector merging (scene, merge, 1);
  bool merged_boxes = false;
  for (const RGBDFrame::Ptr& f : frames)
    for (const simulation::Detection& d : merging.detect (f->instance_mask, f->index).detections)
    {
      const std::set<std::uint16_t> members (d.gt_instances.begin (), d.gt_instances.end ());
      merged_boxes |= members.count (idOf ("cereal_a")) && members.count (idOf ("cereal_b"));
    }
  EXPECT_TRUE (merged_boxes);

  simulation::DetectorErrorConfig miss;
  miss.miss_probability = 1.0;
  EXPECT_TRUE (simulation::SimulatedDetector (scene, miss, 1).detect (frames[0]->instance_mask, 0).detections.empty ());

  simulation::DetectorErrorConfig fp;
  fp.false_positives = 3.0;
  const simulation::SimulatedDetector spurious (scene, fp, 5);
  int false_positives = 0;
  for (const RGBDFrame::Ptr& f : frames)
    for (const simulation::Detection& d : spurious.detect (f->instance_mask, f->index).detections)
      false_positives += d.gt_instances.empty ();
  EXPECT_GT (false_positives, 0);
}

TEST_F (DetectorFixture, MergesAreDrawnPerFrameAndSplitsCutOneObjectInTwo)
{
  // Merges per frame: at p = 0.5 the touching boxes come as one mask in some frames and
  // as two in others, and the draw for a frame is the same whatever was asked before.
  simulation::DetectorErrorConfig merge;
  merge.merge_probability = 0.5;
  const simulation::SimulatedDetector merging (scene, merge, 3);
  const std::uint16_t a = idOf ("cereal_a"), b = idOf ("cereal_b");
  int merged = 0, separate = 0;
  for (std::size_t frame = 0; frame < 200; ++frame)
    (merging.mergesPair (a, b, frame) ? merged : separate) += 1;
  EXPECT_GT (merged, 60);
  EXPECT_GT (separate, 60);
  EXPECT_EQ (merging.mergesPair (a, b, 17), merging.mergesPair (b, a, 17));

  // A split reports one object as two masks that together are its exact mask.
  simulation::DetectorErrorConfig split;
  split.split_probability = 1.0;
  const RGBDFrame& f = *frames[0];
  const simulation::DetectionResult result = simulation::SimulatedDetector (scene, split, 1).detect (f.instance_mask, 0);
  const std::uint16_t book = idOf ("book");
  std::vector<std::uint16_t> pieces;
  for (const simulation::Detection& d : result.detections)
    if (d.gt_instances.size () == 1 && d.gt_instances[0] == book)
      pieces.push_back (d.id);
  ASSERT_EQ (pieces.size (), 2u) << result.detections.size () << " detections, book " << book << " visible on "
                                 << cv::countNonZero (f.instance_mask == book) << " pixels";
  const cv::Mat union_mask = (result.ids == pieces[0]) | (result.ids == pieces[1]);
  EXPECT_EQ (cv::countNonZero (union_mask != (f.instance_mask == book)), 0);
  EXPECT_GT (cv::countNonZero (result.ids == pieces[0]), 0);
  EXPECT_GT (cv::countNonZero (result.ids == pieces[1]), 0);
}

TEST_F (DetectorFixture, SeededAndOrderIndependent)
{
  simulation::DetectorErrorConfig noisy;
  noisy.boundary_jitter_px = 3;
  noisy.miss_probability = 0.3;
  noisy.false_positives = 1.0;
  const simulation::SimulatedDetector a (scene, noisy, 11), b (scene, noisy, 11), c (scene, noisy, 12);
  const simulation::DetectionResult later = b.detect (frames[3]->instance_mask, 3);
  EXPECT_FALSE (a.detect (frames[1]->instance_mask, 1).ids.empty ());  // another frame first
  const simulation::DetectionResult r3 = a.detect (frames[3]->instance_mask, 3);
  EXPECT_EQ (cv::norm (r3.ids, later.ids, cv::NORM_INF), 0.0);
  bool differs = false;
  for (std::size_t i = 0; i < frames.size (); ++i)
    differs |= cv::norm (a.detect (frames[i]->instance_mask, i).ids, c.detect (frames[i]->instance_mask, i).ids,
                         cv::NORM_INF) > 0;
  EXPECT_TRUE (differs);
  EXPECT_THROW (simulation::SimulatedDetector (scene, [] {
                  simulation::DetectorErrorConfig bad;
                  bad.merge_probability = 1.5;
                  return bad;
                }(), 1),
                ParameterError);
}
