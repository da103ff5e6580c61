// SPDX-License-Identifier: BSD-3-Clause
// An ONNX model file, as `run --model` and `segment-frame --model` load it: the structural
// check first (recognition::checkOnnxModel), then OpenCV's importer on what passed. The
// check refuses with cuefusion::Error; OpenCV may refuse with cv::Exception; a crash,
// another exception or a sanitizer report anywhere is a finding.
#include "fuzz_input.h"

#include <cuefusion/recognition/onnx_model_check.h>

#include <opencv2/core/utils/logger.hpp>
#include <opencv2/dnn.hpp>

extern "C" int
LLVMFuzzerTestOneInput (const std::uint8_t* data, std::size_t size)
{
  static const bool quiet = [] {
    cv::utils::logging::setLogLevel (cv::utils::logging::LOG_LEVEL_SILENT);
    return true;
  }();
  (void) quiet;
  const std::string path = cuefusion::fuzz::writeInput (data, size, "model.onnx");
  cuefusion::fuzz::expectErrorOrSuccess ([&] {
    cuefusion::recognition::checkOnnxModel (path);
    try
    {
      cv::dnn::readNetFromONNX (path);
    }
    catch (const cv::Exception&)
    {
    }
  });
  return 0;
}
