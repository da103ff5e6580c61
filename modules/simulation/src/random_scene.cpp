// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>
#include <cuefusion/simulation/random_room.h>
#include <cuefusion/simulation/random_scene.h>

#include "scene_shapes.h"

#include <nlohmann/json.hpp>

#include <boost/filesystem.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace simulation
{
namespace
{
using namespace shapes;

/** An object already in the scene, for placing the next ones. */
struct Placed
{
  Eigen::Vector2d xy;
  double base_z;
  double yaw;
  Shape shape;
  bool carries = false;  // something stands on it
};
/** Scene \a index as a random room (kitchen, office or living room, drawn from \a pick).
  * A draw may find no camera path through its furniture (generateRoom says so): the next
  * draw of the same stream is taken, so the scene still depends on (seed, index) alone. */
SyntheticScene
randomRoom (Rng& pick, std::uint64_t seed, std::size_t index)
{
  RoomConfig room;
  room.type = static_cast<RoomType> (std::uniform_int_distribution<int> (0, 2) (pick));
  for (std::uint64_t attempt = 0;; ++attempt)
    try
    {
      SyntheticScene scene = generateRoom (room, mixSeed (seed ^ 0x5400dULL, 64 * static_cast<std::uint64_t> (index) + attempt));
      scene.name = "room-" + std::to_string (index);
      return scene;
    }
    catch (const Error&)
    {
      if (attempt == 63)
        throw;
    }
}
}  // namespace

void
RandomSceneConfig::validate () const
{
  if (min_objects < 1 || max_objects < min_objects || max_objects > 60)
    throw ParameterError ("RandomSceneConfig::min_objects", "need 1 <= min_objects <= max_objects <= 60");
  for (const auto& [value, name] :
       {std::make_pair (table_probability, "table_probability"), std::make_pair (touching_probability, "touching_probability"),
        std::make_pair (stacking_probability, "stacking_probability"),
        std::make_pair (multipart_probability, "multipart_probability"), std::make_pair (figure_probability, "figure_probability"),
        std::make_pair (aligned_probability, "aligned_probability"), std::make_pair (room_probability, "room_probability"),
        std::make_pair (focal_jitter, "focal_jitter")})
    if (!(value >= 0.0 && value <= 1.0))
      throw ParameterError (std::string ("RandomSceneConfig::") + name, "must lie in [0, 1]");
  if (!(min_size >= 0.005 && max_size >= min_size && max_size <= 1.0))
    throw ParameterError ("RandomSceneConfig::min_size", "need 0.005 <= min_size <= max_size <= 1 (m)");
  if (!(min_distance >= 0.2 && max_distance >= min_distance && max_distance <= 10.0))
    throw ParameterError ("RandomSceneConfig::min_distance", "need 0.2 <= min_distance <= max_distance <= 10 (m)");
  if (!(min_elevation_deg >= 5.0 && max_elevation_deg >= min_elevation_deg && max_elevation_deg <= 85.0))
    throw ParameterError ("RandomSceneConfig::min_elevation_deg", "need 5 <= min <= max <= 85 (degrees)");
  if (!(focal_640 >= 100.0 && focal_640 <= 5000.0))
    throw ParameterError ("RandomSceneConfig::focal_640", "must lie in [100, 5000] pixels");
  if (views_per_scene < 1)
    throw ParameterError ("RandomSceneConfig::views_per_scene", "must be at least 1");
}

RandomSceneGenerator::RandomSceneGenerator (const RandomSceneConfig& config, std::uint64_t seed)
  : config_ (config), seed_ (seed)
{
  config_.validate ();
}

SyntheticScene
RandomSceneGenerator::scene (std::size_t index) const
{
  if (config_.room_probability > 0.0)
  {
    Rng pick (mixSeed (seed_ ^ 0x400dULL, index));
    if (chance (pick, config_.room_probability))
      return randomRoom (pick, seed_, index);
  }
  Rng rng (mixSeed (seed_, 2 * static_cast<std::uint64_t> (index)));
  const RandomSceneConfig& c = config_;
  SyntheticScene scene;
  scene.name = "random-" + std::to_string (index);

  SceneObject floor = stuff ("floor", randomColor (rng, 90, 220));
  floor.checker = chance (rng, 0.4);
  floor.parts.push_back (box (Eigen::Vector3d (0, 0, -0.01), Eigen::Vector3d (10, 10, 0.02), 0.0));
  scene.objects.push_back (floor);
  const int walls = std::uniform_int_distribution<int> (0, 2) (rng);
  for (int w = 0; w < walls; ++w)
  {
    SceneObject wall = stuff ("wall", randomColor (rng, 120, 230));
    const double angle = uniform (rng, 0, 2 * kPi), distance = uniform (rng, 2.2, 3.5);
    const Eigen::Vector2d centre = rotate2 (Eigen::Vector2d (distance, 0), angle);
    wall.parts.push_back (box (Eigen::Vector3d (centre.x (), centre.y (), 1.25), Eigen::Vector3d (0.1, 8, 2.5), angle));
    scene.objects.push_back (wall);
  }

  // The support: a table top (with legs) or a patch of floor.
  double support_z = 0.0, support_yaw = uniform (rng, 0, kPi);
  Eigen::Vector2d support_half (0.6, 0.6);
  if (chance (rng, c.table_probability))
  {
    SceneObject table = stuff ("table", randomColor (rng, 40, 200));
    const double thickness = uniform (rng, 0.02, 0.05);
    support_half = Eigen::Vector2d (uniform (rng, 0.3, 0.8), uniform (rng, 0.25, 0.5));
    support_z = uniform (rng, 0.4, 0.9);
    table.parts.push_back (box (Eigen::Vector3d (0, 0, support_z - thickness / 2),
                                Eigen::Vector3d (2 * support_half.x (), 2 * support_half.y (), thickness), support_yaw));
    for (const double sx : {-1.0, 1.0})
      for (const double sy : {-1.0, 1.0})
      {
        const Eigen::Vector2d leg = rotate2 (Eigen::Vector2d (sx * (support_half.x () - 0.05), sy * (support_half.y () - 0.05)),
                                             support_yaw);
        table.parts.push_back (box (Eigen::Vector3d (leg.x (), leg.y (), (support_z - thickness) / 2),
                                    Eigen::Vector3d (0.05, 0.05, support_z - thickness), support_yaw));
      }
    scene.objects.push_back (table);
  }

  const int count = std::uniform_int_distribution<int> (c.min_objects, c.max_objects) (rng);
  std::vector<Placed> placed;
  auto free_at = [&] (const Eigen::Vector2d& xy, double radius, double base_z, double height, int except) {
    for (std::size_t j = 0; j < placed.size (); ++j)
    {
      if (static_cast<int> (j) == except)
        continue;
      const Placed& o = placed[j];
      const bool levels_meet = base_z < o.base_z + o.shape.height && o.base_z < base_z + height;
      if (levels_meet && (xy - o.xy).norm () < 0.92 * (radius + o.shape.radius))
        return false;
    }
    return true;
  };
  for (int i = 0; i < count; ++i)
  {
    const Shape shape = randomShape (rng, c);
    bool done = false;
    for (int attempt = 0; attempt < 25 && !done; ++attempt)
    {
      Eigen::Vector2d xy;
      double yaw = uniform (rng, 0, 2 * kPi), base_z = support_z;
      int partner = -1;
      if (!placed.empty () && chance (rng, c.stacking_probability + c.touching_probability))
        partner = std::uniform_int_distribution<int> (0, static_cast<int> (placed.size ()) - 1) (rng);
      const bool can_stand = shape.plain_box || shape.parts.size () == 1;  // a box, can or ball on a box
      if (partner >= 0 && can_stand && placed[partner].shape.plain_box && !placed[partner].carries &&
          chance (rng, c.stacking_probability / (c.stacking_probability + c.touching_probability)))
      {
        // Stacked: the upper object's centre over the lower box's top (overhang allowed),
        // turned at random, its footprint not much wider than the lower box.
        const Placed& below = placed[partner];
        const Eigen::Vector2d half = below.shape.box_size.head<2> () / 2;
        if (shape.radius > 1.2 * half.maxCoeff ())
          continue;
        xy = below.xy + rotate2 (Eigen::Vector2d (uniform (rng, -0.6, 0.6) * half.x (), uniform (rng, -0.6, 0.6) * half.y ()),
                                 below.yaw);
        yaw = chance (rng, 0.4) ? below.yaw : uniform (rng, 0, 2 * kPi);
        base_z = below.base_z + below.shape.height;
      }
      else if (partner >= 0)
      {
        const Placed& other = placed[partner];
        if (other.base_z > support_z)
          continue;
        if (shape.plain_box && other.shape.plain_box)
        {
          // Flush against a face of the other box, sliding along it.
          yaw = other.yaw;
          const int axis = chance (rng, 0.5) ? 0 : 1;
          const double side = chance (rng, 0.5) ? 1.0 : -1.0;
          Eigen::Vector2d offset;
          offset[axis] = side * (other.shape.box_size[axis] + shape.box_size[axis]) / 2;
          const double slide = std::max (0.0, (other.shape.box_size[1 - axis] + shape.box_size[1 - axis]) / 2 - 0.02);
          if (c.aligned_probability > 0.0 && chance (rng, c.aligned_probability))
            offset[1 - axis] = (chance (rng, 0.5) ? 0.5 : -0.5) * (other.shape.box_size[1 - axis] - shape.box_size[1 - axis]);
          else
            offset[1 - axis] = uniform (rng, -slide, slide) * 0.7;
          xy = other.xy + rotate2 (offset, other.yaw);
        }
        else
        {
          const double angle = uniform (rng, 0, 2 * kPi);
          xy = other.xy + rotate2 (Eigen::Vector2d (other.shape.radius + shape.radius, 0), angle);
        }
      }
      else
      {
        xy = rotate2 (Eigen::Vector2d (uniform (rng, -1, 1) * support_half.x (), uniform (rng, -1, 1) * support_half.y ()),
                      support_yaw);
      }
      // The centre must stand on the support (the table top, or the floor patch).
      const Eigen::Vector2d local = rotate2 (xy, -support_yaw);
      if (base_z == support_z && (std::abs (local.x ()) > support_half.x () || std::abs (local.y ()) > support_half.y ()))
        continue;
      if (!free_at (xy, shape.radius, base_z, shape.height, partner))
        continue;
      SceneObject o = instantiate (shape, xy, base_z, yaw);
      o.name = "object" + std::to_string (placed.size () + 1);
      o.class_name = "object";
      o.rgb = randomColor (rng);
      scene.objects.push_back (o);
      if (base_z > support_z)
        placed[partner].carries = true;
      placed.push_back ({xy, base_z, yaw, shape, false});
      done = true;
    }
  }
  for (std::size_t i = 0; i < scene.objects.size (); ++i)
    scene.objects[i].id = static_cast<std::uint16_t> (i + 1);

  // The camera looks at the objects: the trajectory holds the support's centre and height.
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero ();
  for (const Placed& p : placed)
    centroid += p.xy / static_cast<double> (placed.size ());
  scene.trajectory.target = Eigen::Vector3d (centroid.x (), centroid.y (), support_z + 0.05);
  return scene;
}

RandomView
RandomSceneGenerator::view (std::size_t index, int width, int height) const
{
  if (width < 16 || height < 16)
    throw ParameterError ("RandomSceneGenerator::view", "image size must be at least 16x16");
  const std::size_t scene_index = index / static_cast<std::size_t> (config_.views_per_scene);
  const SyntheticScene scene = this->scene (scene_index);
  const SceneRenderer renderer (scene);
  Rng rng (mixSeed (seed_, 2 * static_cast<std::uint64_t> (index) + 1));
  const RandomSceneConfig& c = config_;

  RandomView out;
  out.scene_index = scene_index;
  PinholeCamera& camera = out.camera;
  camera.width = width;
  camera.height = height;
  camera.fx = c.focal_640 * width / 640.0 * (1.0 + uniform (rng, -c.focal_jitter, c.focal_jitter));
  camera.fy = camera.fx * (1.0 + uniform (rng, -0.01, 0.01));
  camera.cx = (width - 1) / 2.0 + uniform (rng, -0.03, 0.03) * width;
  camera.cy = (height - 1) / 2.0 + uniform (rng, -0.03, 0.03) * height;

  const bool room = scene.path.waypoints.size () >= 2;
  // In a room: a point of its hand-held path (clear of the furniture), turned a little.
  // Else a pose above the support looking near the objects, with a clear line of sight to
  // the point looked at (not behind a wall or inside an object).
  if (room)
  {
    out.pose = scene.cameraPoseAt (uniform (rng, 0, 1));
    out.pose.linear () = out.pose.linear () * Eigen::AngleAxisd (uniform (rng, -15, 15) * kDeg, Eigen::Vector3d::UnitY ()) *
                         Eigen::AngleAxisd (uniform (rng, -10, 10) * kDeg, Eigen::Vector3d::UnitX ()) *
                         Eigen::AngleAxisd (uniform (rng, -10, 10) * kDeg, Eigen::Vector3d::UnitZ ());
  }
  else
    for (int attempt = 0; attempt < 20; ++attempt)
    {
      const Eigen::Vector3d target = scene.trajectory.target +
                                     Eigen::Vector3d (uniform (rng, -0.15, 0.15), uniform (rng, -0.15, 0.15), uniform (rng, -0.05, 0.1));
      const double azimuth = uniform (rng, 0, 2 * kPi);
      const double elevation = uniform (rng, c.min_elevation_deg, c.max_elevation_deg) * kDeg;
      const double distance = uniform (rng, c.min_distance, c.max_distance);
      const Eigen::Vector3d eye =
        target + distance * Eigen::Vector3d (std::cos (elevation) * std::cos (azimuth), std::cos (elevation) * std::sin (azimuth),
                                             std::sin (elevation));
      out.pose = lookAt (eye, target);
      out.pose.linear () = out.pose.linear () * Eigen::AngleAxisd (uniform (rng, -10, 10) * kDeg, Eigen::Vector3d::UnitZ ());
      double t;
      Eigen::Vector3d n;
      const Eigen::Vector3d back = (eye - target).normalized ();
      if (renderer.castRay (target + 0.02 * back, back, t, n) == 0 || t > distance)
        break;
    }
  DepthNoiseConfig noise;
  noise.enabled = true;
  noise.dropout_start_deg = uniform (rng, 60, 75);
  noise.max_incidence_deg = noise.dropout_start_deg + uniform (rng, 8, 14);
  out.view = renderer.render (camera, out.pose, noise, mixSeed (seed_ ^ 0x5eedULL, index));
  // Objects are what a detector reports; in a room only those of a table-top object's
  // sizes (furniture is to the network what a table is).
  std::vector<bool> object (scene.objects.size ());
  for (std::size_t i = 0; i < scene.objects.size (); ++i)
    object[i] = scene.objects[i].detectable && (!room || scene.objects[i].bounds ().sizes ().maxCoeff () <= 2 * c.max_size);
  out.objects = out.view.instance.clone ();
  for (int v = 0; v < out.objects.rows; ++v)
    for (int u = 0; u < out.objects.cols; ++u)
    {
      std::uint16_t& id = out.objects.at<std::uint16_t> (v, u);
      if (id && !object[id - 1u])
        id = 0;
    }
  out.object_count = static_cast<int> (std::count (object.begin (), object.end (), true));
  return out;
}

namespace
{
nlohmann::json
generatorJson (const RandomSceneGenerator& generator)
{
  const RandomSceneConfig& c = generator.getConfig ();
  return {{"seed", generator.seed ()},
          {"min_objects", c.min_objects},
          {"max_objects", c.max_objects},
          {"table_probability", c.table_probability},
          {"touching_probability", c.touching_probability},
          {"stacking_probability", c.stacking_probability},
          {"multipart_probability", c.multipart_probability},
          {"figure_probability", c.figure_probability},
          {"aligned_probability", c.aligned_probability},
          {"room_probability", c.room_probability},
          {"min_size", c.min_size},
          {"max_size", c.max_size},
          {"min_distance", c.min_distance},
          {"max_distance", c.max_distance},
          {"min_elevation_deg", c.min_elevation_deg},
          {"max_elevation_deg", c.max_elevation_deg},
          {"focal_640", c.focal_640},
          {"focal_jitter", c.focal_jitter},
          {"views_per_scene", c.views_per_scene}};
}
}  // namespace

void
writeRandomViews (const RandomSceneGenerator& generator, std::size_t count, int width, int height, const std::string& dir,
                  bool overwrite, const std::function<void (std::size_t)>& progress)
{
  io::writeFolderAtomic (dir, overwrite, [&] (const std::string& staging) {
    for (const char* sub : {"depth", "instance", "color"})
      fs::create_directories (fs::path (staging) / sub);
    nlohmann::json views = nlohmann::json::array ();
    for (std::size_t i = 0; i < count; ++i)
    {
      const RandomView v = generator.view (i, width, height);
      char stem[32];
      std::snprintf (stem, sizeof stem, "%06zu.png", i);
      io::writeImageAtomic ((fs::path (staging) / "depth" / stem).string (), io::depthToRaw (v.view.depth, 1000.0));
      io::writeImageAtomic ((fs::path (staging) / "instance" / stem).string (), v.objects);
      io::writeImageAtomic ((fs::path (staging) / "color" / stem).string (), v.view.color);
      const PinholeCamera& k = v.camera;
      const Eigen::Matrix4d pose = v.pose.matrix ();
      std::vector<double> pose_rows (pose.data (), pose.data () + 16);
      views.push_back ({{"file", stem},
                        {"scene", v.scene_index},
                        {"objects", v.object_count},
                        {"camera", {{"width", k.width}, {"height", k.height}, {"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy}}},
                        {"pose_column_major", pose_rows}});
      if (progress)
        progress (i + 1);
    }
    io::writeTextAtomic ((fs::path (staging) / "views.json").string (),
                     io::jsonText (nlohmann::json ({{"generator", generatorJson (generator)}, {"depth_units_per_metre", 1000}, {"views", views}}), 1) + "\n");
  });
}
}  // namespace simulation
}  // namespace cuefusion
