// SPDX-License-Identifier: BSD-3-Clause
// numpy arrays in and out of the library's types, checked: a wrong dtype, shape or
// memory layout is a ValueError naming the argument, never a crash.
#pragma once

#include <cuefusion/common/instance.h>
#include <cuefusion/common/pinhole_camera.h>
#include <cuefusion/common/rgbd_frame.h>

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace cuefusion
{
namespace python
{
namespace py = pybind11;

/** \brief Raises Python's OSError with \a message (a file that cannot be read or written). */
[[noreturn]] void
raiseOSError (const std::string& message);

/** \brief Depth as CV_32F metres (a copy): float32 metres, or uint16 divided by \a depth_scale. */
cv::Mat
depthFromArray (const py::array& depth, double depth_scale);

/** \brief An H×W×3 uint8 RGB image as OpenCV's BGR (a copy); None gives an empty image. */
cv::Mat
colorFromArray (const py::object& color, cv::Size size);

/** \brief The 3×3 intrinsic matrix K for an image of \a size; ValueError unless fx, fy > 0
  * and every entry is finite. */
PinholeCamera
cameraFromArray (const py::object& K, cv::Size size);

/** \brief A 4×4 rigid transform (camera to world); ValueError otherwise. */
Eigen::Isometry3d
poseFromArray (const py::object& pose, const std::string& name);

/** \brief The frame's masks: None (no masks), an H×W integer array of instance ids (0 =
  * none; as a folder of id PNGs: class −1, score 1), or a list of (mask, score, class
  * name) with H×W boolean or uint8 masks. False for None. */
bool
instancesFromPython (const py::object& masks, cv::Size size, std::vector<Instance>& instances);

/** \brief A frame from numpy arrays (the colour converted to BGR). */
RGBDFrame
frameFromArrays (const py::array& depth, const py::object& color, const py::object& K, double depth_scale);

/** \brief Copies of OpenCV images and Eigen transforms as numpy arrays. */
py::array
arrayFromMat (const cv::Mat& image);
py::array
rgbArrayFromBgr (const cv::Mat& bgr);
py::array
arrayFromPose (const Eigen::Isometry3d& pose);
py::array
arrayFromCamera (const PinholeCamera& camera);
}  // namespace python
}  // namespace cuefusion
