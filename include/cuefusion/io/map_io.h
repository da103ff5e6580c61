#pragma once

#include <pcl/PCLPointCloud2.h>
#include <pcl/PolygonMesh.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <string>

namespace cuefusion
{
namespace io
{
/** \brief Saves a binary-compressed PCD atomically (temporary file, then rename), so an
  * existing map is replaced whole or not at all. Throws cuefusion::Error on failure.
  */
/** \brief True when \a cloud has a field called \a name. */
bool
hasField (const pcl::PCLPointCloud2& cloud, const std::string& name);

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
