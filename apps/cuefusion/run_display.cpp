// SPDX-License-Identifier: BSD-3-Clause
#include "run_display.h"

#include "plugin.h"

namespace cuefusion
{
namespace cli
{
const RunDisplay&
loadRunDisplay ()
{
  // The window and the video live until the process ends: the library is never closed.
  using Entry = const RunDisplay* (*) ();
  static const RunDisplay* const display = reinterpret_cast<Entry> (pluginSymbol (kRunDisplayLibrary, kRunDisplaySymbol)) ();
  return *display;
}
}  // namespace cli
}  // namespace cuefusion
