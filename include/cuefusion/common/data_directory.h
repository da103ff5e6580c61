// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <string>

namespace cuefusion
{
/** \brief The folder holding cuefusion's data files (scenes/, classes/, models/).
  *
  * In this order: $CUEFUSION_DATA_DIR when set; the installed copy beside the library
  * (<prefix>/share/cuefusion, found relative to the folder of the loaded
  * libcuefusion_common, so an installed tree or the Debian package can be moved); the
  * source tree's data/ the library was built from.
  */
std::string
dataDirectory ();

/** \brief The folder of the loaded libcuefusion_common (the build's lib/, or the installed
  * library folder), where the other cuefusion libraries and the command line's loadable
  * libraries are; "" when the loader cannot say.
  */
std::string
libraryDirectory ();
}  // namespace cuefusion
