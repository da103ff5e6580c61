// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include "test_utils.h"

#include <cuefusion/simulation/scene_renderer.h>
#include <cuefusion/simulation/synthetic_scene.h>
#include <cuefusion/reconstruction/tsdf_volume.h>

#include <cmath>
#include <string>

namespace cuefusion
{
namespace test
{
/** The volume's model seen from \a pose (TSDFVolume::raycast into a new result). */
inline reconstruction::RaycastResult
rendered (const reconstruction::TSDFVolume& volume, const PinholeCamera& camera, const Eigen::Isometry3d& pose)
{
  reconstruction::RaycastResult out;
  volume.raycast (camera, pose, out);
  return out;
}

/** Raycast options with a depth hint (and a hole skip). */
inline reconstruction::RaycastOptions
withHint (const cv::Mat& hint, const reconstruction::RaycastHoleSkip& skip = reconstruction::RaycastHoleSkip ())
{
  reconstruction::RaycastOptions options;
  options.depth_hint = hint;
  options.hole_skip = skip;
  return options;
}

/** A sphere (r = 0.15 m) and a cube (0.24 m) floating side by side; the camera orbits them
  * a full turn. Primitive 0 of object 1 is the sphere, of object 2 the box.
  */
inline simulation::SyntheticScene
sphereAndBoxScene (int width = 320, int height = 240)
{
  const std::string text = "scene sphere_and_box\n"
                           "camera 640 480 525 525 319.5 239.5\n"
                           "trajectory target=0,0,0.75 radius=1.0 height=0.5 start=0 sweep=360 bob=0\n"
                           "object ball class=ball color=200,60,60\n"
                           "  sphere center=-0.2,0,0.75 radius=0.15\n"
                           "object cube class=box color=60,60,200\n"
                           "  box center=0.22,0.02,0.75 size=0.24,0.24,0.24 yaw=25\n";
  simulation::SyntheticScene scene = simulation::SyntheticScene::parse (text, "sphereAndBoxScene");
  scene.camera = scene.camera.scaled (width, height);
  return scene;
}

/** Signed distance from \a p to an (unrotated-in-local-frame) box primitive. */
inline double
boxDistance (const simulation::Primitive& box, const Eigen::Vector3d& p)
{
  const Eigen::Vector3d q = box.toLocal (p).cwiseAbs () - box.half_size;
  return q.cwiseMax (0.0).norm () + std::min (q.maxCoeff (), 0.0);
}

/** Integrates \a views evenly spaced views of the scene's orbit (exact depth). */
inline void
integrateOrbit (const simulation::SyntheticScene& scene, int views, reconstruction::TSDFVolume& volume)
{
  const simulation::SceneRenderer renderer (scene);
  for (int i = 0; i < views; ++i)
  {
    const Eigen::Isometry3d pose = scene.trajectory.poseAt (static_cast<double> (i) / views);
    const simulation::RenderedView view = renderer.render (scene.camera, pose);
    volume.integrate (view.depth, view.color, scene.camera, pose);
  }
}
}  // namespace test
}  // namespace cuefusion
