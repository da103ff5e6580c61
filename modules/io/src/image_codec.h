// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace cuefusion
{
namespace io
{
namespace detail
{
/** \brief PNG and JPEG through libpng and libjpeg directly.
  *
  * Why not OpenCV's imgcodecs: Debian builds it with GDAL, whose dependency tree (about 120
  * shared libraries) is loaded and relocated in every process that links it — 41 MB of
  * resident memory in `cuefusion run` for two formats. The pixels and bytes are the same as
  * OpenCV 4.6's for every image cuefusion reads or writes (the codecs are configured as
  * imgcodecs configures them; test/io/test_image_codec.cpp compares both). Not done, on
  * purpose: EXIF orientation (an RGB-D frame must not be rotated apart from its depth),
  * CMYK JPEG, and formats other than PNG and JPEG.
  */

/** \brief Decodes \a bytes (PNG or JPEG, by signature) into the type cv::imdecode would give
  * for \a flags (cv::IMREAD_*). On failure returns an empty Mat with the reason in
  * \a failure; decoder warnings of a good image are appended to \a warnings. */
cv::Mat
decodeImage (const std::vector<uchar>& bytes, int flags, std::string& failure, std::string& warnings);

/** \brief Encodes \a image for \a extension (".png", ".jpg", ".jpeg"; any case) with
  * cv::IMWRITE_PNG_COMPRESSION, cv::IMWRITE_PNG_STRATEGY or cv::IMWRITE_JPEG_QUALITY in
  * \a params. False with the reason in \a failure when it cannot. */
bool
encodeImage (const std::string& extension, const cv::Mat& image, const std::vector<int>& params, std::vector<uchar>& out,
             std::string& failure);
}  // namespace detail
}  // namespace io
}  // namespace cuefusion
