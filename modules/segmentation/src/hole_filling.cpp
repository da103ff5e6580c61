// SPDX-License-Identifier: BSD-3-Clause
// fillSmallHoles: small holes of missing depth inside one surface get points (and, where
// the planes have normals, normals) before the edge operators see them.
#include <cuefusion/segmentation/surface_preprocessing.h>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <vector>

namespace cuefusion
{
namespace segmentation
{
std::size_t
fillSmallHoles (SurfacePlanes& planes, int max_hole_pixels, float max_depth_jump, bool fill_normals)
{
  if (max_hole_pixels <= 0)
    return 0;
  const int w = planes.width, h = planes.height;
  cv::Mat missing (h, w, CV_8U);
  for (int y = 0; y < h; ++y)
  {
    std::uint8_t* row = missing.ptr<std::uint8_t> (y);
    const float* z = planes.z.data () + static_cast<std::size_t> (y) * w;
    for (int x = 0; x < w; ++x)
      row[x] = std::isfinite (z[x]) ? 0 : 1;
  }
  cv::Mat components, stats, centroids;
  const int count = cv::connectedComponentsWithStats (missing, components, stats, centroids, 8, CV_32S);
  std::size_t filled = 0;
  std::vector<int> ring, hole;
  for (int c = 1; c < count; ++c)
  {
    const int x0 = stats.at<int> (c, cv::CC_STAT_LEFT), y0 = stats.at<int> (c, cv::CC_STAT_TOP);
    const int x1 = x0 + stats.at<int> (c, cv::CC_STAT_WIDTH), y1 = y0 + stats.at<int> (c, cv::CC_STAT_HEIGHT);
    // Too large, or open to the image border (nothing on the far side to fit).
    if (stats.at<int> (c, cv::CC_STAT_AREA) > max_hole_pixels || x0 == 0 || y0 == 0 || x1 == w || y1 == h)
      continue;
    ring.clear ();
    hole.clear ();
    for (int y = y0 - 1; y <= y1; ++y)
      for (int x = x0 - 1; x <= x1; ++x)
      {
        const int i = y * w + x;
        if (components.at<int> (y, x) == c)
          hole.push_back (i);
        else if (!missing.at<std::uint8_t> (y, x))
        {
          bool touches = false;
          for (int v = std::max (y0, y - 1); v <= std::min (y1 - 1, y + 1) && !touches; ++v)
            for (int u = std::max (x0, x - 1); u <= std::min (x1 - 1, x + 1) && !touches; ++u)
              touches = components.at<int> (v, u) == c;
          if (touches)
            ring.push_back (i);
        }
      }
    if (ring.size () < 6)
      continue;
    // One surface around the hole: inverse depth is linear in the pixel coordinates on a
    // plane, and so are the rays' x/z and y/z (the intrinsics need not be known). Least
    // squares by the normal equations (3 × 3, a few dozen points).
    Eigen::Matrix3d normal_matrix = Eigen::Matrix3d::Zero ();
    Eigen::Matrix3d moments = Eigen::Matrix3d::Zero ();  // columns: 1/z, x/z, y/z
    for (const int i : ring)
    {
      const auto j = static_cast<std::size_t> (i);
      const Eigen::Vector3d at (1.0, i % w, i / w);
      const Eigen::Vector3d value (1.0 / planes.z[j], planes.x[j] / planes.z[j], planes.y[j] / planes.z[j]);
      normal_matrix += at * at.transpose ();
      moments += at * value.transpose ();
    }
    const Eigen::LDLT<Eigen::Matrix3d> solver (normal_matrix);
    if (solver.info () != Eigen::Success)
      continue;
    const Eigen::Matrix3d fit = solver.solve (moments);
    bool surface = true;
    for (std::size_t k = 0; k < ring.size () && surface; ++k)
    {
      const Eigen::Vector3d at (1.0, ring[k] % w, ring[k] / w);
      const double inverse = at.dot (fit.col (0));
      const double z = planes.z[static_cast<std::size_t> (ring[k])];
      surface = inverse > 0.0 && std::abs (1.0 / inverse - z) <= max_depth_jump * z;  // the depth-jump rule of the normals
    }
    if (!surface)
      continue;
    Eigen::Vector3f normal = Eigen::Vector3f::Zero ();
    if (fill_normals)
      for (const int i : ring)
        if (std::isfinite (planes.nx[static_cast<std::size_t> (i)]))
          normal += Eigen::Vector3f (planes.nx[static_cast<std::size_t> (i)], planes.ny[static_cast<std::size_t> (i)],
                                     planes.nz[static_cast<std::size_t> (i)]);
    const bool has_normal = normal.norm () > 0.f;
    normal.normalize ();
    for (const int i : hole)
    {
      const Eigen::Vector3d at (1.0, i % w, i / w);
      const double inverse = at.dot (fit.col (0));
      if (!(inverse > 0.0))
        continue;
      const auto j = static_cast<std::size_t> (i);
      const double z = 1.0 / inverse;
      planes.z[j] = static_cast<float> (z);
      planes.x[j] = static_cast<float> (at.dot (fit.col (1)) * z);
      planes.y[j] = static_cast<float> (at.dot (fit.col (2)) * z);
      if (fill_normals && has_normal)
      {
        planes.nx[j] = normal.x ();
        planes.ny[j] = normal.y ();
        planes.nz[j] = normal.z ();
      }
      ++filled;
    }
  }
  return filled;
}
}  // namespace segmentation
}  // namespace cuefusion
