// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <opencv2/core/utils/logger.hpp>

namespace cuefusion
{
/** \brief OpenCV's own log silenced for the object's lifetime (the level before comes
  * back at its end): where OpenCV reports on stderr what cuefusion reports as its one
  * error line (a model's refused input shape, a video backend that cannot open).
  */
class QuietOpenCVLog
{
public:
  QuietOpenCVLog () : before_ (cv::utils::logging::setLogLevel (cv::utils::logging::LOG_LEVEL_SILENT)) {}
  ~QuietOpenCVLog () { cv::utils::logging::setLogLevel (before_); }
  QuietOpenCVLog (const QuietOpenCVLog&) = delete;
  QuietOpenCVLog& operator= (const QuietOpenCVLog&) = delete;

private:
  cv::utils::logging::LogLevel before_;
};
}  // namespace cuefusion
