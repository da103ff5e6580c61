// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <pcl/PCLPointCloud2.h>
#include <pcl/PolygonMesh.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstdint>
#include <string>
#include <vector>

namespace cuefusion
{
namespace io
{
/** \brief True when \a cloud has a field called \a name. */
bool
hasField (const pcl::PCLPointCloud2& cloud, const std::string& name);

/** \brief Reads any PCD into a blob, checking its header first (PCL 1.13's reader crashes
  * on a header without FIELDS). Throws cuefusion::Error naming the file when it is
  * missing, corrupt, has no points or lacks one of \a required_fields.
  */
pcl::PCLPointCloud2
readPCD (const std::string& path, const std::vector<std::string>& required_fields = {"x", "y", "z"});

/** \brief Saves a binary-compressed PCD atomically (temporary file, then rename), so an
  * existing map is replaced whole or not at all. Throws cuefusion::Error on failure.
  */
void
saveMapPCD (const std::string& path, const pcl::PointCloud<pcl::PointXYZRGBL>& cloud);

/** \brief Saves a mesh as binary little-endian PLY, atomically. Vertex properties are
  * written for the fields the mesh cloud has: x y z, nx ny nz (from normal_*), red green
  * blue (from rgb/rgba) and label (uint, the segment label); faces as int index lists.
  * Throws cuefusion::Error when the cloud has no x/y/z or a face indexes past it.
  */
void
saveMeshPLY (const std::string& path, const pcl::PolygonMesh& mesh);
}  // namespace io
}  // namespace cuefusion
