#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/map_io.h>

#include <boost/filesystem.hpp>
#include <pcl/io/pcd_io.h>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace io
{
void
saveMapPCD (const std::string& path, const pcl::PointCloud<pcl::PointXYZRGBL>& cloud)
{
  const fs::path target (path);
  const fs::path tmp = target.parent_path () / fs::unique_path (".tmp-%%%%%%%%-" + target.filename ().string ());
  boost::system::error_code ec;
  // PCL refuses to write an empty cloud; an empty map is still a valid answer.
  const int status = cloud.empty () ? pcl::io::savePCDFileASCII (tmp.string (), cloud)
                                    : pcl::io::savePCDFileBinaryCompressed (tmp.string (), cloud);
  if (status != 0)
  {
    fs::remove (tmp, ec);
    throw Error (path, "cannot write point cloud");
  }
  fs::rename (tmp, target, ec);
  if (ec)
  {
    fs::remove (tmp, ec);
    throw Error (path, "cannot replace file: " + ec.message ());
  }
}
}  // namespace io
}  // namespace cuefusion
