// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <string>

namespace cuefusion
{
/** \brief This library's version, "MAJOR.MINOR.PATCH" (the project's CMake version). */
std::string
version ();

/** \brief The folder holding cuefusion's data files (scenes/, classes/, models/).
  *
  * In this order: $CUEFUSION_DATA_DIR when set; the installed copy beside the library
  * (<prefix>/share/cuefusion, found relative to the folder of the loaded
  * libcuefusion_common, so an installed tree or the Debian package can be moved); the
  * source tree's data/ the library was built from.
  */
std::string
dataDirectory ();

/** \brief A data file named by path or by name, as the commands' --model and --classes take
  * it: \a given itself when that file exists; else, for a bare name (no '/'),
  * <dataDirectory()>/<folder>/<name>, or that with \a extension appended
  * (`xyz_instances` → models/xyz_instances.onnx); else, for a relative path that starts
  * with `data/`, the rest of it under dataDirectory() (the source tree's spelling,
  * `data/models/xyz_instances.onnx`, then works from any folder and from an installed
  * tree); else \a given unchanged, for the caller to report missing.
  */
std::string
findDataFile (const std::string& given, const std::string& folder, const std::string& extension);

/** \brief The folder of the loaded libcuefusion_common (the build's lib/, or the installed
  * library folder), where the other cuefusion libraries and the command line's loadable
  * libraries are; "" when the loader cannot say.
  */
std::string
libraryDirectory ();
}  // namespace cuefusion
