// SPDX-License-Identifier: BSD-3-Clause
#pragma once

#include <csignal>
#include <string>
#include <vector>

namespace cuefusion
{
namespace cli
{
/** How a child process ended. */
struct ProcessResult
{
  bool started = false;  ///< false: it could not be started (error says why)
  int exit_code = -1;    ///< its exit status when it exited normally
  int signal = 0;        ///< the signal that ended it, 0 when it exited
  std::string error;     ///< why it could not be started
  int forwarded = 0;     ///< SIGINT or SIGTERM this process received and passed on to it (0: none)
  /** Exited with status 0. */
  bool
  ok () const
  {
    return started && signal == 0 && exit_code == 0;
  }
  /** "exit status 3", "killed by signal 9 (Killed)", or why it did not start. */
  std::string
  describe () const;
};

/** Where a child's standard output or error goes. */
struct Redirect
{
  std::string path;     ///< "" = inherited from this process
  bool append = false;  ///< append to \a path instead of truncating it
};

/** \a handler on SIGINT and SIGTERM for the object's lifetime; the handlers before it
  * come back at its end. */
class StopSignalHandlers
{
public:
  explicit StopSignalHandlers (void (*handler) (int));
  ~StopSignalHandlers ();
  StopSignalHandlers (const StopSignalHandlers&) = delete;
  StopSignalHandlers& operator= (const StopSignalHandlers&) = delete;

private:
  struct sigaction previous_int_{}, previous_term_{};
};

/** Runs \a argv (argv[0] is looked up on PATH unless it holds a slash) in \a directory
  * ("" = this process's), with stdout and stderr redirected as given, and waits for it.
  * With \a forward_signals, a SIGINT or SIGTERM this process receives meanwhile is sent
  * on to the child (which decides how to stop) and the wait goes on until it ends: a
  * parent never leaves children writing behind it (ProcessResult::forwarded says so). Such
  * a child runs in a process group of its own, so that it receives each signal once. */
ProcessResult
runProcess (const std::vector<std::string>& argv, const Redirect& out = Redirect (), const Redirect& err = Redirect (),
            const std::string& directory = std::string (), bool forward_signals = false);

/** An executable called \a name on PATH, or "" when there is none. */
std::string
findOnPath (const std::string& name);

/** The running program's own executable (absolute), from /proc/self/exe. */
std::string
selfExecutable ();
}  // namespace cli
}  // namespace cuefusion
