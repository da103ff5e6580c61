// SPDX-License-Identifier: BSD-3-Clause
// Every pose and trajectory reader on the same bytes: TUM lists, Redwood .log, 4x4 files.
#include "fuzz_input.h"

#include <cuefusion/io/pose_io.h>

extern "C" int
LLVMFuzzerTestOneInput (const std::uint8_t* data, std::size_t size)
{
  const std::string path = cuefusion::fuzz::writeInput (data, size, "poses.txt");
  cuefusion::fuzz::expectErrorOrSuccess ([&] { cuefusion::io::readTumTrajectory (path); });
  cuefusion::fuzz::expectErrorOrSuccess ([&] { cuefusion::io::readRedwoodLog (path); });
  cuefusion::fuzz::expectErrorOrSuccess ([&] { cuefusion::io::readPoseMatrixFile (path); });
  return 0;
}
