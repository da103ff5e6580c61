// SPDX-License-Identifier: BSD-3-Clause
// TSDF volume files (run --save-volume, --load-volume).
#include "fuzz_input.h"

#include <cuefusion/reconstruction/tsdf_volume.h>

extern "C" int
LLVMFuzzerTestOneInput (const std::uint8_t* data, std::size_t size)
{
  const std::string path = cuefusion::fuzz::writeInput (data, size, "volume.tsdf");
  cuefusion::fuzz::expectErrorOrSuccess ([&] {
    const cuefusion::reconstruction::TSDFVolume volume = cuefusion::reconstruction::TSDFVolume::load (path);
    pcl::PointCloud<pcl::PointXYZRGBL> cloud;  // a loaded volume must be usable
    volume.extractPointCloud (cloud);
  });
  return 0;
}
