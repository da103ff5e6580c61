#include <cuefusion/common/data_directory.h>

#include <boost/filesystem.hpp>

#include <dlfcn.h>

#include <cstdlib>

namespace cuefusion
{
namespace fs = boost::filesystem;

namespace
{
/** \brief <folder of the file holding this function>/CUEFUSION_DATA_FROM_LIBDIR, or "" when
  * the loader cannot say where that file is.
  */
fs::path
installedDataDirectory ()
{
  Dl_info info;
  if (dladdr (reinterpret_cast<void*> (&installedDataDirectory), &info) == 0 || !info.dli_fname)
    return {};
  boost::system::error_code error;
  const fs::path library = fs::canonical (info.dli_fname, error);
  if (error)
    return {};
  return library.parent_path () / CUEFUSION_DATA_FROM_LIBDIR;
}
}  // namespace

std::string
dataDirectory ()
{
  if (const char* dir = std::getenv ("CUEFUSION_DATA_DIR"))
    if (*dir)
      return dir;
  const fs::path installed = installedDataDirectory ();
  boost::system::error_code error;
  if (!installed.empty () && fs::is_directory (installed / "scenes", error))
    return installed.lexically_normal ().string ();
  return CUEFUSION_SOURCE_DATA_DIR;
}
}  // namespace cuefusion
