#include "run_display.h"

#include <cuefusion/common/exceptions.h>

#include <dlfcn.h>

#include <mutex>

namespace cuefusion
{
namespace cli
{
const RunDisplay&
loadRunDisplay ()
{
  static std::once_flag once;
  static const RunDisplay* display = nullptr;
  static std::string failure;
  std::call_once (once, [] {
    // Found like the executable's own libraries: its run path (the build's lib/ folder, or
    // the installed library folder relative to the executable), then the system's. Never
    // closed: the window and the video live until the process ends.
    void* handle = dlopen (kRunDisplayLibrary, RTLD_NOW | RTLD_LOCAL);
    if (!handle)
    {
      const char* why = dlerror ();
      failure = why ? why : "not found";
      return;
    }
    using Entry = const RunDisplay* (*) ();
    const auto entry = reinterpret_cast<Entry> (dlsym (handle, kRunDisplaySymbol));
    if (!entry || !(display = entry ()))
      failure = std::string ("it has no ") + kRunDisplaySymbol;
  });
  if (!display)
    throw Error (kRunDisplayLibrary, "cannot load the viewer and video library (" + failure + ")");
  return *display;
}
}  // namespace cli
}  // namespace cuefusion
