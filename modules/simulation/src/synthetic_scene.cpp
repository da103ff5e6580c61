// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/data_directory.h>
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/simulation/synthetic_scene.h>
#include "scene_shapes.h"

#include <boost/algorithm/string.hpp>
#include <boost/filesystem.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <map>
#include <sstream>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace simulation
{
namespace
{
using shapes::kPi;

/** \a v turned about z by the angle whose cosine and sine are \a c and \a s. The renderer
  * calls this per ray and primitive: Eigen::AngleAxisd builds a whole 3×3 matrix from two
  * sines and cosines each time, which was most of a generated frame's rendering time. */
Eigen::Vector3d
turnAboutZ (const Eigen::Vector3d& v, double c, double s)
{
  return {c * v.x () - s * v.y (), s * v.x () + c * v.y (), v.z ()};
}
}  // namespace

Eigen::Vector3d
Primitive::toLocal (const Eigen::Vector3d& p) const
{
  return turnAboutZ (p - center, std::cos (yaw), -std::sin (yaw));
}

Eigen::Vector3d
Primitive::fromLocal (const Eigen::Vector3d& p) const
{
  return turnAboutZ (p, std::cos (yaw), std::sin (yaw)) + center;
}

Eigen::Vector3d
Primitive::directionFromLocal (const Eigen::Vector3d& d) const
{
  return turnAboutZ (d, std::cos (yaw), std::sin (yaw));
}

bool
Primitive::intersect (const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min, double& t,
                      Eigen::Vector3d& normal) const
{
  if (type == Type::Sphere)
    return intersect (origin, dir, t_min, 1.0, 0.0, t, normal);
  return intersect (origin, dir, t_min, std::cos (yaw), std::sin (yaw), t, normal);
}

bool
Primitive::intersect (const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min, double cos_yaw,
                      double sin_yaw, double& t, Eigen::Vector3d& normal) const
{
  if (type == Type::Sphere)
  {
    const double r = half_size.x ();
    const Eigen::Vector3d oc = origin - center;
    const double b = oc.dot (dir);
    const double c = oc.squaredNorm () - r * r;
    const double disc = b * b - c;
    if (disc < 0.0)
      return false;
    const double s = std::sqrt (disc);
    double hit = -b - s;
    if (hit <= t_min)
      hit = -b + s;
    if (hit <= t_min)
      return false;
    t = hit;
    normal = (origin + t * dir - center) / r;
    return true;
  }
  const Eigen::Vector3d o = turnAboutZ (origin - center, cos_yaw, -sin_yaw);
  const Eigen::Vector3d d = turnAboutZ (dir, cos_yaw, -sin_yaw);
  double best = std::numeric_limits<double>::infinity ();
  Eigen::Vector3d best_n;
  if (type == Type::Box)
  {
    // Slab test; the entry face gives the normal.
    double t0 = -std::numeric_limits<double>::infinity (), t1 = std::numeric_limits<double>::infinity ();
    int axis0 = -1, axis1 = -1;
    for (int a = 0; a < 3; ++a)
    {
      if (std::abs (d[a]) < 1e-15)
      {
        if (std::abs (o[a]) > half_size[a])
          return false;
        continue;
      }
      double ta = (-half_size[a] - o[a]) / d[a];
      double tb = (half_size[a] - o[a]) / d[a];
      if (ta > tb)
        std::swap (ta, tb);
      if (ta > t0)
      {
        t0 = ta;
        axis0 = a;
      }
      if (tb < t1)
      {
        t1 = tb;
        axis1 = a;
      }
    }
    if (t0 > t1)
      return false;
    if (t0 > t_min && axis0 >= 0)
    {
      best = t0;
      best_n = Eigen::Vector3d::Zero ();
      best_n[axis0] = d[axis0] > 0 ? -1.0 : 1.0;
    }
    else if (t1 > t_min && axis1 >= 0)
    {
      best = t1;
      best_n = Eigen::Vector3d::Zero ();
      best_n[axis1] = d[axis1] > 0 ? 1.0 : -1.0;
    }
  }
  else  // upright cylinder
  {
    const double r = half_size.x (), h = half_size.z ();
    const double a = d.x () * d.x () + d.y () * d.y ();
    if (a > 1e-15)
    {
      const double b = o.x () * d.x () + o.y () * d.y ();
      const double c = o.x () * o.x () + o.y () * o.y () - r * r;
      const double disc = b * b - a * c;
      if (disc >= 0.0)
      {
        const double s = std::sqrt (disc);
        for (double cand : {(-b - s) / a, (-b + s) / a})
        {
          const double z = o.z () + cand * d.z ();
          if (cand > t_min && cand < best && std::abs (z) <= h)
          {
            best = cand;
            best_n = Eigen::Vector3d (o.x () + cand * d.x (), o.y () + cand * d.y (), 0.0) / r;
          }
        }
      }
    }
    if (std::abs (d.z ()) > 1e-15)
      for (double cap : {-h, h})
      {
        const double cand = (cap - o.z ()) / d.z ();
        const double x = o.x () + cand * d.x (), y = o.y () + cand * d.y ();
        if (cand > t_min && cand < best && x * x + y * y <= r * r)
        {
          best = cand;
          best_n = Eigen::Vector3d (0, 0, cap > 0 ? 1.0 : -1.0);
        }
      }
  }
  if (!std::isfinite (best))
    return false;
  t = best;
  normal = turnAboutZ (best_n, cos_yaw, sin_yaw);
  return true;
}

bool
Primitive::contains (const Eigen::Vector3d& p, double margin) const
{
  if (type == Type::Sphere)
    return (p - center).norm () < half_size.x () + margin;
  const Eigen::Vector3d q = toLocal (p);
  if (type == Type::Box)
    return (q.cwiseAbs () - half_size).maxCoeff () < margin;
  return std::hypot (q.x (), q.y ()) < half_size.x () + margin && std::abs (q.z ()) < half_size.z () + margin;
}

void
Primitive::sampleSurface (double spacing, std::vector<Eigen::Vector3d>& points) const
{
  auto steps = [spacing] (double length) { return std::max (1, static_cast<int> (std::ceil (length / spacing))); };
  if (type == Type::Sphere)
  {
    // Fibonacci lattice: near-uniform points on the sphere.
    const double r = half_size.x ();
    const int n = std::max (8, static_cast<int> (4.0 * kPi * r * r / (spacing * spacing)));
    const double golden = kPi * (3.0 - std::sqrt (5.0));
    for (int i = 0; i < n; ++i)
    {
      const double z = 1.0 - 2.0 * (i + 0.5) / n;
      const double rho = std::sqrt (1.0 - z * z);
      points.push_back (center + r * Eigen::Vector3d (rho * std::cos (golden * i), rho * std::sin (golden * i), z));
    }
    return;
  }
  if (type == Type::Box)
  {
    for (int axis = 0; axis < 3; ++axis)
    {
      const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
      const int n1 = steps (2 * half_size[a1]), n2 = steps (2 * half_size[a2]);
      for (double side : {-1.0, 1.0})
        for (int i = 0; i < n1; ++i)
          for (int j = 0; j < n2; ++j)
          {
            Eigen::Vector3d q;
            q[axis] = side * half_size[axis];
            q[a1] = -half_size[a1] + (i + 0.5) * 2 * half_size[a1] / n1;
            q[a2] = -half_size[a2] + (j + 0.5) * 2 * half_size[a2] / n2;
            points.push_back (fromLocal (q));
          }
    }
    return;
  }
  const double r = half_size.x (), h = half_size.z ();
  const int n_around = steps (2 * kPi * r), n_up = steps (2 * h);
  for (int i = 0; i < n_around; ++i)
  {
    const double phi = 2 * kPi * (i + 0.5) / n_around;
    for (int j = 0; j < n_up; ++j)
      points.push_back (fromLocal ({r * std::cos (phi), r * std::sin (phi), -h + (j + 0.5) * 2 * h / n_up}));
  }
  const int n_cap = steps (2 * r);
  for (double cap : {-h, h})
    for (int i = 0; i < n_cap; ++i)
      for (int j = 0; j < n_cap; ++j)
      {
        const double x = -r + (i + 0.5) * 2 * r / n_cap, y = -r + (j + 0.5) * 2 * r / n_cap;
        if (x * x + y * y <= r * r)
          points.push_back (fromLocal ({x, y, cap}));
      }
}

Eigen::Isometry3d
OrbitTrajectory::poseAt (double s) const
{
  const double azimuth = (start_deg + sweep_deg * s) * kPi / 180.0;
  const Eigen::Vector3d position =
    target + Eigen::Vector3d (radius * std::cos (azimuth), radius * std::sin (azimuth),
                              height + bob * std::sin (2.0 * kPi * s));
  return lookAt (position, target);
}

Eigen::Isometry3d
CameraPath::poseAt (double s) const
{
  if (waypoints.size () < 2)
    throw ParameterError ("CameraPath::waypoints", "a path needs two waypoints or more");
  const double x = std::clamp (s, 0.0, 1.0) * static_cast<double> (waypoints.size () - 1);
  const std::size_t i = std::min (static_cast<std::size_t> (x), waypoints.size () - 2);
  const double t = x - static_cast<double> (i);
  const auto point = [&] (std::ptrdiff_t k) {
    return waypoints[static_cast<std::size_t> (std::clamp<std::ptrdiff_t> (k, 0, static_cast<std::ptrdiff_t> (waypoints.size ()) - 1))];
  };
  // Uniform Catmull-Rom through P1 (t = 0) and P2 (t = 1), the ends repeated.
  const auto spline = [t] (const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& p2,
                           const Eigen::Vector3d& p3) -> Eigen::Vector3d {
    return 0.5 * (2.0 * p1 + (p2 - p0) * t + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t * t +
                  (3.0 * p1 - p0 - 3.0 * p2 + p3) * t * t * t);
  };
  const auto k = static_cast<std::ptrdiff_t> (i);
  const Eigen::Vector3d eye = spline (point (k - 1).eye, point (k).eye, point (k + 1).eye, point (k + 2).eye);
  const Eigen::Vector3d target = spline (point (k - 1).target, point (k).target, point (k + 1).target, point (k + 2).target);
  return lookAt (eye, target);
}

Eigen::AlignedBox3d
SceneObject::bounds () const
{
  Eigen::AlignedBox3d box;
  for (const Primitive& p : parts)
  {
    Eigen::Vector3d half = p.half_size;
    if (p.type == Primitive::Type::Box)
    {
      const double c = std::abs (std::cos (p.yaw)), s = std::abs (std::sin (p.yaw));
      half.head<2> () = Eigen::Vector2d (c * p.half_size.x () + s * p.half_size.y (), s * p.half_size.x () + c * p.half_size.y ());
    }
    box.extend (p.center - half);
    box.extend (p.center + half);
  }
  return box;
}

Eigen::Isometry3d
SyntheticScene::cameraPoseAt (double s) const
{
  return path.waypoints.empty () ? trajectory.poseAt (s) : path.poseAt (s);
}

std::vector<std::string>
SyntheticScene::classNames () const
{
  std::vector<std::string> names;
  for (const SceneObject& o : objects)
    if (std::find (names.begin (), names.end (), o.class_name) == names.end ())
      names.push_back (o.class_name);
  return names;
}

std::uint16_t
SyntheticScene::classIdOf (const SceneObject& object) const
{
  const std::vector<std::string> names = classNames ();
  return static_cast<std::uint16_t> (std::find (names.begin (), names.end (), object.class_name) - names.begin () + 1);
}

const SceneObject*
SyntheticScene::objectById (std::uint16_t id) const
{
  for (const SceneObject& o : objects)
    if (o.id == id)
      return &o;
  return nullptr;
}

namespace
{
class LineParser
{
public:
  LineParser (const std::string& where, const std::vector<std::string>& tokens) : where_ (where)
  {
    for (std::size_t i = 1; i < tokens.size (); ++i)
    {
      const auto eq = tokens[i].find ('=');
      if (eq == std::string::npos)
        positional_.push_back (tokens[i]);
      else
        keys_[tokens[i].substr (0, eq)] = tokens[i].substr (eq + 1);
    }
  }

  double
  number (const std::string& text, const std::string& what) const
  {
    char* end = nullptr;
    const double v = std::strtod (text.c_str (), &end);
    if (text.empty () || *end != '\0' || !std::isfinite (v))
      throw Error (where_, what + ": '" + text + "' is not a number");
    return v;
  }

  double
  scalar (const std::string& key, double fallback, bool required = false)
  {
    auto it = keys_.find (key);
    if (it == keys_.end ())
    {
      if (required)
        throw Error (where_, "missing " + key + "=");
      return fallback;
    }
    const double v = number (it->second, key);
    keys_.erase (it);
    return v;
  }

  Eigen::Vector3d
  vector3 (const std::string& key, const Eigen::Vector3d& fallback, bool required = false)
  {
    auto it = keys_.find (key);
    if (it == keys_.end ())
    {
      if (required)
        throw Error (where_, "missing " + key + "=x,y,z");
      return fallback;
    }
    std::vector<std::string> parts;
    boost::algorithm::split (parts, it->second, boost::is_any_of (","));
    if (parts.size () != 3)
      throw Error (where_, key + " needs three comma-separated numbers");
    Eigen::Vector3d v (number (parts[0], key), number (parts[1], key), number (parts[2], key));
    keys_.erase (it);
    return v;
  }

  std::string
  text (const std::string& key, const std::string& fallback)
  {
    auto it = keys_.find (key);
    if (it == keys_.end ())
      return fallback;
    const std::string v = it->second;
    keys_.erase (it);
    return v;
  }

  bool
  flag (const std::string& key, bool fallback)
  {
    const std::string v = text (key, fallback ? "yes" : "no");
    if (v == "yes" || v == "true" || v == "1")
      return true;
    if (v == "no" || v == "false" || v == "0")
      return false;
    throw Error (where_, key + " must be yes or no");
  }

  const std::vector<std::string>& positional () const { return positional_; }

  /** Every key must have been used: a typo is an error, not a silent default. */
  void
  finish () const
  {
    if (!keys_.empty ())
      throw Error (where_, "unknown setting '" + keys_.begin ()->first + "'");
  }

private:
  std::string where_;
  std::vector<std::string> positional_;
  std::map<std::string, std::string> keys_;
};

void
requirePositive (const std::string& where, const std::string& what, double v)
{
  if (!(v > 0.0))
    throw Error (where, what + " must be positive");
}
}  // namespace

SyntheticScene
SyntheticScene::parse (const std::string& text, const std::string& source)
{
  SyntheticScene scene;
  scene.name = fs::path (source).stem ().string ();
  std::istringstream in (text);
  std::string line;
  int line_no = 0;
  while (std::getline (in, line))
  {
    ++line_no;
    const std::string where = source + ":" + std::to_string (line_no);
    const auto hash = line.find ('#');
    if (hash != std::string::npos)
      line.erase (hash);
    boost::algorithm::trim (line);
    if (line.empty ())
      continue;
    std::vector<std::string> tokens;
    boost::algorithm::split (tokens, line, boost::is_any_of (" \t"), boost::token_compress_on);
    const std::string& kind = tokens[0];
    LineParser p (where, tokens);
    if (kind == "scene")
    {
      if (p.positional ().size () != 1)
        throw Error (where, "expected 'scene NAME'");
      scene.name = p.positional ()[0];
    }
    else if (kind == "camera")
    {
      const auto& v = p.positional ();
      if (v.size () != 6)
        throw Error (where, "expected 'camera WIDTH HEIGHT FX FY CX CY'");
      const auto size = [&] (const std::string& text, const char* name) {  // checked before the cast to int
        const double value = p.number (text, name);
        if (!(value >= 1.0 && value <= 65536.0) || value != std::floor (value))
          throw Error (where, std::string (name) + " must be an integer in [1, 65536], got " + text);
        return static_cast<int> (value);
      };
      scene.camera = PinholeCamera (p.number (v[2], "fx"), p.number (v[3], "fy"), p.number (v[4], "cx"),
                                    p.number (v[5], "cy"), size (v[0], "width"), size (v[1], "height"));
      scene.camera.validate (where);
    }
    else if (kind == "trajectory")
    {
      OrbitTrajectory& t = scene.trajectory;
      t.target = p.vector3 ("target", t.target);
      t.radius = p.scalar ("radius", t.radius);
      t.height = p.scalar ("height", t.height);
      t.start_deg = p.scalar ("start", t.start_deg);
      t.sweep_deg = p.scalar ("sweep", t.sweep_deg);
      t.bob = p.scalar ("bob", t.bob);
      requirePositive (where, "radius", t.radius);
    }
    else if (kind == "waypoint")
    {
      CameraWaypoint w;
      w.eye = p.vector3 ("eye", w.eye, true);
      w.target = p.vector3 ("target", w.target, true);
      const Eigen::Vector3d view = w.target - w.eye;
      if (!(view.norm () > 1e-3) || !(view.head<2> ().norm () > 1e-3 * view.norm ()))
        throw Error (where, "a waypoint's target must lie away from its eye, and not straight above or below it");
      scene.path.waypoints.push_back (w);
    }
    else if (kind == "object")
    {
      if (p.positional ().size () != 1)
        throw Error (where, "expected 'object NAME class=CLASS color=R,G,B'");
      if (scene.objects.size () >= 65535)
        throw Error (where, "too many objects (instance ids are 16-bit)");
      SceneObject o;
      o.id = static_cast<std::uint16_t> (scene.objects.size () + 1);
      o.name = p.positional ()[0];
      o.class_name = boost::algorithm::replace_all_copy (p.text ("class", o.name), "_", " ");
      const Eigen::Vector3d c = p.vector3 ("color", Eigen::Vector3d (128, 128, 128));
      for (int i = 0; i < 3; ++i)
      {
        if (!(c[i] >= 0 && c[i] <= 255))
          throw Error (where, "color components must lie in 0..255");
        o.rgb[static_cast<std::size_t> (i)] = static_cast<std::uint8_t> (c[i]);
      }
      o.detectable = p.flag ("detectable", true);
      const std::string texture = p.text ("texture", "plain");
      if (texture != "plain" && texture != "checker" && texture != "print")
        throw Error (where, "texture must be plain, checker or print");
      o.checker = texture == "checker";
      o.print = texture == "print";
      scene.objects.push_back (o);
    }
    else if (kind == "box" || kind == "cylinder" || kind == "sphere")
    {
      if (scene.objects.empty ())
        throw Error (where, kind + " before any 'object' line");
      Primitive prim;
      prim.center = p.vector3 ("center", Eigen::Vector3d::Zero (), true);
      if (kind == "box")
      {
        prim.type = Primitive::Type::Box;
        prim.half_size = 0.5 * p.vector3 ("size", Eigen::Vector3d::Zero (), true);
        prim.yaw = p.scalar ("yaw", 0.0) * kPi / 180.0;
      }
      else if (kind == "cylinder")
      {
        prim.type = Primitive::Type::Cylinder;
        const double r = p.scalar ("radius", 0.0, true);
        prim.half_size = Eigen::Vector3d (r, r, 0.5 * p.scalar ("height", 0.0, true));
      }
      else
      {
        prim.type = Primitive::Type::Sphere;
        prim.half_size = Eigen::Vector3d::Constant (p.scalar ("radius", 0.0, true));
      }
      if (!(prim.half_size.minCoeff () > 0.0))
        throw Error (where, kind + " dimensions must be positive");
      // Scenes are rooms: a primitive of kilometres is a typo, and sampling it (the ground-
      // truth cloud, at millimetres) would not fit in memory.
      if (!(prim.half_size.maxCoeff () <= 50.0) || !(prim.center.cwiseAbs ().maxCoeff () <= 1000.0))
        throw Error (where, kind + " must lie within 1 km of the origin and measure at most 100 m");
      scene.objects.back ().parts.push_back (prim);
    }
    else
      throw Error (where, "unknown line '" + kind + "' (scene, camera, trajectory, waypoint, object, box, cylinder, sphere)");
    p.finish ();
  }
  if (scene.objects.empty ())
    throw Error (source, "scene has no objects");
  if (scene.path.waypoints.size () == 1)
    throw Error (source, "a camera path needs two waypoints or more, found one");
  for (const SceneObject& o : scene.objects)
    if (o.parts.empty ())
      throw Error (source, "object '" + o.name + "' has no box, cylinder or sphere");
  return scene;
}

std::string
SyntheticScene::text () const
{
  std::ostringstream out;
  out << std::setprecision (6);
  const auto v3 = [&out] (const Eigen::Vector3d& v) -> std::ostream& { return out << v.x () << "," << v.y () << "," << v.z (); };
  out << "scene " << name << "\ncamera " << camera.width << " " << camera.height << " " << camera.fx << " " << camera.fy << " "
      << camera.cx << " " << camera.cy << "\n";
  out << "trajectory target=";
  v3 (trajectory.target) << " radius=" << trajectory.radius << " height=" << trajectory.height << " start=" << trajectory.start_deg
                         << " sweep=" << trajectory.sweep_deg << " bob=" << trajectory.bob << "\n";
  for (const CameraWaypoint& w : path.waypoints)
  {
    out << "waypoint eye=";
    v3 (w.eye) << " target=";
    v3 (w.target) << "\n";
  }
  for (const SceneObject& o : objects)
  {
    out << "object " << o.name << " class=" << boost::algorithm::replace_all_copy (o.class_name, " ", "_") << " color="
        << int (o.rgb[0]) << "," << int (o.rgb[1]) << "," << int (o.rgb[2]) << " detectable=" << (o.detectable ? "yes" : "no")
        << " texture=" << (o.checker ? "checker" : o.print ? "print" : "plain") << "\n";
    for (const Primitive& p : o.parts)
    {
      out << "  " << (p.type == Primitive::Type::Box ? "box" : p.type == Primitive::Type::Cylinder ? "cylinder" : "sphere")
          << " center=";
      v3 (p.center);
      if (p.type == Primitive::Type::Box)
      {
        out << " size=";
        v3 (2.0 * p.half_size) << " yaw=" << p.yaw * 180.0 / kPi;
      }
      else if (p.type == Primitive::Type::Cylinder)
        out << " radius=" << p.half_size.x () << " height=" << 2.0 * p.half_size.z ();
      else
        out << " radius=" << p.half_size.x ();
      out << "\n";
    }
  }
  return out.str ();
}

SyntheticScene
SyntheticScene::load (const std::string& path)
{
  const FileContext context (path);
  return parse (io::readTextFile (path), path);
}

std::string
resolveScenePath (const std::string& name_or_file, const std::string& scenes_dir)
{
  if (fs::is_regular_file (name_or_file))
    return name_or_file;
  const fs::path named = fs::path (scenes_dir) / (name_or_file + ".scene");
  if (fs::is_regular_file (named))
    return named.string ();
  throw Error (name_or_file, "no such scene file, and no " + named.string ());
}

std::string
defaultScenesDir ()
{
  return (fs::path (dataDirectory ()) / "scenes").string ();
}
}  // namespace simulation
}  // namespace cuefusion
