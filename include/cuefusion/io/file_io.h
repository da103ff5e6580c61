#pragma once

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>

#include <functional>
#include <string>
#include <vector>

namespace cuefusion
{
namespace io
{
/** \brief Reads and decodes an image; throws cuefusion::Error naming the file when it is
  * missing, unreadable, truncated or not an image. \a flags as for cv::imread.
  */
cv::Mat
readImage (const std::string& path, int flags);

/** \brief Reads a 16-bit single-channel depth PNG and returns CV_32F metres
  * (raw / \a units_per_metre); raw 0 stays 0 (invalid).
  */
cv::Mat
readDepthImage (const std::string& path, double units_per_metre);

/** \brief Reads a 16-bit single-channel label/instance PNG (CV_16U). */
cv::Mat
readLabelImage (const std::string& path);

/** \brief Converts CV_32F metres to CV_16U raw units (rounded; invalid and out-of-range → 0). */
cv::Mat
depthToRaw (const cv::Mat& depth_m, double units_per_metre);

/** \brief Encodes \a image by the file's extension and writes it atomically
  * (temporary file in the same folder, then rename), so a reader never sees half a file.
  */
void
writeImageAtomic (const std::string& path, const cv::Mat& image, const std::vector<int>& params = {});

/** \brief Atomic replacement of \a path: \a write fills a temporary file in the same
  * folder (returning false on failure), which is then renamed over \a path. On any
  * failure the temporary file is removed, \a path is untouched, and cuefusion::Error
  * names \a path.
  */
void
writeFileAtomic (const std::string& path, const std::function<bool (const std::string& temporary)>& write);

/** \brief Writes a whole folder atomically: \a fill writes into a temporary sibling
  * folder, which then replaces \a dir (an old \a dir is removed only after the swap). On
  * any failure the temporary folder is removed and \a dir is untouched. An existing
  * non-empty \a dir is a cuefusion::Error unless \a overwrite.
  */
void
writeFolderAtomic (const std::string& dir, bool overwrite, const std::function<void (const std::string& staging)>& fill);

/** \brief Writes text atomically (temporary file, then rename). */
void
writeTextAtomic (const std::string& path, const std::string& text);

/** \brief Whole file as a string; throws cuefusion::Error naming it when it cannot be read. */
std::string
readTextFile (const std::string& path);

/** \brief JSON text from \a source, parsed; throws cuefusion::Error naming \a source when
  * it is not JSON or nests deeper than 64 levels. */
nlohmann::json
parseJson (const std::string& text, const std::string& source);

/** \brief A JSON file, parsed; throws cuefusion::Error naming it ("not valid JSON (…)")
  * when it cannot be read or parsed. */
nlohmann::json
readJsonFile (const std::string& path);

/** \brief Whitespace-separated numbers of a text file; throws on any non-numeric token. */
std::vector<double>
readNumbers (const std::string& path);
}  // namespace io
}  // namespace cuefusion
