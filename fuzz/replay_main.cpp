// SPDX-License-Identifier: BSD-3-Clause
// Without libFuzzer (every normal build): the harness as a program that feeds it each
// file named on the command line, or each file of a folder named there. ctest runs it on
// test/data/fuzz/HARNESS/, the inputs that once crashed or were refused wrongly.
#include <boost/filesystem.hpp>

#include <cstdint>
#include <fstream>
#include <iostream>
#include <iterator>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput (const std::uint8_t* data, std::size_t size);

int
main (int argc, char** argv)
{
  namespace fs = boost::filesystem;
  std::vector<fs::path> inputs;
  for (int i = 1; i < argc; ++i)
  {
    if (fs::is_directory (argv[i]))
    {
      for (fs::directory_iterator it (argv[i]), end; it != end; ++it)
        if (fs::is_regular_file (it->path ()))
          inputs.push_back (it->path ());
    }
    else
      inputs.emplace_back (argv[i]);
  }
  if (inputs.empty ())
  {
    std::cerr << "usage: " << argv[0] << " FILE_OR_FOLDER...\n";
    return 2;
  }
  for (const fs::path& path : inputs)
  {
    std::ifstream in (path.string (), std::ios::binary);
    if (!in)
    {
      std::cerr << path.string () << ": cannot open\n";
      return 1;
    }
    const std::vector<char> bytes ((std::istreambuf_iterator<char> (in)), std::istreambuf_iterator<char> ());
    LLVMFuzzerTestOneInput (reinterpret_cast<const std::uint8_t*> (bytes.data ()), bytes.size ());
  }
  std::cout << inputs.size () << " inputs replayed\n";
  return 0;
}
