// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/simulation/scene_renderer.h>
#include <cuefusion/simulation/synthetic_scene.h>

#include <cstdint>
#include <functional>
#include <string>

namespace cuefusion
{
namespace simulation
{
/** \brief How random training scenes and views are drawn (RandomSceneGenerator). */
struct RandomSceneConfig
{
  int min_objects = 3;                   ///< objects per scene, uniform in [min, max]
  int max_objects = 12;
  double table_probability = 0.75;       ///< objects stand on a table; else on the floor
  double touching_probability = 0.4;     ///< an object is placed against one already there
  double stacking_probability = 0.3;     ///< a box, can or ball is put on a box already there
  double multipart_probability = 0.25;   ///< bottle, L-block, snowman or mug
  /** Share of the multi-part objects drawn as a figure (a soft toy: a body sphere, a head,
    * arms, ears, legs). 0 (the default) draws no random number for it, so scenes of
    * earlier versions render unchanged. */
  double figure_probability = 0.0;
  /** Share of the boxes placed flush against another box that are lined up with it: one
    * side face of each in one plane (boxes in a row, products on a shelf), so depth shows
    * no step along that face. 0 (the default) draws no random number for it. */
  double aligned_probability = 0.0;
  /** Share of the scenes drawn as a random room (generateRoom: a kitchen, office or living
    * room, each as likely) seen from points of its hand-held camera path, 1–4 m from its
    * furniture, instead of a table-top scene. In a room's views only the objects no larger
    * than twice max_size (books, monitors, keyboards, the small objects on every surface)
    * are objects; furniture, like the table of a table-top scene, is not. 0 (the default)
    * draws no random number for it, so scenes of earlier versions render unchanged. */
  double room_probability = 0.0;
  double min_size = 0.03;                ///< smallest object extent (m)
  double max_size = 0.28;                ///< largest object extent (m)
  double min_distance = 0.45;            ///< camera distance to the point it looks at (m)
  double max_distance = 1.9;
  double min_elevation_deg = 15.0;       ///< camera elevation above the support surface
  double max_elevation_deg = 75.0;
  double focal_640 = 525.0;              ///< mean focal length of a 640-pixel-wide image (Kinect)
  double focal_jitter = 0.08;            ///< relative spread of the focal length
  int views_per_scene = 4;               ///< camera poses per random scene
  void validate () const;
};

/** \brief One random view with exact truth. */
struct RandomView
{
  PinholeCamera camera;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();  ///< camera-to-world
  RenderedView view;            ///< instance holds every object id, stuff included
  cv::Mat objects;              ///< CV_16U: the instance image with stuff (detectable=no) set to 0
  std::size_t scene_index = 0;
  int object_count = 0;         ///< objects of the scene that `objects` keeps (detectable; in a room no larger than twice max_size)
};

/** \brief Draws randomized table-top and floor scenes (boxes, cylinders, spheres and
  * multi-part objects of random sizes, touching, stacked and occluding one another, random
  * colours, checkered or plain floors, walls) and random views of them (camera distance,
  * elevation, look-at point, focal length near Kinect's, principal point jitter), rendered
  * with Kinect-like depth noise and dropout. Training data for an instance segmenter:
  * view i depends only on (seed, i), so any subset renders the same on every run.
  */
class RandomSceneGenerator
{
public:
  RandomSceneGenerator (const RandomSceneConfig& config, std::uint64_t seed);

  /** \brief Scene number \a index (deterministic). */
  SyntheticScene scene (std::size_t index) const;

  /** \brief View number \a index at \a width × \a height pixels: scene index /
    * views_per_scene, seen from a random pose.
    */
  RandomView view (std::size_t index, int width, int height) const;

  const RandomSceneConfig& getConfig () const { return config_; }
  std::uint64_t seed () const { return seed_; }

private:
  RandomSceneConfig config_;
  std::uint64_t seed_;
};

/** \brief Writes views [0, count) into \a dir: depth/NNNNNN.png (16-bit, millimetres),
  * instance/NNNNNN.png (16-bit object ids, stuff = 0), color/NNNNNN.png and views.json
  * (per view: intrinsics, pose, scene index, object count; plus the generator settings).
  * The folder appears complete or not at all (io::writeFolderAtomic).
  */
void
writeRandomViews (const RandomSceneGenerator& generator, std::size_t count, int width, int height,
                  const std::string& dir, bool overwrite, const std::function<void (std::size_t)>& progress = {});
}  // namespace simulation
}  // namespace cuefusion
