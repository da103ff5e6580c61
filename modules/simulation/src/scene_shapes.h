// SPDX-License-Identifier: BSD-3-Clause
#pragma once
// Internal to the io module: the solids and small objects random scenes and rooms are drawn
// from (RandomSceneGenerator, generateRoom). Not installed.

#include <cuefusion/simulation/random_scene.h>

#include <random>
#include <string>
#include <vector>

namespace cuefusion
{
namespace simulation
{
namespace shapes
{
constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

using Rng = std::mt19937_64;

double uniform (Rng& rng, double lo, double hi);
bool chance (Rng& rng, double p);
std::array<std::uint8_t, 3> randomColor (Rng& rng, int lo = 20, int hi = 240);

Primitive box (const Eigen::Vector3d& center, const Eigen::Vector3d& size, double yaw);
Primitive cylinder (const Eigen::Vector3d& center, double radius, double height);
Primitive sphere (const Eigen::Vector3d& center, double radius);

/** An object built in its own frame: base centre at the origin on the support, z up. */
struct Shape
{
  std::vector<Primitive> parts;   // in the object frame (yaw 0)
  double radius = 0.0;            // footprint: circle around the origin holding every part
  double height = 0.0;
  bool plain_box = false;         // one box: may be placed flush against another, or carry one
  Eigen::Vector3d box_size = Eigen::Vector3d::Zero ();
};

/** A random small object (box, book, can, ball, bottle, L-block, snowman, mug, figure) of
  * extents in [c.min_size, c.max_size]. */
Shape randomShape (Rng& rng, const RandomSceneConfig& c);
/** Sets the footprint radius and height of a shape from its parts. */
void measure (Shape& shape);

Eigen::Vector2d rotate2 (const Eigen::Vector2d& v, double yaw);
/** The shape standing at \a xy on a support at height \a base_z, turned by \a yaw. */
SceneObject instantiate (const Shape& shape, const Eigen::Vector2d& xy, double base_z, double yaw);
/** An empty object a detector does not report (floor, walls). */
SceneObject stuff (const std::string& name, const std::array<std::uint8_t, 3>& rgb);
}  // namespace shapes
}  // namespace simulation
}  // namespace cuefusion
