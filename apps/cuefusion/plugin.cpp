#include "plugin.h"

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
  // dlopen counts references: a second call returns the same handle.
  void* handle = dlopen (library, RTLD_NOW | RTLD_LOCAL);
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
