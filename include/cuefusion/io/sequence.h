// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/io/dataset_grabber.h>

#include <string>

namespace cuefusion
{
namespace io
{
enum class SequenceFormat
{
  Auto,
  TUM,
  Redwood,
  SevenScenes,
  ScanNet,
  OpenNI2
};

/** \brief "auto", "tum", "redwood", "7scenes", "scannet", "openni2" (throws otherwise). */
SequenceFormat
parseSequenceFormat (const std::string& name);

std::string
toString (SequenceFormat format);

/** \brief Options shared by every way of opening a sequence. */
struct SequenceOptions
{
  SequenceFormat format = SequenceFormat::Auto;   ///< Auto = detect from the folder layout
  std::string intrinsics_path;                    ///< overrides the sequence's intrinsics
  double tum_max_difference = 0.02;               ///< TUM colour/depth association (s)
};

/** \brief Detects the layout of \a source:
  * - "openni2" / "openni2:DEVICE" or a *.oni file → OpenNI2
  * - rgb.txt + depth.txt → TUM
  * - color/ + depth/ + intrinsic/ → ScanNet
  * - depth/ + image/ or color/ → Redwood
  * - frame-*.depth.png → 7-Scenes
  * Throws cuefusion::Error naming the path when it is missing, empty or unrecognised.
  */
SequenceFormat
detectSequenceFormat (const std::string& source);

/** \brief Opens an offline sequence (any format but OpenNI2). */
DatasetGrabber::Ptr
openDataset (const std::string& source, const SequenceOptions& options = SequenceOptions ());

/** \brief Opens any source, live cameras and .oni recordings included. */
RGBDGrabber::Ptr
openSequence (const std::string& source, const SequenceOptions& options = SequenceOptions ());

/** \brief "openni2:#1" → "#1", "openni2" → "", a .oni path → itself. */
std::string
openni2DeviceOf (const std::string& source);
}  // namespace io
}  // namespace cuefusion
