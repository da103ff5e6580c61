// SPDX-License-Identifier: BSD-3-Clause
#include "process.h"

#include <boost/filesystem.hpp>

#include <atomic>
#include <memory>

#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <sstream>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

extern char** environ;

namespace fs = boost::filesystem;

namespace cuefusion
{
namespace cli
{
std::string
ProcessResult::describe () const
{
  if (!started)
    return "could not start: " + error;
  if (signal)
    return "killed by signal " + std::to_string (signal) + " (" + strsignal (signal) + ")";
  return "exit status " + std::to_string (exit_code);
}

std::string
findOnPath (const std::string& name)
{
  const char* path = std::getenv ("PATH");
  std::istringstream dirs (path ? path : "/usr/bin:/bin");
  std::string dir;
  while (std::getline (dirs, dir, ':'))
  {
    const fs::path candidate = fs::path (dir.empty () ? "." : dir) / name;
    boost::system::error_code ec;
    if (fs::is_regular_file (candidate, ec) && ::access (candidate.c_str (), X_OK) == 0)
      return candidate.string ();
  }
  return std::string ();
}

std::string
selfExecutable ()
{
  boost::system::error_code ec;
  const fs::path self = fs::read_symlink ("/proc/self/exe", ec);
  return ec ? std::string () : self.string ();
}

StopSignalHandlers::StopSignalHandlers (void (*handler) (int))
{
  struct sigaction action{};
  action.sa_handler = handler;
  sigemptyset (&action.sa_mask);
  sigaction (SIGINT, &action, &previous_int_);
  sigaction (SIGTERM, &action, &previous_term_);
}

StopSignalHandlers::~StopSignalHandlers ()
{
  sigaction (SIGINT, &previous_int_, nullptr);
  sigaction (SIGTERM, &previous_term_, nullptr);
}

namespace
{
std::atomic<pid_t> g_child{0};
std::atomic<int> g_forwarded{0};

extern "C" void
forwardSignal (int signal)
{
  g_forwarded = signal;
  const pid_t child = g_child;
  if (child > 0)
    ::kill (child, signal);
}

/** SIGINT and SIGTERM passed on to the running child while it lives. */
class SignalForwarding
{
public:
  explicit SignalForwarding (bool on)
  {
    if (!on)
      return;
    g_forwarded = 0;
    handlers_ = std::make_unique<StopSignalHandlers> (forwardSignal);
  }
  ~SignalForwarding ()
  {
    g_child = 0;
  }
  SignalForwarding (const SignalForwarding&) = delete;
  SignalForwarding& operator= (const SignalForwarding&) = delete;

private:
  std::unique_ptr<StopSignalHandlers> handlers_;
};
}  // namespace

ProcessResult
runProcess (const std::vector<std::string>& argv, const Redirect& out, const Redirect& err, const std::string& directory,
            bool forward_signals)
{
  ProcessResult result;
  if (argv.empty ())
  {
    result.error = "no command";
    return result;
  }
  std::string program = argv.front ();
  if (program.find ('/') == std::string::npos)
    program = findOnPath (program);
  if (program.empty ())
  {
    result.error = argv.front () + " not found on PATH";
    return result;
  }
  // posix_spawn cannot change directory (before glibc's _np extension): with one, run
  // sh -c 'cd "$1" && shift && exec "$0" "$@"' PROGRAM DIRECTORY ARGS..., the arguments as they are.
  std::vector<std::string> args;
  if (!directory.empty ())
    args = {"/bin/sh", "-c", "cd \"$1\" || exit 127; shift; exec \"$0\" \"$@\"", program, directory};
  else
    args = {program};
  args.insert (args.end (), argv.begin () + 1, argv.end ());
  std::vector<char*> c_args;
  for (std::string& a : args)
    c_args.push_back (a.data ());
  c_args.push_back (nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init (&actions);
  const auto redirect = [&actions] (int fd, const Redirect& r) {
    if (!r.path.empty ())
      posix_spawn_file_actions_addopen (&actions, fd, r.path.c_str (), O_WRONLY | O_CREAT | (r.append ? O_APPEND : O_TRUNC), 0644);
  };
  redirect (1, out);
  if (!err.path.empty () && err.path == out.path)
    posix_spawn_file_actions_adddup2 (&actions, 1, 2);
  else
    redirect (2, err);
  // A forwarding parent starts its child in a process group of its own: a signal sent to
  // the parent's group (Ctrl-C at a terminal, GNU parallel stopping a job) then reaches the
  // child once, from the parent, not twice (the group's and the forwarded one), and a
  // child's second signal keeps its meaning (`run`: abandon writing).
  posix_spawnattr_t attributes;
  posix_spawnattr_init (&attributes);
  if (forward_signals)
  {
    posix_spawnattr_setflags (&attributes, POSIX_SPAWN_SETPGROUP);
    posix_spawnattr_setpgroup (&attributes, 0);
  }
  const SignalForwarding forwarding (forward_signals);
  pid_t pid = 0;
  const int spawned = posix_spawn (&pid, c_args.front (), &actions, &attributes, c_args.data (), environ);
  posix_spawn_file_actions_destroy (&actions);
  posix_spawnattr_destroy (&attributes);
  if (spawned != 0)
  {
    result.error = std::string (std::strerror (spawned));
    return result;
  }
  if (forward_signals)
  {
    g_child = pid;
    if (g_forwarded)  // a signal came between the handlers' installation and the spawn
      ::kill (pid, g_forwarded);
  }
  result.started = true;
  int status = 0;
  while (waitpid (pid, &status, 0) < 0)
    if (errno != EINTR)
    {
      result.error = std::strerror (errno);
      result.started = false;
      return result;
    }
  result.forwarded = forward_signals ? g_forwarded.load () : 0;
  if (WIFSIGNALED (status))
    result.signal = WTERMSIG (status);
  else
    result.exit_code = WEXITSTATUS (status);
  return result;
}
}  // namespace cli
}  // namespace cuefusion
