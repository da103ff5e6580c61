// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/pinhole_camera.h>
#include <cuefusion/reconstruction/noise_estimation.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <vector>

namespace cuefusion
{
namespace reconstruction
{
namespace
{
/** \brief (measured σ_z) / (model σ_z) of the patch at (x0, y0), or a negative value when
  * fewer than three quarters of its pixels are valid. The plane w = a + b·x + c·y is fitted
  * to inverse depth w = 1/z by least squares about the patch's means (in double: the
  * residuals are a thousandth of w).
  */
double
patchRatio (const cv::Mat& depth, int x0, int y0, int size)
{
  double n = 0, sx = 0, sy = 0, sw = 0, sz = 0;
  for (int y = 0; y < size; ++y)
  {
    const float* row = depth.ptr<float> (y0 + y) + x0;
    for (int x = 0; x < size; ++x)
      if (row[x] > 0.f && std::isfinite (row[x]))
      {
        n += 1;
        sx += x;
        sy += y;
        sw += 1.0 / row[x];
        sz += row[x];
      }
  }
  if (4 * n < 3 * size * size)
    return -1.0;
  const double mx = sx / n, my = sy / n, mw = sw / n, mean_z = sz / n;
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero ();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero ();
  double ww = 0;
  for (int y = 0; y < size; ++y)
  {
    const float* row = depth.ptr<float> (y0 + y) + x0;
    for (int x = 0; x < size; ++x)
      if (row[x] > 0.f && std::isfinite (row[x]))
      {
        const Eigen::Vector3d a (1.0, x - mx, y - my);
        const double w = 1.0 / row[x] - mw;
        normal += a * a.transpose ();
        rhs += a * w;
        ww += w * w;
      }
  }
  const Eigen::Vector3d plane = normal.ldlt ().solve (rhs);
  const double residual = std::max (0.0, ww - plane.dot (rhs));  // Σ r² of the least-squares fit
  const double sigma_inverse = std::sqrt (residual / (n - 3.0));
  return sigma_inverse * mean_z * mean_z / KinectNoiseModel::atNormalIncidence (static_cast<float> (mean_z));
}
}  // namespace

DepthNoiseEstimate
estimateDepthNoise (const cv::Mat& depth, int patch_size)
{
  if (depth.type () != CV_32F)
    throw Error ("estimateDepthNoise", "depth must be CV_32F metres");
  if (patch_size < 3)
    throw Error ("estimateDepthNoise", "patch size must be at least 3 pixels");
  std::vector<double> ratios;
  for (int y = 0; y + patch_size <= depth.rows; y += patch_size)
    for (int x = 0; x + patch_size <= depth.cols; x += patch_size)
    {
      const double r = patchRatio (depth, x, y, patch_size);
      if (r >= 0.0)
        ratios.push_back (r);
    }
  DepthNoiseEstimate estimate;
  estimate.patches = static_cast<int> (ratios.size ());
  if (ratios.empty ())
    return estimate;
  const auto middle = ratios.begin () + static_cast<std::ptrdiff_t> (ratios.size () / 2);
  std::nth_element (ratios.begin (), middle, ratios.end ());
  estimate.ratio = static_cast<float> (*middle);
  return estimate;
}
}  // namespace reconstruction
}  // namespace cuefusion
