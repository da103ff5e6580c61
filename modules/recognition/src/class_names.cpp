// SPDX-License-Identifier: BSD-3-Clause
#include <cuefusion/io/file_io.h>
#include <cuefusion/common/data_directory.h>
#include <cuefusion/common/exceptions.h>
#include <cuefusion/recognition/instance_segmenter.h>

#include <boost/algorithm/string/trim.hpp>
#include <boost/filesystem.hpp>

#include <fstream>

namespace cuefusion
{
namespace recognition
{
std::vector<std::string>
readClassNames (const std::string& path)
{
  const FileContext context (path);
  io::requireRegularFile (path);
  std::ifstream in (path);
  if (!in)
    throw Error (path, "cannot read class names");
  std::vector<std::string> names;
  std::string line;
  while (std::getline (in, line))
  {
    boost::algorithm::trim (line);
    if (!line.empty ())
      names.push_back (line);
  }
  if (names.empty ())
    throw Error (path, "holds no class name");
  return names;
}

std::string
defaultClassNamesPath ()
{
  return (boost::filesystem::path (dataDirectory ()) / "classes" / "coco.names").string ();
}
}  // namespace recognition
}  // namespace cuefusion
