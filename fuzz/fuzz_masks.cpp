// SPDX-License-Identifier: BSD-3-Clause
// A mask JSON sidecar next to a fixed id PNG (ids 1, 2, 3), as MaskFolderSegmenter reads it.
#include "fuzz_input.h"

#include <cuefusion/io/file_io.h>
#include <cuefusion/recognition/mask_folder_segmenter.h>

#include <opencv2/core.hpp>

extern "C" int
LLVMFuzzerTestOneInput (const std::uint8_t* data, std::size_t size)
{
  static const std::string png = [] {
    cv::Mat ids (8, 8, CV_16UC1, cv::Scalar (0));
    ids (cv::Rect (0, 0, 4, 4)) = 1;
    ids (cv::Rect (4, 0, 4, 4)) = 2;
    ids (cv::Rect (0, 4, 8, 4)) = 3;
    const std::string path = cuefusion::fuzz::folder () + "/masks.png";
    cuefusion::io::writeImageAtomic (path, ids);
    return path;
  }();
  cuefusion::fuzz::writeInput (data, size, "masks.json");
  cuefusion::fuzz::expectErrorOrSuccess ([&] {
    for (const cuefusion::Instance& instance :
         cuefusion::recognition::MaskFolderSegmenter::readInstanceMasks (png, cv::Size (8, 8), {"a", "b"}))
      if (!(instance.score >= 0.f && instance.score <= 1.f))
        std::abort ();
  });
  return 0;
}
