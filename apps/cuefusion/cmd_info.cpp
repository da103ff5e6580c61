// SPDX-License-Identifier: BSD-3-Clause
#include "cli.h"

#include <cuefusion/io/openni2_frame_grabber.h>
#include <cuefusion/io/sequence.h>

#include <iomanip>
#include <iostream>

namespace cuefusion
{
namespace cli
{
int
runInfo (const std::vector<std::string>& args)
{
  std::string source, format, intrinsics;
  po::options_description options ("options");
  options.add_options ()
    ("sequence", po::value (&source)->required (), "dataset folder, openni2[:DEVICE] or .oni file")
    ("format", po::value (&format)->default_value ("auto"), "auto, tum, redwood, 7scenes, scannet, openni2")
    ("intrinsics", po::value (&intrinsics), "intrinsics file overriding the sequence's own");
  po::positional_options_description positional;
  positional.add ("sequence", 1);
  po::variables_map vm;
  if (!parseCommandLine ("info", "SEQUENCE [options]", args, options, positional, vm))
    return 0;

  io::SequenceOptions opts;
  opts.format = io::parseSequenceFormat (format);
  opts.intrinsics_path = intrinsics;
  const io::RGBDGrabber::Ptr grabber = io::openSequence (source, opts);
  std::cout << "sequence:    " << source << "\n"
            << "format:      " << grabber->formatName () << "\n";
  const auto dataset = std::dynamic_pointer_cast<io::DatasetGrabber> (grabber);
  if (!dataset)
  {
    std::cout << "frames:      live (" << grabber->getFramesPerSecond () << " fps)\n";
    return 0;
  }
  const PinholeCamera& c = dataset->camera ();
  const auto& records = dataset->records ();
  std::size_t with_pose = 0;
  for (const io::FrameRecord& r : records)
    with_pose += (r.pose || !r.pose_path.empty ()) ? 1 : 0;
  std::cout << "frames:      " << dataset->size () << "\n"
            << "resolution:  " << c.width << "x" << c.height << "\n"
            << "intrinsics:  fx=" << c.fx << " fy=" << c.fy << " cx=" << c.cx << " cy=" << c.cy << "\n"
            << "duration:    " << std::fixed << std::setprecision (2)
            << (records.back ().timestamp - records.front ().timestamp) << " s\n"
            << "poses:       " << (with_pose ? "yes" : "no") << " (" << with_pose << " of " << records.size ()
            << " frames)\n"
            << "masks:       " << (dataset->hasInstanceMasks () ? "yes" : "no") << "\n";
  return 0;
}
}  // namespace cli
}  // namespace cuefusion
