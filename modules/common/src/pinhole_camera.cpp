// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/common/pinhole_camera.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace cuefusion
{
PinholeCamera
PinholeCamera::scaled (int new_width, int new_height) const
{
  const double sx = static_cast<double> (new_width) / width;
  const double sy = static_cast<double> (new_height) / height;
  return {fx * sx, fy * sy, (cx + 0.5) * sx - 0.5, (cy + 0.5) * sy - 0.5, new_width, new_height};
}

Eigen::Matrix3d
PinholeCamera::matrix () const
{
  Eigen::Matrix3d k;
  k << fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0;
  return k;
}

bool
PinholeCamera::isValid () const
{
  // Bounds, not just signs: a focal length of 1e-300 loses every frame silently, and a
  // principal point far outside the image (10^6 px on a 640-px frame) sends every ray of
  // the raycast past the volume, where it marches for hours. Real cameras have theirs
  // inside the image; four image sizes either way leave room for crops and odd rigs.
  constexpr double max_focal = 1e6, max_centre_in_sizes = 4.0;
  constexpr int max_size = 65536;
  return std::isfinite (fx) && std::isfinite (fy) && std::isfinite (cx) && std::isfinite (cy) && fx >= 1.0 &&
         fy >= 1.0 && fx <= max_focal && fy <= max_focal && width > 0 && height > 0 && width <= max_size &&
         height <= max_size && std::abs (cx) <= max_centre_in_sizes * width && std::abs (cy) <= max_centre_in_sizes * height;
}

void
PinholeCamera::validate (const std::string& source) const
{
  if (isValid ())
    return;
  std::ostringstream msg;
  msg << "invalid camera intrinsics (fx=" << fx << " fy=" << fy << " cx=" << cx << " cy=" << cy
      << " size=" << width << "x" << height << ")";
  throw Error (source, msg.str ());
}

bool
PinholeCamera::operator== (const PinholeCamera& o) const
{
  return fx == o.fx && fy == o.fy && cx == o.cx && cy == o.cy && width == o.width && height == o.height;
}

double
kinectAxialNoise (double z, double theta)
{
  constexpr double half_pi = 1.57079632679489661923;
  const double t = std::min (std::abs (theta), half_pi - 1e-3);
  const double dz = z - KinectNoiseModel::offset;
  return KinectNoiseModel::base + KinectNoiseModel::quadratic * dz * dz + 0.0001 / std::sqrt (std::max (z, 1e-6)) * t * t / ((half_pi - t) * (half_pi - t));
}

Eigen::Isometry3d
lookAt (const Eigen::Vector3d& eye, const Eigen::Vector3d& target, const Eigen::Vector3d& up)
{
  const Eigen::Vector3d forward = (target - eye).normalized ();
  const Eigen::Vector3d right = forward.cross (up).normalized ();
  const Eigen::Vector3d down = forward.cross (right);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity ();
  pose.linear ().col (0) = right;
  pose.linear ().col (1) = down;
  pose.linear ().col (2) = forward;
  pose.translation () = eye;
  return pose;
}
}  // namespace cuefusion
