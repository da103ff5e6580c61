#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/rgbd_frame.h>

#include <limits>
#include <sstream>

namespace cuefusion
{
namespace
{
std::string
sizeOf (const cv::Mat& m)
{
  std::ostringstream s;
  s << m.cols << "x" << m.rows;
  return s.str ();
}
}  // namespace

void
RGBDFrame::validate (const std::string& source) const
{
  camera.validate (source);
  if (depth.empty () || depth.type () != CV_32FC1)
    throw Error (source, "depth must be a non-empty CV_32F image");
  if (depth.cols != camera.width || depth.rows != camera.height)
    throw Error (source, "depth image is " + sizeOf (depth) + " but the intrinsics are for " +
                             std::to_string (camera.width) + "x" + std::to_string (camera.height));
  if (color.empty () || color.type () != CV_8UC3)
    throw Error (source, "colour must be a non-empty CV_8UC3 image");
  if (color.size () != depth.size ())
    throw Error (source, "colour image is " + sizeOf (color) + " but depth is " + sizeOf (depth));
  for (const cv::Mat* mask : {&instance_mask, &class_mask})
    if (!mask->empty () && (mask->type () != CV_16UC1 || mask->size () != depth.size ()))
      throw Error (source, "mask must be CV_16U and " + sizeOf (depth) + ", got " + sizeOf (*mask));
}

pcl::PointCloud<pcl::PointXYZRGBA>::Ptr
toPointCloud (const RGBDFrame& frame)
{
  const int w = frame.depth.cols;
  const int h = frame.depth.rows;
  auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZRGBA>> (w, h);
  cloud->is_dense = true;
  cloud->header.stamp = static_cast<std::uint64_t> (frame.timestamp * 1e6);
  cloud->header.seq = static_cast<std::uint32_t> (frame.index);
  cloud->header.frame_id = "camera";
  const float nan = std::numeric_limits<float>::quiet_NaN ();
  for (int v = 0; v < h; ++v)
  {
    const float* z_row = frame.depth.ptr<float> (v);
    const cv::Vec3b* c_row = frame.color.empty () ? nullptr : frame.color.ptr<cv::Vec3b> (v);
    for (int u = 0; u < w; ++u)
    {
      pcl::PointXYZRGBA& p = (*cloud) (u, v);
      const float z = z_row[u];
      if (isValidDepth (z))
        p.getVector3fMap () = frame.camera.backProject (static_cast<float> (u), static_cast<float> (v), z);
      else
      {
        p.x = p.y = p.z = nan;
        cloud->is_dense = false;
      }
      if (c_row)
      {
        p.b = c_row[u][0];
        p.g = c_row[u][1];
        p.r = c_row[u][2];
      }
      p.a = 255;
    }
  }
  return cloud;
}
}  // namespace cuefusion
