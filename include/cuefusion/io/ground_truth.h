// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace cuefusion
{
namespace io
{
/** \brief A labelled ground-truth cloud for 3D instance evaluation. */
struct GroundTruthCloud
{
  pcl::PointCloud<pcl::PointXYZL>::Ptr cloud;        ///< label = instance id, 0 = none
  std::map<std::uint32_t, std::string> class_names;  ///< instance → class
  std::set<std::uint32_t> ignored;                   ///< stuff (walls, floor, …) not scored
  std::string source;                                ///< the file(s) it came from
};

/** \brief ScanNet's annotation files of one scene. */
struct ScanNetGroundTruthFiles
{
  std::string mesh;          ///< <scene>_vh_clean_2.ply
  std::string segments;      ///< <scene>_vh_clean_2.0.010000.segs.json ("segIndices" per vertex)
  std::string aggregation;   ///< <scene>.aggregation.json (or _vh_clean.aggregation.json): "segGroups"
};

/** \brief Classes ScanNet's instance benchmark does not score, the default "stuff". */
std::set<std::string>
defaultStuffClasses ();

/** \brief Reads a ScanNet scene's ground truth: every mesh vertex gets the instance of the
  * segment group (objectId + 1) whose over-segments contain it; vertices of no group are
  * 0. Instances whose label is in \a stuff_classes are marked ignored. Throws
  * cuefusion::Error naming the file on missing/corrupt files or when the per-vertex
  * segment list does not match the mesh's vertex count.
  */
GroundTruthCloud
readScanNetGroundTruth (const ScanNetGroundTruthFiles& files,
                        const std::set<std::string>& stuff_classes = defaultStuffClasses ());

/** \brief Finds the three ScanNet files in \a folder (the scene folder), if all exist. */
std::optional<ScanNetGroundTruthFiles>
findScanNetGroundTruth (const std::string& folder);

/** \brief A synthetic sequence's truth (`cuefusion synth`): gt_cloud.pcd (PointXYZRGBL,
  * label = object id) and scene.json (classes; objects with "detectable": false are stuff).
  */
GroundTruthCloud
readSyntheticGroundTruth (const std::string& folder);

/** \brief Whichever of the two \a folder holds (synthetic first); nullopt when neither. */
std::optional<GroundTruthCloud>
findGroundTruthCloud (const std::string& folder);

/** \brief Instance ids marked "detectable": false in a synthetic folder's scene.json, or of
  * a stuff class; empty when there is no scene.json. Used to leave stuff out of
  * per-frame scores as well. */
std::set<std::uint32_t>
syntheticStuffInstances (const std::string& folder);
}  // namespace io
}  // namespace cuefusion
