// SPDX-License-Identifier: BSD-3-Clause
// Image files as the grabbers, mask folders and segment-frame read them: io::readImage
// (PNG and JPEG through libpng and libjpeg, modules/io/src/image_codec.cpp) under the
// flag sets cuefusion uses (colour frames, depth and label images, unchanged).
#include "fuzz_input.h"

#include <cuefusion/io/file_io.h>

#include <opencv2/imgcodecs.hpp>

extern "C" int
LLVMFuzzerTestOneInput (const std::uint8_t* data, std::size_t size)
{
  const std::string path = cuefusion::fuzz::writeInput (data, size, "image");
  for (const int flags : {int (cv::IMREAD_COLOR), cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR, int (cv::IMREAD_UNCHANGED)})
    cuefusion::fuzz::expectErrorOrSuccess ([&] {
      const cv::Mat image = cuefusion::io::readImage (path, flags);
      if (image.empty () || image.data == nullptr)
        std::abort ();  // an image or an Error, never an empty answer
    });
  return 0;
}
