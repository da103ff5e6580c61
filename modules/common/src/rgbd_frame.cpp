// SPDX-License-Identifier: BSD-3-Clause
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

RGBDFrame
fromOrganizedCloud (const pcl::PointCloud<pcl::PointXYZRGBA>& cloud)
{
  RGBDFrame frame;
  const int w = static_cast<int> (cloud.width), h = static_cast<int> (cloud.height);
  frame.depth = cv::Mat (h, w, CV_32F, cv::Scalar (0.f));
  frame.color = cv::Mat (h, w, CV_8UC3);
  // Normal equations of u = fx·a + cx (a = x/z) and v = fy·b + cy (b = y/z).
  double saa = 0, sa = 0, sau = 0, su = 0, sbb = 0, sb = 0, sbv = 0, sv = 0;
  std::size_t n = 0;
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u)
    {
      const pcl::PointXYZRGBA& p = cloud (u, v);
      frame.color.at<cv::Vec3b> (v, u) = cv::Vec3b (p.b, p.g, p.r);
      if (!(std::isfinite (p.x) && std::isfinite (p.y) && isValidDepth (p.z)))
        continue;
      frame.depth.at<float> (v, u) = p.z;
      const double a = p.x / p.z, b = p.y / p.z;
      saa += a * a, sa += a, sau += a * u, su += u;
      sbb += b * b, sb += b, sbv += b * v, sv += v;
      ++n;
    }
  const double m = static_cast<double> (n);
  const double det_u = m * saa - sa * sa, det_v = m * sbb - sb * sb;
  frame.camera = PinholeCamera ().scaled (w, h);
  if (n >= 10 && det_u > 1e-12 * m * m && det_v > 1e-12 * m * m)
  {
    const double fx = (m * sau - sa * su) / det_u, fy = (m * sbv - sb * sv) / det_v;
    if (fx > 0.0 && fy > 0.0 && std::isfinite (fx) && std::isfinite (fy))
      frame.camera = PinholeCamera (fx, fy, (su - fx * sa) / m, (sv - fy * sb) / m, w, h);
  }
  return frame;
}
}  // namespace cuefusion
