// SPDX-License-Identifier: BSD-3-Clause
// The PCD path of segment-frame and eval: header check, PCL's reader, conversion.
#include "fuzz_input.h"

#include <cuefusion/io/map_io.h>

#include <pcl/console/print.h>
#include <pcl/conversions.h>

extern "C" int
LLVMFuzzerTestOneInput (const std::uint8_t* data, std::size_t size)
{
  static const bool quiet = [] {  // PCL's console warnings would drown libFuzzer's output
    pcl::console::setVerbosityLevel (pcl::console::L_ALWAYS);
    return true;
  }();
  (void) quiet;
  const std::string path = cuefusion::fuzz::writeInput (data, size, "input.pcd");
  cuefusion::fuzz::expectErrorOrSuccess ([&] {
    const pcl::PCLPointCloud2 blob = cuefusion::io::readPCD (path, {"x", "y", "z"});
    pcl::PointCloud<pcl::PointXYZ> cloud;
    pcl::fromPCLPointCloud2 (blob, cloud);
    if (cloud.size () != static_cast<std::size_t> (blob.width) * blob.height)
      std::abort ();
  });
  return 0;
}
