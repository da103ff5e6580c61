// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/pinhole_camera.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstddef>
#include <memory>
#include <optional>
#include <string>

namespace cuefusion
{
/** \brief One registered RGB-D frame, as every grabber delivers it.
  *
  * - color: CV_8UC3 in OpenCV's BGR channel order, same size as depth
  * - depth: CV_32F z-depth in metres; 0 or NaN marks an invalid pixel
  * - pose: optional reference camera-to-world transform (the sequence's own poses)
  * - instance_mask / class_mask: optional CV_16U per-pixel instance id and class id
  *   (0 = none), e.g. ScanNet's instance-filt / label-filt or the synthetic truth
  */
struct RGBDFrame
{
  using Ptr = std::shared_ptr<RGBDFrame>;
  using ConstPtr = std::shared_ptr<const RGBDFrame>;

  std::size_t index = 0;     ///< position in the sequence, from 0
  double timestamp = 0.0;    ///< seconds
  std::string name;          ///< source file stem, e.g. "frame-000012" or "1305031102.175304"
  PinholeCamera camera;      ///< intrinsics of depth (colour is registered to it)
  cv::Mat color;
  cv::Mat depth;
  std::optional<Eigen::Isometry3d> pose;
  cv::Mat instance_mask;
  cv::Mat class_mask;

  bool hasPose () const { return pose.has_value (); }
  bool hasInstanceMask () const { return !instance_mask.empty (); }

  /** \brief Throws cuefusion::Error when types or sizes disagree with the contract above. */
  void validate (const std::string& source) const;
};

/** \brief Organized cloud (width × height of the frame) in the camera frame.
  * Invalid depth (0, NaN, inf) gives a point with NaN x, y, z; colour is kept.
  */
pcl::PointCloud<pcl::PointXYZRGBA>::Ptr
toPointCloud (const RGBDFrame& frame);

/** \brief The inverse of toPointCloud for an organized cloud whose intrinsics are not
  * known (a PCD file): depth = z (0 where the point is NaN), colour from the points, and
  * the pinhole camera fitted by least squares to u = fx·x/z + cx and v = fy·y/z + cy over
  * the valid points. With fewer than 10 valid points (or a degenerate fit) the camera is
  * Kinect's, scaled to the cloud's width.
  */
RGBDFrame
fromOrganizedCloud (const pcl::PointCloud<pcl::PointXYZRGBA>& cloud);

/** \brief True for a depth value that marks a measurement. */
inline bool
isValidDepth (float z)
{
  return z > 0.f && std::isfinite (z);
}
}  // namespace cuefusion
