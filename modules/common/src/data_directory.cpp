// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/data_directory.h>

#include <boost/filesystem.hpp>

#include <dlfcn.h>

#include <cstdlib>
#include <vector>

namespace cuefusion
{
namespace fs = boost::filesystem;

std::string
version ()
{
  return CUEFUSION_VERSION;
}

std::string
libraryDirectory ()
{
  Dl_info info;
  if (dladdr (reinterpret_cast<void*> (&libraryDirectory), &info) == 0 || !info.dli_fname)
    return {};
  boost::system::error_code error;
  const fs::path library = fs::canonical (info.dli_fname, error);
  return error ? std::string () : library.parent_path ().string ();
}

std::string
dataDirectory ()
{
  if (const char* dir = std::getenv ("CUEFUSION_DATA_DIR"))
    if (*dir)
      return dir;
  const std::string libraries = libraryDirectory ();
  const fs::path installed = fs::path (libraries) / CUEFUSION_DATA_FROM_LIBDIR;
  boost::system::error_code error;
  if (!libraries.empty () && fs::is_directory (installed / "scenes", error))
    return installed.lexically_normal ().string ();
  return CUEFUSION_SOURCE_DATA_DIR;
}

std::string
findDataFile (const std::string& given, const std::string& folder, const std::string& extension)
{
  boost::system::error_code error;
  if (given.empty () || fs::is_regular_file (given, error))
    return given;
  const fs::path data (dataDirectory ());
  std::vector<fs::path> candidates;
  if (given.find ('/') == std::string::npos)
    candidates = {data / folder / given, data / folder / (given + extension)};
  else if (given.rfind ("data/", 0) == 0)
    candidates = {data / given.substr (5)};
  for (const fs::path& candidate : candidates)
    if (fs::is_regular_file (candidate, error))
      return candidate.string ();
  return given;
}
}  // namespace cuefusion
