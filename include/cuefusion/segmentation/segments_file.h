// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/segmentation/global_segment_map.h>
#include <cuefusion/segmentation/object_geometry.h>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace cuefusion
{
namespace segmentation
{
/** \file
  * segments.json, a run's list of objects: the one place it is written (`cuefusion run`)
  * and read (`cuefusion eval`, library users). The file holds
  * `{"segments": [...], "fragmentation": {...}}`; each segment its `id` (the label in
  * map.pcd and mesh.ply), `voxels`, `first_frame`, `last_frame`, `frames_seen`, `loaded`,
  * `bounds` {min, max} of its voxels, `class` (null without one) and `score` (the mean
  * score of the masks that gave it its class; 0 without a class where the masks gave some
  * segment of the run one, null in a run where they gave none, such as geometry), `class_votes`
  * (frames per class), and from the map's points of it `points`, `centroid` and
  * `oriented_box` {center, axes (largest spread first), extents} (0 / null without points);
  * the fragmentation report is fragmentationReport's (fragmentation.h).
  */

/** \brief What `readSegmentsJson` gives of one segment: its id and, where the masks gave
  * them, its class and score. */
struct SegmentEntry
{
  std::uint32_t id = 0;
  std::string class_name;  ///< "" when the segment has no class
  double score = -1.0;     ///< in [0, 1]; -1 when it has none
};

/** \brief segments.json's text: \a segments with their \a geometry and the fragmentation
  * report, as writeSegmentsJson writes it (the Python binding's segments() parses it). */
std::string
segmentsJsonText (const std::vector<SegmentRecord>& segments, const std::map<std::uint32_t, ObjectGeometry>& geometry);

/** \brief Writes \a segments (GlobalSegmentMap::segments(), after refreshStatistics) to
  * \a path atomically, each with its \a geometry (by label; objectGeometry of the map
  * written beside it) where it has one, and their fragmentation report. Throws
  * cuefusion::Error naming the file when it cannot be written. */
void
writeSegmentsJson (const std::string& path, const std::vector<SegmentRecord>& segments,
                   const std::map<std::uint32_t, ObjectGeometry>& geometry);

/** \brief Reads a run's segments.json (`{"segments": [{"id": …, "class": …, "score": …}, …]}`;
  * other fields are not read); cuefusion::Error naming the file for anything else: ids
  * must be integers in [1, 2^32) and unique, classes strings or null, scores numbers in
  * [0, 1] or null. */
std::vector<SegmentEntry>
readSegmentsJson (const std::string& path);
}  // namespace segmentation
}  // namespace cuefusion
