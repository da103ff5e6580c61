// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <opencv2/core.hpp>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace cuefusion
{
namespace io
{
/** \brief Throws cuefusion::Error naming \a path unless it is a regular file (or a link
  * to one): a folder, a device (/dev/zero, /dev/stdin), a FIFO or a socket is refused
  * before it is opened, so no reader blocks on it or reads it without end. Returns the
  * file's size in bytes. Every reader of cuefusion calls it (or readTextFile, which does).
  */
std::uint64_t
requireRegularFile (const std::string& path);

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
  * failure (including \a write throwing) the temporary file is removed, \a path is
  * untouched, and cuefusion::Error names \a path. An existing \a path that is not a
  * regular file (a folder, a device such as /dev/full, a pipe) is refused, not replaced.
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

/** \brief A command's output files in a folder, replaced as one set.
  *
  * Every output is first written below a staging folder inside \a dir
  * (`.cuefusion-staging-XXXXXX`, on the same file system, so moving is renaming); until
  * commit() nothing in \a dir changes, and an OutputSet destroyed without commit()
  * removes its staging folder (and \a dir, when it created it and it is empty) — an
  * error or an interruption while writing leaves the previous set untouched. commit() first moves the previous set's \a marker file
  * aside, then replaces each staged entry, removes the previous set's \a owned entries
  * the new set does not have (so files of two runs are never mixed), and moves the new
  * \a marker into place last: a folder whose marker is present holds one complete set.
  * SIGINT and SIGTERM are held back during commit() (a few renames). Staging folders
  * left by a killed process are removed when the next OutputSet opens the folder.
  * Other files in \a dir (renders, reports, the user's own) are never touched.
  */
class OutputSet
{
public:
  /** Creates \a dir when missing and a staging folder in it, and holds an exclusive
    * lock on \a dir until destroyed; cuefusion::Error naming \a dir when that fails or
    * another process holds the lock (two commands writing into one folder). \a owned: the top-level names this command writes;
    * \a marker: the one among them written last (it marks the set complete). */
  OutputSet (const std::string& dir, std::vector<std::string> owned, std::string marker);
  ~OutputSet ();
  OutputSet (const OutputSet&) = delete;
  OutputSet& operator= (const OutputSet&) = delete;

  /** Where to write \a name (a path relative to the folder, e.g. "labels/000010.png"):
    * inside the staging folder, its parent folders created. The final location is
    * finalPath (\a name). */
  std::string
  stagingPath (const std::string& name) const;

  /** Where \a name will be once committed. */
  std::string
  finalPath (const std::string& name) const;

  /** \a message with the staging folders of output sets (OutputSet, writeFolderAtomic)
    * taken out of the paths it names: an error names the file as the user will find it
    * ("out/map.pcd"), not where it was being written. */
  static std::string
  finalPaths (const std::string& message);

  /** Moves the staged set into place as described above; cuefusion::Error naming the
    * entry that could not be moved (the staging folder is removed either way). */
  void
  commit ();

  const std::string&
  folder () const
  {
    return dir_;
  }

private:
  std::string dir_, staging_, marker_;
  std::vector<std::string> owned_;
  bool committed_ = false;
  bool created_ = false;  ///< dir_ did not exist before: removed again (when empty) if never committed
  int lock_ = -1;         ///< the folder, open and flock()ed for the set's lifetime
};

/** \brief \a j as JSON text (\a indent as nlohmann::json::dump; -1: one line). Text that
  * is not UTF-8 (a path or class name of other bytes) is written with U+FFFD for each bad
  * byte instead of failing: every JSON cuefusion writes or quotes goes through here. */
std::string
jsonText (const nlohmann::json& j, int indent = -1);

/** \brief Writes text atomically (temporary file, then rename). */
void
writeTextAtomic (const std::string& path, const std::string& text);

/** \brief Whole file as a string; throws cuefusion::Error naming it when it cannot be read. */
std::string
readTextFile (const std::string& path);

/** \brief SHA-256 (FIPS 180-4) of \a bytes as 64 lowercase hex digits. */
std::string
sha256 (const std::string& bytes);

/** \brief SHA-256 of a file's bytes (what outputs.json records of the network a run used);
  * throws cuefusion::Error naming the file when it cannot be read. */
std::string
sha256OfFile (const std::string& path);

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
