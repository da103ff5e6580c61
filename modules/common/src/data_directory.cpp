// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/common/data_directory.h>

#include <boost/filesystem.hpp>

#include <dlfcn.h>

#include <cstdlib>

namespace cuefusion
{
namespace fs = boost::filesystem;

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
}  // namespace cuefusion
