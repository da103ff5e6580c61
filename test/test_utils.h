#pragma once

#include <cuefusion/common/exceptions.h>

#include <boost/filesystem.hpp>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <string>

namespace cuefusion
{
namespace test
{
/** A fresh folder under the system temp dir, removed with its contents at scope exit. */
class TempDir
{
public:
  TempDir ()
    : path_ (boost::filesystem::temp_directory_path () / boost::filesystem::unique_path ("cuefusion-test-%%%%%%%%"))
  {
    boost::filesystem::create_directories (path_);
  }
  ~TempDir ()
  {
    boost::system::error_code ec;
    boost::filesystem::remove_all (path_, ec);
  }
  std::string str () const { return path_.string (); }
  std::string operator/ (const std::string& name) const { return (path_ / name).string (); }

private:
  boost::filesystem::path path_;
};

inline void
writeFile (const std::string& path, const std::string& text)
{
  std::ofstream (path, std::ios::binary) << text;
}

inline std::string
readFile (const std::string& path)
{
  std::ifstream in (path, std::ios::binary);
  return std::string ((std::istreambuf_iterator<char> (in)), std::istreambuf_iterator<char> ());
}

/** Runs \a f and expects a cuefusion::Error whose one-line message mentions \a file and \a what. */
template <typename F>
void
expectError (F f, const std::string& file, const std::string& what)
{
  try
  {
    f ();
    ADD_FAILURE () << "no error for " << file;
  }
  catch (const Error& e)
  {
    const std::string msg = e.what ();
    EXPECT_NE (msg.find (file), std::string::npos) << msg;
    EXPECT_NE (msg.find (what), std::string::npos) << msg;
    EXPECT_EQ (msg.find ('\n'), std::string::npos) << msg;
  }
}

/** Exit code and output of one run of the cuefusion binary. */
struct CommandResult
{
  int code;
  std::string out, err;
};

/** Runs `cuefusion ARGS`, stdout and stderr captured into files of \a dir. */
inline CommandResult
runCuefusion (const std::string& args, const TempDir& dir)
{
  const std::string cmd = std::string (CUEFUSION_BINARY) + " " + args + " >" + (dir / "out.txt") + " 2>" +
                          (dir / "err.txt") + " </dev/null";
  const int status = std::system (cmd.c_str ());
  return {WIFEXITED (status) ? WEXITSTATUS (status) : -1, readFile (dir / "out.txt"), readFile (dir / "err.txt")};
}

inline std::string
tabletopScenePath ()
{
  return std::string (CUEFUSION_TEST_DATA_DIR) + "/scenes/tabletop.scene";
}
}  // namespace test
}  // namespace cuefusion
