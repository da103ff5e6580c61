// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <cuefusion/common/exceptions.h>

#include <boost/filesystem.hpp>
#include <gtest/gtest.h>
#include <fcntl.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

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

/** Runs `cuefusion ARGS`, stdout and stderr captured into files of \a dir; with
  * \a in_dir, in \a dir as the working directory (for relative paths in ARGS); \a env
  * ("NAME=VALUE ...") is set for that command only. */
inline CommandResult
runCuefusion (const std::string& args, const TempDir& dir, bool in_dir = false, const std::string& env = "")
{
  const std::string cmd = (in_dir ? "cd " + dir.str () + " && " : std::string ()) + (env.empty () ? "" : "env " + env + " ") +
                          std::string (CUEFUSION_BINARY) + " " + args + " >" + (dir / "out.txt") + " 2>" + (dir / "err.txt") +
                          " </dev/null";
  const int status = std::system (cmd.c_str ());
  return {WIFEXITED (status) ? WEXITSTATUS (status) : -1, readFile (dir / "out.txt"), readFile (dir / "err.txt")};
}

/** \brief A folder of generated inputs made once per build and read by every test
  * process that asks for it (ctest runs each test in its own process, so a suite's
  * SetUpTestSuite would make it again for every test).
  *
  * \a make fills the folder it is given (throwing or leaving a gtest failure when it
  * cannot). The folder lives in the build tree (test-fixtures/NAME-STAMP), STAMP being
  * the cuefusion binary's modification time, so a rebuilt generator makes it anew; a
  * lock keeps tests running in parallel from making it twice. Tests only read it.
  */
inline std::string
sharedFixture (const std::string& name, const std::function<void (const std::string& folder)>& make)
{
  namespace fs = boost::filesystem;
  const fs::path root (CUEFUSION_TEST_FIXTURE_DIR);
  fs::create_directories (root);
  const std::string key = name + "-" + std::to_string (fs::last_write_time (CUEFUSION_BINARY));
  const fs::path folder = root / key, done = folder / ".complete";
  if (fs::exists (done))
    return folder.string ();
  const int lock = ::open ((root / (name + ".lock")).c_str (), O_CREAT | O_RDWR | O_CLOEXEC, 0644);
  if (lock < 0 || ::flock (lock, LOCK_EX) != 0)
    throw std::runtime_error ("cannot lock the test fixture " + name);
  struct Unlock
  {
    int fd;
    ~Unlock () { ::close (fd); }
  } unlock{lock};
  if (!fs::exists (done))
  {
    for (fs::directory_iterator it (root), end; it != end; ++it)  // older stamps, a half-made one
      if (it->path ().filename ().string ().rfind (name + "-", 0) == 0)
        fs::remove_all (it->path ());
    fs::create_directories (folder);
    make (folder.string ());
    if (::testing::Test::HasFailure ())
      throw std::runtime_error ("making the test fixture " + name + " failed");
    writeFile (done.string (), "");
  }
  return folder.string ();
}

inline std::string
tabletopScenePath ()
{
  return std::string (CUEFUSION_TEST_DATA_DIR) + "/scenes/tabletop.scene";
}

/** \brief The trajectory line of the scene file \a path with the fields in \a changes set
  * (name, value; added when the line has none): the bundled orbit with another start,
  * sweep or bob, for printedSceneText. */
inline std::string
changedTrajectory (const std::string& path, const std::vector<std::pair<std::string, double>>& changes)
{
  std::istringstream lines (readFile (path));
  std::string line;
  while (std::getline (lines, line))
  {
    if (line.rfind ("trajectory ", 0) != 0)
      continue;
    for (const auto& [name, value] : changes)
    {
      const std::string field = " " + name + "=" + std::to_string (value);
      const std::size_t at = line.find (" " + name + "=");
      if (at == std::string::npos)
        line += field;
      else
        line.replace (at, std::min (line.find (' ', at + 1), line.size ()) - at, field);
    }
    return line;
  }
  throw std::runtime_error (path + ": no trajectory line");
}

/** \brief The scene file \a path with every object printed (texture=print, in place of
  * any checker): the texture real scenes have, which colour features are found on;
  * \a trajectory, when given, replaces its trajectory line. */
inline std::string
printedSceneText (const std::string& path, const std::string& trajectory = "")
{
  std::istringstream lines (readFile (path));
  std::string text, line;
  while (std::getline (lines, line))
  {
    if (!trajectory.empty () && line.rfind ("trajectory ", 0) == 0)
      line = trajectory;
    else if (line.rfind ("object ", 0) == 0)
    {
      const std::size_t checker = line.find (" texture=checker");
      line = (checker == std::string::npos ? line : line.erase (checker, 16)) + " texture=print";
    }
    text += line + "\n";
  }
  return text;
}
}  // namespace test
}  // namespace cuefusion
