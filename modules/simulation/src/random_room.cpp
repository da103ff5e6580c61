// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/simulation/random_room.h>
#include <cuefusion/simulation/scene_renderer.h>

#include "scene_shapes.h"

#include <algorithm>
#include <cmath>

namespace cuefusion
{
namespace simulation
{
RoomType
parseRoomType (const std::string& name, const std::string& option)
{
  if (name == "kitchen")
    return RoomType::Kitchen;
  if (name == "office")
    return RoomType::Office;
  if (name == "living")
    return RoomType::Living;
  throw ParameterError (option, "must be kitchen, office or living, not '" + name + "'");
}

const char*
roomTypeName (RoomType type)
{
  switch (type)
  {
    case RoomType::Kitchen: return "kitchen";
    case RoomType::Office: return "office";
    case RoomType::Living: return "living";
  }
  return "?";
}

void
RoomConfig::validate () const
{
  if (!(min_extent >= 2.5 && max_extent >= min_extent && max_extent <= 20.0))
    throw ParameterError ("RoomConfig::min_extent", "need 2.5 <= min_extent <= max_extent <= 20 (m)");
  if (!(min_distance >= 0.5 && max_distance >= min_distance && max_distance <= 10.0))
    throw ParameterError ("RoomConfig::min_distance", "need 0.5 <= min_distance <= max_distance <= 10 (m)");
  if (!(min_eye_height >= 0.3 && max_eye_height >= min_eye_height && max_eye_height <= 2.3))
    throw ParameterError ("RoomConfig::min_eye_height", "need 0.3 <= min_eye_height <= max_eye_height <= 2.3 (m)");
  if (waypoints < 2 || waypoints > 100)
    throw ParameterError ("RoomConfig::waypoints", "must lie in [2, 100]");
  if (!(clutter >= 0.0 && clutter <= 4.0))
    throw ParameterError ("RoomConfig::clutter", "must lie in [0, 4]");
}

namespace
{
using namespace shapes;

/** A horizontal surface small objects stand on (a counter, a desk, a shelf board, a table). */
struct Surface
{
  Eigen::Vector2d xy;    // centre (world)
  Eigen::Vector2d half;  // half extents along its own axes
  double yaw = 0.0;
  double z = 0.0;
  double max_height = 0.35;  // room above it (shelves)
};

/** A footprint already taken on a surface, for placing the next objects. */
struct Taken
{
  Eigen::Vector2d xy;
  double radius;
  Shape shape;
  double yaw;
};

/** What the camera looks at: a point on a piece of furniture and the direction it is seen from. */
struct Interest
{
  Eigen::Vector3d target;
  Eigen::Vector2d facing;  // unit, into the room; zero: from anywhere
};

class RoomBuilder
{
public:
  RoomBuilder (const RoomConfig& config, std::uint64_t seed) : c_ (config), rng_ (mixSeed (seed, 0x400d)) {}

  SyntheticScene build ();

private:
  // Walls: 0 south (y = 0), 1 east (x = W), 2 north (y = D), 3 west (x = 0), seen from inside.
  double wallLength (int w) const { return w % 2 == 0 ? size_.x () : size_.y (); }
  double wallYaw (int w) const { return w * kPi / 2; }
  /** World point of (u along the wall from its start, v out into the room). */
  Eigen::Vector2d onWall (int w, double u, double v) const
  {
    static const Eigen::Vector2d starts[4] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    const Eigen::Vector2d start = starts[w].cwiseProduct (size_);
    return start + rotate2 (Eigen::Vector2d (u, v), wallYaw (w));
  }
  /** Free intervals along a wall: takes [u, u + length] of it with a random start, or returns false. */
  bool takeWall (int w, double length, double& u);

  void shell ();
  void add (SceneObject o, const std::string& name, const std::string& class_name, const std::array<std::uint8_t, 3>& rgb);
  bool place (const Shape& shape, const Eigen::Vector2d& xy, double yaw, const std::string& name, const std::string& class_name,
              const std::array<std::uint8_t, 3>& rgb, double base_z = 0.0);
  bool collides (const SceneObject& o) const;
  void againstWall (int w, double u, double depth, const Shape& shape, const std::string& name, const std::string& class_name,
                    const std::array<std::uint8_t, 3>& rgb);
  void look (const Eigen::Vector3d& target, const Eigen::Vector2d& facing) { interests_.push_back ({target, facing}); }

  int smallCount (double area);
  void smallObjects (const Surface& s, int count, std::vector<Taken> taken = {});
  bool placeSmall (const Surface& s, const Shape& shape, std::vector<Taken>& taken);

  Shape cabinetShape (double width, double depth, double height, double z0, int doors);
  void kitchen ();
  void office ();
  void living ();
  void cabinetRun (int w, double length, bool wall_cabinets);
  void desk (int w);
  void bookshelf (int w);
  void lowCabinet (int w, bool with_tv);
  void sofa (int w);
  void refrigerator (int w);
  bool freeFloor (const Eigen::Vector2d& xy, const Eigen::Vector2d& half, double yaw, double margin) const;
  void table (double height, Eigen::Vector2d half, int chairs);

  bool clearAt (const Eigen::Vector3d& eye, double margin) const;
  bool findEye (const Interest& interest, const SceneRenderer& renderer, CameraWaypoint& w);
  void cameraPath ();

  RoomConfig c_;
  Rng rng_;
  Eigen::Vector2d size_;
  double height_ = 2.6;
  SyntheticScene scene_;
  std::vector<std::vector<std::pair<double, double>>> wall_taken_ = std::vector<std::vector<std::pair<double, double>>> (4);
  std::vector<Interest> interests_;
  int count_ = 0;
};

bool
RoomBuilder::takeWall (int w, double length, double& u)
{
  const double total = wallLength (w);
  if (length > total - 0.2)
    return false;
  for (int attempt = 0; attempt < 20; ++attempt)
  {
    u = uniform (rng_, 0.1, total - 0.1 - length);
    bool free = true;
    for (const auto& [a, b] : wall_taken_[w])
      free = free && (u + length < a - 0.05 || u > b + 0.05);
    // The corners: a piece along the neighbouring wall may reach 0.75 m into this one.
    for (const int other : {(w + 3) % 4, (w + 1) % 4})
      for (const auto& [a, b] : wall_taken_[other])
      {
        const bool at_start = other == (w + 3) % 4 && b > wallLength (other) - 0.8;
        const bool at_end = other == (w + 1) % 4 && a < 0.8;
        free = free && !(at_start && u < 0.8) && !(at_end && u + length > total - 0.8);
      }
    if (free)
    {
      wall_taken_[w].push_back ({u, u + length});
      return true;
    }
  }
  return false;
}

void
RoomBuilder::add (SceneObject o, const std::string& name, const std::string& class_name, const std::array<std::uint8_t, 3>& rgb)
{
  o.name = name + std::to_string (++count_);
  o.class_name = class_name;
  o.rgb = rgb;
  scene_.objects.push_back (std::move (o));
}

bool
RoomBuilder::collides (const SceneObject& o) const
{
  // Solids may touch (a book against a book, a mug on the counter), never overlap: no point
  // of the new object's surface lies 3 mm or more inside another's, and no point of another's
  // inside the new one.
  std::vector<Eigen::Vector3d> points;
  double largest = 0.0;
  for (const Primitive& part : o.parts)
  {
    part.sampleSurface (0.02, points);
    largest = std::max (largest, part.boundingRadius ());
  }
  for (const SceneObject& other : scene_.objects)
    for (const Primitive& prim : other.parts)
    {
      const bool near = std::any_of (o.parts.begin (), o.parts.end (), [&] (const Primitive& part) {
        return (prim.center - part.center).norm () < prim.boundingRadius () + part.boundingRadius ();
      });
      if (!near)
        continue;
      if (std::any_of (points.begin (), points.end (), [&] (const Eigen::Vector3d& p) { return prim.contains (p, -0.003); }))
        return true;
      // ... nor the other way round (a thin cable inside a new box shows no point of the box);
      // only a solid no larger than the new one's parts can hide inside them.
      if (prim.boundingRadius () > largest)
        continue;
      std::vector<Eigen::Vector3d> theirs;
      prim.sampleSurface (0.02, theirs);
      for (const Eigen::Vector3d& p : theirs)
        for (const Primitive& part : o.parts)
          if (part.contains (p, -0.003))
            return true;
    }
  return false;
}

bool
RoomBuilder::place (const Shape& shape, const Eigen::Vector2d& xy, double yaw, const std::string& name,
                    const std::string& class_name, const std::array<std::uint8_t, 3>& rgb, double base_z)
{
  SceneObject o = instantiate (shape, xy, base_z, yaw);
  if (collides (o))
    return false;
  add (std::move (o), name, class_name, rgb);
  return true;
}

void
RoomBuilder::againstWall (int w, double u, double depth, const Shape& shape, const std::string& name,
                          const std::string& class_name, const std::array<std::uint8_t, 3>& rgb)
{
  // The shape is built centred on its own origin, its back along local y = -depth / 2.
  place (shape, onWall (w, u, depth / 2), wallYaw (w), name, class_name, rgb);
}

void
RoomBuilder::shell ()
{
  size_ = Eigen::Vector2d (uniform (rng_, c_.min_extent, c_.max_extent), uniform (rng_, c_.min_extent, c_.max_extent));
  height_ = uniform (rng_, 2.4, 2.9);
  const Eigen::Vector2d mid = size_ / 2;
  SceneObject floor = stuff ("floor", randomColor (rng_, 90, 210));
  floor.checker = chance (rng_, 0.4);
  floor.parts.push_back (box (Eigen::Vector3d (mid.x (), mid.y (), -0.01), Eigen::Vector3d (size_.x () + 0.2, size_.y () + 0.2, 0.02), 0));
  scene_.objects.push_back (floor);
  SceneObject ceiling = stuff ("ceiling", randomColor (rng_, 200, 245));
  ceiling.parts.push_back (box (Eigen::Vector3d (mid.x (), mid.y (), height_ + 0.01), Eigen::Vector3d (size_.x () + 0.2, size_.y () + 0.2, 0.02), 0));
  scene_.objects.push_back (ceiling);
  for (int w = 0; w < 4; ++w)
  {
    SceneObject wall = stuff ("wall", randomColor (rng_, 130, 235));
    const Eigen::Vector2d centre = onWall (w, wallLength (w) / 2, -0.05);
    wall.parts.push_back (box (Eigen::Vector3d (centre.x (), centre.y (), height_ / 2), Eigen::Vector3d (wallLength (w) + 0.2, 0.1, height_), wallYaw (w)));
    scene_.objects.push_back (wall);
  }
  for (std::size_t i = 0; i < scene_.objects.size (); ++i)
    scene_.objects[i].name = scene_.objects[i].class_name + (i < 2 ? "" : std::to_string (i - 1));
}

int
RoomBuilder::smallCount (double area)
{
  // About one object per 0.12 m² of free surface, at least one, scaled by the clutter.
  const double mean = c_.clutter * area / 0.12;
  return std::max (c_.clutter > 0 ? 1 : 0, static_cast<int> (std::round (mean * uniform (rng_, 0.6, 1.2))));
}

bool
RoomBuilder::placeSmall (const Surface& s, const Shape& shape, std::vector<Taken>& taken)
{
  for (int attempt = 0; attempt < 20; ++attempt)
  {
    Eigen::Vector2d at;  // in the surface's frame
    double yaw = uniform (rng_, 0, 2 * kPi);
    int partner = -1;
    if (!taken.empty () && chance (rng_, 0.4))
    {
      partner = std::uniform_int_distribution<int> (0, static_cast<int> (taken.size ()) - 1) (rng_);
      const Taken& other = taken[static_cast<std::size_t> (partner)];
      if (shape.plain_box && other.shape.plain_box)
      {
        // Flush against a face of the other box, sliding along it.
        yaw = other.yaw;
        const int axis = chance (rng_, 0.5) ? 0 : 1;
        Eigen::Vector2d offset;
        offset[axis] = (chance (rng_, 0.5) ? 1.0 : -1.0) * (other.shape.box_size[axis] + shape.box_size[axis]) / 2;
        offset[1 - axis] = uniform (rng_, -0.5, 0.5) * std::max (0.0, (other.shape.box_size[1 - axis] + shape.box_size[1 - axis]) / 2 - 0.02);
        at = other.xy + rotate2 (offset, other.yaw);
      }
      else
        at = other.xy + rotate2 (Eigen::Vector2d (other.radius + shape.radius, 0), uniform (rng_, 0, 2 * kPi));
    }
    else
      at = Eigen::Vector2d (uniform (rng_, -1, 1) * s.half.x (), uniform (rng_, -1, 1) * s.half.y ());
    if (std::abs (at.x ()) > s.half.x () - 0.7 * shape.radius || std::abs (at.y ()) > s.half.y () - 0.7 * shape.radius)
      continue;
    bool free = true;
    for (std::size_t j = 0; j < taken.size () && free; ++j)
      free = static_cast<int> (j) == partner || (at - taken[j].xy).norm () >= 0.92 * (shape.radius + taken[j].radius);
    if (!free || !place (shape, s.xy + rotate2 (at, s.yaw), yaw + s.yaw, "object", "object", randomColor (rng_), s.z))
      continue;
    taken.push_back ({at, shape.radius, shape, yaw});
    return true;
  }
  return false;
}

void
RoomBuilder::smallObjects (const Surface& s, int count, std::vector<Taken> taken)
{
  RandomSceneConfig shapes;
  shapes.min_size = 0.04;
  shapes.max_size = std::min (0.3, s.max_height);
  for (int i = 0; i < count; ++i)
  {
    Shape shape = randomShape (rng_, shapes);
    for (int retry = 0; retry < 5 && shape.height > s.max_height - 0.02; ++retry)
      shape = randomShape (rng_, shapes);
    if (shape.height <= s.max_height - 0.02)
      placeSmall (s, shape, taken);
  }
}

/** A cabinet of \a doors doors in its own frame (back at y = -depth / 2, floor or wall
  * mount at z0): a body, doors 2 cm proud of it with 3 mm gaps, a handle on each. */
Shape
RoomBuilder::cabinetShape (double width, double depth, double height, double z0, int doors)
{
  Shape s;
  s.parts.push_back (box (Eigen::Vector3d (0, -0.01, z0 + height / 2), Eigen::Vector3d (width, depth - 0.02, height), 0));
  const double door = (width - 0.003 * (doors + 1)) / doors;
  for (int d = 0; d < doors; ++d)
  {
    const double x = -width / 2 + 0.003 + door / 2 + d * (door + 0.003);
    s.parts.push_back (box (Eigen::Vector3d (x, depth / 2 - 0.01, z0 + height / 2), Eigen::Vector3d (door, 0.02, height - 0.006), 0));
    const double hx = x + (d % 2 == 0 ? 1 : -1) * (door / 2 - 0.04);
    s.parts.push_back (box (Eigen::Vector3d (hx, depth / 2 + 0.01, z0 + height * (z0 > 0.5 ? 0.2 : 0.8)),
                            Eigen::Vector3d (0.015, 0.02, std::min (0.15, height / 4)), 0));
  }
  measure (s);
  return s;
}

void
RoomBuilder::cabinetRun (int w, double length, bool wall_cabinets)
{
  double u = 0;
  if (!takeWall (w, length, u))
    return;
  const std::array<std::uint8_t, 3> colour = randomColor (rng_, 60, 235);
  const auto modules = [&] (double depth, double height, double z0) {
    for (double x = 0; x < length - 0.01;)
    {
      double width = uniform (rng_, 0.4, 0.8);
      if (length - x - width < 0.3)
        width = length - x;
      againstWall (w, u + x + width / 2, depth, cabinetShape (width, depth, height, z0, width > 0.55 ? 2 : 1), "cabinet", "cabinet",
                   colour);
      x += width;
    }
  };
  modules (0.6, 0.88, 0.0);
  SceneObject counter = stuff ("counter", randomColor (rng_, 40, 230));
  counter.print = chance (rng_, 0.5);
  const Eigen::Vector2d centre = onWall (w, u + length / 2, 0.32);
  counter.parts.push_back (box (Eigen::Vector3d (centre.x (), centre.y (), 0.9), Eigen::Vector3d (length, 0.64, 0.04), wallYaw (w)));
  add (counter, "counter", "counter", counter.rgb);
  if (wall_cabinets)
    modules (0.35, 0.7, 1.45);
  Surface top{centre, Eigen::Vector2d (length / 2, 0.3), wallYaw (w), 0.92, wall_cabinets ? 0.5 : 0.4};
  smallObjects (top, smallCount (length * 0.6 * 1.5));
  const Eigen::Vector2d facing = rotate2 (Eigen::Vector2d (0, 1), wallYaw (w));
  for (const double f : length > 2.5 ? std::vector<double>{0.25, 0.75} : std::vector<double>{0.5})
  {
    const Eigen::Vector2d at = onWall (w, u + f * length, 0.3);
    look (Eigen::Vector3d (at.x (), at.y (), 1.0), facing);
  }
}

void
RoomBuilder::desk (int w)
{
  const double width = uniform (rng_, 1.2, 1.6), depth = 0.7, height = 0.74;
  double u = 0;
  if (!takeWall (w, width, u))
    return;
  Shape d;
  d.parts.push_back (box (Eigen::Vector3d (0, 0, height - 0.015), Eigen::Vector3d (width, depth, 0.03), 0));
  for (const double side : {-1.0, 1.0})
    d.parts.push_back (box (Eigen::Vector3d (side * (width / 2 - 0.015), 0, (height - 0.03) / 2), Eigen::Vector3d (0.03, depth, height - 0.03), 0));
  measure (d);
  againstWall (w, u + width / 2, depth, d, "desk", "desk", randomColor (rng_, 60, 230));

  // On it, in the desk's frame (x along the wall, y from its back edge): a monitor, a keyboard, a mouse, a cable.
  const Eigen::Vector2d origin = onWall (w, u + width / 2, depth / 2);
  const double yaw = wallYaw (w), top = height;
  const double mx = uniform (rng_, -0.2, 0.2) * width;
  Shape monitor;
  const double screen_w = uniform (rng_, 0.48, 0.68), screen_h = uniform (rng_, 0.28, 0.4), lift = uniform (rng_, 0.08, 0.15);
  monitor.parts.push_back (box (Eigen::Vector3d (0, 0, 0.0075), Eigen::Vector3d (0.22, 0.18, 0.015), 0));
  monitor.parts.push_back (box (Eigen::Vector3d (0, -0.04, lift / 2 + 0.05), Eigen::Vector3d (0.05, 0.03, lift + 0.1), 0));
  monitor.parts.push_back (box (Eigen::Vector3d (0, -0.01, lift + screen_h / 2), Eigen::Vector3d (screen_w, 0.03, screen_h), 0));
  measure (monitor);
  place (monitor, origin + rotate2 (Eigen::Vector2d (mx, -depth / 2 + 0.15), yaw), yaw, "monitor", "monitor", randomColor (rng_, 20, 80), top);
  Shape keyboard;
  keyboard.parts.push_back (box (Eigen::Vector3d (0, 0, 0.01), Eigen::Vector3d (0.44, 0.14, 0.02), 0));
  for (int row = 0; row < 5; ++row)
    for (int col = 0; col < 14; ++col)
      keyboard.parts.push_back (box (Eigen::Vector3d (-0.2 + col * 0.0308, -0.052 + row * 0.026, 0.025), Eigen::Vector3d (0.022, 0.02, 0.01), 0));
  measure (keyboard);
  const double kx = mx + uniform (rng_, -0.08, 0.08), ky = -depth / 2 + uniform (rng_, 0.4, 0.5);
  place (keyboard, origin + rotate2 (Eigen::Vector2d (kx, ky), yaw), yaw + uniform (rng_, -0.15, 0.15), "keyboard", "keyboard",
         randomColor (rng_, 20, 200), top);
  Shape mouse;
  mouse.parts.push_back (box (Eigen::Vector3d (0, 0, 0.0175), Eigen::Vector3d (0.06, 0.1, 0.035), 0));
  measure (mouse);
  const double side = kx > 0 ? -1.0 : 1.0;  // the mouse where the desk has room, the paper across
  const double mouse_x = kx + side * uniform (rng_, 0.3, 0.38);
  place (mouse, origin + rotate2 (Eigen::Vector2d (mouse_x, ky), yaw), yaw + uniform (rng_, -0.4, 0.4), "mouse", "mouse",
         randomColor (rng_), top);
  Shape cable;  // from behind the monitor's foot along the desk to its back edge, in two straight runs
  const double run = uniform (rng_, 0.2, 0.4) * (chance (rng_, 0.5) ? 1 : -1);
  cable.parts.push_back (box (Eigen::Vector3d (run / 2, 0, 0.006), Eigen::Vector3d (std::abs (run), 0.012, 0.012), 0));
  cable.parts.push_back (box (Eigen::Vector3d (run, -0.06, 0.006), Eigen::Vector3d (0.012, 0.12, 0.012), 0));
  measure (cable);
  place (cable, origin + rotate2 (Eigen::Vector2d (mx, -depth / 2 + 0.26), yaw), yaw, "cable", "cable", randomColor (rng_, 10, 60), top);
  Shape paper;
  paper.parts.push_back (box (Eigen::Vector3d (0, 0, 0.0015), Eigen::Vector3d (0.21, 0.297, 0.003), 0));
  measure (paper);
  const double px = kx - side * uniform (rng_, 0.42, 0.5);
  if (std::abs (px) < width / 2 - 0.18)
    place (paper, origin + rotate2 (Eigen::Vector2d (px, uniform (rng_, -0.1, 0.15)), yaw), yaw + uniform (rng_, -0.5, 0.5), "paper",
           "paper", randomColor (rng_, 200, 250), top);

  std::vector<Taken> taken{{Eigen::Vector2d (mx, -depth / 2 + 0.15), 0.25, {}, 0},
                           {Eigen::Vector2d (kx, ky), 0.24, {}, 0},
                           {Eigen::Vector2d (mouse_x, ky), 0.07, {}, 0},
                           {Eigen::Vector2d (px, 0.02), 0.19, {}, 0}};
  smallObjects (Surface{origin, Eigen::Vector2d (width / 2, depth / 2), yaw, top, 0.4}, smallCount (width * depth * 0.5), taken);
  look (Eigen::Vector3d (origin.x (), origin.y (), 0.95), rotate2 (Eigen::Vector2d (0, 1), yaw));

  // An office chair in front of it, turned a little.
  Shape chair;
  chair.parts.push_back (cylinder (Eigen::Vector3d (0, 0, 0.02), 0.3, 0.04));
  chair.parts.push_back (cylinder (Eigen::Vector3d (0, 0, 0.23), 0.025, 0.38));
  chair.parts.push_back (box (Eigen::Vector3d (0, 0, 0.45), Eigen::Vector3d (0.46, 0.46, 0.07), 0));
  chair.parts.push_back (box (Eigen::Vector3d (0, -0.22, 0.75), Eigen::Vector3d (0.44, 0.05, 0.5), 0));
  measure (chair);
  place (chair, onWall (w, u + width / 2 + uniform (rng_, -0.2, 0.2), depth + uniform (rng_, 0.3, 0.5)),
         yaw + kPi + uniform (rng_, -0.5, 0.5), "chair", "chair", randomColor (rng_, 20, 120));
}

void
RoomBuilder::bookshelf (int w)
{
  const double width = uniform (rng_, 0.6, 1.0), depth = 0.3, height = uniform (rng_, 1.5, 2.0);
  const int boards = height > 1.75 ? 5 : 4;
  double u = 0;
  if (!takeWall (w, width, u))
    return;
  Shape shelf;
  for (const double side : {-1.0, 1.0})
    shelf.parts.push_back (box (Eigen::Vector3d (side * (width / 2 - 0.01), 0, height / 2), Eigen::Vector3d (0.02, depth, height), 0));
  shelf.parts.push_back (box (Eigen::Vector3d (0, -depth / 2 + 0.005, height / 2), Eigen::Vector3d (width - 0.04, 0.01, height), 0));
  const double gap = (height - 0.02) / boards;
  for (int b = 0; b <= boards; ++b)
    shelf.parts.push_back (box (Eigen::Vector3d (0, 0.005, 0.01 + b * gap), Eigen::Vector3d (width - 0.04, depth - 0.01, 0.02), 0));
  measure (shelf);
  againstWall (w, u + width / 2, depth, shelf, "shelf", "shelf", randomColor (rng_, 60, 230));
  const Eigen::Vector2d origin = onWall (w, u + width / 2, depth / 2);
  const double yaw = wallYaw (w);
  for (int b = 0; b < boards; ++b)
  {
    const double z = 0.02 + b * gap;
    // A row of books standing against one another, now and then a gap; small objects after them.
    double x = -width / 2 + 0.02 + (chance (rng_, 0.5) ? 0.0 : uniform (rng_, 0.0, 0.2));
    const double end = x + uniform (rng_, 0.3, 0.9) * (width - 0.04);
    while (x < end)
    {
      const double thick = uniform (rng_, 0.02, 0.05), tall = uniform (rng_, 0.15, std::min (0.3, gap - 0.04)),
                   deep = uniform (rng_, 0.14, 0.24);
      if (x + thick > width / 2 - 0.02)
        break;
      Shape book;
      book.parts.push_back (box (Eigen::Vector3d (0, 0, tall / 2), Eigen::Vector3d (thick, deep, tall), 0));
      measure (book);
      place (book, origin + rotate2 (Eigen::Vector2d (x + thick / 2, -depth / 2 + 0.015 + deep / 2), yaw), yaw, "book", "book",
             randomColor (rng_), z);
      x += thick + (chance (rng_, 0.12) ? uniform (rng_, 0.02, 0.1) : 0.0);
    }
    const double free_w = width / 2 - 0.02 - x;
    if (free_w > 0.12)
      smallObjects (Surface{origin + rotate2 (Eigen::Vector2d (x + free_w / 2, 0.0), yaw), Eigen::Vector2d (free_w / 2, depth / 2 - 0.02),
                            yaw, z, gap - 0.04},
                    smallCount (free_w * depth * 0.7));
  }
  look (Eigen::Vector3d (origin.x (), origin.y (), std::min (1.2, height / 2)), rotate2 (Eigen::Vector2d (0, 1), yaw));
}

void
RoomBuilder::refrigerator (int w)
{
  double u = 0;
  if (takeWall (w, 0.7, u))
  {
    againstWall (w, u + 0.35, 0.68, cabinetShape (0.7, 0.68, 1.8, 0.0, 1), "refrigerator", "refrigerator", randomColor (rng_, 150, 250));
    const Eigen::Vector2d at = onWall (w, u + 0.35, 0.3);
    look (Eigen::Vector3d (at.x (), at.y (), 1.0), rotate2 (Eigen::Vector2d (0, 1), wallYaw (w)));
  }
}

void
RoomBuilder::lowCabinet (int w, bool with_tv)
{
  const double width = uniform (rng_, 0.9, 1.6), depth = uniform (rng_, 0.4, 0.5), height = uniform (rng_, 0.45, 0.8);
  double u = 0;
  if (!takeWall (w, width, u))
    return;
  againstWall (w, u + width / 2, depth, cabinetShape (width, depth, height, 0.0, width > 1.2 ? 3 : 2), "cabinet", "cabinet",
               randomColor (rng_, 60, 235));
  const Eigen::Vector2d origin = onWall (w, u + width / 2, depth / 2);
  const double yaw = wallYaw (w);
  std::vector<Taken> taken;
  if (with_tv)
  {
    Shape tv;
    const double screen_w = std::min (width - 0.1, uniform (rng_, 0.9, 1.3)), screen_h = screen_w * 0.58;
    tv.parts.push_back (box (Eigen::Vector3d (0, 0, 0.01), Eigen::Vector3d (0.3, 0.2, 0.02), 0));
    tv.parts.push_back (box (Eigen::Vector3d (0, -0.02, 0.07), Eigen::Vector3d (0.06, 0.03, 0.1), 0));
    tv.parts.push_back (box (Eigen::Vector3d (0, 0, 0.1 + screen_h / 2), Eigen::Vector3d (screen_w, 0.05, screen_h), 0));
    measure (tv);
    place (tv, origin, yaw, "tv", "tv", randomColor (rng_, 10, 50), height);
    taken.push_back ({Eigen::Vector2d::Zero (), screen_w / 2, {}, 0});
  }
  smallObjects (Surface{origin, Eigen::Vector2d (width / 2, depth / 2 - 0.02), yaw, height, 0.4}, smallCount (width * depth * 0.6), taken);
  look (Eigen::Vector3d (origin.x (), origin.y (), height + 0.1), rotate2 (Eigen::Vector2d (0, 1), yaw));
}

void
RoomBuilder::sofa (int w)
{
  const double length = uniform (rng_, 1.6, 2.3), depth = 0.85, seat = 0.42;
  double u = 0;
  if (!takeWall (w, length, u))
    return;
  Shape s;
  s.parts.push_back (box (Eigen::Vector3d (0, 0.05, seat / 2), Eigen::Vector3d (length - 0.36, depth - 0.1, seat), 0));
  s.parts.push_back (box (Eigen::Vector3d (0, -depth / 2 + 0.1, 0.425), Eigen::Vector3d (length - 0.36, 0.2, 0.85), 0));
  for (const double side : {-1.0, 1.0})
    s.parts.push_back (box (Eigen::Vector3d (side * (length / 2 - 0.09), 0, 0.31), Eigen::Vector3d (0.18, depth, 0.62), 0));
  measure (s);
  againstWall (w, u + length / 2, depth, s, "sofa", "sofa", randomColor (rng_, 40, 200));
  const Eigen::Vector2d origin = onWall (w, u + length / 2, depth / 2);
  const double yaw = wallYaw (w);
  const int cushions = std::uniform_int_distribution<int> (1, 3) (rng_);
  for (int k = 0; k < cushions; ++k)
  {
    Shape cushion;
    const double cw = uniform (rng_, 0.35, 0.45), ch = uniform (rng_, 0.3, 0.4);
    cushion.parts.push_back (box (Eigen::Vector3d (0, 0, ch / 2), Eigen::Vector3d (cw, 0.14, ch), 0));
    measure (cushion);
    const double x = (k + 0.5) / cushions * (length - 0.36) - (length - 0.36) / 2 + uniform (rng_, -0.05, 0.05);
    place (cushion, origin + rotate2 (Eigen::Vector2d (x, -depth / 2 + 0.27), yaw), yaw + uniform (rng_, -0.2, 0.2), "cushion",
           "pillow", randomColor (rng_), seat);
  }
  look (Eigen::Vector3d (origin.x (), origin.y (), 0.6), rotate2 (Eigen::Vector2d (0, 1), yaw));
}

bool
RoomBuilder::freeFloor (const Eigen::Vector2d& xy, const Eigen::Vector2d& half, double yaw, double margin) const
{
  const Eigen::Vector2d grown = half + Eigen::Vector2d::Constant (margin);
  for (double a = -1; a <= 1.001; a += 0.25)
    for (double b = -1; b <= 1.001; b += 0.25)
    {
      const Eigen::Vector2d p = xy + rotate2 (Eigen::Vector2d (a * grown.x (), b * grown.y ()), yaw);
      if (p.x () < 0.3 || p.y () < 0.3 || p.x () > size_.x () - 0.3 || p.y () > size_.y () - 0.3)
        return false;
      for (const SceneObject& o : scene_.objects)
        for (const Primitive& prim : o.parts)
          if (o.detectable && (prim.contains (Eigen::Vector3d (p.x (), p.y (), 0.3), 0.0) ||
                               prim.contains (Eigen::Vector3d (p.x (), p.y (), 1.0), 0.0)))
            return false;
    }
  return true;
}

/** A table in the free middle of the room with \a chairs chairs around it and small objects on it. */
void
RoomBuilder::table (double height, Eigen::Vector2d half, int chairs)
{
  Eigen::Vector2d xy;
  const double yaw = uniform (rng_, 0, kPi);
  bool found = false;
  for (int attempt = 0; attempt < 30 && !found; ++attempt)
  {
    xy = Eigen::Vector2d (uniform (rng_, 0.25, 0.75) * size_.x (), uniform (rng_, 0.25, 0.75) * size_.y ());
    found = freeFloor (xy, half, yaw, chairs > 0 ? 0.6 : 0.3);
  }
  if (!found)
    return;
  Shape t;
  t.parts.push_back (box (Eigen::Vector3d (0, 0, height - 0.02), Eigen::Vector3d (2 * half.x (), 2 * half.y (), 0.04), 0));
  for (const double sx : {-1.0, 1.0})
    for (const double sy : {-1.0, 1.0})
      t.parts.push_back (box (Eigen::Vector3d (sx * (half.x () - 0.05), sy * (half.y () - 0.05), (height - 0.04) / 2),
                              Eigen::Vector3d (0.05, 0.05, height - 0.04), 0));
  measure (t);
  place (t, xy, yaw, "table", "table", randomColor (rng_, 40, 200));
  const std::array<std::uint8_t, 3> colour = randomColor (rng_, 30, 220);
  for (int k = 0; k < chairs; ++k)
  {
    Shape chair;
    chair.parts.push_back (box (Eigen::Vector3d (0, 0, 0.44), Eigen::Vector3d (0.42, 0.42, 0.04), 0));
    chair.parts.push_back (box (Eigen::Vector3d (0, -0.19, 0.7), Eigen::Vector3d (0.42, 0.04, 0.5), 0));
    for (const double sx : {-1.0, 1.0})
      for (const double sy : {-1.0, 1.0})
        chair.parts.push_back (box (Eigen::Vector3d (sx * 0.18, sy * 0.18, 0.21), Eigen::Vector3d (0.035, 0.035, 0.42), 0));
    measure (chair);
    // Chairs at the long sides, facing the table, pulled out a little.
    const double side = k % 2 == 0 ? 1.0 : -1.0, along = (k / 2 == 0 ? -0.5 : 0.5) * (half.x () - 0.3);
    const Eigen::Vector2d at (along, side * (half.y () + uniform (rng_, 0.1, 0.3)));
    place (chair, xy + rotate2 (at, yaw), yaw + (side > 0 ? kPi : 0.0) + uniform (rng_, -0.3, 0.3), "chair", "chair", colour);
  }
  smallObjects (Surface{xy, half - Eigen::Vector2d::Constant (0.03), yaw, height, 0.4}, smallCount (4 * half.x () * half.y () * 0.6));
  look (Eigen::Vector3d (xy.x (), xy.y (), height + 0.1), Eigen::Vector2d::Zero ());
}

void
RoomBuilder::kitchen ()
{
  const int w = std::uniform_int_distribution<int> (0, 3) (rng_);
  cabinetRun (w, uniform (rng_, 1.8, std::min (4.0, wallLength (w) - 0.4)), chance (rng_, 0.7));
  if (chance (rng_, 0.6))
    cabinetRun ((w + 1) % 4, uniform (rng_, 1.2, std::min (3.0, wallLength ((w + 1) % 4) - 1.2)), chance (rng_, 0.5));
  refrigerator ((w + 2 + std::uniform_int_distribution<int> (0, 1) (rng_)) % 4);
  if (chance (rng_, 0.5))
    lowCabinet ((w + 3) % 4, false);
  table (0.75, Eigen::Vector2d (uniform (rng_, 0.5, 0.8), uniform (rng_, 0.4, 0.5)), std::uniform_int_distribution<int> (2, 4) (rng_));
}

void
RoomBuilder::office ()
{
  const int w = std::uniform_int_distribution<int> (0, 3) (rng_);
  desk (w);
  if (chance (rng_, 0.6))
    desk (chance (rng_, 0.5) ? w : (w + 1) % 4);
  bookshelf ((w + 2) % 4);
  if (chance (rng_, 0.5))
    bookshelf ((w + 1 + 2 * std::uniform_int_distribution<int> (0, 1) (rng_)) % 4);
  lowCabinet ((w + 3) % 4, false);
}

void
RoomBuilder::living ()
{
  const int w = std::uniform_int_distribution<int> (0, 3) (rng_);
  sofa (w);
  lowCabinet ((w + 2) % 4, true);
  bookshelf ((w + 1 + 2 * std::uniform_int_distribution<int> (0, 1) (rng_)) % 4);
  if (chance (rng_, 0.5))
    bookshelf ((w + 1) % 4);
  table (0.45, Eigen::Vector2d (uniform (rng_, 0.4, 0.6), uniform (rng_, 0.25, 0.35)), 0);
}

bool
RoomBuilder::clearAt (const Eigen::Vector3d& eye, double margin) const
{
  if (eye.x () < margin || eye.y () < margin || eye.x () > size_.x () - margin || eye.y () > size_.y () - margin)
    return false;
  for (const SceneObject& o : scene_.objects)
    for (const Primitive& prim : o.parts)
      if (prim.contains (eye, margin))
        return false;
  return true;
}

bool
RoomBuilder::findEye (const Interest& interest, const SceneRenderer& renderer, CameraWaypoint& w)
{
  for (int attempt = 0; attempt < 60; ++attempt)
  {
    const double distance = uniform (rng_, c_.min_distance, c_.max_distance);
    const double z = uniform (rng_, c_.min_eye_height, c_.max_eye_height), rise = z - interest.target.z ();
    if (distance < std::abs (rise) + 0.3)
      continue;
    const bool anywhere = interest.facing.isZero () || attempt >= 40;
    const Eigen::Vector2d facing = anywhere ? Eigen::Vector2d (1, 0) : interest.facing;
    const Eigen::Vector2d dir = rotate2 (facing, anywhere ? uniform (rng_, 0, 2 * kPi) : uniform (rng_, -0.8, 0.8));
    const Eigen::Vector2d xy = interest.target.head<2> () + std::sqrt (distance * distance - rise * rise) * dir;
    const Eigen::Vector3d eye (xy.x (), xy.y (), z);
    if (!clearAt (eye, 0.35))
      continue;
    // The point looked at must be in sight (a little short of it: it may be on an object).
    const Eigen::Vector3d ray = (interest.target - eye).normalized ();
    double t;
    Eigen::Vector3d n;
    if (renderer.castRay (eye, ray, t, n) == 0 || t < 0.8 * distance)
      continue;
    w.eye = eye;
    w.target = interest.target;
    return true;
  }
  return false;
}

void
RoomBuilder::cameraPath ()
{
  // The points looked at in their order around the room's centre; the path visits a run of
  // consecutive ones from a random start, so the camera turns steadily as a person would.
  const Eigen::Vector2d mid = size_ / 2;
  std::sort (interests_.begin (), interests_.end (), [&] (const Interest& a, const Interest& b) {
    return std::atan2 (a.target.y () - mid.y (), a.target.x () - mid.x ()) < std::atan2 (b.target.y () - mid.y (), b.target.x () - mid.x ());
  });
  const SceneRenderer renderer (scene_);
  for (int attempt = 0; attempt < 40; ++attempt)
  {
    scene_.path.waypoints.clear ();
    std::size_t k = std::uniform_int_distribution<std::size_t> (0, interests_.size () - 1) (rng_);
    for (int i = 0; i < c_.waypoints; ++i, ++k)
    {
      CameraWaypoint w;
      if (!findEye (interests_[k % interests_.size ()], renderer, w))
        break;
      scene_.path.waypoints.push_back (w);
    }
    if (scene_.path.waypoints.size () < static_cast<std::size_t> (c_.waypoints))
      continue;
    // Between the waypoints too the camera stays clear of walls and furniture.
    bool clear = true;
    for (int i = 0; i <= 200 && clear; ++i)
      clear = clearAt (scene_.path.poseAt (i / 200.0).translation (), 0.25);
    if (clear)
      return;
  }
  throw Error ("generateRoom", "found no camera path through the room (try another seed or a larger room)");
}

SyntheticScene
RoomBuilder::build ()
{
  scene_.name = std::string (roomTypeName (c_.type)) + "-room";
  scene_.camera = PinholeCamera (525.0, 525.0, 319.5, 239.5, 640, 480);
  shell ();
  if (c_.type == RoomType::Kitchen)
    kitchen ();
  else if (c_.type == RoomType::Office)
    office ();
  else
    living ();
  for (std::size_t i = 0; i < scene_.objects.size (); ++i)
    scene_.objects[i].id = static_cast<std::uint16_t> (i + 1);
  if (interests_.empty ())
    throw Error ("generateRoom", "no furniture fitted in the room");
  scene_.trajectory.target = Eigen::Vector3d (size_.x () / 2, size_.y () / 2, 0.8);
  cameraPath ();
  return scene_;
}
}  // namespace

SyntheticScene
generateRoom (const RoomConfig& config, std::uint64_t seed)
{
  config.validate ();
  return RoomBuilder (config, seed).build ();
}
}  // namespace simulation
}  // namespace cuefusion
