// Relocalisation keyframe files (run --save-volume writes volume.keyframes, --load-volume reads it).
#include "fuzz_input.h"

#include <cuefusion/reconstruction/keyframe_database.h>

extern "C" int
LLVMFuzzerTestOneInput (const std::uint8_t* data, std::size_t size)
{
  const std::string path = cuefusion::fuzz::writeInput (data, size, "volume.keyframes");
  cuefusion::fuzz::expectErrorOrSuccess ([&] {
    const cuefusion::reconstruction::KeyframeDatabase database = cuefusion::reconstruction::KeyframeDatabase::load (path);
    // A loaded database must be usable: encode a small depth image and query it.
    const cv::Mat depth (48, 64, CV_32F, cv::Scalar (1.5f));
    database.query (database.encode (depth), 3);
  });
  return 0;
}
