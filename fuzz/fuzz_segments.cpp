// SPDX-License-Identifier: BSD-3-Clause
// A run's segments.json, as eval reads it.
#include "fuzz_input.h"

#include <cuefusion/segmentation/segments_file.h>

extern "C" int
LLVMFuzzerTestOneInput (const std::uint8_t* data, std::size_t size)
{
  const std::string path = cuefusion::fuzz::writeInput (data, size, "segments.json");
  cuefusion::fuzz::expectErrorOrSuccess ([&] {
    for (const cuefusion::segmentation::SegmentEntry& s : cuefusion::segmentation::readSegmentsJson (path))
      if (s.id == 0 || !(s.score == -1.0 || (s.score >= 0.0 && s.score <= 1.0)))
        std::abort ();
  });
  return 0;
}
