// SPDX-License-Identifier: BSD-3-Clause
#include "image_codec.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>  // the IMREAD_ constants; decoding is image_codec.cpp's

#include <boost/filesystem.hpp>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <mutex>
#include <regex>
#include <sstream>

#include <fcntl.h>
#include <pthread.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace io
{
namespace
{
std::vector<uchar>
readBytes (const std::string& path)
{
  const FileContext context (path);
  const std::uint64_t size = requireRegularFile (path);
  std::ifstream in (path, std::ios::binary);
  if (!in)
    throw Error (path, std::string ("cannot open: ") + std::strerror (errno));
  // The size stat() gave, and no more: a file that grows while it is read is cut there.
  std::vector<uchar> bytes (static_cast<std::size_t> (size));
  in.read (reinterpret_cast<char*> (bytes.data ()), static_cast<std::streamsize> (size));
  bytes.resize (static_cast<std::size_t> (in.gcount ()));
  return bytes;
}

// libpng decodes a PNG cut short after its first rows without an error and fills
// the rest with zeros; a PNG must end with its IEND chunk, so check that first.
bool
isTruncatedPng (const std::vector<uchar>& bytes)
{
  static const uchar signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (bytes.size () < 8 || std::memcmp (bytes.data (), signature, 8) != 0)
    return false;
  static const uchar iend[8] = {'I', 'E', 'N', 'D', 0xae, 0x42, 0x60, 0x82};
  return bytes.size () < 20 || std::memcmp (bytes.data () + bytes.size () - 8, iend, 8) != 0;
}

// JPEG data must end with the EOI marker FF D9.
bool
isTruncatedJpeg (const std::vector<uchar>& bytes)
{
  if (bytes.size () < 3 || bytes[0] != 0xff || bytes[1] != 0xd8)
    return false;
  std::size_t end = bytes.size ();
  while (end > 2 && (bytes[end - 1] == 0x00 || bytes[end - 1] == '\n' || bytes[end - 1] == '\r'))
    --end;  // some writers pad after EOI
  return !(bytes[end - 2] == 0xff && bytes[end - 1] == 0xd9);
}
}  // namespace

std::uint64_t
requireRegularFile (const std::string& path)
{
  struct stat info;
  if (::stat (path.c_str (), &info) != 0)
  {
    if (errno == ENOENT || errno == ENOTDIR)
      throw Error (path, "no such file");
    throw Error (path, std::string ("cannot open: ") + std::strerror (errno));
  }
  if (S_ISDIR (info.st_mode))
    throw Error (path, "is a folder, expected a file");
  if (S_ISFIFO (info.st_mode))
    throw Error (path, "is a pipe (FIFO), expected a regular file");
  if (S_ISCHR (info.st_mode) || S_ISBLK (info.st_mode))
    throw Error (path, "is a device, expected a regular file");
  if (!S_ISREG (info.st_mode))
    throw Error (path, "is not a regular file");
  return static_cast<std::uint64_t> (info.st_size);
}

cv::Mat
readImage (const std::string& path, int flags)
{
  const FileContext context (path);
  const std::vector<uchar> bytes = readBytes (path);
  if (bytes.empty ())
    throw Error (path, "file is empty");
  if (isTruncatedPng (bytes) || isTruncatedJpeg (bytes))
    throw Error (path, "image file is truncated");
  std::string failure, warnings;
  const cv::Mat image = detail::decodeImage (bytes, flags, failure, warnings);
  if (image.empty ())
    throw Error (path, "cannot decode image (" + (failure.empty () ? std::string ("corrupt or not an image") : failure) + ")");
  if (!warnings.empty ())  // a good image with oddities (a bad CRC in an ancillary chunk, ...)
    std::cerr << path << ": " << warnings << "\n";
  return image;
}

cv::Mat
readDepthImage (const std::string& path, double units_per_metre)
{
  const cv::Mat raw = readImage (path, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
  if (raw.type () != CV_16UC1)
    throw Error (path, "expected a 16-bit single-channel depth image, got " + std::to_string (raw.channels ()) +
                           " channel(s) of " + std::to_string (raw.elemSize1 () * 8) + " bits");
  cv::Mat depth;
  raw.convertTo (depth, CV_32F, 1.0 / units_per_metre);
  depth.setTo (0.f, raw == 65535);  // 7-Scenes marks invalid pixels with 65535, others with 0
  return depth;
}

cv::Mat
readLabelImage (const std::string& path)
{
  cv::Mat raw = readImage (path, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
  if (raw.channels () != 1)
    throw Error (path, "expected a single-channel label image, got " + std::to_string (raw.channels ()) + " channels");
  if (raw.type () == CV_8UC1)
    raw.convertTo (raw, CV_16U);
  if (raw.type () != CV_16UC1)
    throw Error (path, "expected an 8- or 16-bit label image");
  return raw;
}

cv::Mat
depthToRaw (const cv::Mat& depth_m, double units_per_metre)
{
  cv::Mat raw (depth_m.size (), CV_16UC1, cv::Scalar (0));
  for (int v = 0; v < depth_m.rows; ++v)
  {
    const float* z = depth_m.ptr<float> (v);
    std::uint16_t* out = raw.ptr<std::uint16_t> (v);
    for (int u = 0; u < depth_m.cols; ++u)
    {
      const double value = std::round (static_cast<double> (z[u]) * units_per_metre);
      out[u] = (std::isfinite (value) && value > 0.0 && value <= 65535.0) ? static_cast<std::uint16_t> (value) : 0;
    }
  }
  return raw;
}

namespace
{
void
refuseNonRegularTarget (const std::string& path)
{
  boost::system::error_code ec;
  const fs::file_status status = fs::status (path, ec);
  if (!ec && fs::exists (status) && !fs::is_regular_file (status))
    throw Error (path, fs::is_directory (status) ? "is a folder; refusing to replace it with a file"
                                                 : "exists and is not a regular file (a device, pipe or socket?); refusing to replace it");
}
}  // namespace

namespace
{
/** Why a write into \a folder failed: a full disk when it is (libraries report that in
  * their own words, or not at all: PCL's posix_fallocate leaves errno alone), else
  * \a otherwise. */
std::string
writeFailure (const fs::path& folder, const std::string& otherwise)
{
  boost::system::error_code ec;
  const fs::space_info space = fs::space (folder.empty () ? fs::path (".") : folder, ec);
  constexpr std::uintmax_t kNearlyFull = 1u << 20;
  if (!ec && space.available < kNearlyFull)
    return "the disk is full (" + std::to_string (space.available / 1024) + " KiB free)";
  return otherwise;
}
}  // namespace

void
writeFileAtomic (const std::string& path, const std::function<bool (const std::string& temporary)>& write)
{
  const FileContext context (path);
  refuseNonRegularTarget (path);
  const fs::path target (path);
  const fs::path tmp = target.parent_path () / fs::unique_path (".tmp-%%%%%%%%-" + target.filename ().string ());
  boost::system::error_code ec;
  bool written = false;
  try
  {
    written = write (tmp.string ());
  }
  catch (const Error&)
  {
    fs::remove (tmp, ec);
    throw;
  }
  catch (const std::bad_alloc&)
  {
    fs::remove (tmp, ec);
    throw;
  }
  catch (const std::exception& e)  // a library's writer (PCL's): its message names no file, often not the cause
  {
    fs::remove (tmp, ec);
    std::string said = e.what ();  // PCL's start ": [pcl::Class::method] "
    said.erase (0, std::min (said.size (), said.find_first_not_of (": ")));
    throw Error (path, "cannot write: " + writeFailure (target.parent_path (), said));
  }
  if (!written)
  {
    fs::remove (tmp, ec);
    throw Error (path, "cannot write: " + writeFailure (target.parent_path (), "folder missing or read-only?"));
  }
  fs::rename (tmp, target, ec);
  if (ec)
  {
    boost::system::error_code ignored;
    fs::remove (tmp, ignored);
    throw Error (path, "cannot replace file: " + ec.message ());
  }
}

void
writeFolderAtomic (const std::string& dir, bool overwrite, const std::function<void (const std::string& staging)>& fill)
{
  const fs::path target = fs::absolute (dir);
  boost::system::error_code ec;
  const fs::file_status status = fs::symlink_status (target, ec);
  if (fs::exists (status) && !fs::is_directory (status))  // a file, link or device is never moved aside
    throw Error (dir, "exists and is not a folder; refusing to replace it");
  if (fs::exists (target, ec) && !(fs::is_directory (target, ec) && fs::is_empty (target, ec)) && !overwrite)
    throw Error (dir, "already exists and is not empty (use --overwrite to replace it)");
  fs::create_directories (target.parent_path (), ec);
  const fs::path staging = target.parent_path () / fs::unique_path ("." + target.filename ().string () + ".tmp-%%%%%%");
  try
  {
    if (!fs::create_directory (staging, ec) || ec)
      throw Error (dir, "cannot create a temporary folder beside it: " + ec.message ());
    fill (staging.string ());
  }
  catch (...)
  {
    fs::remove_all (staging, ec);
    throw;
  }
  // Swap in the finished folder; the old one (if any) is removed only afterwards.
  const fs::path old = target.parent_path () / fs::unique_path ("." + target.filename ().string () + ".old-%%%%%%");
  const bool had_old = fs::exists (target, ec);
  ec.clear ();
  if (had_old)
    fs::rename (target, old, ec);
  if (!ec)
    fs::rename (staging, target, ec);
  if (ec)
  {
    boost::system::error_code ignored;
    fs::remove_all (staging, ignored);
    if (had_old)
      fs::rename (old, target, ignored);
    throw Error (dir, "cannot move the finished folder into place: " + ec.message ());
  }
  if (had_old)
    fs::remove_all (old, ec);
}

namespace
{
const std::string kStagingPrefix = ".cuefusion-staging-";

const std::string kJournal = ".journal", kPrevious = ".previous";

/** The previous set, put back from the staging folder \a staging of a commit that was
  * killed before its marker arrived: the entries it had moved in (its journal names them)
  * are removed, those it had moved aside (`.previous/`) return. */
void
restorePreviousSet (const fs::path& dir, const fs::path& staging)
{
  std::istringstream journal (readTextFile ((staging / kJournal).string ()));
  std::string marker, name;
  std::getline (journal, marker);
  if (marker.empty () || !fs::exists (fs::symlink_status (staging / marker)))
    return;  // the new marker had arrived: that commit finished; nothing to put back
  boost::system::error_code ec;
  while (std::getline (journal, name))
    if (!name.empty () && !fs::exists (fs::symlink_status (staging / name)))
      fs::remove_all (dir / name, ec);  // moved in by the killed commit
  for (fs::directory_iterator it (staging / kPrevious, ec), end; !ec && it != end; it.increment (ec))
  {
    boost::system::error_code ignored;
    fs::remove_all (dir / it->path ().filename (), ignored);
    fs::rename (it->path (), dir / it->path ().filename (), ignored);
  }
}

/** Staging folders of processes that no longer run (killed while writing); a commit
  * killed half-way gets the previous set back first. */
void
removeStaleStaging (const fs::path& dir)
{
  boost::system::error_code ec;
  std::vector<fs::path> stale;
  for (fs::directory_iterator it (dir, ec), end; !ec && it != end; it.increment (ec))
  {
    const std::string name = it->path ().filename ().string ();
    if (name.compare (0, kStagingPrefix.size (), kStagingPrefix) != 0)
      continue;
    const long pid = std::strtol (name.c_str () + kStagingPrefix.size (), nullptr, 10);
    if (pid > 0 && ::kill (static_cast<pid_t> (pid), 0) != 0 && errno == ESRCH)
      stale.push_back (it->path ());
  }
  for (const fs::path& staging : stale)
  {
    if (fs::is_regular_file (staging / kJournal, ec))
    {
      try
      {
        restorePreviousSet (dir, staging);
      }
      catch (const Error&)
      {
        continue;  // an unreadable journal: left as it is, for a person to look at
      }
    }
    boost::system::error_code ignored;
    fs::remove_all (staging, ignored);
  }
}

/** SIGINT and SIGTERM held back in this thread for the object's lifetime. */
class SignalHold
{
public:
  SignalHold ()
  {
    sigset_t held;
    sigemptyset (&held);
    sigaddset (&held, SIGINT);
    sigaddset (&held, SIGTERM);
    pthread_sigmask (SIG_BLOCK, &held, &previous_);
  }
  ~SignalHold () { pthread_sigmask (SIG_SETMASK, &previous_, nullptr); }

private:
  sigset_t previous_;
};
}  // namespace

OutputSet::OutputSet (const std::string& dir, std::vector<std::string> owned, std::string marker)
  : dir_ (dir), marker_ (std::move (marker)), owned_ (std::move (owned))
{
  boost::system::error_code ec;
  created_ = !fs::exists (fs::symlink_status (dir_, ec));
  fs::create_directories (dir_, ec);
  if (ec || !fs::is_directory (dir_))
    throw Error (dir_, "cannot create output folder" + (ec ? ": " + ec.message () : std::string ()));
  // One writer a folder: a second command writing its set into the same folder at the
  // same time would leave one's marker beside the other's files. flock on the folder
  // itself leaves no lock file behind; the kernel releases it when the process dies.
  lock_ = ::open (dir_.c_str (), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (lock_ < 0)
    throw Error (dir_, std::string ("cannot open output folder: ") + std::strerror (errno));
  if (::flock (lock_, LOCK_EX | LOCK_NB) != 0)
  {
    ::close (lock_);
    throw Error (dir_, "another cuefusion command is writing its outputs in this folder now");
  }
  removeStaleStaging (dir_);
  const fs::path staging =
    fs::path (dir_) / fs::unique_path (kStagingPrefix + std::to_string (::getpid ()) + "-%%%%%%");
  if (!fs::create_directory (staging, ec) || ec)
    throw Error (dir_, "cannot create a staging folder in it" + (ec ? ": " + ec.message () : std::string ()));
  staging_ = staging.string ();
}

OutputSet::~OutputSet ()
{
  boost::system::error_code ec;
  fs::remove_all (staging_, ec);
  if (!committed_ && created_)
    fs::remove (dir_, ec);  // only when still empty: a failed command leaves no trace
  ::close (lock_);
}

std::string
OutputSet::finalPaths (const std::string& message)
{
  // OutputSet's "DIR/.cuefusion-staging-PID-XXXXXX/NAME" and writeFolderAtomic's
  // "PARENT/.NAME.tmp-XXXXXX/FILE" (unique_path's '%' are lowercase hex digits).
  static const std::regex set ("/\\.cuefusion-staging-[0-9]+-[0-9a-f]{6}");
  static const std::regex folder ("/\\.([^/\\s:]+)\\.tmp-[0-9a-f]{6}");
  return std::regex_replace (std::regex_replace (message, set, ""), folder, "/$1");
}

std::string
OutputSet::stagingPath (const std::string& name) const
{
  const fs::path path = fs::path (staging_) / name;
  boost::system::error_code ec;
  fs::create_directories (path.parent_path (), ec);
  if (ec)
    throw Error (finalPath (name), "cannot create its folder: " + ec.message ());
  return path.string ();
}

std::string
OutputSet::finalPath (const std::string& name) const
{
  return (fs::path (dir_) / name).string ();
}

void
OutputSet::commit ()
{
  if (committed_)
    throw Error (dir_, "output set committed twice");
  committed_ = true;
  const SignalHold hold;
  const fs::path dir (dir_), staging (staging_), aside = staging / ".previous";
  boost::system::error_code ec;

  std::vector<std::string> staged;
  for (fs::directory_iterator it (staging, ec), end; !ec && it != end; it.increment (ec))
    if (it->path ().filename () != marker_)
      staged.push_back (it->path ().filename ().string ());
  if (ec)
    throw Error (dir_, "cannot list the staged outputs: " + ec.message ());
  std::sort (staged.begin (), staged.end ());
  const bool has_marker = fs::exists (staging / marker_);
  // Refuse before anything moves: a file never replaces a folder or a device, nor the other way round.
  for (const std::string& name : staged)
  {
    const fs::file_status target = fs::symlink_status (dir / name, ec);
    if (!fs::exists (target))
      continue;
    const bool folder = fs::is_directory (staging / name);
    if (folder ? !fs::is_directory (target) : !fs::is_regular_file (target))
      throw Error ((dir / name).string (), std::string ("exists and is not a ") + (folder ? "folder" : "regular file") +
                                             "; refusing to replace it");
  }
  if (!fs::create_directory (aside, ec) || ec)
    throw Error (dir_, "cannot create a folder for the previous outputs: " + ec.message ());
  // What this commit moves in, for the next writer should it be killed half-way
  // (restorePreviousSet): the marker first, then the entries.
  std::string journal = marker_ + "\n";
  for (const std::string& name : staged)
    journal += name + "\n";
  writeTextAtomic ((staging / kJournal).string (), journal);

  // A journal of what moved, to put everything back if a rename fails half-way.
  std::vector<std::pair<fs::path, fs::path>> moved;  // (from, to)
  const auto move = [&] (const fs::path& from, const fs::path& to) {
    fs::rename (from, to, ec);
    if (ec)
    {
      const std::string reason = ec.message ();
      for (auto it = moved.rbegin (); it != moved.rend (); ++it)
      {
        boost::system::error_code ignored;
        fs::rename (it->second, it->first, ignored);
      }
      throw Error (to.string (), "cannot move into place: " + reason + " (the previous outputs are kept)");
    }
    moved.emplace_back (from, to);
  };
  const auto move_aside = [&] (const std::string& name) {
    if (fs::exists (fs::symlink_status (dir / name, ec)))
      move (dir / name, aside / name);
  };
  move_aside (marker_);  // from here until the new marker is in place, the folder is marked incomplete
  for (const std::string& name : owned_)
    if (name != marker_ && std::find (staged.begin (), staged.end (), name) == staged.end ())
      move_aside (name);
  for (const std::string& name : staged)
  {
    move_aside (name);
    move (staging / name, dir / name);
  }
  if (has_marker)
    move (staging / marker_, dir / marker_);
  fs::remove_all (staging, ec);
}

namespace
{
void
writeBytesAtomic (const std::string& path, const char* data, std::size_t size)
{
  writeFileAtomic (path, [data, size] (const std::string& tmp) {
    std::ofstream out (tmp, std::ios::binary | std::ios::trunc);
    out.write (data, static_cast<std::streamsize> (size));
    out.flush ();
    return static_cast<bool> (out);
  });
}
}  // namespace

void
writeImageAtomic (const std::string& path, const cv::Mat& image, const std::vector<int>& params)
{
  std::vector<uchar> buffer;
  std::string failure;
  if (!detail::encodeImage (fs::path (path).extension ().string (), image, params, buffer, failure))
    throw Error (path, "cannot encode image (" + failure + ")");
  writeBytesAtomic (path, reinterpret_cast<const char*> (buffer.data ()), buffer.size ());
}

void
writeTextAtomic (const std::string& path, const std::string& text)
{
  writeBytesAtomic (path, text.data (), text.size ());
}

std::string
readTextFile (const std::string& path)
{
  const std::vector<uchar> bytes = readBytes (path);
  return std::string (bytes.begin (), bytes.end ());
}

nlohmann::json
parseJson (const std::string& text, const std::string& source)
{
  // Deep nesting is refused while parsing: copying a document nested 10^6 deep recurses
  // once per level and overflows the stack. cuefusion's own files nest 4 levels.
  constexpr int max_depth = 64;
  struct TooDeep
  {
  };
  try
  {
    return nlohmann::json::parse (text, [] (int depth, nlohmann::json::parse_event_t, nlohmann::json&) {
      if (depth > max_depth)
        throw TooDeep ();
      return true;
    });
  }
  catch (const TooDeep&)
  {
    throw Error (source, "JSON nested deeper than " + std::to_string (max_depth) + " levels");
  }
  catch (const nlohmann::json::exception& e)
  {
    throw Error (source, std::string ("not valid JSON (") + e.what () + ")");
  }
}

std::string
jsonText (const nlohmann::json& j, int indent)
{
  return j.dump (indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

nlohmann::json
readJsonFile (const std::string& path)
{
  const FileContext context (path);
  return parseJson (readTextFile (path), path);
}

std::vector<double>
readNumbers (const std::string& path)
{
  const FileContext context (path);
  std::istringstream in (readTextFile (path));
  std::vector<double> values;
  std::string token;
  while (in >> token)
  {
    // strtod accepts "inf"/"-inf"/"nan", which ScanNet writes for frames without a pose.
    char* end = nullptr;
    const double value = std::strtod (token.c_str (), &end);
    if (end == token.c_str () || *end != '\0')
      throw Error (path, "not a number: '" + token + "'");
    values.push_back (value);
  }
  return values;
}
}  // namespace io
}  // namespace cuefusion
