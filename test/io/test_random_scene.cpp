// SPDX-License-Identifier: BSD-3-Clause
// Training views for the instance network (RandomSceneGenerator, synth-views): seeded,
// with truth that agrees with the depth, and written as a whole folder or not at all.
#include "test_utils.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/simulation/random_scene.h>

#include <boost/filesystem.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <random>


using namespace cuefusion;

TEST (RandomSceneGenerator, ViewsDependOnlyOnSeedAndIndex)
{
  const simulation::RandomSceneGenerator a (simulation::RandomSceneConfig (), 7), b (simulation::RandomSceneConfig (), 7), c (simulation::RandomSceneConfig (), 8);
  const simulation::RandomView v3 = a.view (3, 160, 120);
  const simulation::RandomView again = b.view (3, 160, 120);  // another generator, no view 0..2 before it
  EXPECT_EQ (cv::countNonZero (v3.view.depth != again.view.depth), 0);
  EXPECT_EQ (cv::countNonZero (v3.objects != again.objects), 0);
  EXPECT_GT (cv::countNonZero (v3.view.depth != c.view (3, 160, 120).view.depth), 0);
  EXPECT_GT (cv::countNonZero (v3.view.depth != a.view (4, 160, 120).view.depth), 0);
}

TEST (RandomSceneGenerator, ScenesHoldSupportedObjectsAndTheTruthMatchesTheDepth)
{
  simulation::RandomSceneConfig config;
  config.min_objects = 4;
  config.max_objects = 8;
  const simulation::RandomSceneGenerator generator (config, 11);
  int views_with_objects = 0, touching_views = 0;
  for (std::size_t i = 0; i < 12; ++i)
  {
    const simulation::SyntheticScene scene = generator.scene (i);
    int objects = 0;
    for (const simulation::SceneObject& o : scene.objects)
    {
      objects += o.detectable ? 1 : 0;
      // Nothing floats below the floor; every object has parts.
      EXPECT_FALSE (o.parts.empty ());
      for (const simulation::Primitive& p : o.parts)
        EXPECT_GE (p.center.z () + p.half_size.z (), -0.02 - 1e-9) << o.name;
    }
    EXPECT_LE (objects, config.max_objects);
    EXPECT_GE (objects, 1);

    const simulation::RandomView view = generator.view (i * config.views_per_scene, 160, 120);
    EXPECT_EQ (view.object_count, objects);
    // objects = instance with stuff removed; only detectable ids; depth wherever an object is
    // seen, except the Kinect-like dropout (grazing angles), which stays rare.
    int object_pixels = 0, without_depth = 0;
    for (int v = 0; v < view.objects.rows; ++v)
      for (int u = 0; u < view.objects.cols; ++u)
      {
        const std::uint16_t id = view.objects.at<std::uint16_t> (v, u);
        if (!id)
          continue;
        EXPECT_EQ (id, view.view.instance.at<std::uint16_t> (v, u));
        ASSERT_TRUE (scene.objectById (id) && scene.objectById (id)->detectable);
        ++object_pixels;
        without_depth += view.view.depth.at<float> (v, u) > 0.f ? 0 : 1;
      }
    views_with_objects += object_pixels > 0 ? 1 : 0;
    EXPECT_LT (without_depth, 0.25 * object_pixels + 1);
    // Two objects next to each other somewhere in the image (touching or occluding).
    bool touch = false;
    for (int v = 0; v + 1 < view.objects.rows && !touch; ++v)
      for (int u = 0; u + 1 < view.objects.cols && !touch; ++u)
      {
        const std::uint16_t id = view.objects.at<std::uint16_t> (v, u);
        const std::uint16_t right = view.objects.at<std::uint16_t> (v, u + 1), down = view.objects.at<std::uint16_t> (v + 1, u);
        touch = id && ((right && right != id) || (down && down != id));
      }
    touching_views += touch ? 1 : 0;
  }
  // The camera looks at the objects: nearly every view sees some, and many see neighbours.
  EXPECT_GE (views_with_objects, 11);
  EXPECT_GE (touching_views, 4);
}

TEST (RandomSceneGenerator, RefusesAbsurdSettings)
{
  simulation::RandomSceneConfig config;
  config.max_objects = 0;
  test::expectError ([&] { simulation::RandomSceneGenerator g (config, 1); }, "RandomSceneConfig::min_objects", "min_objects");
  config = simulation::RandomSceneConfig ();
  config.touching_probability = 1.5;
  EXPECT_THROW (simulation::RandomSceneGenerator (config, 1), ParameterError);
  config = simulation::RandomSceneConfig ();
  config.min_distance = 3.0;
  config.max_distance = 1.0;
  EXPECT_THROW (simulation::RandomSceneGenerator (config, 1), ParameterError);
  EXPECT_THROW (simulation::RandomSceneGenerator (simulation::RandomSceneConfig (), 1).view (0, 8, 8), ParameterError);
}

TEST (RandomSceneGenerator, SynthViewsWritesTheWholeFolder)
{
  test::TempDir dir;
  const auto r = test::runCuefusion ("synth-views --views 5 --size 96x72 --seed 4 --out " + (dir / "views"), dir);
  ASSERT_EQ (r.code, 0) << r.err;
  const nlohmann::json meta = nlohmann::json::parse (test::readFile (dir / "views/views.json"));
  ASSERT_EQ (meta.at ("views").size (), 5u);
  EXPECT_EQ (meta.at ("generator").at ("seed"), 4);
  const simulation::RandomSceneGenerator generator (simulation::RandomSceneConfig (), 4);
  for (int i = 0; i < 5; ++i)
  {
    const nlohmann::json& v = meta.at ("views").at (static_cast<std::size_t> (i));
    const std::string file = v.at ("file");
    const cv::Mat depth = io::readDepthImage (dir / ("views/depth/" + file), 1000.0);
    const cv::Mat ids = io::readLabelImage (dir / ("views/instance/" + file));
    const simulation::RandomView truth = generator.view (static_cast<std::size_t> (i), 96, 72);
    EXPECT_EQ (cv::countNonZero (ids != truth.objects), 0);
    cv::Mat difference;
    cv::absdiff (depth, truth.view.depth, difference);
    double worst = 0;
    cv::minMaxLoc (difference, nullptr, &worst);
    EXPECT_LE (worst, 0.0005 + 1e-6);  // millimetre PNG
    EXPECT_DOUBLE_EQ (v.at ("camera").at ("fx").get<double> (), truth.camera.fx);
    EXPECT_EQ (v.at ("objects").get<int> (), truth.object_count);
  }
  // An existing folder is not replaced without --overwrite; bad counts and sizes are refused.
  EXPECT_EQ (test::runCuefusion ("synth-views --views 2 --out " + (dir / "views"), dir).code, 1);
  const auto zero = test::runCuefusion ("synth-views --views 0 --out " + (dir / "other"), dir);
  EXPECT_EQ (zero.code, 2);
  EXPECT_NE (zero.err.find ("--views"), std::string::npos) << zero.err;
  const auto tiny = test::runCuefusion ("synth-views --views 1 --size 0x0 --out " + (dir / "other"), dir);
  EXPECT_EQ (tiny.code, 2);
  EXPECT_NE (tiny.err.find ("--size"), std::string::npos) << tiny.err;
  EXPECT_FALSE (boost::filesystem::exists (dir / "other"));
}

TEST (WriteFolderAtomic, AFailedFillLeavesTheOldFolderAndNoTemporary)
{
  test::TempDir dir;
  const std::string target = dir / "set";
  io::writeFolderAtomic (target, false, [] (const std::string& staging) { test::writeFile (staging + "/a.txt", "one"); });
  EXPECT_EQ (test::readFile (target + "/a.txt"), "one");
  EXPECT_THROW (io::writeFolderAtomic (target, true,
                                       [] (const std::string& staging) {
                                         test::writeFile (staging + "/b.txt", "half");
                                         throw Error ("b.txt", "disk full");
                                       }),
                Error);
  EXPECT_EQ (test::readFile (target + "/a.txt"), "one");
  EXPECT_FALSE (boost::filesystem::exists (target + "/b.txt"));
  int entries = 0;
  for (const auto& e : boost::filesystem::directory_iterator (dir.str ()))
    entries += e.path ().filename ().string () == "set" ? 0 : 1;
  EXPECT_EQ (entries, 0);
  test::expectError ([&] { io::writeFolderAtomic (target, false, [] (const std::string&) {}); }, target, "not empty");
  io::writeFolderAtomic (target, true, [] (const std::string& staging) { test::writeFile (staging + "/c.txt", "two"); });
  EXPECT_FALSE (boost::filesystem::exists (target + "/a.txt"));
  EXPECT_EQ (test::readFile (target + "/c.txt"), "two");
}

TEST (RandomSceneGenerator, FiguresAreOneObjectOfSpheresAndOnlyWhenAskedFor)
{
  const auto spheres = [] (const simulation::SceneObject& o) {
    return std::all_of (o.parts.begin (), o.parts.end (), [] (const simulation::Primitive& p) { return p.type == simulation::Primitive::Type::Sphere; });
  };
  simulation::RandomSceneConfig config;
  config.multipart_probability = 1.0;
  config.figure_probability = 1.0;
  int with_limbs = 0, objects = 0;
  double largest_body = 0.0;
  for (std::size_t i = 0; i < 4; ++i)
    for (const simulation::SceneObject& o : simulation::RandomSceneGenerator (config, 3).scene (i).objects)
      if (o.detectable)
      {
        ++objects;
        EXPECT_TRUE (spheres (o)) << o.name;
        ASSERT_GE (o.parts.size (), 2u) << o.name;
        // The head rests on the body, sunk into it: one connected object.
        const simulation::Primitive &body = o.parts[0], &head = o.parts[1];
        EXPECT_LT ((head.center - body.center).norm (), body.half_size.x () + head.half_size.x ());
        EXPECT_LT (head.half_size.x (), body.half_size.x ());
        with_limbs += o.parts.size () >= 4 ? 1 : 0;
        // Bodies span a single ball's radii, min_size / 2 to max_size / 3.
        EXPECT_GE (body.half_size.x (), config.min_size / 2 - 1e-9);
        EXPECT_LE (body.half_size.x (), config.max_size / 3 + 1e-9);
        largest_body = std::max (largest_body, body.half_size.x ());
      }
  EXPECT_GE (objects, 4);
  EXPECT_GE (with_limbs, objects / 2);
  // Some figures are larger than a max_size / 4 body (the radii before 2026-11-25).
  EXPECT_GT (largest_body, config.max_size / 4);
  // By default no figures: no object of more than two spheres (a snowman has two).
  for (std::size_t i = 0; i < 8; ++i)
    for (const simulation::SceneObject& o : simulation::RandomSceneGenerator (simulation::RandomSceneConfig (), 3).scene (i).objects)
      EXPECT_FALSE (spheres (o) && o.parts.size () > 2) << o.name;
  config.figure_probability = -0.1;
  test::expectError ([&] { simulation::RandomSceneGenerator g (config, 1); }, "RandomSceneConfig::figure_probability", "[0, 1]");
}

TEST (RandomSceneGenerator, AlignedFlushBoxesShareASideFace)
{
  // Pairs of single boxes standing flush face to face (same yaw, touching along one axis,
  // overlapping along the other: boxes that only meet at an edge are not a pair):
  // with aligned_probability 1 each placed pair has one side face in one plane, at 0 most
  // do not.
  const auto flushPairs = [] (const simulation::RandomSceneConfig& config, int& aligned) {
    int pairs = 0;
    aligned = 0;
    for (std::size_t i = 0; i < 12; ++i)
    {
      std::vector<simulation::Primitive> boxes;
      for (const simulation::SceneObject& o : simulation::RandomSceneGenerator (config, 5).scene (i).objects)
        if (o.detectable && o.parts.size () == 1 && o.parts[0].type == simulation::Primitive::Type::Box)
          boxes.push_back (o.parts[0]);
      for (std::size_t a = 0; a < boxes.size (); ++a)
        for (std::size_t b = a + 1; b < boxes.size (); ++b)
        {
          if (std::abs (boxes[a].yaw - boxes[b].yaw) > 1e-9 || std::abs (boxes[a].center.z () - boxes[b].center.z ()) >
                                                                  boxes[a].half_size.z () + boxes[b].half_size.z ())
            continue;
          const Eigen::Vector3d offset = boxes[a].toLocal (boxes[b].center);
          for (int axis = 0; axis < 2; ++axis)
          {
            const int other = 1 - axis;
            if (std::abs (std::abs (offset[axis]) - (boxes[a].half_size[axis] + boxes[b].half_size[axis])) > 1e-6 ||
                std::abs (offset[other]) > boxes[a].half_size[other] + boxes[b].half_size[other] - 1e-6)
              continue;
            ++pairs;
            aligned += std::abs (std::abs (offset[other]) - std::abs (boxes[a].half_size[other] - boxes[b].half_size[other])) < 1e-6;
          }
        }
    }
    return pairs;
  };
  simulation::RandomSceneConfig config;
  config.touching_probability = 1.0;
  config.stacking_probability = 0.0;
  config.multipart_probability = 0.0;
  config.aligned_probability = 1.0;
  int aligned = 0;
  const int pairs = flushPairs (config, aligned);
  EXPECT_GE (pairs, 5);
  EXPECT_GE (aligned, pairs * 9 / 10);  // a box flush against two can meet a third by chance
  config.aligned_probability = 0.0;
  const int unaligned_pairs = flushPairs (config, aligned);
  EXPECT_GE (unaligned_pairs, 5);
  EXPECT_LT (aligned, unaligned_pairs / 2);
  config.aligned_probability = 2.0;
  test::expectError ([&] { simulation::RandomSceneGenerator g (config, 1); }, "RandomSceneConfig::aligned_probability", "[0, 1]");
}

TEST (RandomSceneGenerator, RoomViewsSeeTheRoomsSmallObjectsAndNotItsFurniture)
{
  // A generator seed drawn at random (the draw itself seeded, so a failure reproduces).
  const std::uint64_t seed = std::mt19937 (20261130) ();
  SCOPED_TRACE ("seed " + std::to_string (seed));
  simulation::RandomSceneConfig config;
  config.room_probability = 1.0;
  const simulation::RandomSceneGenerator rooms (config, seed);
  const double largest = 2 * config.max_size;
  int views_with_objects = 0, views_with_furniture = 0;
  for (std::size_t i = 0; i < 6; ++i)
  {
    const simulation::SyntheticScene scene = rooms.scene (i);
    ASSERT_GE (scene.path.waypoints.size (), 2u);  // a room and its camera path
    const simulation::RandomView view = rooms.view (i * config.views_per_scene + i % 4, 160, 120);
    // Seen from inside the room at standing distances: depth nearly everywhere, 0.5–6 m.
    std::vector<float> depth;
    for (int v = 0; v < view.view.depth.rows; ++v)
      for (int u = 0; u < view.view.depth.cols; ++u)
        if (view.view.depth.at<float> (v, u) > 0.f)
          depth.push_back (view.view.depth.at<float> (v, u));
    ASSERT_GT (depth.size (), 0.8 * view.view.depth.total ());
    std::nth_element (depth.begin (), depth.begin () + depth.size () / 2, depth.end ());
    EXPECT_GT (depth[depth.size () / 2], 0.5f);
    EXPECT_LT (depth[depth.size () / 2], 6.f);
    // Objects are exactly the detectable instances no larger than twice max_size.
    bool furniture = false, object = false;
    for (int v = 0; v < view.objects.rows; ++v)
      for (int u = 0; u < view.objects.cols; ++u)
      {
        const std::uint16_t id = view.view.instance.at<std::uint16_t> (v, u), kept = view.objects.at<std::uint16_t> (v, u);
        const simulation::SceneObject* o = scene.objectById (id);
        ASSERT_TRUE (o);
        const bool small = o->detectable && o->bounds ().sizes ().maxCoeff () <= largest;
        EXPECT_EQ (kept, small ? id : 0) << o->name;
        furniture = furniture || (o->detectable && !small);
        object = object || small;
      }
    views_with_objects += object ? 1 : 0;
    views_with_furniture += furniture ? 1 : 0;
  }
  // The path looks at furniture, which carries the objects.
  EXPECT_GE (views_with_furniture, 5);
  EXPECT_GE (views_with_objects, 4);

  // A share of rooms leaves every other scene as it was: a table-top scene of the mixed
  // generator is the scene (and views) of the generator without rooms.
  config.room_probability = 0.5;
  const simulation::RandomSceneGenerator mixed (config, seed), tabletops (simulation::RandomSceneConfig (), seed);
  int room_scenes = 0;
  for (std::size_t i = 0; i < 16; ++i)
  {
    const simulation::SyntheticScene scene = mixed.scene (i);
    if (scene.path.waypoints.size () >= 2)
    {
      ++room_scenes;
      continue;
    }
    EXPECT_EQ (scene.text (), tabletops.scene (i).text ());
    EXPECT_EQ (cv::countNonZero (mixed.view (4 * i, 80, 60).view.depth != tabletops.view (4 * i, 80, 60).view.depth), 0);
  }
  EXPECT_GE (room_scenes, 3);
  EXPECT_LE (room_scenes, 13);
  config.room_probability = 1.5;
  test::expectError ([&] { simulation::RandomSceneGenerator g (config, 1); }, "RandomSceneConfig::room_probability", "[0, 1]");
}
