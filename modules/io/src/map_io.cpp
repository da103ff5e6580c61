#include <cuefusion/io/file_io.h>
#include <cuefusion/io/map_io.h>

#include <pcl/io/pcd_io.h>

namespace cuefusion
{
namespace io
{
void
saveMapPCD (const std::string& path, const pcl::PointCloud<pcl::PointXYZRGBL>& cloud)
{
  writeFileAtomic (path, [&cloud] (const std::string& tmp) {
    // PCL refuses to write an empty cloud in binary; an empty map is still a valid answer.
    return (cloud.empty () ? pcl::io::savePCDFileASCII (tmp, cloud) : pcl::io::savePCDFileBinaryCompressed (tmp, cloud)) == 0;
  });
}
}  // namespace io
}  // namespace cuefusion
