// SPDX-License-Identifier: BSD-3-Clause
#include "plugin.h"

#include <cuefusion/common/data_directory.h>
#include <cuefusion/common/exceptions.h>

#include <dlfcn.h>

#include <string>

namespace cuefusion
{
namespace cli
{
void*
pluginSymbol (const char* library, const char* symbol)
{
  // By its full path (in cuefusion/ beside the cuefusion libraries), not by dlopen's search: a tool that
  // wraps dlopen (heaptrack, some profilers) becomes the "caller" whose run path is
  // searched, and would not find it. dlopen counts references: a second call returns the
  // same handle.
  // The command's private libraries are in cuefusion/ beside the modules' libraries
  // (apps/CMakeLists.txt; /usr/lib/cuefusion when packaged).
  const std::string folder = libraryDirectory ();
  const std::string path = folder.empty () ? std::string (library) : folder + "/cuefusion/" + library;
  void* handle = dlopen (path.c_str (), RTLD_NOW | RTLD_LOCAL);
  if (!handle)
  {
    const char* why = dlerror ();
    throw Error (library, std::string ("cannot be loaded (") + (why ? why : "not found") + ")");
  }
  dlerror ();
  void* address = dlsym (handle, symbol);
  if (!address)
    throw Error (library, std::string ("has no ") + symbol + "; it is not this cuefusion's");
  return address;
}
}  // namespace cli
}  // namespace cuefusion
