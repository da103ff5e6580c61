#pragma once

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
void
saveMapPCD (const std::string& path, const pcl::PointCloud<pcl::PointXYZRGBL>& cloud);
}  // namespace io
}  // namespace cuefusion
