#pragma once

namespace cuefusion
{
namespace cli
{
/** \a symbol of the shared library \a library (a file name, no folder), loaded once and
  * never closed. The library is found like the calling program's own: its run path (the
  * build's lib/ folder, or the installed library folder relative to the executable), then
  * the system's. Throws cuefusion::Error naming the library and the loader's reason. */
void*
pluginSymbol (const char* library, const char* symbol);
}  // namespace cli
}  // namespace cuefusion
