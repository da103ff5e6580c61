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
}  // namespace cuefusion
