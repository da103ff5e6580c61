// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/rgbd_frame.h>
#include <cuefusion/io/pose_io.h>

#include <memory>
#include <string>

namespace cuefusion
{
namespace io
{
enum class DatasetLayout
{
  TUM,
  ScanNet,
  Redwood,
  SevenScenes
};

/** \brief "tum", "scannet", "redwood", "7scenes" (throws naming --layout otherwise). */
DatasetLayout
parseDatasetLayout (const std::string& name);

/** \brief Writes RGBDFrames as a dataset folder that the matching grabber reads back.
  *
  * - TUM: rgb/T.png, depth/T'.png (depth × 5000; depth stamped 4 ms after colour, as
  *   real TUM sequences are not synchronised), rgb.txt, depth.txt, groundtruth.txt,
  *   intrinsics.txt, masks in instance/ and label/
  * - ScanNet: color/N.jpg at twice the depth resolution (as SensReader exports differ in
  *   size), depth/N.png (mm), pose/N.txt, intrinsic/intrinsic_{depth,color}.txt, masks
  *   in instance-filt/ and label-filt/ at colour resolution
  * - Redwood: depth/NNNNN.png (mm), image/NNNNN.png, trajectory.log,
  *   camera_intrinsics.json, masks in instance/ and label/
  * - 7-Scenes: frame-NNNNNN.{color.png,depth.png,pose.txt,instance.png,label.png},
  *   camera-intrinsics.txt
  * Every file is written atomically.
  */
class SequenceWriter
{
public:
  virtual ~SequenceWriter () = default;

  static std::unique_ptr<SequenceWriter> create (DatasetLayout layout, const std::string& dir, const PinholeCamera& camera);

  /** \brief Writes one frame (index, timestamp, colour, depth, pose, masks). */
  virtual void write (const RGBDFrame& frame) = 0;
  /** \brief Writes the index and trajectory files. */
  virtual void finish () = 0;
  /** \brief Stem a grabber reports as RGBDFrame::name for \a frame. */
  virtual std::string frameName (const RGBDFrame& frame) const = 0;

protected:
  SequenceWriter (const std::string& dir, const PinholeCamera& camera) : dir_ (dir), camera_ (camera) {}
  std::string dir_;
  PinholeCamera camera_;
};
}  // namespace io
}  // namespace cuefusion
