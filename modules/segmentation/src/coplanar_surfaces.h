// SPDX-License-Identifier: BSD-3-Clause
// One flat surface that what stands in front of it parts in every view (a floor around a
// kitchen island, a wall beside a bookshelf, a table top between the objects on it) shown
// as one object: GlobalSegmentMap::settledLabels' last step. Internal to the segmentation
// module.
#pragma once

#include <cuefusion/segmentation/global_segment_map.h>

#include <cstdint>
#include <set>
#include <unordered_map>
#include <utility>
#include <vector>

namespace cuefusion
{
namespace segmentation
{
namespace detail
{
/** \brief The objects to show as one because they are one flat surface.
  *
  * \a shown gives for every label (index) the object it shows as (0: none). Of the
  * objects in \a stuff (those no mask gave a class), each whose surface voxels (within a
  * voxel of the zero crossing) lie on a plane — 90 % of them within
  * GlobalSegmentMapConfig::surface_tolerance of the plane fitted to those within it, at
  * least surface_min_extent across in both directions of the plane — is a flat surface.
  * Two flat surfaces are one when their normals are within surface_max_angle_deg, each
  * centroid lies within surface_tolerance of the other's plane, the evidence has not had
  * its say on them (\a judged: pairs of objects, the smaller first, whose labels' pairs
  * have votes for or against in confirm_confidence frames or more: pieces that frames
  * saw touching, such as two cabinets side by side, are the evidence's to decide), and the volume shows no free space on their
  * plane between them: along the line between the centroids, more than surface_tolerance
  * of observed voxels whose surface is further than surface_tolerance away (a gap a
  * camera looked through: two tables at one height with the floor between). Where the
  * plane runs behind or under furniture the volume has no observation or is inside it,
  * which is no gap. Nor may another object's surface lie on the plane between them for
  * more than surface_min_extent along that line (a third door between two), and no
  * group holds two objects of a judged pair, even through a third.
  *
  * A flat object of \a stuff narrower than that (a patch: a strip of a floor seen only
  * between the slats of a chair's back) joins the larger object of \a stuff it touches
  * (surface voxels sharing a face) whose surface continues the patch's plane: within
  * surface_min_extent of the patch's bounds, at least as many of its surface voxels as the
  * patch has lie within surface_tolerance of the patch's plane, and those voxels and the
  * patch's lie on one plane (90 % of each within surface_tolerance of it); never a judged
  * pair.
  *
  * Returns object → the object it joins (the smallest of its group), only for objects
  * that join another.
  */
std::unordered_map<std::uint32_t, std::uint32_t>
coplanarSurfaces (const reconstruction::TSDFVolume& volume, const VoxelLabelLayer& labels, const std::vector<std::uint32_t>& shown,
                  const std::set<std::uint32_t>& stuff, const std::set<std::pair<std::uint32_t, std::uint32_t>>& judged,
                  const GlobalSegmentMapConfig& config);
}  // namespace detail
}  // namespace segmentation
}  // namespace cuefusion
