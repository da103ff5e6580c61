// SPDX-License-Identifier: BSD-3-Clause
// Shared by the libFuzzer harnesses: cuefusion's readers take paths, so each input is
// written to a file of the right name in a private temporary folder first.
#pragma once

#include <cuefusion/common/exceptions.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace cuefusion
{
namespace fuzz
{
inline const std::string&
folder ()
{
  static const std::string dir = [] {
    char name[] = "/tmp/cuefusion-fuzz-XXXXXX";
    if (!mkdtemp (name))
      std::abort ();
    return std::string (name);
  }();
  return dir;
}

/** Writes \a size bytes to folder()/name and returns the path. */
inline std::string
writeInput (const std::uint8_t* data, std::size_t size, const std::string& name)
{
  const std::string path = folder () + "/" + name;
  std::FILE* f = std::fopen (path.c_str (), "wb");
  if (!f)
    std::abort ();
  if (size > 0 && std::fwrite (data, 1, size, f) != size)
    std::abort ();
  std::fclose (f);
  return path;
}

/** Runs \a read; a cuefusion::Error (bad input, named) is the expected outcome. Any
  * other exception escapes and libFuzzer reports it: every failure must be an Error. */
template <typename F>
void
expectErrorOrSuccess (F&& read)
{
  try
  {
    read ();
  }
  catch (const Error&)
  {
  }
}
}  // namespace fuzz
}  // namespace cuefusion
