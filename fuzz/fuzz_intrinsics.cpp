// SPDX-License-Identifier: BSD-3-Clause
// Every intrinsics format: Open3D/cuefusion JSON, 3x3/4x4 matrices, "fx fy cx cy [w h]".
#include "fuzz_input.h"

#include <cuefusion/io/camera_io.h>

extern "C" int
LLVMFuzzerTestOneInput (const std::uint8_t* data, std::size_t size)
{
  for (const char* name : {"intrinsics.json", "intrinsics.txt"})
  {
    const std::string path = cuefusion::fuzz::writeInput (data, size, name);
    cuefusion::fuzz::expectErrorOrSuccess ([&] {
      const cuefusion::PinholeCamera camera = cuefusion::io::readIntrinsics (path);
      if (!(camera.fx >= 1.0 && camera.fy >= 1.0))  // what was accepted is usable
        std::abort ();
    });
  }
  return 0;
}
