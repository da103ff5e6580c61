// SPDX-License-Identifier: BSD-3-Clause
#include "scene_shapes.h"

#include <algorithm>
#include <cmath>

namespace cuefusion
{
namespace simulation
{
namespace shapes
{
double
uniform (Rng& rng, double lo, double hi)
{
  return std::uniform_real_distribution<double> (lo, hi) (rng);
}

bool
chance (Rng& rng, double p)
{
  return uniform (rng, 0.0, 1.0) < p;
}

std::array<std::uint8_t, 3>
randomColor (Rng& rng, int lo, int hi)
{
  std::uniform_int_distribution<int> c (lo, hi);
  return {{static_cast<std::uint8_t> (c (rng)), static_cast<std::uint8_t> (c (rng)), static_cast<std::uint8_t> (c (rng))}};
}

Primitive
box (const Eigen::Vector3d& center, const Eigen::Vector3d& size, double yaw)
{
  Primitive p;
  p.type = Primitive::Type::Box;
  p.center = center;
  p.half_size = size / 2;
  p.yaw = yaw;
  return p;
}

Primitive
cylinder (const Eigen::Vector3d& center, double radius, double height)
{
  Primitive p;
  p.type = Primitive::Type::Cylinder;
  p.center = center;
  p.half_size = Eigen::Vector3d (radius, radius, height / 2);
  return p;
}

Primitive
sphere (const Eigen::Vector3d& center, double radius)
{
  Primitive p;
  p.type = Primitive::Type::Sphere;
  p.center = center;
  p.half_size = Eigen::Vector3d::Constant (radius);
  return p;
}

namespace
{
/** A figure (a soft toy): a body sphere with a smaller head sunk into its top, usually arms
  * at its sides, sometimes ears on the head and legs at the front; one object whose parts
  * meet at concave creases, like a snowman with limbs. Its body is drawn over the radii of
  * a single ball (min_size / 2 to max_size / 3): soft toys come as large as balls, and a
  * network that only saw small figures reads a large ball with a head as a ball with
  * something stacked on it. */
std::vector<Primitive>
figureParts (Rng& rng, double lo, double hi)
{
  std::vector<Primitive> parts;
  const double body = uniform (rng, lo / 2, hi / 3), head = body * uniform (rng, 0.55, 0.8);
  const double head_z = 2 * body + 0.7 * head;
  parts.push_back (sphere (Eigen::Vector3d (0, 0, body), body));
  parts.push_back (sphere (Eigen::Vector3d (0, 0, head_z), head));
  if (chance (rng, 0.8))  // arms
  {
    const double arm = body * uniform (rng, 0.25, 0.4), x = body * uniform (rng, 0.8, 1.0);
    const double y = body * uniform (rng, 0.0, 0.4), z = body * uniform (rng, 0.9, 1.5);
    for (const double side : {-1.0, 1.0})
      parts.push_back (sphere (Eigen::Vector3d (side * x, y, z), arm));
  }
  if (chance (rng, 0.6))  // ears
  {
    const double ear = head * uniform (rng, 0.3, 0.45), x = head * uniform (rng, 0.5, 0.8);
    const double z = head_z + head * uniform (rng, 0.6, 0.85);
    for (const double side : {-1.0, 1.0})
      parts.push_back (sphere (Eigen::Vector3d (side * x, 0, z), ear));
  }
  if (chance (rng, 0.5))  // legs
  {
    const double leg = body * uniform (rng, 0.3, 0.45);
    for (const double side : {-1.0, 1.0})
      parts.push_back (sphere (Eigen::Vector3d (side * body * 0.5, body * 0.75, leg), leg));
  }
  return parts;
}
}  // namespace

Shape
randomShape (Rng& rng, const RandomSceneConfig& c)
{
  const double lo = c.min_size, hi = c.max_size;
  Shape s;
  if (!chance (rng, c.multipart_probability))
  {
    const int kind = std::uniform_int_distribution<int> (0, 6) (rng);
    if (kind <= 3)  // boxes are the most common object on tables (OSD, YCB); some lie flat (books)
    {
      s.plain_box = true;
      const double height = kind == 3 ? uniform (rng, std::min (lo, 0.02), std::max (lo, 0.06)) : uniform (rng, lo, hi);
      s.box_size = Eigen::Vector3d (uniform (rng, lo, hi), uniform (rng, lo, hi), height);
      if (kind == 3)
        s.box_size.head<2> () = s.box_size.head<2> ().cwiseMax (Eigen::Vector2d::Constant (2.5 * height));
      s.parts.push_back (box (Eigen::Vector3d (0, 0, s.box_size.z () / 2), s.box_size, 0.0));
    }
    else if (kind <= 5)
    {
      const double r = uniform (rng, lo / 2, hi / 3), h = uniform (rng, lo, hi);
      s.parts.push_back (cylinder (Eigen::Vector3d (0, 0, h / 2), r, h));
    }
    else
    {
      const double r = uniform (rng, lo / 2, hi / 3);
      s.parts.push_back (sphere (Eigen::Vector3d (0, 0, r), r));
    }
  }
  else if (c.figure_probability > 0.0 && chance (rng, c.figure_probability))
    s.parts = figureParts (rng, lo, hi);
  else
  {
    // No lidded or stacked-looking compounds: a box on a box is two objects (stacking).
    const int kind = std::uniform_int_distribution<int> (0, 3) (rng);
    if (kind == 0)  // bottle: body and neck
    {
      const double r = uniform (rng, lo / 2, hi / 4), h = uniform (rng, std::max (lo, 3 * r), hi);
      const double neck = uniform (rng, 0.15, 0.35) * h;
      s.parts.push_back (cylinder (Eigen::Vector3d (0, 0, h / 2), r, h));
      s.parts.push_back (cylinder (Eigen::Vector3d (0, 0, h + neck / 2), r * uniform (rng, 0.3, 0.45), neck));
    }
    else if (kind == 1)  // L-block: two boxes
    {
      const double a = uniform (rng, lo * 2, hi), b = uniform (rng, lo, hi / 2), h = uniform (rng, lo, hi / 2);
      s.parts.push_back (box (Eigen::Vector3d (0, 0, h / 2), Eigen::Vector3d (a, b, h), 0.0));
      s.parts.push_back (box (Eigen::Vector3d (a / 2 - b / 2, b / 2 + a / 4, h / 2), Eigen::Vector3d (b, a / 2, h), 0.0));
    }
    else if (kind == 2)  // snowman: a sphere on a sphere
    {
      const double r1 = uniform (rng, lo / 2, hi / 4), r2 = r1 * uniform (rng, 0.5, 0.8);
      s.parts.push_back (sphere (Eigen::Vector3d (0, 0, r1), r1));
      s.parts.push_back (sphere (Eigen::Vector3d (0, 0, 2 * r1 + r2 * 0.7), r2));
    }
    else  // mug: a cylinder with a handle
    {
      const double r = uniform (rng, lo / 2, hi / 4), h = uniform (rng, lo, hi / 2);
      s.parts.push_back (cylinder (Eigen::Vector3d (0, 0, h / 2), r, h));
      s.parts.push_back (box (Eigen::Vector3d (r + 0.25 * r, 0, h / 2), Eigen::Vector3d (0.5 * r, 0.2 * r + 0.005, 0.6 * h), 0.0));
    }
  }
  measure (s);
  return s;
}

void
measure (Shape& s)
{
  s.radius = s.height = 0.0;
  for (const Primitive& p : s.parts)
  {
    const double extent = p.type == Primitive::Type::Box ? p.half_size.head<2> ().norm () : p.half_size.x ();
    s.radius = std::max (s.radius, p.center.head<2> ().norm () + extent);
    s.height = std::max (s.height, p.center.z () + p.half_size.z ());
  }
}

Eigen::Vector2d
rotate2 (const Eigen::Vector2d& v, double yaw)
{
  return Eigen::Vector2d (std::cos (yaw) * v.x () - std::sin (yaw) * v.y (), std::sin (yaw) * v.x () + std::cos (yaw) * v.y ());
}

SceneObject
instantiate (const Shape& shape, const Eigen::Vector2d& xy, double base_z, double yaw)
{
  SceneObject o;
  for (Primitive p : shape.parts)
  {
    const Eigen::Vector2d at = xy + rotate2 (p.center.head<2> (), yaw);
    p.center = Eigen::Vector3d (at.x (), at.y (), base_z + p.center.z ());
    p.yaw += yaw;
    o.parts.push_back (p);
  }
  return o;
}

SceneObject
stuff (const std::string& name, const std::array<std::uint8_t, 3>& rgb)
{
  SceneObject o;
  o.name = name;
  o.class_name = name;
  o.rgb = rgb;
  o.detectable = false;
  return o;
}
}  // namespace shapes
}  // namespace simulation
}  // namespace cuefusion
