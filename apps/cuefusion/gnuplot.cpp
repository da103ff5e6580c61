#include "gnuplot.h"

#include <cuefusion/common/exceptions.h>
#include <cuefusion/io/file_io.h>

#include <boost/filesystem.hpp>

#include <cstdlib>
#include <fcntl.h>
#include <unistd.h>
#include <sstream>
#include <spawn.h>
#include <sys/wait.h>

extern char** environ;

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace cli
{
namespace
{
/** gnuplot single-quoted string: only ' needs escaping (doubled). */
std::string
quoted (const std::string& s)
{
  std::string out = "'";
  for (const char c : s)
    out += c == '\'' ? std::string ("''") : std::string (1, c);
  return out + "'";
}
}  // namespace

std::string
findGnuplot ()
{
  const char* path = std::getenv ("PATH");
  std::istringstream dirs (path ? path : "/usr/bin:/bin");
  std::string dir;
  while (std::getline (dirs, dir, ':'))
  {
    const fs::path candidate = fs::path (dir.empty () ? "." : dir) / "gnuplot";
    boost::system::error_code ec;
    if (fs::is_regular_file (candidate, ec) && ::access (candidate.c_str (), X_OK) == 0)
      return candidate.string ();
  }
  return std::string ();
}

void
renderPlot (const std::string& gnuplot, const PlotSpec& spec)
{
  const fs::path png (spec.output_png);
  const fs::path temporary = png.parent_path () / fs::unique_path ("." + png.stem ().string () + ".tmp-%%%%%%.png");
  const fs::path script = fs::path (png).replace_extension (".gp");
  const fs::path log = png.parent_path () / fs::unique_path ("." + png.stem ().string () + ".log-%%%%%%");
  std::ostringstream gp;
  gp << "# " << spec.title << " — written by cuefusion eval; run `gnuplot " << script.filename ().string ()
     << "` here to redraw\n"
     << "set terminal pngcairo size 1000,640 enhanced font 'sans,11'\n"
     << "set output " << quoted (png.filename ().string ()) << "\n"
     << "set title " << quoted (spec.title) << " noenhanced\n"
     << "set xlabel " << quoted (spec.xlabel) << "\nset ylabel " << quoted (spec.ylabel) << "\n"
     << "set grid\nset key outside right top noenhanced\n";
  if (!spec.yrange.empty ())
    gp << "set yrange " << spec.yrange << "\n";
  if (spec.equal_axes)
    gp << "set size ratio -1\n";
  gp << "plot ";
  for (std::size_t i = 0; i < spec.series.size (); ++i)
  {
    const PlotSeries& s = spec.series[i];
    gp << (i ? ", \\\n     " : "") << quoted (fs::path (s.data_file).filename ().string ()) << " using " << s.x_column << ":"
       << s.y_column << " with " << s.style << " lw 2 title " << quoted (s.title);
  }
  gp << "\n";
  io::writeTextAtomic (script.string (), gp.str ());

  // Run in the plot's folder (the script names files relative to it), output to the
  // temporary name, so a failure leaves no broken PNG.
  std::string text = gp.str ();
  const std::string target_line = "set output " + quoted (png.filename ().string ());
  text.replace (text.find (target_line), target_line.size (), "set output " + quoted (temporary.filename ().string ()));
  const fs::path run_script = png.parent_path () / fs::unique_path (".plot-%%%%%%.gp");
  io::writeTextAtomic (run_script.string (), text);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init (&actions);
  posix_spawn_file_actions_addopen (&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen (&actions, 2, log.c_str (), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  const std::string cwd_script = run_script.filename ().string ();
  const std::string directory = png.parent_path ().empty () ? "." : png.parent_path ().string ();
  // posix_spawn cannot change directory (before glibc's _np extension): sh -c 'cd DIR && exec gnuplot SCRIPT'.
  const auto shell_quoted = [] (const std::string& s) {
    std::string out = "'";
    for (const char c : s)
      out += c == '\'' ? std::string ("'\\''") : std::string (1, c);
    return out + "'";
  };
  const std::string shell_command =
    "cd " + shell_quoted (directory) + " && exec " + shell_quoted (gnuplot) + " " + shell_quoted (cwd_script);
  char* argv[] = {const_cast<char*> ("sh"), const_cast<char*> ("-c"), const_cast<char*> (shell_command.c_str ()), nullptr};
  pid_t pid = 0;
  const int spawned = posix_spawn (&pid, "/bin/sh", &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy (&actions);
  int status = 0;
  if (spawned == 0)
    waitpid (pid, &status, 0);
  boost::system::error_code ec;
  fs::remove (run_script, ec);
  std::string message;
  if (fs::exists (log))
  {
    message = io::readTextFile (log.string ());
    fs::remove (log, ec);
  }
  if (spawned != 0 || !WIFEXITED (status) || WEXITSTATUS (status) != 0 || !fs::exists (temporary))
  {
    fs::remove (temporary, ec);
    const auto end = message.find ('\n', message.find_first_not_of ("\n "));
    throw Error (script.string (), "gnuplot failed" + (message.empty () ? std::string () : ": " + message.substr (0, end)));
  }
  fs::rename (temporary, png, ec);
  if (ec)
    throw Error (png.string (), "cannot move the plot into place: " + ec.message ());
}
}  // namespace cli
}  // namespace cuefusion
