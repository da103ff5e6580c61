// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/reconstruction/tsdf_volume.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <cstddef>
#include <limits>

namespace cuefusion
{
namespace reconstruction
{
/** \brief How well a frame's texture lines up with the model's fused colours at a pose: the
  * normalised cross-correlation of the two images' grey levels less their local mean (over
  * 9 pixels a side per 320 columns: texture, not the shading of whole surfaces, which two
  * wrong views share by their layout),
  * over the frame's points that, placed at \a pose, meet the surface \a view shows (their
  * depth within \a max_distance of the raycast's). Every other pixel of every other row.
  *
  * A cue independent of ICP's geometry: on a textured surface a pose a few centimetres or
  * degrees off reads near 0, a right one clearly above (docs/reconstruction.md gives the
  * measured values). \a color is the frame's CV_8UC3 image and \a vertices its CV_32FC3
  * camera-frame points (NaN invalid), of one size; \a view's camera may have another.
  * \return NaN when fewer than \a min_pixels points meet the surface or either side has no
  * texture there (a standard deviation under one grey level).
  */
double
textureAgreement (const cv::Mat& color, const cv::Mat& vertices, const RaycastResult& view, const Eigen::Isometry3d& pose,
                  double max_distance, std::size_t min_pixels);

/** \brief textureAgreement at \a pose, and whether the pose is its peak. */
struct TexturePeak
{
  double agreement = std::numeric_limits<double>::quiet_NaN ();
  /// above textureAgreement at \a pose moved by \a step along the camera's x and y, each way
  /// (a reading that is not NaN): the texture lines up there and not merely somewhere near.
  /// A wrong pose whose texture correlates by the layout of its surfaces reads as high moved
  /// a few centimetres; a right one drops (measured: docs/reconstruction.md)
  bool peak = false;
};

/** \brief textureAgreement at \a pose, and at \a pose moved by \a step (metres) along the
  * camera's x and y axes both ways, from one filtering of the two images. */
TexturePeak
texturePeak (const cv::Mat& color, const cv::Mat& vertices, const RaycastResult& view, const Eigen::Isometry3d& pose,
             double step, double max_distance, std::size_t min_pixels);
}  // namespace reconstruction
}  // namespace cuefusion
