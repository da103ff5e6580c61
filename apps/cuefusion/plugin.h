// SPDX-License-Identifier: BSD-3-Clause
#pragma once

namespace cuefusion
{
namespace cli
{
/** \a symbol of the shared library \a library (a file name, no folder), loaded once and
  * never closed, from the folder of the cuefusion libraries (libraryDirectory (): the
  * build's lib/, or the installed library folder). Throws cuefusion::Error naming the
  * library and the loader's reason. */
void*
pluginSymbol (const char* library, const char* symbol);
}  // namespace cli
}  // namespace cuefusion
