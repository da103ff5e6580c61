// SPDX-License-Identifier: BSD-3-Clause
// A TUM RGB-D folder's rgb.txt and depth.txt (the input split at its first 0xff byte),
// associated by io::TumGrabber: cuefusion::Error or a list of frames, each colour entry
// used once, in time order.
#include "fuzz_input.h"

#include <cuefusion/io/dataset_layouts.h>

#include <cmath>

extern "C" int
LLVMFuzzerTestOneInput (const std::uint8_t* data, std::size_t size)
{
  const std::string text (reinterpret_cast<const char*> (data), size);
  const std::size_t split = text.find ('\xff');
  const std::string dir = cuefusion::fuzz::folder ();
  cuefusion::fuzz::writeInput (reinterpret_cast<const std::uint8_t*> (text.data ()), std::min (split, text.size ()), "rgb.txt");
  const std::string depth = split == std::string::npos ? std::string () : text.substr (split + 1);
  cuefusion::fuzz::writeInput (reinterpret_cast<const std::uint8_t*> (depth.data ()), depth.size (), "depth.txt");
  static const std::string intrinsics = "52.5 52.5 31.5 23.5 64 48\n";
  cuefusion::fuzz::writeInput (reinterpret_cast<const std::uint8_t*> (intrinsics.data ()), intrinsics.size (), "intrinsics.txt");
  cuefusion::fuzz::expectErrorOrSuccess ([&] {
    const cuefusion::io::TumGrabber grabber (dir);
    // (a list may name one file at two stamps: entries are told apart by their stamps)
    double last = -INFINITY;
    for (const cuefusion::io::FrameRecord& r : grabber.records ())
    {
      if (!(r.timestamp > last))
        std::abort ();
      last = r.timestamp;
    }
  });
  return 0;
}
