// SPDX-License-Identifier: BSD-3-Clause
// Relocalisation keyframe files (run --save-volume writes volume.keyframes, --load-volume reads it).
#include "fuzz_input.h"

#include <cuefusion/reconstruction/keyframe_database.h>
#include <cuefusion/reconstruction/tsdf_volume.h>

extern "C" int
LLVMFuzzerTestOneInput (const std::uint8_t* data, std::size_t size)
{
  const std::string path = cuefusion::fuzz::writeInput (data, size, "volume.keyframes");
  cuefusion::fuzz::expectErrorOrSuccess ([&] {
    // Loaded beside an empty volume of the default configuration (the corpus's files name
    // it); the volume check comes after every other, so the parser is covered in full.
    const cuefusion::reconstruction::TSDFVolume volume;
    const cuefusion::reconstruction::KeyframeDatabase database = cuefusion::reconstruction::KeyframeDatabase::load (path, volume);
    // A loaded database must be usable: encode a small depth image and query it.
    const cv::Mat depth (48, 64, CV_32F, cv::Scalar (1.5f));
    database.query (database.encode (depth), 3);
  });
  return 0;
}
