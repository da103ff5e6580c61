// SPDX-License-Identifier: BSD-3-Clause
// Random rooms (generateRoom) and the hand-held camera path through waypoints: exact
// truth for whole-room benchmarks, so what is generated must be physically sound (nothing
// overlaps, nothing floats, the camera never inside furniture) and reproducible.
#include "test_utils.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/simulation/random_room.h>
#include <cuefusion/simulation/scene_renderer.h>

#include <gtest/gtest.h>

#include <random>

using namespace cuefusion;

namespace
{
/** Points of \a o's surface that lie 3 mm or more inside \a other. */
int
pointsInside (const simulation::SceneObject& o, const simulation::SceneObject& other)
{
  std::vector<Eigen::Vector3d> points;
  for (const simulation::Primitive& part : o.parts)
    part.sampleSurface (0.02, points);
  int inside = 0;
  for (const Eigen::Vector3d& p : points)
    for (const simulation::Primitive& prim : other.parts)
      inside += prim.contains (p, -0.003) ? 1 : 0;
  return inside;
}

/** Whether \a o stands on something: 1 mm under some point of its lowest parts' bottom
  * lies inside another object (its support), or it stands on the floor. */
bool
standsOnSomething (const simulation::SyntheticScene& scene, const simulation::SceneObject& o)
{
  const Eigen::AlignedBox3d box = o.bounds ();
  if (box.min ().z () < 0.001)
    return true;  // on the floor
  if (o.class_name == "cabinet" && box.min ().z () > 1.0)
    return true;  // wall cabinets hang on the wall
  for (const simulation::Primitive& part : o.parts)
  {
    if (part.center.z () - part.half_size.z () > box.min ().z () + 0.002)
      continue;
    for (double dx : {-0.3, 0.0, 0.3})
      for (double dy : {-0.3, 0.0, 0.3})
      {
        const Eigen::Vector3d under = part.center + Eigen::Vector3d (dx * part.half_size.x (), dy * part.half_size.y (),
                                                                   -part.half_size.z () - 0.001);
        for (const simulation::SceneObject& other : scene.objects)
          for (const simulation::Primitive& prim : other.parts)
            if (other.id != o.id && prim.contains (under, 0.0))
              return true;
      }
  }
  return false;
}
}  // namespace

TEST (CameraPath, PassesThroughItsWaypointsSmoothly)
{
  simulation::CameraPath path;
  path.waypoints = {{Eigen::Vector3d (1, 1, 1.5), Eigen::Vector3d (3, 1, 1)},
                    {Eigen::Vector3d (2, 1.5, 1.4), Eigen::Vector3d (3, 3, 0.9)},
                    {Eigen::Vector3d (2.5, 2, 1.6), Eigen::Vector3d (1, 3.5, 1.0)}};
  for (std::size_t k = 0; k < path.waypoints.size (); ++k)
  {
    const Eigen::Isometry3d pose = path.poseAt (k / 2.0);
    const simulation::CameraWaypoint& w = path.waypoints[k];
    EXPECT_LT ((pose.translation () - w.eye).norm (), 1e-9) << k;
    EXPECT_GT (pose.linear ().col (2).dot ((w.target - w.eye).normalized ()), 1 - 1e-9) << k;
  }
  // No jumps: consecutive poses of a 200-frame sequence move little and turn little.
  for (int i = 0; i < 200; ++i)
  {
    const Eigen::Isometry3d a = path.poseAt (i / 200.0), b = path.poseAt ((i + 1) / 200.0);
    EXPECT_LT ((a.translation () - b.translation ()).norm (), 0.03) << i;
    EXPECT_LT (Eigen::AngleAxisd (a.linear ().transpose () * b.linear ()).angle (), 2.0 * 3.14159 / 180) << i;
  }
  path.waypoints.resize (1);
  EXPECT_THROW (path.poseAt (0.5), ParameterError);
}

TEST (CameraPath, IsReadFromTheSceneFileAndWrittenBack)
{
  const std::string text = "scene walk\ncamera 320 240 262.5 262.5 159.5 119.5\n"
                           "waypoint eye=1,1,1.5 target=3,1,1\nwaypoint eye=2,1.5,1.4 target=3,3,0.9\n"
                           "object floor class=floor color=100,100,100 detectable=no texture=checker\n"
                           "  box center=2,2,-0.01 size=4,4,0.02\n"
                           "object mug class=coffee_mug color=200,40,40\n  cylinder center=3,1,0.06 radius=0.04 height=0.12\n"
                           "  box center=3.05,1,0.06 size=0.02,0.01,0.06 yaw=30\n"
                           "object ball class=ball color=1,2,3 texture=print\n  sphere center=2,3,0.1 radius=0.1\n";
  const simulation::SyntheticScene scene = simulation::SyntheticScene::parse (text, "walk.scene");
  ASSERT_EQ (scene.path.waypoints.size (), 2u);
  EXPECT_LT ((scene.cameraPoseAt (1.0).translation () - Eigen::Vector3d (2, 1.5, 1.4)).norm (), 1e-9);
  const simulation::SyntheticScene again = simulation::SyntheticScene::parse (scene.text (), "again.scene");
  EXPECT_EQ (again.name, "walk");
  EXPECT_EQ (again.camera.width, 320);
  EXPECT_DOUBLE_EQ (again.camera.fx, 262.5);
  ASSERT_EQ (again.objects.size (), scene.objects.size ());
  for (std::size_t i = 0; i < scene.objects.size (); ++i)
  {
    const simulation::SceneObject &a = scene.objects[i], &b = again.objects[i];
    EXPECT_EQ (a.name, b.name);
    EXPECT_EQ (a.class_name, b.class_name);
    EXPECT_EQ (a.rgb, b.rgb);
    EXPECT_EQ (a.detectable, b.detectable);
    EXPECT_EQ (a.checker, b.checker);
    EXPECT_EQ (a.print, b.print);
    ASSERT_EQ (a.parts.size (), b.parts.size ());
    for (std::size_t k = 0; k < a.parts.size (); ++k)
    {
      EXPECT_EQ (a.parts[k].type, b.parts[k].type);
      EXPECT_LT ((a.parts[k].center - b.parts[k].center).norm (), 1e-5);
      EXPECT_LT ((a.parts[k].half_size - b.parts[k].half_size).norm (), 1e-5);
      EXPECT_NEAR (a.parts[k].yaw, b.parts[k].yaw, 1e-5);
    }
  }
  for (std::size_t k = 0; k < 2; ++k)
    EXPECT_LT ((again.path.waypoints[k].eye - scene.path.waypoints[k].eye).norm (), 1e-6);

  test::expectError ([&] { simulation::SyntheticScene::parse ("waypoint eye=1,1,1 target=2,1,1\nobject a\n box center=0,0,0 size=1,1,1\n", "one.scene"); },
                     "one.scene", "two waypoints");
  test::expectError ([&] { simulation::SyntheticScene::parse ("waypoint eye=1,1,1 target=1,1,3\n", "up.scene"); }, "up.scene:1",
                     "straight above");
}

TEST (RandomRoom, RoomsAreSoundAndReproducible)
{
  // Seeds drawn at random (the draw itself seeded, so a failure reproduces), every room type.
  std::mt19937 draw (2026);
  for (const simulation::RoomType type : {simulation::RoomType::Kitchen, simulation::RoomType::Office, simulation::RoomType::Living})
    for (int k = 0; k < 2; ++k)
    {
      simulation::RoomConfig config;
      config.type = type;
      const std::uint64_t seed = draw ();
      SCOPED_TRACE (std::string (simulation::roomTypeName (type)) + " seed " + std::to_string (seed));
      const simulation::SyntheticScene room = simulation::generateRoom (config, seed);
      EXPECT_EQ (room.text (), simulation::generateRoom (config, seed).text ());

      // Floor, ceiling and four walls are stuff; the room measures 3–6 m a side.
      int walls = 0, objects = 0, small = 0;
      Eigen::AlignedBox3d floor;
      for (const simulation::SceneObject& o : room.objects)
      {
        walls += o.class_name == "wall" ? 1 : 0;
        if (o.class_name == "floor")
          floor = o.bounds ();
        if (o.detectable)
        {
          ++objects;
          small += o.bounds ().sizes ().maxCoeff () < 0.3 ? 1 : 0;
        }
        if (o.class_name == "floor" || o.class_name == "wall" || o.class_name == "ceiling" || o.class_name == "counter")
        {
          EXPECT_FALSE (o.detectable) << o.name;
        }
      }
      EXPECT_EQ (walls, 4);
      const Eigen::Vector2d inside = floor.sizes ().head<2> () - Eigen::Vector2d::Constant (0.2);
      EXPECT_GE (inside.minCoeff (), 3.0 - 1e-9);
      EXPECT_LE (inside.maxCoeff (), 6.0 + 1e-9);
      EXPECT_GE (objects, 8);
      EXPECT_GE (small, 4);

      // Nothing overlaps another thing, everything stands on something.
      for (const simulation::SceneObject& o : room.objects)
      {
        if (!o.detectable)
          continue;
        EXPECT_TRUE (standsOnSomething (room, o)) << o.name;
        for (const simulation::SceneObject& other : room.objects)
          if (&other != &o && o.bounds ().intersects (other.bounds ()))
          {
            EXPECT_EQ (pointsInside (o, other), 0) << o.name << " in " << other.name;
          }
      }

      // The camera: at standing height, clear of everything along the whole path, each
      // waypoint 1–4 m from what it looks at, which is in sight.
      ASSERT_EQ (room.path.waypoints.size (), static_cast<std::size_t> (config.waypoints));
      for (const simulation::CameraWaypoint& w : room.path.waypoints)
      {
        const double d = (w.target - w.eye).norm ();
        EXPECT_GE (d, 1.0 - 1e-9);
        EXPECT_LE (d, 4.0 + 1e-9);
        EXPECT_GE (w.eye.z (), 1.2 - 1e-9);
        EXPECT_LE (w.eye.z (), 1.7 + 1e-9);
      }
      for (int i = 0; i <= 100; ++i)
      {
        const Eigen::Vector3d eye = room.cameraPoseAt (i / 100.0).translation ();
        for (const simulation::SceneObject& o : room.objects)
          for (const simulation::Primitive& p : o.parts)
            EXPECT_FALSE (p.contains (eye, 0.2)) << "frame " << i << " in " << o.name;
      }
    }
}

TEST (RandomRoom, RefusesAbsurdSettings)
{
  simulation::RoomConfig config;
  config.min_extent = 8;
  test::expectError ([&] { simulation::generateRoom (config, 1); }, "RoomConfig::min_extent", "min_extent");
  config = simulation::RoomConfig ();
  config.waypoints = 1;
  EXPECT_THROW (simulation::generateRoom (config, 1), ParameterError);
  test::expectError ([] { simulation::parseRoomType ("garage", "--room"); }, "--room", "kitchen, office or living");
  EXPECT_EQ (simulation::parseRoomType ("office"), simulation::RoomType::Office);
}
