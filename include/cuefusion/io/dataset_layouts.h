// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/io/dataset_grabber.h>
#include <cuefusion/common/sensor_defaults.h>

#include <string>

namespace cuefusion
{
namespace io
{
/** \brief Options of TumGrabber. */
struct TumGrabberConfig
{
  double max_difference = 0.02;   ///< seconds between associated colour and depth
  std::string intrinsics_path;    ///< overrides the folder's intrinsics
};

/** \brief TUM RGB-D benchmark folder: rgb.txt, depth.txt, rgb/, depth/ (depth / 5000),
  * optional groundtruth.txt interpolated to the colour timestamps.
  *
  * Colour and depth are associated by nearest timestamp within max_difference, each
  * image used at most once (as the benchmark's associate.py does). Intrinsics come from
  * Config::intrinsics_path, else <root>/intrinsics.txt, else the benchmark's published
  * values for a freiburg1/2/3 folder name, else the ROS default (525, 319.5, 239.5).
  * Optional instance/ and label/ folders hold masks named like the colour images.
  */
class TumGrabber : public DatasetGrabber
{
public:
  using Config = TumGrabberConfig;
  explicit TumGrabber (const std::string& root, const Config& config = Config ());
  std::string formatName () const override { return "tum"; }
};

/** \brief Options of the grabbers whose layouts store no timestamps
  * (Redwood, 7-Scenes, ScanNet).
  */
struct FolderGrabberConfig
{
  std::string intrinsics_path;   ///< overrides the folder's intrinsics
  double fps = kFrameRate;             ///< timestamps = frame number / fps
};

/** \brief Redwood / ICL-NUIM folder as Open3D reads it: depth/ (mm), image/ or color/,
  * optional trajectory.log (camera-to-world), camera_intrinsics.json. Folders of Open3D's
  * RealSense and Azure Kinect recorders (color/, depth/, camera_intrinsic.json or
  * intrinsic.json) are read as such.
  * Depth and colour are paired in sorted (numeric) file order.
  */
class RedwoodGrabber : public DatasetGrabber
{
public:
  using Config = FolderGrabberConfig;
  explicit RedwoodGrabber (const std::string& root, const Config& config = Config ());
  std::string formatName () const override { return "redwood"; }
};

/** \brief Microsoft 7-Scenes layout: frame-NNNNNN.color.{png,jpg}, .depth.png (mm,
  * 65535 = invalid), .pose.txt (4×4 camera-to-world), camera-intrinsics.txt (3×3 K).
  */
class SevenScenesGrabber : public DatasetGrabber
{
public:
  using Config = FolderGrabberConfig;
  explicit SevenScenesGrabber (const std::string& root, const Config& config = Config ());
  std::string formatName () const override { return "7scenes"; }
};

/** \brief ScanNet export as written by SensReader: color/N.jpg, depth/N.png (mm),
  * pose/N.txt, intrinsic/intrinsic_{depth,color}.txt, optional instance-filt/N.png and
  * label-filt/N.png; frames in numeric order. Colour (and the masks, which ScanNet
  * stores at colour resolution) is registered to the depth camera.
  */
class ScanNetGrabber : public DatasetGrabber
{
public:
  using Config = FolderGrabberConfig;
  explicit ScanNetGrabber (const std::string& root, const Config& config = Config ());
  std::string formatName () const override { return "scannet"; }
};
}  // namespace io
}  // namespace cuefusion
