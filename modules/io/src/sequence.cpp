// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/dataset_layouts.h>
#include <cuefusion/io/openni2_frame_grabber.h>
#include <cuefusion/io/sequence.h>

#include <boost/algorithm/string.hpp>
#include <boost/filesystem.hpp>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace io
{
SequenceFormat
parseSequenceFormat (const std::string& name)
{
  const std::string n = boost::algorithm::to_lower_copy (name);
  if (n == "auto")
    return SequenceFormat::Auto;
  if (n == "tum")
    return SequenceFormat::TUM;
  if (n == "redwood" || n == "icl" || n == "icl-nuim")
    return SequenceFormat::Redwood;
  if (n == "7scenes" || n == "7-scenes")
    return SequenceFormat::SevenScenes;
  if (n == "scannet")
    return SequenceFormat::ScanNet;
  if (n == "openni2" || n == "oni")
    return SequenceFormat::OpenNI2;
  throw ParameterError ("SequenceFormat", "unknown format '" + name + "' (auto, tum, redwood, 7scenes, scannet, openni2)");
}

std::string
toString (SequenceFormat format)
{
  switch (format)
  {
    case SequenceFormat::Auto: return "auto";
    case SequenceFormat::TUM: return "tum";
    case SequenceFormat::Redwood: return "redwood";
    case SequenceFormat::SevenScenes: return "7scenes";
    case SequenceFormat::ScanNet: return "scannet";
    case SequenceFormat::OpenNI2: return "openni2";
  }
  return "unknown";
}

namespace
{
bool
isOpenNI2Source (const std::string& source)
{
  return source == "openni2" || boost::algorithm::starts_with (source, "openni2:") ||
         boost::algorithm::iends_with (source, ".oni");
}
}  // namespace

std::string
openni2DeviceOf (const std::string& source)
{
  if (source == "openni2")
    return "";
  if (boost::algorithm::starts_with (source, "openni2:"))
    return source.substr (8);
  return source;
}

SequenceFormat
detectSequenceFormat (const std::string& source)
{
  if (isOpenNI2Source (source))
    return SequenceFormat::OpenNI2;
  const fs::path dir (source);
  if (!fs::exists (dir))
    throw Error (source, "no such file or folder");
  if (!fs::is_directory (dir))
    throw Error (source, "not a folder (expected a dataset folder, openni2[:DEVICE] or a .oni file)");
  if (fs::is_empty (dir))
    throw Error (source, "folder is empty");
  if (fs::is_regular_file (dir / "rgb.txt") && fs::is_regular_file (dir / "depth.txt"))
    return SequenceFormat::TUM;
  if (fs::is_directory (dir / "depth") && fs::is_directory (dir / "color") && fs::is_directory (dir / "intrinsic"))
    return SequenceFormat::ScanNet;
  if (fs::is_directory (dir / "depth") && (fs::is_directory (dir / "image") || fs::is_directory (dir / "color")))
    return SequenceFormat::Redwood;
  for (const fs::directory_entry& e : fs::directory_iterator (dir))
  {
    const std::string name = e.path ().filename ().string ();
    if (boost::algorithm::starts_with (name, "frame-") && boost::algorithm::ends_with (name, ".depth.png"))
      return SequenceFormat::SevenScenes;
  }
  throw Error (source, "unrecognised sequence layout (expected TUM rgb.txt+depth.txt, ScanNet color/ depth/ "
                       "intrinsic/, Redwood depth/ image/, or 7-Scenes frame-*.depth.png)");
}

DatasetGrabber::Ptr
openDataset (const std::string& source, const SequenceOptions& options)
{
  SequenceFormat format = options.format;
  if (format == SequenceFormat::Auto)
    format = detectSequenceFormat (source);
  else if (!fs::is_directory (source))
    throw Error (source, fs::exists (source) ? "not a folder" : "no such folder");
  FolderGrabberConfig folder;
  folder.intrinsics_path = options.intrinsics_path;
  try
  {
    switch (format)
    {
      case SequenceFormat::TUM:
      {
        TumGrabber::Config c;
        c.intrinsics_path = options.intrinsics_path;
        c.max_difference = options.tum_max_difference;
        return std::make_shared<TumGrabber> (source, c);
      }
      case SequenceFormat::Redwood: return std::make_shared<RedwoodGrabber> (source, folder);
      case SequenceFormat::SevenScenes: return std::make_shared<SevenScenesGrabber> (source, folder);
      case SequenceFormat::ScanNet: return std::make_shared<ScanNetGrabber> (source, folder);
      default: break;
    }
  }
  catch (const fs::filesystem_error& e)
  {
    throw Error (source, e.code ().message ());
  }
  throw Error (source, "is a live source (" + toString (format) + "), not a dataset folder");
}

RGBDGrabber::Ptr
openSequence (const std::string& source, const SequenceOptions& options)
{
  SequenceFormat format = options.format;
  if (format == SequenceFormat::Auto)
    format = detectSequenceFormat (source);
  if (format == SequenceFormat::OpenNI2)
    return std::make_shared<OpenNI2FrameGrabber> (openni2DeviceOf (source));
  SequenceOptions o = options;
  o.format = format;
  return openDataset (source, o);
}
}  // namespace io
}  // namespace cuefusion
