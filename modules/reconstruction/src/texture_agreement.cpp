// SPDX-License-Identifier: BSD-3-Clause
// Texture agreement between a frame and the model's fused colours at a pose: a second cue,
// beside ICP's geometry, for a relocalised pose that overlaps the map in part.
#include <cuefusion/reconstruction/texture_agreement.h>

#include <opencv2/imgproc.hpp>

#include <cmath>
#include <limits>

namespace cuefusion
{
namespace reconstruction
{
namespace
{
/** Grey levels less their local mean over 9 pixels a side per 320 columns (17 at 640: the
  * same angle of view at any resolution): the texture, without the shading of whole
  * surfaces. */
cv::Mat
texture (const cv::Mat& bgr)
{
  cv::Mat grey, mean;
  cv::cvtColor (bgr, grey, cv::COLOR_BGR2GRAY);
  grey.convertTo (grey, CV_32F);
  const int side = 2 * static_cast<int> (std::lround (4.0 * bgr.cols / 320.0)) + 1;
  cv::blur (grey, mean, cv::Size (side, side));
  return grey - mean;
}

/** textureAgreement on the two images' textures (texture()). */
double
correlate (const cv::Mat& ours, const cv::Mat& theirs, const cv::Mat& vertices, const RaycastResult& view,
           const Eigen::Isometry3d& pose, double max_distance, std::size_t min_pixels)
{
  const Eigen::Matrix4f to_view = (view.pose.inverse () * pose).matrix ().cast<float> ();
  double n = 0.0, sa = 0.0, sb = 0.0, saa = 0.0, sbb = 0.0, sab = 0.0;
  for (int v = 0; v < vertices.rows; v += 2)
  {
    const cv::Vec3f* row = vertices.ptr<cv::Vec3f> (v);
    const float* grey = ours.ptr<float> (v);
    for (int u = 0; u < vertices.cols; u += 2)
    {
      if (!std::isfinite (row[u][2]))
        continue;
      const Eigen::Vector3f q = (to_view * Eigen::Vector4f (row[u][0], row[u][1], row[u][2], 1.f)).head<3> ();
      int x = 0, y = 0;
      if (!view.camera.projectToPixel (q, x, y))
        continue;
      const cv::Vec3f& hit = view.vertices.at<cv::Vec3f> (y, x);
      if (!std::isfinite (hit[2]) || std::abs (hit[2] - q.z ()) > max_distance)
        continue;
      const double a = grey[u], b = theirs.at<float> (y, x);
      n += 1.0, sa += a, sb += b, saa += a * a, sbb += b * b, sab += a * b;
    }
  }
  if (n < static_cast<double> (min_pixels) || n < 2.0)
    return std::numeric_limits<double>::quiet_NaN ();
  const double va = saa - sa * sa / n, vb = sbb - sb * sb / n;
  if (!(va > n && vb > n))  // a standard deviation under one grey level: no texture to judge by
    return std::numeric_limits<double>::quiet_NaN ();
  return (sab - sa * sb / n) / std::sqrt (va * vb);
}

bool
comparable (const cv::Mat& color, const cv::Mat& vertices, const RaycastResult& view)
{
  return !color.empty () && !view.colors.empty () && color.size () == vertices.size () && color.type () == CV_8UC3 &&
         vertices.type () == CV_32FC3 && view.colors.size () == view.vertices.size ();
}
}  // namespace

double
textureAgreement (const cv::Mat& color, const cv::Mat& vertices, const RaycastResult& view, const Eigen::Isometry3d& pose,
                  double max_distance, std::size_t min_pixels)
{
  if (!comparable (color, vertices, view))
    return std::numeric_limits<double>::quiet_NaN ();
  return correlate (texture (color), texture (view.colors), vertices, view, pose, max_distance, min_pixels);
}

TexturePeak
texturePeak (const cv::Mat& color, const cv::Mat& vertices, const RaycastResult& view, const Eigen::Isometry3d& pose,
             double step, double max_distance, std::size_t min_pixels)
{
  TexturePeak result;
  if (!comparable (color, vertices, view))
    return result;
  const cv::Mat ours = texture (color), theirs = texture (view.colors);
  result.agreement = correlate (ours, theirs, vertices, view, pose, max_distance, min_pixels);
  if (std::isnan (result.agreement))
    return result;
  result.peak = true;
  for (const Eigen::Vector3d& move : {Eigen::Vector3d (step, 0, 0), Eigen::Vector3d (-step, 0, 0), Eigen::Vector3d (0, step, 0),
                                      Eigen::Vector3d (0, -step, 0)})
  {
    // Moved in the camera's own x and y: where the view's texture shifts across the image.
    const double moved = correlate (ours, theirs, vertices, view, pose * Eigen::Translation3d (move), max_distance, min_pixels);
    result.peak = result.peak && !(moved >= result.agreement);
  }
  return result;
}
}  // namespace reconstruction
}  // namespace cuefusion
