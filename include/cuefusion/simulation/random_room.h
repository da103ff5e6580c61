// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/simulation/synthetic_scene.h>

#include <cstdint>
#include <string>

namespace cuefusion
{
namespace simulation
{
/** \brief The kinds of room generateRoom draws. */
enum class RoomType
{
  Kitchen,  ///< base and wall cabinets with doors under a counter crowded with small objects, a refrigerator, a table with chairs
  Office,   ///< desks with monitors, keyboards, mice, cables and papers, office chairs, a bookshelf, a cabinet with doors
  Living    ///< a sofa with cushions, a coffee table, a TV on a low cabinet, a bookshelf
};

/** \brief "kitchen", "office" or "living" → RoomType; throws ParameterError naming \a option otherwise. */
RoomType
parseRoomType (const std::string& name, const std::string& option = "RoomConfig::type");

const char*
roomTypeName (RoomType type);

/** \brief How generateRoom draws a room and the hand-held path through it. */
struct RoomConfig
{
  RoomType type = RoomType::Kitchen;
  double min_extent = 3.0;       ///< room width and depth, each uniform in [min, max] (m)
  double max_extent = 6.0;
  double min_distance = 1.0;     ///< camera to the point it looks at, per waypoint (m)
  double max_distance = 4.0;
  double min_eye_height = 1.2;   ///< a hand-held camera's height above the floor (m)
  double max_eye_height = 1.7;
  int waypoints = 5;             ///< points of the camera path (each looking at a piece of furniture)
  double clutter = 1.0;          ///< scales the number of small objects on every surface
  void validate () const;
};

/** \brief A random room with exact truth: a floor, four walls and a ceiling (stuff the
  * simulated detector does not report), furniture along the walls and in the middle,
  * small objects on counters, desks, shelves and tables (touching one another, books in
  * rows), and a hand-held camera path (SyntheticScene::path) that looks at the furniture
  * from config.min_distance–max_distance at standing height. Counters are stuff too, as in
  * ScanNet's and the reference's classes. Deterministic in (config, seed).
  */
SyntheticScene
generateRoom (const RoomConfig& config, std::uint64_t seed);
}  // namespace simulation
}  // namespace cuefusion
